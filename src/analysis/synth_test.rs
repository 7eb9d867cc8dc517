//! Test-only generator of one channel with known truth (the project's simulator replaces it):
//! white noise + a first-order Gauss–Markov bias + optional undeclared effects, with a
//! temperature warm-up curve and a drive-like specific force always present as exogenous series.
//!
//! GM bias: b_n = φ b_{n−1} + σ_b √(1 − φ²) w_n, φ = e^{−Δt/τ} (stationary sd σ_b).
//! Temperature: T(t) = 40 − 25 e^{−t/300 s} + 1.5 sin(2πt/120 s) + 0.005 °C white (a device
//! warming up in a room whose thermostat cycles; the cycle makes a thermal lag identifiable).
//! Specific force: f_x, f_y, f_z = −g + GM accelerations (drive: surge, sway, heave/bumps).
//! Each random part has its own `Rng::fork` stream, so the clean twin (`y − effect`) has the
//! same noise as the log with the effect.

use crate::rng::Rng;
use std::f64::consts::PI;

pub(crate) struct SynthSpec {
    pub seed: u64,
    pub n: usize,
    pub rate_hz: f64,
    pub white_sd: f64,
    pub gm_sd: f64,
    pub gm_tau_s: f64,
    /// (freq_hz, amplitude, phase_rad)
    pub line: Option<(f64, f64, f64)>,
    /// (t0_c, c1_per_c, c2_per_c2, lag_s)
    pub temperature: Option<(f64, f64, f64, f64)>,
    /// (t_s, size)
    pub step: Option<(f64, f64)>,
    /// coefficients per m/s² on the specific force (gravity included)
    pub gsens: Option<[f64; 3]>,
    /// random-walk variance rate, units²/s
    pub rrw_q_per_s: Option<f64>,
}

impl SynthSpec {
    /// White noise sd 1 + GM bias sd 0.5, τ = 0.05 s (AR(1) φ = 0.82, which AR(p ≤ 20) holds:
    /// its ARMA(1,1) form has AR(∞) weights decaying as 0.69^k), 10 min at 100 Hz, no effect.
    pub fn clean(seed: u64) -> Self {
        SynthSpec {
            seed,
            n: 60_000,
            rate_hz: 100.0,
            white_sd: 1.0,
            gm_sd: 0.5,
            gm_tau_s: 0.05,
            line: None,
            temperature: None,
            step: None,
            gsens: None,
            rrw_q_per_s: None,
        }
    }
}

pub(crate) struct SynthLog {
    pub y: Vec<f64>,
    /// The summed contribution of the undeclared effects.
    pub effect: Vec<f64>,
    pub temperature_c: Vec<f64>,
    pub specific_force: [Vec<f64>; 3],
}

impl SynthLog {
    /// The same log without its effects (same noise streams).
    pub fn clean_twin(&self) -> Vec<f64> {
        self.y
            .iter()
            .zip(&self.effect)
            .map(|(a, b)| a - b)
            .collect()
    }
}

fn gm(rng: &mut Rng, n: usize, sd: f64, tau_s: f64, rate_hz: f64) -> Vec<f64> {
    let phi = (-1.0 / (tau_s * rate_hz)).exp();
    let drive = sd * (1.0 - phi * phi).sqrt();
    let mut b = sd * rng.normal();
    (0..n)
        .map(|_| {
            b = phi * b + drive * rng.normal();
            b
        })
        .collect()
}

pub(crate) fn generate(s: &SynthSpec) -> SynthLog {
    let n = s.n;
    let dt = 1.0 / s.rate_hz;
    let mut wr = Rng::fork(s.seed, 1);
    let mut br = Rng::fork(s.seed, 2);
    let mut tr = Rng::fork(s.seed, 3);
    let mut ar = Rng::fork(s.seed, 4);
    let mut rr = Rng::fork(s.seed, 5);
    let bias = gm(&mut br, n, s.gm_sd, s.gm_tau_s, s.rate_hz);
    let temperature_c: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            40.0 - 25.0 * (-t / 300.0).exp()
                + 1.5 * (2.0 * PI * t / 120.0).sin()
                + 0.005 * tr.normal()
        })
        .collect();
    let fx = gm(&mut ar, n, 1.5, 2.0, s.rate_hz);
    let fy = gm(&mut ar, n, 1.0, 3.0, s.rate_hz);
    let fz: Vec<f64> = gm(&mut ar, n, 0.7, 0.2, s.rate_hz)
        .iter()
        .map(|v| v - 9.81)
        .collect();
    let mut effect = vec![0.0; n];
    if let Some((f, a, ph)) = s.line {
        for (i, e) in effect.iter_mut().enumerate() {
            *e += a * (2.0 * PI * f * i as f64 * dt + ph).sin();
        }
    }
    if let Some((t0, c1, c2, lag_s)) = s.temperature {
        let lag = (lag_s * s.rate_hz).round() as usize;
        for (i, e) in effect.iter_mut().enumerate() {
            // The die follows the measured temperature with a pure delay here.
            let d = temperature_c[i.saturating_sub(lag)] - t0;
            *e += c1 * d + c2 * d * d;
        }
    }
    if let Some((t_s, size)) = s.step {
        for (i, e) in effect.iter_mut().enumerate() {
            if i as f64 * dt >= t_s {
                *e += size;
            }
        }
    }
    if let Some(k) = s.gsens {
        for (i, e) in effect.iter_mut().enumerate() {
            *e += k[0] * fx[i] + k[1] * fy[i] + k[2] * fz[i];
        }
    }
    if let Some(q) = s.rrw_q_per_s {
        let sd = (q * dt).sqrt();
        let mut rw = 0.0;
        for e in effect.iter_mut() {
            rw += sd * rr.normal();
            *e += rw;
        }
    }
    let y = (0..n)
        .map(|i| s.white_sd * wr.normal() + bias[i] + effect[i])
        .collect();
    SynthLog {
        y,
        effect,
        temperature_c,
        specific_force: [fx, fy, fz],
    }
}
