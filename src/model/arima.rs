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
//! `analysis::hypothesis`) — unit root rejected at `adf_alpha` ⇒ d = 0, else d = 1; ACF/PACF of
//! `w` with ±1.96/√n bounds, giving the classical suggestions (p = last significant PACF lag ≤ p_max,
//! q = last significant ACF lag ≤ q_max); the order is then the minimum AIC over the full grid
//! `p ≤ p_max, q ≤ q_max` (the paper uses AIC to choose among the ACF/PACF candidates; the full grid
//! contains them); residual diagnosis by Ljung–Box (dof = lags − p − q) and residual ACF/PACF.

// `!(v > 0.0)` is used on purpose throughout: unlike `v <= 0.0` it is also true for NaN, so a
// single guard rejects both non-positive and NaN input.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::stats::NumError;
use crate::stats::acf::{LjungBox, acf, acf_bound_95, ljung_box, pacf_from_acf};
use crate::stats::adf::{AdfLag, AdfResult, adf};
pub use crate::stats::ar_poly::is_stable;
use crate::stats::ar_poly::levinson_partial;

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

/// A fitted ARMA on the differenced series (the output of one CSS fit).
#[derive(Debug, Clone, PartialEq)]
pub struct ArimaFit {
    pub p: usize,
    pub d: usize,
    pub q: usize,
    /// Intercept c of the differenced equation (channel units per sample for d = 1).
    pub constant: f64,
    /// φ_1..φ_p.
    pub ar: Vec<f64>,
    /// θ_1..θ_q (plus sign convention).
    pub ma: Vec<f64>,
    /// Innovation variance S/n_r.
    pub sigma2: f64,
    /// Conditional sum of squares S.
    pub ssr: f64,
    /// Values of w conditioned on (residuals start there).
    pub n_cond: usize,
    /// Residuals used, n_r = len(w) − n_cond.
    pub n_resid: usize,
    /// Conditional-likelihood AIC.
    pub aic: f64,
    /// LM iterations taken.
    pub iterations: usize,
    /// True if LM met its tolerance (false: iteration cap or stuck at the admissibility boundary).
    pub converged: bool,
}

impl ArimaFit {
    /// True if the AR or MA polynomial sits within twice the LM margin of the admissibility
    /// boundary, i.e. LM stopped because the boundary blocked it.
    pub fn at_boundary(&self) -> bool {
        !is_stable(&self.ar, 2.0 * AR_MARGIN)
            || !is_stable(
                &self.ma.iter().map(|t| -t).collect::<Vec<_>>(),
                2.0 * MA_MARGIN,
            )
    }

    /// Process mean of w, `c / (1 − Σφ)`.
    pub fn mean(&self) -> f64 {
        self.constant / (1.0 - self.ar.iter().sum::<f64>())
    }
}

/// Options of the CSS fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CssOptions {
    /// LM iteration cap.
    pub max_iter: usize,
    /// Stop when an accepted step lowers S by less than this fraction.
    pub rel_tol: f64,
}

impl Default for CssOptions {
    fn default() -> Self {
        CssOptions {
            max_iter: 100,
            rel_tol: 1e-12,
        }
    }
}

/// One pass of the CSS recursion: returns S and (if `jac`) accumulates JᵀJ (k×k, row-major) and
/// Jᵀe. `beta = [c, φ_1..φ_p, θ_1..θ_q]`.
fn css_pass(
    w: &[f64],
    beta: &[f64],
    p: usize,
    q: usize,
    n_cond: usize,
    jac: Option<(&mut [f64], &mut [f64])>,
    resid_out: Option<&mut Vec<f64>>,
) -> f64 {
    let k = 1 + p + q;
    let c = beta[0];
    let phi = &beta[1..1 + p];
    let theta = &beta[1 + p..];
    let mut e_lag = [0.0f64; MAX_FIT_ORDER]; // e_{t−1}, e_{t−2}, … (newest first)
    let mut g_lag = [[0.0f64; 1 + 2 * MAX_FIT_ORDER]; MAX_FIT_ORDER];
    let mut g = [0.0f64; 1 + 2 * MAX_FIT_ORDER];
    let mut ssr = 0.0;
    let (mut jtj, mut jte) = match jac {
        Some((a, b)) => {
            a.iter_mut().for_each(|v| *v = 0.0);
            b.iter_mut().for_each(|v| *v = 0.0);
            (Some(a), Some(b))
        }
        None => (None, None),
    };
    let mut resid_out = resid_out;
    for t in n_cond..w.len() {
        let mut e = w[t] - c;
        for i in 0..p {
            e -= phi[i] * w[t - 1 - i];
        }
        for j in 0..q {
            e -= theta[j] * e_lag[j];
        }
        ssr += e * e;
        if let (Some(jtj), Some(jte)) = (jtj.as_deref_mut(), jte.as_deref_mut()) {
            // ∂e_t/∂β: direct term, minus the MA filter of the lagged derivatives.
            g[0] = -1.0;
            for i in 0..p {
                g[1 + i] = -w[t - 1 - i];
            }
            for m in 0..q {
                g[1 + p + m] = -e_lag[m];
            }
            for j in 0..q {
                let th = theta[j];
                for (gi, gl) in g[..k].iter_mut().zip(&g_lag[j][..k]) {
                    *gi -= th * gl;
                }
            }
            for a in 0..k {
                let ga = g[a];
                jte[a] += ga * e;
                let row = &mut jtj[a * k..a * k + k];
                for b in a..k {
                    row[b] += ga * g[b];
                }
            }
            if q > 0 {
                for j in (1..q).rev() {
                    g_lag[j] = g_lag[j - 1];
                }
                g_lag[0] = g;
            }
        }
        if q > 0 {
            for j in (1..q).rev() {
                e_lag[j] = e_lag[j - 1];
            }
            e_lag[0] = e;
        }
        if let Some(r) = resid_out.as_deref_mut() {
            r.push(e);
        }
    }
    if let Some(jtj) = jtj {
        for a in 0..k {
            for b in 0..a {
                jtj[a * k + b] = jtj[b * k + a];
            }
        }
    }
    ssr
}

/// CSS residuals `e_t`, t = n_cond..n−1, of the ARMA with intercept `c` on `w`.
pub fn css_residuals(w: &[f64], c: f64, ar: &[f64], ma: &[f64], n_cond: usize) -> Vec<f64> {
    let mut beta = vec![c];
    beta.extend_from_slice(ar);
    beta.extend_from_slice(ma);
    let mut out = Vec::with_capacity(w.len().saturating_sub(n_cond));
    css_pass(w, &beta, ar.len(), ma.len(), n_cond, None, Some(&mut out));
    out
}

