//! Exogenous correlation of a residual: temperature (lagged, linear + quadratic), the other axes,
//! and the specific force (components and magnitude, for gyro g-sensitivity).
//!
//! Each is an ordinary least-squares regression with intercept,
//!   r_n = c_0 + Σ_j c_j z_{j,n} + e_n,
//! solved by Cholesky on the normal equations of the centred columns; the explained share is
//! R² = 1 − SSE/SST. Temperature enters as z_1 = T(t − L) − T_0, z_2 = z_1² with T_0 the mean of
//! the lagged series over the segment (so c_1 is the slope at T_0), and the lag L is scanned on
//! a grid 0..max_lag; the reported lag maximises R² (a thermal lag between the sensor's die and
//! its temperature sensor is common: the die follows with a first-order delay).
//! R² on serially correlated data is descriptive only: the close-the-loop decision is made by the
//! validation test in `diagnose`, never here.

use super::AnalysisError;
use crate::stats::{NumError, check_same_len, check_series};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// A least-squares fit with intercept.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Regression {
    /// c_0.
    pub intercept: f64,
    /// c_1..c_k in column order.
    pub coefficients: Vec<f64>,
    /// R² = 1 − SSE/SST.
    pub explained_share: f64,
    /// Samples used.
    pub n: usize,
}

