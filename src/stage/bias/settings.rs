//! Settings of the bias stage (`[bias]` in the daemon config): deterministic calibration,
//! stillness detection, the stochastic model (inline or a path) and the online estimator's knobs.
//!
//! Calibration model, per sensor (gyro and accel separately), with `M = diag(scale) · N`:
//!
//! ```text
//!   raw = M · true + bias      =>      corrected = M^-1 (raw - bias)
//! ```
//!
//! `scale` are the scale factors (1 = nominal), `N` the misalignment / non-orthogonality matrix
//! (row-major, identity = ideal axes), `bias` the constant offset in sensor units after
//! conversion (rad/s, m/s²). This is the usual laboratory calibration form (e.g. Titterton &
//! Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., §8.5).

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Largest bias-update delay, samples (fixed-size delay line).
pub const MAX_UPDATE_DELAY: usize = 512;

/// Deterministic calibration of one triad.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CalibrationSettings {
    /// Constant offset per axis, rad/s (gyro) or m/s² (accel). Default 0.
    pub bias: [f64; 3],
    /// Scale factor per axis (dimensionless, raw = scale · true). Default 1.
    pub scale: [f64; 3],
    /// Misalignment matrix N, row-major (dimensionless). Default identity.
    pub misalignment: [[f64; 3]; 3],
}

impl Default for CalibrationSettings {
    fn default() -> Self {
        CalibrationSettings {
            bias: [0.0; 3],
            scale: [1.0; 3],
            misalignment: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }
}

/// A validated calibration: `corrected = minv (raw - bias)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// `M^-1`.
    pub minv: Matrix3<f64>,
    /// Constant offset (unit).
    pub bias: Vector3<f64>,
}

impl CalibrationSettings {
    fn m(&self) -> Matrix3<f64> {
        let n = Matrix3::from_fn(|i, j| self.misalignment[i][j]);
        Matrix3::from_diagonal(&Vector3::from(self.scale)) * n
    }

    /// Append every problem to `errors`, keys prefixed by `key`.
    pub fn validate_into(&self, key: &str, errors: &mut Vec<String>) {
        if self.bias.iter().any(|v| !v.is_finite()) {
            errors.push(format!("{key}.bias: must be finite"));
        }
        for (a, s) in self.scale.iter().enumerate() {
            if !(s.is_finite() && *s > 0.5 && *s < 2.0) {
                errors.push(format!("{key}.scale[{a}]: must be in (0.5, 2) (got {s})"));
            }
        }
        if self.misalignment.iter().flatten().any(|v| !v.is_finite()) {
            errors.push(format!("{key}.misalignment: must be finite"));
            return;
        }
        // Real misalignments are a few mrad to a few %: reject matrices far from orthonormal
        // axes (condition number > 10), which are typing errors, not calibrations.
        let sv = Matrix3::from_fn(|i, j| self.misalignment[i][j]).singular_values();
        let (mx, mn) = (sv.max(), sv.min());
        if !(mn > 0.0 && mx / mn < 10.0) {
            errors.push(format!(
                "{key}.misalignment: must be well conditioned (singular values {mn:.3e}..{mx:.3e})"
            ));
        }
    }

    /// The calibration to apply; `None` if M is not invertible (validation rejects that).
    pub fn build(&self) -> Option<Calibration> {
        self.m().try_inverse().map(|minv| Calibration {
            minv,
            bias: Vector3::from(self.bias),
        })
    }
}

impl Calibration {
    /// `M^-1 (raw - bias)`.
    #[inline]
    pub fn apply(&self, raw: &Vector3<f64>) -> Vector3<f64> {
        self.minv * (raw - self.bias)
    }
}