/// Residuals of the Hannan–Rissanen long autoregression (first `start` entries are not defined).
struct LongAr {
    resid: Vec<f64>,
    start: usize,
}

/// Long AR(m) by Durbin–Levinson on the biased autocovariances; residuals from t = m.
fn long_ar(w: &[f64], m: usize) -> Result<LongAr, ArimaError> {
    let r = acf(w, m)?;
    let n = w.len();
    let mean = w.iter().sum::<f64>() / n as f64;
    // Durbin–Levinson coefficients of order m (those reached while the prediction variance
    // stays positive; the rest are 0).
    let a = levinson_partial(&r, m).phi;
    let mut resid = vec![0.0; n];
    for t in m..n {
        let mut e = w[t] - mean;
        for j in 1..=m {
            e -= a[j - 1] * (w[t - j] - mean);
        }
        resid[t] = e;
    }
    Ok(LongAr { resid, start: m })
}

fn long_ar_order(n: usize, p: usize, q: usize) -> usize {
    let ln = (n as f64).ln();
    ((ln * ln).floor() as usize)
        .max(2 * p.max(q))
        .min(n / 10)
        .max(1)
}

/// Hannan–Rissanen starting values `[c, φ, θ]` (admissible).
fn initial_values(
    w: &[f64],
    p: usize,
    q: usize,
    n_cond: usize,
    hr: Option<&LongAr>,
) -> Result<Vec<f64>, ArimaError> {
    let k = 1 + p + q;
    let first = match (q, hr) {
        (0, _) => n_cond,
        (_, Some(h)) => n_cond.max(h.start + q),
        (_, None) => {
            return Err(ArimaError::Singular(
                "Hannan-Rissanen without long AR".into(),
            ));
        }
    };
    if w.len() <= first + k {
        return Err(ArimaError::TooShort {
            needed: first + k + 1,
            got: w.len(),
        });
    }
    // Normal equations of w_t ~ [1, w_{t−1..p}, ê_{t−1..q}] (k ≤ 21, small).
    let mut xtx = DMatrix::<f64>::zeros(k, k);
    let mut xty = DVector::<f64>::zeros(k);
    let mut row = vec![0.0; k];
    for t in first..w.len() {
        row[0] = 1.0;
        for i in 0..p {
            row[1 + i] = w[t - 1 - i];
        }
        if let Some(h) = hr {
            for j in 0..q {
                row[1 + p + j] = h.resid[t - 1 - j];
            }
        }
        for a in 0..k {
            xty[a] += row[a] * w[t];
            for b in a..k {
                xtx[(a, b)] += row[a] * row[b];
            }
        }
    }
    for a in 0..k {
        for b in 0..a {
            xtx[(a, b)] = xtx[(b, a)];
        }
    }
    let beta =
        solve_spd(xtx, xty).ok_or_else(|| ArimaError::Singular("initial regression".into()))?;
    let mut beta: Vec<f64> = beta.iter().copied().collect();
    shrink_until(&mut beta[1..1 + p], ar_is_stationary);
    shrink_until(&mut beta[1 + p..], ma_is_invertible);
    Ok(beta)
}

/// Solve a symmetric positive (semi)definite system with Jacobi scaling and Cholesky.
fn solve_spd(a: DMatrix<f64>, b: DVector<f64>) -> Option<DVector<f64>> {
    let n = a.nrows();
    let d: Vec<f64> = (0..n).map(|i| a[(i, i)].max(0.0).sqrt()).collect();
    if d.iter().any(|v| !(*v > 0.0) || !v.is_finite()) {
        return None;
    }
    let s = DMatrix::from_fn(n, n, |i, j| a[(i, j)] / (d[i] * d[j]));
    let rhs = DVector::from_fn(n, |i, _| b[i] / d[i]);
    let y = s.cholesky()?.solve(&rhs);
    Some(DVector::from_fn(n, |i, _| y[i] / d[i]))
}

fn admissible(beta: &[f64], p: usize) -> bool {
    beta.iter().all(|v| v.is_finite())
        && ar_is_stationary(&beta[1..1 + p])
        && ma_is_invertible(&beta[1 + p..])
}

fn check_input(w: &[f64]) -> Result<(), ArimaError> {
    match w.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(ArimaError::NonFinite { index }),
        None => Ok(()),
    }
}

/// Minimise the CSS of an ARMA(p, q) with intercept on the (already differenced) series `w`,
/// conditioning on the first `n_cond ≥ p` values. `d` is only recorded in the result.
pub fn fit_css(
    w: &[f64],
    p: usize,
    d: usize,
    q: usize,
    n_cond: usize,
    opts: &CssOptions,
) -> Result<ArimaFit, ArimaError> {
    check_input(w)?;
    if p > MAX_FIT_ORDER || q > MAX_FIT_ORDER {
        return Err(ArimaError::BadOrder(format!(
            "p = {p}, q = {q}; the fitter supports up to {MAX_FIT_ORDER}"
        )));
    }
    let hr = if q > 0 {
        Some(long_ar(w, long_ar_order(w.len(), p, q))?)
    } else {
        None
    };
    fit_css_with(w, (p, d, q), n_cond, opts, hr.as_ref(), None)
}

