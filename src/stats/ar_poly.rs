//! The AR polynomial `A(z) = 1 − Σ_{i=1}^{p} φ_i z^{−i}` and its autocovariances: stability by the
//! Schur–Cohn step-down recursion, the Durbin–Levinson recursion and its inverse, and the exact
//! autocovariances of a stationary AR(p) — each once, for the AR fitters, the ARIMA fit, the bias
//! state-space model, the PACF and the simulator (Kay, *Modern Spectral Estimation*, 1988, §6.3;
//! Box & Jenkins, App. A3.2).
//!
//! * Step-down: `k_m = φ^{(m)}_m`, `φ^{(m−1)}_i = (φ^{(m)}_i + k_m φ^{(m)}_{m−i}) / (1 − k_m²)`;
//!   `A` has all roots strictly inside the unit circle (the process is stationary; for an MA
//!   polynomial `1 + Σ θ_j z^{−j}`, pass −θ: invertible) iff every `|k_m| < 1`.
//! * Durbin–Levinson on autocovariances `r(0..=p)`: `k_m = (r_m − Σ_{i<m} φ^{(m−1)}_i r_{m−i}) /
//!   E_{m−1}`, `φ^{(m)}_i = φ^{(m−1)}_i − k_m φ^{(m−1)}_{m−i}`, `E_m = E_{m−1} (1 − k_m²)`,
//!   `E_0 = r_0`. The `k_m` are the partial autocorrelations when `r` is an ACF.
//! * Autocovariances: `γ(0) = σ² / Π (1 − k_m²)`, `γ(m) = Σ_{i≤m} φ^{(m)}_i γ(m−i)` by step-up,
//!   the AR recursion beyond p.

use std::cmp::Ordering;

/// Reflection coefficients `k_1..k_p` of `phi` by the step-down recursion; `None` if some
/// `|k_m| ≥ 1 − margin` or a value is not finite (NaN fails every comparison).
pub fn reflection_coefficients(phi: &[f64], margin: f64) -> Option<Vec<f64>> {
    let p = phi.len();
    let mut a = phi.to_vec();
    let mut k = vec![0.0; p];
    for m in (1..=p).rev() {
        let km = a[m - 1];
        if km.abs().partial_cmp(&(1.0 - margin)) != Some(Ordering::Less) {
            return None;
        }
        k[m - 1] = km;
        let d = 1.0 - km * km;
        let prev: Vec<f64> = (0..m - 1).map(|i| (a[i] + km * a[m - 2 - i]) / d).collect();
        a.truncate(m - 1);
        a.copy_from_slice(&prev);
    }
    Some(k)
}

/// True if every reflection coefficient of `a` has `|k| < 1 − margin` (margin 0: all roots of the
/// AR polynomial strictly inside the unit circle).
pub fn is_stable(a: &[f64], margin: f64) -> bool {
    reflection_coefficients(a, margin).is_some()
}

/// True if the AR polynomial is stationary (margin 0).
pub fn ar_is_stationary(phi: &[f64]) -> bool {
    is_stable(phi, 0.0)
}

/// One Levinson step-up, in place: the order-(m−1) coefficients `phi` become the order-m ones,
/// `φ^{(m)}_i = φ^{(m−1)}_i − k φ^{(m−1)}_{m−i}` and `φ^{(m)}_m = k` (`phi` grows by one).
pub fn step_up(phi: &mut Vec<f64>, k: f64) {
    let n = phi.len();
    for i in 0..n / 2 {
        let (a, b) = (phi[i], phi[n - 1 - i]);
        phi[i] = a - k * b;
        phi[n - 1 - i] = b - k * a;
    }
    if n % 2 == 1 {
        let c = phi[n / 2];
        phi[n / 2] = c - k * c;
    }
    phi.push(k);
}

/// AR coefficients from reflection coefficients `k_1..k_p` (the Levinson step-up).
pub fn reflection_to_ar(refl: &[f64]) -> Vec<f64> {
    let mut phi = Vec::with_capacity(refl.len());
    for &k in refl {
        step_up(&mut phi, k);
    }
    phi
}

/// The result of the Durbin–Levinson recursion.
#[derive(Debug, Clone, PartialEq)]
pub struct Levinson {
    /// `φ_1..φ_m` of the last order reached (zeros beyond it, up to the order asked for).
    pub phi: Vec<f64>,
    /// Prediction-error variance `E_m` of that order.
    pub var: f64,
    /// Reflection coefficients `k_1..k_m`, one per step done.
    pub refl: Vec<f64>,
}