/// The default bias model of a gyro channel the config gives none for: a random-walk bias under
/// white noise, both measured on the sensor itself.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WarmupSettings {
    /// Length of the first contiguous still stretch whose per-axis variance (about a fitted
    /// line, so a drifting bias does not count as noise) is the white-noise variance R, samples.
    /// Default 300 (3 s at 100 Hz: R to ±8 %).
    pub still_samples: usize,
    /// ... or fewer: a stretch spanning this long at the nominal rate is enough, s (default 4:
    /// 300 samples at ≥ 75 Hz come first; at 25 Hz 100 samples, R to ±14 %), never fewer than
    /// [`MIN_STILL_SAMPLES`]. Raise it with `still_samples`: it bounds a larger count too.
    pub still_max_s: f64,
    /// Time constant of the bias estimate, s: the random walk's variance per second is
    /// R/(T² fs), so the estimate follows bias changes slower than T and averages away noise
    /// faster than T. Its steady state is a first-order low-pass, so the output's Allan deviation
    /// can only fall at every τ (|1 − H| ≤ 1). Default 60 (the rate random walk it implies,
    /// N/T, is 1.1e-5 rad/s/√s for an ADIS16405 whose measured K is 1.0–1.8e-5).
    pub time_constant_s: f64,
}

/// Fewest still samples the warm-up measures R on, whatever `still_max_s` says (and the floor of
/// `still_samples`): R about a fitted line has n − 2 degrees of freedom, ±√(2/18) = ±33 % at 20.
pub const MIN_STILL_SAMPLES: usize = 20;

impl WarmupSettings {
    /// The still stretch the warm-up measures R on at `fs` Hz, samples: `still_samples`, or
    /// `still_max_s` of them if fewer, never fewer than [`MIN_STILL_SAMPLES`].
    pub fn still_samples_at(&self, fs: f64) -> usize {
        let in_time = (self.still_max_s * fs).ceil();
        if in_time.is_finite() && in_time < self.still_samples as f64 {
            (in_time as usize).max(MIN_STILL_SAMPLES)
        } else {
            self.still_samples
        }
    }
}

impl Default for WarmupSettings {
    fn default() -> Self {
        WarmupSettings {
            still_samples: 300,
            still_max_s: 4.0,
            time_constant_s: 60.0,
        }
    }
}

/// Settings of the bias stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BiasSettings {
    /// Nominal sample rate of the sensor, Hz. Default 100. Models must match it within 1 %.
    pub sample_rate_hz: f64,
    /// Gyro calibration (bias in rad/s).
    pub gyro: CalibrationSettings,
    /// Accelerometer calibration (bias in m/s²).
    pub accel: CalibrationSettings,
    /// Stillness detector.
    pub stillness: StillnessSettings,
    /// Online identification for gyro channels without a model.
    pub warmup: WarmupSettings,
    /// Prior 1-σ of the gyro turn-on bias about the model's mean, rad/s; 0 disables the
    /// random-constant state (unless a step or rate-random-walk effect needs it).
    /// Default 0.02 rad/s (1.1 °/s: consumer MEMS turn-on repeatability).
    pub turn_on_bias_sd_rad_s: f64,
    /// Delay between a sample and its use as a bias measurement, s (0..=2): a still sample is
    /// trusted only once the detector has seen this long after it, so the onset of motion never
    /// leaks into the estimate. Default 0.3 (the detector needs < 0.2 s for a smooth 0.3 rad/s
    /// turn onset). In time, not samples: the same protection at 100 Hz and at 1 kHz (at most
    /// `MAX_UPDATE_DELAY` samples).
    pub update_delay_s: f64,
    /// 3-dB bandwidth of each vibration-line canceller, Hz. Default 0.2: follows a phase drifting
    /// by 0.01 Hz with 10 % residual amplitude; time constant 1/(π·BW) = 1.6 s.
    pub vibration_bandwidth_hz: f64,
    /// Mean still time between false step alarms of the CUSUM step detector, s. Default 36000.
    pub step_false_alarm_interval_s: f64,
    /// On a step alarm the constant state's variance grows by `(factor · |size|)²` (the model's
    /// Step size). Default 3.
    pub step_inflation_factor: f64,
    /// Smallest gyro bias step (a shock) the CUSUM is tuned for on a channel whose model declares
    /// no `step` effect (warm-up models included), rad/s; 0 = no step detector on such channels.
    /// Default 0: an absolute step size fits one sensor class only, and on real benches the
    /// alarms it raised on noise made the estimate jump; a persistent change is re-anchored by
    /// the consistency guard instead (see the stage docs). Models that learned a step declare it.
    pub default_step_rad_s: f64,
    /// Rate random walk of the constant state on a channel whose model declares no
    /// `rate_random_walk` effect, (rad/s)²/s; 0 = none. Default 1e-10 (as the warm-up's): a model
    /// fitted on minutes of data cannot reveal the slow wander, and without it the constant state
    /// becomes certain after the first stop and never follows the bias again.
    pub default_rate_random_walk_q_per_s: f64,
    /// Evidence a gyro channel's warm-up estimate (no model file) needs before it is
    /// subtracted, in σ of the estimate: the channel engages (and follows its estimate from then
    /// on) once |estimate| > `apply_k`·σ; before, the sample keeps its value and the estimate is
    /// published (stage health) with a σ that covers it. 0 = subtract from the first estimate. A
    /// model file's estimate is subtracted from the start. Default 3: if the true bias were 0, an
    /// estimate beyond 3σ would have a 0.27 % chance (Gaussian) — a correction is made on
    /// evidence at the 99.7 % level. Why it matters: a GPS/INS filter downstream learns the
    /// residual bias at its own zero-rate updates; a correction that settles while the vehicle
    /// moves is a step it must learn again, and in a GNSS outage an unexplained step becomes
    /// attitude error (docs/navigation.md, "Do no harm").
    pub apply_k: f64,
}

