//! `[temperature]`: the temperature the sensor sees over time, and how it reports it.

use serde::Deserialize;

/// Temperature the sensor sees, and how it reports it.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TemperatureConfig {
    /// Resolution of the reported temperature, °C (0 = unquantised).
    #[serde(default)]
    pub resolution_c: f64,
    /// White noise on the reported temperature, °C (1σ).
    #[serde(default)]
    pub noise_sd_c: f64,
    pub profile: TemperatureProfile,
}

/// True temperature over time.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TemperatureProfile {
    Constant {
        temp_c: f64,
    },
    /// Linear from `start_c` to `end_c` between `start_s` and `start_s + duration_s`, flat
    /// outside.
    Ramp {
        start_c: f64,
        end_c: f64,
        #[serde(default)]
        start_s: f64,
        duration_s: f64,
    },
    /// Self-heating after power-on: T = ambient + rise · (1 − e^(−t/τ)).
    WarmUp {
        ambient_c: f64,
        rise_c: f64,
        tau_s: f64,
    },
    /// Chamber set-point steps; the sensor follows each step with a first-order lag `tau_s`
    /// (0 = instantly).
    Steps {
        initial_c: f64,
        steps: Vec<TemperatureStep>,
        #[serde(default)]
        tau_s: f64,
    },
}

/// One set-point change of a [`TemperatureProfile::Steps`] profile.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TemperatureStep {
    pub t_s: f64,
    pub to_c: f64,
}
