//! ARIMA(p, d, q) with a constant: identification, conditional-sum-of-squares estimation, the model
//! file, and the fixed-size one-step predictor shared by the offline tools and the online
//! gross-error stage (Chen, Li & Zhang 2013, §1–2; Box & Jenkins, *Time Series Analysis*, ch. 6–7).
//!
//! Model (differenced series `w_t = ∇^d x_t`, d ∈ {0, 1}; MA sign as Box–Jenkins-with-plus /
//! statsmodels — the paper's eq. (1) writes `−θ`, i.e. its θ is our −θ):
//!
//! ```text
//!   w_t = c + Σ_{i=1}^{p} φ_i w_{t−i} + e_t + Σ_{j=1}^{q} θ_j e_{t−j},   e_t ~ N(0, σ²)
//! ```
//!
//! `c` is the intercept (`constant`); the process mean is `μ = c / (1 − Σφ_i)`; for d = 1, `c` is a
//! drift per sample.
//!
//! **Estimation — conditional sum of squares (CSS).** Conditioning on the first `m ≥ p` values of
//! `w` and on `e_t = 0` for `t < m`, the residuals follow the recursion above solved for `e_t`, and
//! `S(β) = Σ_{t=m}^{n−1} e_t²` is minimised over `β = (c, φ, θ)` by Levenberg–Marquardt:
//! `(JᵀJ + λ diag JᵀJ) δ = −Jᵀe`, with the Jacobian from the recursions
//! `∂e_t/∂c = −1 − Σθ_j ∂e_{t−j}/∂c`, `∂e_t/∂φ_i = −w_{t−i} − Σθ_j ∂e_{t−j}/∂φ_i`,
//! `∂e_t/∂θ_k = −e_{t−k} − Σθ_j ∂e_{t−j}/∂θ_k`; JᵀJ and Jᵀe are accumulated on the fly (no n×k
//! matrix). Steps that leave the stationary (AR) or invertible (MA) region — tested by the
//! Schur–Cohn step-down recursion, all reflection coefficients |κ| < 1 − margin — are rejected like
//! steps that increase S. For q = 0 the problem is linear and LM converges in one step to OLS.
//!
//! **Initial values — Hannan & Rissanen (1982).** A long AR(m), `m = min(max(⌊(ln n)²⌋, 2 max(p, q)),
//! n/10)`, is fitted by Durbin–Levinson on the sample autocovariances; its residuals `ê_t` stand in
//! for the innovations in the OLS regression `w_t ~ 1, w_{t−1..p}, ê_{t−1..q}`. Inadmissible
//! starting polynomials are shrunk (`a_i ← 0.9^i a_i`, which moves every root outward) until they pass.
//!
//! **Innovation variance and AIC.** `σ̂² = S / n_r` (n_r = n − m residuals); the conditional Gaussian
//! log-likelihood gives `AIC = n_r (ln(2π σ̂²) + 1) + 2 (p + q + 2)` (+2: constant and σ²). In the
//! order search every candidate is conditioned on the same `m = p_max` values so the AICs compare
//! like with like.
//!
//! **Identification** (the paper's §2.1–2.4): ADF on x (constant, AIC lag rule, see
//! [`crate::stats::adf`]) — unit root rejected at `adf_alpha` ⇒ d = 0, else d = 1; ACF/PACF of
//! `w` with ±1.96/√n bounds, giving the classical suggestions (p = last significant PACF lag ≤ p_max,
//! q = last significant ACF lag ≤ q_max); the order is then the minimum AIC over the full grid
//! `p ≤ p_max, q ≤ q_max` (the paper uses AIC to choose among the ACF/PACF candidates; the full grid
//! contains them); residual diagnosis by Ljung–Box (dof = lags − p − q) and residual ACF/PACF.

// `!(v > 0.0)` is used on purpose throughout: unlike `v <= 0.0` it is also true for NaN, so a
// single guard rejects both non-positive and NaN input.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::stats::acf::{LjungBox, acf, acf_bound_95, ljung_box, pacf_from_acf};
use crate::stats::adf::{AdfLag, AdfResult, adf};
pub use crate::stats::ar_poly::is_stable;
use crate::stats::ar_poly::levinson_partial;
use crate::stats::{NumError, check_finite, check_series};

mod file;
mod fit;
mod identify;
mod predictor;
#[cfg(test)]
mod tests;

pub use file::*;
pub use fit::*;
pub use identify::*;
pub use predictor::*;

/// Largest AR order the online predictor holds.
pub const MAX_P: usize = 3;
/// Largest differencing order the online predictor holds.
pub const MAX_D: usize = 1;
/// Largest MA order the online predictor holds.
pub const MAX_Q: usize = 2;
/// Largest orders accepted by the offline fitter.
pub const MAX_FIT_ORDER: usize = 10;

/// AR roots must stay this far inside the stationary region (reflection coefficients).
const AR_MARGIN: f64 = 1e-6;
/// MA reflection coefficients are kept ≤ 0.999 so the innovation recursion forgets its start
/// within ~10³ samples, which the online predictor relies on after a re-seed.
const MA_MARGIN: f64 = 1e-3;

/// First `d`-th difference (d ∈ {0, 1, 2, …}).
pub fn difference(x: &[f64], d: usize) -> Vec<f64> {
    let mut w = x.to_vec();
    for _ in 0..d {
        w = w.windows(2).map(|v| v[1] - v[0]).collect();
    }
    w
}

/// AR polynomial stationary (margin [`AR_MARGIN`]).
pub fn ar_is_stationary(phi: &[f64]) -> bool {
    is_stable(phi, AR_MARGIN)
}

/// MA polynomial `1 + Σ θ_j z^j` invertible (margin [`MA_MARGIN`]).
pub fn ma_is_invertible(theta: &[f64]) -> bool {
    let a: Vec<f64> = theta.iter().map(|t| -t).collect();
    is_stable(&a, MA_MARGIN)
}

/// Shrink `a_i ← 0.9^i a_i` until `ok(a)`; each shrink divides every root's modulus by 0.9.
fn shrink_until(a: &mut [f64], ok: impl Fn(&[f64]) -> bool) {
    for _ in 0..200 {
        if ok(a) {
            return;
        }
        let mut f = 1.0;
        for v in a.iter_mut() {
            f *= 0.9;
            *v *= f;
        }
    }
    a.iter_mut().for_each(|v| *v = 0.0);
}

/// Why an ARIMA model could not be identified, fitted, loaded or used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ArimaError {
    /// The series is too short, non-finite or constant, or a system is singular (the shared
    /// numerical vocabulary, [`NumError`]), in the fit or in a statistic used during identification.
    #[error(transparent)]
    Numeric(#[from] NumError),
    /// Model order outside what the caller supports.
    #[error("bad model order: {0}")]
    BadOrder(String),
    /// A model (e.g. loaded from TOML) that is inconsistent or not usable.
    #[error("invalid model: {0}")]
    InvalidModel(String),
    /// Settings that failed validation (all problems listed).
    #[error("invalid settings: {}", .0.join("; "))]
    InvalidSettings(Vec<String>),
    /// A model file that does not parse or serialise.
    #[error("model file: {0}")]
    Toml(String),
}
