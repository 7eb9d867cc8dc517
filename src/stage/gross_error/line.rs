//! The vibration line a channel's model holds, tracked so that the stage's tests judge the
//! channel without it.
//!
//! The jump test and the confirmation are model-free: they take the signal to be smooth at the
//! sample scale. A vibration line well above the noise (a motor's order) is not, and it hid the
//! gross errors on top of it (docs/gross_error_results.md, "A vibration line blinds the
//! model-free tests"). A channel tracks a line with a notch ([`LineCanceller`], bandwidth
//! [`LINE_BANDWIDTH`] of the sample rate, learning only from samples the gate accepted) when
//!
//! * its warm-up window held one that matters to the tests
//!   ([`window_line`](super::identify::window_line): a stationary sinusoid, at least a tenth
//!   of the window's second-difference variance). The model was identified on the window
//!   without it, and the notch starts from the window's fit; or
//! * its model holds one ([`ArimaChannelModel::line`]: an AR part on the stationarity boundary
//!   with a complex root pair there; a model from a file, say). The notch starts at zero.
//!
//! Every test (the ARIMA gate, the jump test, the confirmation, the several-axes test's
//! partners) then judges the value less the line predicted for it; a replacement gets the line
//! back, and a value passed keeps its own. The stale-repeat detector still compares the raw
//! values. A line that moves away — an engine's firing order at idle when the revs rise (the
//! rtklibexplorer drive: 30.7 Hz at idle for its first 40 s, then spread over 25–31 Hz) — is
//! no longer taken out ([`ChannelLine::predict`]), so that a slice of the motion the notch would
//! then track does not sharpen the tests against real motion. Without a line nothing changes.

use super::RING;
use crate::model::arima::ArimaChannelModel;
use crate::stage::bias::line_canceller::LineCanceller;
use crate::stats::line::Sinusoid;
use std::f64::consts::TAU;

/// Bandwidth of a line's notch, cycles per sample: μ = π × this = 0.005, so the tracked line
/// settles within about 1/(2μ) = 100 samples and its estimate carries √μ ≈ 7 % of the noise σ.
pub const LINE_BANDWIDTH: f64 = 0.0016;

/// Samples between two looks at whether the tracked line is still a line: about 2.5
/// notch time constants (1/(2μ) = 100 samples), so that a narrow slice of broadband motion,
/// which is all a notch tracks once its line has gone, has forgotten the previous look.
pub const LINE_CHECK_SAMPLES: u32 = 256;

/// The tracker of one channel's line.
#[derive(Debug, Clone)]
struct Tracker {
    notch: LineCanceller,
    /// The estimate taken out of the raw value at each index % RING (0 while not a line).
    taken: [f64; RING],
    /// The line is taken out (it was still a line at the last look).
    live: bool,
    /// Successive looks at which it was a line (two bring a lost line back).
    passes: u8,
    /// The notch's weights (a, b) at the last look (`None` before the first, for a notch that
    /// starts at zero), and predictions since.
    seen: Option<(f64, f64)>,
    since: u32,
}

/// One channel's line: none until its model is active and its warm-up or model holds one.
#[derive(Debug, Clone)]
pub(super) struct ChannelLine {
    /// Allocated only with a line: a channel without one holds one pointer and touches nothing
    /// per sample.
    tracker: Option<Box<Tracker>>,
    /// The model was looked at (once, when the channel became active).
    checked: bool,
}

impl ChannelLine {
    pub(super) fn new() -> Self {
        ChannelLine {
            tracker: None,
            checked: false,
        }
    }

    /// Whether the model was looked at already.
    #[inline]
    pub(super) fn checked(&self) -> bool {
        self.checked
    }

    /// Look for a line once (call when the channel is active, at its first active sample,
    /// index `idx`): the line its warm-up window held (`window`, indexed from this sample: the
    /// notch starts on it), else one its `model` holds (the notch starts at zero).
    pub(super) fn adopt(
        &mut self,
        window: Option<Sinusoid>,
        model: Option<&ArimaChannelModel>,
        idx: u64,
        channel: &str,
    ) {
        if self.checked {
            return;
        }
        self.checked = true;
        // Per-sample units: frequency ω/2π cycles per sample, "time" the sample index.
        let (notch, seen) = match (window, model.and_then(|m| m.line())) {
            (Some(l), _) => {
                // In the notch's time: a sin(ω t) + b cos(ω t) = A sin(ω t + φ).
                let l = l.shifted(-(idx as f64));
                let f = l.omega / TAU;
                tracing::info!(
                    channel,
                    "gross_error: the warm-up held a vibration line ({f:.4} of the sample rate, amplitude {:.3e}); the channel's model is of the channel without it, and its tests judge the channel with it taken out while it stays a line",
                    l.amplitude()
                );
                let n = LineCanceller::new(f, 1.0, LINE_BANDWIDTH, l.amplitude(), l.b.atan2(l.a));
                (n, Some((l.a, l.b)))
            }
            (None, Some(omega)) => {
                let f = omega / TAU;
                tracing::info!(
                    channel,
                    "gross_error: the channel's model holds a vibration line ({f:.4} of the sample rate); its tests judge the channel with the line taken out while it stays a line"
                );
                (LineCanceller::new(f, 1.0, LINE_BANDWIDTH, 0.0, 0.0), None)
            }
            (None, None) => return,
        };
        self.tracker = Some(Box::new(Tracker {
            notch,
            taken: [0.0; RING],
            live: true,
            passes: 0,
            seen,
            since: 0,
        }));
    }

