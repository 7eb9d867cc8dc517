//! The causal one-step gate of one channel (Chen, Li & Zhang 2013, §2.5): which samples are
//! gross-error *candidates*. Heap-free per sample.
//!
//! With the model's one-step prediction `x̂_t` from the channel's own (corrected) history, `h` =
//! samples since the last accepted one (1 outside runs and gaps), and `ℓ_J`, `s` a fast Holt
//! local linear trend of the accepted samples:
//!
//! ```text
//!   ν_t = x_t − x̂_t                          innovation (an h-step forecast error inside a run)
//!   J_t = x_t − (ℓ_J + h·s)                   jump from the local trend of the accepted samples
//!   outside a run:  candidate ⇔ ν_t² > k² r_h² σ² ∧ J_t² > k_Δ² σ_Δ²   (r_h² = Σ_{i<h} ψ_i²)
//!   inside a run:   candidate ⇔ ν_t² > run_k² σ²                 (hysteresis, run_k < k)
//!   at max_run:     candidate ⇔ ν_t² > k² r_h² σ²                (else a level change)
//!   always:         x_t non-finite, implausible or saturated
//! ```
//!
//! A candidate's prediction (or the median of recent predictions) — never the sample — enters the
//! history, so a spike cannot drag the forecast. At most `max_run` successive candidates; the next
//! one is a genuine level change: the predictor restarts there. The release rule ends an event
//! whose first sample was borderline (< `release_k` σ) and that continues smoothly. Whether a
//! candidate is *replaced* is not decided here: the stage confirms it two-sidedly (`confirm.rs`).
//!
//! **Scale tracking.** σ² and σ_Δ² are exponentially weighted, Huber-winsorised mean squares of
//! accepted one-step samples (`min(ν², c²σ²)/β(c)`, c = 2.5, β(c) = E[min(Z², c²)]): candidates
//! do not contribute, unusual accepted samples at most c²σ².
//!
//! **Tail adaptation.** The share p₃ of accepted one-step innovations beyond 3σ is tracked (EWMA,
//! `tail_window_samples`); while it exceeds twice the Gaussian 0.27 % the gate widens to
//! `k (1 + β ln(p₃ / 0.54 %))`: heavy-tailed vibration makes fewer candidates.
//!
//! **Saturation.** A saturated sample is a candidate and never enters the history. A saturated
//! stretch longer than `max_run` freezes the predictor (its values pass, flagged, as the best
//! measurement there is: the rail), and the first unsaturated sample re-seeds it — so a
//! saturated value can never become a prediction the model trusts.
//!
//! **Gaps.** Up to `bridge_max_missing` missing frames are bridged with the model's own
//! predictions (h grows, the gate widens by r_h); longer gaps reset, and the next good sample
//! re-seeds the history.
//!
//! **No model.** A channel without a fitted model collects `warmup_samples` finite samples (or
//! fewer: see [`WarmupLimits`]), cleans them with a Hampel filter, and identifies its ARIMA model
//! once; a failed identification falls back to white noise about the median. By default the
//! window goes to the stage's worker thread and the warm-up goes on for `identify_defer_s` of
//! the channel's own time, when the channel takes the model over ([`super::identify`]). Its
//! buffers (the window's copy for the worker included) are allocated at construction: on the
//! sample path the close allocates only the job's handle and name.

// `!(v > 0.0)` is used on purpose: unlike `v <= 0.0` it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::identify::{
    HAMPEL_HALF_WIDTH, HAMPEL_K, Identified, Identifier, Missing, Pending, white_model,
};
use super::settings::{GrossErrorSettings, MAX_MEDIAN_WINDOW, Replacement};
use crate::model::arima::{
    ArimaChannelModel, ArimaError, ArimaPredictor, MAX_D, MAX_P, psi_weights,
};
use crate::stats::grid::grid_step;
use crate::stats::line::Sinusoid;
use crate::stats::robust::{HampelScratch, hampel_at, median_small, upper_median_and_mad_sigma};
use crate::stats::special::{normal_cdf, normal_pdf};

