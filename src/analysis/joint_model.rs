//! The model the diagnosis loop refits: deterministic effect regressors with AR(p) errors,
//! optionally plus a random-walk level tracked causally.
//!
//!   y_n = c + Σ_j β_j x_{j,n} + ℓ_n + u_n,   u_n − m = Σ_{i=1}^{p} φ_i (u_{n−i} − m) + e_n,
//!
//! x_j the effect regressors (sin/cos of a line, lagged temperature and its square, a step,
//! specific-force components), ℓ an optional random-walk level, e the one-step innovation.
//!
//! **Regression with AR errors** by feasible generalised least squares, iterated (Cochrane &
//! Orcutt 1949, generalised to AR(p); e.g. Hamilton, *Time Series Analysis*, §8.3): OLS for (c, β);
//! Burg AR(p) on the regression residual; prewhiten y and every regressor with the AR polynomial,
//! ỹ_n = y_n − Σφ_i y_{n−i}; OLS of ỹ on the prewhitened regressors gives the GLS (c, β); repeat
//! (three passes; the estimates settle in one or two). Starting from OLS on levels matters: an
//! effect left out of the regressors is absorbed by a near-unit-root AR, and only the OLS start
//! lets the AR be re-estimated on a residual from which the effect is gone.
//!
//! **Random-walk level** (the rate-random-walk effect): a local-level model with random-walk
//! variance q per sample seen through measurement noise of variance R has the steady-state
//! Kalman predictor ℓ_{n+1} = ℓ_n + K (d_n − ℓ_n) with d = y − c − Xβ, K = P/(P+R) and
//! P = (q + √(q² + 4qR))/2 (Harvey 1989, *Forecasting, structural time series models and the
//! Kalman filter*, §3.2), i.e. q = K² R/(1 − K). K is chosen by minimising the one-step error on the
//! fit range (golden section in ln K after a coarse grid); the AR is then fitted to d − ℓ. With a
//! level, (c, β) are re-estimated by GLS under the level + AR noise model (the causal one-step
//! error filter applied to y and to every regressor; two passes, K and the AR refitted between),
//! so that a slow regressor is not credited with a random walk's excursions. This is a two-stage
//! causal predictor (the gain is not re-solved jointly with the AR in one state-space filter),
//! which keeps the online form a scalar update.
//!
//! The one-step prediction of y_n uses only samples before n, over the whole log, so a
//! validation or test segment is predicted with its true history.

use super::AnalysisError;
use crate::model::{ArFit, burg, burg_orders};
use crate::stats::{NumError, check_same_len, check_series};
use nalgebra::{DMatrix, DVector};
use std::ops::Range;

/// How the random-walk level is treated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LevelSpec {
    /// No level (q = 0).
    None,
    /// Choose the gain on the fit range.
    Fit,
    /// Use this gain K in (0, 1).
    Fixed(f64),
}

/// A fitted joint model.
#[derive(Clone, Debug)]
pub struct JointFit {
    /// Intercept c.
    pub intercept: f64,
    /// β_j in column order.
    pub beta: Vec<f64>,
    /// AR model of the regression (and level) residual.
    pub ar: ArFit,
    /// Level gain K, if a level is tracked.
    pub level_gain: Option<f64>,
    /// Level random-walk variance q per sample, if tracked (units²).
    pub level_q_per_sample: Option<f64>,
}

/// Residuals of a fitted model over the whole log.
#[derive(Clone, Debug)]
pub struct Residuals {
    /// d = y − c − Xβ (what the deterministic part leaves).
    pub open_loop: Vec<f64>,
    /// One-step innovations e_n = y_n − ŷ_{n|n−1}.
    pub innovation: Vec<f64>,
}

