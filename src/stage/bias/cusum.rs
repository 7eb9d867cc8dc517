//! Two-sided CUSUM (Page 1954) on normalised Kalman innovations, for bias-step detection.
//!
//! With `u_k = nu_k / sqrt(S_k)` ~ N(0,1) while the model holds, and a step expected to shift `u`
//! by `delta` (in σ), the one-sided statistics are
//!
//! ```text
//!   g+_k = max(0, g+_{k-1} + u_k - kr),   g-_k = max(0, g-_{k-1} - u_k - kr),   kr = delta / 2,
//! ```
//!
//! and an alarm is raised when either exceeds `h`. `h` is chosen for an in-control average run
//! length (mean samples between false alarms) by Siegmund's approximation for one-sided CUSUM on
//! unit-variance Gaussian data, `ARL0 ≈ (exp(2 kr b) - 2 kr b - 1) / (2 kr²)`, `b = h + 1.166`;
//! the two-sided ARL is half the one-sided one (Siegmund, *Sequential Analysis*, 1985, §X.2;
//! Basseville & Nikiforov, *Detection of Abrupt Changes*, 1993, §5.2).

/// Siegmund's approximation of the one-sided CUSUM average run length for a mean shift
/// `shift` (σ units; 0 = in control) with reference `kr` and threshold `h`.
pub fn siegmund_arl(kr: f64, h: f64, shift: f64) -> f64 {
    let d = shift - kr; // drift of the statistic per sample, negated
    let b = h + 1.166;
    if d.abs() < 1e-9 {
        return b * b;
    }
    ((-2.0 * d * b).exp() + 2.0 * d * b - 1.0) / (2.0 * d * d)
}

/// Threshold `h` giving a two-sided in-control average run length of `arl0_samples`
/// (bisection on [`siegmund_arl`]).
pub fn threshold_for_arl(kr: f64, arl0_samples: f64) -> f64 {
    let target = 2.0 * arl0_samples.max(1.0);
    let (mut lo, mut hi) = (0.0, 1.0);
    while siegmund_arl(kr, hi, 0.0) < target && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if siegmund_arl(kr, mid, 0.0) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// Two-sided CUSUM detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cusum {
    kr: f64,
    h: f64,
    g_pos: f64,
    g_neg: f64,
}

impl Cusum {
    /// Detector for a shift of `shift_sigma` (σ units, > 0) with a mean of `arl0_samples`
    /// samples between false alarms.
    pub fn new(shift_sigma: f64, arl0_samples: f64) -> Self {
        let kr = 0.5 * shift_sigma.abs();
        Cusum {
            kr,
            h: threshold_for_arl(kr, arl0_samples),
            g_pos: 0.0,
            g_neg: 0.0,
        }
    }

    /// Reference value `kr` (σ).
    pub fn reference(&self) -> f64 {
        self.kr
    }

    /// Alarm threshold `h` (σ).
    pub fn threshold(&self) -> f64 {
        self.h
    }

    /// Feed one normalised innovation; returns +1 / -1 on an upward / downward alarm (and
    /// restarts), 0 otherwise.
    #[inline]
    pub fn update(&mut self, u: f64) -> i8 {
        if !u.is_finite() {
            return 0;
        }
        self.g_pos = (self.g_pos + u - self.kr).max(0.0);
        self.g_neg = (self.g_neg - u - self.kr).max(0.0);
        let alarm = if self.g_pos > self.h {
            1
        } else if self.g_neg > self.h {
            -1
        } else {
            0
        };
        if alarm != 0 {
            self.reset();
        }
        alarm
    }

    /// Restart both statistics at zero.
    pub fn reset(&mut self) {
        self.g_pos = 0.0;
        self.g_neg = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn false_alarm_interval_matches_the_design_value() {
        // Designed for ARL0 = 2000 samples with kr = 0.5. 300 alarms: the mean of ~exponential run
        // lengths has sd ARL/sqrt(300) = 5.8 %; Siegmund's approximation is within a few % at this
        // kr. 25 % = 4 sd + approximation error.
        let mut c = Cusum::new(1.0, 2000.0);
        let mut r = Rng::new(11);
        let (mut n, mut alarms) = (0u64, 0u64);
        while alarms < 300 {
            n += 1;
            if c.update(r.normal()) != 0 {
                alarms += 1;
            }
        }
        let arl = n as f64 / alarms as f64;
        assert!((arl / 2000.0 - 1.0).abs() < 0.25, "empirical ARL0 {arl}");
    }

    #[test]
    fn a_shift_is_detected_after_the_predicted_delay_in_its_direction() {
        // Shift of 1.5 σ with a detector tuned for 1 σ and ARL0 = 1e5: Siegmund's ARL1 formula
        // predicts the mean delay; 200 trials give a 5 % sd on the mean, tolerance 20 %.
        let mut r = Rng::new(12);
        let proto = Cusum::new(1.0, 1e5);
        let want = siegmund_arl(proto.reference(), proto.threshold(), 1.5);
        let mut total = 0u64;
        for _ in 0..200 {
            let mut c = proto;
            let mut k = 0u64;
            loop {
                k += 1;
                let a = c.update(-1.5 + r.normal());
                if a != 0 {
                    assert_eq!(a, -1, "downward shift must raise a downward alarm");
                    break;
                }
            }
            total += k;
        }
        let mean = total as f64 / 200.0;
        assert!(
            (mean / want - 1.0).abs() < 0.2,
            "mean delay {mean} vs Siegmund {want}"
        );
    }
}