impl Default for BiasSettings {
    fn default() -> Self {
        BiasSettings {
            sample_rate_hz: 100.0,
            gyro: CalibrationSettings::default(),
            accel: CalibrationSettings::default(),
            stillness: StillnessSettings::default(),
            warmup: WarmupSettings::default(),
            turn_on_bias_sd_rad_s: 0.02,
            update_delay_s: 0.3,
            vibration_bandwidth_hz: 0.2,
            step_false_alarm_interval_s: 36_000.0,
            step_inflation_factor: 3.0,
            default_step_rad_s: 0.0,
            default_rate_random_walk_q_per_s: 1e-10,
            apply_k: 3.0,
        }
    }
}

pub use crate::settings::SettingsErrors;

crate::valid_settings!(
    /// Bias settings that passed [`BiasSettings::validate`]: the only form
    /// [`super::BiasStage`] is built from.
    ValidBiasSettings,
    BiasSettings
);

impl BiasSettings {
    /// The one validation: every field checked, all problems with their key paths (relative to
    /// the `[bias.settings]` table, e.g. `stillness.window_s`).
    pub fn validate(self) -> Result<ValidBiasSettings, SettingsErrors> {
        let mut e = Vec::new();
        let fs = self.sample_rate_hz;
        if !(fs.is_finite() && fs > 0.0 && fs <= 100_000.0) {
            e.push(format!(
                "sample_rate_hz: must be in (0, 100000] Hz (got {fs})"
            ));
        }
        self.gyro.validate_into("gyro", &mut e);
        self.accel.validate_into("accel", &mut e);
        let n_before = e.len();
        self.stillness.validate_into("stillness", &mut e);
        // Cross-key checks run only on keys that passed their own: one mistake, one message.
        let stillness_ok = e.len() == n_before;
        let fs_ok = fs.is_finite() && fs > 0.0 && fs <= 100_000.0;
        if self.warmup.still_samples < MIN_STILL_SAMPLES || self.warmup.still_samples > 1_000_000 {
            e.push(format!(
                "warmup.still_samples: must be in {MIN_STILL_SAMPLES}..=1000000 (got {})",
                self.warmup.still_samples
            ));
        }
        let m = self.warmup.still_max_s;
        if !(m.is_finite() && (1.0..=3600.0).contains(&m)) {
            e.push(format!(
                "warmup.still_max_s: must be in [1, 3600] s (got {m})"
            ));
        }
        let t = self.warmup.time_constant_s;
        if !(t.is_finite() && (1.0..=1e6).contains(&t)) {
            e.push(format!(
                "warmup.time_constant_s: must be in [1, 1e6] s (got {t})"
            ));
        }
        if !(self.turn_on_bias_sd_rad_s.is_finite() && self.turn_on_bias_sd_rad_s >= 0.0) {
            e.push(format!(
                "turn_on_bias_sd_rad_s: must be >= 0 (got {})",
                self.turn_on_bias_sd_rad_s
            ));
        }
        if !(self.update_delay_s.is_finite() && (0.0..=2.0).contains(&self.update_delay_s)) {
            e.push(format!(
                "update_delay_s: must be in [0, 2] s (got {})",
                self.update_delay_s
            ));
        } else if stillness_ok && self.update_delay_s > self.stillness.window_s {
            // A delayed sample must lie inside the window that declared it still.
            e.push(format!(
                "update_delay_s: must not exceed stillness.window_s ({} s) (got {} s)",
                self.stillness.window_s, self.update_delay_s
            ));
        }
        if !(self.vibration_bandwidth_hz.is_finite()
            && self.vibration_bandwidth_hz > 0.0
            && (!fs_ok || self.vibration_bandwidth_hz < 0.05 * fs))
        {
            let bound = if fs_ok {
                format!(" = {} Hz", 0.05 * fs)
            } else {
                String::new()
            };
            e.push(format!(
                "vibration_bandwidth_hz: must be in (0, sample_rate_hz/20{bound}) (got {})",
                self.vibration_bandwidth_hz
            ));
        }
        if !(self.step_false_alarm_interval_s.is_finite()
            && self.step_false_alarm_interval_s >= 1.0)
        {
            e.push(format!(
                "step_false_alarm_interval_s: must be >= 1 s (got {})",
                self.step_false_alarm_interval_s
            ));
        }
        for (key, v) in [
            ("default_step_rad_s", self.default_step_rad_s),
            (
                "default_rate_random_walk_q_per_s",
                self.default_rate_random_walk_q_per_s,
            ),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                e.push(format!("{key}: must be >= 0 (got {v})"));
            }
        }
        if !(self.apply_k.is_finite() && (0.0..=100.0).contains(&self.apply_k)) {
            e.push(format!(
                "apply_k: must be in [0, 100] (got {})",
                self.apply_k
            ));
        }
        if !(self.step_inflation_factor.is_finite() && self.step_inflation_factor > 0.0) {
            e.push(format!(
                "step_inflation_factor: must be > 0 (got {})",
                self.step_inflation_factor
            ));
        }
        SettingsErrors::check("bias", e, ValidBiasSettings::checked(self))
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn the_still_stretch_is_bounded_in_time_but_never_below_the_minimum() {
        let w = WarmupSettings::default();
        assert_eq!((w.still_samples, w.still_max_s), (300, 4.0));
        // ≥ 75 Hz: the 300 samples come first (the MPU6050's 99.32 Hz too).
        for fs in [250.0, 104.0, 100.0, 99.32, 75.0] {
            assert_eq!(w.still_samples_at(fs), 300, "{fs}");
        }
        // 50 and 25 Hz: 4 s of samples; 2 Hz: the minimum, not 8.
        assert_eq!(w.still_samples_at(50.0), 200);
        assert_eq!(w.still_samples_at(25.0), 100);
        assert_eq!(w.still_samples_at(2.0), MIN_STILL_SAMPLES);
    }

