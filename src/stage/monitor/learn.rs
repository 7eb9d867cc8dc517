//! The monitor's learning rule, shared by its tests: a channel's own no-effect value is learned
//! from the windows that raised no alarm, each one only after a delay (two windows), and
//! dropped if an alarm comes meanwhile — so the rise of an effect, seen in the windows just
//! before the one that crossed the bar, does not teach the detector that the effect is ordinary.

use statrs::distribution::{ContinuousCDF, FisherSnedecor};
use std::collections::VecDeque;

/// Cap on the EDF of a learned value (beyond it the quantile no longer moves).
const MAX_POOLED_EDF: f64 = 1000.0;

/// The `F(ν, ν·n)` quantile at `q`: a window's statistic of EDF `ν` divided by the channel's
/// own value learned from `n` independent windows of the same EDF (the pooled EDF capped at
/// 1000). `None` where the distribution is undefined (ν or n not positive).
pub fn f_quantile(nu: f64, independent: f64, q: f64) -> Option<f64> {
    let pooled = (independent * nu).min(MAX_POOLED_EDF);
    Some(FisherSnedecor::new(nu, pooled).ok()?.inverse_cdf(q))
}

/// Values waiting `delay` further offers before they are learned from.
#[derive(Debug, Clone)]
pub struct Delayed<T> {
    pending: VecDeque<T>,
    delay: usize,
}

impl<T> Delayed<T> {
    /// Each value is learned from after `delay` more values were offered.
    pub fn new(delay: usize) -> Self {
        Delayed {
            pending: VecDeque::with_capacity(delay + 1),
            delay,
        }
    }

    /// Offers one quiet window's value; returns the value that has now waited long enough.
    pub fn offer(&mut self, v: T) -> Option<T> {
        self.pending.push_back(v);
        if self.pending.len() > self.delay {
            self.pending.pop_front()
        } else {
            None
        }
    }

    /// An alarm: every value still waiting is dropped.
    pub fn drop_pending(&mut self) {
        self.pending.clear();
    }
}

/// Samples that cannot be used inside a still run (not judged still; a replaced, saturated or
/// non-finite value): up to `max` in a row are bridged, one more breaks the run. The bias
/// stage's stillness drops out for a sample or a few now and then at rest (on the simulated
/// bench 131 times in 20 min at 100 Hz, 462 times at 200 Hz, median 10–20 ms), and the
/// gross-error stage replaces a sample now and then; a break no longer than `max` cannot hold
/// a motion that moves a test's statistic much.
#[derive(Debug, Clone)]
pub struct Bridge {
    skipped: usize,
    max: usize,
}

impl Bridge {
    /// Up to `max` skipped samples in a row are bridged.
    pub fn new(max: usize) -> Self {
        Bridge { skipped: 0, max }
    }

    /// One sample skipped; `true` when the run must break (more than `max` in a row).
    pub fn skip(&mut self) -> bool {
        self.skipped += 1;
        self.skipped > self.max
    }

    /// A sample used, or the run broken: the count starts again.
    pub fn reset(&mut self) {
        self.skipped = 0;
    }
}

/// The scatter of learned positive values on a log scale, and the degrees of freedom it implies
/// for a `χ²_ν/ν` variate: `var(ln χ²_ν/ν) ≈ 2/ν + 2/ν²`, solved for ν. A channel's own values
/// that scatter wider than the statistic's textbook distribution (a real bench's episodes, a
/// line's amplitude changing) lower ν and so raise the F bar.
#[derive(Debug, Clone, Default)]
pub struct LogScatter {
    n: u64,
    sum: f64,
    sq: f64,
}

impl LogScatter {
    /// One learned value (> 0).
    pub fn add(&mut self, x: f64) {
        let l = x.ln();
        self.sum += l;
        self.sq += l * l;
        self.n += 1;
    }

    /// ν from the values' log-variance (`None` with fewer than two values).
    pub fn edf(&self) -> Option<f64> {
        if self.n < 2 {
            return None;
        }
        let n = self.n as f64;
        let mean = self.sum / n;
        let v = (self.sq / n - mean * mean).max(1e-9) * n / (n - 1.0);
        Some((1.0 + (1.0 + 2.0 * v).sqrt()) / v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_wait_their_delay_and_an_alarm_drops_them() {
        let mut d = Delayed::new(2);
        assert_eq!(d.offer(1), None);
        assert_eq!(d.offer(2), None);
        assert_eq!(d.offer(3), Some(1));
        d.drop_pending();
        assert_eq!(d.offer(4), None);
        assert_eq!(d.offer(5), None);
        assert_eq!(d.offer(6), Some(4));
    }

    #[test]
    fn log_scatter_recovers_the_edf_of_chi_square_values() {
        // 20 000 draws of χ²₁₀/10: the log-variance formula gives ν within 10 % of 10 (the
        // formula's own approximation is ≈ 3 % at ν = 10; the sampling error of the variance
        // at 20 000 draws ≈ 1.5 %).
        let mut r = crate::rng::Rng::new(5);
        let mut ls = LogScatter::default();
        for _ in 0..20_000 {
            let x: f64 = (0..10).map(|_| r.normal().powi(2)).sum::<f64>() / 10.0;
            ls.add(x);
        }
        let nu = ls.edf().unwrap();
        assert!((nu / 10.0 - 1.0).abs() < 0.1, "{nu}");
    }
}
