//! AR(p) by the covariance method (Tamazin, Noureldin & Korenberg 2013, section 3.2).
//!
//! Least squares on the forward prediction error over the samples whose whole past exists (no
//! windowing): with `d(n) = x(n) - mu`, minimise `sum_{n=p}^{N-1} (d(n) - sum_i phi_i d(n-i))^2`.
//! The normal equations `C phi = c` use the covariance
//! `C(i,j) = sum_{n=p}^{N-1} d(n-i) d(n-j)` (i, j = 1..p) and `c(i) = C(i,0)`; C is not
//! Toeplitz, so it is solved by Cholesky (nalgebra). The noise variance is the residual energy
//! divided by the number of residuals, `N - p`. The method does not guarantee stability.

use super::ar::ArFit;
use super::{ModelError, check_ar_input, mean};
use crate::stats::NumError;
use nalgebra::{DMatrix, DVector};

/// Fit AR(p) by the covariance (least-squares) method.
pub fn covariance(x: &[f64], p: usize) -> Result<ArFit, ModelError> {
    check_ar_input(x, p)?;
    let mu = mean(x);
    let d: Vec<f64> = x.iter().map(|v| v - mu).collect();
    let n = d.len();
    let m = n - p; // number of equations
    // cov(i, j) = sum_{n=p}^{N-1} d(n-i) d(n-j), i, j = 0..=p. Each is a dot product of two
    // length-m windows.
    let win = |i: usize| &d[p - i..n - i];
    let mut c = DMatrix::<f64>::zeros(p + 1, p + 1);
    for i in 0..=p {
        for j in i..=p {
            let s: f64 = win(i).iter().zip(win(j)).map(|(a, b)| a * b).sum();
            c[(i, j)] = s;
            c[(j, i)] = s;
        }
    }
    if c[(0, 0)] <= 0.0 {
        return Err(ModelError::Numeric(NumError::Constant));
    }
    let a = c.view((1, 1), (p, p)).into_owned();
    let rhs = DVector::from_fn(p, |i, _| c[(i + 1, 0)]);
    let max_diag = (0..p).map(|i| a[(i, i)]).fold(0.0, f64::max);
    let chol = a
        .cholesky()
        .ok_or_else(|| ModelError::singular("covariance matrix not positive definite"))?;
    // Cholesky may "succeed" on an exactly singular matrix through rounding; a pivot below
    // 1e-12 of the largest diagonal means fewer than ~4 significant digits would survive in
    // phi, so report the system as singular instead of returning noise.
    let l = chol.l_dirty();
    let min_pivot_sq = (0..p)
        .map(|i| l[(i, i)] * l[(i, i)])
        .fold(f64::INFINITY, f64::min);
    if min_pivot_sq.is_nan() || min_pivot_sq <= 1e-12 * max_diag {
        return Err(ModelError::singular(format!(
            "covariance matrix ill-conditioned (pivot^2 {min_pivot_sq:e} vs diag {max_diag:e})"
        )));
    }
    let phi = chol.solve(&rhs);
    // residual energy = c00 - 2 phi.c + phi' A phi = c00 - phi.c at the LS solution; computed
    // directly from the residuals instead, which does not lose digits when the fit is tight.
    let mut energy = 0.0;
    for t in p..n {
        let mut e = d[t];
        for (i, ph) in phi.iter().enumerate() {
            e -= ph * d[t - 1 - i];
        }
        energy += e * e;
    }
    Ok(ArFit {
        coeffs: phi.iter().copied().collect(),
        noise_var: energy / m as f64,
        mean: mu,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, ar_series};

    #[test]
    fn covariance_ar2_recovers_coefficients() {
        // AR(2) with phi = (1.2, -0.5) (stable, complex poles), N = 100k.
        let x: Vec<f64> = ar_series(&mut Rng::new(8), 100_000, &[1.2, -0.5], 1.0)
            .into_iter()
            .map(|v| v + 3.0)
            .collect();
        let f = covariance(&x, 2).unwrap();
        // asymptotic sd of each phi_hat is sqrt((1-phi2^2)/N) = 0.0027; 5 sd
        assert!((f.coeffs[0] - 1.2).abs() < 0.014, "{:?}", f.coeffs);
        assert!((f.coeffs[1] + 0.5).abs() < 0.014, "{:?}", f.coeffs);
        // the mean is removed: 3.0 within 5 sd of the sample mean (sd = 1/(1-1.2+0.5)/sqrt(N) = 0.0105)
        assert!((f.mean - 3.0).abs() < 0.053);
    }

    #[test]
    fn covariance_equals_nalgebra_least_squares() {
        // The normal-equation solution must equal an SVD least-squares solve of the same system.
        let mut rng = Rng::new(9);
        let x: Vec<f64> = (0..500).map(|_| rng.normal()).collect();
        let p = 3;
        let f = covariance(&x, p).unwrap();
        let mu = f.mean;
        let rows = x.len() - p;
        let a = DMatrix::from_fn(rows, p, |r, c| x[r + p - 1 - c] - mu);
        let b = DVector::from_fn(rows, |r, _| x[r + p] - mu);
        let sol = a.svd(true, true).solve(&b, 1e-14).unwrap();
        for i in 0..p {
            // 500x3 well-conditioned system: both solutions agree to ~1e-14; 1e-12 allows rounding
            assert!((f.coeffs[i] - sol[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn covariance_reports_singular_for_perfectly_collinear_lags() {
        // A pure alternating series: d(n-1) = -d(n-2) exactly, so the 2x2 matrix is singular.
        let x: Vec<f64> = (0..40)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert!(matches!(
            covariance(&x, 2),
            Err(ModelError::Numeric(NumError::Singular(_)))
        ));
    }
}
