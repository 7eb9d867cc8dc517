//! The bias model file: per-channel stochastic bias models plus the effects learned by
//! `diagnose`, written by `fit` / `diagnose` / `simulate` and loaded by the online bias stage.
//!
//! A channel's stochastic part is a linear AR(p) model in the form the fitters produce,
//!
//! ```text
//!   y[n] - mean = sum_{i=1..p} ar[i-1] (y[n-i] - mean) + e[n],   var(e) = innovation_var,
//! ```
//!
//! where `y` is, by default (`ar_of = "signal"`), the whole calibrated static signal
//! (= bias + white measurement noise of variance `white_noise_var`). The online stage splits that
//! signal model into a bias process and white noise ([`crate::model::bias_state_space`]). A
//! producer that knows the bias process itself (the simulator, from its truth) writes
//! `ar_of = "bias"`: then `ar`/`innovation_var` describe the bias alone.
//!
//! Effects (issue 6) add deterministic or tracked terms to the bias of the channel; each
//! variant documents its equation and units. "unit" below is the channel's unit: rad/s for
//! gyro channels (`gx gy gz`), m/s² for accelerometer channels (`ax ay az`).
//!
//! ```toml
//! [[channels]]
//! channel = "gz"
//! method = "burg"
//! sample_rate_hz = 100.0
//! mean = 0.0012
//! ar = [0.6, 0.3]
//! innovation_var = 3.1e-6
//! white_noise_var = 3.0e-6
//! effects = [ { kind = "temperature", t0_c = 25.0, c1_per_c = 1e-4, c2_per_c2 = 0.0, lag_s = 30.0 } ]
//! ```

use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::model::fos_candidates::TermSpec;
use crate::model::fos_model::FosModel;
use crate::sample::channel_index;

/// `|1 - sum ar|` below which [`ChannelBiasModel::from_linear_fos`] reports a unit root.
const UNIT_ROOT_TOL: f64 = 1e-9;

/// Longest AR polynomial accepted in a file. The online stage reduces any order to
/// [`crate::model::bias_state_space::MAX_AR_ORDER`] by autocovariance matching; this bound only
/// rejects nonsense (and keeps the autocovariance recursion cheap).
pub const MAX_FILE_AR_ORDER: usize = 64;

/// A bias model file: one table per modelled channel (`[[channels]]` in TOML).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BiasModelFile {
    /// Per-channel models; each channel name at most once.
    pub channels: Vec<ChannelBiasModel>,
}

/// What the `ar` / `innovation_var` fields of a channel describe.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArOf {
    /// The whole calibrated static signal (bias + white noise): what `fit` produces.
    #[default]
    Signal,
    /// The bias process alone (white noise excluded): what a simulator with truth can write.
    Bias,
}

/// One channel's stochastic bias model.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelBiasModel {
    /// Channel name: `gx gy gz ax ay az`.
    pub channel: String,
    /// Provenance: `burg | yule_walker | covariance | fos | warmup_burg | truth | ...`.
    pub method: String,
    /// Sample rate the model was fitted at, Hz. The AR dynamics are per sample at this rate.
    pub sample_rate_hz: f64,
    /// Level the stochastic part wanders around, after the deterministic calibration (unit).
    /// Gyro channels: the stage subtracts it. Accelerometer channels: it contains the gravity
    /// projection of the fit log and is never subtracted.
    pub mean: f64,
    /// phi_1..phi_p of the AR model (dimensionless); empty = white.
    pub ar: Vec<f64>,
    /// One-step innovation variance of the AR model (unit²).
    pub innovation_var: f64,
    /// Variance of the white measurement noise (ARW / VRW part) per sample (unit²), the KF's R
    /// (e.g. `ARW² · sample_rate_hz` with ARW in unit/√Hz). With `ar_of = "signal"`, `0` means
    /// "unknown": the stage then takes the largest white variance the fitted signal spectrum
    /// admits (its minimum), and so it does for a value not below the signal variance. With
    /// `ar_of = "bias"` it is taken literally.
    pub white_noise_var: f64,
    /// What `ar` and `innovation_var` describe (default: the whole signal).
    #[serde(default)]
    pub ar_of: ArOf,
    /// Effects learned by `diagnose` (close the loop); applied online by the bias stage.
    #[serde(default)]
    pub effects: Vec<Effect>,
}

