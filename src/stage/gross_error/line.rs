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
//!   with a complex root pair there; a model from a file, say). The notch starts at zero; or
//! * later, a search of the channel's last [`RING`] values finds one, as the warm-up's window
//!   is searched ([`ChannelLine::start_search`]): every [`LINE_SEARCH_SAMPLES`] while no line
//!   is taken out, on the stage's line-search thread (`search.rs`), the result taken up [`LINE_CHECK_SAMPLES`]
//!   after the search started. A motor switched on after the warm-up, a line that drifted out
//!   of its notch. The notch starts from a fit on the window's last [`SEARCH_TAIL`] samples.
//!
//! Every test (the ARIMA gate, the jump test, the confirmation, the several-axes test's
//! partners) then judges the value less the line predicted for it; a replacement gets the line
//! back, and a value passed keeps its own. The stale-repeat detector still compares the raw
//! values. A line that drifts slowly (a fan's speed) is followed: at each look the turn of the
//! notch's weights is its frequency error, and the notch is moved by it and by the drift it has
//! shown ([`LINE_MAX_TURN`], [`LINE_FOLLOW_SHARE`], [`LINE_DRIFT_GAIN`]). A line that moves away — an engine's firing order at idle when the
//! revs rise (the rtklibexplorer drive: 30.7 Hz at idle for its first 40 s, then spread over
//! 25–31 Hz) — is no longer taken out ([`ChannelLine::predict`]), so that a slice of the motion
//! the notch would then track does not sharpen the tests against real motion; the searches find
//! it again where it settles. Without a line nothing changes but the searches (a window copied
//! every [`LINE_SEARCH_SAMPLES`]; the search thread's test, 18–26 µs on 2048 samples without a
//! line, stops at the periodogram when no peak could hold a line that matters, and estimates no
//! floor under a peak that could not pass).

use super::RING;
use super::identify::window_line;
use super::search::Searcher;
use crate::model::arima::ArimaChannelModel;
use crate::stage::bias::line_canceller::LineCanceller;
use crate::stats::line::{Sinusoid, fit_sinusoid, pair_ls, peak_on_grid};
use std::f64::consts::TAU;

/// Bandwidth of a line's notch, cycles per sample: μ = π × this = 0.005, so the tracked line
/// settles within about 1/(2μ) = 100 samples and its estimate carries √μ ≈ 7 % of the noise σ.
pub const LINE_BANDWIDTH: f64 = 0.0016;

/// Samples between two looks at whether the tracked line is still a line: about 2.5
/// notch time constants (1/(2μ) = 100 samples), so that a narrow slice of broadband motion,
/// which is all a notch tracks once its line has gone, has forgotten the previous look.
pub const LINE_CHECK_SAMPLES: u32 = 256;

/// Samples between two searches for a line on a channel that has none taken out (none found
/// in its warm-up, or one that moved away): a quarter of the stage's ring, each search reading
/// the whole ring. A motor switched on after the warm-up, or an engine back at idle at other
/// revs, is then taken out too, once the line fills about three quarters of the ring (the
/// test's halves must agree): taken out 18–23 s after it starts at 100 Hz, where a search
/// every ring length took 20–37 s (the six channels of the line bench's line switched on at
/// 300 s, `tests/reference/vibration/line_bench.sh`, at 4 and at 10 times the white σ).
pub const LINE_SEARCH_SAMPLES: u64 = RING as u64 / 4;

/// Most a live line's notch weights may turn between two looks, rad: a quarter turn, a
/// frequency error of 1/(4 × [`LINE_CHECK_SAMPLES`]) cycles per sample (0.1 Hz at 100 Hz).
/// Within it the turn is the line's frequency error, and the notch is moved by it.
pub const LINE_MAX_TURN: f64 = std::f64::consts::FRAC_PI_2;

