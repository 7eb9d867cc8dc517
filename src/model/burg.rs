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
//!
//! Burg's method is order-recursive: the stage-m errors give k_m and the stage-m fit, so one pass
//! over orders 1..p yields every order's fit ([`burg_orders`]); `burg(x, p)` is its last one.
//! Each stage is one blocked pass over the data: the lattice update of a block and the sums of
//! the next stage's k over it (while the block is in L1), each sum split over independent
//! accumulators (`kernels`). With the pairs `(f_{m-1}(n), b_{m-1}(n-1))` stored aligned
//! (f from index m, b from index 0), the update is element-wise and in place. The stage-m error
//! energy is the next stage's denominator plus the two end terms it leaves out,
//! `f_m(m)^2 + b_m(N-1)^2`, so no extra pass is needed for any order's noise variance.

use super::ar::ArFit;
use super::kernels::{BLOCK, CrossEnergy, sum};
use super::{ModelError, check_ar_input};
use crate::stats::NumError;
use crate::stats::ar_poly::step_up;

/// Fit AR(p) by Burg's method.
pub fn burg(x: &[f64], p: usize) -> Result<ArFit, ModelError> {
    let (mut fits, err) = burg_lattice(x, p)?;
    match err {
        Some(e) => Err(e),
        None => fits.pop().ok_or(ModelError::BadOrder(p)),
    }
}

/// Burg fits of every order 1..=p from one lattice pass: element `m - 1` is the AR(m) fit, equal
/// (to rounding) to `burg(x, m)`.
///
/// Fewer than p fits are returned only when the error energy vanishes at some order q + 1 > 1
/// (a perfectly predictable series; `burg(x, q + 1)` is then an error); an error is returned when
/// no order can be fitted.
pub fn burg_orders(x: &[f64], p: usize) -> Result<Vec<ArFit>, ModelError> {
    let (fits, err) = burg_lattice(x, p)?;
    match err {
        Some(e) if fits.is_empty() => Err(e),
        _ => Ok(fits),
    }
}

