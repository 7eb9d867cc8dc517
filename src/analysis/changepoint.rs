//! Bias steps: a CUSUM test for a mean shift in a serially correlated residual, the
//! least-squares location and size of the shift, and several steps by binary segmentation.
//!
//! For a segment x_1..x_m with mean x̄, the CUSUM is C_k = Σ_{i≤k} (x_i − x̄). Under H0 (no shift,
//! stationary x with long-run variance σ²_LR = 2π S(0)), C_⌊mt⌋ / (σ_LR √m) converges to a
//! Brownian bridge B(t) (Csörgő & Horváth 1997, "Limit theorems in change-point analysis", §1),
//! so T = max_k |C_k| / (σ_LR √m) is tested against the Kolmogorov law
//! P(sup|B| > t) = 2 Σ_{j≥1} (−1)^{j−1} e^{−2 j² t²}.
//! σ²_LR is the spectral density at zero of the residual *after* removing the step at its
//! estimated location (so the step itself does not inflate it), estimated by the Daniell average
//! of the lowest K raw periodogram ordinates, σ̂²_LR = Σ_{j=1}^{K} |X_j|²/m / (K − ½), X_j the DFT
//! at f_j = j/m (the step fit removes about one ordinate's worth: hence K − ½). These are the
//! frequencies the CUSUM's partial sums actually see, so a slow coloured wander (a Gauss–Markov
//! bias with a long correlation time) is not mistaken for a step, as it would be with a
//! low-order AR estimate of S(0). With σ̂²_LR ~ σ²_LR χ²_ν/ν, ν = 2K − 1, the p-value is the
//! Kolmogorov tail averaged over that law: p = E[P(sup|B| > T √(χ²_ν/ν))] (midpoint quadrature).
//! The location is the least-squares estimate k̂ = argmax_k C_k² m / (k (m − k)) (restricted to
//! `min_segment` samples from each end), the size the difference of the two segment means.
//! Binary segmentation (Scott & Knott 1974; Vostrikova 1981): test the whole series; if the
//! shift is significant at `alpha`, split at k̂ and test each half; stop where none is.

use super::AnalysisError;
use crate::stats::{NumError, check_series};
use serde::Serialize;

/// Settings of the step detector.
#[derive(Clone, Debug)]
pub struct ChangePointSettings {
    /// Significance level of each test in the segmentation.
    pub alpha: f64,
    /// Shortest segment on either side of a step, s.
    pub min_segment_s: f64,
    /// Number K of low-frequency periodogram ordinates in the long-run variance.
    pub lrv_ordinates: usize,
    /// Most steps reported.
    pub max_steps: usize,
}

impl Default for ChangePointSettings {
    fn default() -> Self {
        // 5 s segments hold enough samples at IMU rates for a stable mean; K = 10 ordinates give
        // the long-run variance 19 degrees of freedom while staying at the lowest frequencies.
        ChangePointSettings {
            alpha: 0.01,
            min_segment_s: 5.0,
            lrv_ordinates: 10,
            max_steps: 5,
        }
    }
}

/// A detected step.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ChangePoint {
    /// Index of the first sample after the step (in the log's numbering).
    pub index: usize,
    /// Time of the step, s from the start of the log.
    pub t_s: f64,
    /// Mean after minus mean before (units of x).
    pub size: f64,
    /// CUSUM statistic T.
    pub statistic: f64,
    /// Kolmogorov p-value of T.
    pub p_value: f64,
}

/// P(sup_t |B(t)| > t) for a Brownian bridge B.
pub fn kolmogorov_sf(t: f64) -> f64 {
    if t <= 0.2 {
        return 1.0; // the series is 1 to double precision here
    }
    let mut s = 0.0;
    for j in 1..200 {
        let jf = j as f64;
        let term = (-2.0 * jf * jf * t * t).exp();
        s += if j % 2 == 1 { term } else { -term };
        if term < 1e-18 {
            break;
        }
    }
    (2.0 * s).clamp(0.0, 1.0)
}

