//! Quantisation and saturation of a channel.
//!
//! **LSB.** A quantised channel takes values on a grid x = c + k·q. Among the distinct values
//! inside the 5–95 % quantile range (the densely populated core, where every code occurs), the
//! spacing of consecutive distinct values is q; the estimate is the core's span divided by its
//! number of gaps when the gaps are uniform (max gap < 1.5 × median gap), which also averages out
//! a printing rounding finer than q (values written with fewer decimals than the grid needs), and
//! the median gap otherwise. The grid offset c is the circular mean of frac(x/q); the share of
//! samples within ±0.1 q of the grid tells how exact the grid is. Quantisation noise, if it acts
//! as uniform rounding, has variance q²/12 (Widrow & Kollár 2008, ch. 4).
//! **Saturation.** A clipped channel piles samples up at its extreme: a continuous variable never
//! repeats its maximum, and a quantised one has fewer samples on its extreme code than on the
//! code next to it. The extreme is flagged when it occurs at least 3 times and more often than
//! the neighbouring code (or at all repeatedly, for unquantised data).

use super::AnalysisError;
use crate::stats::check_series;
use serde::Serialize;

/// Quantisation finding.
#[derive(Clone, Debug, Serialize)]
pub struct Quantisation {
    /// Number of distinct values.
    pub distinct_values: usize,
    /// Number of samples.
    pub n: usize,
    /// Estimated LSB q, if the data sit on a grid.
    pub lsb: Option<f64>,
    /// Share of samples within ±0.1 q of the grid.
    pub on_grid_share: f64,
    /// q²/12.
    pub noise_var: Option<f64>,
    /// q²/12 divided by the channel's variance.
    pub share_of_variance: Option<f64>,
}

/// Estimate the LSB of `x` (None when the data are not visibly quantised).
pub fn quantisation(x: &[f64]) -> Result<Quantisation, AnalysisError> {
    check_series(x, 16)?;
    let n = x.len();
    let mut s = x.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let mut distinct = s.clone();
    distinct.dedup();
    let mean = x.iter().sum::<f64>() / n as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    let mut q = Quantisation {
        distinct_values: distinct.len(),
        n,
        lsb: None,
        on_grid_share: 0.0,
        noise_var: None,
        share_of_variance: None,
    };
    // A grid shows as far fewer distinct values than samples.
    if distinct.len() < 3 || distinct.len() * 4 > n {
        return Ok(q);
    }
    let lo = s[n / 20];
    let hi = s[n - 1 - n / 20];
    let core: Vec<f64> = distinct
        .iter()
        .copied()
        .filter(|v| *v >= lo && *v <= hi)
        .collect();
    if core.len() < 3 {
        return Ok(q);
    }
    let mut gaps: Vec<f64> = core.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(|a, b| a.total_cmp(b));
    let med = gaps[gaps.len() / 2];
    let maxg = gaps[gaps.len() - 1];
    let lsb = if maxg < 1.5 * med {
        (core[core.len() - 1] - core[0]) / (core.len() - 1) as f64
    } else {
        med
    };
    if !super::is_pos(lsb) {
        return Ok(q);
    }
    // Grid offset as the circular mean of the fractional parts.
    let (mut sc, mut ss) = (0.0, 0.0);
    for v in x {
        let ang = 2.0 * std::f64::consts::PI * (v / lsb);
        sc += ang.cos();
        ss += ang.sin();
    }
    let offset = ss.atan2(sc) / (2.0 * std::f64::consts::PI);
    let on = x
        .iter()
        .filter(|v| ((*v / lsb - offset) - (*v / lsb - offset).round()).abs() < 0.1)
        .count();
    q.on_grid_share = on as f64 / n as f64;
    if q.on_grid_share > 0.9 {
        q.lsb = Some(lsb);
        q.noise_var = Some(lsb * lsb / 12.0);
        q.share_of_variance = (var > 0.0).then(|| lsb * lsb / 12.0 / var);
    }
    Ok(q)
}

