//! Settings of the gross-error stage (`[gross_error.settings]`), with units and defaults; the
//! one place they are validated.

// `!(v > 0.0)` is used on purpose: unlike `v <= 0.0` it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use serde::{Deserialize, Serialize};

use crate::model::arima::{IdentifySettings, MAX_D, MAX_P, MAX_Q};
use crate::sample::N_CHANNELS;
use crate::settings::SettingsErrors;

/// Largest median window of the paper's replacement option.
pub const MAX_MEDIAN_WINDOW: usize = 5;
/// Largest look-ahead (samples).
pub const MAX_LOOKAHEAD: usize = 1000;
/// Largest pre-event context of the confirmation test (samples).
pub const MAX_CONTEXT: usize = 64;
/// Largest post-event context of the confirmation test (samples).
pub const MAX_POST: usize = 16;

/// What replaces a confirmed gross error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Replacement {
    /// The two-sided interpolation through the samples around the event (needs the
    /// look-ahead; without one, the prediction).
    Interpolation,
    /// The one-step prediction x̂_t.
    Prediction,
    /// The median of the last `median_window` predictions (x̂_{t−w+1}..x̂_t), as in the paper.
    #[serde(alias = "median")]
    MedianOfPredictions,
}

/// Settings of the gross-error stage. Units in names or in the comment of each field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrossErrorSettings {
    /// Gate each channel gx, gy, gz, ax, ay, az (default: all).
    pub enabled: [bool; N_CHANNELS],
    /// Innovation gate k, in tracked innovation σ (default 4.5): what makes a sample a
    /// *candidate*; the confirmation test decides whether it is replaced.
    pub k: f64,
    /// Require a jump J from the local trend of the accepted samples as well (default true).
    pub confirm_jump: bool,
    /// Jump gate k_Δ, in tracked σ of the jump J (default 3.0).
    pub jump_k: f64,
    /// Innovation gate inside a run (hysteresis), in σ (default 3.5).
    pub run_k: f64,
    /// Level weight α_J of the jump reference (Holt, per sample; default 0.5).
    pub jump_level_alpha: f64,
    /// Trend weight β_J of the jump reference (default 0.3).
    pub slope_alpha: f64,
    /// Longest run of successive candidates; the next one is a level change (samples; 10).
    pub max_run: u32,
    /// Release rule: an event whose first sample was within `release_k` σ of the forecast and
    /// that continues smoothly is released at its third sample (σ; default 7; 0 = off).
    pub release_k: f64,
    /// Replacement of a confirmed gross error (default: the two-sided interpolation).
    pub replacement: Replacement,
    /// Window of the median-of-predictions replacement (samples; 3 or 5; default 3).
    pub median_window: usize,
    /// Time constant of the σ trackers (samples; default 200).
    pub scale_window_samples: f64,
    /// Tail adaptation: time constant of the tracked share of accepted innovations beyond 3σ
    /// (samples; default 1000; 0 = off).
    pub tail_window_samples: f64,
    /// Tail adaptation gain β: the gate widens by 1 + β ln(p₃ / (2 · 0.27 %)) (default 0.75).
    pub tail_gain: f64,
    /// Local-level weight per sample for d = 0 models (Holt's α; default 0.2).
    pub level_alpha: f64,
    /// Local-slope weight per sample (default 0.1).
    pub trend_beta: f64,
    /// Warm-up length for channels without a model (samples; default 2000).
    pub warmup_samples: usize,
    /// The warm-up also ends once its samples span this long, from their own time stamps, if it
    /// has the identification's minimum by then (s; default 30: 2000 samples at ≥ 66.7 Hz end
    /// first, so nothing changes at ≥ 100 Hz; a 25-Hz sensor identifies on 750). Raise it with
    /// `warmup_samples`: it bounds a larger count too.
    pub warmup_max_s: f64,
    /// The model is identified off the sample path, on a worker thread, while the warm-up goes
    /// on for this long after its window closed (s of the channel's own time stamps, counted as
    /// the warm-up's; at most `warmup_samples` more samples; default 0.5), channel c c samples
    /// later (one take-over per call). It activates at that sample whatever the worker's speed
    /// (a slower worker is waited for), so the output does not depend on the machine. 0 = identify on the sample that closes the window (one call
    /// then takes the whole identification: about 80 ms for six channels, `cargo bench --bench
    /// latency`). With 0 the searches for a vibration line (`line.rs`) run inline too, instead
    /// of on the stage's line-search thread.
    pub identify_defer_s: f64,
    /// Floor of the tracked gyro scales (rad/s; default 1e-4).
    pub min_sigma_gyro_rad_s: f64,
    /// Floor of the tracked accelerometer scales (m/s²; default 1e-3).
    pub min_sigma_accel_m_s2: f64,
    /// Gaps of at most this many missing frames are bridged, longer ones reset (frames; 4).
    pub bridge_max_missing: u32,
    /// Longest time an event may hold the output while its evidence comes in (samples; default
    /// 16 = `max_run` + `post_samples` + 2, so every event the gate can produce is judged).
    /// Samples are held only while an event is open: outside events the output has no lag.
    /// 0 = causal: nothing is held and nothing is replaced on the gate's word alone (candidates
    /// pass flagged suspect; only non-finite and implausible values are replaced).
    pub lookahead_samples: usize,
    /// Confirmation: an event is a gross error when its samples lie more than `confirm_k`
    /// white-noise-equivalent σ off the interpolation through the samples around it, σ from the
    /// roughness of those samples (default 6).
    pub confirm_k: f64,
    /// Confirmation: the breaks into and out of the event (second differences at its edges), in
    /// σ of a second difference, must both reach `edge_k` (default 2.5): a smooth excursion the
    /// forecast missed enters and leaves without a break.
    pub edge_k: f64,
    /// Confirmation: the event must also stand out from the sharpest ordinary sample around it
    /// by this factor (default 2; see `confirm.rs`).
    pub stand_out: f64,
    /// Confirmation: the breaks into and out of the event must stand out from the sharpest
    /// ordinary sample around it by this factor, both measured as a spike's height (default 4;
    /// see `confirm.rs`: an edge's second difference has 2× the sd of a centred one, so 4 here
    /// is what `stand_out = 2` has always meant for the edges; 2 would be the same bar as the
    /// interpolation's, and is measured as a trade-off in `docs/gross_error_results.md`).
    pub edge_stand_out: f64,
    /// Confirmation at rest: an event that fails the shape tests above is still a gross error
    /// when the channel is at rest around it and every other channel is at rest and undisturbed
    /// (`rest::at_rest`), and its samples lie a median of at least `rest_k` spreads off the
    /// channel's resting level (default 6, as `confirm_k`; 0 = off). At rest the level is
    /// known, so a spike is `A` spreads off it where the interpolation sees `A/√1.5` σ̂.
    pub rest_k: f64,
    /// "At rest": the context's spread about its median at most `rest_ratio` times its
    /// white-noise-equivalent roughness (default 1.5: equal for white noise, 1.16 for the
    /// ADIS16405's lag-1 correlation of 0.2; a trend or a slow manoeuvre inflates the spread).
    pub rest_ratio: f64,
    /// Confirmation: the interpolation across an event of m samples uses the nearest
    /// `clamp(m, 3, run_fit_side)` samples on each side (default 3: three for every event;
    /// at most 10; see `confirm.rs`).
    pub run_fit_side: usize,
    /// Samples before an event whose roughness sets the confirmation scale (default 32: the
    /// scale's own sampling error is then ~12 %, small enough not to make 4σ noise look 6σ).
    pub context_samples: usize,
    /// Samples after an event the confirmation waits for (default 4).
    pub post_samples: usize,
    /// Level test, opt-in (s; default 0 = off): the time before an event over which the
    /// channel's own level is read, from the stream's own time stamps. An event judged on fewer
    /// samples than the smoothness test needs (`confirm::SMOOTH_MIN`, 4) is then confirmed only
    /// if its samples lie at least `level_k` robust σ of those values from their median: a value
    /// the signal itself held within that time is taken as no evidence of a gross error. Off by
    /// default: measured in `docs/real-data.md` ("Sensor classes we do not have"), it spares
    /// real motion on lower-rate copies but also spikes on smooth synthetic manoeuvres.
    pub level_window_s: f64,
    /// Level test: least distance of a short event from the recent level, in robust σ of the
    /// level over `level_window_s` (default 4; used only when the test is on).
    pub level_k: f64,
    /// |gyro| beyond this is no measurement of any MEMS gyro: treated as a bad value, flagged
    /// saturated and replaced (rad/s; default 60 ≈ 3400 °/s).
    pub plausible_gyro_rad_s: f64,
    /// |accel| beyond this is treated as a bad value (m/s²; default 4000 ≈ 400 g).
    pub plausible_accel_m_s2: f64,
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
            replacement: Replacement::Interpolation,
            median_window: 3,
            scale_window_samples: 200.0,
            tail_window_samples: 1000.0,
            tail_gain: 0.75,
            level_alpha: 0.2,
            trend_beta: 0.1,
            warmup_samples: 2000,
            warmup_max_s: 30.0,
            identify_defer_s: 0.5,
            min_sigma_gyro_rad_s: 1e-4,
            min_sigma_accel_m_s2: 1e-3,
            bridge_max_missing: 4,
            lookahead_samples: 16,
            confirm_k: 6.0,
            edge_k: 2.5,
            stand_out: 2.0,
            edge_stand_out: 4.0,
            rest_k: 6.0,
            rest_ratio: 1.5,
            run_fit_side: 3,
            context_samples: 32,
            post_samples: 4,
            level_window_s: 0.0,
            level_k: 4.0,
            plausible_gyro_rad_s: 60.0,
            plausible_accel_m_s2: 4000.0,
            identify: IdentifySettings::default(),
        }
    }
}

