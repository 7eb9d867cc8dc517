//! Online gross-error detection and correction by one-step ARIMA prediction (Chen, Li & Zhang
//! 2013, §2.5), per channel, heap-free per sample.
//!
//! For each enabled channel, with the model's one-step prediction `x̂_t` from the stage's own
//! (corrected) history (`model::arima::ArimaPredictor`), `h` = samples since the last accepted
//! one (1 outside runs and gaps), and `ℓ_J`, `s` a fast Holt local linear trend of the accepted
//! raw samples (`ℓ ← m + α_J (x − m)`, `s ← s + β_J (ℓ_new − ℓ − s)`, `m = ℓ + s`; α_J =
//! `jump_level_alpha`, β_J = `slope_alpha`):
//!
//! ```text
//!   ν_t = x_t − x̂_t                          innovation (an h-step forecast error inside a run)
//!   J_t = x_t − (ℓ_J + h·s)                   jump from the local trend of the accepted samples
//!   outside a run:  gross ⇔ ν_t² > k² r_h² σ² ∧ J_t² > k_Δ² σ_Δ²   (the second term is the
//!                   confirmation rule, optional; r_h² = Σ_{i<h} ψ_i² from the model's ψ-weights
//!                   widens the gate for the h-step forecast after a bridged gap, r_1 = 1)
//!   inside a run:   gross ⇔ ν_t² > run_k² σ²                 (hysteresis, run_k < k)
//!   at max_run:     gross ⇔ ν_t² > k² r_h² σ²                (then a level change, see below)
//!   always gross:   x_t non-finite, or the channel flagged saturated
//! ```
//!
//! A gross error is replaced by `x̂_t` (or, as the paper, by the median of the last `median_window`
//! predictions), and the replacement — not the spike — enters the history (with innovation
//! `replacement − x̂_t`, i.e. 0 for the prediction). At most `max_run` successive samples are
//! replaced; the next gross one is taken as a genuine level change: it is passed through, flagged
//! `LEVEL_CHANGE`, and the predictor restarts at that value with the pre-run slope, so a true
//! signal can never be replaced for longer than `max_run` samples. (The level-change decision uses
//! the full gate k, not the in-run hysteresis.)
//!
//! **Why a confirmation rule.** The model is identified on whatever the warm-up saw — usually a
//! vehicle at rest. During a turn or a braking manoeuvre the predictor may lag and `ν` grow with no
//! gross error. A real manoeuvre is smooth at the sample scale (vehicle dynamics are a few Hz, the
//! IMU samples at 100–1000 Hz): locally a straight line, so `J` stays at noise level; a gross error
//! is a discontinuity, so its first sample jumps from the last good value. The rule is applied to
//! the first sample of an event only: inside a run the reference `ℓ_J + h·s` extrapolates a noisy
//! slope over h steps and would let genuine spikes through. The reference is a smoothed level
//! rather than the last accepted sample because J then carries less noise (≈1.2σ instead of
//! ≈1.5σ for white noise): measured on white noise at k = 4.5, recall on 6–8σ spikes went from
//! 0.91 (last sample + EWMA slope) to 0.94, equal to the stage without the rule. Inside a run the innovation gate
//! drops to `run_k` so that a weak member of a run (a 6σ spike seen against a drifting h-step
//! forecast) is not let into the history, where it would turn the good samples after the run into
//! apparent jumps — for a d = 1 model the predictor would even extrapolate from it. For the same
//! reason the in-run gate is not widened by r_h (measured on the synthetic drive whose warm-up
//! yields an ARIMA(2,1,2): with widening 35 of ~2000 spike samples were let through, each followed
//! by a run of false replacements; without it none).
//!
//! **Scale tracking.** `σ²` and `σ_Δ²` are exponentially weighted, Huber-winsorised mean squares
//! (a recursive M-estimate of scale): each *accepted* one-step sample contributes
//! `min(ν², c² σ²) / β(c)` with `c = 2.5` and `β(c) = E[min(Z², c²)]` (so the estimate is unbiased for
//! Gaussian innovations), weight `1/scale_window_samples`. Gross errors do not contribute at all, so
//! spikes cannot inflate σ; accepted-but-unusual samples (a manoeuvre's lag, a rise in vibration)
//! contribute at most `c²σ²`, so σ follows real changes in variability at a bounded rate (≤ +2.7 %
//! in variance per sample at the default 200-sample window) instead of jumping on one outlier. A
//! running MAD would be as robust but needs a sort per sample; this is O(1).
//!
//! **Tail adaptation.** Real vibration and shocks give heavy-tailed innovations (kurtosis 4–26
//! per channel on the rtklibexplorer drive), so a Gaussian k-σ gate calls their tails gross. Each
//! channel tracks the share `p₃` of accepted one-step innovations beyond 3σ (EWMA, time constant
//! `tail_window_samples`; Gaussian: 0.27 %). While `p₃` exceeds twice the Gaussian share the gate
//! widens to `k (1 + β ln(p₃ / 0.54 %))`, β = `tail_gain` — at the default β = 0.75 ×1.74 for a
//! Laplace-like 1.4 %, i.e. 7.8σ at k = 4.5, where a Laplace stream's false-alarm rate (1.6e-5)
//! is back near a Gaussian one's at 4.5σ (6.8e-6). Below twice Gaussian nothing changes; over the
//! default 1000-sample window a Gaussian stream's EWMA share crosses that line now and then, and
//! the measured synthetic k-sweeps moved by at most 3 false alarms in 2·10⁶ samples when the window
//! went from 5000 to 1000 samples. On the real drives the window and gain were chosen by measurement
//! (`docs/results.md`: flags on the rtklibexplorer drive 1148 → 449 → 202 channel-samples without
//! adaptation / at 5000 samples, β 0.5 / at 1000, β 0.75); spikes smaller than the widened gate
//! are not caught there — the price of not replacing real motion, bounded by the ADIS16405
//! injected-spike target (F1 0.9802 at 1000/0.75; a gain of 1.0 drops it to 0.9788).
//!
//! **Local trend.** The predictor is centred on a local linear trend (d = 0) or a local mean of ∇x
//! (d = 1) instead of the fitted constant (`level_alpha`, `trend_beta`; see `ArimaPredictor`), so
//! a model identified at rest follows manoeuvre levels it has never seen.
//!
//! **Gaps (`flags::GAP`).** Missing frames are counted from `seq`. Up to `bridge_max_missing`
//! missing frames are *bridged*: the predictor is advanced through them with its own predictions
//! (innovation 0, its conditional expectation), `h` grows accordingly (so the gate widens by
//! `r_h`), and the next sample is gated normally — over a few sample periods a vehicle's signal
//! moves little, and resetting would instead let the first sample after the gap through ungated
//! and seed the history with it. Longer gaps *reset*: the multi-step prediction error grows with
//! the horizon (without bound for d = 1), the sensor may have restarted, and a one-step gate would
//! then replace genuine changes; the first good sample after the gap re-seeds the history (passed
//! through ungated) and σ is kept (it describes the sensor's noise, which a gap does not change).
//!
//! **Look-ahead (`lookahead_samples` = L, default 0).** The gate above is causal: it must judge
//! an event's first sample before it knows how the event goes on, so a real step costs `max_run`
//! replaced samples and a knock the vehicle really felt is replaced like a spike. With L > 0 the
//! stage emits each sample L samples late (`Stage::push`/`flush`; `process` stays causal) and,
//! when an event ends within that time, restores the raw values of its held samples (flag
//! `REVISED`, the replaced bits cleared) if it proved to be motion:
//! - a level change or a release (the causal rules' own verdict, which came too late to save
//!   the samples before it);
//! - a smooth event: the return to the signal (last raw sample of the event → the first one
//!   accepted after it) is no jump, ≤ `jump_k` σ_Δ, and no step between successive raw samples
//!   after the first is one the gate would call gross, > k σ_Δ (σ_Δ as at the event's start). A
//!   gross error has to jump back; the second test catches a return hidden inside the event when
//!   the stage went on replacing a few good samples after a run (measured on the synthetic logs:
//!   such returns are ≥ 9 σ_Δ). The event still needed a jump to start (the confirmation rule);
//! - part of a shock on several axes: at least two other channels had a one-step innovation
//!   beyond 4σ (`SHOCK_K`; gross or not) within one sample of the event's start — a knock moves
//!   the whole body, a glitch stays in its channel. Not for a one-sample event whose partners
//!   were off on that same sample only: that is what a corrupted whole frame looks like. Each
//!   channel keeps the last 64 samples' "beyond 4σ" bits in a shift register, so the test is
//!   O(1). Independent gross errors on three channels within one sample do pass as a shock:
//!   ~2e-7 of events at a realistic 5e-5 per channel-sample; on the dense synthetic bench
//!   (2e-3) it restored one such coincidence (7 samples, recall 0.9958 → 0.9921).
//!
//! Events with a non-finite, saturated or gap-bridged sample are never revised. The gate's own
//! decisions and state do not change with L: only the output is revised. L = `max_run` + 1 sees
//! every event to its end; a shorter L restores only what it still holds. Measured
//! (`docs/results.md`): at L = 11 the replaced share of the real drives falls 6.4e-4 → 9.5e-5
//! (rtklibexplorer) and 4.9e-3 → 7.8e-5 (comma2k19), within the issue's 1e-4; the synthetic and
//! ADIS16405 targets hold (ADIS16405 F1 0.9802 → 0.9845). The default stays causal: a GPS/INS
//! filter beside the daemon gets its samples without delay unless the user accepts the lag.
//!
//! **No model.** A channel without a fitted model collects `warmup_samples` finite, unsaturated
//! samples (flagged `WARMING_UP`, passed through), cleans them with a Hampel filter (so spikes in
//! the warm-up do not bias the fit), and calls `arima::identify` once — the only allocation after
//! construction. Should identification fail (e.g. a constant channel), a white-noise-about-the-
//! median model with a robust σ is used instead and counted (`fallback_models`).

