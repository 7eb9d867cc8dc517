//! The noise of the gyro fit's residuals (`calib_gyro`), so that its σ cover the error
//! (issue 17: a published σ must cover the error).
//!
//! A motion's residual r_k = u_{k+1} − ΔR_kᵀ u_k (rotations through K = I here: the model is
//! first order, and K is within a few % of I) carries, to first order, all of it in the plane
//! orthogonal to u_{k+1}:
//!
//! ```text
//!   δr_k = δu_{k+1} − ΔR_kᵀ δu_k − G_k a_k + G_k M_k δb_k,     G_k = ΔR_kᵀ [u_k]×,  M_k = Σ_i R_i Δt_i
//! ```
//!
//! - δu_s, each still stretch's direction error: its mean specific force's white noise
//!   (per-axis sample variance / N) through the accelerometer calibration, P L⁻¹ with
//!   P = (I − u uᵀ)/|t|;
//! - a_k = Σ_i R_i n_i Δt_i, the gyro's white noise integrated over the motion (per-axis sample
//!   variance of the flanking stretches);
//! - δb_k, the error of the bias taken for the motion (the gyro's mean over the two flanking
//!   stretches, each mean's variance its sample variance / N).
//!
//! Consecutive motions share a still stretch s, so their residuals are correlated: the shared
//! direction enters one as +δu_s and the next as −ΔRᵀδu_s, the shared stretch's gyro mean both
//! biases. The covariance of the residuals projected on each motion's plane (2 components) is
//! therefore block tridiagonal; the fit whitens them with its block Cholesky factor
//! (generalised least squares), and scales the σ by the whitened residuals' variance, as before.
//!
//! The accelerometer calibration's own error moves every u at once (a common frame error that
//! more motions do not average out): ∂r_k/∂θ_a = ∂u_{k+1}/∂θ_a − ΔR_kᵀ ∂u_k/∂θ_a, and the fitted
//! K moves by D δθ_a, D = −(JᵀJ)⁻¹Jᵀ ∂r/∂θ_a (whitened), so its covariance gains D Cov(θ_a) Dᵀ.
//! The accelerometer fit uses each stretch's |f| (its radial noise), the directions their
//! transverse noise: the two are independent to first order, so the terms add.

use nalgebra::{
    DMatrix, Matrix2, Matrix3, Matrix3x2, Rotation3, SMatrix, SymmetricEigen, Vector2, Vector3,
};

use super::calib_fit::{Cov9, FittedCalibration, direction, nominal};
use super::calib_still::{AccelStretch, mean_var};
use crate::sample::Sample;

/// Smallest per-sample variances used, (m/s²)² and (rad/s)²: a stretch whose samples are all one
/// code (sample variance 0) still gets a positive-definite covariance. Far below any real
/// sensor's noise, so they decide nothing else.
const ACCEL_VAR_FLOOR: f64 = 1e-12;
const GYRO_VAR_FLOOR: f64 = 1e-14;

/// What one still stretch gives the motions next to it.
#[derive(Clone, Debug)]
pub(crate) struct StretchNoise {
    /// Gravity direction through the accelerometer calibration.
    pub u: Vector3<f64>,
    /// Covariance of `u`.
    pub u_cov: Matrix3<f64>,
    /// ∂u/∂θ_a times a square root of the accelerometer fit's covariance (3 × 9).
    pub u_accel: SMatrix<f64, 3, 9>,
    /// The gyro's mean and per-sample variance per axis over the stretch.
    pub gyro_mean: Vector3<f64>,
    pub gyro_var: Vector3<f64>,
    /// Samples.
    pub n: usize,
}

/// A square root S of a covariance (S Sᵀ = C; NaN when C is not finite, so the σ it enters
/// are NaN rather than too small).
fn sqrt_cov(c: &Cov9) -> Cov9 {
    if c.iter().any(|v| !v.is_finite()) {
        return Cov9::from_element(f64::NAN);
    }
    let e = SymmetricEigen::new(*c);
    e.eigenvectors * Cov9::from_diagonal(&e.eigenvalues.map(|l| l.max(0.0).sqrt()))
}

