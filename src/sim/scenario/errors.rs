//! `[errors]`: the sensor error effects (noise, biases and their wander, scale, misalignment,
//! g-sensitivity, temperature, lines, steps, gross errors, saturation, quantisation).

use super::default_true;
use serde::Deserialize;

/// All sensor error effects. An absent table (or `enabled = false`) switches an effect off.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ErrorsConfig {
    #[serde(default)]
    pub white_noise: Option<WhiteNoise>,
    #[serde(default)]
    pub turn_on_bias: Option<TurnOnBias>,
    #[serde(default)]
    pub scale_factor: Option<ScaleFactor>,
    #[serde(default)]
    pub misalignment: Option<Misalignment>,
    #[serde(default)]
    pub g_sensitivity: Option<GSensitivity>,
    /// Bias instability as a sum of first-order Gauss-Markov processes.
    #[serde(default)]
    pub gauss_markov: Vec<GaussMarkov>,
    #[serde(default)]
    pub ar_bias: Option<ArBias>,
    #[serde(default)]
    pub random_walk: Option<RandomWalk>,
    #[serde(default)]
    pub temperature: Option<TemperatureBias>,
    #[serde(default)]
    pub vibration_lines: Vec<VibrationLine>,
    #[serde(default)]
    pub steps: Vec<BiasStep>,
    #[serde(default)]
    pub gross: Option<GrossErrors>,
    #[serde(default)]
    pub saturation: Option<Saturation>,
    #[serde(default)]
    pub quantisation: Option<Quantisation>,
}

/// White measurement noise, specified by its Allan-deviation coefficient.
/// Per-sample σ = N · √(rate), with N the ARW in rad/√s (= deg/√h · π/180 / 60).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WhiteNoise {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Angle random walk per gyro axis, deg/√h.
    #[serde(default)]
    pub arw_deg_sqrt_h: [f64; 3],
    /// Velocity random walk per accel axis, m/s/√h.
    #[serde(default)]
    pub vrw_m_s_sqrt_h: [f64; 3],
}

/// Constant bias present from power-on: fixed values plus an optional per-seed random part
/// (run-to-run repeatability).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TurnOnBias {
    #[serde(default = "default_true")]
    pub enabled: bool,
    #[serde(default)]
    pub gyro_deg_s: [f64; 3],
    #[serde(default)]
    pub accel_mg: [f64; 3],
    /// 1σ of a random turn-on bias drawn once per seed, deg/s.
    #[serde(default)]
    pub gyro_sd_deg_s: [f64; 3],
    /// 1σ of a random turn-on bias drawn once per seed, mg.
    #[serde(default)]
    pub accel_sd_mg: [f64; 3],
}

/// Scale-factor error: component = s · input.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScaleFactor {
    #[serde(default = "default_true")]
    pub enabled: bool,
    #[serde(default)]
    pub gyro_ppm: [f64; 3],
    #[serde(default)]
    pub accel_ppm: [f64; 3],
}

/// Small-angle axis misalignment / cross-axis sensitivity: component = M · input, M with zero
/// diagonal; row i, column j = sensitivity of axis i to input on axis j.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Misalignment {
    #[serde(default = "default_true")]
    pub enabled: bool,
    #[serde(default)]
    pub gyro_mrad: [[f64; 3]; 3],
    #[serde(default)]
    pub accel_mrad: [[f64; 3]; 3],
}

/// Gyro g-sensitivity: gyro bias = K · f, f the specific force (gravity included) in g.
/// Row i = gyro axis i, column j = accel axis j.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GSensitivity {
    #[serde(default = "default_true")]
    pub enabled: bool,
    pub deg_s_per_g: [[f64; 3]; 3],
}

/// One first-order Gauss-Markov process per channel, all with correlation time `tau_s`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GaussMarkov {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Correlation time, s.
    pub tau_s: f64,
    /// Stationary 1σ per gyro axis, deg/h.
    #[serde(default)]
    pub gyro_sigma_deg_h: [f64; 3],
    /// Stationary 1σ per accel axis, mg.
    #[serde(default)]
    pub accel_sigma_mg: [f64; 3],
}

/// Coloured bias b[n] = Σ φ_i b[n−i] + e[n]; the coefficients are shared by the three axes
/// of a sensor, the innovation σ is per axis. Must be stationary.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ArBias {
    #[serde(default = "default_true")]
    pub enabled: bool,
    #[serde(default)]
    pub gyro_coeffs: Vec<f64>,
    /// Innovation 1σ per gyro axis, deg/h.
    #[serde(default)]
    pub gyro_innovation_sd_deg_h: [f64; 3],
    #[serde(default)]
    pub accel_coeffs: Vec<f64>,
    /// Innovation 1σ per accel axis, mg.
    #[serde(default)]
    pub accel_innovation_sd_mg: [f64; 3],
}