/// One Durbin–Levinson step on the autocovariances `r` (`r.len() > m`): the order-(m−1)
/// predictor `phi` and its error variance `e` become the order-m ones (m = `phi.len()` + 1);
/// returns `k_m`. `e` must be positive for the step to mean anything (the callers check).
pub fn levinson_step(r: &[f64], phi: &mut Vec<f64>, e: &mut f64) -> f64 {
    let m = phi.len() + 1;
    let mut num = r[m];
    for i in 1..m {
        num -= phi[i - 1] * r[m - i];
    }
    let k = num / *e;
    step_up(phi, k);
    *e *= 1.0 - k * k;
    k
}

/// Durbin–Levinson on `r(0..=p)` (`r.len() > p`), stopping early — before step m — when `E_{m−1}`
/// is not positive (a perfectly predictable or not positive-definite sequence): then
/// `refl.len() < p`.
pub fn levinson_partial(r: &[f64], p: usize) -> Levinson {
    let mut phi = Vec::with_capacity(p);
    let mut refl = Vec::with_capacity(p);
    let mut e = r[0];
    for _ in 1..=p {
        if e.partial_cmp(&0.0) != Some(Ordering::Greater) {
            break;
        }
        refl.push(levinson_step(r, &mut phi, &mut e));
    }
    phi.resize(p, 0.0);
    Levinson { phi, var: e, refl }
}

/// Durbin–Levinson on `r(0..=p)`: `None` unless every `E_0..E_p` is positive and finite (the
/// Toeplitz matrix of `r` positive definite) and `r` holds `p + 1` values.
pub fn levinson(r: &[f64], p: usize) -> Option<Levinson> {
    if r.len() < p + 1 || !r[0].is_finite() {
        return None;
    }
    let l = levinson_partial(r, p);
    (l.refl.len() == p && l.var > 0.0).then_some(l)
}

