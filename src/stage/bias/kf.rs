//! A fixed-size Kalman filter for one channel's stochastic bias (heap-free, O(n²) per sample).
//!
//! State (dimension `n = [1] + p <= MAX_STATE`):
//!
//! ```text
//!   x = [ c, d_k, d_{k-1}, ..., d_{k-p+1} ]      bias b_k = mean + c + d_k
//!   c_{k+1} = c_k + u_k,                 var(u) = q_c        (random constant / rate random walk)
//!   d_{k+1} = sum_i phi_i d_{k+1-i} + w_k, var(w) = q         (the bias AR(p), companion form)
//!   z_k     = y_k - mean = c_k + d_k + v_k, var(v) = r        (only while the sensor is still)
//! ```
//!
//! The `c` state is optional: present when the stage gives it a prior (turn-on bias uncertainty),
//! a rate random walk or a step detector to re-anchor; otherwise it has zero prior and zero
//! process noise and stays exactly 0. Prediction `P <- F P F' + Q` exploits the companion
//! structure of F: with `v = P_{:,ar} phi`, the new AR block is the old one shifted down and right
//! by one, its first row/column is `v`, and `P'_{d0 d0} = phi' v_ar + q` — one matrix-vector
//! product instead of two matrix products. The measurement update is the standard scalar update
//! `K = P H' / S`, `S = H P H' + r`, `P <- P - K (P H')'`.
//! Reference: Brown & Hwang, *Introduction to Random Signals and Applied Kalman Filtering*
//! (4th ed., 2012), ch. 4 and §3.9 (AR processes in state-space form).
//!
//! **Lead prediction.** The stage updates the filter with samples delayed by L steps (so motion
//! onset is seen before the samples next to it are trusted) and publishes the L-step prediction
//! `b_{k+L} = mean + h_L' x`, `var = h_L' P h_L + sum_{j<L} h_j' Q h_j`, `h_j = (F')^j H'`, which
//! [`Lead`] precomputes.

use nalgebra::{SMatrix, SVector};

use crate::model::bias_state_space::{BiasStateSpace, MAX_AR_ORDER};

/// Largest state dimension: the bias AR order plus the random-constant state.
pub const MAX_STATE: usize = MAX_AR_ORDER + 1;
/// Gaps longer than this many samples are not propagated step by step: the AR block is reset to
/// its stationary prior (the exact limit, reached to within `max|pole|^GAP_LOOP_MAX`).
pub const GAP_LOOP_MAX: u32 = 2000;

type Mat = SMatrix<f64, MAX_STATE, MAX_STATE>;
type Vect = SVector<f64, MAX_STATE>;

/// Settings of the optional random-constant / random-walk state `c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantState {
    /// Prior variance of `c`, unit² (turn-on bias uncertainty about the model's mean).
    pub prior_var: f64,
    /// Random-walk variance added per sample, unit² (`q_per_s / sample_rate_hz`).
    pub q_per_step: f64,
}

/// L-step lead vector `h_L = (F')^L H'` and the accumulated process-noise variance of the
/// prediction (see module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lead {
    /// `h_L`, length n (rest zero).
    pub h: [f64; MAX_STATE],
    /// `sum_{j<L} h_j' Q h_j`, unit².
    pub var_add: f64,
    /// L, in samples.
    pub steps: u32,
}

/// One channel's bias Kalman filter.
///
/// Storage and arithmetic always use the full [`MAX_STATE`] dimension with constant loop bounds
/// (unrolled, no bounds checks): a model of order p < 4 is padded with zero coefficients, which
/// describes the same process (the extra lags are carried but never feed back), and an absent
/// `c` state has zero prior and zero process noise, so it stays exactly 0. The results are those
/// of the n-dimensional filter.
#[derive(Debug, Clone)]
pub struct BiasKf {
    has_c: bool,
    order: usize,
    phi: [f64; MAX_AR_ORDER],
    q_ar: f64,
    q_c: f64,
    r: f64,
    mean: f64,
    gamma: [f64; MAX_AR_ORDER + 1],
    x: Vect,
    pm: Mat,
}

/// Index of the first AR state (`c` is state 0).
const D0: usize = 1;