/// OLS of `y` on `columns` plus an intercept.
pub fn ols(y: &[f64], columns: &[&[f64]]) -> Result<Regression, AnalysisError> {
    let n = y.len();
    let k = columns.len();
    check_series(y, k + 2)?;
    for c in columns {
        check_same_len(n, c.len())?;
        check_series(c, 1)?;
    }
    let nf = n as f64;
    let ym = y.iter().sum::<f64>() / nf;
    let means: Vec<f64> = columns.iter().map(|c| c.iter().sum::<f64>() / nf).collect();
    let sst: f64 = y.iter().map(|v| (v - ym) * (v - ym)).sum();
    if k == 0 {
        return Ok(Regression {
            intercept: ym,
            coefficients: vec![],
            explained_share: 0.0,
            n,
        });
    }
    // Normal equations of the centred problem (better conditioned than with a ones column).
    let mut ata = DMatrix::<f64>::zeros(k, k);
    let mut atb = DVector::<f64>::zeros(k);
    for i in 0..n {
        for a in 0..k {
            let za = columns[a][i] - means[a];
            atb[a] += za * (y[i] - ym);
            for b in a..k {
                ata[(a, b)] += za * (columns[b][i] - means[b]);
            }
        }
    }
    for a in 0..k {
        for b in 0..a {
            ata[(a, b)] = ata[(b, a)];
        }
    }
    let sol = ata
        .cholesky()
        .ok_or_else(|| AnalysisError::singular("ols: dependent or constant columns"))?
        .solve(&atb);
    let coefficients: Vec<f64> = sol.iter().copied().collect();
    let ssr: f64 = coefficients
        .iter()
        .zip(atb.iter())
        .map(|(c, b)| c * b)
        .sum();
    let intercept = ym
        - coefficients
            .iter()
            .zip(&means)
            .map(|(c, m)| c * m)
            .sum::<f64>();
    let share = if sst > 0.0 {
        (ssr / sst).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Ok(Regression {
        intercept,
        coefficients,
        explained_share: share,
        n,
    })
}

/// `x` delayed by `lag` samples (x_{n−lag}), the first sample held before the start.
pub fn lagged(x: &[f64], lag: usize) -> Vec<f64> {
    (0..x.len()).map(|n| x[n.saturating_sub(lag)]).collect()
}

/// Result of the lag scan of a polynomial in a lagged exogenous series.
#[derive(Clone, Debug, Serialize)]
pub struct LagScan {
    /// Best lag, s.
    pub lag_s: f64,
    /// Best lag, samples.
    pub lag_samples: usize,
    /// Centre T_0 of the polynomial (mean of the lagged series over the segment).
    pub x0: f64,
    /// Fit at the best lag: coefficients of (x − x0), (x − x0)², ...
    pub fit: Regression,
    /// (lag_s, R²) for every lag tried.
    pub share_by_lag: Vec<(f64, f64)>,
}

/// Scan lags 0..=max_lag_s in steps of step_s: regress `y` (which is samples
/// `offset..offset+y.len()` of the log) on powers 1..=degree of the centred lagged `x` (whole log).
pub fn lagged_polynomial_scan(
    y: &[f64],
    x: &[f64],
    offset: usize,
    rate_hz: f64,
    max_lag_s: f64,
    step_s: f64,
    degree: usize,
) -> Result<LagScan, AnalysisError> {
    if !super::is_pos(rate_hz)
        || !super::is_pos(step_s)
        || !(super::is_pos(max_lag_s) || max_lag_s == 0.0)
        || degree == 0
    {
        return Err(AnalysisError::bad(
            "lagged_polynomial_scan: rate, lag grid or degree",
        ));
    }
    if offset + y.len() > x.len() {
        return Err(NumError::LengthMismatch {
            expected: offset + y.len(),
            got: x.len(),
        }
        .into());
    }
    check_series(x, 1)?;
    let step = ((step_s * rate_hz).round() as usize).max(1);
    let max_lag = (max_lag_s * rate_hz).round() as usize;
    let mut best: Option<LagScan> = None;
    let mut shares = Vec::new();
    let mut lag = 0;
    while lag <= max_lag {
        let xl: Vec<f64> = (offset..offset + y.len())
            .map(|n| x[n.saturating_sub(lag)])
            .collect();
        let x0 = xl.iter().sum::<f64>() / xl.len().max(1) as f64;
        let cols: Vec<Vec<f64>> = (1..=degree)
            .map(|d| xl.iter().map(|v| (v - x0).powi(d as i32)).collect())
            .collect();
        let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        // A constant exogenous series (e.g. a temperature that never moved) has nothing to say.
        let Ok(fit) = ols(y, &refs) else {
            lag += step;
            continue;
        };
        shares.push((lag as f64 / rate_hz, fit.explained_share));
        if best
            .as_ref()
            .is_none_or(|b| fit.explained_share > b.fit.explained_share)
        {
            best = Some(LagScan {
                lag_s: lag as f64 / rate_hz,
                lag_samples: lag,
                x0,
                fit,
                share_by_lag: vec![],
            });
        }
        lag += step;
    }
    let mut b = best.ok_or_else(|| {
        AnalysisError::singular("lagged_polynomial_scan: exogenous series constant")
    })?;
    b.share_by_lag = shares;
    Ok(b)
}

/// Correlation of the residual with another axis.
#[derive(Clone, Debug, Serialize)]
pub struct AxisCorrelation {
    /// Channel name.
    pub name: String,
    /// Pearson correlation.
    pub correlation: f64,
    /// OLS slope of the residual on that axis.
    pub coefficient: f64,
}

/// All exogenous findings for one residual segment.
#[derive(Clone, Debug, Serialize, Default)]
pub struct ExogenousReport {
    /// Temperature, lagged linear + quadratic.
    pub temperature: Option<LagScan>,
    /// The other axes one by one.
    pub other_axes: Vec<AxisCorrelation>,
    /// Specific-force components f_x, f_y, f_z (gyro g-sensitivity), m/s².
    pub specific_force: Option<Regression>,
    /// Specific-force magnitude |f| (linear).
    pub specific_force_magnitude: Option<Regression>,
}

/// Exogenous series available for a channel (whole-log length each).
#[derive(Clone, Copy, Debug, Default)]
pub struct Exogenous<'a> {
    /// Temperature, °C.
    pub temperature_c: Option<&'a [f64]>,
    /// Specific force x, y, z, m/s².
    pub specific_force_m_s2: Option<[&'a [f64]; 3]>,
    /// Other channels by name.
    pub other_axes: &'a [(String, &'a [f64])],
}