/// Huber clip of the scale trackers, in units of the current scale.
const SCALE_CLIP: f64 = 2.5;
/// Warm-up samples used to seed the predictor before it is run through the rest (p + d ≤ 4).
pub const RAW_KEEP: usize = MAX_P + MAX_D;
/// Horizons for which the h-step widening r_h is tabulated (longer horizons use the last).
const PSI_N: usize = 32;
/// P(|Z| > 3) for a standard normal Z.
const GAUSS_TAIL3: f64 = 0.002_699_796;
/// Tail adaptation: no widening until the tracked share beyond 3σ is this many times Gaussian.
const TAIL_DEAD_ZONE: f64 = 2.0;

/// Constants of the gate derived once from the settings.
#[derive(Debug, Clone, Copy)]
pub struct GateParams {
    pub warmup: WarmupLimits,
    k2: f64,
    jump_k2: f64,
    run_k2: f64,
    release_k2: f64,
    tail_w: f64,
    tail_gain: f64,
    scale_w: f64,
    inv_beta: f64,
    keep_preds: bool,
    median_window: usize,
    confirm: bool,
    max_run: u32,
    slope_alpha: f64,
    jump_level_alpha: f64,
    level_alpha: f64,
    trend_beta: f64,
    scale_window: f64,
}

impl GateParams {
    pub fn new(s: &GrossErrorSettings) -> Self {
        GateParams {
            warmup: WarmupLimits::new(s),
            k2: s.k * s.k,
            jump_k2: s.jump_k * s.jump_k,
            run_k2: s.run_k * s.run_k,
            release_k2: s.release_k * s.release_k,
            tail_w: if s.tail_window_samples > 0.0 {
                1.0 / s.tail_window_samples
            } else {
                0.0
            },
            tail_gain: s.tail_gain,
            scale_w: 1.0 / s.scale_window_samples,
            inv_beta: 1.0 / huber_beta(SCALE_CLIP),
            keep_preds: s.replacement == Replacement::MedianOfPredictions,
            median_window: s.median_window,
            confirm: s.confirm_jump,
            max_run: s.max_run,
            slope_alpha: s.slope_alpha,
            jump_level_alpha: s.jump_level_alpha,
            level_alpha: s.level_alpha,
            trend_beta: s.trend_beta,
            scale_window: s.scale_window_samples,
        }
    }
}

crate::stage::health::counters! {
    /// Health counters of one channel.
    #[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
    pub struct ChannelCounters {
        /// Samples replaced (confirmed gross errors and bad values).
        replaced,
        /// Events (runs of successive candidates; a single spike is a run of 1).
        runs,
        /// Events confirmed as gross errors (replaced).
        confirmed,
        /// Events passed unchanged, flagged suspect, and their samples.
        suspect_events,
        suspect,
        /// Runs longer than `max_run` accepted as level changes.
        level_changes,
        /// Events released by the release rule.
        released,
        /// Non-finite values seen.
        non_finite,
        /// Finite values beyond the plausible range of any MEMS sensor.
        implausible,
        /// Saturated samples seen.
        saturated,
        /// Samples passed through while warming up.
        warmup,
        /// Identifications that fell back to the white-noise model.
        fallback_models,
        /// Vibration lines found after the warm-up and taken out (`line.rs`).
        lines_found,
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Disabled,
    WarmingUp,
    Active,
}

/// What the gate made of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// Accepted into the history.
    Passed,
    /// A candidate; `pred` is what entered the history in its place.
    Candidate { pred: f64 },
    /// A run outlasted `max_run`: the value is accepted as a new level.
    LevelChange,
    /// The channel has no model yet.
    Warming,
}

/// How the event that just ended ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EventEnd {
    /// Motion by the gate's own rules (a level change or the release rule).
    pub motion: bool,
}

