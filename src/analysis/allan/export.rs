//! The Allan terms as the numbers three consumers read.
//!
//! **Kalibr `imu.yaml`** (also what VINS-Mono/-Fusion call `acc_n gyr_n acc_w gyr_w`, and
//! OpenVINS' `kalibr_imu_chain.yaml` per IMU): continuous-time values,
//! `*_noise_density` = N (the −½ line at τ = 1 s; rad/s/√Hz, m/s²/√Hz) and `*_random_walk` = K
//! (the +½ line at τ = 3 s; rad/s²/√Hz, m/s³/√Hz); a consumer discretises them with
//! `update_rate` (σ_d = density·√rate, σ_bd = walk/√rate). One value per sensor: the **largest**
//! of the three axes — a filter that under-states a noise is overconfident, one that over-states
//! it only loses a little; per-axis values are in the report. A random walk the record does not
//! resolve on an axis enters as its upper bound and the file says so.
//!
//! **GNSS_IMU config** (rtklibexplorer's loosely coupled filter, `<run>_config.py`):
//! `gyro_noise_PSD` deg/s/√Hz = N_gyro·180/π; `accel_noise_PSD` µg/√Hz = N_acc/(g₀·10⁻⁶);
//! `gyro_bias_PSD` deg/s²/√Hz (= deg/s/√s) = K_gyro·180/π; `accel_bias_PSD` (its comment says
//! µg/√Hz; dimensionally µg/√s) = K_acc/(g₀·10⁻⁶), g₀ = 9.80665 m/s² as in the filter. Same
//! aggregation as Kalibr. The filter turns each value v into the per-step process noise
//! `(v·√rate)²·Δt = v²` (its `imu_noise_factors` aside), which is `rate` times the
//! continuous-time `S·Δt` of Groves (14.82); the file states the values that would give exactly
//! `S·Δt` too (`v/√rate`), as comments, and writes the densities its own config uses.
//!
//! **imuprep bias model** (`[bias] model`, [`crate::model::bias_model`]), per channel, with
//! `ar_of = "bias"` (the bias process itself, used as is by the stage):
//! * bias instability B → a first-order Gauss–Markov bias `ar = [φ]`, placed so that its Allan
//!   peak (σ_A,max = 0.61736 σ_GM at τ = 1.8926 T_c: the Allan variance of a Markov process in IEEE 952 Annex C, maximised) equals the flicker
//!   floor 0.6643 B at the τ where the fitted curve is lowest: `T_c = τ_min/1.8926`,
//!   `σ_GM = 0.6643 B/0.61736`, `φ = exp(−1/(rate·T_c))`, `innovation_var = σ_GM²(1 − φ²)`. An
//!   unresolved B enters as its upper bound (the report says so);
//! * N and Q → `white_noise_var = N²·rate + 2Q²·rate²` (the per-sample variance of white rate
//!   noise plus that of the first difference of white angle noise; the latter's MA(1) colour is
//!   not representable and is dropped);
//! * K (gyros, when resolved) → effect `rate_random_walk` with `q_per_s = K²` (the stage runs it
//!   for gyro channels; for accelerometers it would be ignored, so it is not written);
//! * R (rate ramp) has no place in the format: not exported.

use super::report::{AllanReport, ChannelAllan, G0_M_S2};
use super::terms::{Resolution, Term};
use crate::model::bias_model::{ArOf, BiasModelFile, ChannelBiasModel, Effect};
use serde::Serialize;
use std::fmt::Write;

/// `(2 ln 2 / π)^½`: the flicker floor per unit B.
pub const FLICKER_FLOOR: f64 = 0.664_282_470_267_960_1;
/// τ/T_c at the peak of a first-order Gauss–Markov process's Allan deviation.
pub const GM_PEAK_TAU_PER_TC: f64 = 1.892_618;
/// Peak Allan deviation of a first-order Gauss–Markov process per unit stationary σ.
pub const GM_PEAK_PER_SIGMA: f64 = 0.617_364_3;

/// Allan variance of a first-order Gauss–Markov process of stationary variance `var` and
/// correlation time `tc_s` at τ (IEEE 952 Annex C, correlated noise, with `q_c² = 2 var / T_c`).
pub fn gm_allan_var(var: f64, tc_s: f64, tau_s: f64) -> f64 {
    let x = tau_s / tc_s;
    2.0 * var / x * (1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x))
}

/// One number per sensor, aggregated over its axes.
#[derive(Clone, Debug, Serialize)]
pub struct SensorNoise {
    /// Axes that entered.
    pub axes: Vec<String>,
    /// Largest N over the axes (SI: rad/√s or m/s/√s = unit/√Hz).
    pub noise_density: f64,
    /// Largest K over the axes (SI: rad/s/√s or m/s²/√s).
    pub random_walk: f64,
    /// Axes whose N is an upper bound (not resolved).
    pub noise_density_bounds: Vec<String>,
    /// Axes whose K is an upper bound (not resolved).
    pub random_walk_bounds: Vec<String>,
}

