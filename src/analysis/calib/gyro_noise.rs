//! The noise of the gyro fit's residuals (`calib::gyro`), so that its σ cover the error
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
//!
//! The leave-one-motion-out test whitens the held-out residuals with their own covariance
//! (`HeldOutWhitener`): e_k = y_k − J_k θ̂_{−k} carries the data's noise (the block-tridiagonal
//! Σ), the accelerometer frame error in full (A Aᵀ: the fit leaves it out of its weights, as
//! more motions do not average it away, but a held-out residual has it) and the error of the
//! refit without motion k projected through that motion (J_k Cov(θ̂_{−k}) J_kᵀ, less what k's
//! neighbours, which share its stretches, and the frame error put into both). Each motion's
//! block is that exact linearised Var(e_k); the blocks between motions are the data's (the
//! refits' own cross terms are left out: with them the covariance is singular, as any
//! residual in J's column space is refitted exactly, and whitening with its pseudo-inverse
//! would turn the held-out test into the in-sample one).

use nalgebra::{
    DMatrix, DVector, Matrix2, Matrix3, Matrix3x2, Rotation3, SMatrix, SymmetricEigen, Vector2,
    Vector3,
};

use super::fit::{Cov9, FittedCalibration, direction, nominal};
use super::still::{AccelStretch, mean_var};
use crate::sample::Channels;

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
    ch: &Channels,
    stretches: &[AccelStretch],
    accel: Option<&FittedCalibration>,
) -> Vec<StretchNoise> {
    let (th, s) = accel.map_or((nominal(), Cov9::zeros()), |a| (a.theta, sqrt_cov(&a.cov)));
    stretches
        .iter()
        .map(|st| {
            let n = st.len.max(1) as f64;
            let (mean, var) = mean_var(st.start..st.start + st.len, |i| ch.gyro(i));
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
                n: st.len,
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
        columns_as_pairs(m, |x| self.apply(x))
    }
}

/// `apply` (a map of the stacked 2-vectors, one per motion) on each column of `m`, whose rows
/// `2k, 2k + 1` are motion k's.
fn columns_as_pairs(
    m: &DMatrix<f64>,
    apply: impl Fn(&[Vector2<f64>]) -> Vec<Vector2<f64>>,
) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(m.nrows(), m.ncols());
    for c in 0..m.ncols() {
        let x: Vec<Vector2<f64>> = (0..m.nrows() / 2)
            .map(|k| Vector2::new(m[(2 * k, c)], m[(2 * k + 1, c)]))
            .collect();
        for (k, v) in apply(&x).iter().enumerate() {
            out[(2 * k, c)] = v.x;
            out[(2 * k + 1, c)] = v.y;
        }
    }
    out
}

/// The whitening of the stacked held-out residuals (the leave-one-motion-out test, module
/// docs): the fit's block-tridiagonal noise Σ plus the accelerometer calibration's error, which
/// every motion shares (A Aᵀ, A the projected residuals' sensitivity to it times a square root
/// of its covariance; the fit leaves it out of its weights, as it cannot be averaged away, but
/// a held-out residual carries it), with each motion's diagonal block replaced by its held-out
/// residual's whole variance when a model is refitted without it (`refit_block`). Dense
/// (2n × 2n, n ≤ a few dozen motions); L⁻¹ of its Cholesky factor, by forward substitution.
pub(crate) struct HeldOutWhitener {
    chol: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
    /// The block whitener, used if neither the covariance nor Σ + A Aᵀ is positive definite (not
    /// expected: Σ is, and A Aᵀ is positive semi-definite).
    fallback: Whitener,
}

/// The covariance of motion `k`'s held-out residual e_k = y_k − J_k θ̂_{−k}: with θ̂_{−k} the
/// generalised least squares on the others (their noise model `c` without k), e_k = M_k y,
/// M_k = E_k − J_k P, P = (J_Tᵀ c_T⁻¹ J_T)⁻¹ J_Tᵀ c_T⁻¹, and Var(e_k) = M_k `tot` M_kᵀ with
/// `tot` the data's whole noise (the fit's and the accelerometer frame's): its own noise, the
/// refit's parameter error, their correlation through the neighbours' shared stretches and the
/// frame error the refit absorbs.
fn refit_block(
    c: &DMatrix<f64>,
    tot: &DMatrix<f64>,
    j: &DMatrix<f64>,
    k: usize,
) -> Option<Matrix2<f64>> {
    let m = c.nrows();
    let keep: Vec<usize> = (0..m).filter(|&i| i / 2 != k).collect();
    let c_t = c.select_rows(&keep).select_columns(&keep);
    let j_t = j.select_rows(&keep);
    let ch = c_t.cholesky()?;
    let ci_j = ch.solve(&j_t);
    let info = (j_t.transpose() * &ci_j).try_inverse()?;
    let p = info * ci_j.transpose();
    let jk = j.rows(2 * k, 2);
    let jp = jk * p;
    let mut mk = DMatrix::zeros(2, m);
    mk[(0, 2 * k)] = 1.0;
    mk[(1, 2 * k + 1)] = 1.0;
    for (col, &i) in keep.iter().enumerate() {
        mk[(0, i)] -= jp[(0, col)];
        mk[(1, i)] -= jp[(1, col)];
    }
    let v = &mk * tot * mk.transpose();
    let out = Matrix2::new(v[(0, 0)], v[(0, 1)], v[(1, 0)], v[(1, 1)]);
    out.iter().all(|x| x.is_finite()).then_some(out)
}