/// Saturation finding.
#[derive(Clone, Debug, Serialize)]
pub struct Saturation {
    /// Largest value.
    pub max: f64,
    /// Smallest value.
    pub min: f64,
    /// Samples equal to the largest value.
    pub at_max: usize,
    /// Samples equal to the smallest value.
    pub at_min: usize,
    /// Pile-up at the maximum.
    pub clipped_high: bool,
    /// Pile-up at the minimum.
    pub clipped_low: bool,
}

/// Detect clipping at either extreme of `x`, given its LSB if quantised.
pub fn saturation(x: &[f64], lsb: Option<f64>) -> Result<Saturation, AnalysisError> {
    check_series(x, 2)?;
    let max = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = x.iter().copied().fold(f64::INFINITY, f64::min);
    let at_max = x.iter().filter(|v| **v == max).count();
    let at_min = x.iter().filter(|v| **v == min).count();
    let pile = |edge: f64, count: usize, dir: f64| -> bool {
        if count < 3 {
            return false;
        }
        match lsb {
            None => true,
            Some(q) => {
                // Samples on the code next to the edge.
                let next = x
                    .iter()
                    .filter(|v| ((edge - **v) * dir - q).abs() < 0.5 * q)
                    .count();
                count > next
            }
        }
    };
    Ok(Saturation {
        max,
        min,
        at_max,
        at_min,
        clipped_high: pile(max, at_max, 1.0),
        clipped_low: pile(min, at_min, -1.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn lsb_of_a_rounded_gaussian_is_recovered() {
        // Gaussian sd 0.4 rounded to a 0.05 grid offset by 0.013: the core holds every code, so
        // the span/gaps estimate is exact to float rounding.
        let mut rng = Rng::new(1);
        let x: Vec<f64> = (0..50_000)
            .map(|_| (0.4 * rng.normal() / 0.05).round() * 0.05 + 0.013)
            .collect();
        let q = quantisation(&x).unwrap();
        assert!((q.lsb.unwrap() - 0.05).abs() < 1e-9, "{q:?}");
        assert!(q.on_grid_share > 0.999);
    }

    #[test]
    fn lsb_survives_coarser_printing() {
        // LSB 0.0076 printed with 3 decimals (the rtklibexplorer case): gaps alternate 0.007 /
        // 0.008, their mean is the LSB within the 0.0005 print rounding over the core span.
        let mut rng = Rng::new(2);
        let x: Vec<f64> = (0..50_000)
            .map(|_| (((0.05 * rng.normal() / 0.0076).round() * 0.0076) * 1000.0).round() / 1000.0)
            .collect();
        let q = quantisation(&x).unwrap();
        assert!((q.lsb.unwrap() - 0.0076).abs() < 1e-4, "{q:?}");
    }

    #[test]
    fn continuous_data_are_not_quantised() {
        let mut rng = Rng::new(3);
        let x: Vec<f64> = (0..10_000).map(|_| rng.normal()).collect();
        assert!(quantisation(&x).unwrap().lsb.is_none());
    }

    #[test]
    fn clipping_is_a_pile_up_at_the_edge() {
        // Gaussian sd 1 on a 0.01 grid clipped at +1.5: ~6.7 % of samples pile on the top code,
        // against ~0.13 % on the next one; the bottom is not clipped.
        let mut rng = Rng::new(4);
        let x: Vec<f64> = (0..20_000)
            .map(|_| ((rng.normal().min(1.5)) / 0.01).round() * 0.01)
            .collect();
        let s = saturation(&x, Some(0.01)).unwrap();
        assert!(s.clipped_high && !s.clipped_low, "{s:?}");
        let y: Vec<f64> = (0..20_000)
            .map(|_| (rng.normal() / 0.01).round() * 0.01)
            .collect();
        let s = saturation(&y, Some(0.01)).unwrap();
        assert!(!s.clipped_high && !s.clipped_low, "{s:?}");
    }
}
