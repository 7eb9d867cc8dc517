//! Conditional-sum-of-squares estimation: Hannan–Rissanen initial values, the Levenberg–Marquardt
//! loop, the admissibility checks (module docs of [`super`]).

use super::*;

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
        !is_stable(&self.ar, 2.0 * AR_MARGIN) || self.ma_at_boundary()
    }

    /// True if the MA polynomial sits within twice the LM margin of the invertibility boundary:
    /// an MA root on the unit circle never forgets an innovation, and one there usually cancels
    /// an AR root (an over-parameterised fit). An AR root there is a line (or a unit root): a
    /// legitimate model of a channel that carries one.
    pub fn ma_at_boundary(&self) -> bool {
        !is_stable(
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
pub(super) fn css_pass(
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
pub(super) struct LongAr {
    resid: Vec<f64>,
    start: usize,
}

/// Long AR(m) by Durbin–Levinson on the biased autocovariances; residuals from t = m.
pub(super) fn long_ar(w: &[f64], m: usize) -> Result<LongAr, ArimaError> {
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

pub(super) fn long_ar_order(n: usize, p: usize, q: usize) -> usize {
    let ln = (n as f64).ln();
    ((ln * ln).floor() as usize)
        .max(2 * p.max(q))
        .min(n / 10)
        .max(1)
}

/// Hannan–Rissanen starting values `[c, φ, θ]` (admissible).
pub(super) fn initial_values(
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
            return Err(NumError::singular("Hannan-Rissanen without long AR").into());
        }
    };
    if w.len() <= first + k {
        return Err(NumError::TooShort {
            needed: first + k + 1,
            got: w.len(),
        }
        .into());
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
    let beta = solve_spd(xtx, xty).ok_or_else(|| NumError::singular("initial regression"))?;
    let mut beta: Vec<f64> = beta.iter().copied().collect();
    shrink_until(&mut beta[1..1 + p], ar_is_stationary);
    shrink_until(&mut beta[1 + p..], ma_is_invertible);
    Ok(beta)
}

/// Solve a symmetric positive (semi)definite system with Jacobi scaling and Cholesky.
pub(super) fn solve_spd(a: DMatrix<f64>, b: DVector<f64>) -> Option<DVector<f64>> {
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

pub(super) fn admissible(beta: &[f64], p: usize) -> bool {
    beta.iter().all(|v| v.is_finite())
        && ar_is_stationary(&beta[1..1 + p])
        && ma_is_invertible(&beta[1 + p..])
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
    check_finite(w)?;
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

pub(super) fn fit_css_with(
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
        return Err(NumError::singular("CSS at the initial values").into());
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
        return Err(NumError::Constant.into());
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
    check_finite(x)?;
    let w = difference(x, d);
    fit_css(&w, p, d, q, p, opts)
}