/// Least squares with column scaling (normal equations, Cholesky).
fn lstsq(x: &DMatrix<f64>, y: &DVector<f64>) -> Result<DVector<f64>, AnalysisError> {
    let g = x.transpose() * x;
    let b = x.transpose() * y;
    let k = g.nrows();
    let d: Vec<f64> = (0..k)
        .map(|j| {
            if g[(j, j)] > 0.0 {
                1.0 / g[(j, j)].sqrt()
            } else {
                0.0
            }
        })
        .collect();
    if d.contains(&0.0) {
        return Err(AnalysisError::singular(
            "joint model: a regressor is zero on the fit range",
        ));
    }
    let gs = DMatrix::from_fn(k, k, |i, j| g[(i, j)] * d[i] * d[j]);
    let bs = DVector::from_fn(k, |i, _| b[i] * d[i]);
    let z = gs
        .cholesky()
        .ok_or_else(|| {
            AnalysisError::singular("joint model: regressors collinear on the fit range")
        })?
        .solve(&bs);
    Ok(DVector::from_fn(k, |i, _| z[i] * d[i]))
}

/// Design matrix rows `range` of [1, cols...].
fn design(cols: &[Vec<f64>], range: Range<usize>) -> DMatrix<f64> {
    DMatrix::from_fn(range.len(), cols.len() + 1, |i, j| {
        if j == 0 {
            1.0
        } else {
            cols[j - 1][range.start + i]
        }
    })
}

/// Fit the joint model to `y` on `range` (columns are whole-log length).
pub fn fit(
    y: &[f64],
    cols: &[Vec<f64>],
    range: Range<usize>,
    ar_order: usize,
    level: LevelSpec,
) -> Result<JointFit, AnalysisError> {
    check_series(y, 1)?;
    if range.end > y.len() || range.len() < 4 * ar_order + cols.len() + 16 {
        return Err(NumError::TooShort {
            needed: 4 * ar_order + cols.len() + 16,
            got: range.len(),
        }
        .into());
    }
    for c in cols {
        check_same_len(y.len(), c.len())?;
        check_series(c, 1)?;
    }
    let x = design(cols, range.clone());
    let yv = DVector::from_column_slice(&y[range.clone()]);
    let mut coef = lstsq(&x, &yv)?;
    let mut ar = ArFit {
        coeffs: vec![],
        noise_var: 0.0,
        mean: 0.0,
    };
    if ar_order > 0 && !cols.is_empty() {
        for _ in 0..3 {
            let u: Vec<f64> = (&yv - &x * &coef).iter().copied().collect();
            ar = burg(&u, ar_order)?;
            let p = ar_order;
            let rows = range.len() - p;
            let xw = DMatrix::from_fn(rows, x.ncols(), |i, j| {
                let n = i + p;
                x[(n, j)]
                    - (1..=p)
                        .map(|l| ar.coeffs[l - 1] * x[(n - l, j)])
                        .sum::<f64>()
            });
            let yw = DVector::from_fn(rows, |i, _| {
                let n = i + p;
                yv[n] - (1..=p).map(|l| ar.coeffs[l - 1] * yv[n - l]).sum::<f64>()
            });
            coef = lstsq(&xw, &yw)?;
        }
    }
    let mut jf = JointFit {
        intercept: coef[0],
        beta: coef.iter().skip(1).copied().collect(),
        ar,
        level_gain: None,
        level_q_per_sample: None,
    };
    let mut d = jf.open_loop(y, cols);
    let mut k = match level {
        LevelSpec::None => {
            jf.ar = burg(&d[range.clone()], ar_order)?;
            return Ok(jf);
        }
        LevelSpec::Fixed(k) => k,
        LevelSpec::Fit => search_gain(&d, range.clone(), ar_order),
    };
    set_level(&mut jf, &d, range.clone(), ar_order, k)?;
    // GLS of (c, β) under the level + AR noise model: the one-step error is the linear causal
    // filter L(v) = A(B)[v − EWMA_K(v)] applied to y − c − Xβ, so (c, β) minimise
    // ‖L(y) − L([1, X])(c, β)‖². Without this a slow regressor would be credited with a random
    // walk's excursions (spurious regression); with it only their short-term co-movement counts.
    for _ in 0..2 {
        let end = range.end;
        let filt = |v: &[f64]| -> Vec<f64> {
            let l = level_track(&v[..end], k);
            let z: Vec<f64> = v[..end].iter().zip(&l).map(|(a, b)| a - b).collect();
            whiten(&z, &jf.ar.coeffs)
        };
        let ones = vec![1.0; end];
        let mut fcols = vec![filt(&ones)];
        fcols.extend(cols.iter().map(|c| filt(c)));
        let fy = filt(y);
        let start = range.start + ar_order;
        let xw = DMatrix::from_fn(end - start, fcols.len(), |i, j| fcols[j][start + i]);
        let yw = DVector::from_fn(end - start, |i, _| fy[start + i]);
        let Ok(coef) = lstsq(&xw, &yw) else { break };
        jf.intercept = coef[0];
        jf.beta = coef.iter().skip(1).copied().collect();
        d = jf.open_loop(y, cols);
        if level == LevelSpec::Fit {
            k = search_gain(&d, range.clone(), ar_order);
        }
        set_level(&mut jf, &d, range.clone(), ar_order, k)?;
        if cols.is_empty() {
            break;
        }
    }
    Ok(jf)
}