/// Rate random walk (gyro) and acceleration random walk: b[n+1] = b[n] + K·√Δt·w, b[0] = 0.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RandomWalk {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Rate random walk K per gyro axis, deg/h/√h.
    #[serde(default)]
    pub gyro_deg_h_sqrt_h: [f64; 3],
    /// Acceleration random walk K per accel axis, m/s/h/√h.
    #[serde(default)]
    pub accel_m_s_h_sqrt_h: [f64; 3],
}

/// Temperature-dependent bias b = c1 (T − T0) + c2 (T − T0)², T the sensor temperature seen
/// through an optional first-order lag (the die lags the package).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TemperatureBias {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Reference temperature, °C.
    pub t0_c: f64,
    /// First-order lag of the temperature that drives the bias, s (0 = none).
    #[serde(default)]
    pub lag_tau_s: f64,
    #[serde(default)]
    pub gyro_deg_s_per_c: [f64; 3],
    #[serde(default)]
    pub gyro_deg_s_per_c2: [f64; 3],
    #[serde(default)]
    pub accel_mg_per_c: [f64; 3],
    #[serde(default)]
    pub accel_mg_per_c2: [f64; 3],
}

/// A sinusoidal error line A sin(2π f t + φ) (e.g. a nearby motor, a PWM supply ripple), from
/// `start_s` on, its frequency drifting by `drift_hz_per_s`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VibrationLine {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Frequency, Hz (any value below Nyquist; need not sit on an FFT bin).
    pub freq_hz: f64,
    #[serde(default)]
    pub phase_deg: f64,
    /// Amplitude per gyro axis, deg/s.
    #[serde(default)]
    pub gyro_amp_deg_s: [f64; 3],
    /// Amplitude per accel axis, mg.
    #[serde(default)]
    pub accel_amp_mg: [f64; 3],
    /// The line is there from this time on, s (0: from the start; a motor switched on later).
    #[serde(default)]
    pub start_s: f64,
    /// Its frequency changes by this much per second from `start_s` on, Hz/s (0: constant; a
    /// fan or an engine whose speed drifts): sin(2π (f τ + d τ²/2) + φ), τ = t − `start_s`.
    #[serde(default)]
    pub drift_hz_per_s: f64,
}

/// A bias step of the given size from `t_s` on.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BiasStep {
    #[serde(default = "default_true")]
    pub enabled: bool,
    pub t_s: f64,
    #[serde(default)]
    pub gyro_deg_s: [f64; 3],
    #[serde(default)]
    pub accel_mg: [f64; 3],
}

/// Gross errors (outliers): single spikes and runs of successive bad samples.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GrossErrors {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Probability per sample and channel that an event starts (when none is in progress).
    pub rate_per_sample: f64,
    /// Amplitude range [min, max] in units of the channel's white-noise σ, drawn uniformly per
    /// sample; the sign is drawn once per event.
    pub amplitude_sigma: [f64; 2],
    /// Fraction of events that are runs (length uniform in 2..=max_run_len) instead of spikes.
    #[serde(default)]
    pub run_fraction: f64,
    /// Longest run, samples (2..=10).
    #[serde(default = "default_max_run")]
    pub max_run_len: u32,
    /// Channels affected (default: all six).
    #[serde(default)]
    pub channels: Option<Vec<String>>,
    /// σ unit for gyro amplitudes, deg/s (default: the white-noise σ per sample; set it when
    /// white noise is off, or to size spikes against a larger innovation σ, e.g. road vibration).
    #[serde(default)]
    pub gyro_sigma_deg_s: Option<f64>,
    /// σ unit for accel amplitudes, mg (default: the white-noise σ per sample).
    #[serde(default)]
    pub accel_sigma_mg: Option<f64>,
}
fn default_max_run() -> u32 {
    10
}

/// Clip at the sensor's full-scale range (`sensor.*_range_*`) and flag the clipped axes.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Saturation {
    #[serde(default = "default_true")]
    pub enabled: bool,
}

/// Output quantisation: y = LSB · round(x / LSB).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Quantisation {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Gyro LSB, deg/s (e.g. 1/131 for ±250 deg/s on 16 bits).
    pub gyro_lsb_deg_s: f64,
    /// Accel LSB, mg (e.g. 1000/4096 for ±8 g on 16 bits).
    pub accel_lsb_mg: f64,
}
