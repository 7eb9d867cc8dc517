//! Classical gross-error criteria (the baselines of Chen, Li & Zhang 2013, §0) and a Hampel filter,
//! offline, plus the scoring used to compare them with the ARIMA stage.
//!
//! * **Global 3σ**: mean x̄ and sample sd s of the whole series; flag `|x_i − x̄| > 3 s`.
//! * **Grubbs** (1969), iterative, two-sided, α = 0.05: on the n samples still in,
//!   `G = max |x_i − x̄| / s`; flag and remove the extreme while
//!   `G > (n−1)/√n · √(t² / (n − 2 + t²))`, `t = t_{1−α/(2n), n−2}` (Student t quantile); stop at the
//!   first non-significant G. (The extremes are taken from a sorted copy, so each step is O(1).)
//! * **Chauvenet** (single pass, as the criterion is defined): flag `n · P(|Z| > |x_i − x̄|/s) < ½`.
//! * **Dixon's Q** (r10), window-wise: the series is cut into consecutive non-overlapping windows of
//!   `window` samples (default 10; a trailing window of ≥ 3 is tested at its own size); in each, the
//!   more extreme end's gap-to-range ratio `Q = gap / range` is compared with Rorabacher's (1991)
//!   two-sided 95 % critical value for that n (tabulated for n = 3..10; the table is checked by
//!   simulation in the tests). At most one sample per window is flagged.
//! * **Hampel** (moving median/MAD, [`crate::stats::robust::hampel`], re-exported here); baseline
//!   parameters h = 10 (a 21-sample window: the median stays uncontaminated by runs of up to 10)
//!   and k = 3.
//!
//! Corrections: Hampel replaces a flagged sample by its window median (its own definition); the
//! other four replace flagged samples by linear interpolation between the nearest unflagged
//! neighbours (the nearest one at the ends), the "average of data around X_i" of the paper.
//!
//! Scores: precision TP/(TP+FP) (1 if nothing flagged), recall TP/(TP+FN) (1 if nothing to find),
//! F1 = 2PR/(P+R), false-alarm rate FP / (clean samples), and the RMSE of the corrected series
//! against the spike-free truth.

// `!(v > 0.0)` is used on purpose throughout: unlike `v <= 0.0` it is also true for NaN, so a
// single guard rejects both non-positive and NaN input.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use serde::{Deserialize, Serialize};

use crate::stats::special::{normal_sf, student_t_quantile};
use crate::stats::{NumError, check_series};

pub use crate::stats::robust::{Detection, hampel};

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let ss: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    (m, (ss / (n - 1.0)).sqrt())
}

