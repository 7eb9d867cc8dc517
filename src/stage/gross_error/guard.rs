//! A model-free jump guard of one channel: a sample is a candidate when it jumps from the last
//! accepted sample by more than k times the RMS of the last `GUARD_N` accepted increments.
//!
//! Why beside the ARIMA gate: the gate's model is identified once, on whatever its warm-up saw,
//! and its σ follows the signal with a time constant of `scale_window_samples`. On a real
//! recording that warms up while moving, the model carries the motion's momentum into rest
//! (an AR polynomial with a root near 1) and σ stays inflated for a second after the motion
//! stops; a spike there passes the gate and the predictor extrapolates it into a ramp. The guard
//! knows only the last few increments, so it sees that spike against the rest noise around it.
//! It is also the only candidate source while the gate warms up. Either source makes a
//! candidate; the two-sided confirmation (`confirm.rs`) decides what is replaced.

/// Accepted increments whose RMS sets the guard's scale.
pub const GUARD_N: usize = 16;
/// Increments the guard learns before it judges.
const GUARD_MIN: usize = 8;

/// The guard (fixed size, no allocation).
#[derive(Debug, Clone, Copy)]
pub struct JumpGuard {
    sq: [f64; GUARD_N],
    head: usize,
    n: usize,
    /// Running sum of `sq` (recomputed exactly at every wrap of `head`, against round-off).
    sum: f64,
    last: f64,
    run: u32,
    /// Floor of the mean squared increment (2 × the gate's σ floor²), and that floor raised to
    /// the channel's quantisation noise (see [`JumpGuard::set_quantum`]).
    base_floor2: f64,
    floor2: f64,
}

impl JumpGuard {
    pub fn new(min_sigma: f64) -> Self {
        JumpGuard {
            sq: [0.0; GUARD_N],
            head: 0,
            n: 0,
            sum: 0.0,
            last: f64::NAN,
            run: 0,
            base_floor2: 2.0 * min_sigma * min_sigma,
            floor2: 2.0 * min_sigma * min_sigma,
        }
    }

    /// The channel's quantisation step `lsb` (0: none seen): the increments' floor becomes at
    /// least that of two independent quantisation errors, 2 · LSB²/12. A channel whose noise is
    /// below one LSB sits on one code for many samples, its recent increments are all 0, and
    /// without this every one-LSB toggle would jump "infinitely many σ".
    pub fn set_quantum(&mut self, lsb: f64) {
        self.floor2 = self.base_floor2.max(lsb * lsb / 6.0);
    }

    /// Would `v` be a candidate (|v − last accepted| > k · RMS of recent increments)? Not after
    /// `max_run` successive candidates: the level has changed.
    #[inline]
    pub fn candidate(&self, v: f64, k: f64, max_run: u32) -> bool {
        if !self.last.is_finite() || self.n < GUARD_MIN || self.run >= max_run {
            return false;
        }
        let mean = (self.sum / self.n as f64).max(self.floor2);
        let d = v - self.last;
        d * d > k * k * mean
    }

    /// Record the verdict on `v`: accepted (a new increment and level) or a candidate.
    #[inline]
    pub fn commit(&mut self, v: f64, accepted: bool) {
        if !accepted {
            self.run = self.run.saturating_add(1);
            return;
        }
        if self.last.is_finite() {
            let d = v - self.last;
            let old = if self.n == GUARD_N {
                self.sq[self.head]
            } else {
                0.0
            };
            self.sq[self.head] = d * d;
            self.sum += d * d - old;
            self.head = (self.head + 1) % GUARD_N;
            self.n = (self.n + 1).min(GUARD_N);
            if self.head == 0 {
                self.sum = self.sq[..self.n].iter().sum();
            }
        }
        self.last = v;
        self.run = 0;
    }

    /// Successive candidates so far.
    pub fn run(&self) -> u32 {
        self.run
    }

    /// The last accepted value (NaN before the first).
    pub fn last(&self) -> f64 {
        self.last
    }

    /// Forget the level (after a reset gap): the next value is accepted.
    pub fn reset(&mut self) {
        self.last = f64::NAN;
        self.run = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spike_after_quiet_samples_is_a_candidate_and_noise_is_not() {
        let mut g = JumpGuard::new(1e-6);
        let noise = [0.1, -0.2, 0.05, 0.15, -0.1, 0.0, 0.2, -0.05, 0.1, -0.15];
        for &v in &noise {
            assert!(!g.candidate(v, 4.5, 10));
            g.commit(v, true);
        }
        // RMS of the increments here is ~0.2: a jump of 3 is a candidate, 0.3 is not.
        assert!(g.candidate(3.0, 4.5, 10));
        assert!(!g.candidate(0.3, 4.5, 10));
        g.commit(3.0, false);
        assert_eq!(g.run(), 1);
        // The level it compares with is still the last accepted one.
        assert!(!g.candidate(-0.1, 4.5, 10));
    }

    #[test]
    fn after_max_run_candidates_the_level_is_accepted() {
        let mut g = JumpGuard::new(1e-6);
        for k in 0..10 {
            g.commit(0.01 * f64::from(k % 3), true);
        }
        for _ in 0..3 {
            assert!(g.candidate(5.0, 4.5, 3));
            g.commit(5.0, false);
        }
        assert!(!g.candidate(5.0, 4.5, 3));
    }
}