/// [`StretchNoise`] of every stretch; `accel` the kept accelerometer calibration, if any
/// (without one the raw directions, with no frame error).
pub(crate) fn stretch_noise(
    samples: &[Sample],
    stretches: &[AccelStretch],
    accel: Option<&FittedCalibration>,
) -> Vec<StretchNoise> {
    let (th, s) = accel.map_or((nominal(), Cov9::zeros()), |a| (a.theta, sqrt_cov(&a.cov)));
    stretches
        .iter()
        .map(|st| {
            let x = &samples[st.start..st.start + st.len];
            let n = x.len().max(1) as f64;
            let (mean, var) = mean_var(x, |v| v.gyro);
            let f_cov = Matrix3::from_diagonal(
                &Vector3::from(st.sd_m_s2).map(|v| (v * v).max(ACCEL_VAR_FLOOR) / n),
            );
            // A calibration that passed validation has positive scales; the raw directions
            // otherwise.
            let (u, du_df, du_dth) = direction(&th, &st.mean())
                .unwrap_or_else(|| direction(&nominal(), &st.mean()).unwrap_or_default());
            StretchNoise {
                u,
                u_cov: du_df * f_cov * du_df.transpose(),
                u_accel: du_dth * s,
                gyro_mean: mean,
                gyro_var: var.map(|v| v.max(GYRO_VAR_FLOOR)),
                n: x.len(),
            }
        })
        .collect()
}

/// The noise of one motion's residual, projected on the plane orthogonal to u_{k+1}.
#[derive(Clone, Debug, Default)]
pub struct MotionNoise {
    /// Orthonormal basis of that plane (3 × 2).
    pub(crate) basis: Matrix3x2<f64>,
    /// Covariance of the projected residual.
    pub(crate) own: Matrix2<f64>,
    /// Its covariance with the next motion's, when that one starts at the stretch this one ends
    /// at.
    pub(crate) next: Option<Matrix2<f64>>,
    /// The projected residual's sensitivity to the accelerometer fit's error times a square
    /// root of that fit's covariance (2 × 9).
    pub(crate) accel: SMatrix<f64, 2, 9>,
}

/// An orthonormal basis of the plane orthogonal to the unit vector `u`.
fn plane(u: &Vector3<f64>) -> Matrix3x2<f64> {
    let a = u.iamin();
    let e1 = u.cross(&Vector3::ith(a, 1.0)).normalize();
    Matrix3x2::from_columns(&[e1, u.cross(&e1)])
}

/// One motion: the flanking stretches' indices and its bias-free rates.
pub(crate) struct MotionRates<'a> {
    pub stretches: [usize; 2],
    pub rates: &'a [(Vector3<f64>, f64)],
}

