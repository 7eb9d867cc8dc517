//! The augmented Dickey–Fuller unit-root test (Dickey & Fuller 1979; Said & Dickey 1984) with
//! MacKinnon's critical values and p-value, as the ARIMA identification uses it (Chen, Li & Zhang
//! 2013, §2.2).
//!
//! * Regression with a constant:
//!   `Δx_t = α + γ x_{t−1} + Σ_{j=1}^{l} β_j Δx_{t−j} + ε_t`, statistic `τ = γ̂ / se(γ̂)` (OLS).
//!   Lag choice (as statsmodels `adfuller(regression="c", autolag="AIC")`): `l_max =
//!   ⌈12 (N/100)^{1/4}⌉` (Schwert 1989) capped at `N/2 − 2`; every `l ∈ 0..=l_max` is fitted on the
//!   same `N − 1 − l_max` rows and the smallest `AIC = n ln(2π SSR/n) + n + 2k` (k = l + 2 regressors)
//!   wins (ties to the smaller l); the chosen regression is then refitted on all `N − 1 − l` rows.
//!   A fixed lag can be requested instead.
//! * Critical values: MacKinnon (2010) response surfaces `τ_α(T) = b0 + b1/T + b2/T² + b3/T³` for one
//!   variable with constant, at 1/5/10 %, T = rows of the final regression.
//! * p-value: MacKinnon (1994) asymptotic approximation `p = Φ(Σ_i c_i τ^i)` with the small-p
//!   (quadratic) coefficients for `τ ≤ −1.61` and the large-p (cubic) ones above, 0 below −18.83 and
//!   1 above 2.74 (the same tables as statsmodels' `mackinnonp`).

// `!(v > 0.0)` is used on purpose throughout: unlike `v <= 0.0` it is also true for NaN, so a
// single guard rejects both non-positive and NaN input.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::special::normal_cdf;
use super::{NumError, check_finite};

/// How the ADF regression's number of lagged differences is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case", tag = "rule")]
pub enum AdfLag {
    /// Minimum AIC over `0..=max_lag` on a common sample (statsmodels `autolag="AIC"`);
    /// `max_lag = None` uses Schwert's `⌈12 (N/100)^{1/4}⌉`.
    Aic { max_lag: Option<usize> },
    /// Exactly this many lagged differences.
    Fixed { lags: usize },
}

impl Default for AdfLag {
    fn default() -> Self {
        AdfLag::Aic { max_lag: None }
    }
}

/// Result of an augmented Dickey–Fuller test (regression with constant).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdfResult {
    /// τ = γ̂ / se(γ̂).
    pub stat: f64,
    /// MacKinnon (1994) approximate p-value of τ.
    pub p_value: f64,
    /// Lagged differences in the final regression.
    pub used_lag: usize,
    /// Largest lag considered (equal to `used_lag` for a fixed lag).
    pub max_lag: usize,
    /// Rows of the final regression (N − 1 − used_lag).
    pub n_obs: usize,
    /// MacKinnon (2010) critical values at 1 %, 5 %, 10 % for `n_obs`.
    pub crit: [f64; 3],
    /// AIC of the chosen lag on the common autolag sample (None for a fixed lag).
    pub ic_best: Option<f64>,
}

/// MacKinnon (2010) response-surface coefficients, one variable, constant: rows 1 %, 5 %, 10 %;
/// columns b0, b1, b2, b3 of `τ(T) = b0 + b1/T + b2/T² + b3/T³`.
const MACKINNON_2010_C: [[f64; 4]; 3] = [
    [-3.43035, -6.5393, -16.786, -79.433],
    [-2.86154, -2.8903, -4.234, -40.040],
    [-2.56677, -1.5384, -2.809, 0.0],
];

/// MacKinnon (2010) ADF critical values (constant, N = 1) at 1 %, 5 %, 10 % for `n_obs` rows.
pub fn mackinnon_crit(n_obs: usize) -> [f64; 3] {
    let r = 1.0 / n_obs as f64;
    MACKINNON_2010_C.map(|b| b[0] + r * (b[1] + r * (b[2] + r * b[3])))
}