/// An effect on a channel's bias. Online semantics are those of [`crate::stage::bias`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Effect {
    /// `b += c1 (T_l - t0) + c2 (T_l - t0)^2`, where `T_l` is the sensor temperature (°C) passed
    /// through a first-order lag `dT_l/dt = (T - T_l) / lag_s` (`lag_s = 0`: no lag).
    Temperature {
        /// Reference temperature, °C.
        t0_c: f64,
        /// Linear coefficient, unit/°C.
        c1_per_c: f64,
        /// Quadratic coefficient, unit/°C².
        c2_per_c2: f64,
        /// Thermal lag time constant, s (≥ 0).
        lag_s: f64,
    },
    /// `b += amplitude sin(2 pi freq_hz t + phase_rad)`, t = sensor time `t_ns·1e-9`, s.
    /// Online the amplitude and phase only seed a tracker (the phase of a live line drifts).
    VibrationLine {
        /// Line frequency, Hz (0 < f < sample_rate_hz / 2).
        freq_hz: f64,
        /// Amplitude, unit (≥ 0).
        amplitude: f64,
        /// Phase at t = 0, rad.
        phase_rad: f64,
    },
    /// `b += size` for `t >= t_s` in the log it was found in. Online `t_s` is provenance only:
    /// `size` is the expected size of bias steps of this sensor and tunes the step detector.
    Step {
        /// Time of the step in the diagnosed log, s.
        t_s: f64,
        /// Step size, unit (≠ 0).
        size: f64,
    },
    /// Gyro only: `b += sum_j coeffs_per_m_s2[j] * f[j]`, with `f` the calibrated specific force
    /// (m/s², body axes x y z, gravity included), coefficients in rad/s per m/s². The part of the
    /// term that is constant at rest (`k · f_rest`) is indistinguishable from bias; the stage's
    /// estimator absorbs it, so fitting with or without a constant term gives the same result.
    GSensitivity {
        /// Coefficients for the x, y, z specific force, rad/s per m/s².
        coeffs_per_m_s2: [f64; 3],
    },
    /// Rate random walk: the bias holds a random-walk component whose variance grows by
    /// `q_per_s` per second (unit²/s; for a gyro `q_per_s = K²` with K the RRW coefficient in
    /// rad/s/√s).
    RateRandomWalk {
        /// Random-walk intensity, unit²/s (≥ 0).
        q_per_s: f64,
    },
}

/// Why a model file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum BiasModelError {
    /// The file could not be read.
    #[error("cannot read bias model {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The TOML does not parse into the model structure.
    #[error("bias model does not parse: {0}")]
    Parse(String),
    /// The model could not be serialised.
    #[error("bias model does not serialise: {0}")]
    Serialize(String),
    /// The model parsed but is invalid; every problem is listed with its key path.
    #[error("invalid bias model:\n  {}", .0.join("\n  "))]
    Invalid(Vec<String>),
}

fn finite(errors: &mut Vec<String>, key: &str, v: f64) -> bool {
    if v.is_finite() {
        true
    } else {
        errors.push(format!("{key}: must be finite (got {v})"));
        false
    }
}

impl BiasModelFile {
    /// Parse a model from TOML text and validate it.
    pub fn from_toml_str(text: &str) -> Result<Self, BiasModelError> {
        let m: BiasModelFile =
            toml::from_str(text).map_err(|e| BiasModelError::Parse(e.to_string()))?;
        m.validate().map_err(BiasModelError::Invalid)?;
        Ok(m)
    }

    /// Read, parse and validate a model file.
    pub fn load(path: &Path) -> Result<Self, BiasModelError> {
        let text = std::fs::read_to_string(path).map_err(|source| BiasModelError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text)
    }

    /// Serialise to TOML (the format [`Self::from_toml_str`] reads).
    pub fn to_toml_string(&self) -> Result<String, BiasModelError> {
        toml::to_string(self).map_err(|e| BiasModelError::Serialize(e.to_string()))
    }