fn term_or_bound(ch: &ChannelAllan, t: Term) -> (f64, bool) {
    let r = ch.fit.term(t);
    match r.value() {
        Some(v) => (v, false),
        None => (r.upper_bound, true),
    }
}

/// Aggregate the gyro (`gyro = true`) or accelerometer axes; `None` if the report has none.
pub fn sensor_noise(report: &AllanReport, gyro: bool) -> Option<SensorNoise> {
    let chans: Vec<&ChannelAllan> = report.channels.iter().filter(|c| c.gyro == gyro).collect();
    if chans.is_empty() {
        return None;
    }
    let mut s = SensorNoise {
        axes: chans.iter().map(|c| c.channel.clone()).collect(),
        noise_density: 0.0,
        random_walk: 0.0,
        noise_density_bounds: vec![],
        random_walk_bounds: vec![],
    };
    for c in chans {
        let (n, nb) = term_or_bound(c, Term::RandomWalk);
        let (k, kb) = term_or_bound(c, Term::RateRandomWalk);
        s.noise_density = s.noise_density.max(n);
        s.random_walk = s.random_walk.max(k);
        if nb {
            s.noise_density_bounds.push(c.channel.clone());
        }
        if kb {
            s.random_walk_bounds.push(c.channel.clone());
        }
    }
    Some(s)
}

fn bound_note(b: &[String]) -> String {
    if b.is_empty() {
        String::new()
    } else {
        format!(
            "  [includes upper bounds: not resolved by the record on {}]",
            b.join(" ")
        )
    }
}

/// Kalibr `imu.yaml` (module docs). Needs gyro and accelerometer channels.
pub fn kalibr_yaml(report: &AllanReport) -> Option<String> {
    let g = sensor_noise(report, true)?;
    let a = sensor_noise(report, false)?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# imuprep allan {} ({} samples, {:.0} s at {} Hz)",
        report.source, report.n_samples, report.duration_s, report.rate_hz
    );
    for w in &report.warnings {
        let _ = writeln!(s, "# WARNING: {w}");
    }
    let _ = writeln!(
        s,
        "# Continuous-time values from the IEEE-952 fit of the overlapping Allan variance:\n\
         #   noise density = N (the -1/2 line at tau = 1 s), random walk = K (the +1/2 line at tau = 3 s).\n\
         # One value per sensor: the largest over the axes ({} / {}); per-axis values in the report.\n\
         # Discrete per sample: sigma_d = density * sqrt(update_rate), sigma_bd = random_walk / sqrt(update_rate).\n\
         # VINS-Mono / VINS-Fusion: acc_n, acc_w, gyr_n, gyr_w take these four values.",
        a.axes.join(" "),
        g.axes.join(" ")
    );
    for (key, v, unit, bounds) in [
        (
            "accelerometer_noise_density",
            a.noise_density,
            "m/s^2/sqrt(Hz)",
            &a.noise_density_bounds,
        ),
        (
            "accelerometer_random_walk",
            a.random_walk,
            "m/s^3/sqrt(Hz)",
            &a.random_walk_bounds,
        ),
        (
            "gyroscope_noise_density",
            g.noise_density,
            "rad/s/sqrt(Hz)",
            &g.noise_density_bounds,
        ),
        (
            "gyroscope_random_walk",
            g.random_walk,
            "rad/s^2/sqrt(Hz)",
            &g.random_walk_bounds,
        ),
    ] {
        let _ = writeln!(s, "{key}: {v:.6e}  # {unit}{}", bound_note(bounds));
    }
    let _ = writeln!(s, "rostopic: /imu0");
    let _ = writeln!(s, "update_rate: {:.6}  # Hz", report.rate_hz);
    Some(s)
}

/// The four noise lines of a GNSS_IMU `<run>_config.py` (module docs). Needs gyro and
/// accelerometer channels.
pub fn gnss_imu_config(report: &AllanReport) -> Option<String> {
    let g = sensor_noise(report, true)?;
    let a = sensor_noise(report, false)?;
    let deg = 180.0 / std::f64::consts::PI;
    let ug = 1.0 / (G0_M_S2 * 1e-6);
    let sr = report.rate_hz.sqrt();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# imuprep allan {}: noise lines for GNSS_IMU's <run>_config.py, in the units its comments give.\n\
         # One value per sensor: the largest over the axes. GNSS_IMU.py uses v as (v*sqrt(imu_sample_rate))^2 * tor_s\n\
         # per IMU step (= v^2), i.e. imu_sample_rate times Groves' (14.82) S*tor_s; the value that gives exactly\n\
         # S*tor_s is shown after 'physical:' (v / sqrt(imu_sample_rate)).",
        report.source
    );
    for w in &report.warnings {
        let _ = writeln!(s, "# WARNING: {w}");
    }
    let _ = writeln!(s, "imu_sample_rate = {}", report.rate_hz);
    let mut line = |name: &str, v: f64, unit: &str, from: &str, bounds: &[String]| {
        let _ = writeln!(
            s,
            "{name} = {v:.6e}  # {unit}: {from}; physical: {:.6e}{}",
            v / sr,
            bound_note(bounds)
        );
    };
    line(
        "gyro_noise_PSD",
        g.noise_density * deg,
        "deg/s/sqrt(Hz)",
        "N of the gyros",
        &g.noise_density_bounds,
    );
    line(
        "accel_noise_PSD",
        a.noise_density * ug,
        "ug/sqrt(Hz)",
        "N of the accelerometers",
        &a.noise_density_bounds,
    );
    line(
        "accel_bias_PSD",
        a.random_walk * ug,
        "ug/sqrt(s) (the config says ug/sqrt(Hz))",
        "K of the accelerometers",
        &a.random_walk_bounds,
    );
    line(
        "gyro_bias_PSD",
        g.random_walk * deg,
        "deg/s^2/sqrt(Hz) = deg/s/sqrt(s)",
        "K of the gyros",
        &g.random_walk_bounds,
    );
    Some(s)
}