    use super::*;

    #[test]
    fn defaults_are_valid_and_parse_from_an_empty_table() {
        BiasSettings::default().validate().unwrap();
        let s: BiasSettings = toml::from_str("").unwrap();
        assert_eq!(s, BiasSettings::default());
    }

    #[test]
    fn validation_reports_several_errors_at_once_with_key_paths() {
        let text = r#"
            sample_rate_hz = 100.0
            update_delay_s = 5.0
            [gyro]
            scale = [1.0, 0.1, 1.0]
            [stillness]
            window_s = 0.0
            [warmup]
            time_constant_s = 0.0
        "#;
        let s: BiasSettings = toml::from_str(text).unwrap();
        let errs = s.validate().unwrap_err().errors;
        let all = errs.join("\n");
        for key in [
            "update_delay_s:",
            "gyro.scale[1]:",
            "stillness.window_s:",
            "warmup.time_constant_s:",
        ] {
            assert!(all.contains(key), "missing `{key}` in\n{all}");
        }
    }

    #[test]
    fn a_full_config_table_parses_and_validates() {
        // Every key of the [bias] table, as the lead's config/default.toml would carry it.
        let text = r#"
            sample_rate_hz = 100.0
            turn_on_bias_sd_rad_s = 0.02
            update_delay_s = 0.3
            vibration_bandwidth_hz = 0.2
            step_false_alarm_interval_s = 36000.0
            step_inflation_factor = 3.0
            default_step_rad_s = 0.0
            default_rate_random_walk_q_per_s = 1e-10
            apply_k = 3.0
            [gyro]
            bias = [0.001, -0.002, 0.0]
            scale = [1.0, 1.0, 1.0]
            misalignment = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            [accel]
            bias = [0.0, 0.0, 0.0]
            [stillness]
            window_s = 0.5
            enter_after_s = 1.0
            noise_factor = 1.6
            instant_k = 6.0
            mean_k = 4.0
            floor_rise_s = 600.0
            gyro_sd_max_rad_s = 0.1
            accel_sd_max_m_s2 = 0.3
            accel_norm_dev_max_m_s2 = 1.0
            gravity_m_s2 = 9.80665
            [warmup]
            still_samples = 300
            time_constant_s = 60.0
        "#;
        let s: BiasSettings = toml::from_str(text).unwrap();
        let v = s.clone().validate().unwrap();
        assert_eq!(v, s, "validation changes nothing");
        assert_eq!(v.gyro.bias, [0.001, -0.002, 0.0]);
    }