/// The gate of one channel.
#[derive(Debug, Clone)]
pub struct ChannelGate {
    pub mode: Mode,
    pred: Option<ArimaPredictor>,
    /// Tracked innovation variance σ² and jump variance σ_Δ².
    sig2: f64,
    jump2: f64,
    min_var: f64,
    /// Successive candidates so far.
    pub run: u32,
    /// Samples since the last accepted one.
    h: u32,
    /// Jump reference: Holt level ℓ_J and slope s of the accepted samples.
    x_acc: f64,
    slope: f64,
    r2: [f64; PSI_N],
    needs_seed: bool,
    /// A saturated stretch outlasted max_run: the predictor is frozen until it ends.
    sat_frozen: bool,
    tail3: f64,
    first_raw: f64,
    first_ratio2: f64,
    /// The event that ended at the current sample.
    pub ended: Option<EventEnd>,
    preds: [f64; MAX_MEDIAN_WINDOW],
    n_preds: usize,
    pub counters: ChannelCounters,
    warm: Vec<f64>,
    /// Warm-up time counted so far (ns; see [`WarmupLimits`]), the time stamp of the last kept
    /// warm-up sample, and whether a gap came since.
    warm_span_ns: u64,
    warm_last_t: Option<u64>,
    warm_gap: bool,
    /// The window's model, being identified off the sample path.
    deferred: Option<Deferred>,
    /// Samples a deferred take-over waits after the deferral's end (the stage gives each channel
    /// its index, so six channels do not take their models over in one call).
    stagger: usize,
    /// The samples kept since the window closed, Hampel-cleaned as they get their context.
    tail: Vec<f64>,
    hampel_scratch: HampelScratch,
    /// The buffer the closed window is copied into for the worker (its pages touched at
    /// construction).
    job_buf: Vec<f64>,
    pub model: Option<ArimaChannelModel>,
    /// The line taken out of the warm-up window before its model was identified
    /// ([`identify_window`](super::identify::identify_window)), indexed from the sample after
    /// activation (the channel's line tracker starts from it, [`super::line`]).
    pub line: Option<Sinusoid>,
    /// A model file's model that declares a line, seeded at the warm-up's end
    /// ([`ChannelGate::warm_up_for`]).
    given: Option<ArimaChannelModel>,
    /// The step of the grid the warm-up's values lie on (the channel's LSB), 0 when they lie on
    /// none (or the model came from a file): see [`grid_step`](crate::stats::grid::grid_step) and [`ChannelGate::resolution`].
    resolution: f64,
}

/// Warm-up samples before the grid is read. With few, the smallest difference seen may still be
/// a multiple of the LSB (a floor too high: fewer candidates, never more); but a channel quiet
/// enough for the floor to matter steps by one LSB at nearly every change, and until the grid is
/// read every toggle of such a channel is a break (σ = 0.2 LSB: 5 toggles replaced in the first
/// second when this was 100). The grid is re-read at every warm-up sample up to
/// [`GRID_SETTLED_SAMPLES`], and from the whole window at activation.
pub const GRID_MIN_SAMPLES: usize = 10;
/// Warm-up samples after which the grid is re-read only at activation.
pub const GRID_SETTLED_SAMPLES: usize = 100;

/// `E[min(Z², c²)]` for Z ~ N(0, 1).
pub fn huber_beta(c: f64) -> f64 {
    let p_in = 2.0 * normal_cdf(c) - 1.0;
    p_in - 2.0 * c * normal_pdf(c) + c * c * (1.0 - p_in)
}

/// Var(x_t − x_{t−1}) implied by a model (from the ψ-weights of its ARMA part).
pub fn model_increment_var(m: &ArimaChannelModel) -> f64 {
    let mut psi_hist = [0.0f64; MAX_P];
    let (mut g0, mut g1, mut prev) = (0.0, 0.0, 0.0);
    for j in 0..5000 {
        let mut psi = if j == 0 {
            1.0
        } else if j <= m.q {
            m.ma[j - 1]
        } else {
            0.0
        };
        if j > 0 {
            for (i, phi) in m.ar.iter().enumerate() {
                if j > i {
                    psi += phi * psi_hist[i];
                }
            }
        }
        g0 += psi * psi;
        if j > 0 {
            g1 += prev * psi;
        }
        prev = psi;
        for i in (1..MAX_P).rev() {
            psi_hist[i] = psi_hist[i - 1];
        }
        psi_hist[0] = psi;
        if j > 50 && psi.abs() < 1e-12 {
            break;
        }
    }
    let s2 = m.sigma * m.sigma;
    if m.d == 1 {
        s2 * g0
    } else {
        2.0 * s2 * (g0 - g1)
    }
}

/// One Holt step: forecast m = ℓ + b, then ℓ ← m + α (x − m), b ← b + β (ℓ_new − ℓ − b).
#[inline]
fn holt_step(level: f64, slope: f64, x: f64, alpha: f64, beta: f64) -> (f64, f64) {
    let m = level + slope;
    let l_new = m + alpha * (x - m);
    (l_new, slope + beta * (l_new - level - slope))
}