/// The [`MotionNoise`] of consecutive `motions` (in order) from their stretches' `st`.
pub(crate) fn motion_noise(motions: &[MotionRates], st: &[StretchNoise]) -> Vec<MotionNoise> {
    // Per motion: ΔR, G M (the bias error's map), the bias weights of its two stretches.
    struct Parts {
        dr: Matrix3<f64>,
        gm: Matrix3<f64>,
        w: [f64; 2],
    }
    let var_of_mean = |s: &StretchNoise| Matrix3::from_diagonal(&(s.gyro_var / s.n.max(1) as f64));
    let mut parts = Vec::with_capacity(motions.len());
    let mut out: Vec<MotionNoise> = motions
        .iter()
        .map(|m| {
            let (a, b) = (&st[m.stretches[0]], &st[m.stretches[1]]);
            let (na, nb) = (a.n as f64, b.n as f64);
            let w = [na / (na + nb), nb / (na + nb)];
            let var = Matrix3::from_diagonal(&(a.gyro_var * w[0] + b.gyro_var * w[1]));
            let mut r = Rotation3::identity();
            let (mut sum_r, mut arw) = (Matrix3::zeros(), Matrix3::zeros());
            for (wv, dt) in m.rates {
                r *= Rotation3::new(wv * *dt);
                sum_r += r.matrix() * *dt;
                arw += r.matrix() * var * r.matrix().transpose() * (dt * dt);
            }
            let dr = *r.matrix();
            let g = dr.transpose() * a.u.cross_matrix();
            let gm = g * sum_r;
            let bias = var_of_mean(a) * (w[0] * w[0]) + var_of_mean(b) * (w[1] * w[1]);
            let own = b.u_cov
                + dr.transpose() * a.u_cov * dr
                + g * arw * g.transpose()
                + gm * bias * gm.transpose();
            let e = plane(&b.u);
            let accel = e.transpose() * (b.u_accel - dr.transpose() * a.u_accel);
            parts.push(Parts { dr, gm, w });
            MotionNoise {
                basis: e,
                own: e.transpose() * own * e,
                next: None,
                accel,
            }
        })
        .collect();
    for k in 1..motions.len() {
        let s = motions[k].stretches[0];
        if motions[k - 1].stretches[1] != s {
            continue;
        }
        let (p, q) = (&parts[k - 1], &parts[k]);
        let cross =
            -st[s].u_cov * q.dr + p.gm * var_of_mean(&st[s]) * (p.w[1] * q.w[0]) * q.gm.transpose();
        out[k - 1].next = Some(out[k - 1].basis.transpose() * cross * out[k].basis);
    }
    out
}

/// The whitening of consecutive motions' projected residuals: the block Cholesky factor L of
/// their block-tridiagonal covariance, applied as L⁻¹.
pub(crate) struct Whitener {
    /// Per motion: L_kk⁻¹ and L_{k,k−1} (None when it shares no stretch with the one before).
    blocks: Vec<(Matrix2<f64>, Option<Matrix2<f64>>)>,
}

/// `(motion noise, shares a stretch with the one before in this selection)`.
pub(crate) type Selected<'a> = (&'a MotionNoise, bool);

impl Whitener {
    pub fn new(sel: &[Selected]) -> Whitener {
        let mut blocks: Vec<(Matrix2<f64>, Option<Matrix2<f64>>)> = Vec::with_capacity(sel.len());
        let chol_inv = |m: Matrix2<f64>| m.cholesky().and_then(|c| c.l().try_inverse());
        for (k, (m, shares)) in sel.iter().enumerate() {
            // L_{k,k−1} = Σ_{k,k−1} L_{k−1,k−1}⁻ᵀ, Σ_{k,k−1} = (cov of k−1 with k)ᵀ.
            let off = (k > 0 && *shares)
                .then(|| {
                    sel[k - 1]
                        .0
                        .next
                        .map(|c| c.transpose() * blocks[k - 1].0.transpose())
                })
                .flatten();
            let inv = off
                .and_then(|o| chol_inv(m.own - o * o.transpose()))
                .map(|i| (i, off))
                .or_else(|| chol_inv(m.own).map(|i| (i, None)))
                .unwrap_or_else(|| {
                    let v = (m.own.trace() / 2.0).max(f64::MIN_POSITIVE);
                    (Matrix2::identity() / v.sqrt(), None)
                });
            blocks.push(inv);
        }
        Whitener { blocks }
    }

    /// L⁻¹ x for the stacked 2-vectors `x`, one per motion.
    pub fn apply(&self, x: &[Vector2<f64>]) -> Vec<Vector2<f64>> {
        let mut out: Vec<Vector2<f64>> = Vec::with_capacity(x.len());
        for (k, (inv, off)) in self.blocks.iter().enumerate() {
            let prev = off.map_or(Vector2::zeros(), |o| o * out[k - 1]);
            out.push(inv * (x[k] - prev));
        }
        out
    }