/// [`fit`] at every AR order 1..=max_order (element p − 1; `None` where that order cannot be
/// fitted). Without regressors or level the AR is fitted to one residual whatever the order, so
/// every order comes from one Burg pass (`burg_orders`); otherwise the GLS passes depend on the
/// order and each order is fitted separately.
pub fn fit_orders(
    y: &[f64],
    cols: &[Vec<f64>],
    range: Range<usize>,
    max_order: usize,
    level: LevelSpec,
) -> Vec<Option<JointFit>> {
    if !cols.is_empty() || level != LevelSpec::None {
        return (1..=max_order)
            .map(|p| fit(y, cols, range.clone(), p, level).ok())
            .collect();
    }
    // What `fit` does without regressors or level: intercept by OLS, Burg on the residual. Its
    // length check (`4 p + 16` samples) decides which orders are allowed.
    let usable = (1..=max_order)
        .take_while(|p| range.len() >= 4 * p + 16)
        .count();
    let Ok(first) = fit(y, cols, range.clone(), 1, level) else {
        return vec![None; max_order];
    };
    let d = first.open_loop(y, cols);
    let ars = burg_orders(&d[range], usable).unwrap_or_default();
    let mut out: Vec<Option<JointFit>> = ars
        .into_iter()
        .map(|ar| {
            Some(JointFit {
                ar,
                ..first.clone()
            })
        })
        .collect();
    out.resize(max_order, None);
    out
}

/// e_n = z_n − Σ φ_i z_{n−i} (the AR error filter, no mean: linear).
fn whiten(z: &[f64], phi: &[f64]) -> Vec<f64> {
    (0..z.len())
        .map(|n| {
            z[n] - (1..=phi.len().min(n))
                .map(|i| phi[i - 1] * z[n - i])
                .sum::<f64>()
        })
        .collect()
}