    /// The model of channel `name`, if present.
    pub fn channel(&self, name: &str) -> Option<&ChannelBiasModel> {
        self.channels.iter().find(|c| c.channel == name)
    }

    /// Check every field; returns all problems, each prefixed with its key path
    /// (`channels[i].field`).
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut errors = Vec::new();
        for (i, ch) in self.channels.iter().enumerate() {
            let key = format!("channels[{i}]");
            ch.validate_into(&key, &mut errors);
            if self.channels[..i].iter().any(|o| o.channel == ch.channel) {
                errors.push(format!(
                    "{key}.channel: `{}` appears more than once",
                    ch.channel
                ));
            }
        }
        if errors.is_empty() {
            Ok(())
        } else {
            Err(errors)
        }
    }
}

impl ChannelBiasModel {
    /// The AR model of channel `channel` equal to a linear FOS model (CP degree 1: a constant
    /// and output lags), with `method = "fos"` and `ar_of = "signal"`.
    ///
    /// The FOS model works on `u = (y - center) / scale`:
    /// `u(n) = a_0 + sum_l a_l u(n-l)` (`a_0` = coefficient of the constant, 0 if the search did
    /// not select it; `a_l` = coefficient of `y(n-l)`, 0 for unselected lags). In `y` units that
    /// is `y(n) = k + sum_l a_l y(n-l)`, `k = center (1 - S) + scale a_0`, `S = sum_l a_l`: the lag
    /// coefficients are unchanged, and the level the model reverts to is
    /// `mean = k / (1 - S) = center + scale a_0 / (1 - S)` (computed in the second form, which
    /// does not cancel). Then `mean + sum_l a_l (y(n-l) - mean)` is the FOS one-step prediction
    /// exactly, for every history. `ar` has the length of the largest selected lag (empty if no
    /// lag was selected: white).
    ///
    /// `innovation_var` is the one-step residual variance of the model on its fit data in `y`
    /// units (unit²), e.g. the mean square of [`FosModel::residuals`]; it is stored as given.
    ///
    /// Only linear, autonomous models convert: the online bias stage is a linear Kalman filter
    /// over an AR state space, so a model with a cross-product term (CP degree 2) or an
    /// exogenous term cannot run online and is rejected with an error naming the term. A model
    /// whose lag coefficients sum to (nearly) 1 has a unit root and no level to revert to; it is
    /// rejected too. The result is not validated (stationarity etc.): call
    /// [`BiasModelFile::validate`] on the file.
    pub fn from_linear_fos(
        channel: &str,
        sample_rate_hz: f64,
        model: &FosModel,
        innovation_var: f64,
    ) -> Result<Self, String> {
        if model.terms.len() != model.coefficients.len() {
            return Err(format!(
                "FOS model of {channel}: {} terms but {} coefficients",
                model.terms.len(),
                model.coefficients.len()
            ));
        }
        if !(model.center.is_finite() && model.scale.is_finite() && model.scale != 0.0) {
            return Err(format!(
                "FOS model of {channel}: bad standardisation (center {}, scale {})",
                model.center, model.scale
            ));
        }
        let mut a0 = 0.0;
        let mut ar = vec![0.0; model.max_lag()];
        for (t, &c) in model.terms.iter().zip(&model.coefficients) {
            if !c.is_finite() {
                return Err(format!(
                    "FOS model of {channel}: coefficient of {} is not finite ({c})",
                    t.name()
                ));
            }
            match *t {
                TermSpec::Constant => a0 += c,
                TermSpec::Lag { lag } if lag >= 1 => ar[lag - 1] += c,
                TermSpec::Lag { .. } => {
                    return Err(format!(
                        "FOS model of {channel}: term {} is not a past output",
                        t.name()
                    ));
                }
                TermSpec::CrossProduct { .. } => {
                    return Err(format!(
                        "FOS model of {channel} has the non-linear term {}: the online bias stage \
                         is a linear Kalman filter and runs only linear (CP degree 1) models",
                        t.name()
                    ));
                }
                TermSpec::ExoLag { .. } => {
                    return Err(format!(
                        "FOS model of {channel} has the exogenous term {}: the online bias stage \
                         runs only autonomous AR models (constant and output lags)",
                        t.name()
                    ));
                }
            }
        }
        let one_minus_sum = 1.0 - ar.iter().sum::<f64>();
        if one_minus_sum.is_nan() || one_minus_sum.abs() <= UNIT_ROOT_TOL {
            return Err(format!(
                "FOS model of {channel}: the lag coefficients sum to {} (a unit root): the model \
                 reverts to no level, so it has no mean and cannot be a stationary bias model",
                1.0 - one_minus_sum
            ));
        }
        Ok(ChannelBiasModel {
            channel: channel.to_string(),
            method: "fos".into(),
            sample_rate_hz,
            mean: model.center + model.scale * a0 / one_minus_sum,
            ar,
            innovation_var,
            white_noise_var: 0.0,
            ar_of: ArOf::Signal,
            effects: Vec::new(),
        })
    }