/// Most a live line is followed from the frequency it was found at, as a share of it (a fan's
/// or an idling engine's slow drift); beyond it the line is no longer taken out, and the
/// channel's searches ([`LINE_SEARCH_SAMPLES`]) find it where it went.
pub const LINE_FOLLOW_SHARE: f64 = 0.05;

/// A live line's notch is set ahead by the drift it has shown: at each look the frequency error
/// left (the turn) corrects the drift's estimate by this share of it, and the notch is moved by
/// the error and by one look's drift (a second-order loop). With 1/8 the estimate averages about
/// eight looks, so a constant line's notch barely jitters (line bench, 10×: F1 0.901 without the
/// drift term, 0.899 with it) while a line drifting 0.005 Hz/s at 100 Hz is followed closely
/// (0.753 → 0.878).
pub const LINE_DRIFT_GAIN: f64 = 0.125;

/// The tracker of one channel's line.
#[derive(Debug, Clone)]
struct Tracker {
    notch: LineCanceller,
    /// The frequency the line was found at, cycles per sample.
    found_at: f64,
    /// The estimate taken out of the raw value at each index % RING (0 while not a line).
    taken: [f64; RING],
    /// The line is taken out (it was still a line at the last look).
    live: bool,
    /// Successive looks at which it was a line (two bring a lost line back).
    passes: u8,
    /// The notch's weights (a, b) at the last look (`None` before the first, for a notch that
    /// starts at zero), its index, and predictions since.
    seen: Option<(f64, f64)>,
    seen_at: u64,
    since: u32,
    /// The line's frequency drift, cycles per sample per sample ([`LINE_DRIFT_GAIN`]).
    rate: f64,
}

impl Tracker {
    fn new(notch: LineCanceller, seen: Option<(f64, f64)>, idx: u64) -> Self {
        Tracker {
            found_at: notch.freq_hz(),
            notch,
            taken: [0.0; RING],
            live: true,
            passes: 0,
            seen,
            seen_at: idx,
            since: 0,
            rate: 0.0,
        }
    }

    /// A new line, found at index `idx`, replaces the tracked one (what was taken out while the
    /// last one was live stays, for its replacements).
    fn restart(&mut self, notch: LineCanceller, seen: Option<(f64, f64)>, idx: u64) {
        let taken = std::mem::replace(&mut self.taken, [0.0; RING]);
        *self = Tracker {
            taken,
            ..Tracker::new(notch, seen, idx)
        };
    }

    /// The look at index `idx` (module docs of [`ChannelLine::predict`]).
    fn look(&mut self, idx: u64) {
        let now = self.notch.weights();
        if let Some(was) = self.seen {
            let (a_now, a_was) = (now.0.hypot(now.1), was.0.hypot(was.1));
            if self.live {
                let turn = (now.1.atan2(now.0) - was.1.atan2(was.0) + std::f64::consts::PI)
                    .rem_euclid(TAU)
                    - std::f64::consts::PI;
                let n = idx.saturating_sub(self.seen_at).max(1) as f64;
                let e = turn / (TAU * n);
                let f = self.notch.freq_hz() + e;
                self.live = (a_now - a_was).abs() <= 0.5 * a_now.max(a_was)
                    && turn.abs() <= LINE_MAX_TURN
                    && (f - self.found_at).abs() <= LINE_FOLLOW_SHARE * self.found_at;
                if self.live {
                    self.rate += LINE_DRIFT_GAIN * e / n;
                    self.notch.retune(f + self.rate * n, 1.0);
                } else {
                    self.rate = 0.0;
                }
                self.passes = 0;
            } else {
                let still = (now.0 - was.0).hypot(now.1 - was.1) <= 0.5 * a_now.max(a_was);
                self.passes = if still {
                    self.passes.saturating_add(1)
                } else {
                    0
                };
                self.live = self.passes >= 2;
            }
        }
        self.seen = Some(now);
        self.seen_at = idx;
    }
}

