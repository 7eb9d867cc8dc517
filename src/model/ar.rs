//! AR(p) model type shared by the three fitters, and the Yule-Walker (autocorrelation) method
//! solved by the Levinson-Durbin recursion.
//!
//! Model (mean removed): `x[n] - mu = sum_{i=1..p} phi_i (x[n-i] - mu) + e[n]`, `var(e) = sigma_e^2`.
//! The paper (Tamazin, Noureldin & Korenberg 2013, eqs 3-4) writes the same model with
//! `a_k = -phi_k`; we keep the statsmodels sign so coefficients compare directly.
//!
//! Yule-Walker (paper eqs 7-9): with the *biased* autocovariance
//! `R(k) = (1/N) sum_{n=k}^{N-1} (x[n]-mu)(x[n-k]-mu)` the normal equations `R phi = r` are
//! Toeplitz and are solved by Levinson-Durbin (eqs 9b-9g, in the phi sign):
//! `E_0 = R(0)`; `k_m = (R(m) - sum_{i<m} phi_{i,m-1} R(m-i)) / E_{m-1}`; `phi_{m,m} = k_m`;
//! `phi_{i,m} = phi_{i,m-1} - k_m phi_{m-i,m-1}`; `E_m = (1 - k_m^2) E_{m-1}`.
//! `sigma_e^2 = E_p = R(0) - sum phi_i R(i)` (eq 9a). The biased estimate keeps the Toeplitz
//! matrix positive semidefinite, so |k_m| <= 1 and the fitted model is stable
//! (statsmodels `yule_walker(method="mle")` uses the same estimate).

use super::{ModelError, check_ar_input, mean};
use crate::stats::NumError;
use crate::stats::ar_poly::{levinson, levinson_step};

/// A fitted AR(p) model.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ArFit {
    /// phi_1..phi_p in `x[n]-mean = sum_i phi_i (x[n-i]-mean) + e[n]`.
    pub coeffs: Vec<f64>,
    /// Variance of e (one-step prediction error variance on the fit data), units of x squared.
    pub noise_var: f64,
    /// Mean removed before fitting, units of x.
    pub mean: f64,
}

impl ArFit {
    /// Model order p.
    pub fn order(&self) -> usize {
        self.coeffs.len()
    }

    /// One-step prediction of the next value from past values, newest last.
    ///
    /// Uses `history[len-i]` as `x[n-i]`. If fewer than p values are given, the missing
    /// (older) ones are taken as the mean, i.e. their deviation contributes nothing; this keeps
    /// the call total (no panic, no allocation) during start-up.
    #[inline]
    pub fn predict_next(&self, history_newest_last: &[f64]) -> f64 {
        let h = history_newest_last;
        let mut acc = self.mean;
        for (i, phi) in self.coeffs.iter().enumerate() {
            // x[n-1-i] is at h[len-1-i]
            if let Some(idx) = h.len().checked_sub(i + 1) {
                acc += phi * (h[idx] - self.mean);
            }
        }
        acc
    }

    /// One-step prediction residuals `x[n] - predict(x[..n])` for `n` in `range`, each using the
    /// full past of `x` (so a test segment can be scored with its true preceding history).
    /// Indices below p use the shortened history of [`ArFit::predict_next`].
    pub fn residuals(&self, x: &[f64], range: std::ops::Range<usize>) -> Vec<f64> {
        let end = range.end.min(x.len());
        (range.start.min(end)..end)
            .map(|n| x[n] - self.predict_next(&x[..n]))
            .collect()
    }
}

/// Biased autocovariance `R(k) = (1/N) sum_{n=k}^{N-1} (x[n]-mu)(x[n-k]-mu)` for k = 0..=max_lag,
/// with `mu` the sample mean. Returns (R, mu). Lags beyond N-1 are zero.
pub fn autocovariance_biased(x: &[f64], max_lag: usize) -> (Vec<f64>, f64) {
    let mu = mean(x);
    let d: Vec<f64> = x.iter().map(|v| v - mu).collect();
    let n = d.len() as f64;
    // one blocked pass, every lag's sum over several accumulators (`kernels`)
    let r = super::kernels::lagged_products(&d, max_lag)
        .into_iter()
        .map(|s| s / n)
        .collect();
    (r, mu)
}

/// Fit AR(p) by the Yule-Walker method (biased autocovariance, Levinson-Durbin).
pub fn yule_walker(x: &[f64], p: usize) -> Result<ArFit, ModelError> {
    check_ar_input(x, p)?;
    let (r, mu) = autocovariance_biased(x, p);
    if r[0].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(ModelError::Numeric(NumError::Constant));
    }
    let l = levinson(&r, p).ok_or_else(|| {
        ModelError::singular("Levinson-Durbin error energy reached zero".to_string())
    })?;
    Ok(ArFit {
        coeffs: l.phi,
        noise_var: l.var,
        mean: mu,
    })
}