    /// The line predicted for the sample at index `idx`, `steps` samples after the previous one
    /// (0 without a line, or while it is not a line), kept for its replacement. Every
    /// [`LINE_CHECK_SAMPLES`] the notch's weights are compared with the last look's: a line
    /// keeps its amplitude and phase, so they differ by at most half their size (the window's
    /// own test, `stats::line`); a line that moved away (an engine's order when the revs
    /// change) leaves the notch tracking a slice of whatever is there, whose weights wander.
    /// Then the line is no longer taken out, until two looks in a row find it again.
    #[inline]
    pub(super) fn predict(&mut self, idx: u64, steps: u32) -> f64 {
        let Some(t) = self.tracker.as_deref_mut() else {
            return 0.0;
        };
        let est = t.notch.predict_next(idx as f64, steps);
        t.since += 1;
        if t.since >= LINE_CHECK_SAMPLES {
            t.since = 0;
            let now = t.notch.weights();
            if let Some(was) = t.seen {
                let still = (now.0 - was.0).hypot(now.1 - was.1)
                    <= 0.5 * now.0.hypot(now.1).max(was.0.hypot(was.1));
                t.passes = if still { t.passes.saturating_add(1) } else { 0 };
                t.live = if t.live { still } else { t.passes >= 2 };
            }
            t.seen = Some(now);
        }
        let est = if t.live { est } else { 0.0 };
        t.taken[(idx % RING as u64) as usize] = est;
        est
    }

    /// Learn the line from raw value `x`, the sample last predicted (one the gate accepted).
    #[inline]
    pub(super) fn learn(&mut self, x: f64) {
        if let Some(t) = self.tracker.as_deref_mut() {
            t.notch.learn(x);
        }
    }

    /// `r`, a replacement at index `idx` judged without the line, with the line put back (`r`
    /// itself without a line).
    #[inline]
    pub(super) fn put_back(&self, idx: u64, r: f64) -> f64 {
        match self.tracker.as_deref() {
            Some(t) => r + t.taken[(idx % RING as u64) as usize],
            None => r,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Feed `n` samples of `a sin(ω i + 0.3) + noise` from index `from`; the estimates returned.
    fn feed(l: &mut ChannelLine, rng: &mut Rng, from: u64, n: u64, omega: f64) -> Vec<f64> {
        (from..from + n)
            .map(|i| {
                let est = l.predict(i, 1);
                let x = 2.0 * (omega * i as f64 + 0.3).sin() + 0.5 * rng.normal();
                l.learn(x);
                est
            })
            .collect()
    }

    #[test]
    fn a_line_is_taken_out_while_it_stays_and_not_once_it_moves() {
        let omega = std::f64::consts::TAU * 0.22;
        // The window's fit of the same line, indexed from the first active sample (1000).
        let fitted = Sinusoid {
            omega,
            a: 2.0 * (omega * 1000.0 + 0.3).cos(),
            b: 2.0 * (omega * 1000.0 + 0.3).sin(),
        };
        let mut l = ChannelLine::new();
        l.adopt(Some(fitted), None, 1000, "gx");
        let mut rng = Rng::new(5);
        // Seeded from the fit: right from the first sample the estimate is the line (its
        // value at 1000 is 2 sin(ω·1000 + 0.3)).
        let first = feed(&mut l, &mut rng, 1000, 3000, omega);
        assert!((first[0] - 2.0 * (omega * 1000.0 + 0.3).sin()).abs() < 1e-9);
        assert!(
            first[2900..].iter().any(|e| e.abs() > 1.5),
            "the line is taken out"
        );
        // The line moves 0.01 cycles per sample (an engine's revs change): 70 notch bandwidths
        // away. Within two looks (512 samples) it is no longer taken out.
        let moved = feed(&mut l, &mut rng, 4000, 3000, omega + 0.063);
        assert!(
            moved[600..].iter().all(|e| *e == 0.0),
            "a lost line is not taken out"
        );
        // Back at its frequency (the engine idles again): taken out again after two looks in a
        // row find it (the notch first re-learns it, ~100 samples).
        let back = feed(&mut l, &mut rng, 7000, 3000, omega);
        assert!(
            back[1500..].iter().all(|e| *e != 0.0),
            "a line found again is taken out"
        );
        // A replacement gets back what was taken out.
        let i = 9999;
        assert_eq!(l.put_back(i, 1.0), 1.0 + back[(i - 7000) as usize]);
    }

    #[test]
    fn without_a_line_nothing_is_allocated_or_taken_out() {
        let mut l = ChannelLine::new();
        l.adopt(None, None, 0, "gx");
        assert!(l.checked() && l.tracker.is_none());
        assert_eq!(l.predict(5, 1), 0.0);
        assert_eq!(l.put_back(5, 1.5), 1.5);
    }
}
