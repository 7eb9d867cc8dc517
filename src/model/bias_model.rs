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

/// `b += c1 (T_l - t0) + c2 (T_l - t0)^2`, where `T_l` is the sensor temperature (°C) passed
/// through a first-order lag `dT_l/dt = (T - T_l) / lag_s` (`lag_s = 0`: no lag). Written in a
/// model file as `kind = "temperature"` with these four keys.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureTerm {
    /// Reference temperature, °C.
    pub t0_c: f64,
    /// Linear coefficient, unit/°C.
    pub c1_per_c: f64,
    /// Quadratic coefficient, unit/°C².
    pub c2_per_c2: f64,
    /// Thermal lag time constant, s (≥ 0).
    pub lag_s: f64,
}

impl TemperatureTerm {
    /// Every problem with the term, each under `key` (`….effects[j]`).
    fn check(&self, errors: &mut Vec<String>, key: &str) {
        finite(errors, &format!("{key}.t0_c"), self.t0_c);
        finite(errors, &format!("{key}.c1_per_c"), self.c1_per_c);
        finite(errors, &format!("{key}.c2_per_c2"), self.c2_per_c2);
        non_negative(errors, &format!("{key}.lag_s"), self.lag_s);
    }
}

impl std::fmt::Display for TemperatureTerm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "temperature c1 = {:.4e}/°C, c2 = {:.4e}/°C² about T0 = {:.2} °C, lag {:.1} s",
            self.c1_per_c, self.c2_per_c2, self.t0_c, self.lag_s
        )
    }
}

/// An effect on a channel's bias. Online semantics are those of [`crate::stage::bias`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Effect {
    /// A temperature term ([`TemperatureTerm`]).
    Temperature(TemperatureTerm),
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

/// [`finite`], then `v > 0`.
fn positive(errors: &mut Vec<String>, key: &str, v: f64) {
    if finite(errors, key, v) && v <= 0.0 {
        errors.push(format!("{key}: must be > 0 (got {v})"));
    }
}

/// [`finite`], then `v ≥ 0`.
fn non_negative(errors: &mut Vec<String>, key: &str, v: f64) {
    if finite(errors, key, v) && v < 0.0 {
        errors.push(format!("{key}: must be >= 0 (got {v})"));
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
        positive(
            errors,
            &format!("{key}.sample_rate_hz"),
            self.sample_rate_hz,
        );
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
        positive(
            errors,
            &format!("{key}.innovation_var"),
            self.innovation_var,
        );
        non_negative(
            errors,
            &format!("{key}.white_noise_var"),
            self.white_noise_var,
        );
        let nyquist = 0.5 * self.sample_rate_hz;
        let mut n_temperature = 0;
        let mut n_gsens = 0;
        for (j, e) in self.effects.iter().enumerate() {
            let ek = format!("{key}.effects[{j}]");
            match *e {
                Effect::Temperature(term) => {
                    n_temperature += 1;
                    term.check(errors, &ek);
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
                    non_negative(errors, &format!("{ek}.amplitude"), amplitude);
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
                    non_negative(errors, &format!("{ek}.q_per_s"), q_per_s);
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
#[path = "bias_model_tests.rs"]
mod tests;