impl ChannelGate {
    /// A gate with scale floor `min_sigma`, enabled or not; it warms up until it gets a model.
    pub fn new(enabled: bool, min_sigma: f64) -> Self {
        let v = min_sigma * min_sigma;
        ChannelGate {
            mode: if enabled {
                Mode::WarmingUp
            } else {
                Mode::Disabled
            },
            pred: None,
            sig2: v,
            jump2: v,
            min_var: v,
            run: 0,
            h: 1,
            x_acc: 0.0,
            slope: 0.0,
            r2: [1.0; PSI_N],
            needs_seed: true,
            sat_frozen: false,
            tail3: GAUSS_TAIL3,
            first_raw: 0.0,
            first_ratio2: f64::INFINITY,
            ended: None,
            preds: [0.0; MAX_MEDIAN_WINDOW],
            n_preds: 0,
            counters: ChannelCounters::default(),
            warm: Vec::new(),
            warm_span_ns: 0,
            warm_last_t: None,
            warm_gap: false,
            deferred: None,
            stagger: 0,
            tail: Vec::new(),
            hampel_scratch: HampelScratch::default(),
            job_buf: Vec::new(),
            resolution: 0.0,
            model: None,
            line: None,
            given: None,
        }
    }

    /// Tracked innovation σ (None unless active).
    pub fn sigma(&self) -> Option<f64> {
        (self.mode == Mode::Active).then(|| self.sig2.sqrt())
    }

    /// Tracked jump σ_Δ (None unless active).
    pub fn jump_sigma(&self) -> Option<f64> {
        (self.mode == Mode::Active).then(|| self.jump2.sqrt())
    }

    /// Advance through `m` missing samples with the model's own predictions (a bridged gap).
    pub fn bridge(&mut self, m: u32) {
        if let Some(pr) = self.pred.as_mut() {
            for _ in 0..m {
                let xh = pr.predict();
                pr.update(xh, 0.0);
            }
            self.h = self.h.saturating_add(m);
        }
    }

    /// Forget the history: the next good sample re-seeds it.
    pub fn reset(&mut self) {
        if self.mode == Mode::Active {
            self.needs_seed = true;
        }
    }

    /// The stage judged the current event to be motion: end it, and continue from the raw
    /// values (newest first) instead of the predictions the event fed in.
    pub fn resume_from(&mut self, recent_newest_first: &[f64]) {
        let Some(pr) = self.pred.as_mut() else {
            return;
        };
        let Some(&v) = recent_newest_first.first() else {
            return;
        };
        pr.reseed(recent_newest_first);
        self.x_acc = v;
        self.slope = pr.slope();
        self.run = 0;
        self.h = 1;
        self.n_preds = 0;
        self.first_ratio2 = f64::INFINITY;
    }

    /// The event was motion (released, or a new level): restart the predictor at the raw value
    /// `v` with the current slope, and end the event.
    fn continue_from(&mut self, v: f64) {
        if let Some(pr) = self.pred.as_mut() {
            pr.restart(v, self.slope);
        }
        self.x_acc = v;
        self.h = 1;
        self.run = 0;
        self.n_preds = 0;
        self.ended = Some(EventEnd { motion: true });
    }