/// τ (s) where the fitted model deviation is lowest within the measured τ range (searched on a
/// grid of 64 points per decade).
pub fn tau_of_minimum(ch: &ChannelAllan) -> f64 {
    let p = &ch.fit.points;
    let (a, b) = (p[0].tau_s.log10(), p[p.len() - 1].tau_s.log10());
    let steps = ((b - a) * 64.0).ceil().max(1.0) as usize;
    (0..=steps)
        .map(|i| 10f64.powf(a + (b - a) * i as f64 / steps as f64))
        .min_by(|x, y| ch.fit.model_var(*x).total_cmp(&ch.fit.model_var(*y)))
        .unwrap_or(p[0].tau_s)
}

/// What went into one channel's bias model (for the report).
#[derive(Clone, Debug, Serialize)]
pub struct BiasModelNote {
    pub channel: String,
    /// Gauss–Markov correlation time, s.
    pub tc_s: f64,
    /// Gauss–Markov stationary σ, channel unit.
    pub sigma_gm: f64,
    /// True when B was not resolved and its upper bound was used.
    pub b_is_bound: bool,
    /// True when N was not resolved and its upper bound was used.
    pub n_is_bound: bool,
    /// Rate random walk written (q_per_s = K²), if any.
    pub rrw_q_per_s: Option<f64>,
    /// True when a rate ramp was resolved but could not be written.
    pub ramp_dropped: bool,
}

/// imuprep's bias model file from the terms (module docs), with a note per channel.
pub fn bias_model(report: &AllanReport) -> (BiasModelFile, Vec<BiasModelNote>) {
    let fs = report.rate_hz;
    let mut file = BiasModelFile::default();
    let mut notes = Vec::new();
    for ch in &report.channels {
        let (b, b_is_bound) = term_or_bound(ch, Term::BiasInstability);
        let (n, n_is_bound) = term_or_bound(ch, Term::RandomWalk);
        let q = ch.fit.term(Term::Quantisation).value().unwrap_or(0.0);
        let tc_s = tau_of_minimum(ch) / GM_PEAK_TAU_PER_TC;
        let sigma_gm = FLICKER_FLOOR * b / GM_PEAK_PER_SIGMA;
        let phi = (-1.0 / (fs * tc_s)).exp();
        let rrw = ch
            .fit
            .term(Term::RateRandomWalk)
            .value()
            .filter(|_| ch.gyro)
            .map(|k| k * k);
        file.channels.push(ChannelBiasModel {
            channel: ch.channel.clone(),
            method: "allan".into(),
            sample_rate_hz: fs,
            mean: ch.mean,
            ar: vec![phi],
            innovation_var: sigma_gm * sigma_gm * (1.0 - phi * phi),
            white_noise_var: n * n * fs + 2.0 * q * q * fs * fs,
            ar_of: ArOf::Bias,
            effects: rrw
                .map(|q_per_s| vec![Effect::RateRandomWalk { q_per_s }])
                .unwrap_or_default(),
        });
        notes.push(BiasModelNote {
            channel: ch.channel.clone(),
            tc_s,
            sigma_gm,
            b_is_bound,
            n_is_bound,
            rrw_q_per_s: rrw,
            ramp_dropped: ch.fit.term(Term::RateRamp).resolution == Resolution::Resolved,
        });
    }
    (file, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_markov_peak_constants() {
        // The constants are the maximum of that Allan variance in x = τ/T_c; a fine scan reproduces them
        // to the digits given (4–5 significant).
        let (var, tc) = (1.0, 1.0);
        let (mut best_x, mut best) = (0.0, 0.0);
        for i in 1..200_000 {
            let x = i as f64 * 1e-4;
            let v = gm_allan_var(var, tc, x);
            if v > best {
                best = v;
                best_x = x;
            }
        }
        assert!((best_x - GM_PEAK_TAU_PER_TC).abs() < 1e-3, "{best_x}");
        assert!(
            (best.sqrt() - GM_PEAK_PER_SIGMA).abs() < 1e-4,
            "{}",
            best.sqrt()
        );
        assert!(
            (FLICKER_FLOOR - (2.0 * std::f64::consts::LN_2 / std::f64::consts::PI).sqrt()).abs()
                < 1e-15
        );
    }
}