fn fit_css_with(
    w: &[f64],
    (p, d, q): (usize, usize, usize),
    n_cond: usize,
    opts: &CssOptions,
    hr: Option<&LongAr>,
    start: Option<&[f64]>,
) -> Result<ArimaFit, ArimaError> {
    if n_cond < p {
        return Err(ArimaError::BadOrder(format!(
            "conditioning on {n_cond} values cannot support p = {p}"
        )));
    }
    let k = 1 + p + q;
    let mut beta = match start {
        Some(b) if b.len() == k && admissible(b, p) => b.to_vec(),
        _ => initial_values(w, p, q, n_cond, hr)?,
    };
    let mut jtj = vec![0.0; k * k];
    let mut jte = vec![0.0; k];
    let mut ssr = css_pass(w, &beta, p, q, n_cond, Some((&mut jtj, &mut jte)), None);
    if !ssr.is_finite() {
        return Err(ArimaError::Singular("CSS at the initial values".into()));
    }
    let mut lambda = 1e-3;
    let mut converged = false;
    let mut iterations = 0;
    let mut trial = vec![0.0; k];
    let mut jtj_new = vec![0.0; k * k];
    let mut jte_new = vec![0.0; k];
    'outer: while iterations < opts.max_iter {
        iterations += 1;
        loop {
            // Damped normal equations.
            let a = DMatrix::from_fn(k, k, |i, j| {
                let v = jtj[i * k + j];
                if i == j {
                    v * (1.0 + lambda) + 1e-300
                } else {
                    v
                }
            });
            let rhs = DVector::from_fn(k, |i, _| -jte[i]);
            let step = match solve_spd(a, rhs) {
                Some(s) => s,
                None => {
                    lambda *= 10.0;
                    if lambda > 1e16 {
                        converged = true;
                        break 'outer;
                    }
                    continue;
                }
            };
            for i in 0..k {
                trial[i] = beta[i] + step[i];
            }
            let small_step = (0..k).all(|i| step[i].abs() <= 1e-10 * (1.0 + beta[i].abs()));
            if admissible(&trial, p) {
                let s_new = css_pass(
                    w,
                    &trial,
                    p,
                    q,
                    n_cond,
                    Some((&mut jtj_new, &mut jte_new)),
                    None,
                );
                if s_new.is_finite() && s_new <= ssr {
                    let gain = ssr - s_new;
                    beta.copy_from_slice(&trial);
                    std::mem::swap(&mut jtj, &mut jtj_new);
                    std::mem::swap(&mut jte, &mut jte_new);
                    ssr = s_new;
                    lambda = (lambda / 10.0).max(1e-12);
                    if gain <= opts.rel_tol * ssr || small_step {
                        converged = true;
                        break 'outer;
                    }
                    break;
                }
            }
            if small_step {
                // No admissible improvement even for a negligible step: at the optimum (or on
                // the admissibility boundary).
                converged = true;
                break 'outer;
            }
            lambda *= 10.0;
            if lambda > 1e16 {
                converged = true;
                break 'outer;
            }
        }
    }
    let n_resid = w.len() - n_cond;
    let sigma2 = ssr / n_resid as f64;
    if !(sigma2 > 0.0) {
        return Err(ArimaError::Constant);
    }
    let aic = n_resid as f64 * ((2.0 * std::f64::consts::PI * sigma2).ln() + 1.0)
        + 2.0 * (p + q + 2) as f64;
    Ok(ArimaFit {
        p,
        d,
        q,
        constant: beta[0],
        ar: beta[1..1 + p].to_vec(),
        ma: beta[1 + p..].to_vec(),
        sigma2,
        ssr,
        n_cond,
        n_resid,
        aic,
        iterations,
        converged,
    })
}

/// Fit ARIMA(p, d, q) with constant by CSS on `x`, conditioning on the first p differenced values.
pub fn fit_arima(
    x: &[f64],
    p: usize,
    d: usize,
    q: usize,
    opts: &CssOptions,
) -> Result<ArimaFit, ArimaError> {
    check_input(x)?;
    let w = difference(x, d);
    fit_css(&w, p, d, q, p, opts)
}

/// Settings of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifySettings {
    /// Largest AR order in the AIC grid (default 3).
    pub p_max: usize,
    /// Largest MA order in the AIC grid (default 2).
    pub q_max: usize,
    /// Largest differencing order (0 or 1; default 1). d itself comes from the ADF test.
    pub d_max: usize,
    /// ADF significance level: unit root rejected at p < adf_alpha ⇒ d = 0 (default 0.05).
    pub adf_alpha: f64,
    /// ADF lag rule (default: AIC over 0..=⌈12 (N/100)^¼⌉, as statsmodels).
    pub adf_lag: AdfLag,
    /// Lags of the reported ACF/PACF (default 20).
    pub acf_lags: usize,
    /// Ljung–Box lags on the residuals (default 20; dof = lags − p − q).
    pub ljung_box_lags: usize,
    /// LM options.
    pub css: CssOptions,
}

impl Default for IdentifySettings {
    fn default() -> Self {
        IdentifySettings {
            p_max: 3,
            q_max: 2,
            d_max: 1,
            adf_alpha: 0.05,
            adf_lag: AdfLag::default(),
            acf_lags: 20,
            ljung_box_lags: 20,
            css: CssOptions::default(),
        }
    }
}

impl IdentifySettings {
    /// All problems at once (empty = valid).
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut e = Vec::new();
        if self.p_max > MAX_FIT_ORDER {
            e.push(format!("p_max = {} exceeds {MAX_FIT_ORDER}", self.p_max));
        }
        if self.q_max > MAX_FIT_ORDER {
            e.push(format!("q_max = {} exceeds {MAX_FIT_ORDER}", self.q_max));
        }
        if self.d_max > MAX_D {
            e.push(format!("d_max = {} exceeds {MAX_D}", self.d_max));
        }
        if !(self.adf_alpha > 0.0 && self.adf_alpha < 1.0) {
            e.push(format!("adf_alpha = {} must be in (0, 1)", self.adf_alpha));
        }
        if self.acf_lags == 0 {
            e.push("acf_lags must be ≥ 1".into());
        }
        if self.ljung_box_lags <= self.p_max + self.q_max {
            e.push(format!(
                "ljung_box_lags = {} must exceed p_max + q_max = {}",
                self.ljung_box_lags,
                self.p_max + self.q_max
            ));
        }
        if self.css.max_iter == 0 {
            e.push("css.max_iter must be ≥ 1".into());
        }
        if !(self.css.rel_tol >= 0.0 && self.css.rel_tol < 1.0) {
            e.push(format!(
                "css.rel_tol = {} must be in [0, 1)",
                self.css.rel_tol
            ));
        }
        if e.is_empty() { Ok(()) } else { Err(e) }
    }

    /// Shortest series `identify` accepts with these settings.
    pub fn min_len(&self) -> usize {
        // Enough for the long AR (n/10 ≥ 2 max(p,q)), the ACF lags and a few dozen residuals.
        (20 * (self.p_max + self.q_max + 1))
            .max(2 * self.acf_lags + 2)
            .max(2 * self.ljung_box_lags + 2)
            .max(50)
    }
}

/// One row of the AIC table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AicEntry {
    pub p: usize,
    pub q: usize,
    /// Conditional-likelihood AIC (common conditioning on p_max values).
    pub aic: f64,
    /// Innovation standard deviation of this candidate.
    pub sigma: f64,
    /// The fit ended on the admissibility boundary (not eligible; see `identify`).
    #[serde(default)]
    pub at_boundary: bool,
}

/// Everything `identify` found.
#[derive(Debug, Clone, PartialEq)]
pub struct ArimaIdentification {
    /// The chosen model.
    pub fit: ArimaFit,
    /// ADF on the original series.
    pub adf: AdfResult,
    /// Samples in the input.
    pub n_obs: usize,
    /// ACF of w, lags 0..=acf_lags.
    pub acf: Vec<f64>,
    /// PACF of w, lags 0..=acf_lags.
    pub pacf: Vec<f64>,
    /// 95 % white-noise bound ±z/√n of the ACF/PACF of w.
    pub acf_bound: f64,
    /// Last PACF lag ≤ p_max outside the bound (classical AR-order suggestion).
    pub suggested_p: usize,
    /// Last ACF lag ≤ q_max outside the bound (classical MA-order suggestion).
    pub suggested_q: usize,
    /// AIC of every candidate that fitted.
    pub aic_table: Vec<AicEntry>,
    /// Ljung–Box on the chosen model's residuals.
    pub ljung_box: LjungBox,
    /// Residual ACF / PACF, lags 0..=acf_lags, and their bound.
    pub resid_acf: Vec<f64>,
    pub resid_pacf: Vec<f64>,
    pub resid_bound: f64,
    /// The chosen model's CSS residuals.
    pub residuals: Vec<f64>,
}