/// Level gain K minimising the one-step SSE on `range`: coarse log grid, then golden section.
fn search_gain(d: &[f64], range: Range<usize>, ar_order: usize) -> f64 {
    let grid: Vec<f64> = (0..14).map(|i| 10f64.powf(-7.0 + 0.5 * i as f64)).collect();
    let sse = |k: f64| -> f64 { level_sse(d, range.clone(), ar_order, k).unwrap_or(f64::INFINITY) };
    let vals: Vec<f64> = grid.iter().map(|k| sse(*k)).collect();
    let ib = vals
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|v| v.0)
        .unwrap_or(0);
    let (mut lo, mut hi) = (
        grid[ib.saturating_sub(1)].ln(),
        grid[(ib + 1).min(grid.len() - 1)].ln(),
    );
    let gr = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut dd) = (hi - gr * (hi - lo), lo + gr * (hi - lo));
    let (mut fc, mut fd) = (sse(c.exp()), sse(dd.exp()));
    for _ in 0..30 {
        if fc < fd {
            hi = dd;
            dd = c;
            fd = fc;
            c = hi - gr * (hi - lo);
            fc = sse(c.exp());
        } else {
            lo = c;
            c = dd;
            fc = fd;
            dd = lo + gr * (hi - lo);
            fd = sse(dd.exp());
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// Causal level predictions ℓ_n (from samples before n) with gain k, ℓ_0 = 0.
fn level_track(d: &[f64], k: f64) -> Vec<f64> {
    let mut l = 0.0;
    d.iter()
        .map(|v| {
            let out = l;
            l += k * (v - l);
            out
        })
        .collect()
}

fn innovations(z: &[f64], ar: &ArFit) -> Vec<f64> {
    let p = ar.coeffs.len();
    (0..z.len())
        .map(|n| {
            let mut pred = ar.mean;
            for i in 1..=p.min(n) {
                pred += ar.coeffs[i - 1] * (z[n - i] - ar.mean);
            }
            z[n] - pred
        })
        .collect()
}

fn level_sse(d: &[f64], range: Range<usize>, p: usize, k: f64) -> Result<f64, AnalysisError> {
    let d = &d[..range.end];
    let l = level_track(d, k);
    let z: Vec<f64> = d.iter().zip(&l).map(|(a, b)| a - b).collect();
    let ar = burg(&z[range.clone()], p)?;
    let e = innovations(&z, &ar);
    Ok(e[range].iter().map(|v| v * v).sum())
}

fn set_level(
    jf: &mut JointFit,
    d: &[f64],
    range: Range<usize>,
    p: usize,
    k: f64,
) -> Result<(), AnalysisError> {
    if !super::in_open_unit(k) {
        return Err(AnalysisError::bad("level gain must be in (0, 1)"));
    }
    let l = level_track(d, k);
    let z: Vec<f64> = d.iter().zip(&l).map(|(a, b)| a - b).collect();
    jf.ar = burg(&z[range.clone()], p)?;
    let r = {
        let s = &z[range];
        let m = s.iter().sum::<f64>() / s.len() as f64;
        s.iter().map(|v| (v - m).powi(2)).sum::<f64>() / s.len() as f64
    };
    jf.level_gain = Some(k);
    jf.level_q_per_sample = Some(k * k * r / (1.0 - k));
    Ok(())
}

impl JointFit {
    /// d = y − c − Xβ over the whole log.
    pub fn open_loop(&self, y: &[f64], cols: &[Vec<f64>]) -> Vec<f64> {
        (0..y.len())
            .map(|n| {
                y[n] - self.intercept
                    - cols
                        .iter()
                        .zip(&self.beta)
                        .map(|(c, b)| b * c[n])
                        .sum::<f64>()
            })
            .collect()
    }

    /// Both residuals over the whole log.
    pub fn residuals(&self, y: &[f64], cols: &[Vec<f64>]) -> Residuals {
        self.residuals_to(y, cols, y.len())
    }

    /// Both residuals for samples 0..end only (predictions need only the past, so a validation
    /// score need not compute a long test part).
    pub fn residuals_to(&self, y: &[f64], cols: &[Vec<f64>], end: usize) -> Residuals {
        let end = end.min(y.len());
        let d = self.open_loop(&y[..end], cols);
        let z: Vec<f64> = match self.level_gain {
            Some(k) => d
                .iter()
                .zip(level_track(&d, k))
                .map(|(a, b)| a - b)
                .collect(),
            None => d.clone(),
        };
        Residuals {
            innovation: innovations(&z, &self.ar),
            open_loop: d,
        }
    }
}

/// Mean of squares over a range.
pub fn mse(x: &[f64], range: Range<usize>) -> f64 {
    let n = range.len().max(1) as f64;
    x[range].iter().map(|v| v * v).sum::<f64>() / n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, ar_series};

    #[test]
    fn regression_with_ar1_errors_recovers_beta_and_phi() {
        // y = 1 + 0.5 x + u, u AR(1) phi = 0.8 (innovation sd 1), x a slow sine: the GLS
        // estimate of β has sd ≈ σ_e /(1 − φ)/(σ_x √N) ≈ 0.02 here; 0.08 is 4 sd. φ from Burg on
        // 20 000 samples: sd √((1 − φ²)/N) ≈ 0.004; ±0.02.
        let mut rng = Rng::new(17);
        let n = 20_000;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 / 700.0).sin()).collect();
        let mut u = 0.0;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                u = 0.8 * u + rng.normal();
                1.0 + 0.5 * x[i] + u
            })
            .collect();
        let f = fit(&y, std::slice::from_ref(&x), 0..n, 1, LevelSpec::None).unwrap();
        assert!((f.beta[0] - 0.5).abs() < 0.08, "{:?}", f.beta);
        assert!((f.ar.coeffs[0] - 0.8).abs() < 0.02, "{:?}", f.ar.coeffs);
        // One-step innovations of the right model have the innovation variance 1 (±3 %).
        let r = f.residuals(&y, &[x]);
        let v = mse(&r.innovation, 100..n);
        assert!((v - 1.0).abs() < 0.03, "{v}");
    }

    #[test]
    fn level_gain_tracks_a_random_walk() {
        // White noise sd 1 + random walk sd 0.02 per sample: q/R = 4e-4, so the optimal gain is
        // K = P/(P+R) with P = (q + √(q² + 4qR))/2 ≈ 0.0202, K ≈ 0.0198. The prediction-error
        // minimum is flat; a factor 2 around the optimum changes the MSE by < 1 %, so the fitted
        // K is only required within a factor 2, and the fitted q within a factor 4.
        let mut rng = Rng::new(5);
        let n = 40_000;
        let mut rw = 0.0;
        let y: Vec<f64> = (0..n)
            .map(|_| {
                rw += 0.02 * rng.normal();
                rw + rng.normal()
            })
            .collect();
        let f = fit(&y, &[], 0..n, 2, LevelSpec::Fit).unwrap();
        let k = f.level_gain.unwrap();
        assert!(k > 0.0099 && k < 0.04, "{k}");
        let q = f.level_q_per_sample.unwrap();
        assert!(q > 1e-4 && q < 1.6e-3, "{q}");
    }

    #[test]
    fn every_order_from_one_pass_equals_separate_fits() {
        // Without regressors or level, `fit_orders` must give what `fit` gives order by order
        // (same intercept, same AR to Burg's rounding: 1e-12); orders the range is too short
        // for are None, as `fit` errors there.
        let y: Vec<f64> = ar_series(&mut Rng::new(23), 3000, &[0.9], 1.0)
            .into_iter()
            .map(|u| 2.0 + u)
            .collect();
        let range = 100..200; // 100 samples: orders up to 21 allowed (4 p + 16 <= 100)
        let all = fit_orders(&y, &[], range.clone(), 25, LevelSpec::None);
        assert_eq!(all.len(), 25);
        for (i, f) in all.iter().enumerate() {
            let p = i + 1;
            match fit(&y, &[], range.clone(), p, LevelSpec::None) {
                Ok(one) => {
                    let f = f.as_ref().expect("fit_orders lost an order fit accepts");
                    assert_eq!(f.intercept, one.intercept);
                    for (a, b) in f.ar.coeffs.iter().zip(&one.ar.coeffs) {
                        assert!((a - b).abs() < 1e-12, "p={p}");
                    }
                    assert!((f.ar.noise_var / one.ar.noise_var - 1.0).abs() < 1e-12);
                }
                Err(_) => assert!(f.is_none(), "p={p}"),
            }
        }
        assert!(all[20].is_some() && all[21].is_none());
    }

    #[test]
    fn collinear_regressors_are_an_error() {
        let y: Vec<f64> = (0..200).map(|i| i as f64).collect();
        let c = vec![1.0; 200];
        assert!(fit(&y, &[c], 0..200, 1, LevelSpec::None).is_err());
    }
}