    /// L⁻¹ applied to each column of `m` (2 rows per motion).
    pub fn apply_columns(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(m.nrows(), m.ncols());
        for c in 0..m.ncols() {
            let x: Vec<Vector2<f64>> = (0..self.blocks.len())
                .map(|k| Vector2::new(m[(2 * k, c)], m[(2 * k + 1, c)]))
                .collect();
            for (k, v) in self.apply(&x).iter().enumerate() {
                out[(2 * k, c)] = v.x;
                out[(2 * k + 1, c)] = v.y;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A random symmetric positive-definite 2 × 2 block and a cross block small enough that the
    /// whole chain stays positive definite.
    fn chain(n: usize, breaks: &[usize], rng: &mut Rng) -> (Vec<MotionNoise>, Vec<bool>) {
        let mut out = Vec::new();
        for _ in 0..n {
            let a = Matrix2::from_fn(|_, _| rng.normal());
            out.push(MotionNoise {
                own: a * a.transpose() + Matrix2::identity(),
                next: Some(Matrix2::from_fn(|_, _| 0.3 * rng.normal())),
                ..MotionNoise::default()
            });
        }
        let shares = (0..n).map(|k| k > 0 && !breaks.contains(&k)).collect();
        (out, shares)
    }

    #[test]
    fn the_direction_derivatives_match_finite_differences() {
        // ∂u/∂θ_a and ∂u/∂f of `calib_fit::direction`, which carry the accelerometer's noise and
        // its calibration's error into the gyro's σ, against central differences (step 1e-6;
        // the second-order error is ~1e-12 relative, the tolerance 1e-7 leaves rounding room).
        let th = [0.1, -0.2, 0.25, 1.012, 0.992, 1.005, 0.006, -0.0075, 0.006];
        let f = Vector3::new(3.0, -5.0, 7.5);
        let (_, du_df, du_dth) = direction(&th, &f).unwrap();
        let h = 1e-6;
        for c in 0..9 {
            let (mut p, mut m) = (th, th);
            p[c] += h;
            m[c] -= h;
            let d = (direction(&p, &f).unwrap().0 - direction(&m, &f).unwrap().0) / (2.0 * h);
            assert!(
                (d - du_dth.column(c)).norm() < 1e-7,
                "θ {c}: {d} vs {}",
                du_dth.column(c)
            );
        }
        for c in 0..3 {
            let e = Vector3::ith(c, h);
            let d = (direction(&th, &(f + e)).unwrap().0 - direction(&th, &(f - e)).unwrap().0)
                / (2.0 * h);
            assert!((d - du_df.column(c)).norm() < 1e-7, "f {c}");
        }
    }

    #[test]
    fn the_whitener_turns_the_block_tridiagonal_covariance_into_the_identity() {
        // L⁻¹ Σ L⁻ᵀ = I for Σ assembled densely from the blocks (a cross block only where a
        // motion shares a stretch with the one before), to rounding.
        let mut rng = Rng::new(17);
        let n = 7;
        let (noise, shares) = chain(n, &[3], &mut rng);
        let sel: Vec<Selected> = noise.iter().zip(&shares).map(|(m, s)| (m, *s)).collect();
        let mut sigma = DMatrix::zeros(2 * n, 2 * n);
        for k in 0..n {
            sigma
                .view_mut((2 * k, 2 * k), (2, 2))
                .copy_from(&noise[k].own);
            if k + 1 < n && shares[k + 1] {
                let c = noise[k].next.unwrap();
                sigma.view_mut((2 * k, 2 * k + 2), (2, 2)).copy_from(&c);
                sigma
                    .view_mut((2 * k + 2, 2 * k), (2, 2))
                    .copy_from(&c.transpose());
            }
        }
        assert!(
            sigma.clone().cholesky().is_some(),
            "test chain not positive definite"
        );
        let w = Whitener::new(&sel);
        let half = w.apply_columns(&sigma);
        let white = w.apply_columns(&half.transpose());
        let err = (white - DMatrix::<f64>::identity(2 * n, 2 * n)).abs().max();
        assert!(err < 1e-12, "{err}");
    }
}