/// Identify and fit an ARIMA(p, d, q) with constant for `x` (see the module header).
pub fn identify(x: &[f64], settings: &IdentifySettings) -> Result<ArimaIdentification, ArimaError> {
    settings.validate().map_err(ArimaError::InvalidSettings)?;
    check_input(x)?;
    let need = settings.min_len();
    if x.len() < need {
        return Err(ArimaError::TooShort {
            needed: need,
            got: x.len(),
        });
    }
    let adf_res = adf(x, settings.adf_lag)?;
    let d = if adf_res.p_value < settings.adf_alpha {
        0
    } else {
        settings.d_max.min(1)
    };
    let w = difference(x, d);
    let acf_w = acf(&w, settings.acf_lags)?;
    let pacf_w = pacf_from_acf(&acf_w);
    let bound = acf_bound_95(w.len());
    let last_sig = |v: &[f64], max: usize| {
        (1..=max.min(v.len() - 1))
            .filter(|&k| v[k].abs() > bound)
            .max()
            .unwrap_or(0)
    };
    let suggested_p = last_sig(&pacf_w, settings.p_max);
    let suggested_q = last_sig(&acf_w, settings.q_max);

    let hr = if settings.q_max > 0 {
        Some(long_ar(
            &w,
            long_ar_order(w.len(), settings.p_max, settings.q_max),
        )?)
    } else {
        None
    };
    let n_cond = settings.p_max;
    // The grid only has to rank AICs: stop each candidate once the last LM step gains less than
    // 1e-4/n of S (the AIC then moves by ≲ 1e-2 even if ~100 such steps remained — well below any
    // AIC difference that means something); the winner is then polished to `css.rel_tol`. This
    // keeps over-parameterised candidates (near-common AR/MA factors, a flat ridge) from
    // crawling for dozens of iterations.
    let grid_css = CssOptions {
        rel_tol: settings.css.rel_tol.max(1e-4 / w.len() as f64),
        ..settings.css
    };
    let mut table = Vec::new();
    let mut best: Option<ArimaFit> = None;
    let mut last_err = None;
    for p in 0..=settings.p_max {
        for q in 0..=settings.q_max {
            match fit_css_with(&w, (p, d, q), n_cond, &grid_css, hr.as_ref(), None) {
                Ok(f) => {
                    let at_boundary = f.at_boundary();
                    table.push(AicEntry {
                        p,
                        q,
                        aic: f.aic,
                        sigma: f.sigma2.sqrt(),
                        at_boundary,
                    });
                    // A fit that ends on the stationarity/invertibility boundary is an
                    // over-parameterised candidate (near-common AR/MA factors or a unit MA
                    // root): its AIC is not trustworthy and, online, an MA root on the unit
                    // circle never forgets an innovation. It is reported but not chosen.
                    if !at_boundary && best.as_ref().is_none_or(|b| f.aic < b.aic) {
                        best = Some(f);
                    }
                }
                Err(e) => last_err = Some(e),
            }
        }
    }
    let fit = match best {
        Some(f) => {
            let mut start = vec![f.constant];
            start.extend_from_slice(&f.ar);
            start.extend_from_slice(&f.ma);
            let polished = fit_css_with(
                &w,
                (f.p, d, f.q),
                n_cond,
                &settings.css,
                hr.as_ref(),
                Some(&start),
            )?;
            let chosen = if polished.ssr <= f.ssr { polished } else { f };
            // Report the polished AIC in the table too.
            if let Some(row) = table
                .iter_mut()
                .find(|r| r.p == chosen.p && r.q == chosen.q)
            {
                row.aic = chosen.aic;
                row.sigma = chosen.sigma2.sqrt();
            }
            chosen
        }
        None => return Err(last_err.unwrap_or(ArimaError::Singular("every candidate".into()))),
    };
    let residuals = css_residuals(&w, fit.constant, &fit.ar, &fit.ma, fit.n_cond);
    let lb_lags = settings.ljung_box_lags.min(residuals.len() / 2);
    let ljung = ljung_box(&residuals, lb_lags, fit.p + fit.q)?;
    let lags = settings.acf_lags.min(residuals.len() - 1);
    let resid_acf = acf(&residuals, lags)?;
    let resid_pacf = pacf_from_acf(&resid_acf);
    Ok(ArimaIdentification {
        adf: adf_res,
        n_obs: x.len(),
        acf: acf_w,
        pacf: pacf_w,
        acf_bound: bound,
        suggested_p,
        suggested_q,
        aic_table: table,
        ljung_box: ljung,
        resid_acf,
        resid_pacf,
        resid_bound: acf_bound_95(residuals.len()),
        residuals,
        fit,
    })
}

/// Diagnostics stored with a model (what `fit` found; informative, not used online).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArimaDiagnostics {
    /// Samples the model was identified from.
    pub n_obs: usize,
    /// ADF on the raw series.
    pub adf: AdfResult,
    /// 95 % bound of the ACF/PACF below.
    pub acf_bound: f64,
    /// ACF / PACF of the differenced series, lags 0..
    pub acf: Vec<f64>,
    pub pacf: Vec<f64>,
    /// Classical ACF/PACF order suggestions.
    pub suggested_p: usize,
    pub suggested_q: usize,
    /// AIC of the chosen model and of every candidate.
    pub aic: f64,
    pub aic_table: Vec<AicEntry>,
    /// LM converged for the chosen model.
    pub converged: bool,
    /// Ljung–Box on the residuals.
    pub ljung_box: LjungBox,
    /// Residual ACF / PACF (lags 0..) and their bound.
    pub resid_bound: f64,
    pub resid_acf: Vec<f64>,
    pub resid_pacf: Vec<f64>,
}

/// One channel's ARIMA model as written by `fit` and read by the daemon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArimaChannelModel {
    /// Channel name, `gx` … `az`.
    pub channel: String,
    /// AR order.
    pub p: usize,
    /// Differencing order (0 or 1).
    pub d: usize,
    /// MA order.
    pub q: usize,
    /// Intercept c of the differenced equation (rad/s or m/s²; per sample for d = 1).
    pub constant: f64,
    /// φ_1..φ_p.
    pub ar: Vec<f64>,
    /// θ_1..θ_q (w_t = c + Σφ w + e_t + Σθ e).
    pub ma: Vec<f64>,
    /// Innovation standard deviation σ (rad/s or m/s²).
    pub sigma: f64,
    /// What identification found (optional in hand-written files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diagnostics: Option<ArimaDiagnostics>,
}