/// Yule-Walker fits of every order 1..=p from one autocovariance and one Levinson-Durbin
/// recursion (which passes through every order): element `m - 1` is the AR(m) fit, equal to
/// `yule_walker(x, m)` to rounding.
///
/// Fewer than p fits are returned only when the prediction-error variance reaches zero at some
/// order q + 1 > 1 (`yule_walker(x, q + 1)` is then an error); an error is returned when no
/// order can be fitted.
pub fn yule_walker_orders(x: &[f64], p: usize) -> Result<Vec<ArFit>, ModelError> {
    check_ar_input(x, p)?;
    let (r, mu) = autocovariance_biased(x, p);
    if r[0].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(ModelError::Numeric(NumError::Constant));
    }
    // The Durbin–Levinson recursion, keeping each order's (phi, E_m).
    let mut fits: Vec<ArFit> = Vec::with_capacity(p);
    let mut phi: Vec<f64> = Vec::with_capacity(p);
    let mut e = r[0];
    for _ in 1..=p {
        levinson_step(&r, &mut phi, &mut e);
        if e.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            break;
        }
        fits.push(ArFit {
            coeffs: phi.clone(),
            noise_var: e,
            mean: mu,
        });
    }
    if fits.is_empty() {
        return Err(ModelError::singular(format!(
            "Levinson-Durbin error energy reached {e} at order 1"
        )));
    }
    Ok(fits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn ar1(phi: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let mut x = Vec::with_capacity(n);
        let mut v = 0.0;
        for _ in 0..n {
            v = phi * v + rng.normal();
            x.push(v);
        }
        x
    }

    #[test]
    fn yule_walker_ar1_recovers_phi() {
        // N = 100k: sd of phi_hat = sqrt((1-phi^2)/N) = 0.0014 for phi = 0.8; 5 sd bound.
        let x = ar1(0.8, 100_000, 11);
        let f = yule_walker(&x, 1).unwrap();
        assert!((f.coeffs[0] - 0.8).abs() < 0.007, "{:?}", f.coeffs);
        // noise variance 1: sd of the estimate ~ sqrt(2/N) = 0.0045; 5 sd
        assert!((f.noise_var - 1.0).abs() < 0.023, "{}", f.noise_var);
    }

    #[test]
    fn levinson_matches_direct_toeplitz_solve() {
        // Closed form check: the recursion must solve R phi = r exactly (to rounding).
        let x = ar1(0.5, 2000, 3);
        let p = 6;
        let (r, _) = autocovariance_biased(&x, p);
        let l = levinson(&r, p).unwrap();
        let (phi, e) = (l.phi, l.var);
        let m = nalgebra::DMatrix::from_fn(p, p, |i, j| r[i.abs_diff(j)]);
        let rhs = nalgebra::DVector::from_fn(p, |i, _| r[i + 1]);
        let sol = m.lu().solve(&rhs).unwrap();
        for i in 0..p {
            // well conditioned 6x6 system: agreement to ~1e-13 relative; 1e-12 absolute
            assert!((phi[i] - sol[i]).abs() < 1e-12);
        }
        let e_direct = r[0] - (0..p).map(|i| phi[i] * r[i + 1]).sum::<f64>();
        assert!((e - e_direct).abs() < 1e-12);
    }

    #[test]
    fn yule_walker_orders_match_one_fit_per_order() {
        // Same autocovariance, same recursion: each order's fit equals a separate Levinson
        // solve of that order to rounding (1e-13 for these well-conditioned AR(1)-like systems).
        let x = ar1(0.7, 5003, 9);
        let all = yule_walker_orders(&x, 8).unwrap();
        assert_eq!(all.len(), 8);
        for (m0, fit) in all.iter().enumerate() {
            let one = yule_walker(&x, m0 + 1).unwrap();
            assert_eq!(fit.coeffs.len(), m0 + 1);
            for (u, v) in fit.coeffs.iter().zip(&one.coeffs) {
                assert!((u - v).abs() < 1e-13);
            }
            assert!((fit.noise_var / one.noise_var - 1.0).abs() < 1e-13);
            assert_eq!(fit.mean, one.mean);
        }
        assert_eq!(
            yule_walker_orders(&[2.0; 20], 2),
            Err(ModelError::Numeric(NumError::Constant))
        );
    }

    #[test]
    fn yule_walker_rejects_bad_input() {
        assert_eq!(yule_walker(&[1.0; 10], 0), Err(ModelError::BadOrder(0)));
        assert!(matches!(
            yule_walker(&[1.0, 2.0], 3),
            Err(ModelError::Numeric(NumError::TooShort { .. }))
        ));
        assert_eq!(
            yule_walker(&[1.0, f64::NAN, 2.0, 3.0], 1),
            Err(ModelError::Numeric(NumError::NonFinite { index: 1 }))
        );
        assert_eq!(
            yule_walker(&[2.0; 20], 2),
            Err(ModelError::Numeric(NumError::Constant))
        );
    }

    #[test]
    fn predict_next_uses_newest_last_and_tolerates_short_history() {
        let f = ArFit {
            coeffs: vec![0.5, 0.25],
            noise_var: 1.0,
            mean: 10.0,
        };
        // x[n-1] = 12 (dev 2), x[n-2] = 14 (dev 4): 10 + 0.5*2 + 0.25*4 = 12
        assert_eq!(f.predict_next(&[14.0, 12.0]), 12.0);
        // short history: only x[n-1] known, the missing one counts as the mean
        assert_eq!(f.predict_next(&[12.0]), 11.0);
        assert_eq!(f.predict_next(&[]), 10.0);
    }
}
