//! Robust location and scale: the median, the MAD-based σ, and the Hampel filter (Hampel 1974;
//! Pearson et al. 2016), each written once for every floor above.
//!
//! * Median: [`median`] follows numpy (the mean of the two middle values for an even count);
//!   [`upper_median`] takes the upper of the two (`sorted[n/2]`, a value of the sample). Both
//!   reorder their slice (selection, O(n)); the chosen order statistic is the same value a full
//!   sort would give.
//! * `σ = 1.4826 · median |x − m|` ([`MAD_TO_SIGMA`] makes it consistent for Gaussian data).
//!   [`sigma_from_abs_dev`] falls back to the mean absolute deviation × √(π/2) when more than half
//!   of the deviations are 0, as on a channel quantised to about one LSB.
//! * Hampel: for each i, over the window `i−h..=i+h` (truncated at the ends) the median m_i and
//!   `S_i = 1.4826 · median |x_j − m_i|`; flag `|x_i − m_i| > k S_i` (never when `S_i = 0`, a flat
//!   window) and replace the flagged sample by m_i.

// `!(v > 0.0)` is used on purpose: unlike `v <= 0.0` it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{NumError, check_series};

/// `1 / Φ⁻¹(¾)`: MAD → σ for Gaussian data.
pub const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Median of `v` (mean of the two middle values for an even count, as numpy); reorders `v`.
/// NaN for an empty slice.
pub fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let mid = n / 2;
    let hi = *v.select_nth_unstable_by(mid, f64::total_cmp).1;
    if n % 2 == 1 {
        hi
    } else {
        let lo = v[..mid].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// Upper median `sorted(v)[n/2]` (a value of the sample); reorders `v`. NaN for an empty slice.
pub fn upper_median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Median of at most `N` values without touching the heap (insertion sort on a stack copy; for
/// the per-sample paths). Values beyond the first `N` are ignored.
#[inline]
pub fn median_small<const N: usize>(v: &[f64]) -> f64 {
    let mut a = [0.0f64; N];
    let n = v.len().min(N);
    a[..n].copy_from_slice(&v[..n]);
    for i in 1..n {
        let mut j = i;
        while j > 0 && a[j - 1] > a[j] {
            a.swap(j - 1, j);
            j -= 1;
        }
    }
    if n % 2 == 1 {
        a[n / 2]
    } else {
        0.5 * (a[n / 2 - 1] + a[n / 2])
    }
}

/// Upper median and MAD-based σ of the finite values of `v` (allocates); `(0, 0)` if none.
pub fn upper_median_and_mad_sigma(v: &[f64]) -> (f64, f64) {
    let mut a: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if a.is_empty() {
        return (0.0, 0.0);
    }
    let med = upper_median(&mut a);
    let mut dev: Vec<f64> = a.iter().map(|x| (x - med).abs()).collect();
    (med, MAD_TO_SIGMA * upper_median(&mut dev))
}

/// Robust σ from absolute deviations `dev` (reordered): the MAD (upper median), or — when more
/// than half are 0, as on a quantised channel whose noise is about one LSB — the mean absolute
/// deviation × √(π/2) (unbiased for Gaussian data). 0 for an empty slice.
pub fn sigma_from_abs_dev(dev: &mut [f64]) -> f64 {
    if dev.is_empty() {
        return 0.0;
    }
    let mad = upper_median(dev) * MAD_TO_SIGMA;
    if mad > 0.0 {
        mad
    } else {
        dev.iter().sum::<f64>() / dev.len() as f64 * (std::f64::consts::PI / 2.0).sqrt()
    }
}

/// Robust σ of the finite values of `v` (allocates): [`sigma_from_abs_dev`] of the deviations
/// from their upper median.
pub fn robust_sigma(v: &[f64]) -> f64 {
    let mut a: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if a.is_empty() {
        return 0.0;
    }
    let med = upper_median(&mut a);
    let mut d: Vec<f64> = a.iter().map(|x| (x - med).abs()).collect();
    sigma_from_abs_dev(&mut d)
}

/// A detector's output: which samples it flags and the corrected series.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    pub mask: Vec<bool>,
    pub corrected: Vec<f64>,
}

/// Buffers for [`hampel_at`] (a window's values and deviations), allocated once.
#[derive(Debug, Clone, Default)]
pub struct HampelScratch {
    win: Vec<f64>,
    dev: Vec<f64>,
}

impl HampelScratch {
    pub fn new(half_width: usize) -> Self {
        HampelScratch {
            win: Vec::with_capacity(2 * half_width + 1),
            dev: Vec::with_capacity(2 * half_width + 1),
        }
    }
}

/// The Hampel filter's verdict on `x[i]` alone (the window cut at the ends of `x`): the window
/// median if `x[i]` lies more than `k` MAD σ from it, else `None`. No allocation once `scratch`
/// holds a window.
pub fn hampel_at(
    x: &[f64],
    i: usize,
    half_width: usize,
    k: f64,
    scratch: &mut HampelScratch,
) -> Option<f64> {
    let lo = i.saturating_sub(half_width);
    let hi = (i + half_width + 1).min(x.len());
    let HampelScratch { win, dev } = scratch;
    win.clear();
    win.extend_from_slice(&x[lo..hi]);
    let m = median(win);
    dev.clear();
    dev.extend(x[lo..hi].iter().map(|v| (v - m).abs()));
    let s = MAD_TO_SIGMA * median(dev);
    (s > 0.0 && (x[i] - m).abs() > k * s).then_some(m)
}

/// Hampel filter with half-width `half_width` and threshold `k` (MAD-scaled); flagged samples are
/// replaced by their window median (module docs).
pub fn hampel(x: &[f64], half_width: usize, k: f64) -> Result<Detection, NumError> {
    check_series(x, 1)?;
    if !(k > 0.0) {
        return Err(NumError::bad(format!("k = {k}")));
    }
    let n = x.len();
    let mut mask = vec![false; n];
    let mut corrected = x.to_vec();
    let mut scratch = HampelScratch::new(half_width);
    for i in 0..n {
        if let Some(m) = hampel_at(x, i, half_width, k, &mut scratch) {
            mask[i] = true;
            corrected[i] = m;
        }
    }
    Ok(Detection { mask, corrected })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::normal_vec as noise;

    #[test]
    fn medians_match_a_full_sort() {
        // Selection must give the same order statistics as sorting: exact equality.
        for n in 1..40 {
            let v = noise(n, n as u64);
            let mut s = v.clone();
            s.sort_by(f64::total_cmp);
            let numpy = if n % 2 == 1 {
                s[n / 2]
            } else {
                0.5 * (s[n / 2 - 1] + s[n / 2])
            };
            assert_eq!(median(&mut v.clone()), numpy, "n = {n}");
            assert_eq!(upper_median(&mut v.clone()), s[n / 2], "n = {n}");
            if n <= 8 {
                assert_eq!(median_small::<8>(&v), numpy, "n = {n}");
            }
        }
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn mad_sigma_of_gaussian_noise_is_its_sd() {
        // 20 000 N(0, 2²) draws: the MAD σ estimate has relative sd ≈ 1.17/√n ≈ 0.8 %; 4 % is > 4 sd.
        let x: Vec<f64> = noise(20_000, 9).iter().map(|v| 2.0 * v).collect();
        let (m, s) = upper_median_and_mad_sigma(&x);
        assert!(m.abs() < 0.1 && (s / 2.0 - 1.0).abs() < 0.04, "{m} {s}");
        assert!((robust_sigma(&x) / 2.0 - 1.0).abs() < 0.04);
    }

    #[test]
    fn quantised_deviations_fall_back_to_the_mean_absolute_deviation() {
        // 6 of 10 deviations are 0 (MAD = 0): mean |d| = 0.4, × √(π/2).
        let mut d = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        let want = 0.4 * (std::f64::consts::PI / 2.0).sqrt();
        assert!((sigma_from_abs_dev(&mut d) - want).abs() < 1e-15);
    }

    #[test]
    fn hampel_catches_a_run_of_ten_and_replaces_by_median() {
        let mut x: Vec<f64> = noise(300, 5).iter().map(|v| 0.1 * v).collect();
        for v in x.iter_mut().skip(100).take(10) {
            *v += 5.0;
        }
        let d = hampel(&x, 10, 3.0).unwrap();
        assert!((100..110).all(|i| d.mask[i]));
        // Window of 21 with 10 outliers: the median is still a clean sample (< 0.5 from 0).
        assert!((100..110).all(|i| d.corrected[i].abs() < 0.5));
    }

    #[test]
    fn hampel_leaves_flat_windows_alone() {
        let x = vec![1.0; 50];
        let d = hampel(&x, 3, 3.0).unwrap();
        assert!(d.mask.iter().all(|m| !m));
        assert!(hampel(&[1.0, f64::NAN, 2.0, 3.0], 2, 3.0).is_err());
    }
}
