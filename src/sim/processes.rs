//! The stochastic bias processes, discretised exactly at the sample interval Δt.
//!
//! * **First-order Gauss-Markov** ḃ = −b/τ + w: exact discretisation
//!   b[n+1] = φ b[n] + σ √(1 − φ²) w[n],  φ = e^(−Δt/τ),  w ~ N(0,1),
//!   started from the stationary N(0, σ²) so that the autocovariance is σ² e^(−|lag|/τ) from
//!   the first sample (Gelb, *Applied Optimal Estimation*, 1974, §3.8; the Sensors 2012 paper,
//!   eq. 9, uses the forward-Euler form φ ≈ 1 − Δt/τ, which is exact only as Δt/τ → 0).
//! * **AR(p)** b[n] = Σᵢ φᵢ b[n−i] + e[n], e ~ N(0, s²): stationary iff every reflection
//!   coefficient of the step-down (inverse Levinson-Durbin) recursion has |k| < 1
//!   (Box, Jenkins & Reinsel, *Time Series Analysis*, §3.2; Tamazin 2013, eqs. 1–13, fits this
//!   model). It starts from its exact stationary distribution N(0, Γ_p), Γ_p the Toeplitz matrix
//!   of the autocovariances γ₀…γ_{p−1}, which solve γ_k − Σᵢ φᵢ γ_{|k−i|} = s² δ_k, k = 0…p.
//! * **Random walk** b[n+1] = b[n] + K √Δt w[n], b[0] = 0: its Allan deviation is
//!   K √(τ/3) (IEEE Std 952-1997, annex C), K in signal/√s.

use crate::rng::Rng;
use crate::sample::N_CHANNELS;
use crate::stats::ar_poly::ar_autocovariance;
use nalgebra::{DMatrix, DVector};

/// Largest AR order supported (fixed-size per-sample state).
pub const MAX_AR_ORDER: usize = 16;

/// Six first-order Gauss-Markov processes sharing one correlation time.
#[derive(Clone, Debug)]
pub struct GaussMarkov6 {
    phi: f64,
    drive_sd: [f64; N_CHANNELS],
    state: [f64; N_CHANNELS],
}

impl GaussMarkov6 {
    /// σ per channel (signal units), correlation time τ, step Δt; the initial state is drawn
    /// from the stationary distribution with `rng`.
    pub fn new(sigma: [f64; N_CHANNELS], tau_s: f64, dt_s: f64, rng: &mut Rng) -> Self {
        let phi = (-dt_s / tau_s).exp();
        let k = (1.0 - phi * phi).sqrt();
        let mut state = [0.0; N_CHANNELS];
        let mut drive_sd = [0.0; N_CHANNELS];
        for c in 0..N_CHANNELS {
            state[c] = sigma[c] * rng.normal();
            drive_sd[c] = sigma[c] * k;
        }
        GaussMarkov6 {
            phi,
            drive_sd,
            state,
        }
    }

    /// Current value, then advance one step.
    #[inline]
    pub fn step(&mut self, rng: &mut Rng) -> [f64; N_CHANNELS] {
        let out = self.state;
        for c in 0..N_CHANNELS {
            self.state[c] = self.phi * self.state[c] + self.drive_sd[c] * rng.normal();
        }
        out
    }
}

/// Six AR(p) processes; coefficients shared per sensor (gyro channels 0–2, accel 3–5).
#[derive(Clone, Debug)]
pub struct ArBias6 {
    order: [usize; N_CHANNELS],
    coeffs: [[f64; MAX_AR_ORDER]; N_CHANNELS],
    innov_sd: [f64; N_CHANNELS],
    /// hist[c][i] = b[n−1−i] (newest first).
    hist: [[f64; MAX_AR_ORDER]; N_CHANNELS],
}

impl ArBias6 {
    /// `coeffs_gyro`/`coeffs_accel` must be stationary with at most [`MAX_AR_ORDER`] terms
    /// (checked by validation). Starts from the stationary distribution.
    pub fn new(
        coeffs_gyro: &[f64],
        coeffs_accel: &[f64],
        innov_sd: [f64; N_CHANNELS],
        rng: &mut Rng,
    ) -> Self {
        let mut s = ArBias6 {
            order: [0; N_CHANNELS],
            coeffs: [[0.0; MAX_AR_ORDER]; N_CHANNELS],
            innov_sd,
            hist: [[0.0; MAX_AR_ORDER]; N_CHANNELS],
        };
        for (c, sd) in innov_sd.iter().enumerate() {
            let co = if c < 3 { coeffs_gyro } else { coeffs_accel };
            let p = co.len().min(MAX_AR_ORDER);
            s.order[c] = p;
            s.coeffs[c][..p].copy_from_slice(&co[..p]);
            if p == 0 || *sd == 0.0 {
                continue;
            }
            // Exact stationary start: hist ~ N(0, Γ_p) via Cholesky of the Toeplitz matrix.
            let Some(gamma) = ar_autocovariance(&co[..p], sd * sd, p) else {
                continue;
            };
            let gm = DMatrix::from_fn(p, p, |i, j| gamma[i.abs_diff(j)]);
            let z = DVector::from_fn(p, |_, _| rng.normal());
            if let Some(ch) = gm.cholesky() {
                let x = ch.l() * z;
                s.hist[c][..p].copy_from_slice(x.as_slice());
            }
        }
        s
    }

    /// Next value b[n] (advances the state).
    #[inline]
    pub fn step(&mut self, rng: &mut Rng) -> [f64; N_CHANNELS] {
        let mut out = [0.0; N_CHANNELS];
        for (c, o) in out.iter_mut().enumerate() {
            let e = rng.normal();
            let p = self.order[c];
            if p == 0 {
                continue;
            }
            let h = &mut self.hist[c];
            let mut b = self.innov_sd[c] * e;
            for (phi, past) in self.coeffs[c][..p].iter().zip(h.iter()) {
                b += phi * past;
            }
            h.copy_within(0..p - 1, 1);
            h[0] = b;
            *o = b;
        }
        out
    }
}

/// Six random walks.
#[derive(Clone, Debug)]
pub struct RandomWalk6 {
    step_sd: [f64; N_CHANNELS],
    state: [f64; N_CHANNELS],
}

impl RandomWalk6 {
    /// `k_per_sqrt_s`: K in signal units per √s; per-step increment σ = K √Δt.
    pub fn new(k_per_sqrt_s: [f64; N_CHANNELS], dt_s: f64) -> Self {
        RandomWalk6 {
            step_sd: k_per_sqrt_s.map(|k| k * dt_s.sqrt()),
            state: [0.0; N_CHANNELS],
        }
    }

    /// Current value, then advance one step.
    #[inline]
    pub fn step(&mut self, rng: &mut Rng) -> [f64; N_CHANNELS] {
        let out = self.state;
        for c in 0..N_CHANNELS {
            self.state[c] += self.step_sd[c] * rng.normal();
        }
        out
    }
}