// `!(v > 0.0)` is used on purpose throughout: unlike `v <= 0.0` it is also true for NaN, so a
// single guard rejects both non-positive and NaN input.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use serde::{Deserialize, Serialize};

use crate::analysis::detectors::hampel;
use crate::analysis::special::{normal_cdf, normal_pdf};
use crate::model::arima::ArimaError;
use crate::model::arima::{
    ArimaChannelModel, ArimaModelFile, ArimaPredictor, IdentifySettings, MAX_D, MAX_P, MAX_Q,
    identify, psi_weights,
};
use crate::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use crate::stage::Stage;

/// Huber clip of the scale trackers, in units of the current scale.
const SCALE_CLIP: f64 = 2.5;
/// Largest median window of the paper's replacement option.
pub const MAX_MEDIAN_WINDOW: usize = 5;
/// Warm-up samples used to seed the predictor before it is run through the rest (p + d ≤ 4).
const RAW_KEEP: usize = MAX_P + MAX_D;
/// Horizons for which the h-step widening r_h is tabulated (longer horizons use the last).
const PSI_N: usize = 32;
/// P(|Z| > 3) for a standard normal Z.
const GAUSS_TAIL3: f64 = 0.002_699_796;
/// Tail adaptation: no widening until the tracked share beyond 3σ is this many times Gaussian.
const TAIL_DEAD_ZONE: f64 = 2.0;
/// Look-ahead: an innovation beyond this many σ on another channel within one sample of an
/// event's start makes that channel a partner in the several-axes test.
const SHOCK_K: f64 = 4.0;
/// Largest look-ahead (samples).
pub const MAX_LOOKAHEAD: usize = 1000;
/// 1/Φ⁻¹(¾): MAD → σ for Gaussian data.
const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// What replaces a gross error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Replacement {
    /// The one-step prediction x̂_t.
    Prediction,
    /// The median of the last `median_window` predictions (x̂_{t−w+1}..x̂_t), as in the paper.
    MedianOfPredictions,
}