/// Samples at the end of a searched window on which the line found is measured again.
const SEARCH_TAIL: usize = 2 * LINE_CHECK_SAMPLES as usize;

/// The line a window holds that the tests should not see ([`window_line`] on the window as
/// the values came, not Hampel-cleaned: the ring already holds the stage's replacements), as it
/// is at the window's end: its frequency (within one bin of the tail's
/// resolution around the window's), amplitude and phase fitted again on the last
/// [`SEARCH_TAIL`] samples, since a line that drifts (the reason it is searched for again) is
/// not where the whole window's mean puts it by the time it is taken up. None in a window with
/// a bad value not yet replaced (the next search).
pub(super) fn search_window(window: &[f64]) -> Option<Sinusoid> {
    if window.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let l = window_line(window)?;
    let t0 = window.len().checked_sub(SEARCH_TAIL)?;
    let tail = &window[t0..];
    let mean = tail.iter().sum::<f64>() / tail.len() as f64;
    let bin = TAU / SEARCH_TAIL as f64;
    let omega = peak_on_grid(
        |w| {
            let (a, b) = pair_ls(tail, mean, w, t0);
            a * a + b * b
        },
        l.omega,
        bin / 8.0,
        17,
    );
    Some(fit_sinusoid(tail, omega, t0))
}

/// One channel's line: none until its model is active and its warm-up or model holds one.
#[derive(Debug, Clone)]
pub(super) struct ChannelLine {
    /// Allocated only with a line: a channel without one holds one pointer and touches nothing
    /// per sample.
    tracker: Option<Box<Tracker>>,
    /// The model was looked at (once, when the channel became active).
    checked: bool,
    /// Index of the next search for a line ([`LINE_SEARCH_SAMPLES`]).
    next_search: u64,
    /// The last window searched (its capacity reserved when the stage is built).
    window: Vec<f64>,
    /// The search under way: its window's first index, and the index at which its result is
    /// taken up ([`LINE_CHECK_SAMPLES`] after it started).
    pending: Option<(u64, u64)>,
}

impl ChannelLine {
    pub(super) fn new() -> Self {
        ChannelLine {
            tracker: None,
            checked: false,
            next_search: u64::MAX,
            window: Vec::with_capacity(RING),
            pending: None,
        }
    }

    /// Whether a search for a line is due at index `idx`: the model was looked at, no line is
    /// taken out, and [`LINE_SEARCH_SAMPLES`] have passed since the last search.
    #[inline]
    pub(super) fn search_due(&self, idx: u64) -> bool {
        idx >= self.next_search && !self.tracker.as_deref().is_some_and(|t| t.live)
    }

    /// Start a search of the channel's last [`RING`] values (`ring`, by index % RING, the
    /// current sample's index `idx` not yet in it; what a live line took out put back) for a
    /// line the tests should not see, as the warm-up's window is searched ([`window_line`]):
    /// on the `searcher`'s thread, or at its take-up without one. Its result is taken up
    /// [`LINE_CHECK_SAMPLES`] later ([`ChannelLine::take_up`]). No allocation.
    pub(super) fn start_search(
        &mut self,
        ring: &[f64; RING],
        idx: u64,
        c: usize,
        searcher: &Searcher,
    ) {
        self.next_search = idx + LINE_SEARCH_SAMPLES;
        let first = idx - RING as u64;
        self.window.clear();
        for i in first..idx {
            let v = ring[(i % RING as u64) as usize];
            self.window.push(self.put_back(i, v));
        }
        searcher.ask(c, &self.window, first);
        self.pending = Some((first, idx + u64::from(LINE_CHECK_SAMPLES)));
    }