    #[test]
    fn unknown_keys_are_rejected() {
        assert!(toml::from_str::<BiasSettings>("sample_rate = 100.0").is_err());
        assert!(toml::from_str::<BiasSettings>("[stillness]\nwindow = 3").is_err());
    }

    #[test]
    fn calibration_inverts_scale_misalignment_and_bias() {
        // raw = diag(s) N true + b  =>  apply(raw) = true exactly (1e-12).
        let c = CalibrationSettings {
            bias: [0.01, -0.02, 0.03],
            scale: [1.01, 0.99, 1.02],
            misalignment: [[1.0, 0.002, -0.001], [0.0, 1.0, 0.003], [0.001, 0.0, 1.0]],
        };
        let cal = c.build().unwrap();
        let truth = Vector3::new(0.3, -0.1, 0.2);
        let raw = c.m() * truth + Vector3::from(c.bias);
        assert!((cal.apply(&raw) - truth).amax() < 1e-12);
    }
}

/// Stillness detector settings (units in names; each test explained in the [`super::stillness`]
/// module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StillnessSettings {
    /// Window length, s (at least `MIN_WINDOW` = 25 samples, at most `MAX_WINDOW`). Default 0.5.
    /// In time, not samples, so a 250 Hz sensor's detector sees a motion onset as soon as a
    /// 100 Hz one's; below 50 Hz the window is 25 samples (1 s at 25 Hz, 2.5 s at 10 Hz).
    pub window_s: f64,
    /// Candidate time required before entering STILL, s (T_in). Default 1.0.
    pub enter_after_s: f64,
    /// A window is still when its gyro and accel sds are at most this factor above their noise
    /// floors. Default 2: a 50-sample window's three-axis sd of white noise varies by ~6 % (1σ),
    /// so the quietest windows sit ~15 % below the typical and the loudest ~15 % above; real
    /// rest wanders more (x-IMU3 at rest: accel window sd 0.038–0.063 in its first 4 s), while
    /// motion is many times the floor (x-IMU3 handheld: gyro ×12 at the median).
    pub noise_factor: f64,
    /// A sample further than this many per-axis σ (the window's own, no lower than the floor's)
    /// from the window mean is motion. Default 7: real rest is heavy-tailed (an ADIS16405's
    /// quantised accelerometers show 5–11 LSB samples at ~1 LSB noise).
    pub instant_k: f64,
    /// The window's gyro mean may differ from a confident bias estimate by this many σ (the
    /// mean's noise and the estimate's σ combined). Default 4.
    pub mean_k: f64,
    /// The mean test vetoes an otherwise quiet stretch for this long, s, before its offset may
    /// be taken for a bias that moved (a shock; the bias stage's consistency guard then
    /// re-anchors). Default 2. A steady turn stays vetoed for as long as it lasts (module docs,
    /// "Steady turns").
    pub mean_veto_s: f64,
    /// The noise floors may rise by at most a factor 2 per this many seconds. Default 600.
    pub floor_rise_s: f64,
    /// Ceiling of the gyro window sd, rad/s, whatever the floor. Default 0.1 (5.7 °/s: no MEMS
    /// gyro at rest is noisier, engine vibration included).
    pub gyro_sd_max_rad_s: f64,
    /// Ceiling of the accel window sd, m/s². Default 0.3: above any MEMS accelerometer's noise
    /// and a standing car's engine vibration (rtklibexplorer: 0.10–0.15), below a moving car's
    /// road vibration (comma2k19 on a highway: ≥ 0.49).
    pub accel_sd_max_m_s2: f64,
    /// Max `accel_norm`, m/s². Default 1.0: room for an uncalibrated consumer accelerometer's
    /// zero-g offset and scale (MPU-6050: ±80 mg on z); guards against sustained vertical
    /// acceleration and free fall.
    pub accel_norm_dev_max_m_s2: f64,
    /// Gravity magnitude, m/s². Default 9.80665.
    pub gravity_m_s2: f64,
}