/// Run all exogenous regressions on the residual segment `y` (samples `offset..` of the log).
pub fn analyse(
    y: &[f64],
    offset: usize,
    rate_hz: f64,
    exo: &Exogenous<'_>,
    max_temp_lag_s: f64,
) -> Result<ExogenousReport, AnalysisError> {
    let range = offset..offset + y.len();
    let mut rep = ExogenousReport::default();
    if let Some(t) = exo.temperature_c {
        rep.temperature =
            lagged_polynomial_scan(y, t, offset, rate_hz, max_temp_lag_s, 1.0, 2).ok();
    }
    for (name, a) in exo.other_axes {
        if a.len() < range.end {
            return Err(NumError::LengthMismatch {
                expected: range.end,
                got: a.len(),
            }
            .into());
        }
        let seg = &a[range.clone()];
        if let Ok(fit) = ols(y, &[seg]) {
            rep.other_axes.push(AxisCorrelation {
                name: name.clone(),
                correlation: fit.coefficients[0].signum() * fit.explained_share.sqrt(),
                coefficient: fit.coefficients[0],
            });
        }
    }
    if let Some(f) = exo.specific_force_m_s2 {
        for c in f {
            if c.len() < range.end {
                return Err(NumError::LengthMismatch {
                    expected: range.end,
                    got: c.len(),
                }
                .into());
            }
        }
        let segs = [
            &f[0][range.clone()],
            &f[1][range.clone()],
            &f[2][range.clone()],
        ];
        rep.specific_force = ols(y, &segs).ok();
        let mag: Vec<f64> = range
            .clone()
            .map(|n| (f[0][n].powi(2) + f[1][n].powi(2) + f[2][n].powi(2)).sqrt())
            .collect();
        rep.specific_force_magnitude = ols(y, &[&mag]).ok();
    }
    Ok(rep)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn ols_recovers_exact_coefficients() {
        // Noise-free linear data: the solution is exact up to rounding.
        let x1: Vec<f64> = (0..100).map(|i| (i as f64 * 0.1).sin()).collect();
        let x2: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
        let y: Vec<f64> = (0..100).map(|i| 2.0 - 3.0 * x1[i] + 0.5 * x2[i]).collect();
        let r = ols(&y, &[&x1, &x2]).unwrap();
        assert!((r.intercept - 2.0).abs() < 1e-10);
        assert!((r.coefficients[0] + 3.0).abs() < 1e-10 && (r.coefficients[1] - 0.5).abs() < 1e-10);
        assert!((r.explained_share - 1.0).abs() < 1e-12);
    }

    #[test]
    fn lag_scan_finds_the_thermal_lag() {
        // y = 0.2 (T(t−12 s) − 30) + 0.01 (T(t−12 s) − 30)² + white noise sd 0.05, T a 5 °C
        // sinusoid of period 400 s. A lag error of 1 s shifts the regressor by dT/dt·1 s ≈ 0.08 °C
        // at the steepest point, i.e. an unexplained ≈ 0.2·0.08·0.7 ≈ 0.011 rms against the 0.05
        // noise over 5000 samples: its SSE cost (≈ 0.6) is many times the noise in the SSE
        // difference (≈ 2·0.05·0.011·√5000 ≈ 0.08), so the scan picks the true lag ±1 s. With
        // the lag right, c1 and c2 have sd ≈ 0.05/(σ_T √N) ≈ 2e-4 and 6e-5: ±5 % is > 20 sd.
        let fs = 10.0;
        let n: usize = 6000;
        let temp: Vec<f64> = (0..n)
            .map(|i| 30.0 + 5.0 * (2.0 * std::f64::consts::PI * i as f64 / fs / 400.0).sin())
            .collect();
        let mut rng = Rng::new(9);
        let lag: usize = 120;
        let y: Vec<f64> = (0..n)
            .map(|i: usize| {
                let d = temp[i.saturating_sub(lag)] - 30.0;
                0.2 * d + 0.01 * d * d + 0.05 * rng.normal()
            })
            .collect();
        let scan = lagged_polynomial_scan(&y[1000..], &temp, 1000, fs, 30.0, 1.0, 2).unwrap();
        assert!((scan.lag_s - 12.0).abs() <= 1.0, "lag {}", scan.lag_s);
        // Convert to the centre 30 °C: c1(30) = c1(x0) + 2 c2 (30 − x0).
        let c2 = scan.fit.coefficients[1];
        let c1_at_30 = scan.fit.coefficients[0] + 2.0 * c2 * (30.0 - scan.x0);
        assert!(
            (c1_at_30 - 0.2).abs() < 0.01 && (c2 - 0.01).abs() < 5e-4,
            "{c1_at_30} {c2}"
        );
    }

    #[test]
    fn constant_exogenous_is_an_error_not_a_panic() {
        let y = vec![1.0, 2.0, 3.0, 4.0, 5.0];
        assert!(ols(&y, &[&[1.0; 5]]).is_err());
        assert!(lagged_polynomial_scan(&y, &[2.0; 5], 0, 1.0, 2.0, 1.0, 1).is_err());
        assert!(ols(&y, &[&[1.0; 4]]).is_err());
    }
}