impl HeldOutWhitener {
    /// `refit`: the projected (unwhitened) Jacobian (2 rows per motion) of the model refitted
    /// without each motion, whose error then enters that motion's held-out residual.
    pub fn new(sel: &[Selected], refit: Option<&DMatrix<f64>>) -> HeldOutWhitener {
        let n = sel.len();
        let mut c = DMatrix::zeros(2 * n, 2 * n);
        let mut a = DMatrix::zeros(2 * n, 9);
        for (k, (m, _)) in sel.iter().enumerate() {
            c.view_mut((2 * k, 2 * k), (2, 2)).copy_from(&m.own);
            a.view_mut((2 * k, 0), (2, 9)).copy_from(&m.accel);
            if let Some(x) = m.next.filter(|_| k + 1 < n && sel[k + 1].1) {
                c.view_mut((2 * k, 2 * k + 2), (2, 2)).copy_from(&x);
                c.view_mut((2 * k + 2, 2 * k), (2, 2))
                    .copy_from(&x.transpose());
            }
        }
        let tot = &c + &a * a.transpose();
        let mut full = tot.clone();
        if let Some(j) = refit.filter(|j| j.ncols() > 0 && n > 1) {
            for k in 0..n {
                if let Some(v) = refit_block(&c, &tot, j, k) {
                    full.view_mut((2 * k, 2 * k), (2, 2)).copy_from(&v);
                }
            }
        }
        let chol_of = |m: DMatrix<f64>| m.iter().all(|v| v.is_finite()).then(|| m.cholesky());
        let chol = chol_of(full).flatten().or_else(|| chol_of(tot).flatten());
        HeldOutWhitener {
            chol,
            fallback: Whitener::new(sel),
        }
    }

    /// L⁻¹ x for the stacked 2-vectors `x`, one per motion.
    pub fn apply(&self, x: &[Vector2<f64>]) -> Vec<Vector2<f64>> {
        let Some(ch) = &self.chol else {
            return self.fallback.apply(x);
        };
        let v = DVector::from_iterator(2 * x.len(), x.iter().flat_map(|v| [v.x, v.y]));
        match ch.l_dirty().solve_lower_triangular(&v) {
            Some(w) if w.len() == v.len() => (0..x.len())
                .map(|k| Vector2::new(w[2 * k], w[2 * k + 1]))
                .collect(),
            _ => self.fallback.apply(x),
        }
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
        // ∂u/∂θ_a and ∂u/∂f of `calib::fit::direction`, which carry the accelerometer's noise and
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
    fn a_held_out_block_is_the_classical_leave_one_out_variance_for_white_noise() {
        // With independent white noise (Σ = I) and no frame error, leaving out block k of a
        // linear least-squares fit gives e_k = (I − H_kk)⁻¹ r_k, so Var(e_k) = (I − H_kk)⁻¹,
        // H = J (JᵀJ)⁻¹ Jᵀ (the hat matrix): `refit_block` (which builds M_k from the refit
        // without k instead) must agree to rounding (entries O(1), well conditioned: 1e-10
        // leaves room). 12 blocks of 2 rows, 5 parameters.
        let mut rng = Rng::new(5);
        let (n, p) = (12, 5);
        let j = DMatrix::from_fn(2 * n, p, |_, _| rng.normal());
        let eye = DMatrix::<f64>::identity(2 * n, 2 * n);
        let h = &j * (j.transpose() * &j).try_inverse().unwrap() * j.transpose();
        for k in 0..n {
            let hk = Matrix2::new(
                h[(2 * k, 2 * k)],
                h[(2 * k, 2 * k + 1)],
                h[(2 * k + 1, 2 * k)],
                h[(2 * k + 1, 2 * k + 1)],
            );
            let want = (Matrix2::identity() - hk).try_inverse().unwrap();
            let got = refit_block(&eye, &eye, &j, k).unwrap();
            assert!((got - want).abs().max() < 1e-10, "{k}: {got} vs {want}");
        }
    }

    #[test]
    fn the_held_out_whitener_whitens_the_noise_and_the_frame_error() {
        // Without a refit its covariance is Σ (block tridiagonal) + A Aᵀ: L⁻¹ (Σ + A Aᵀ) L⁻ᵀ = I
        // to rounding (entries O(1); 1e-10 leaves room). The block whitener alone (the
        // fallback) would leave A Aᵀ in and fail.
        let mut rng = Rng::new(23);
        let n = 6;
        let (mut noise, shares) = chain(n, &[], &mut rng);
        for m in &mut noise {
            m.accel = SMatrix::<f64, 2, 9>::from_fn(|_, _| 0.5 * rng.normal());
        }
        let sel: Vec<Selected> = noise.iter().zip(&shares).map(|(m, s)| (m, *s)).collect();
        let mut sigma = DMatrix::zeros(2 * n, 2 * n);
        let mut a = DMatrix::zeros(2 * n, 9);
        for (k, m) in noise.iter().enumerate() {
            sigma.view_mut((2 * k, 2 * k), (2, 2)).copy_from(&m.own);
            a.view_mut((2 * k, 0), (2, 9)).copy_from(&m.accel);
            if k + 1 < n {
                let c = m.next.unwrap();
                sigma.view_mut((2 * k, 2 * k + 2), (2, 2)).copy_from(&c);
                sigma
                    .view_mut((2 * k + 2, 2 * k), (2, 2))
                    .copy_from(&c.transpose());
            }
        }
        let full = sigma + &a * a.transpose();
        let w = HeldOutWhitener::new(&sel, None);
        let cols = |m: &DMatrix<f64>| columns_as_pairs(m, |x| w.apply(x));
        let white = cols(&cols(&full).transpose());
        let err = (white - DMatrix::<f64>::identity(2 * n, 2 * n)).abs().max();
        assert!(err < 1e-10, "{err}");
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