/// P-value of the CUSUM statistic `t` when the long-run variance was estimated with `nu`
/// degrees of freedom: E[K(t √(χ²_ν/ν))], K the Kolmogorov tail.
pub fn cusum_p_value(t: f64, nu: f64) -> f64 {
    // u = χ²_ν/ν has density ∝ u^{ν/2−1} e^{−νu/2}; integrate on (0, 6] (the mass beyond is
    // < 1e-9 for ν ≥ 19) by the midpoint rule on 2000 cells, normalised numerically.
    let a = 0.5 * nu;
    let cells = 2000;
    let h = 6.0 / cells as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..cells {
        let u = (i as f64 + 0.5) * h;
        let w = ((a - 1.0) * u.ln() - a * u).exp();
        num += w * kolmogorov_sf(t * u.sqrt());
        den += w;
    }
    if den > 0.0 {
        (num / den).clamp(0.0, 1.0)
    } else {
        kolmogorov_sf(t)
    }
}

/// Single mean-shift test on `x` (local indices): (k̂, size, T, p).
pub fn mean_shift_test(
    x: &[f64],
    min_segment: usize,
    lrv_ordinates: usize,
) -> Result<(usize, f64, f64, f64), AnalysisError> {
    let m = x.len();
    let kk = lrv_ordinates.max(2);
    check_series(x, (2 * min_segment).max(4 * kk + 8))?;
    let mf = m as f64;
    let mean = x.iter().sum::<f64>() / mf;
    let mut c = 0.0;
    let (mut best_k, mut best_w) = (0usize, -1.0);
    let mut max_abs = 0.0f64;
    for (i, v) in x.iter().enumerate() {
        c += v - mean;
        let k = i + 1;
        if k < m {
            max_abs = max_abs.max(c.abs());
            if k >= min_segment.max(1) && m - k >= min_segment.max(1) {
                let w = c * c * mf / (k as f64 * (m - k) as f64);
                if w > best_w {
                    best_w = w;
                    best_k = k;
                }
            }
        }
    }
    if best_k == 0 {
        return Err(NumError::TooShort {
            needed: 2 * min_segment,
            got: m,
        }
        .into());
    }
    let m1 = x[..best_k].iter().sum::<f64>() / best_k as f64;
    let m2 = x[best_k..].iter().sum::<f64>() / (m - best_k) as f64;
    // Daniell estimate of the long-run variance from the lowest K ordinates of the residual.
    let mut acc = 0.0;
    for j in 1..=kk {
        let w = 2.0 * std::f64::consts::PI * j as f64 / mf;
        let (mut re, mut im) = (0.0, 0.0);
        for (i, v) in x.iter().enumerate() {
            let r = v - if i < best_k { m1 } else { m2 };
            let (s, co) = (w * i as f64).sin_cos();
            re += r * co;
            im -= r * s;
        }
        acc += (re * re + im * im) / mf;
    }
    let lrv = acc / (kk as f64 - 0.5);
    if !super::is_pos(lrv) {
        return Err(AnalysisError::singular(
            "mean_shift_test: zero long-run variance",
        ));
    }
    let t = max_abs / (lrv.sqrt() * mf.sqrt());
    Ok((best_k, m2 - m1, t, cusum_p_value(t, 2.0 * kk as f64 - 1.0)))
}

