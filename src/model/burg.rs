//! AR(p) by Burg's method (Burg 1975; Tamazin, Noureldin & Korenberg 2013, eqs 10-13).
//!
//! With the mean removed, forward and backward prediction errors start as
//! `f_0(n) = b_0(n) = x(n) - mu`. At stage m = 1..p the reflection coefficient minimises the
//! summed forward + backward error energy (eq 13, here in the phi sign, `a = -phi`):
//! `k_m = 2 sum_{n=m}^{N-1} f_{m-1}(n) b_{m-1}(n-1) / sum_{n=m}^{N-1} [f_{m-1}(n)^2 + b_{m-1}(n-1)^2]`,
//! and the lattice recursions (eqs 12a, 12b) are
//! `f_m(n) = f_{m-1}(n) - k_m b_{m-1}(n-1)`, `b_m(n) = b_{m-1}(n-1) - k_m f_{m-1}(n)`.
//! |k_m| <= 1 by the Cauchy-Schwarz inequality, so the model is stable. The AR coefficients
//! follow from the k_m by the Levinson step (eq 9e). The noise variance is the mean of the
//! final forward and backward error energies, `sum_{n=p}^{N-1} (f_p^2 + b_p^2) / (2 (N - p))`,
//! which is the `sigma2` of statsmodels `burg` (its `(1-k_p^2) d_p / (2 (N-p))`).

use super::ar::ArFit;
use super::{ModelError, check_ar_input, mean};
use crate::stats::ar_poly::reflection_to_ar;

/// Fit AR(p) by Burg's method.
pub fn burg(x: &[f64], p: usize) -> Result<ArFit, ModelError> {
    check_ar_input(x, p)?;
    let mu = mean(x);
    let mut f: Vec<f64> = x.iter().map(|v| v - mu).collect();
    let mut b = f.clone();
    let n = f.len();
    let mut refl = Vec::with_capacity(p);
    let mut energy = 0.0;
    for m in 1..=p {
        // k_m over n = m..N-1 (f_{m-1}(n), b_{m-1}(n-1) valid there)
        let mut num = 0.0;
        let mut den = 0.0;
        for i in m..n {
            num += f[i] * b[i - 1];
            den += f[i] * f[i] + b[i - 1] * b[i - 1];
        }
        if den.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(if m == 1 {
                ModelError::ZeroVariance
            } else {
                ModelError::Singular(format!("Burg error energy vanished at order {m}"))
            });
        }
        let k = 2.0 * num / den;
        // update downwards so that b[i-1] still holds stage m-1 when it is read
        energy = 0.0;
        for i in (m..n).rev() {
            let fi = f[i] - k * b[i - 1];
            let bi = b[i - 1] - k * f[i];
            f[i] = fi;
            b[i] = bi;
            energy += fi * fi + bi * bi;
        }
        refl.push(k);
    }
    Ok(ArFit {
        coeffs: reflection_to_ar(&refl),
        noise_var: energy / (2.0 * (n - p) as f64),
        mean: mu,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn burg_ar1_recovers_phi() {
        let mut rng = Rng::new(21);
        let mut v = 0.0;
        let x: Vec<f64> = (0..100_000)
            .map(|_| {
                v = -0.6 * v + 0.5 * rng.normal();
                v
            })
            .collect();
        let f = burg(&x, 1).unwrap();
        // sd(phi_hat) = sqrt((1-0.36)/1e5) = 0.0025; 5 sd
        assert!((f.coeffs[0] + 0.6).abs() < 0.013, "{:?}", f.coeffs);
        // noise var 0.25, sd ~ 0.25*sqrt(2/N) = 0.0011; 5 sd
        assert!((f.noise_var - 0.25).abs() < 0.0056, "{}", f.noise_var);
    }

    #[test]
    fn burg_model_is_stable_even_near_a_unit_root() {
        // A random walk (unit root): Burg's reflection coefficients, recovered from the AR
        // coefficients by the step-down recursion, must all have |k| < 1 (a stable model).
        let mut rng = Rng::new(4);
        let mut v = 0.0;
        let x: Vec<f64> = (0..5000)
            .map(|_| {
                v += rng.normal();
                v
            })
            .collect();
        let f = burg(&x, 6).unwrap();
        let k = crate::stats::ar_poly::reflection_coefficients(&f.coeffs, 0.0).expect("stable");
        assert!(k.iter().all(|k| k.abs() < 1.0), "{k:?}");
        // the first reflection coefficient of a random walk is close to 1
        assert!(k[0] > 0.99, "{k:?}");
    }

    #[test]
    fn burg_rejects_constant_series() {
        assert_eq!(burg(&[3.0; 50], 2), Err(ModelError::ZeroVariance));
    }
}