impl BiasKf {
    /// A filter at the model's stationary prior: `d = 0` with covariance `Toeplitz(gamma_b)`,
    /// `c = 0` with `constant.prior_var`.
    pub fn new(ss: &BiasStateSpace, constant: Option<ConstantState>) -> Self {
        let mut kf = BiasKf {
            has_c: constant.is_some(),
            order: ss.order,
            phi: ss.phi,
            q_ar: ss.q,
            q_c: constant.map_or(0.0, |c| c.q_per_step),
            r: ss.r,
            mean: ss.mean,
            gamma: ss.gamma,
            x: Vect::zeros(),
            pm: Mat::zeros(),
        };
        if let Some(c) = constant {
            kf.pm[(0, 0)] = c.prior_var;
        }
        kf.reset_ar_to_stationary();
        kf
    }

    fn reset_ar_to_stationary(&mut self) {
        for i in 0..MAX_AR_ORDER {
            self.x[D0 + i] = 0.0;
            for j in 0..MAX_AR_ORDER {
                self.pm[(D0 + i, D0 + j)] = self.gamma[i.abs_diff(j)];
            }
            self.pm[(0, D0 + i)] = 0.0;
            self.pm[(D0 + i, 0)] = 0.0;
        }
    }

    /// State dimension of the unpadded filter (`[1] + p`).
    pub fn dim(&self) -> usize {
        usize::from(self.has_c) + self.order
    }

    /// True if the filter carries the random-constant state.
    pub fn has_constant(&self) -> bool {
        self.has_c
    }

    /// Model mean (unit).
    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// White measurement noise variance R (unit²).
    pub fn r(&self) -> f64 {
        self.r
    }

    /// One prediction step `x <- F x`, `P <- F P F' + Q` (structured, see module docs).
    #[inline]
    pub fn predict(&mut self) {
        let pm = &mut self.pm;
        // v = P[:, ar] phi over every row (old P).
        let mut v = [0.0; MAX_STATE];
        for (m, vm) in v.iter_mut().enumerate() {
            let mut acc = 0.0;
            for k in 0..MAX_AR_ORDER {
                acc += pm[(m, D0 + k)] * self.phi[k];
            }
            *vm = acc;
        }
        let mut p00 = self.q_ar;
        for k in 0..MAX_AR_ORDER {
            p00 += self.phi[k] * v[D0 + k];
        }
        // Shift the AR block down/right (descending so sources are still old).
        for a in (D0 + 1..MAX_STATE).rev() {
            for b in (D0 + 1..MAX_STATE).rev() {
                pm[(a, b)] = pm[(a - 1, b - 1)];
            }
        }
        for b in D0 + 1..MAX_STATE {
            pm[(D0, b)] = v[b - 1];
            pm[(b, D0)] = v[b - 1];
        }
        pm[(D0, D0)] = p00;
        // The c row/column shifts with the AR lags; its first AR entry is v[c].
        for b in (D0 + 1..MAX_STATE).rev() {
            let val = pm[(0, b - 1)];
            pm[(0, b)] = val;
            pm[(b, 0)] = val;
        }
        pm[(0, D0)] = v[0];
        pm[(D0, 0)] = v[0];
        pm[(0, 0)] += self.q_c;
        // State.
        let mut d0 = 0.0;
        for k in 0..MAX_AR_ORDER {
            d0 += self.phi[k] * self.x[D0 + k];
        }
        for i in (D0 + 1..MAX_STATE).rev() {
            self.x[i] = self.x[i - 1];
        }
        self.x[D0] = d0;
    }

    /// Propagate `steps` samples (a gap); beyond [`GAP_LOOP_MAX`] the AR block is reset to its
    /// stationary prior and `c`'s variance grows by `steps q_c`.
    #[inline]
    pub fn predict_steps(&mut self, steps: u32) {
        if steps == 1 {
            self.predict();
        } else if steps <= GAP_LOOP_MAX {
            for _ in 0..steps {
                self.predict();
            }
        } else {
            self.pm[(0, 0)] += self.q_c * steps as f64;
            self.reset_ar_to_stationary();
        }
    }

    /// The innovation `nu = z - H x` a measurement `z` would have, and its variance `S`, without
    /// updating (the stage's consistency guard looks before it leaps).
    #[inline]
    pub fn innovation(&self, z: f64) -> (f64, f64) {
        let nu = z - self.x[0] - self.x[D0];
        let s = self.pm[(0, 0)] + 2.0 * self.pm[(0, D0)] + self.pm[(D0, D0)] + self.r;
        (nu, s)
    }