/// Replace flagged samples by linear interpolation between the nearest unflagged neighbours.
pub fn interpolate_flagged(x: &[f64], mask: &[bool]) -> Vec<f64> {
    let mut out = x.to_vec();
    let n = x.len();
    let mut i = 0;
    while i < n {
        if !mask[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && mask[i] {
            i += 1;
        }
        let left = start.checked_sub(1);
        let right = (i < n).then_some(i);
        for (j, o) in out.iter_mut().enumerate().take(i).skip(start) {
            *o = match (left, right) {
                (Some(l), Some(r)) => {
                    let f = (j - l) as f64 / (r - l) as f64;
                    x[l] + f * (x[r] - x[l])
                }
                (Some(l), None) => x[l],
                (None, Some(r)) => x[r],
                (None, None) => x[j],
            };
        }
    }
    out
}

fn detection(x: &[f64], mask: Vec<bool>) -> Detection {
    let corrected = interpolate_flagged(x, &mask);
    Detection { mask, corrected }
}

/// Global 3σ rule.
pub fn three_sigma(x: &[f64]) -> Result<Detection, NumError> {
    check_series(x, 3)?;
    let (m, s) = mean_sd(x);
    let mask = x.iter().map(|v| (v - m).abs() > 3.0 * s).collect();
    Ok(detection(x, mask))
}

/// Grubbs' critical G for n samples at two-sided level α.
pub fn grubbs_critical(n: usize, alpha: f64) -> f64 {
    let nf = n as f64;
    let t = student_t_quantile(1.0 - alpha / (2.0 * nf), nf - 2.0);
    (nf - 1.0) / nf.sqrt() * (t * t / (nf - 2.0 + t * t)).sqrt()
}

/// Iterative two-sided Grubbs test at level `alpha` (the paper's baseline uses 0.05).
pub fn grubbs(x: &[f64], alpha: f64) -> Result<Detection, NumError> {
    check_series(x, 3)?;
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(NumError::BadSetting(format!("alpha = {alpha}")));
    }
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    // Running sums of deviations from a fixed reference (the initial mean) to avoid cancellation.
    let (r, _) = mean_sd(x);
    let mut s1: f64 = x.iter().map(|v| v - r).sum();
    let mut s2: f64 = x.iter().map(|v| (v - r) * (v - r)).sum();
    let (mut lo, mut hi) = (0usize, x.len() - 1);
    let mut mask = vec![false; x.len()];
    while hi - lo + 1 >= 3 {
        let n = (hi - lo + 1) as f64;
        let mean_dev = s1 / n;
        let var = (s2 - n * mean_dev * mean_dev) / (n - 1.0);
        if !(var > 0.0) {
            break;
        }
        let sd = var.sqrt();
        let dl = (x[idx[lo]] - r - mean_dev).abs();
        let dh = (x[idx[hi]] - r - mean_dev).abs();
        let (g, take_hi) = if dh >= dl {
            (dh / sd, true)
        } else {
            (dl / sd, false)
        };
        if g <= grubbs_critical(hi - lo + 1, alpha) {
            break;
        }
        let i = if take_hi { idx[hi] } else { idx[lo] };
        mask[i] = true;
        s1 -= x[i] - r;
        s2 -= (x[i] - r) * (x[i] - r);
        if take_hi {
            hi -= 1;
        } else {
            lo += 1;
        }
    }
    Ok(detection(x, mask))
}

/// Chauvenet's criterion (single pass).
pub fn chauvenet(x: &[f64]) -> Result<Detection, NumError> {
    check_series(x, 3)?;
    let (m, s) = mean_sd(x);
    let n = x.len() as f64;
    let mask = x
        .iter()
        .map(|v| s > 0.0 && n * 2.0 * normal_sf((v - m).abs() / s) < 0.5)
        .collect();
    Ok(detection(x, mask))
}

/// Rorabacher (1991) two-sided 95 % critical values of Dixon's r10 (Q) for n = 3..=10.
pub const DIXON_Q95: [f64; 8] = [0.970, 0.829, 0.710, 0.625, 0.568, 0.526, 0.493, 0.466];

/// Window-wise Dixon's Q test (window 3..=10 samples).
pub fn dixon_q(x: &[f64], window: usize) -> Result<Detection, NumError> {
    if !(3..=10).contains(&window) {
        return Err(NumError::BadSetting(format!(
            "Dixon window {window} outside the tabulated 3..=10"
        )));
    }
    check_series(x, 3)?;
    let mut mask = vec![false; x.len()];
    let mut idx = Vec::with_capacity(window);
    for start in (0..x.len()).step_by(window) {
        let end = (start + window).min(x.len());
        let n = end - start;
        if n < 3 {
            break;
        }
        idx.clear();
        idx.extend(start..end);
        idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
        let range = x[idx[n - 1]] - x[idx[0]];
        if !(range > 0.0) {
            continue;
        }
        let q_lo = (x[idx[1]] - x[idx[0]]) / range;
        let q_hi = (x[idx[n - 1]] - x[idx[n - 2]]) / range;
        let crit = DIXON_Q95[n - 3];
        if q_hi >= q_lo {
            if q_hi > crit {
                mask[idx[n - 1]] = true;
            }
        } else if q_lo > crit {
            mask[idx[0]] = true;
        }
    }
    Ok(detection(x, mask))
}