crate::valid_settings!(
    /// Gross-error settings that passed [`GrossErrorSettings::validate`]: the only form
    /// [`super::GrossErrorStage`] is built from.
    ValidGrossErrorSettings,
    GrossErrorSettings
);

impl GrossErrorSettings {
    /// The confirmation's bars (the settings of the same names).
    pub fn thresholds(&self) -> super::confirm::Thresholds {
        super::confirm::Thresholds {
            confirm_k: self.confirm_k,
            edge_k: self.edge_k,
            stand_out: self.stand_out,
            edge_stand_out: self.edge_stand_out,
        }
    }

    /// The one validation: every problem at once, each naming its key.
    pub fn validate(self) -> Result<ValidGrossErrorSettings, SettingsErrors> {
        let mut e = Vec::new();
        let pos = |v: f64| v.is_finite() && v > 0.0;
        for (name, v) in [
            ("k", self.k),
            ("jump_k", self.jump_k),
            ("run_k", self.run_k),
            ("confirm_k", self.confirm_k),
            ("edge_k", self.edge_k),
            ("stand_out", self.stand_out),
            ("edge_stand_out", self.edge_stand_out),
            ("level_k", self.level_k),
        ] {
            if !(pos(v) && v <= 50.0) {
                e.push(format!("{name} = {v} must be in (0, 50]"));
            }
        }
        for (name, v) in [
            ("jump_level_alpha", self.jump_level_alpha),
            ("slope_alpha", self.slope_alpha),
        ] {
            if !(v > 0.0 && v <= 1.0) {
                e.push(format!("{name} = {v} must be in (0, 1]"));
            }
        }
        if !(self.rest_ratio.is_finite() && (1.0..=10.0).contains(&self.rest_ratio)) {
            e.push(format!(
                "rest_ratio = {} must be in [1, 10]",
                self.rest_ratio
            ));
        }
        if self.max_run == 0 {
            e.push("max_run must be ≥ 1".into());
        }
        for (name, v) in [("release_k", self.release_k), ("rest_k", self.rest_k)] {
            if !(v.is_finite() && (0.0..=50.0).contains(&v)) {
                e.push(format!("{name} = {v} must be in [0, 50] (0 = off)"));
            }
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
        for (name, v) in [
            ("level_alpha", self.level_alpha),
            ("trend_beta", self.trend_beta),
        ] {
            if !(0.0..=1.0).contains(&v) {
                e.push(format!("{name} = {v} must be in [0, 1]"));
            }
        }
        for (name, v) in [
            ("min_sigma_gyro_rad_s", self.min_sigma_gyro_rad_s),
            ("min_sigma_accel_m_s2", self.min_sigma_accel_m_s2),
            ("plausible_gyro_rad_s", self.plausible_gyro_rad_s),
            ("plausible_accel_m_s2", self.plausible_accel_m_s2),
        ] {
            if !pos(v) {
                e.push(format!("{name} = {v} must be > 0"));
            }
        }
        if !(self.warmup_max_s.is_finite() && (1.0..=3600.0).contains(&self.warmup_max_s)) {
            e.push(format!(
                "warmup_max_s = {} must be in [1, 3600] s",
                self.warmup_max_s
            ));
        }
        if !(self.identify_defer_s.is_finite() && (0.0..=60.0).contains(&self.identify_defer_s)) {
            e.push(format!(
                "identify_defer_s = {} must be in [0, 60] s (0 = identify inline)",
                self.identify_defer_s
            ));
        }
        if !(self.level_window_s.is_finite() && (0.0..=60.0).contains(&self.level_window_s)) {
            e.push(format!(
                "level_window_s = {} must be in [0, 60] s (0 = off)",
                self.level_window_s
            ));
        }
        if self.lookahead_samples > MAX_LOOKAHEAD {
            e.push(format!(
                "lookahead_samples = {} must be at most {MAX_LOOKAHEAD}",
                self.lookahead_samples
            ));
        }
        let max_side = super::confirm::MAX_FIT_SIDE;
        if !(3..=max_side).contains(&self.run_fit_side) {
            e.push(format!(
                "run_fit_side = {} must be in 3..={max_side}",
                self.run_fit_side
            ));
        }
        if !(2..=MAX_CONTEXT).contains(&self.context_samples) {
            e.push(format!(
                "context_samples = {} must be in 2..={MAX_CONTEXT}",
                self.context_samples
            ));
        }
        if !(2..=MAX_POST).contains(&self.post_samples) {
            e.push(format!(
                "post_samples = {} must be in 2..={MAX_POST}",
                self.post_samples
            ));
        }
        // Cross-key checks run only on keys that passed their own: one mistake, one message.
        if self.lookahead_samples > 0
            && self.lookahead_samples <= MAX_LOOKAHEAD
            && (2..=MAX_POST).contains(&self.post_samples)
            && self.lookahead_samples < self.post_samples + 1
        {
            e.push(format!(
                "lookahead_samples = {} must be 0 (causal) or at least post_samples + 1 = {}",
                self.lookahead_samples,
                self.post_samples + 1
            ));
        }
        let id = &self.identify;
        if id.p_max > MAX_P || id.q_max > MAX_Q || id.d_max > MAX_D {
            e.push(format!(
                "identify orders (p_max {}, d_max {}, q_max {}) exceed the online limits ({MAX_P}, {MAX_D}, {MAX_Q})",
                id.p_max, id.d_max, id.q_max
            ));
        }
        let id_ok = match id.validate() {
            Ok(()) => true,
            Err(v) => {
                e.extend(v.into_iter().map(|s| format!("identify: {s}")));
                false
            }
        };
        if id_ok && self.warmup_samples < id.min_len() {
            e.push(format!(
                "warmup_samples = {} is below the {} samples identification needs",
                self.warmup_samples,
                id.min_len()
            ));
        }
        SettingsErrors::check("gross_error", e, ValidGrossErrorSettings::checked(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_test_keys_are_validated_and_off_by_default() {
        let d = GrossErrorSettings::default();
        assert_eq!((d.level_window_s, d.level_k), (0.0, 4.0));
        assert!(d.clone().validate().is_ok());
        for (w, k, bad) in [
            (1.0, 4.0, None),
            (
                -1.0,
                4.0,
                Some("level_window_s = -1 must be in [0, 60] s (0 = off)"),
            ),
            (
                61.0,
                4.0,
                Some("level_window_s = 61 must be in [0, 60] s (0 = off)"),
            ),
            (
                f64::NAN,
                4.0,
                Some("level_window_s = NaN must be in [0, 60] s (0 = off)"),
            ),
            (1.0, 0.0, Some("level_k = 0 must be in (0, 50]")),
        ] {
            let s = GrossErrorSettings {
                level_window_s: w,
                level_k: k,
                ..d.clone()
            };
            match (s.validate(), bad) {
                (Ok(_), None) => {}
                (Err(e), Some(msg)) => assert!(e.to_string().contains(msg), "{e}"),
                (r, want) => panic!("{w} {k}: {r:?}, wanted {want:?}"),
            }
        }
    }
}