/// Autocovariances `γ(0..=max_lag)` of the stationary AR(p) `x[n] = Σ φ_i x[n−i] + e[n]`,
/// `var(e) = sigma2`; `None` if `phi` is not stationary.
pub fn ar_autocovariance(phi: &[f64], sigma2: f64, max_lag: usize) -> Option<Vec<f64>> {
    let k = reflection_coefficients(phi, 0.0)?;
    let p = phi.len();
    let mut gamma = vec![0.0; max_lag.max(p) + 1];
    gamma[0] = sigma2 / k.iter().map(|km| 1.0 - km * km).product::<f64>();
    // Step up: order-m predictor coefficients give gamma(m).
    let mut a: Vec<f64> = Vec::with_capacity(p);
    for m in 1..=p {
        step_up(&mut a, k[m - 1]);
        gamma[m] = (1..=m).map(|i| a[i - 1] * gamma[m - i]).sum();
    }
    for lag in (p + 1)..gamma.len() {
        gamma[lag] = (1..=p).map(|i| phi[i - 1] * gamma[lag - i]).sum();
    }
    gamma.truncate(max_lag + 1);
    Some(gamma)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_in_place_step_up_is_the_textbook_one() {
        // Orders 0..=5 (odd and even lengths, the middle coefficient of odd ones): the pairwise
        // in-place update does the same one multiply and subtract per coefficient as
        // φ_i − k φ_{m−i} on a copy, so the results are equal to the bit.
        let k = 0.37;
        for n in 0..=5 {
            let prev: Vec<f64> = (0..n).map(|i| 0.3 - 0.11 * i as f64).collect();
            let mut want: Vec<f64> = (0..n).map(|i| prev[i] - k * prev[n - 1 - i]).collect();
            want.push(k);
            let mut got = prev.clone();
            step_up(&mut got, k);
            assert_eq!(got, want, "order {n} -> {}", n + 1);
        }
    }

    #[test]
    fn stability_of_known_polynomials() {
        assert!(is_stable(&[0.99], 0.0));
        assert!(!is_stable(&[1.01], 0.0));
        assert!(is_stable(&[1.9, -0.95], 0.0));
        assert!(!is_stable(&[0.6, 0.5], 0.0)); // φ1 + φ2 = 1.1
        assert!(!is_stable(&[-0.6, 0.5], 0.0)); // φ2 − φ1 = 1.1
        assert!(!is_stable(&[0.1, -1.05], 0.0));
        assert!(ar_is_stationary(&[1.5, -0.56])); // roots 0.8 and 0.7
        assert!(!ar_is_stationary(&[1.5, -0.5])); // a root at 1.0
        assert!(ar_is_stationary(&[]));
        assert!(ar_is_stationary(&[1.881, -0.9801])); // complex pair of modulus 0.99
        assert!(!ar_is_stationary(&[1.0, -1.0201]));
        assert!(!ar_is_stationary(&[f64::NAN]));
        // The margin: |k| must stay below 1 − margin.
        assert!(is_stable(&[0.9], 0.05) && !is_stable(&[0.96], 0.05));
    }

    #[test]
    fn ar1_autocovariance_is_closed_form() {
        // γ(k) = σ² φ^k / (1 − φ²); 1e-12 relative: a few roundings.
        let g = ar_autocovariance(&[0.9], 2.0, 5).unwrap();
        for (k, gk) in g.iter().enumerate() {
            let want = 2.0 * 0.9f64.powi(k as i32) / (1.0 - 0.81);
            assert!((gk - want).abs() < 1e-12 * want, "γ({k}) = {gk}");
        }
        assert!(ar_autocovariance(&[1.01], 1.0, 2).is_none());
    }

    #[test]
    fn levinson_inverts_the_autocovariances_and_reflection_to_ar_inverts_step_down() {
        // AR(2) φ = (0.5, 0.3), σ² = 0.5: Levinson of order 2 on its autocovariances returns
        // φ and σ² (1e-12: a handful of roundings); order 4 adds zero coefficients.
        let phi = [0.5, 0.3];
        let g = ar_autocovariance(&phi, 0.5, 6).unwrap();
        let l = levinson(&g, 2).unwrap();
        assert!((l.phi[0] - 0.5).abs() < 1e-12 && (l.phi[1] - 0.3).abs() < 1e-12);
        assert!((l.var - 0.5).abs() < 1e-12);
        let l4 = levinson(&g, 4).unwrap();
        assert!(l4.phi[2].abs() < 1e-12 && l4.phi[3].abs() < 1e-12);
        let k = reflection_coefficients(&phi, 0.0).unwrap();
        assert!((k[0] - l.refl[0]).abs() < 1e-12 && (k[1] - l.refl[1]).abs() < 1e-12);
        let back = reflection_to_ar(&k);
        assert!((back[0] - 0.5).abs() < 1e-12 && (back[1] - 0.3).abs() < 1e-12);
    }

    #[test]
    fn levinson_stops_on_a_perfectly_predictable_sequence() {
        // r = (1, 1, 1): k_1 = 1 makes E_1 = 0, so the recursion stops after one step.
        let l = levinson_partial(&[1.0, 1.0, 1.0], 2);
        assert_eq!(l.refl, vec![1.0]);
        assert!(levinson(&[1.0, 1.0, 1.0], 2).is_none());
        assert!(levinson(&[0.0, 0.0], 1).is_none());
        assert!(levinson(&[1.0], 1).is_none());
        assert!(levinson(&[f64::INFINITY, 0.0], 1).is_none());
    }

    #[test]
    fn ar2_autocovariance_matches_closed_form() {
        // AR(2): γ₀ = s² (1−φ₂) / ((1+φ₂)((1−φ₂)² − φ₁²)), ρ₁ = φ₁/(1−φ₂); 1e-12 relative.
        let (p1, p2) = (1.5, -0.56);
        let g = ar_autocovariance(&[p1, p2], 1.0, 1).unwrap();
        let g0 = (1.0 - p2) / ((1.0 + p2) * ((1.0 - p2).powi(2) - p1 * p1));
        assert!((g[0] - g0).abs() < 1e-12 * g0);
        assert!((g[1] - g0 * p1 / (1.0 - p2)).abs() < 1e-12 * g0);
    }

    proptest::proptest! {
        #[test]
        fn autocovariance_and_levinson_are_inverse(k in proptest::collection::vec(-0.95f64..0.95, 1..6), s2 in 1e-6f64..10.0) {
            // Any reflection coefficients in (-1, 1) give a stationary AR; its autocovariances fed
            // back to Levinson must return the same coefficients and variance (1e-8: round-off
            // grows with 1/prod(1-k²) <= 1e3 here).
            let mut phi: Vec<f64> = Vec::new();
            for (m, km) in k.iter().enumerate() {
                let prev = phi.clone();
                for i in 0..m {
                    phi[i] = prev[i] - km * prev[m - 1 - i];
                }
                phi.push(*km);
            }
            let g = ar_autocovariance(&phi, s2, phi.len()).unwrap();
            let l = levinson(&g, phi.len()).unwrap();
            let (a, e) = (l.phi, l.var);
            for (x, y) in a.iter().zip(phi.iter()) {
                proptest::prop_assert!((x - y).abs() < 1e-8, "{a:?} vs {phi:?}");
            }
            proptest::prop_assert!((e / s2 - 1.0).abs() < 1e-8);
            let back = reflection_coefficients(&phi, 0.0).unwrap();
            for (x, y) in back.iter().zip(k.iter()) {
                proptest::prop_assert!((x - y).abs() < 1e-9);
            }
        }
    }
}