/// MacKinnon (1994) approximate asymptotic p-value of an ADF τ (constant, N = 1).
pub fn mackinnon_p(stat: f64) -> f64 {
    // Table 3 of MacKinnon (1994), "c", N = 1, after the published scalings.
    const TAU_MAX: f64 = 2.74;
    const TAU_MIN: f64 = -18.83;
    const TAU_STAR: f64 = -1.61;
    const SMALL_P: [f64; 3] = [2.1659, 1.4412, 0.038269];
    const LARGE_P: [f64; 4] = [1.7339, 0.93202, -0.12745, -0.010368];
    if stat.is_nan() {
        return f64::NAN;
    }
    if stat > TAU_MAX {
        return 1.0;
    }
    if stat < TAU_MIN {
        return 0.0;
    }
    let arg = if stat <= TAU_STAR {
        SMALL_P[0] + stat * (SMALL_P[1] + stat * SMALL_P[2])
    } else {
        LARGE_P[0] + stat * (LARGE_P[1] + stat * (LARGE_P[2] + stat * LARGE_P[3]))
    };
    normal_cdf(arg)
}

/// Centered cross-products of the ADF regressors `[x_t, Δx_{t−1}, …, Δx_{t−k}]` and of `Δx_t` over
/// the rows `t = first..=N−2` (t indexes Δx_t = x_{t+1} − x_t). Centering is equivalent to
/// including the constant (Frisch–Waugh–Lovell) and keeps the level column's large mean from
/// swamping the products.
struct AdfMoments {
    n: usize,
    szz: DMatrix<f64>,
    szy: DVector<f64>,
    syy: f64,
}

fn adf_moments(x: &[f64], dx: &[f64], k: usize, first: usize) -> AdfMoments {
    let rows = first..dx.len();
    let n = rows.len();
    let ncol = k + 2; // level, k lags, y
    // Row builder: [x_t, dx_{t-1}, ..., dx_{t-k}, dx_t].
    let fill = |t: usize, row: &mut [f64]| {
        row[0] = x[t];
        for j in 1..=k {
            row[j] = dx[t - j];
        }
        row[k + 1] = dx[t];
    };
    let mut row = vec![0.0; ncol];
    let mut mean = vec![0.0; ncol];
    for t in rows.clone() {
        fill(t, &mut row);
        for (m, v) in mean.iter_mut().zip(&row) {
            *m += v;
        }
    }
    for m in mean.iter_mut() {
        *m /= n as f64;
    }
    // Upper triangle of the (ncol × ncol) cross-product, row-major.
    let mut s = vec![0.0; ncol * ncol];
    for t in rows {
        fill(t, &mut row);
        for (v, m) in row.iter_mut().zip(&mean) {
            *v -= m;
        }
        for i in 0..ncol {
            let ri = row[i];
            let dst = &mut s[i * ncol + i..(i + 1) * ncol];
            for (d, rj) in dst.iter_mut().zip(&row[i..]) {
                *d += ri * rj;
            }
        }
    }
    let kz = k + 1;
    let szz = DMatrix::from_fn(kz, kz, |i, j| {
        let (a, b) = if i <= j { (i, j) } else { (j, i) };
        s[a * ncol + b]
    });
    let szy = DVector::from_fn(kz, |i, _| s[i * ncol + kz]);
    AdfMoments {
        n,
        szz,
        szy,
        syy: s[kz * ncol + kz],
    }
}

