//! The ARIMA CSS fit of `imuprep::model::arima` redone with the `levenberg-marquardt` crate, for
//! the hand-vs-crate bench: the same residual recursion and derivative recursions
//! (`model/arima/mod.rs` docs), the same Hannan–Rissanen start (the hand fitter's own, taken from
//! `fit_arima` with `max_iter = 0`), the same stopping tolerances as far as the crate's criteria
//! allow (`ftol` = the hand loop's `rel_tol` on S, `xtol` = its 1e-10 relative small-step rule,
//! `gtol` off).
//!
//! The crate has no hook to reject a step, so the stage's admissibility rule (AR stationary, MA
//! invertible) is imposed the only way its interface allows: an inadmissible trial point returns
//! residuals of 1e100, which the crate counts as "no reduction" and shrinks its trust region, as
//! the hand loop raises λ. The crate needs the n × k Jacobian stored (the hand loop accumulates
//! JᵀJ and Jᵀe in the residual pass) and works on nalgebra 0.34 (the crate's), not the project's
//! 0.35.

use imuprep::model::arima::{
    CssOptions, ar_is_stationary, difference, fit_arima, ma_is_invertible,
};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra034::{DMatrix, DVector, Dyn, Owned};
use std::cell::Cell;

/// Residuals returned for an inadmissible trial point: far above any real residual, so the crate
/// sees the step as increasing the sum of squares and rejects it.
const REJECT: f64 = 1e100;

/// The CSS problem of an ARMA(p, q) with intercept on the differenced series `w`.
struct CssProblem<'a> {
    w: &'a [f64],
    p: usize,
    q: usize,
    n_cond: usize,
    /// `[c, φ_1..φ_p, θ_1..θ_q]`.
    beta: DVector<f64>,
    residual_evals: Cell<usize>,
    jacobian_evals: Cell<usize>,
}

impl CssProblem<'_> {
    fn admissible(&self) -> bool {
        let b = self.beta.as_slice();
        b.iter().all(|v| v.is_finite())
            && ar_is_stationary(&b[1..1 + self.p])
            && ma_is_invertible(&b[1 + self.p..])
    }

    /// e_t for t = n_cond..n−1 and, if `jac`, the rows ∂e_t/∂β.
    fn recursion(&self, mut jac: Option<&mut DMatrix<f64>>) -> DVector<f64> {
        let (w, p, q, k) = (self.w, self.p, self.q, 1 + self.p + self.q);
        let b = self.beta.as_slice();
        let (c, phi, theta) = (b[0], &b[1..1 + p], &b[1 + p..]);
        let mut e_lag = vec![0.0; q];
        let mut g_lag = vec![vec![0.0; k]; q];
        let mut g = vec![0.0; k];
        let mut e_out = DVector::zeros(w.len() - self.n_cond);
        for t in self.n_cond..w.len() {
            let mut e = w[t] - c;
            for i in 0..p {
                e -= phi[i] * w[t - 1 - i];
            }
            for j in 0..q {
                e -= theta[j] * e_lag[j];
            }
            let row = t - self.n_cond;
            e_out[row] = e;
            if let Some(jm) = jac.as_deref_mut() {
                g[0] = -1.0;
                for i in 0..p {
                    g[1 + i] = -w[t - 1 - i];
                }
                for m in 0..q {
                    g[1 + p + m] = -e_lag[m];
                }
                for j in 0..q {
                    for a in 0..k {
                        g[a] -= theta[j] * g_lag[j][a];
                    }
                }
                for a in 0..k {
                    jm[(row, a)] = g[a];
                }
                if q > 0 {
                    g_lag.rotate_right(1);
                    g_lag[0].copy_from_slice(&g);
                }
            }
            if q > 0 {
                e_lag.rotate_right(1);
                e_lag[0] = e;
            }
        }
        e_out
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for CssProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.beta.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.beta.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.residual_evals.set(self.residual_evals.get() + 1);
        if !self.admissible() {
            return Some(DVector::from_element(self.w.len() - self.n_cond, REJECT));
        }
        Some(self.recursion(None))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.jacobian_evals.set(self.jacobian_evals.get() + 1);
        let mut j = DMatrix::zeros(self.w.len() - self.n_cond, self.beta.len());
        self.recursion(Some(&mut j));
        Some(j)
    }
}

/// What the crate's fit gives, in the hand fit's terms.
#[derive(Debug)]
pub struct CrateFit {
    /// `[c, φ, θ]`.
    pub beta: Vec<f64>,
    /// Conditional sum of squares S at `beta`.
    pub ssr: f64,
    pub residual_evals: usize,
    pub jacobian_evals: usize,
    pub termination: TerminationReason,
}

/// ARIMA(p, d, q) with constant by CSS on `x` through the crate, from the hand fitter's start,
/// conditioning on the first p differenced values (as `fit_arima`).
pub fn fit_arima_crate(x: &[f64], p: usize, d: usize, q: usize, opts: &CssOptions) -> CrateFit {
    let start = fit_arima(
        x,
        p,
        d,
        q,
        &CssOptions {
            max_iter: 0,
            ..*opts
        },
    )
    .expect("start values");
    let w = difference(x, d);
    let mut beta0 = vec![start.constant];
    beta0.extend_from_slice(&start.ar);
    beta0.extend_from_slice(&start.ma);
    let problem = CssProblem {
        w: &w,
        p,
        q,
        n_cond: p,
        beta: DVector::from_vec(beta0),
        residual_evals: Cell::new(0),
        jacobian_evals: Cell::new(0),
    };
    let (problem, report) = LevenbergMarquardt::new()
        .with_ftol(opts.rel_tol)
        .with_xtol(1e-10)
        .with_gtol(0.0)
        .minimize(problem);
    CrateFit {
        beta: problem.beta.as_slice().to_vec(),
        // The crate's objective is ½‖e‖².
        ssr: 2.0 * report.objective_function,
        residual_evals: problem.residual_evals.get(),
        jacobian_evals: problem.jacobian_evals.get(),
        termination: report.termination,
    }
}