/// Settings of [`GrossErrorStage`]. Defaults were chosen by the measured k-sweep
/// (`analysis::gate_sweep`, `examples/k_sweep.rs`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrossErrorSettings {
    /// Gate each channel gx, gy, gz, ax, ay, az (default: all).
    pub enabled: [bool; N_CHANNELS],
    /// Innovation gate k, in tracked innovation σ (default 4.5). Measured (2·10⁶ samples per
    /// scenario, `examples/k_sweep.rs`): static false alarms ≤ 1e-4 from k = 4.25 (AR noise) /
    /// 4.0 (white) on; 4.5 keeps a 2× margin (5.6e-5, 4.1e-5) while still catching 93 % of the
    /// 6–8σ spike samples on white noise (89 % at k = 5). On the harsh synthetic drives false
    /// alarms bottom out at ~1e-4 around k = 5 — there they come from false runs at manoeuvre
    /// onsets, which k hardly changes (1.5e-4 / 2.0e-4 at 4.5).
    pub k: f64,
    /// Confirmation rule: require a jump J from the local trend of the accepted samples as well
    /// (default true).
    pub confirm_jump: bool,
    /// Jump gate k_Δ, in tracked σ of the jump J (default 3.0).
    pub jump_k: f64,
    /// Innovation gate inside a run (hysteresis), in σ (default 3.5).
    pub run_k: f64,
    /// Level weight α_J of the jump reference, a fast Holt local linear trend of the accepted
    /// samples (default 0.5).
    pub jump_level_alpha: f64,
    /// Trend weight β_J of the jump reference (default 0.3).
    pub slope_alpha: f64,
    /// Longest run of successive samples replaced; the next gross one is a level change
    /// (samples; default 10).
    pub max_run: u32,
    /// Release rule: an event whose first sample was within `release_k` σ of the forecast (a
    /// borderline trigger) is released at its third sample when the second and third continue
    /// the first smoothly (each off the pre-event trend line from the first by at most `jump_k`
    /// σ_Δ) — the signature of a manoeuvre whose curvature the forecast missed, not of a gross
    /// error (default 7; 0 = off).
    pub release_k: f64,
    /// Replacement of a gross error (default: the prediction).
    pub replacement: Replacement,
    /// Window of the median-of-predictions replacement (samples; 3 or 5; default 3).
    pub median_window: usize,
    /// Time constant of the σ trackers (samples; default 200 = 1 s at 200 Hz).
    pub scale_window_samples: f64,
    /// Tail adaptation: time constant (samples) of the tracked share of accepted innovations
    /// beyond 3σ; 0 = off (default 1000). See the module docs.
    pub tail_window_samples: f64,
    /// Tail adaptation gain β: the gate widens by 1 + β ln(p₃ / (2 · 0.27 %)) (default 0.75).
    pub tail_gain: f64,
    /// Local-level weight per sample for d = 0 models (Holt's α; 0 = the fitted mean;
    /// default 0.2).
    pub level_alpha: f64,
    /// Local-slope weight per sample (Holt's β for d = 0, EWMA weight of the mean of ∇x for
    /// d = 1; 0 = the fitted constant; default 0.1).
    pub trend_beta: f64,
    /// Warm-up length for channels without a model (samples; default 2000 = 10 s at 200 Hz).
    pub warmup_samples: usize,
    /// Floor of the tracked gyro scales (rad/s; default 1e-4, below any MEMS gyro's noise at
    /// 100–1000 Hz, so quantised or stuck-quiet channels do not get a zero-width gate).
    pub min_sigma_gyro_rad_s: f64,
    /// Floor of the tracked accelerometer scales (m/s²; default 1e-3).
    pub min_sigma_accel_m_s2: f64,
    /// Gaps of at most this many missing frames are bridged, longer ones reset (frames; default 4).
    pub bridge_max_missing: u32,
    /// Look-ahead of the pipeline's output (samples; default 0 = none, the causal stage). With
    /// L > 0 each sample is emitted L samples late, and an event that proves to be motion
    /// within that time has its replaced samples restored (`flags::REVISED`): see the module
    /// docs. L = `max_run` + 1 sees every event to its end.
    pub lookahead_samples: usize,
    /// Identification at the end of warm-up (orders limited to p ≤ 3, d ≤ 1, q ≤ 2).
    pub identify: IdentifySettings,
}

impl Default for GrossErrorSettings {
    fn default() -> Self {
        GrossErrorSettings {
            enabled: [true; N_CHANNELS],
            k: 4.5,
            confirm_jump: true,
            jump_k: 3.0,
            run_k: 3.5,
            jump_level_alpha: 0.5,
            slope_alpha: 0.3,
            max_run: 10,
            release_k: 7.0,
            replacement: Replacement::Prediction,
            median_window: 3,
            scale_window_samples: 200.0,
            tail_window_samples: 1000.0,
            tail_gain: 0.75,
            level_alpha: 0.2,
            trend_beta: 0.1,
            warmup_samples: 2000,
            min_sigma_gyro_rad_s: 1e-4,
            min_sigma_accel_m_s2: 1e-3,
            bridge_max_missing: 4,
            lookahead_samples: 0,
            identify: IdentifySettings::default(),
        }
    }
}

impl GrossErrorSettings {
    /// All problems at once.
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut e = Vec::new();
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !(pos(self.k) && self.k <= 50.0) {
            e.push(format!("k = {} must be in (0, 50]", self.k));
        }
        if !(pos(self.jump_k) && self.jump_k <= 50.0) {
            e.push(format!("jump_k = {} must be in (0, 50]", self.jump_k));
        }
        if !(pos(self.run_k) && self.run_k <= 50.0) {
            e.push(format!("run_k = {} must be in (0, 50]", self.run_k));
        }
        if !(self.jump_level_alpha > 0.0 && self.jump_level_alpha <= 1.0) {
            e.push(format!(
                "jump_level_alpha = {} must be in (0, 1]",
                self.jump_level_alpha
            ));
        }
        if !(self.slope_alpha > 0.0 && self.slope_alpha <= 1.0) {
            e.push(format!(
                "slope_alpha = {} must be in (0, 1]",
                self.slope_alpha
            ));
        }
        if self.max_run == 0 {
            e.push("max_run must be ≥ 1".into());
        }
        if !(self.release_k.is_finite() && (0.0..=50.0).contains(&self.release_k)) {
            e.push(format!(
                "release_k = {} must be in [0, 50] (0 = off)",
                self.release_k
            ));
        }
        if !(self.median_window == 3 || self.median_window == 5) {
            e.push(format!(
                "median_window = {} must be 3 or 5",
                self.median_window
            ));
        }
        if !(self.scale_window_samples.is_finite() && self.scale_window_samples >= 1.0) {
            e.push(format!(
                "scale_window_samples = {} must be ≥ 1",
                self.scale_window_samples
            ));
        }
        if !(self.tail_window_samples == 0.0
            || (self.tail_window_samples.is_finite() && self.tail_window_samples >= 100.0))
        {
            e.push(format!(
                "tail_window_samples = {} must be 0 (off) or ≥ 100",
                self.tail_window_samples
            ));
        }
        if !(self.tail_gain.is_finite() && (0.0..=10.0).contains(&self.tail_gain)) {
            e.push(format!("tail_gain = {} must be in [0, 10]", self.tail_gain));
        }
        if !(0.0..=1.0).contains(&self.level_alpha) {
            e.push(format!(
                "level_alpha = {} must be in [0, 1]",
                self.level_alpha
            ));
        }
        if !(0.0..=1.0).contains(&self.trend_beta) {
            e.push(format!(
                "trend_beta = {} must be in [0, 1]",
                self.trend_beta
            ));
        }
        if !pos(self.min_sigma_gyro_rad_s) {
            e.push("min_sigma_gyro_rad_s must be > 0".into());
        }
        if !pos(self.min_sigma_accel_m_s2) {
            e.push("min_sigma_accel_m_s2 must be > 0".into());
        }
        if self.lookahead_samples > MAX_LOOKAHEAD {
            e.push(format!(
                "lookahead_samples = {} must be at most {MAX_LOOKAHEAD}",
                self.lookahead_samples
            ));
        }
        let id = &self.identify;
        if id.p_max > MAX_P || id.q_max > MAX_Q || id.d_max > MAX_D {
            e.push(format!(
                "identify orders (p_max {}, d_max {}, q_max {}) exceed the online limits ({MAX_P}, {MAX_D}, {MAX_Q})",
                id.p_max, id.d_max, id.q_max
            ));
        }
        if let Err(v) = id.validate() {
            e.extend(v.into_iter().map(|s| format!("identify: {s}")));
        }
        if self.warmup_samples < id.min_len() {
            e.push(format!(
                "warmup_samples = {} is below the {} samples identification needs",
                self.warmup_samples,
                id.min_len()
            ));
        }
        if e.is_empty() { Ok(()) } else { Err(e) }
    }
}