    /// Gate one value of an active channel (`bad`: non-finite or implausible; `forced`: the jump
    /// guard calls it a candidate). Per sample: no allocation.
    #[inline]
    pub fn gate(
        &mut self,
        p: &GateParams,
        v: f64,
        bad: bool,
        saturated: bool,
        forced: bool,
    ) -> Outcome {
        self.ended = None;
        let k2 = {
            let r = self.tail3 / (GAUSS_TAIL3 * TAIL_DEAD_ZONE);
            if p.tail_w > 0.0 && r > 1.0 {
                let f = 1.0 + p.tail_gain * r.ln();
                p.k2 * f * f
            } else {
                p.k2
            }
        };
        let Some(pred) = self.pred.as_mut() else {
            return Outcome::Passed;
        };
        let usable = !bad && !saturated;
        if saturated && !bad && self.sat_frozen {
            // A saturated stretch beyond max_run: real motion beyond the sensor's range. The
            // predictor stays frozen; the first unsaturated sample re-seeds it.
            return Outcome::Passed;
        }
        if self.sat_frozen && usable {
            self.sat_frozen = false;
            self.needs_seed = true;
        }
        if self.needs_seed && usable {
            pred.reseed(&[v]);
            self.needs_seed = false;
            self.n_preds = 0;
            self.run = 0;
            self.h = 1;
            self.x_acc = v;
            self.slope = 0.0;
            return Outcome::Passed;
        }
        let xh = pred.predict();
        if p.keep_preds {
            for i in (1..MAX_MEDIAN_WINDOW).rev() {
                self.preds[i] = self.preds[i - 1];
            }
            self.preds[0] = xh;
            self.n_preds = (self.n_preds + 1).min(MAX_MEDIAN_WINDOW);
        }
        let h = self.h.max(1);
        let r2 = self.r2[(h as usize).min(PSI_N) - 1];
        let nu = v - xh;
        let jump = v - self.x_acc - h as f64 * self.slope;
        let strict = nu * nu > k2 * r2 * self.sig2;
        let candidate = if !usable {
            true
        } else if self.run >= p.max_run {
            strict
        } else if self.run > 0 {
            nu * nu > p.run_k2 * self.sig2 || forced
        } else {
            strict && (!p.confirm || jump * jump > p.jump_k2 * self.jump2) || forced
        };
        if !candidate {
            pred.update(v, nu);
            if h == 1 {
                let cap = SCALE_CLIP * SCALE_CLIP;
                if p.tail_w > 0.0 {
                    let beyond = if nu * nu > 9.0 * self.sig2 { 1.0 } else { 0.0 };
                    self.tail3 += p.tail_w * (beyond - self.tail3);
                }
                self.sig2 += p.scale_w * ((nu * nu).min(cap * self.sig2) * p.inv_beta - self.sig2);
                self.jump2 +=
                    p.scale_w * ((jump * jump).min(cap * self.jump2) * p.inv_beta - self.jump2);
                self.sig2 = self.sig2.max(self.min_var);
                self.jump2 = self.jump2.max(self.min_var);
            }
            if self.run > 0 {
                self.ended = Some(EventEnd { motion: false });
            }
            if h == 1 {
                (self.x_acc, self.slope) =
                    holt_step(self.x_acc, self.slope, v, p.jump_level_alpha, p.slope_alpha);
            } else {
                self.slope += p.slope_alpha * ((v - self.x_acc) / h as f64 - self.slope);
                self.x_acc = v;
            }
            self.h = 1;
            self.run = 0;
            return Outcome::Passed;
        }
        if usable && self.run >= 1 && self.first_ratio2 < p.release_k2 {
            // Release rule: a borderline first sample, continued smoothly twice from the
            // pre-event trend — a manoeuvre the forecast lagged, not a gross error.
            let d = v - (self.first_raw + self.run as f64 * self.slope);
            if d * d > p.jump_k2 * self.jump2 {
                self.first_ratio2 = f64::INFINITY;
            } else if self.run >= 2 {
                self.slope += p.slope_alpha * ((v - self.first_raw) / self.run as f64 - self.slope);
                self.counters.released += 1;
                self.continue_from(v);
                return Outcome::Passed;
            }
        }
        if self.run >= p.max_run {
            if usable {
                // Too long to be a gross error: accept the new level.
                self.counters.level_changes += 1;
                self.continue_from(v);
                return Outcome::LevelChange;
            }
            if saturated && !bad {
                // Saturated beyond max_run: freeze (see the module docs).
                self.sat_frozen = true;
                self.run = 0;
                self.h = 1;
                self.counters.level_changes += 1;
                self.ended = Some(EventEnd { motion: true });
                return Outcome::Passed;
            }
        }
        let r = if p.keep_preds && self.n_preds > 0 {
            median_small::<MAX_MEDIAN_WINDOW>(&self.preds[..self.n_preds.min(p.median_window)])
        } else {
            xh
        };
        pred.update(r, r - xh);
        if self.run == 0 {
            self.counters.runs += 1;
            self.first_raw = v;
            self.first_ratio2 = if usable {
                nu * nu / (r2 * self.sig2)
            } else {
                f64::INFINITY
            };
        }
        self.run = self.run.saturating_add(1);
        self.h = self.h.saturating_add(1);
        Outcome::Candidate { pred: r }
    }
}

mod warmup;
use warmup::Deferred;
pub use warmup::{MAX_STAGGER, Seed, WarmupLimits};

#[cfg(test)]
mod tests;