/// Augmented Dickey–Fuller test with a constant (see the module header for the regression and the
/// lag rule).
pub fn adf(x: &[f64], lag: AdfLag) -> Result<AdfResult, NumError> {
    check_finite(x)?;
    let n = x.len();
    // Smallest sample for which the default lag rule leaves a regression with ≥ 1 residual dof.
    const MIN_N: usize = 8;
    if n < MIN_N {
        return Err(NumError::TooShort {
            needed: MIN_N,
            got: n,
        });
    }
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if lo == hi {
        return Err(NumError::Constant);
    }
    // statsmodels: maxlag ≤ nobs/2 − ntrend − 1 with ntrend = 1.
    let cap = n / 2 - 2;
    let schwert = (12.0 * (n as f64 / 100.0).powf(0.25)).ceil() as usize;
    let (max_lag, autolag) = match lag {
        AdfLag::Aic { max_lag: None } => (schwert.min(cap), true),
        AdfLag::Aic { max_lag: Some(m) } => (m, true),
        AdfLag::Fixed { lags } => (lags, false),
    };
    if max_lag > cap {
        return Err(NumError::bad(format!(
            "ADF lag {max_lag} exceeds N/2 - 2 = {cap}"
        )));
    }
    let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();

    let mut ic_best = None;
    let used_lag = if autolag {
        // All lags on the common sample t = max_lag..=N−2: one factorisation of the largest
        // normal matrix serves every nested regression (leading blocks of a Cholesky factor are
        // the factors of the leading blocks), so SSR_l = S_yy − Σ_{i≤l} u_i², u = L⁻¹ S_zy.
        let m = adf_moments(x, &dx, max_lag, max_lag);
        let d = m.szz.diagonal().map(|v| v.sqrt());
        if d.iter().any(|v| !(*v > 0.0)) {
            return Err(NumError::singular("ADF lag search"));
        }
        // Jacobi scaling to unit diagonal before Cholesky (level and differences differ in scale).
        let a = DMatrix::from_fn(max_lag + 1, max_lag + 1, |i, j| {
            m.szz[(i, j)] / (d[i] * d[j])
        });
        let chol = a.cholesky().ok_or(NumError::singular("ADF lag search"))?;
        let b = DVector::from_fn(max_lag + 1, |i, _| m.szy[i] / d[i]);
        let u = chol
            .l()
            .solve_lower_triangular(&b)
            .ok_or(NumError::singular("ADF lag search"))?;
        let nf = m.n as f64;
        let mut ssr = m.syy - u[0] * u[0];
        let mut best = (f64::INFINITY, 0usize);
        for l in 0..=max_lag {
            if l > 0 {
                ssr -= u[l] * u[l];
            }
            let k = (l + 2) as f64; // constant + level + l lags
            let aic = nf
                * ((2.0 * std::f64::consts::PI).ln()
                    + (ssr.max(f64::MIN_POSITIVE) / nf).ln()
                    + 1.0)
                + 2.0 * k;
            if aic < best.0 {
                best = (aic, l);
            }
        }
        ic_best = Some(best.0);
        best.1
    } else {
        max_lag
    };

    // Final regression on all rows the chosen lag allows.
    let m = adf_moments(x, &dx, used_lag, used_lag);
    let kz = used_lag + 1;
    let dof = m.n as f64 - (kz + 1) as f64;
    if dof < 1.0 {
        return Err(NumError::TooShort {
            needed: n + 1,
            got: n,
        });
    }
    let d = m.szz.diagonal().map(|v| v.sqrt());
    if d.iter().any(|v| !(*v > 0.0)) {
        return Err(NumError::singular("ADF regression"));
    }
    let a = DMatrix::from_fn(kz, kz, |i, j| m.szz[(i, j)] / (d[i] * d[j]));
    let chol = a.cholesky().ok_or(NumError::singular("ADF regression"))?;
    let bs = chol.solve(&DVector::from_fn(kz, |i, _| m.szy[i] / d[i]));
    let beta = DVector::from_fn(kz, |i, _| bs[i] / d[i]);
    // (A⁻¹)_00 via one solve; var(γ̂) = s² (S_zz⁻¹)_00 = s² (A⁻¹)_00 / d_0².
    let mut e0 = DVector::zeros(kz);
    e0[0] = 1.0;
    let inv00 = chol.solve(&e0)[0] / (d[0] * d[0]);
    // SSR from the residuals themselves (not S_yy − b'S_zy, which cancels when R² ≈ 1).
    let mut mean = vec![0.0; kz + 1];
    let rows = used_lag..dx.len();
    for t in rows.clone() {
        mean[0] += x[t];
        for j in 1..=used_lag {
            mean[j] += dx[t - j];
        }
        mean[kz] += dx[t];
    }
    for v in mean.iter_mut() {
        *v /= m.n as f64;
    }
    let mut ssr = 0.0;
    for t in rows {
        let mut e = (dx[t] - mean[kz]) - beta[0] * (x[t] - mean[0]);
        for j in 1..=used_lag {
            e -= beta[j] * (dx[t - j] - mean[j]);
        }
        ssr += e * e;
    }
    let s2 = ssr / dof;
    let stat = beta[0] / (s2 * inv00).sqrt();
    if !stat.is_finite() {
        return Err(NumError::singular("ADF regression"));
    }
    Ok(AdfResult {
        stat,
        p_value: mackinnon_p(stat),
        used_lag,
        max_lag,
        n_obs: m.n,
        crit: mackinnon_crit(m.n),
        ic_best,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, ar_series};

    #[test]
    fn mackinnon_crit_is_the_asymptotic_value_for_large_n() {
        // b1/T etc. vanish as T → ∞; at T = 1e12 the correction is < 1e-11.
        let c = mackinnon_crit(1_000_000_000_000);
        assert!((c[0] + 3.43035).abs() < 1e-10);
        assert!((c[1] + 2.86154).abs() < 1e-10);
        assert!((c[2] + 2.56677).abs() < 1e-10);
    }

    #[test]
    fn mackinnon_p_is_monotone_and_continuous_at_the_switch() {
        // The two polynomials are fitted to meet near τ* = −1.61: the jump there is < 1e-3 (the
        // published approximation's own accuracy), and p rises with τ.
        let below = mackinnon_p(-1.61);
        let above = mackinnon_p(-1.61 + 1e-9);
        assert!((below - above).abs() < 1e-3, "{below} vs {above}");
        let mut last = 0.0;
        for i in 0..200 {
            let t = -6.0 + i as f64 * 0.04;
            let p = mackinnon_p(t);
            assert!(p >= last - 1e-3, "p not monotone at {t}");
            last = p;
        }
        assert_eq!(mackinnon_p(-20.0), 0.0);
        assert_eq!(mackinnon_p(3.0), 1.0);
    }

    #[test]
    fn adf_rejects_unit_root_for_white_noise_and_not_for_random_walk() {
        // White noise: τ ≈ −√N·... far below the 1 % value; a random walk: τ is O(1) and the
        // p-value large. Both are overwhelming at N = 2000 (the seeds are fixed).
        let mut rng = Rng::new(3);
        let wn: Vec<f64> = (0..2000).map(|_| rng.normal()).collect();
        let r = adf(&wn, AdfLag::default()).unwrap();
        assert!(r.stat < r.crit[0] && r.p_value < 1e-6, "{r:?}");
        let rw = ar_series(&mut rng, 2000, &[1.0], 1.0);
        let r = adf(&rw, AdfLag::default()).unwrap();
        assert!(r.stat > r.crit[2] && r.p_value > 0.1, "{r:?}");
    }

    #[test]
    fn adf_fixed_lag_zero_is_the_dickey_fuller_t_statistic() {
        // With no lags, τ is the OLS t-statistic of γ in Δx_t = α + γ x_{t−1}: recompute it by
        // the textbook formulas γ̂ = Sxy/Sxx, se² = s²/Sxx.
        let x = ar_series(&mut Rng::new(5), 300, &[0.8], 1.0);
        let r = adf(&x, AdfLag::Fixed { lags: 0 }).unwrap();
        let lv = &x[..x.len() - 1];
        let dy: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let n = lv.len() as f64;
        let mx = lv.iter().sum::<f64>() / n;
        let my = dy.iter().sum::<f64>() / n;
        let sxx: f64 = lv.iter().map(|a| (a - mx) * (a - mx)).sum();
        let sxy: f64 = lv.iter().zip(&dy).map(|(a, b)| (a - mx) * (b - my)).sum();
        let g = sxy / sxx;
        let ssr: f64 = lv
            .iter()
            .zip(&dy)
            .map(|(a, b)| {
                let e = (b - my) - g * (a - mx);
                e * e
            })
            .sum();
        let t = g / (ssr / (n - 2.0) / sxx).sqrt();
        // Same arithmetic up to summation order: 1e-10 relative.
        assert!(((r.stat - t) / t).abs() < 1e-10, "{} vs {t}", r.stat);
        assert_eq!(r.n_obs, 299);
    }

    #[test]
    fn adf_bad_input_is_an_error() {
        assert!(matches!(
            adf(&[1.0; 50], AdfLag::default()),
            Err(NumError::Constant)
        ));
        assert!(matches!(
            adf(
                &[1.0, f64::NAN, 2.0, 3.0, 1.0, 2.0, 3.0, 4.0],
                AdfLag::default()
            ),
            Err(NumError::NonFinite { index: 1 })
        ));
        let x: Vec<f64> = (0..20).map(|i| (i as f64).sin()).collect();
        assert!(matches!(
            adf(&x, AdfLag::Fixed { lags: 15 }),
            Err(NumError::BadSetting(_))
        ));
        assert!(adf(&[1.0, 2.0], AdfLag::default()).is_err());
    }
}