    /// At index `idx`: the result of channel `c`'s search under way, if it is due (waiting for
    /// the `searcher`'s thread if it has not finished); a line found is tracked and taken out
    /// from this sample on, its notch starting from the window's fit (then `true`).
    #[inline]
    pub(super) fn take_up(
        &mut self,
        idx: u64,
        c: usize,
        searcher: &Searcher,
        channel: &str,
    ) -> bool {
        let Some((first, at)) = self.pending else {
            return false;
        };
        if idx < at {
            return false;
        }
        self.pending = None;
        let found = searcher
            .answer(c, first)
            .unwrap_or_else(|| searcher.search_here(&self.window));
        let Some(l) = found else {
            return false;
        };
        let window = &self.window;
        let l = l.shifted(-(first as f64));
        let f = l.omega / TAU;
        tracing::info!(
            channel,
            "gross_error: a vibration line at {f:.4} of the sample rate (amplitude {:.3e}) in samples {first}..{}; the channel's tests judge it with the line taken out from sample {idx} while it stays a line",
            l.amplitude(),
            first + window.len() as u64
        );
        let notch = LineCanceller::new(f, 1.0, LINE_BANDWIDTH, l.amplitude(), l.b.atan2(l.a));
        match self.tracker.as_deref_mut() {
            Some(t) => t.restart(notch, Some((l.a, l.b)), idx),
            None => self.tracker = Some(Box::new(Tracker::new(notch, Some((l.a, l.b)), idx))),
        }
        true
    }

    /// Whether the model was looked at already.
    #[inline]
    pub(super) fn checked(&self) -> bool {
        self.checked
    }

    /// Look for a line once (call when the channel is active, at its first active sample,
    /// index `idx`): the line its warm-up window held (`window`, indexed from this sample: the
    /// notch starts on it), else one its `model` holds (the notch starts at zero).
    /// The first search for a line comes [`LINE_SEARCH_SAMPLES`] + `stagger` samples later
    /// (channels staggered, so that no two search at one sample).
    pub(super) fn adopt(
        &mut self,
        window: Option<Sinusoid>,
        model: Option<&ArimaChannelModel>,
        idx: u64,
        stagger: u64,
        channel: &str,
    ) {
        if self.checked {
            return;
        }
        self.checked = true;
        self.next_search = idx + LINE_SEARCH_SAMPLES + stagger;
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
        self.tracker = Some(Box::new(Tracker::new(notch, seen, idx)));
    }