impl ArimaChannelModel {
    /// Consistency checks; `online` additionally requires the predictor's fixed-size limits.
    pub fn validate(&self, online: bool) -> Result<(), ArimaError> {
        let mut e = Vec::new();
        if self.ar.len() != self.p {
            e.push(format!(
                "ar has {} coefficients, p = {}",
                self.ar.len(),
                self.p
            ));
        }
        if self.ma.len() != self.q {
            e.push(format!(
                "ma has {} coefficients, q = {}",
                self.ma.len(),
                self.q
            ));
        }
        let (pm, qm) = if online {
            (MAX_P, MAX_Q)
        } else {
            (MAX_FIT_ORDER, MAX_FIT_ORDER)
        };
        if self.p > pm || self.q > qm || self.d > MAX_D {
            e.push(format!(
                "order ({}, {}, {}) exceeds ({pm}, {MAX_D}, {qm})",
                self.p, self.d, self.q
            ));
        }
        if !self.constant.is_finite() || self.ar.iter().chain(&self.ma).any(|v| !v.is_finite()) {
            e.push("non-finite coefficient".into());
        }
        if !(self.sigma > 0.0 && self.sigma.is_finite()) {
            e.push(format!("sigma = {} must be positive", self.sigma));
        }
        if self.ar.len() == self.p && !is_stable(&self.ar, 0.0) {
            e.push("AR polynomial is not stationary".into());
        }
        if self.ma.len() == self.q
            && !is_stable(&self.ma.iter().map(|t| -t).collect::<Vec<_>>(), 0.0)
        {
            e.push("MA polynomial is not invertible".into());
        }
        if e.is_empty() {
            Ok(())
        } else {
            Err(ArimaError::InvalidModel(format!(
                "channel {}: {}",
                self.channel,
                e.join("; ")
            )))
        }
    }

    /// Mean of the differenced series, `c / (1 − Σφ)`.
    pub fn mean(&self) -> f64 {
        self.constant / (1.0 - self.ar.iter().sum::<f64>())
    }
}

impl ArimaIdentification {
    /// The model file entry for `channel`, with diagnostics.
    pub fn to_channel_model(&self, channel: &str) -> ArimaChannelModel {
        ArimaChannelModel {
            channel: channel.to_string(),
            p: self.fit.p,
            d: self.fit.d,
            q: self.fit.q,
            constant: self.fit.constant,
            ar: self.fit.ar.clone(),
            ma: self.fit.ma.clone(),
            sigma: self.fit.sigma2.sqrt(),
            diagnostics: Some(ArimaDiagnostics {
                n_obs: self.n_obs,
                adf: self.adf,
                acf_bound: self.acf_bound,
                acf: self.acf.clone(),
                pacf: self.pacf.clone(),
                suggested_p: self.suggested_p,
                suggested_q: self.suggested_q,
                aic: self.fit.aic,
                aic_table: self.aic_table.clone(),
                converged: self.fit.converged,
                ljung_box: self.ljung_box,
                resid_bound: self.resid_bound,
                resid_acf: self.resid_acf.clone(),
                resid_pacf: self.resid_pacf.clone(),
            }),
        }
    }
}

/// ψ-weights `ψ_0..ψ_{n−1}` of the full ARIMA (differencing included): `x_t = Σ ψ_i e_{t−i}`, from
/// `ψ_j = θ_j + Σ_i φ*_i ψ_{j−i}` with `φ*(B) = φ(B)(1−B)^d`. The h-step forecast error variance is
/// `σ² Σ_{i<h} ψ_i²`.
pub fn psi_weights(model: &ArimaChannelModel, out: &mut [f64]) {
    // φ*(B) coefficients (at most MAX_FIT_ORDER + MAX_D).
    let mut phi_star = [0.0f64; MAX_FIT_ORDER + MAX_D];
    let np = model.ar.len().min(MAX_FIT_ORDER);
    phi_star[..np].copy_from_slice(&model.ar[..np]);
    let mut n_star = np;
    if model.d == 1 {
        // (1 − Σφ_i B^i)(1 − B) = 1 − (φ_1 + 1)B − Σ_{i≥2} (φ_i − φ_{i−1}) B^i + φ_p B^{p+1}
        let mut d = [0.0f64; MAX_FIT_ORDER + MAX_D];
        d[0] = 1.0 + if np > 0 { phi_star[0] } else { 0.0 };
        for i in 1..np {
            d[i] = phi_star[i] - phi_star[i - 1];
        }
        if np > 0 {
            d[np] = -phi_star[np - 1];
        }
        n_star = np + 1;
        phi_star = d;
    }
    for j in 0..out.len() {
        let mut v = if j == 0 {
            1.0
        } else {
            model.ma.get(j - 1).copied().unwrap_or(0.0)
        };
        for i in 0..n_star.min(j) {
            v += phi_star[i] * out[j - 1 - i];
        }
        out[j] = v;
    }
}

/// A model file: one table per channel (`[[channels]]`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArimaModelFile {
    pub channels: Vec<ArimaChannelModel>,
}

impl ArimaModelFile {
    /// Parse and validate (offline limits) a TOML model file.
    pub fn from_toml_str(s: &str) -> Result<Self, ArimaError> {
        let f: ArimaModelFile = toml::from_str(s).map_err(|e| ArimaError::Toml(e.to_string()))?;
        for c in &f.channels {
            c.validate(false)?;
        }
        Ok(f)
    }

    /// Serialise to TOML.
    pub fn to_toml_string(&self) -> Result<String, ArimaError> {
        toml::to_string(self).map_err(|e| ArimaError::Toml(e.to_string()))
    }

    /// The model of a channel by name.
    pub fn channel(&self, name: &str) -> Option<&ArimaChannelModel> {
        self.channels.iter().find(|c| c.channel == name)
    }
}