/// Why the stage could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GrossErrorError {
    #[error("invalid gross_error settings: {}", .0.join("; "))]
    InvalidSettings(Vec<String>),
    #[error(transparent)]
    Model(#[from] ArimaError),
}

/// Health counters of one channel.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChannelCounters {
    /// Samples replaced.
    pub replaced: u64,
    /// Runs of successive gross errors (a single spike is a run of 1).
    pub runs: u64,
    /// Runs longer than `max_run` accepted as level changes.
    pub level_changes: u64,
    /// Events released at their second sample by the release rule (borderline first sample,
    /// smooth continuation).
    pub released: u64,
    /// Non-finite values seen.
    pub non_finite: u64,
    /// Saturated samples seen.
    pub saturated: u64,
    /// Samples passed through while warming up.
    pub warmup: u64,
    /// Identifications that fell back to the white-noise model.
    pub fallback_models: u64,
    /// Events the look-ahead restored (motion, not gross errors), and their restored samples.
    pub revised_events: u64,
    pub revised: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Disabled,
    WarmingUp,
    Active,
}

/// Per-channel state. Everything but `warm` and `model` is fixed-size.
#[derive(Debug, Clone)]
struct Channel {
    mode: Mode,
    pred: Option<ArimaPredictor>,
    /// Tracked innovation variance σ² and jump variance σ_Δ².
    sig2: f64,
    jump2: f64,
    /// Floor of both variances.
    min_var: f64,
    /// Successive gross samples so far.
    run: u32,
    /// Samples since the last accepted one (1 outside runs and gaps).
    h: u32,
    /// Jump reference: Holt level ℓ_J and slope s of the accepted samples (units, per sample).
    x_acc: f64,
    slope: f64,
    /// r_h² = Σ_{i<h} ψ_i², h = 1..=PSI_N.
    r2: [f64; PSI_N],
    /// Next finite sample re-seeds the history (after a reset).
    needs_seed: bool,
    /// A saturated run outlasted max_run: saturated samples pass until saturation ends.
    sat_accepted: bool,
    /// Tracked share of accepted one-step innovations beyond 3σ (tail adaptation).
    tail3: f64,
    /// First sample of the current event and its ν²/σ² (release rule).
    first_raw: f64,
    first_ratio2: f64,
    /// Look-ahead bookkeeping of the current event: index of its first sample, σ_Δ² then, the
    /// largest squared step between successive raw samples after it, whether every sample of it
    /// was finite, unsaturated and one step after the last; the last raw sample seen.
    ev_start: u64,
    ev_jump2: f64,
    ev_max_step2: f64,
    ev_clean: bool,
    prev_raw: f64,
    /// Shift register of the last 64 samples, newest in bit 0: set where the one-step
    /// innovation exceeded `SHOCK_K` σ (a gross error included). Read by the look-ahead's
    /// several-axes test.
    big: u64,
    /// The event that ended at the current sample, if the look-ahead may revise it.
    ended: Option<EventEnd>,
    /// Last predictions, newest first, and how many are valid.
    preds: [f64; MAX_MEDIAN_WINDOW],
    n_preds: usize,
    counters: ChannelCounters,
    /// Warm-up buffer (capacity reserved at construction; emptied at the end of warm-up).
    warm: Vec<f64>,
    /// The model in use (given or identified).
    model: Option<ArimaChannelModel>,
}

/// How an event ended, for the look-ahead's revision.
#[derive(Debug, Clone, Copy, PartialEq)]
struct EventEnd {
    /// First sample of the event (stage-wide index); the event is `start..` the current one.
    start: u64,
    /// Motion already by the causal rules (a level change, or the release rule), or by the
    /// smoothness test (see the module docs).
    motion: bool,
    /// Every sample finite, unsaturated and gated one step after the last.
    clean: bool,
}

/// One sample held by the look-ahead: its index, the output so far, the raw channel values.
#[derive(Debug, Clone, Copy)]
struct Held {
    idx: u64,
    out: Sample,
    raw: [f64; N_CHANNELS],
}

/// What happened to one channel of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outcome {
    Passed,
    Replaced(f64),
    LevelChange,
    Warming,
}

/// The gross-error stage (see the module header).
#[derive(Debug, Clone)]
pub struct GrossErrorStage {
    s: GrossErrorSettings,
    ch: [Channel; N_CHANNELS],
    k2: f64,
    jump_k2: f64,
    run_k2: f64,
    release_k2: f64,
    /// 1/tail_window_samples (0 = tail adaptation off).
    tail_w: f64,
    /// Weight of the scale trackers, 1/scale_window_samples.
    scale_w: f64,
    /// 1/β(c), β(c) the Huber consistency factor.
    inv_beta: f64,
    last_seq: Option<u32>,
    gaps_bridged: u64,
    gaps_reset: u64,
    /// Index of the sample being processed (counts every sample).
    n_in: u64,
    /// Samples held by the look-ahead, oldest first (capacity reserved at construction).
    held: std::collections::VecDeque<Held>,
}

/// `E[min(Z², c²)]` for Z ~ N(0, 1).
fn huber_beta(c: f64) -> f64 {
    let p_in = 2.0 * normal_cdf(c) - 1.0;
    p_in - 2.0 * c * normal_pdf(c) + c * c * (1.0 - p_in)
}