    /// Measurement update with `z = y - mean` (expected true value already removed). Returns the
    /// innovation `nu = z - H x` and its variance `S`, or `None` if `S` is not positive.
    #[inline]
    pub fn update(&mut self, z: f64) -> Option<(f64, f64)> {
        let nu = z - self.x[0] - self.x[D0];
        let mut ph = [0.0; MAX_STATE];
        for (m, phm) in ph.iter_mut().enumerate() {
            *phm = self.pm[(m, 0)] + self.pm[(m, D0)];
        }
        let s = ph[0] + ph[D0] + self.r;
        if !(s > 0.0 && s.is_finite()) {
            return None;
        }
        let inv_s = 1.0 / s;
        for i in 0..MAX_STATE {
            let ki = ph[i] * inv_s;
            self.x[i] += ki * nu;
            for (j, phj) in ph.iter().enumerate() {
                self.pm[(i, j)] -= ki * phj;
            }
        }
        for i in 0..MAX_STATE {
            if self.pm[(i, i)] < 0.0 {
                self.pm[(i, i)] = 0.0;
            }
        }
        Some((nu, s))
    }

    /// Add `var_add` to the variance of `c` (re-anchoring after a detected step). No-op without
    /// the `c` state.
    pub fn inflate_constant(&mut self, var_add: f64) {
        if self.has_c {
            self.pm[(0, 0)] += var_add;
        }
    }

    /// Current bias estimate (unit, mean included) at the filter's own time.
    pub fn bias(&self) -> f64 {
        self.mean + self.x[0] + self.x[D0]
    }

    /// Variance of the current bias estimate, `H P H'` (unit²).
    pub fn bias_var(&self) -> f64 {
        (self.pm[(0, 0)] + self.pm[(D0, D0)] + 2.0 * self.pm[(0, D0)]).max(0.0)
    }

    /// The lead vector for an L-step prediction (O(L p); computed once per delay, or at a gap).
    pub fn lead(&self, steps: u32) -> Lead {
        let mut h = [0.0; MAX_STATE];
        h[0] = 1.0;
        h[D0] = 1.0;
        let mut var_add = 0.0;
        for _ in 0..steps {
            var_add += self.q_c + self.q_ar * h[D0] * h[D0];
            // h <- F' h: (F'h)[d_i] = phi_i h[d_0] + h[d_{i+1}]; c unchanged.
            let h0 = h[D0];
            for i in 0..MAX_AR_ORDER {
                let next = if i + 1 < MAX_AR_ORDER {
                    h[D0 + i + 1]
                } else {
                    0.0
                };
                h[D0 + i] = self.phi[i] * h0 + next;
            }
        }
        Lead { h, var_add, steps }
    }