    /// The line predicted for the sample at index `idx`, `steps` samples after the previous one
    /// (0 without a line, or while it is not a line), kept for its replacement. Every
    /// [`LINE_CHECK_SAMPLES`] the notch's weights are compared with the last look's: a line
    /// keeps its amplitude, so it differs by at most half (the window's own test,
    /// `stats::line`), and a line a little off the notch's frequency turns the weights at that
    /// offset — up to [`LINE_MAX_TURN`] the notch is moved by it (and by the drift it has
    /// shown, [`LINE_DRIFT_GAIN`]), within
    /// [`LINE_FOLLOW_SHARE`] of where the line was found. A line that moved away (an engine's
    /// order when the revs change) leaves the notch tracking a slice of whatever is there,
    /// whose weights wander. Then the line is no longer taken out, until two looks in a row
    /// find the weights where they were (a half of their size apart), or a search finds it.
    #[inline]
    pub(super) fn predict(&mut self, idx: u64, steps: u32) -> f64 {
        let Some(t) = self.tracker.as_deref_mut() else {
            return 0.0;
        };
        let est = t.notch.predict_next(idx as f64, steps);
        t.since += 1;
        if t.since >= LINE_CHECK_SAMPLES {
            t.since = 0;
            t.look(idx);
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
        l.adopt(Some(fitted), None, 1000, 0, "gx");
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
    fn a_drifting_line_is_followed_within_its_share() {
        // Found at 0.22 cycles per sample; then its frequency rises by 1e-7 cycles per sample
        // per sample (0.001 Hz/s at 100 Hz: 4.5 % of 0.22 over 1e5 samples, inside the 5 %).
        let f0 = 0.22;
        let fitted = Sinusoid {
            omega: TAU * f0,
            a: 2.0,
            b: 0.0,
        };
        let mut l = ChannelLine::new();
        l.adopt(Some(fitted), None, 0, 0, "gx");
        let mut rng = Rng::new(7);
        let drift = 1e-7;
        let mut phase = 0.0f64;
        let mut live = 0;
        let n = 100_000u64;
        for i in 0..n {
            let est = l.predict(i, 1);
            let f = f0 + drift * i as f64;
            let line = 2.0 * phase.sin();
            phase += TAU * f;
            l.learn(line + 0.5 * rng.normal());
            // Taken out, and close to the line (the notch's residual on a drifting line).
            if i > 1000 && est != 0.0 && (est - line).abs() < 0.5 {
                live += 1;
            }
        }
        // Without the retuning the weights turn by 2π · 1e-7 · i · 256 per look: past a
        // quarter turn after ~10 000 samples, and the line is dropped for good.
        assert!(
            live > 95_000,
            "{live} of {n} samples taken out close to the line"
        );
        let t = l.tracker.as_deref().unwrap();
        let f_end = f0 + drift * n as f64;
        assert!(
            (t.notch.freq_hz() - f_end).abs() < 1e-4,
            "{} vs {f_end}",
            t.notch.freq_hz()
        );
        // The drift itself is learned (the second-order loop): within 30 % after 390 looks.
        assert!(
            (t.rate / drift - 1.0).abs() < 0.3,
            "drift {} vs {drift}",
            t.rate
        );
    }

    #[test]
    fn a_line_switched_on_later_is_found_once_it_fills_most_of_the_ring() {
        // No line in the warm-up; at index 30 000 a line of 4 × the noise σ switches on. The
        // stage's loop (`GrossErrorStage::line_step`), searching inline: the line is taken out
        // once a searched ring holds it over about three quarters of its length (the test's
        // halves must agree), and with a search every quarter ring that is within
        // ¾ RING + ¼ RING + LINE_CHECK_SAMPLES = 2304 samples of its start (23 s at 100 Hz)
        // whatever the stagger, and never before it starts. (With a search every RING samples,
        // as before stop 46, this fails: 2976 samples at stagger 0.)
        let omega = TAU * 0.22;
        let on = 30_000u64;
        let searcher = super::super::search::Searcher::new(false, search_window);
        let bound = RING as u64 + u64::from(LINE_CHECK_SAMPLES);
        for stagger in [0, LINE_SEARCH_SAMPLES / 3, 2 * LINE_SEARCH_SAMPLES / 3] {
            let mut l = ChannelLine::new();
            let mut ring = [0.0; RING];
            let mut rng = Rng::new(11 + stagger);
            l.adopt(None, None, 2000, stagger, "gx");
            let mut found_at = None;
            for idx in 2000..on + 2 * bound {
                if l.take_up(idx, 0, &searcher, "gx") {
                    found_at.get_or_insert(idx);
                }
                if l.search_due(idx) && idx >= RING as u64 {
                    l.start_search(&ring, idx, 0, &searcher);
                }
                let line = if idx >= on {
                    2.0 * (omega * idx as f64).sin()
                } else {
                    0.0
                };
                let x = line + 0.5 * rng.normal();
                l.predict(idx, 1);
                l.learn(x);
                ring[(idx % RING as u64) as usize] = x;
            }
            let at = found_at.expect("the line is found");
            assert!(
                at > on && at - on <= bound,
                "stagger {stagger}: taken out {} samples after it started (bound {bound})",
                at as i64 - on as i64
            );
        }
    }

    #[test]
    fn without_a_line_nothing_is_allocated_or_taken_out() {
        let mut l = ChannelLine::new();
        l.adopt(None, None, 0, 0, "gx");
        assert!(l.checked() && l.tracker.is_none());
        assert_eq!(l.predict(5, 1), 0.0);
        assert_eq!(l.put_back(5, 1.5), 1.5);
    }
}