/// Var(x_t − x_{t−1}) implied by a model: the ψ-weights of the ARMA part give γ₀, γ₁ of w; for
/// d = 1 the increment is w itself (γ₀), for d = 0 it is 2(γ₀ − γ₁).
fn model_increment_var(m: &ArimaChannelModel) -> f64 {
    let mut psi_hist = [0.0f64; MAX_P]; // ψ_{j−1}, ψ_{j−2}, ψ_{j−3}
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

/// One Holt step of the jump reference: forecast m = ℓ + b, then ℓ ← m + α (x − m),
/// b ← b + β (ℓ_new − ℓ − b).
#[inline]
fn holt_step(level: f64, slope: f64, x: f64, alpha: f64, beta: f64) -> (f64, f64) {
    let m = level + slope;
    let l_new = m + alpha * (x - m);
    (l_new, slope + beta * (l_new - level - slope))
}

/// Median of `v` (small, copied).
fn median_small(v: &[f64]) -> f64 {
    let mut a = [0.0f64; MAX_MEDIAN_WINDOW];
    let n = v.len().min(MAX_MEDIAN_WINDOW);
    a[..n].copy_from_slice(&v[..n]);
    // Insertion sort: n ≤ 5.
    for i in 1..n {
        let mut j = i;
        while j > 0 && a[j - 1] > a[j] {
            a.swap(j - 1, j);
            j -= 1;
        }
    }
    if n % 2 == 1 {
        a[n / 2]
    } else {
        0.5 * (a[n / 2 - 1] + a[n / 2])
    }
}

/// Median and MAD-based σ of a slice (allocates; warm-up only).
fn median_and_robust_sigma(v: &[f64]) -> (f64, f64) {
    let mut a: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if a.is_empty() {
        return (0.0, 0.0);
    }
    a.sort_by(f64::total_cmp);
    let med = a[a.len() / 2];
    let mut dev: Vec<f64> = a.iter().map(|x| (x - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    (med, MAD_TO_SIGMA * dev[dev.len() / 2])
}

impl GrossErrorStage {
    /// Build the stage. Channels with a model in `models` (matched by name) start active; the
    /// other enabled channels warm up and identify their own model.
    pub fn new(
        settings: GrossErrorSettings,
        models: Option<&ArimaModelFile>,
    ) -> Result<Self, GrossErrorError> {
        settings
            .validate()
            .map_err(GrossErrorError::InvalidSettings)?;
        let sw = settings.scale_window_samples;
        let settings_lookahead = settings.lookahead_samples;
        let ch = std::array::from_fn(|c| {
            let min_sigma = if c < 3 {
                settings.min_sigma_gyro_rad_s
            } else {
                settings.min_sigma_accel_m_s2
            };
            Channel {
                mode: if settings.enabled[c] {
                    Mode::WarmingUp
                } else {
                    Mode::Disabled
                },
                pred: None,
                sig2: min_sigma * min_sigma,
                jump2: min_sigma * min_sigma,
                min_var: min_sigma * min_sigma,
                run: 0,
                h: 1,
                x_acc: 0.0,
                slope: 0.0,
                r2: [1.0; PSI_N],
                needs_seed: true,
                sat_accepted: false,
                tail3: GAUSS_TAIL3,
                first_raw: 0.0,
                first_ratio2: f64::INFINITY,
                ev_start: 0,
                ev_jump2: 0.0,
                ev_max_step2: 0.0,
                ev_clean: false,
                prev_raw: f64::NAN,
                big: 0,
                ended: None,
                preds: [0.0; MAX_MEDIAN_WINDOW],
                n_preds: 0,
                counters: ChannelCounters::default(),
                warm: Vec::new(),
                model: None,
            }
        });
        let mut st = GrossErrorStage {
            k2: settings.k * settings.k,
            jump_k2: settings.jump_k * settings.jump_k,
            run_k2: settings.run_k * settings.run_k,
            release_k2: settings.release_k * settings.release_k,
            tail_w: if settings.tail_window_samples > 0.0 {
                1.0 / settings.tail_window_samples
            } else {
                0.0
            },
            scale_w: 1.0 / sw,
            inv_beta: 1.0 / huber_beta(SCALE_CLIP),
            s: settings,
            ch,
            last_seq: None,
            gaps_bridged: 0,
            gaps_reset: 0,
            n_in: 0,
            held: std::collections::VecDeque::with_capacity(settings_lookahead + 1),
        };
        for (c, name) in CHANNEL_NAMES.iter().enumerate() {
            if st.ch[c].mode == Mode::Disabled {
                continue;
            }
            match models.and_then(|m| m.channel(name)) {
                Some(m) => st.activate(c, m.clone(), None)?,
                None => st.ch[c].warm.reserve_exact(st.s.warmup_samples),
            }
        }
        Ok(st)
    }

    /// The settings in use.
    pub fn settings(&self) -> &GrossErrorSettings {
        &self.s
    }

    /// Models in use (given or identified so far), for writing a model file.
    pub fn models(&self) -> ArimaModelFile {
        ArimaModelFile {
            channels: self.ch.iter().filter_map(|c| c.model.clone()).collect(),
        }
    }

    /// Counters of channel `c`.
    pub fn channel_counters(&self, c: usize) -> ChannelCounters {
        self.ch[c].counters
    }

    /// Tracked innovation σ of channel `c` (None unless active).
    pub fn sigma(&self, c: usize) -> Option<f64> {
        (self.ch[c].mode == Mode::Active).then(|| self.ch[c].sig2.sqrt())
    }

    /// Tracked jump σ_Δ of channel `c` (None unless active).
    pub fn jump_sigma(&self, c: usize) -> Option<f64> {
        (self.ch[c].mode == Mode::Active).then(|| self.ch[c].jump2.sqrt())
    }

    /// Switch channel `c` to `model`; with `warm` (the warm-up samples, oldest first) the
    /// predictor is run through them to set its history and the initial scales robustly.
    fn activate(
        &mut self,
        c: usize,
        model: ArimaChannelModel,
        warm: Option<&[f64]>,
    ) -> Result<(), GrossErrorError> {
        let mut pred = ArimaPredictor::new(&model, self.s.level_alpha, self.s.trend_beta)?;
        let slope_alpha = self.s.slope_alpha;
        let ja = self.s.jump_level_alpha;
        let ch = &mut self.ch[c];
        // h-step widening from the model's ψ-weights.
        let mut psi = [0.0; PSI_N];
        psi_weights(&model, &mut psi);
        let mut acc = 0.0;
        for (r, p) in ch.r2.iter_mut().zip(&psi) {
            acc += p * p;
            *r = acc;
        }
        match warm {
            Some(w) if w.len() > RAW_KEEP + 1 => {
                let seed: Vec<f64> = w[..RAW_KEEP].iter().rev().copied().collect();
                pred.reseed(&seed);
                let mut innov = Vec::with_capacity(w.len());
                let mut jumps = Vec::with_capacity(w.len());
                let mut level = w[RAW_KEEP - 1];
                let mut slope = 0.0;
                for &v in &w[RAW_KEEP..] {
                    let e = v - pred.predict();
                    jumps.push(v - level - slope);
                    innov.push(e);
                    pred.update(v, e);
                    (level, slope) = holt_step(level, slope, v, ja, slope_alpha);
                }
                let x_acc = level;
                // Initial scales from the most recent part of the window (one tracker window,
                // at least 50 samples): conditions may have changed during the warm-up (a
                // vehicle at rest that starts driving), and the gate must start from the
                // variability of now, not of the window's average.
                let recent = (self.s.scale_window_samples.round() as usize)
                    .max(50)
                    .min(innov.len());
                let (_, s_e) = median_and_robust_sigma(&innov[innov.len() - recent..]);
                let (_, s_d) = median_and_robust_sigma(&jumps[jumps.len() - recent..]);
                ch.sig2 = (s_e * s_e).max(ch.min_var);
                ch.jump2 = (s_d * s_d).max(ch.min_var);
                ch.x_acc = x_acc;
                ch.slope = slope;
                ch.needs_seed = false;
            }
            _ => {
                ch.sig2 = (model.sigma * model.sigma).max(ch.min_var);
                ch.jump2 = model_increment_var(&model).max(ch.min_var);
                ch.needs_seed = true;
            }
        }
        ch.pred = Some(pred);
        ch.model = Some(model);
        ch.mode = Mode::Active;
        ch.run = 0;
        ch.h = 1;
        ch.warm = Vec::new();
        Ok(())
    }

    /// End of warm-up for channel `c`: clean, identify (allocates, once), activate.
    fn finish_warmup(&mut self, c: usize) {
        let raw = std::mem::take(&mut self.ch[c].warm);
        // Hampel (half-width 10, k = 4): strips spikes and runs ≤ 10 before identification.
        let cleaned = hampel(&raw, 10, 4.0)
            .map(|r| r.corrected)
            .unwrap_or_else(|_| raw.clone());
        let name = CHANNEL_NAMES[c];
        let model = match identify(&cleaned, &self.s.identify) {
            Ok(id) => id.to_channel_model(name),
            Err(_) => {
                self.ch[c].counters.fallback_models += 1;
                let (med, sd) = median_and_robust_sigma(&cleaned);
                ArimaChannelModel {
                    channel: name.to_string(),
                    p: 0,
                    d: 0,
                    q: 0,
                    constant: med,
                    ar: vec![],
                    ma: vec![],
                    sigma: sd.max(self.ch[c].min_var.sqrt()),
                    diagnostics: None,
                }
            }
        };
        if self.activate(c, model.clone(), Some(&cleaned)).is_err() {
            // An identified model that the predictor rejects cannot happen with validated
            // settings (orders are bounded, fits are kept admissible); fall back regardless.
            self.ch[c].counters.fallback_models += 1;
            let (med, sd) = median_and_robust_sigma(&cleaned);
            let fallback = ArimaChannelModel {
                p: 0,
                d: 0,
                q: 0,
                constant: med,
                ar: vec![],
                ma: vec![],
                sigma: sd.max(self.ch[c].min_var.sqrt()),
                diagnostics: None,
                ..model
            };
            // A white-noise model with a positive σ always validates.
            let _ = self.activate(c, fallback, Some(&cleaned));
        }
    }

    /// Gate one active channel value. Per sample: no allocation.
    #[inline]
    fn gate(&mut self, c: usize, v: f64, saturated: bool) -> Outcome {
        let tail_w = self.tail_w;
        let k2 = {
            let r = self.ch[c].tail3 / (GAUSS_TAIL3 * TAIL_DEAD_ZONE);
            if tail_w > 0.0 && r > 1.0 {
                let f = 1.0 + self.s.tail_gain * r.ln();
                self.k2 * f * f
            } else {
                self.k2
            }
        };
        let run_k2 = self.run_k2;
        let base_k2 = self.k2;
        let shock_k2 = SHOCK_K * SHOCK_K;
        let release_k2 = self.release_k2;
        let jk2 = self.jump_k2;
        let w = self.scale_w;
        let inv_beta = self.inv_beta;
        let keep_preds = self.s.replacement == Replacement::MedianOfPredictions;
        let confirm = self.s.confirm_jump;
        let max_run = self.s.max_run;
        let slope_alpha = self.s.slope_alpha;
        let ja = self.s.jump_level_alpha;
        let idx = self.n_in;
        let ch = &mut self.ch[c];
        let Some(pred) = ch.pred.as_mut() else {
            return Outcome::Passed;
        };
        let finite = v.is_finite();
        if !saturated {
            ch.sat_accepted = false;
        } else if ch.sat_accepted && finite {
            // Saturation has lasted beyond max_run: a real motion beyond the sensor's range, not
            // a gross error. Pass the (clipped) values on until it ends, instead of cycling
            // through max_run replacements and a level change again and again.
            pred.restart(v, 0.0);
            ch.x_acc = v;
            ch.slope = 0.0;
            return Outcome::Passed;
        }
        if ch.needs_seed && finite && !saturated {
            // First good sample after a reset (or with a given model): it seeds the history.
            pred.reseed(&[v]);
            ch.needs_seed = false;
            ch.n_preds = 0;
            ch.run = 0;
            ch.h = 1;
            ch.x_acc = v;
            ch.slope = 0.0;
            return Outcome::Passed;
        }
        let xh = pred.predict();
        if keep_preds {
            for i in (1..MAX_MEDIAN_WINDOW).rev() {
                ch.preds[i] = ch.preds[i - 1];
            }
            ch.preds[0] = xh;
            ch.n_preds = (ch.n_preds + 1).min(MAX_MEDIAN_WINDOW);
        }
        let h = ch.h.max(1);
        // h > 1 outside a run only after a bridged gap: widen by the h-step forecast sd.
        let r2 = ch.r2[(h as usize).min(PSI_N) - 1];
        let nu = v - xh;
        if finite && !saturated && nu * nu > shock_k2 * ch.sig2 {
            ch.big |= 1;
        }
        let jump = v - ch.x_acc - h as f64 * ch.slope;
        let in_run = ch.run > 0;
        let strict = nu * nu > k2 * r2 * ch.sig2;
        let gross = if !finite || saturated {
            true
        } else if ch.run >= max_run {
            // The run is at its limit: only a sample that fails the full gate makes it longer
            // (and is then taken as a level change below); hysteresis would turn a drifting
            // forecast into a spurious level change.
            strict
        } else if in_run {
            // Inside a run the event has already shown its discontinuity: it goes on while the
            // sample stays off the forecast by run_k σ (hysteresis). The gate is deliberately not
            // widened by r_h here: the h-step forecast does drift, but measured on the synthetic
            // drives, widening lets weak members of a run into the history, and a d = 1 model
            // then extrapolates from them — far costlier than replacing a few more samples.
            nu * nu > run_k2 * ch.sig2
        } else {
            strict && (!confirm || jump * jump > jk2 * ch.jump2)
        };
        if !gross {
            pred.update(v, nu);
            if h == 1 {
                // Winsorised scale updates, one-step samples only.
                let cap = SCALE_CLIP * SCALE_CLIP;
                if tail_w > 0.0 {
                    let beyond = if nu * nu > 9.0 * ch.sig2 { 1.0 } else { 0.0 };
                    ch.tail3 += tail_w * (beyond - ch.tail3);
                }
                ch.sig2 += w * ((nu * nu).min(cap * ch.sig2) * inv_beta - ch.sig2);
                ch.jump2 += w * ((jump * jump).min(cap * ch.jump2) * inv_beta - ch.jump2);
                ch.sig2 = ch.sig2.max(ch.min_var);
                ch.jump2 = ch.jump2.max(ch.min_var);
            }
            if ch.run > 0 {
                // The event ends here. Smooth (motion) if the return to the signal is no jump
                // (≤ jump_k σ_Δ) and no step inside the event was one the gate would call gross
                // (≤ k σ_Δ): a gross error has to jump back, a knock the vehicle felt need not.
                let d = v - ch.prev_raw;
                ch.ended = Some(EventEnd {
                    start: ch.ev_start,
                    motion: d * d <= jk2 * ch.ev_jump2 && ch.ev_max_step2 <= base_k2 * ch.ev_jump2,
                    clean: ch.ev_clean,
                });
            }
            if h == 1 {
                (ch.x_acc, ch.slope) = holt_step(ch.x_acc, ch.slope, v, ja, slope_alpha);
            } else {
                // After a run or a bridged gap: re-anchor the level, update the slope with the
                // mean increment over the h steps.
                ch.slope += slope_alpha * ((v - ch.x_acc) / h as f64 - ch.slope);
                ch.x_acc = v;
            }
            ch.h = 1;
            ch.run = 0;
            return Outcome::Passed;
        }
        if gross && finite && !saturated && ch.run >= 1 && ch.first_ratio2 < release_k2 {
            // Release rule: the event's first sample was borderline; does this one continue it
            // smoothly from the pre-event trend (x_1 + (run)·slope)? Two such continuations in a
            // row — the signature of a manoeuvre the forecast lagged, which a spike run of
            // independent amplitudes almost never shows — release the event.
            let d = v - (ch.first_raw + ch.run as f64 * ch.slope);
            if d * d > jk2 * ch.jump2 {
                ch.first_ratio2 = f64::INFINITY; // not a smooth continuation: a gross event
            } else if ch.run >= 2 {
                // Accept this sample (the earlier replacements are already out); restart the
                // predictor here with the mean increment since the event began as the slope.
                ch.slope += slope_alpha * ((v - ch.first_raw) / ch.run as f64 - ch.slope);
                ch.x_acc = v;
                pred.restart(v, ch.slope);
                ch.h = 1;
                ch.run = 0;
                ch.n_preds = 0;
                ch.counters.released += 1;
                ch.ended = Some(EventEnd {
                    start: ch.ev_start,
                    motion: true,
                    clean: ch.ev_clean,
                });
                return Outcome::Passed;
            }
        }
        if finite && ch.run >= max_run {
            // Too long to be a gross error: accept the new level. The predictor restarts at
            // this value with the slope seen before the run (the run's earlier raw samples may
            // be a different event, so they are not trusted as history).
            pred.restart(v, ch.slope);
            ch.x_acc = v;
            ch.h = 1;
            ch.run = 0;
            ch.n_preds = 0;
            ch.sat_accepted = saturated;
            ch.counters.level_changes += 1;
            ch.ended = Some(EventEnd {
                start: ch.ev_start,
                motion: true,
                clean: ch.ev_clean && !saturated,
            });
            return Outcome::LevelChange;
        }
        let r = match self.s.replacement {
            Replacement::Prediction => xh,
            // n_preds ≥ 1 here (this call pushed x̂); the guard only protects the invariant.
            Replacement::MedianOfPredictions if ch.n_preds > 0 => {
                median_small(&ch.preds[..ch.n_preds.min(self.s.median_window)])
            }
            Replacement::MedianOfPredictions => xh,
        };
        pred.update(r, r - xh);
        let clean = finite && !saturated;
        if ch.run == 0 {
            ch.counters.runs += 1;
            ch.first_raw = v;
            ch.first_ratio2 = if clean {
                nu * nu / (r2 * ch.sig2)
            } else {
                f64::INFINITY
            };
            ch.ev_start = idx;
            ch.ev_jump2 = ch.jump2;
            ch.ev_max_step2 = 0.0;
            ch.ev_clean = clean && h == 1;
        } else if clean {
            let d = v - ch.prev_raw;
            ch.ev_max_step2 = ch.ev_max_step2.max(d * d);
        } else {
            ch.ev_clean = false;
        }
        ch.run = ch.run.saturating_add(1);
        ch.h = ch.h.saturating_add(1);
        ch.counters.replaced += 1;
        Outcome::Replaced(r)
    }

    /// Gate every enabled channel of one sample (the causal stage; `n_in` is its index).
    fn step(&mut self, mut s: Sample) -> Sample {
        if s.has(flags::GAP) {
            self.on_gap(s.seq);
        }
        self.last_seq = Some(s.seq);
        let mut warming = false;
        for c in 0..N_CHANNELS {
            let mode = self.ch[c].mode;
            if mode == Mode::Disabled {
                continue;
            }
            self.ch[c].ended = None;
            self.ch[c].big <<= 1;
            let v = s.channel(c);
            let saturated = s.flags & flags::sat_ch(c) != 0;
            if !v.is_finite() {
                s.flags |= flags::NON_FINITE;
                self.ch[c].counters.non_finite += 1;
            }
            if saturated {
                self.ch[c].counters.saturated += 1;
            }
            let outcome = if mode == Mode::WarmingUp {
                let ch = &mut self.ch[c];
                ch.counters.warmup += 1;
                if v.is_finite() && !saturated {
                    ch.warm.push(v); // within the reserved capacity: no allocation
                }
                if ch.warm.len() >= self.s.warmup_samples {
                    self.finish_warmup(c);
                }
                Outcome::Warming
            } else {
                self.gate(c, v, saturated)
            };
            match outcome {
                Outcome::Passed => {}
                Outcome::Warming => warming = true,
                Outcome::Replaced(r) => {
                    s.set_channel(c, r);
                    s.flags |= flags::REPLACED | flags::replaced_ch(c);
                }
                Outcome::LevelChange => s.flags |= flags::LEVEL_CHANGE,
            }
            self.ch[c].prev_raw = v;
        }
        if warming {
            s.flags |= flags::WARMING_UP;
        }
        s
    }

    /// Look-ahead: restore the held samples of every event that ended at the current sample
    /// and proved to be motion — a level change or a release (the causal rules' own verdict), a
    /// smooth event, or part of a shock seen on several axes: at least two other channels had an
    /// innovation beyond `SHOCK_K` σ within one sample of the event's start. The last is not
    /// applied to a one-sample event whose partners were off on that same sample only, which is
    /// what a corrupted whole frame looks like. Events with a non-finite, saturated or
    /// gap-bridged sample are never revised.
    fn revise(&mut self) {
        let now = self.n_in;
        for c in 0..N_CHANNELS {
            let Some(end) = self.ch[c].ended.take() else {
                continue;
            };
            if !end.clean {
                continue;
            }
            // Several axes: bits start+1, start, start−1 of the other channels' registers are
            // at positions now−start−1 … now−start+1 (bit 0 = now).
            let back = now - end.start;
            let revise = end.motion
                || (back < 63 && {
                    let mut partners = 0;
                    let mut all_same = true;
                    for (o, other) in self.ch.iter().enumerate() {
                        let m = (other.big >> (back - 1)) & 0b111;
                        if o != c && m != 0 {
                            partners += 1;
                            all_same &= m == 0b010;
                        }
                    }
                    partners >= 2 && !(back == 1 && all_same)
                });
            if !revise {
                continue;
            }
            let bit = flags::replaced_ch(c);
            let mut restored = 0;
            for h in self.held.iter_mut().rev() {
                if h.idx < end.start {
                    break;
                }
                if h.out.flags & bit != 0 {
                    h.out.set_channel(c, h.raw[c]);
                    h.out.flags = (h.out.flags & !bit) | flags::REVISED;
                    if h.out.flags & flags::REPLACED_ANY == 0 {
                        h.out.flags &= !flags::REPLACED;
                    }
                    restored += 1;
                }
            }
            if restored > 0 {
                let k = &mut self.ch[c].counters;
                k.revised_events += 1;
                k.revised += restored;
            }
        }
    }

    /// Handle `flags::GAP`: bridge or reset (see the module header).
    fn on_gap(&mut self, seq: u32) {
        let missing = self
            .last_seq
            .map(|last| seq.wrapping_sub(last).wrapping_sub(1));
        match missing {
            Some(m) if m <= self.s.bridge_max_missing => {
                self.gaps_bridged += 1;
                for ch in self.ch.iter_mut() {
                    if ch.run > 0 {
                        ch.ev_clean = false; // an event across a gap is not revised
                    }
                    if let Some(p) = ch.pred.as_mut() {
                        for _ in 0..m {
                            let xh = p.predict();
                            p.update(xh, 0.0);
                        }
                        ch.h = ch.h.saturating_add(m);
                    }
                }
            }
            _ => {
                self.gaps_reset += 1;
                for ch in self.ch.iter_mut() {
                    if ch.mode == Mode::Active {
                        ch.needs_seed = true;
                    }
                }
            }
        }
    }
}

impl Stage for GrossErrorStage {
    fn name(&self) -> &'static str {
        "gross_error"
    }

    fn process(&mut self, s: Sample) -> Sample {
        let out = self.step(s);
        self.n_in += 1;
        out
    }

    fn push(&mut self, s: Sample, out: &mut Vec<Sample>) {
        let lookahead = self.s.lookahead_samples;
        if lookahead == 0 {
            out.push(self.process(s));
            return;
        }
        let raw = s.channels();
        let o = self.step(s);
        self.revise();
        self.held.push_back(Held {
            idx: self.n_in,
            out: o,
            raw,
        });
        self.n_in += 1;
        if self.held.len() > lookahead
            && let Some(h) = self.held.pop_front()
        {
            out.push(h.out);
        }
    }

    fn flush(&mut self, out: &mut Vec<Sample>) {
        out.extend(self.held.drain(..).map(|h| h.out));
    }

    fn lookahead(&self) -> usize {
        self.s.lookahead_samples
    }

    fn counters(&self) -> Vec<(String, u64)> {
        let mut out = vec![
            ("gaps_bridged".to_string(), self.gaps_bridged),
            ("gaps_reset".to_string(), self.gaps_reset),
        ];
        for (c, ch) in self.ch.iter().enumerate() {
            if ch.mode == Mode::Disabled {
                continue;
            }
            let n = CHANNEL_NAMES[c];
            let k = &ch.counters;
            for (name, v) in [
                ("replaced", k.replaced),
                ("runs", k.runs),
                ("level_changes", k.level_changes),
                ("released", k.released),
                ("non_finite", k.non_finite),
                ("saturated", k.saturated),
                ("warmup", k.warmup),
                ("fallback_models", k.fallback_models),
                ("revised_events", k.revised_events),
                ("revised", k.revised),
            ] {
                out.push((format!("{n}.{name}"), v));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(p: Vec<f64>, d: usize, q: Vec<f64>) -> ArimaChannelModel {
        ArimaChannelModel {
            channel: "gz".into(),
            p: p.len(),
            d,
            q: q.len(),
            constant: 0.0,
            ar: p,
            ma: q,
            sigma: 2.0,
            diagnostics: None,
        }
    }

    #[test]
    fn increment_variance_matches_closed_forms() {
        // AR(1): γ0 = σ²/(1−φ²), γ1 = φγ0 ⇒ Var(Δx) = 2σ²/(1+φ). MA(1): Var(Δx) = 2σ²(1+θ²−θ).
        // d = 1 random walk: Var(Δx) = σ². ψ-sums converge to 1e-12 here.
        let v = model_increment_var(&model(vec![0.6], 0, vec![]));
        assert!((v - 2.0 * 4.0 / 1.6).abs() < 1e-9, "{v}");
        let v = model_increment_var(&model(vec![], 0, vec![0.4]));
        assert!((v - 2.0 * 4.0 * (1.0 + 0.16 - 0.4)).abs() < 1e-9, "{v}");
        let v = model_increment_var(&model(vec![], 1, vec![]));
        assert!((v - 4.0).abs() < 1e-12, "{v}");
    }

    #[test]
    fn huber_consistency_factor_is_the_clipped_second_moment() {
        // c → ∞ gives E[Z²] = 1; c = 0 gives 0; c = 2.5: scipy's quadrature of min(z², 6.25)φ(z)
        // (tests/reference/special.py) to ~1e-14, our closed form to Φ's ~1e-15: 1e-12.
        assert!((huber_beta(40.0) - 1.0).abs() < 1e-14);
        assert!(huber_beta(0.0).abs() < 1e-15);
        assert!(
            (huber_beta(2.5) - 0.9775599834528068).abs() < 1e-12,
            "{}",
            huber_beta(2.5)
        );
    }

    #[test]
    fn median_of_small_windows() {
        assert_eq!(median_small(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median_small(&[5.0, -1.0, 4.0, 0.0, 2.0]), 2.0);
        assert_eq!(median_small(&[1.0, 3.0]), 2.0);
    }
}