/// Detection quality against the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorScore {
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
    /// False alarms per clean sample.
    pub false_alarm_rate: f64,
    /// RMSE of the corrected series against the spike-free truth.
    pub rmse: f64,
    pub true_positives: u64,
    pub false_positives: u64,
    pub false_negatives: u64,
    pub clean_samples: u64,
}

/// Score a flag mask and corrected series against the true mask and the spike-free signal.
pub fn score(
    mask_pred: &[bool],
    mask_true: &[bool],
    corrected: &[f64],
    truth_clean: &[f64],
) -> Result<DetectorScore, NumError> {
    let n = mask_true.len();
    if mask_pred.len() != n || corrected.len() != n || truth_clean.len() != n {
        return Err(NumError::bad(format!(
            "lengths differ: pred {}, true {n}, corrected {}, truth {}",
            mask_pred.len(),
            corrected.len(),
            truth_clean.len()
        )));
    }
    if n == 0 {
        return Err(NumError::TooShort { needed: 1, got: 0 });
    }
    let (mut tp, mut fp, mut fneg) = (0u64, 0u64, 0u64);
    for (&p, &t) in mask_pred.iter().zip(mask_true) {
        match (p, t) {
            (true, true) => tp += 1,
            (true, false) => fp += 1,
            (false, true) => fneg += 1,
            _ => {}
        }
    }
    let clean = mask_true.iter().filter(|t| !**t).count() as u64;
    let precision = if tp + fp == 0 {
        1.0
    } else {
        tp as f64 / (tp + fp) as f64
    };
    let recall = if tp + fneg == 0 {
        1.0
    } else {
        tp as f64 / (tp + fneg) as f64
    };
    let f1 = if precision + recall > 0.0 {
        2.0 * precision * recall / (precision + recall)
    } else {
        0.0
    };
    let mse = corrected
        .iter()
        .zip(truth_clean)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        / n as f64;
    Ok(DetectorScore {
        precision,
        recall,
        f1,
        false_alarm_rate: if clean == 0 {
            0.0
        } else {
            fp as f64 / clean as f64
        },
        rmse: mse.sqrt(),
        true_positives: tp,
        false_positives: fp,
        false_negatives: fneg,
        clean_samples: clean,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::normal_vec as noise;

    #[test]
    fn interpolation_fills_runs_linearly_and_holds_at_the_ends() {
        let x = [0.0, 9.0, 9.0, 3.0, 9.0];
        let m = [false, true, true, false, true];
        assert_eq!(interpolate_flagged(&x, &m), vec![0.0, 1.0, 2.0, 3.0, 3.0]);
    }

    #[test]
    fn three_sigma_flags_a_large_spike_only() {
        let mut x = noise(1000, 1);
        x[500] = 50.0;
        let d = three_sigma(&x).unwrap();
        assert!(d.mask[500]);
        // Gaussian: P(|Z| > 3) = 0.27 % ⇒ ~2.7 false flags expected in 999; ≤ 10 is > 4 sd.
        assert!(d.mask.iter().filter(|m| **m).count() <= 10);
    }

    #[test]
    fn grubbs_critical_matches_scipy_and_published_table() {
        // scipy (tests/reference/detectors.py), same formula: agreement is the t quantile's
        // ~1e-12; the published table (Grubbs 1969 / ASTM E178: n = 10 → 2.290, n = 100 → 3.384,
        // 3 decimals) is checked to its rounding, 6e-4.
        for (n, g) in [
            (10, 2.2899540844796036),
            (20, 2.7082456458057584),
            (100, 3.3840829011549176),
            (36000, 4.825845246607337),
        ] {
            let c = grubbs_critical(n, 0.05);
            assert!(((c - g) / g).abs() < 1e-11, "n = {n}: {c} vs {g}");
        }
        assert!((grubbs_critical(10, 0.05) - 2.290).abs() < 6e-4);
        assert!((grubbs_critical(100, 0.05) - 3.384).abs() < 6e-4);
    }

    #[test]
    fn grubbs_removes_several_outliers_and_stops() {
        let mut x = noise(200, 2);
        x[10] = 12.0;
        x[20] = -15.0;
        x[30] = 9.0;
        let d = grubbs(&x, 0.05).unwrap();
        assert!(d.mask[10] && d.mask[20] && d.mask[30]);
        // Under H0 each test has 5 % size overall; at most a couple of extra flags.
        assert!(d.mask.iter().filter(|m| **m).count() <= 5);
        assert!((d.corrected[20] - 0.5 * (x[19] + x[21])).abs() < 1e-12);
    }

    #[test]
    fn chauvenet_threshold_is_the_half_sample_rule() {
        // n = 1000: flag |z| with 1000·P(|Z|>|z|) < ½ ⇔ |z| > Φ⁻¹(1 − 1/4000) = 3.4807564043462422
        // (scipy, tests/reference/detectors.py); samples within 1e-9 of it would be ambiguous.
        let mut x = noise(1000, 3);
        x[7] = 8.0;
        let d = chauvenet(&x).unwrap();
        assert!(d.mask[7]);
        let (m, s) = mean_sd(&x);
        for (i, &f) in d.mask.iter().enumerate() {
            let z = (x[i] - m).abs() / s;
            if (z - 3.4807564043462422).abs() > 1e-9 {
                assert_eq!(f, z > 3.4807564043462422, "i = {i}, z = {z}");
            }
        }
    }

    #[test]
    fn dixon_table_has_five_percent_size_on_gaussian_windows() {
        // 20 000 windows of 10 N(0,1): false-flag rate Binomial(20000, 0.05): sd 0.0015;
        // accept 0.05 ± 0.006 (4 sd). Guards the tabulated critical values.
        let x = noise(200_000, 4);
        let d = dixon_q(&x, 10).unwrap();
        let rate = d.mask.iter().filter(|m| **m).count() as f64 / 20_000.0;
        assert!((rate - 0.05).abs() < 0.006, "rate {rate}");
        let d = dixon_q(&x[..60_000], 5).unwrap();
        let rate = d.mask.iter().filter(|m| **m).count() as f64 / 12_000.0;
        assert!((rate - 0.05).abs() < 0.008, "rate {rate}");
    }

    #[test]
    fn score_counts_and_rmse_are_exact() {
        let pred = [true, true, false, false, false];
        let truth = [true, false, true, false, false];
        let corrected = [0.0, 0.0, 3.0, 0.0, 0.0];
        let clean = [0.0; 5];
        let s = score(&pred, &truth, &corrected, &clean).unwrap();
        assert_eq!(
            (s.true_positives, s.false_positives, s.false_negatives),
            (1, 1, 1)
        );
        assert_eq!(s.precision, 0.5);
        assert_eq!(s.recall, 0.5);
        assert_eq!(s.f1, 0.5);
        assert!((s.false_alarm_rate - 1.0 / 3.0).abs() < 1e-15);
        assert!((s.rmse - (9.0f64 / 5.0).sqrt()).abs() < 1e-15);
        assert!(score(&pred, &truth[..4], &corrected, &clean).is_err());
    }

    #[test]
    fn detectors_reject_non_finite_input() {
        let x = [1.0, f64::NAN, 2.0, 3.0];
        assert!(matches!(
            three_sigma(&x),
            Err(NumError::NonFinite { index: 1 })
        ));
        assert!(grubbs(&x, 0.05).is_err());
        assert!(chauvenet(&x).is_err());
        assert!(dixon_q(&x, 4).is_err());
        assert!(hampel(&x, 2, 3.0).is_err());
        assert!(dixon_q(&[1.0; 20], 11).is_err());
    }
}