/// All steps found by binary segmentation in `x`, whose first sample is sample `t0_index` of
/// the log, sorted by time.
pub fn binary_segmentation(
    x: &[f64],
    rate_hz: f64,
    t0_index: usize,
    s: &ChangePointSettings,
) -> Result<Vec<ChangePoint>, AnalysisError> {
    if !super::is_pos(rate_hz) || !super::in_open_unit(s.alpha) {
        return Err(AnalysisError::bad("binary_segmentation: rate or alpha"));
    }
    check_series(x, 1)?;
    let min_seg = ((s.min_segment_s * rate_hz).round() as usize).max(8);
    let mut found = Vec::new();
    let mut stack = vec![(0usize, x.len())];
    while let Some((a, b)) = stack.pop() {
        if found.len() >= s.max_steps || b - a < 2 * min_seg || b - a < 4 * s.lrv_ordinates + 8 {
            continue;
        }
        let (k, size, t, p) = mean_shift_test(&x[a..b], min_seg, s.lrv_ordinates)?;
        if p < s.alpha {
            let index = t0_index + a + k;
            found.push(ChangePoint {
                index,
                t_s: index as f64 / rate_hz,
                size,
                statistic: t,
                p_value: p,
            });
            stack.push((a, a + k));
            stack.push((a + k, b));
        }
    }
    found.sort_by_key(|c| c.index);
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn kolmogorov_sf_known_values() {
        // Classical critical values of the Kolmogorov distribution: 1.358 (5 %), 1.628 (1 %).
        assert!((kolmogorov_sf(1.358_099) - 0.05).abs() < 1e-4);
        assert!((kolmogorov_sf(1.627_624) - 0.01).abs() < 1e-4);
        assert_eq!(kolmogorov_sf(0.1), 1.0);
        // With many degrees of freedom the estimated-variance tail tends to the Kolmogorov tail;
        // with few it is heavier.
        assert!((cusum_p_value(1.358_099, 4000.0) - 0.05).abs() < 2e-3);
        assert!(cusum_p_value(1.627_624, 19.0) > 0.01);
    }

    fn ar1(rng: &mut Rng, n: usize, phi: f64, sd: f64) -> Vec<f64> {
        let mut v = vec![0.0; n];
        for i in 1..n {
            v[i] = phi * v[i - 1] + sd * rng.normal();
        }
        v
    }

    #[test]
    fn step_in_coloured_noise_is_located_and_sized() {
        // AR(1) phi = 0.9 innovations sd 0.3 plus unit white noise: long-run sd = √(1 + 9) ≈ 3.2
        // per √sample. A step of 1.0 at sample 7000 of 18 000: location error ~ LRV/Δ² = 10
        // samples (±100 samples = 1 s is generous), size error sd ≈ 3.2·√(1/7000 + 1/11000) =
        // 0.049, so ±0.15 is 3 sd.
        let mut rng = Rng::new(21);
        let n = 18_000;
        let b = ar1(&mut rng, n, 0.9, 0.3);
        let x: Vec<f64> = (0..n)
            .map(|i| b[i] + rng.normal() + if i >= 7000 { 1.0 } else { 0.0 })
            .collect();
        let cps = binary_segmentation(&x, 100.0, 500, &ChangePointSettings::default()).unwrap();
        assert_eq!(cps.len(), 1, "{cps:?}");
        assert!((cps[0].index as i64 - 7500).abs() <= 100, "{:?}", cps[0]);
        assert!((cps[0].size - 1.0).abs() < 0.15, "{:?}", cps[0]);
    }

    #[test]
    fn two_steps_are_both_found() {
        // Two steps of +1.5 and −1.0 in white noise (sd 1): each is > 40 sd of its segment-mean
        // difference, so both must be found, within ±1 s.
        let mut rng = Rng::new(2);
        let x: Vec<f64> = (0..30_000)
            .map(|i| {
                rng.normal() + if i >= 8000 { 1.5 } else { 0.0 }
                    - if i >= 20_000 { 1.0 } else { 0.0 }
            })
            .collect();
        let cps = binary_segmentation(&x, 100.0, 0, &ChangePointSettings::default()).unwrap();
        assert_eq!(cps.len(), 2, "{cps:?}");
        assert!(
            (cps[0].index as i64 - 8000).abs() <= 100
                && (cps[1].index as i64 - 20_000).abs() <= 100
        );
    }

    #[test]
    fn no_step_in_stationary_coloured_noise() {
        // Same coloured noise, no step: the test is calibrated by the AR long-run variance, so
        // at alpha = 0.01 nothing should be found for 9 of these 10 fixed seeds at least (the
        // probability of 2+ false alarms in 10 is 0.4 %).
        let mut false_alarms = 0;
        for seed in 0..10 {
            let mut rng = Rng::new(100 + seed);
            let b = ar1(&mut rng, 18_000, 0.9, 0.3);
            let x: Vec<f64> = b.iter().map(|v| v + rng.normal()).collect();
            if !binary_segmentation(&x, 100.0, 0, &ChangePointSettings::default())
                .unwrap()
                .is_empty()
            {
                false_alarms += 1;
            }
        }
        assert!(false_alarms <= 1, "{false_alarms}");
    }
}