    /// Bias predicted `lead.steps` ahead (unit, mean included) and its variance (unit²).
    #[inline]
    pub fn predict_ahead(&self, lead: &Lead) -> (f64, f64) {
        let mut b = self.mean;
        let mut var = lead.var_add;
        for i in 0..MAX_STATE {
            b += lead.h[i] * self.x[i];
            let mut row = 0.0;
            for j in 0..MAX_STATE {
                row += self.pm[(i, j)] * lead.h[j];
            }
            var += lead.h[i] * row;
        }
        (b, var.max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn model() -> BiasStateSpace {
        BiasStateSpace::from_bias_ar(&[1.2, -0.3, 0.05], 2e-3, 0.5, 0.1, 100.0).unwrap()
    }

    /// Dense reference for the unpadded model: F, Q, H with c at 0 and the p AR states at 1..=p.
    fn dense(kf: &BiasKf) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let n = 1 + kf.order;
        let mut f = DMatrix::zeros(n, n);
        let mut q = DMatrix::zeros(n, n);
        let mut h = DMatrix::zeros(1, n);
        f[(0, 0)] = 1.0;
        q[(0, 0)] = kf.q_c;
        h[(0, 0)] = 1.0;
        for i in 0..kf.order {
            f[(1, 1 + i)] = kf.phi[i];
            if i + 1 < kf.order {
                f[(2 + i, 1 + i)] = 1.0;
            }
        }
        q[(1, 1)] = kf.q_ar;
        h[(0, 1)] = 1.0;
        (f, q, h)
    }

    /// The unpadded block of the padded covariance.
    fn pdense(kf: &BiasKf) -> DMatrix<f64> {
        let n = 1 + kf.order;
        DMatrix::from_fn(n, n, |i, j| kf.pm[(i, j)])
    }

    #[test]
    fn structured_predict_and_update_equal_dense_kalman_equations() {
        // The structured code must equal F P F' + Q and the textbook update to round-off (1e-12
        // relative to the largest covariance entry).
        let mut kf = BiasKf::new(
            &model(),
            Some(ConstantState {
                prior_var: 0.7,
                q_per_step: 1e-4,
            }),
        );
        let (f, q, h) = dense(&kf);
        let n = 1 + kf.order;
        let mut xd = DMatrix::from_fn(n, 1, |i, _| kf.x[i]);
        let mut pd = pdense(&kf);
        let zs = [0.3, -0.1, 0.25, 0.0, 0.9, -0.4];
        for (k, z) in zs.iter().enumerate() {
            kf.predict();
            xd = &f * xd;
            pd = &f * pd * f.transpose() + &q;
            if k % 2 == 0 {
                kf.update(*z - kf.mean()).unwrap();
                let s = (&h * &pd * h.transpose())[(0, 0)] + kf.r;
                let gain = &pd * h.transpose() / s;
                let nu = *z - kf.mean() - (&h * &xd)[(0, 0)];
                xd += &gain * nu;
                pd = &pd - &gain * (&h * &pd);
            }
            let scale = pd.amax();
            let pk = pdense(&kf);
            assert!((&pk - &pd).amax() < 1e-12 * scale, "step {k}\n{pk}\n{pd}");
            for i in 0..n {
                assert!((kf.x[i] - xd[(i, 0)]).abs() < 1e-12, "x step {k}");
            }
        }
    }

    #[test]
    fn lead_prediction_equals_repeated_prediction() {
        // Predicting L steps with the lead vector must equal L calls of predict() (1e-12).
        let mut kf = BiasKf::new(
            &model(),
            Some(ConstantState {
                prior_var: 0.2,
                q_per_step: 3e-4,
            }),
        );
        for z in [0.5, 0.1, -0.2, 0.4] {
            kf.predict();
            kf.update(z).unwrap();
        }
        let lead = kf.lead(7);
        let (b, v) = kf.predict_ahead(&lead);
        let mut ahead = kf.clone();
        ahead.predict_steps(7);
        assert!((b - ahead.bias()).abs() < 1e-12, "{b} vs {}", ahead.bias());
        assert!(
            (v - ahead.bias_var()).abs() < 1e-12 * v,
            "{v} vs {}",
            ahead.bias_var()
        );
    }

    #[test]
    fn long_prediction_converges_to_the_stationary_variance() {
        // Without measurements the AR part's variance tends to gamma_b(0) and the estimate to the
        // mean: 5000 steps with poles of modulus <= 0.8 leave 0.8^5000 ~ 0 (1e-9 relative).
        let ss = model();
        let mut kf = BiasKf::new(&ss, None);
        kf.update(3.0).unwrap();
        kf.predict_steps(5000);
        assert!((kf.bias_var() - ss.gamma[0]).abs() < 1e-9 * ss.gamma[0]);
        assert!((kf.bias() - ss.mean).abs() < 1e-9);
    }

    #[test]
    fn random_walk_state_variance_grows_by_q_per_step() {
        // Closed form: with no AR part, var(c) after k predictions = prior + k q.
        let ss = BiasStateSpace::from_bias_ar(&[], 1.0, 0.5, 0.0, 100.0).unwrap();
        let mut kf = BiasKf::new(
            &ss,
            Some(ConstantState {
                prior_var: 0.01,
                q_per_step: 2e-5,
            }),
        );
        kf.predict_steps(1000);
        assert!((kf.bias_var() - (0.01 + 1000.0 * 2e-5)).abs() < 1e-15);
        kf.predict_steps(GAP_LOOP_MAX + 1000);
        assert!((kf.bias_var() - (0.01 + (GAP_LOOP_MAX as f64 + 2000.0) * 2e-5)).abs() < 1e-12);
    }
}