/// The lattice: the fits reached and, if it stopped early, why.
fn burg_lattice(x: &[f64], p: usize) -> Result<(Vec<ArFit>, Option<ModelError>), ModelError> {
    check_ar_input(x, p)?;
    let n = x.len();
    let mu = sum(x) / n as f64;
    // Stage-1 pairs: f_0(n) = x(n) - mu at f[n], b_0(n-1) at b[n-1], for n = 1..N-1.
    let mut f: Vec<f64> = x.iter().map(|v| v - mu).collect();
    let mut b = f.clone();
    let (mut num, mut den) = {
        let mut acc = CrossEnergy::new();
        acc.add(&f[1..], &b[..n - 1]);
        acc.finish()
    };
    let mut fits: Vec<ArFit> = Vec::with_capacity(p);
    let mut phi: Vec<f64> = Vec::with_capacity(p);
    for m in 1..=p {
        // den = sum_{n=m}^{N-1} f_{m-1}(n)^2 + b_{m-1}(n-1)^2
        if den.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            let e = if m == 1 {
                ModelError::Numeric(NumError::Constant)
            } else {
                ModelError::singular(format!("Burg error energy vanished at order {m}"))
            };
            return Ok((fits, Some(e)));
        }
        let k = 2.0 * num / den;
        // Stage-m pairs at fw[j] = f_{m-1}(m+j), bw[j] = b_{m-1}(m-1+j), j = 0..N-m. After the
        // update fw[j] = f_m(m+j), bw[j] = b_m(m+j), and the next stage's pairs are
        // (fw[j+1], bw[j]).
        let len = n - m;
        let fw = &mut f[m..n];
        let bw = &mut b[..len];
        let mut acc = CrossEnergy::new();
        let mut start = 0;
        while start < len {
            let end = (start + BLOCK).min(len);
            for (fj, bj) in fw[start..end].iter_mut().zip(bw[start..end].iter_mut()) {
                let (fo, bo) = (*fj, *bj);
                *fj = fo - k * bo;
                *bj = bo - k * fo;
            }
            let lo = start.max(1);
            if lo < end {
                acc.add(&fw[lo..end], &bw[lo - 1..end - 1]);
            }
            start = end;
        }
        let (num_next, den_next) = acc.finish();
        // stage-m energy sum_{n=m}^{N-1} f_m(n)^2 + b_m(n)^2
        let energy = den_next + fw[0] * fw[0] + bw[len - 1] * bw[len - 1];
        step_up(&mut phi, k);
        fits.push(ArFit {
            coeffs: phi.clone(),
            noise_var: energy / (2.0 * len as f64),
            mean: mu,
        });
        num = num_next;
        den = den_next;
    }
    Ok((fits, None))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, ar_series};
    use crate::stats::ar_poly::reflection_coefficients;

    #[test]
    fn burg_ar1_recovers_phi() {
        let x = ar_series(&mut Rng::new(21), 100_000, &[-0.6], 0.5);
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
        let x = ar_series(&mut Rng::new(4), 5000, &[1.0], 1.0);
        let f = burg(&x, 6).unwrap();
        let k = reflection_coefficients(&f.coeffs, 0.0);
        assert!(k.is_some(), "{:?}", f.coeffs);
        let k = k.unwrap();
        // the first reflection coefficient of a random walk is close to 1
        assert!(k[0] > 0.99, "{k:?}");
    }

    /// The textbook Burg recursion, sequential sums, one order per call (the implementation
    /// before the one-pass lattice): the reference the fast kernel must reproduce.
    fn burg_reference(x: &[f64], p: usize) -> (Vec<f64>, f64) {
        let mu = x.iter().sum::<f64>() / x.len() as f64;
        let mut f: Vec<f64> = x.iter().map(|v| v - mu).collect();
        let mut b = f.clone();
        let n = f.len();
        let mut phi: Vec<f64> = Vec::new();
        let mut energy = 0.0;
        for m in 1..=p {
            let (mut num, mut den) = (0.0, 0.0);
            for i in m..n {
                num += f[i] * b[i - 1];
                den += f[i] * f[i] + b[i - 1] * b[i - 1];
            }
            let k = 2.0 * num / den;
            energy = 0.0;
            for i in (m..n).rev() {
                let fi = f[i] - k * b[i - 1];
                let bi = b[i - 1] - k * f[i];
                f[i] = fi;
                b[i] = bi;
                energy += fi * fi + bi * bi;
            }
            let prev = phi.clone();
            for i in 1..m {
                phi[i - 1] = prev[i - 1] - k * prev[m - i - 1];
            }
            phi.push(k);
        }
        (phi, energy / (2.0 * (n - p) as f64))
    }

    #[test]
    fn every_order_from_one_pass_matches_the_textbook_recursion() {
        // AR(2) plus white noise and an offset, a length that is not a multiple of the block or
        // lane sizes. Only the summation order differs from the reference: coefficients agree
        // to 1e-11 absolute (the AR(12) step-up amplifies rounding of the k's ~1e3-fold; the
        // k's themselves agree to ~1e-15), the noise variance to 1e-11 relative.
        let mut rng = Rng::new(8);
        let (mut a, mut c) = (0.0, 0.0);
        let x: Vec<f64> = (0..10_007)
            .map(|_| {
                let v = 1.5 * a - 0.7 * c + rng.normal();
                c = a;
                a = v;
                4.0 + v + 0.5 * rng.normal()
            })
            .collect();
        let all = burg_orders(&x, 12).unwrap();
        assert_eq!(all.len(), 12);
        for (m0, fit) in all.iter().enumerate() {
            let (phi, var) = burg_reference(&x, m0 + 1);
            assert_eq!(fit.coeffs.len(), m0 + 1);
            for (u, v) in fit.coeffs.iter().zip(&phi) {
                assert!((u - v).abs() < 1e-11, "order {}: {u} vs {v}", m0 + 1);
            }
            assert!(
                (fit.noise_var / var - 1.0).abs() < 1e-11,
                "order {}",
                m0 + 1
            );
            assert_eq!(burg(&x, m0 + 1).unwrap(), *fit);
        }
    }

    #[test]
    fn a_perfectly_predictable_series_keeps_the_orders_before_the_collapse() {
        // x = (-1)^n + 1 is AR(1) with phi = -1 exactly: order 1 fits, its errors vanish, and
        // order 2 has nothing left to fit.
        let x: Vec<f64> = (0..64)
            .map(|i| if i % 2 == 0 { 2.0 } else { 0.0 })
            .collect();
        let all = burg_orders(&x, 3).unwrap();
        assert_eq!(all.len(), 1);
        assert!((all[0].coeffs[0] + 1.0).abs() < 1e-12, "{:?}", all[0]);
        assert!(matches!(
            burg(&x, 2),
            Err(ModelError::Numeric(NumError::Singular(_)))
        ));
        assert!(burg(&x, 1).is_ok());
    }

    #[test]
    fn burg_rejects_constant_series() {
        assert_eq!(
            burg(&[3.0; 50], 2),
            Err(ModelError::Numeric(NumError::Constant))
        );
    }
}