/// Fixed-size one-step ARIMA predictor (p ≤ 3, d ≤ 1, q ≤ 2): no heap, `Copy`.
///
/// The ARMA part is the fitted model; what it is centred on can be the fitted constant or a
/// locally tracked one:
///
/// * d = 0: `x̂_t = m_t + Σφ_i u_{t−i} + Σθ_j e_{t−j}` with deviations `u_s = x_s − m_s` from a
///   centre `m_t`. With `level_alpha = 0`, `m_t = μ = c/(1−Σφ)` and this is exactly the model.
///   With `level_alpha = α > 0`, `m_t = ℓ_{t−1} + b_{t−1}` is Holt's local linear trend of the
///   values fed in: `ℓ_t = m_t + α (x_t − m_t)`, `b_t = b_{t−1} + β (ℓ_t − ℓ_{t−1} − b_{t−1})`
///   (`β = trend_beta`; β = 0 is a local level only).
/// * d = 1: `x̂_t = x_{t−1} + b_t + Σφ_i (w_{t−i} − b_t) + Σθ_j e_{t−j}`, `w = ∇x`, where `b_t` is the
///   fitted mean of w (`trend_beta = 0`: exactly the model, as `b(1−Σφ) = c`) or a local mean
///   `b_t = b_{t−1} + β (w_{t−1} − b_{t−1})`.
///
/// Why: a model identified on a stationary stretch (a vehicle at rest: white noise around a bias)
/// would pull every prediction back to the rest value during a manoeuvre it has never seen. A
/// vehicle's motion is smooth at the sample scale, i.e. locally linear, which a local trend
/// follows with no steady-state lag; the price on stationary data is a small inflation of the
/// prediction variance (measured by the k-sweep). `slope()` exposes `b` (units per sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArimaPredictor {
    p: usize,
    d: usize,
    q: usize,
    ar: [f64; MAX_P],
    ma: [f64; MAX_Q],
    /// Fitted mean of w, c/(1−Σφ).
    mean: f64,
    level_alpha: f64,
    trend_beta: f64,
    /// d = 0: Holt level ℓ_{t−1} (or μ).
    level: f64,
    /// d = 0: Holt trend b_{t−1}; d = 1: (local) mean of w.
    slope: f64,
    /// d = 0: u_{t−1..t−p}; d = 1: w_{t−1..t−p}.
    hist: [f64; MAX_P],
    /// e_{t−1}, e_{t−2}.
    e_hist: [f64; MAX_Q],
    /// x_{t−1}.
    last: f64,
}