    /// True for the gyro channels `gx gy gz`.
    pub fn is_gyro(&self) -> bool {
        matches!(channel_index(&self.channel), Some(c) if c < 3)
    }

    /// Append every problem of this channel to `errors`, keys prefixed by `key`.
    pub fn validate_into(&self, key: &str, errors: &mut Vec<String>) {
        let Some(_) = channel_index(&self.channel) else {
            errors.push(format!(
                "{key}.channel: `{}` is not one of gx gy gz ax ay az",
                self.channel
            ));
            return;
        };
        if self.method.trim().is_empty() {
            errors.push(format!("{key}.method: must name the fitting method"));
        }
        if finite(
            errors,
            &format!("{key}.sample_rate_hz"),
            self.sample_rate_hz,
        ) && self.sample_rate_hz <= 0.0
        {
            errors.push(format!(
                "{key}.sample_rate_hz: must be > 0 (got {})",
                self.sample_rate_hz
            ));
        }
        finite(errors, &format!("{key}.mean"), self.mean);
        if self.ar.len() > MAX_FILE_AR_ORDER {
            errors.push(format!(
                "{key}.ar: order {} exceeds {MAX_FILE_AR_ORDER}",
                self.ar.len()
            ));
        } else if self.ar.iter().all(|v| v.is_finite()) {
            if !crate::stats::ar_poly::ar_is_stationary(&self.ar) {
                errors.push(format!("{key}.ar: the AR polynomial is not stationary (a root on or outside the unit circle)"));
            }
        } else {
            errors.push(format!("{key}.ar: all coefficients must be finite"));
        }
        if finite(
            errors,
            &format!("{key}.innovation_var"),
            self.innovation_var,
        ) && self.innovation_var <= 0.0
        {
            errors.push(format!(
                "{key}.innovation_var: must be > 0 (got {})",
                self.innovation_var
            ));
        }
        if finite(
            errors,
            &format!("{key}.white_noise_var"),
            self.white_noise_var,
        ) && self.white_noise_var < 0.0
        {
            errors.push(format!(
                "{key}.white_noise_var: must be >= 0 (got {})",
                self.white_noise_var
            ));
        }
        let nyquist = 0.5 * self.sample_rate_hz;
        let mut n_temperature = 0;
        let mut n_gsens = 0;
        for (j, e) in self.effects.iter().enumerate() {
            let ek = format!("{key}.effects[{j}]");
            match *e {
                Effect::Temperature {
                    t0_c,
                    c1_per_c,
                    c2_per_c2,
                    lag_s,
                } => {
                    n_temperature += 1;
                    finite(errors, &format!("{ek}.t0_c"), t0_c);
                    finite(errors, &format!("{ek}.c1_per_c"), c1_per_c);
                    finite(errors, &format!("{ek}.c2_per_c2"), c2_per_c2);
                    if finite(errors, &format!("{ek}.lag_s"), lag_s) && lag_s < 0.0 {
                        errors.push(format!("{ek}.lag_s: must be >= 0 (got {lag_s})"));
                    }
                }
                Effect::VibrationLine {
                    freq_hz,
                    amplitude,
                    phase_rad,
                } => {
                    if finite(errors, &format!("{ek}.freq_hz"), freq_hz)
                        && !(freq_hz > 0.0 && freq_hz < nyquist)
                    {
                        errors.push(format!(
                            "{ek}.freq_hz: must be in (0, sample_rate_hz/2 = {nyquist}) (got {freq_hz})"
                        ));
                    }
                    if finite(errors, &format!("{ek}.amplitude"), amplitude) && amplitude < 0.0 {
                        errors.push(format!("{ek}.amplitude: must be >= 0 (got {amplitude})"));
                    }
                    finite(errors, &format!("{ek}.phase_rad"), phase_rad);
                }
                Effect::Step { t_s, size } => {
                    finite(errors, &format!("{ek}.t_s"), t_s);
                    if finite(errors, &format!("{ek}.size"), size) && size == 0.0 {
                        errors.push(format!("{ek}.size: must be non-zero"));
                    }
                }
                Effect::GSensitivity { coeffs_per_m_s2 } => {
                    n_gsens += 1;
                    if !self.is_gyro() {
                        errors.push(format!(
                            "{ek}: g_sensitivity applies to gyro channels only (channel {})",
                            self.channel
                        ));
                    }
                    for (a, k) in coeffs_per_m_s2.iter().enumerate() {
                        finite(errors, &format!("{ek}.coeffs_per_m_s2[{a}]"), *k);
                    }
                }
                Effect::RateRandomWalk { q_per_s } => {
                    if finite(errors, &format!("{ek}.q_per_s"), q_per_s) && q_per_s < 0.0 {
                        errors.push(format!("{ek}.q_per_s: must be >= 0 (got {q_per_s})"));
                    }
                }
            }
        }
        if n_temperature > 1 {
            errors.push(format!(
                "{key}.effects: at most one temperature effect per channel"
            ));
        }
        if n_gsens > 1 {
            errors.push(format!(
                "{key}.effects: at most one g_sensitivity effect per channel"
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fos::FosSettings;
    use crate::model::fos_model::FosModelSpec;
    use crate::rng::Rng;

    /// One-step prediction of the file's AR model: `mean + sum ar[i-1] (y[n-i] - mean)`, with
    /// `history` newest last (at least `ar.len()` values).
    fn ar_predict(m: &ChannelBiasModel, history: &[f64]) -> f64 {
        let n = history.len();
        m.mean
            + m.ar
                .iter()
                .enumerate()
                .map(|(i, a)| a * (history[n - 1 - i] - m.mean))
                .sum::<f64>()
    }

    fn assert_same_prediction(m: &ChannelBiasModel, fos: &FosModel, history: &[f64]) {
        let p_ar = ar_predict(m, history);
        let p_fos = fos.predict_next(history, &[]);
        assert!(
            (p_ar - p_fos).abs() <= 1e-9 * p_fos.abs().max(1e-300),
            "AR {p_ar} vs FOS {p_fos} (diff {:e})",
            p_ar - p_fos
        );
    }

    #[test]
    fn linear_fos_converts_to_the_same_ar_predictor() {
        // Seed 20240605: y(n) = 3 + x(n), x(n) = 0.6 x(n-1) + 0.25 x(n-2) + 0.1 e(n), 20 000
        // samples; FOS CP=1, L=10 as `fit --bias-method fos` runs it.
        let mut rng = Rng::new(20_240_605);
        let (mut x1, mut x2) = (0.0f64, 0.0f64);
        let y: Vec<f64> = (0..20_000)
            .map(|_| {
                let x = 0.6 * x1 + 0.25 * x2 + 0.1 * rng.normal();
                x2 = x1;
                x1 = x;
                3.0 + x
            })
            .collect();
        let l = 10;
        let (fos, _) =
            FosModel::fit(&y, &[], &FosModelSpec::paper(l, 1), &FosSettings::default()).unwrap();
        let r = fos.residuals(&y, &[], l..y.len());
        let mse = r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64;
        let m = ChannelBiasModel::from_linear_fos("gz", 100.0, &fos, mse).unwrap();
        assert_eq!(m.method, "fos");
        assert_eq!(m.ar_of, ArOf::Signal);
        assert_eq!(m.innovation_var, mse);
        let file = BiasModelFile {
            channels: vec![m.clone()],
        };
        file.validate().unwrap();
        // Exactly the FOS predictor, on the fit data and on histories far from it.
        for n in (l..y.len()).step_by(97) {
            assert_same_prediction(&m, &fos, &y[..n]);
        }
        let odd: Vec<f64> = (0..l).map(|i| -7.0 + 1.3 * i as f64).collect();
        assert_same_prediction(&m, &fos, &odd);
        // And it is the generating model, to sampling accuracy (sd of phi ~ 0.007).
        assert!(m.ar.len() >= 2 && m.ar.len() <= l, "{:?}", m.ar);
        assert!((m.ar[0] - 0.6).abs() < 0.04, "{:?}", m.ar);
        assert!((m.ar[1] - 0.25).abs() < 0.04, "{:?}", m.ar);
        assert!((m.mean - 3.0).abs() < 0.05, "{}", m.mean);
        assert!((mse / 0.01 - 1.0).abs() < 0.05, "{mse}");
    }

    #[test]
    fn linear_fos_conversion_maps_the_constant_through_the_standardisation() {
        // u(n) = 0.3 + 0.5 u(n-1) + 0.2 u(n-3), u = (y - 10) / 2: y(n) = 10 (1 - 0.7) + 0.6
        // + 0.5 y(n-1) + 0.2 y(n-3), level 3.6 / 0.3 = 12; lag 2 unselected → 0.
        let fos = FosModel {
            terms: vec![
                TermSpec::Lag { lag: 3 },
                TermSpec::Constant,
                TermSpec::Lag { lag: 1 },
            ],
            coefficients: vec![0.2, 0.3, 0.5],
            center: 10.0,
            scale: 2.0,
            exo_center: vec![],
            exo_scale: vec![],
        };
        let m = ChannelBiasModel::from_linear_fos("ax", 200.0, &fos, 1e-4).unwrap();
        assert_eq!(m.ar, vec![0.5, 0.0, 0.2]);
        assert!((m.mean - 12.0).abs() < 1e-12, "{}", m.mean);
        for h in [[1.0, 2.0, 3.0], [12.0, 12.0, 12.0], [-40.0, 0.5, 1e3]] {
            assert_same_prediction(&m, &fos, &h);
        }
    }

    #[test]
    fn non_linear_exogenous_and_unit_root_fos_models_are_rejected() {
        let model = |terms: Vec<TermSpec>, coefficients: Vec<f64>| FosModel {
            terms,
            coefficients,
            center: 0.0,
            scale: 1.0,
            exo_center: vec![0.0],
            exo_scale: vec![1.0],
        };
        let cp = model(
            vec![
                TermSpec::Lag { lag: 1 },
                TermSpec::CrossProduct { lag1: 1, lag2: 2 },
            ],
            vec![0.5, 0.1],
        );
        let e = ChannelBiasModel::from_linear_fos("gx", 100.0, &cp, 1e-6).unwrap_err();
        assert!(e.contains("y(n-1)*y(n-2)") && e.contains("linear"), "{e}");
        let exo = model(vec![TermSpec::ExoLag { input: 0, lag: 0 }], vec![0.5]);
        let e = ChannelBiasModel::from_linear_fos("gx", 100.0, &exo, 1e-6).unwrap_err();
        assert!(e.contains("x0(n-0)") && e.contains("exogenous"), "{e}");
        let unit_root = model(
            vec![
                TermSpec::Constant,
                TermSpec::Lag { lag: 1 },
                TermSpec::Lag { lag: 2 },
            ],
            vec![0.01, 1.2, -0.2],
        );
        let e = ChannelBiasModel::from_linear_fos("gx", 100.0, &unit_root, 1e-6).unwrap_err();
        assert!(e.contains("unit root"), "{e}");
    }

    fn example() -> BiasModelFile {
        BiasModelFile {
            channels: vec![
                ChannelBiasModel {
                    channel: "gz".into(),
                    method: "burg".into(),
                    sample_rate_hz: 100.0,
                    mean: 1.25e-3,
                    ar: vec![0.61, 0.3],
                    innovation_var: 3.1e-6,
                    white_noise_var: 3.0e-6,
                    ar_of: ArOf::Signal,
                    effects: vec![
                        Effect::Temperature {
                            t0_c: 25.0,
                            c1_per_c: 1e-4,
                            c2_per_c2: -2e-6,
                            lag_s: 30.0,
                        },
                        Effect::VibrationLine {
                            freq_hz: 23.37,
                            amplitude: 0.01,
                            phase_rad: 0.5,
                        },
                        Effect::Step {
                            t_s: 120.5,
                            size: 0.004,
                        },
                        Effect::GSensitivity {
                            coeffs_per_m_s2: [1e-4, 0.0, -2e-4],
                        },
                        Effect::RateRandomWalk { q_per_s: 1e-10 },
                    ],
                },
                ChannelBiasModel {
                    channel: "ax".into(),
                    method: "fos".into(),
                    sample_rate_hz: 100.0,
                    mean: 0.3,
                    ar: vec![],
                    innovation_var: 1e-3,
                    white_noise_var: 0.0,
                    ar_of: ArOf::Bias,
                    effects: vec![],
                },
            ],
        }
    }

    #[test]
    fn model_toml_round_trips_exactly() {
        let m = example();
        let text = m.to_toml_string().unwrap();
        let back = BiasModelFile::from_toml_str(&text).unwrap();
        assert_eq!(m, back, "TOML:\n{text}");
    }

    #[test]
    fn hand_written_toml_with_inline_effects_parses() {
        let text = r#"
            [[channels]]
            channel = "gx"
            method = "yule_walker"
            sample_rate_hz = 100.0
            mean = 0.001
            ar = [0.9]
            innovation_var = 1e-6
            white_noise_var = 3e-6
            effects = [ { kind = "vibration_line", freq_hz = 12.3, amplitude = 0.02, phase_rad = 0.0 },
                        { kind = "rate_random_walk", q_per_s = 1e-12 } ]
        "#;
        let m = BiasModelFile::from_toml_str(text).unwrap();
        assert_eq!(
            m.channels[0].ar_of,
            ArOf::Signal,
            "ar_of defaults to signal"
        );
        assert_eq!(m.channels[0].effects.len(), 2);
    }

    #[test]
    fn unknown_fields_are_rejected() {
        let text = r#"
            [[channels]]
            channel = "gx"
            method = "burg"
            sample_rate_hz = 100.0
            mean = 0.0
            ar = []
            innovation_var = 1e-6
            white_noise_var = 0.0
            colour = "blue"
        "#;
        assert!(matches!(
            BiasModelFile::from_toml_str(text),
            Err(BiasModelError::Parse(_))
        ));
        let text_effect = r#"
            [[channels]]
            channel = "gx"
            method = "burg"
            sample_rate_hz = 100.0
            mean = 0.0
            ar = []
            innovation_var = 1e-6
            white_noise_var = 0.0
            effects = [ { kind = "step", t_s = 1.0, size = 0.1, extra = 2 } ]
        "#;
        assert!(matches!(
            BiasModelFile::from_toml_str(text_effect),
            Err(BiasModelError::Parse(_))
        ));
    }

    #[test]
    fn validation_lists_every_problem_with_its_key() {
        let mut m = example();
        m.channels[0].ar = vec![1.5]; // non-stationary
        m.channels[0].innovation_var = -1.0;
        m.channels[1].effects.push(Effect::GSensitivity {
            coeffs_per_m_s2: [0.0; 3],
        }); // accel
        m.channels[1].effects.push(Effect::VibrationLine {
            freq_hz: 70.0,
            amplitude: 1.0,
            phase_rad: 0.0,
        });
        m.channels.push(m.channels[1].clone()); // duplicate "ax"
        let errs = m.validate().unwrap_err();
        let joined = errs.join("\n");
        for key in [
            "channels[0].ar:",
            "channels[0].innovation_var:",
            "channels[1].effects[0]: g_sensitivity",
            "channels[1].effects[1].freq_hz:",
            "channels[2].channel: `ax` appears more than once",
        ] {
            assert!(joined.contains(key), "missing `{key}` in:\n{joined}");
        }
    }
}
