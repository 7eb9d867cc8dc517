//! The vibration line a channel's model holds, tracked so that the stage's tests judge the
//! channel without it.
//!
//! The jump test and the confirmation are model-free: they take the signal to be smooth at the
//! sample scale. A vibration line well above the noise (a motor's order) is not, and it hid the
//! gross errors on top of it (docs/gross_error_results.md, "A vibration line blinds the
//! model-free tests"). When a channel's model holds a line — its AR part on the stationarity
//! boundary with a complex root pair there ([`ArimaChannelModel::line`]; identification keeps
//! such models since stop 43) — the channel tracks that line with a notch
//! ([`LineCanceller`], bandwidth [`LINE_BANDWIDTH`] of the sample rate, seeded at zero,
//! learning only from samples the gate accepted), and every test (the ARIMA gate, the jump
//! test, the confirmation, the several-axes test's partners) judges the value less the line
//! predicted for it; a replacement gets the line back, and a value passed keeps its own. The
//! stale-repeat detector still compares the raw values. Without a line nothing changes: none of
//! the real recordings here has one.

use super::RING;
use crate::model::arima::ArimaChannelModel;
use crate::stage::bias::line_canceller::LineCanceller;

/// Bandwidth of a line's notch, cycles per sample: μ = π × this = 0.005, so the tracked line
/// settles within about 1/(2μ) = 100 samples and its estimate carries √μ ≈ 7 % of the noise σ.
pub const LINE_BANDWIDTH: f64 = 0.0016;

/// One channel's line: none until its model is active and holds one.
#[derive(Debug, Clone)]
pub(super) struct ChannelLine {
    /// The notch, and the estimate it took out of the raw value at each index % RING (allocated
    /// with the notch: a channel without a line holds one pointer and touches nothing per
    /// sample).
    notch: Option<Box<(LineCanceller, [f64; RING])>>,
    /// The model was looked at (once, when the channel became active).
    checked: bool,
}

impl ChannelLine {
    pub(super) fn new() -> Self {
        ChannelLine {
            notch: None,
            checked: false,
        }
    }

    /// Whether the model was looked at already.
    #[inline]
    pub(super) fn checked(&self) -> bool {
        self.checked
    }

    /// Look at the channel's `model` for a line, once (call when the channel is active).
    pub(super) fn adopt(&mut self, model: Option<&ArimaChannelModel>, channel: &str) {
        if self.checked {
            return;
        }
        self.checked = true;
        if let Some(omega) = model.and_then(|m| m.line()) {
            // Per-sample units: frequency ω/2π cycles per sample, "time" the sample index.
            let f = omega / std::f64::consts::TAU;
            let notch = LineCanceller::new(f, 1.0, LINE_BANDWIDTH, 0.0, 0.0);
            self.notch = Some(Box::new((notch, [0.0; RING])));
            tracing::info!(
                channel,
                "gross_error: the channel's model holds a vibration line ({f:.4} of the sample rate); its tests judge the channel with the line taken out"
            );
        }
    }

    /// The line predicted for the sample at index `idx`, `steps` samples after the previous one
    /// (0 without a line), kept for its replacement.
    #[inline]
    pub(super) fn predict(&mut self, idx: u64, steps: u32) -> f64 {
        match self.notch.as_deref_mut() {
            Some((n, taken)) => {
                let est = n.predict_next(idx as f64, steps);
                taken[(idx % RING as u64) as usize] = est;
                est
            }
            None => 0.0,
        }
    }

    /// Learn the line from raw value `x`, the sample last predicted (one the gate accepted).
    #[inline]
    pub(super) fn learn(&mut self, x: f64) {
        if let Some((n, _)) = self.notch.as_deref_mut() {
            n.learn(x);
        }
    }

    /// `r`, a replacement at index `idx` judged without the line, with the line put back (`r`
    /// itself without a line).
    #[inline]
    pub(super) fn put_back(&self, idx: u64, r: f64) -> f64 {
        match self.notch.as_deref() {
            Some((_, taken)) => r + taken[(idx % RING as u64) as usize],
            None => r,
        }
    }
}