impl Default for StillnessSettings {
    fn default() -> Self {
        StillnessSettings {
            window_s: 0.5,
            enter_after_s: 1.0,
            noise_factor: 2.0,
            instant_k: 7.0,
            mean_k: 4.0,
            mean_veto_s: 2.0,
            floor_rise_s: 600.0,
            gyro_sd_max_rad_s: 0.1,
            accel_sd_max_m_s2: 0.3,
            accel_norm_dev_max_m_s2: 1.0,
            gravity_m_s2: 9.80665,
        }
    }
}

impl StillnessSettings {
    /// Append every problem to `errors`, keys prefixed by `key` (e.g. `stillness`).
    pub fn validate_into(&self, key: &str, errors: &mut Vec<String>) {
        if !(self.window_s.is_finite() && self.window_s > 0.0 && self.window_s <= 10.0) {
            errors.push(format!(
                "{key}.window_s: must be in (0, 10] s (got {})",
                self.window_s
            ));
        }
        if !(self.enter_after_s.is_finite() && (0.0..=3600.0).contains(&self.enter_after_s)) {
            errors.push(format!(
                "{key}.enter_after_s: must be in [0, 3600] s (got {})",
                self.enter_after_s
            ));
        }
        for (name, v, lo, hi) in [
            ("noise_factor", self.noise_factor, 1.0, 100.0),
            ("instant_k", self.instant_k, 1.0, 100.0),
            ("mean_k", self.mean_k, 0.5, 100.0),
            ("mean_veto_s", self.mean_veto_s, 0.0, 3600.0),
            ("floor_rise_s", self.floor_rise_s, 1.0, 1e7),
        ] {
            if !(v.is_finite() && v > lo && v <= hi) {
                errors.push(format!("{key}.{name}: must be in ({lo}, {hi}] (got {v})"));
            }
        }
        for (name, v) in [
            ("gyro_sd_max_rad_s", self.gyro_sd_max_rad_s),
            ("accel_sd_max_m_s2", self.accel_sd_max_m_s2),
            ("accel_norm_dev_max_m_s2", self.accel_norm_dev_max_m_s2),
        ] {
            if !(v.is_finite() && v > 0.0) {
                errors.push(format!("{key}.{name}: must be finite and > 0 (got {v})"));
            }
        }
        if !(self.gravity_m_s2.is_finite() && self.gravity_m_s2 > 9.7 && self.gravity_m_s2 < 9.9) {
            errors.push(format!(
                "{key}.gravity_m_s2: must be in (9.7, 9.9) m/s² (got {})",
                self.gravity_m_s2
            ));
        }
    }
}