impl ArimaPredictor {
    /// Predictor for `model` (validated against the online limits). `level_alpha` (d = 0) and
    /// `trend_beta` are the local-trend weights per sample (0 = the fitted constant). Starts at
    /// the model mean; call [`ArimaPredictor::reseed`] before use.
    pub fn new(
        model: &ArimaChannelModel,
        level_alpha: f64,
        trend_beta: f64,
    ) -> Result<Self, ArimaError> {
        model.validate(true)?;
        for (name, v) in [("level_alpha", level_alpha), ("trend_beta", trend_beta)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(ArimaError::InvalidModel(format!(
                    "{name} = {v} must be in [0, 1]"
                )));
            }
        }
        let mut ar = [0.0; MAX_P];
        ar[..model.p].copy_from_slice(&model.ar);
        let mut ma = [0.0; MAX_Q];
        ma[..model.q].copy_from_slice(&model.ma);
        let mean = model.mean();
        let level_alpha = if model.d == 0 { level_alpha } else { 0.0 };
        // For d = 0 a trend needs a level to ride on.
        let trend_beta = if model.d == 0 && level_alpha == 0.0 {
            0.0
        } else {
            trend_beta
        };
        Ok(ArimaPredictor {
            p: model.p,
            d: model.d,
            q: model.q,
            ar,
            ma,
            mean,
            level_alpha,
            trend_beta,
            level: if model.d == 0 { mean } else { 0.0 },
            slope: if model.d == 1 { mean } else { 0.0 },
            hist: [0.0; MAX_P],
            e_hist: [0.0; MAX_Q],
            last: if model.d == 0 { mean } else { 0.0 },
        })
    }

    /// Restart from recent values (newest first), zero past innovations. With a local trend,
    /// level and slope restart from the least-squares line through the values (slope 0 for fewer
    /// than 3); otherwise from the model.
    pub fn reseed(&mut self, recent_newest_first: &[f64]) {
        let Some(&newest) = recent_newest_first.first() else {
            return;
        };
        let v = &recent_newest_first[..recent_newest_first.len().min(MAX_P + MAX_D)];
        let n = v.len();
        self.e_hist = [0.0; MAX_Q];
        self.last = newest;
        // Least-squares line through (−i, v_i): value at i = 0 and slope per sample.
        let (line0, line_slope) = if n >= 3 {
            let nf = n as f64;
            let tm = -(nf - 1.0) / 2.0;
            let vm = v.iter().sum::<f64>() / nf;
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for (i, x) in v.iter().enumerate() {
                let t = -(i as f64) - tm;
                sxy += t * (x - vm);
                sxx += t * t;
            }
            let b = sxy / sxx;
            (vm - b * tm, b)
        } else {
            (v.iter().sum::<f64>() / n as f64, 0.0)
        };
        if self.d == 0 {
            if self.level_alpha > 0.0 {
                let b = if self.trend_beta > 0.0 {
                    line_slope
                } else {
                    0.0
                };
                self.level = line0;
                self.slope = b;
                for i in 0..MAX_P {
                    let x = v.get(i).copied().unwrap_or(v[n - 1]);
                    self.hist[i] = x - (self.level - b * i as f64);
                }
            } else {
                for i in 0..MAX_P {
                    self.hist[i] = v.get(i).copied().unwrap_or(v[n - 1]) - self.mean;
                }
            }
        } else {
            // w_{t−i} = v_{i} − v_{i+1} where available, else the current mean of w.
            if self.trend_beta > 0.0 {
                self.slope = if n >= 3 {
                    line_slope
                } else if n == 2 {
                    v[0] - v[1]
                } else {
                    0.0
                };
            }
            for i in 0..MAX_P {
                self.hist[i] = if i + 1 < n {
                    v[i] - v[i + 1]
                } else {
                    self.slope
                };
            }
        }
    }

    /// Centre of the d = 0 prediction, m_t.
    #[inline]
    fn centre(&self) -> f64 {
        if self.level_alpha > 0.0 {
            self.level + self.slope
        } else {
            self.mean
        }
    }

    /// One-step prediction of the next value.
    #[inline]
    pub fn predict(&self) -> f64 {
        let mut y = 0.0;
        for j in 0..self.q {
            y += self.ma[j] * self.e_hist[j];
        }
        if self.d == 1 {
            let b = self.slope;
            y += self.last + b;
            for i in 0..self.p {
                y += self.ar[i] * (self.hist[i] - b);
            }
        } else {
            y += self.centre();
            for i in 0..self.p {
                y += self.ar[i] * self.hist[i];
            }
        }
        y
    }

    /// Feed the value accepted for this step and its innovation (value − prediction).
    #[inline]
    pub fn update(&mut self, x: f64, e: f64) {
        let h = if self.d == 1 {
            let w = x - self.last;
            if self.trend_beta > 0.0 {
                self.slope += self.trend_beta * (w - self.slope);
            }
            w
        } else {
            let m = self.centre();
            if self.level_alpha > 0.0 {
                let new_level = m + self.level_alpha * (x - m);
                self.slope += self.trend_beta * (new_level - self.level - self.slope);
                self.level = new_level;
            }
            x - m
        };
        for i in (1..MAX_P).rev() {
            self.hist[i] = self.hist[i - 1];
        }
        self.hist[0] = h;
        for j in (1..MAX_Q).rev() {
            self.e_hist[j] = self.e_hist[j - 1];
        }
        self.e_hist[0] = e;
        self.last = x;
    }

    /// Restart at value `x` moving with `slope` (units per sample): past innovations and
    /// deviations zero, the local trend (if enabled) set to `slope`.
    pub fn restart(&mut self, x: f64, slope: f64) {
        self.e_hist = [0.0; MAX_Q];
        self.last = x;
        if self.d == 0 {
            if self.level_alpha > 0.0 {
                self.level = x;
                self.slope = if self.trend_beta > 0.0 { slope } else { 0.0 };
            }
            self.hist = [if self.level_alpha > 0.0 {
                0.0
            } else {
                x - self.mean
            }; MAX_P];
        } else {
            if self.trend_beta > 0.0 {
                self.slope = slope;
            }
            self.hist = [self.slope; MAX_P];
        }
    }

    /// Model orders (p, d, q).
    pub fn order(&self) -> (usize, usize, usize) {
        (self.p, self.d, self.q)
    }

    /// The last value fed (x_{t−1}).
    #[inline]
    pub fn last(&self) -> f64 {
        self.last
    }

    /// Local slope b (units per sample): Holt's trend (d = 0) or the mean of ∇x (d = 1); 0 for a
    /// d = 0 model without a local trend.
    #[inline]
    pub fn slope(&self) -> f64 {
        self.slope
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// ARMA(p, q) with intercept, simulated with `burn` discarded samples.
    fn simulate(c: f64, ar: &[f64], ma: &[f64], sigma: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let burn = 500;
        let mut x: Vec<f64> = Vec::with_capacity(n + burn);
        let mut e: Vec<f64> = Vec::with_capacity(n + burn);
        for t in 0..n + burn {
            let et = sigma * rng.normal();
            let mut v = c + et;
            for (i, a) in ar.iter().enumerate() {
                if t > i {
                    v += a * x[t - 1 - i];
                }
            }
            for (j, b) in ma.iter().enumerate() {
                if t > j {
                    v += b * e[t - 1 - j];
                }
            }
            x.push(v);
            e.push(et);
        }
        x.split_off(burn)
    }

    #[test]
    fn ma_invertibility_matches_the_closed_form_region() {
        // MA(1) 1 + θz invertible iff |θ| < 1 (the AR regions are tested in stats::ar_poly).
        assert!(ma_is_invertible(&[-0.9]));
        assert!(!ma_is_invertible(&[1.2]));
    }

    #[test]
    fn css_ar1_equals_ols_closed_form() {
        // For q = 0, CSS is OLS of x_t on (1, x_{t−1}); compare with the textbook formulas.
        let x = simulate(0.3, &[0.6], &[], 1.0, 3000, 21);
        let f = fit_arima(&x, 1, 0, 0, &CssOptions::default()).unwrap();
        let (xs, ys) = (&x[..x.len() - 1], &x[1..]);
        let n = xs.len() as f64;
        let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
        let sxy: f64 = xs.iter().zip(ys).map(|(a, b)| (a - mx) * (b - my)).sum();
        let sxx: f64 = xs.iter().map(|a| (a - mx) * (a - mx)).sum();
        let phi = sxy / sxx;
        let c = my - phi * mx;
        // LM on a quadratic objective lands on the normal-equation solution to ~1e-10.
        assert!((f.ar[0] - phi).abs() < 1e-9, "{} vs {phi}", f.ar[0]);
        assert!((f.constant - c).abs() < 1e-9);
        assert!(f.converged);
    }

    #[test]
    fn css_recovers_arma11_parameters() {
        // N = 20 000: asymptotic sd of φ̂, θ̂ for φ = 0.5, θ = 0.3 is ~√((1−φ²)(1+φθ)²/(φ+θ)²/N)
        // ≈ 0.009; 0.04 is > 4 sd.
        let x = simulate(0.2, &[0.5], &[0.3], 0.5, 20_000, 7);
        let f = fit_arima(&x, 1, 0, 1, &CssOptions::default()).unwrap();
        assert!((f.ar[0] - 0.5).abs() < 0.04, "phi {}", f.ar[0]);
        assert!((f.ma[0] - 0.3).abs() < 0.04, "theta {}", f.ma[0]);
        assert!(
            (f.sigma2.sqrt() - 0.5).abs() < 0.01,
            "sigma {}",
            f.sigma2.sqrt()
        );
        assert!((f.mean() - 0.4).abs() < 0.05, "mean {}", f.mean());
        assert!(f.converged);
    }

    #[test]
    fn identify_picks_d1_for_a_random_walk_with_ar_increments() {
        // ∇x is AR(1) φ = 0.6: ADF cannot reject the unit root, so d = 1, and the AIC grid finds
        // φ ≈ 0.6 (sd ≈ 0.8/√5000 ≈ 0.011; 0.05 is > 4 sd) with white residuals.
        let w = simulate(0.0, &[0.6], &[], 1.0, 5000, 9);
        let mut acc = 0.0;
        let x: Vec<f64> = w
            .iter()
            .map(|v| {
                acc += v;
                acc
            })
            .collect();
        let id = identify(&x, &IdentifySettings::default()).unwrap();
        assert_eq!(id.fit.d, 1);
        assert!(id.adf.p_value > 0.05);
        assert_eq!(id.aic_table.len(), 12);
        assert!(id.fit.p >= 1, "p = {}", id.fit.p);
        // Whatever the chosen (p, q), its one-step residual sd matches the true innovation sd.
        assert!((id.fit.sigma2.sqrt() - 1.0).abs() < 0.03);
        assert!(id.ljung_box.p_value > 0.01, "{:?}", id.ljung_box);
        assert_eq!(id.suggested_p, 1);
    }

    #[test]
    fn identify_picks_d0_and_white_noise_for_white_noise() {
        let mut rng = Rng::new(4);
        let x: Vec<f64> = (0..4000).map(|_| 2.0 + 0.1 * rng.normal()).collect();
        let id = identify(&x, &IdentifySettings::default()).unwrap();
        assert_eq!(id.fit.d, 0);
        // AIC's penalty makes (0,0) the usual winner; any chosen model must predict no better
        // than white noise can: σ within 3 % of 0.1 (sd of σ̂ ≈ 0.1/√8000 ≈ 0.0011).
        assert!((id.fit.sigma2.sqrt() - 0.1).abs() < 0.003);
        assert!((id.fit.mean() - 2.0).abs() < 0.01);
    }

    #[test]
    fn identify_rejects_bad_input_with_errors() {
        assert!(matches!(
            identify(&[1.0; 10], &IdentifySettings::default()),
            Err(ArimaError::TooShort { .. })
        ));
        let mut x: Vec<f64> = (0..500).map(|i| (i as f64 * 0.1).sin()).collect();
        x[17] = f64::NAN;
        assert!(matches!(
            identify(&x, &IdentifySettings::default()),
            Err(ArimaError::NonFinite { index: 17 })
        ));
        let bad = IdentifySettings {
            d_max: 2,
            adf_alpha: 1.5,
            ..Default::default()
        };
        match identify(&x, &bad) {
            Err(ArimaError::InvalidSettings(v)) => assert_eq!(v.len(), 2, "{v:?}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn predictor_reproduces_css_residuals() {
        // With level_alpha = 0 the fixed-size predictor is the model: its innovations on the fit
        // data equal the CSS residuals once the same start (history = data, e = 0) is used.
        let x = simulate(0.1, &[0.5, -0.2], &[0.4], 1.0, 2000, 13);
        let f = fit_arima(&x, 2, 0, 1, &CssOptions::default()).unwrap();
        let model = ArimaChannelModel {
            channel: "gz".into(),
            p: 2,
            d: 0,
            q: 1,
            constant: f.constant,
            ar: f.ar.clone(),
            ma: f.ma.clone(),
            sigma: f.sigma2.sqrt(),
            diagnostics: None,
        };
        let resid = css_residuals(&x, f.constant, &f.ar, &f.ma, 2);
        let mut pr = ArimaPredictor::new(&model, 0.0, 0.0).unwrap();
        pr.reseed(&[x[1], x[0]]);
        for t in 2..x.len() {
            let e = x[t] - pr.predict();
            // Same recursion, different summation order: 1e-12 absolute on O(1) values.
            assert!(
                (e - resid[t - 2]).abs() < 1e-12,
                "t = {t}: {e} vs {}",
                resid[t - 2]
            );
            pr.update(x[t], e);
        }
    }

    #[test]
    fn predictor_d1_predicts_last_value_plus_drift_for_random_walk() {
        let model = ArimaChannelModel {
            channel: "gx".into(),
            p: 0,
            d: 1,
            q: 0,
            constant: 0.01,
            ar: vec![],
            ma: vec![],
            sigma: 1.0,
            diagnostics: None,
        };
        let mut pr = ArimaPredictor::new(&model, 0.5, 0.0).unwrap();
        pr.reseed(&[3.0]);
        assert_eq!(pr.predict(), 3.01);
        pr.update(4.0, 0.99);
        assert_eq!(pr.predict(), 4.01);
    }

    #[test]
    fn psi_weights_are_closed_form_for_arma11_and_random_walk() {
        // ARMA(1,1): ψ_0 = 1, ψ_j = (φ+θ) φ^{j−1}. Random walk (0,1,0): ψ_j = 1. ARIMA(1,1,0):
        // ψ_j = (1 − φ^{j+1})/(1 − φ).
        let mut m = ArimaChannelModel {
            channel: "gz".into(),
            p: 1,
            d: 0,
            q: 1,
            constant: 0.0,
            ar: vec![0.5],
            ma: vec![0.3],
            sigma: 1.0,
            diagnostics: None,
        };
        let mut psi = [0.0; 6];
        psi_weights(&m, &mut psi);
        for (j, v) in psi.iter().enumerate() {
            let want = if j == 0 {
                1.0
            } else {
                0.8 * 0.5f64.powi(j as i32 - 1)
            };
            assert!((v - want).abs() < 1e-15, "ψ_{j} = {v}");
        }
        m.d = 1;
        m.q = 0;
        m.ma = vec![];
        psi_weights(&m, &mut psi);
        for (j, v) in psi.iter().enumerate() {
            let want = (1.0 - 0.5f64.powi(j as i32 + 1)) / 0.5;
            assert!((v - want).abs() < 1e-15, "ψ_{j} = {v}");
        }
        m.p = 0;
        m.ar = vec![];
        psi_weights(&m, &mut psi);
        assert!(psi.iter().all(|v| *v == 1.0));
    }

    #[test]
    fn model_file_round_trips_toml_and_rejects_unknown_fields() {
        let x = simulate(0.0, &[0.4], &[0.2], 1.0, 1500, 2);
        let id = identify(&x, &IdentifySettings::default()).unwrap();
        let file = ArimaModelFile {
            channels: vec![id.to_channel_model("gz")],
        };
        let s = file.to_toml_string().unwrap();
        let back = ArimaModelFile::from_toml_str(&s).unwrap();
        assert_eq!(back, file);
        let bad = s.replacen("sigma =", "sigmaa = 1.0\nsigma =", 1);
        assert!(matches!(
            ArimaModelFile::from_toml_str(&bad),
            Err(ArimaError::Toml(_))
        ));
        // A hand-written model without diagnostics loads.
        let hand = "[[channels]]\nchannel = \"gx\"\np = 1\nd = 0\nq = 0\nconstant = 0.0\nar = [0.5]\nma = []\nsigma = 0.01\n";
        let f = ArimaModelFile::from_toml_str(hand).unwrap();
        assert_eq!(f.channel("gx").unwrap().ar, vec![0.5]);
        // An inconsistent one does not.
        let wrong = hand.replace("ar = [0.5]", "ar = [1.5]");
        assert!(ArimaModelFile::from_toml_str(&wrong).is_err());
    }
}

/// Why an ARIMA model could not be identified, fitted, loaded or used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ArimaError {
    /// Fewer samples than the fit needs.
    #[error("series too short: need at least {needed} samples, got {got}")]
    TooShort { needed: usize, got: usize },
    /// NaN or ±Inf in the input.
    #[error("non-finite value at index {index}")]
    NonFinite { index: usize },
    /// Zero variance where a variance must be estimated.
    #[error("series is constant")]
    Constant,
    /// Model order outside what the caller supports.
    #[error("bad model order: {0}")]
    BadOrder(String),
    /// Singular normal equations.
    #[error("singular system in {0}")]
    Singular(String),
    /// A model (e.g. loaded from TOML) that is inconsistent or not usable.
    #[error("invalid model: {0}")]
    InvalidModel(String),
    /// Settings that failed validation (all problems listed).
    #[error("invalid settings: {}", .0.join("; "))]
    InvalidSettings(Vec<String>),
    /// A statistic used during identification failed.
    #[error(transparent)]
    Test(#[from] NumError),
    /// A model file that does not parse or serialise.
    #[error("model file: {0}")]
    Toml(String),
}
