//! Accelerometer calibration from still stretches at varied attitudes: bias, scale factor and
//! misalignment, each kept only where held-out stretches say so.
//!
//! **Model** (the bias stage's, `stage::bias::settings`): raw = A·true + b, A = L lower
//! triangular. At rest |true| = g, so each still stretch k (mean specific force f̄_k) gives
//!
//! ```text
//!   r_k(θ) = | L⁻¹ (f̄_k − b) | − g,     θ = (b_x, b_y, b_z, L_xx, L_yy, L_zz, L_yx, L_zx, L_zy)
//! ```
//!
//! Gravity fixes only the ellipsoid L Lᵀ (a rotation of the true frame leaves every |true|
//! unchanged), so the body frame is the accelerometer's own: x along its x axis, y in its x–y
//! plane (Tedaldi, Pretto & Menegatti, ICRA 2014, who write the same triangular form). For a
//! general A the identifiable part is L = chol(A Aᵀ). A common scale of all three axes is the
//! same thing as a different g: the fitted scales are relative to the g given (9.80665 by
//! default; local gravity differs by up to ±0.3 %).
//!
//! **Fit**: Levenberg–Marquardt on the K residuals, by hand: at most 9 parameters and K in the
//! tens to hundreds, the Jacobian analytic (with u = t/|t|, t = L⁻¹(f̄ − b), w = L⁻ᵀu:
//! ∂r/∂b_i = −w_i, ∂r/∂L_ij = −w_i t_j), each step a 9×9 Cholesky solve — smaller than the glue
//! a generic solver crate would need, and none is among the project's dependencies.
//!
//! **Honest significance** (issue 17). The parameters come in three groups, bias, scale and
//! misalignment.
//! 1. *Identifiable*: the elimination starts from the largest model (all three groups, else
//!    two, else one) with at least p + 2 attitude groups for its p parameters and a condition
//!    number ≤ `max_condition` of its Jacobian at the nominal calibration, columns scaled to unit
//!    norm ([`condition`]). Above that, some combination of parameters is determined that many
//!    times worse than the best one (bias_z and scale_z when every stretch has z up); such a
//!    model is reported "not identifiable", never fitted.
//! 2. *Held out*, backward elimination (as `diagnose`'s slow terms): each round tests every
//!    group of the model against the model without it, by leave-one-attitude-group-out — each
//!    group's mean residual predicted by the model fitted on the other groups — with the paired
//!    z-test of `diagnose` (`diagnose::blocks::held_out_test`: z = G / (2σ̂√Σδ²), G the drop in
//!    the sum of squared held-out errors that the group brings, δ the per-group differences,
//!    σ̂ the RMS held-out error with it) at α / (groups in the model). The weakest group that
//!    fails is removed and the round repeats, until every group left passes. Backward, not
//!    forward: with one group missing, the others' unmodelled error would be the test's noise.
//! 3. *Above quantisation*: a group passes only if it changes some stretch's corrected specific
//!    force by at least one LSB of the accelerometers.
//! 4. *Plausible*: the bias stage accepts the result (scale in (0.5, 2), N well conditioned),
//!    else nothing is written.
//!
//! Held-out errors before/after are reported for the final model against none.

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, Vector3};
use serde::Serialize;

use super::still::{AccelStretch, AttitudeSpread, attitude_groups, attitude_spread};
use crate::analysis::AnalysisError;
use crate::analysis::diagnose::blocks::{GainNoise, HeldOutTest, held_out_test};
use crate::stage::bias::settings::CalibrationSettings;

/// Parameter groups, in θ order: 0..3 bias, 3..6 scale, 6..9 misalignment.
pub const GROUPS: [&str; 3] = ["bias", "scale", "misalignment"];
/// Number of parameters.
const NP: usize = 9;
/// A covariance of the nine parameters (of this module's θ, or of the gyro's K row-major).
pub(crate) type Cov9 = SMatrix<f64, NP, NP>;

/// Settings of the calibration fit.
#[derive(Clone, Debug)]
pub struct CalibSettings {
    /// Significance level of each round (Bonferroni over its candidates). Default 0.001, as
    /// `diagnose`.
    pub alpha: f64,
    /// Largest condition number of the scaled Jacobian. Default 100.
    pub max_condition: f64,
    /// Gravity magnitude, m/s².
    pub gravity_m_s2: f64,
    /// Attitude groups: directions within this angle, degrees.
    pub group_deg: f64,
}

impl Default for CalibSettings {
    fn default() -> Self {
        CalibSettings {
            alpha: 0.001,
            max_condition: 100.0,
            gravity_m_s2: 9.80665,
            group_deg: 10.0,
        }
    }
}

/// θ = nominal (no calibration).
pub(crate) fn nominal() -> [f64; NP] {
    [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
}

/// Which θ indices belong to group `g`.
fn group_mask(g: usize) -> [bool; NP] {
    let mut m = [false; NP];
    for v in m.iter_mut().skip(3 * g).take(3) {
        *v = true;
    }
    m
}

/// (i, j) of each L parameter in θ order 3..9.
const LIJ: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (1, 0), (2, 0), (2, 1)];

fn l_of(th: &[f64; NP]) -> Matrix3<f64> {
    Matrix3::new(th[3], 0.0, 0.0, th[6], th[4], 0.0, th[7], th[8], th[5])
}

/// t = L⁻¹ (f − b) by forward substitution (None when a diagonal is not positive).
fn corrected(th: &[f64; NP], f: &Vector3<f64>) -> Option<Vector3<f64>> {
    if th[3] <= 0.0 || th[4] <= 0.0 || th[5] <= 0.0 {
        return None;
    }
    let d = f - Vector3::new(th[0], th[1], th[2]);
    let t0 = d[0] / th[3];
    let t1 = (d[1] - th[6] * t0) / th[4];
    let t2 = (d[2] - th[7] * t0 - th[8] * t1) / th[5];
    Some(Vector3::new(t0, t1, t2))
}

/// The direction u = t/|t| of f through θ (t = L⁻¹(f − b)), ∂u/∂f = P L⁻¹ and ∂u/∂θ, with
/// P = (I − u uᵀ)/|t|: ∂t/∂b_i = −L⁻¹e_i, ∂t/∂L_ij = −L⁻¹e_i t_j. None when θ is not
/// admissible.
pub(crate) fn direction(
    th: &[f64; NP],
    f: &Vector3<f64>,
) -> Option<(Vector3<f64>, Matrix3<f64>, SMatrix<f64, 3, NP>)> {
    let t = corrected(th, f)?;
    let n = t.norm();
    let u = t / n;
    let du_df = (Matrix3::identity() - u * u.transpose()) / n * l_of(th).try_inverse()?;
    let du_dth = SMatrix::<f64, 3, NP>::from_fn(|r, c| {
        if c < 3 {
            -du_df[(r, c)]
        } else {
            let (i, j) = LIJ[c - 3];
            -du_df[(r, i)] * t[j]
        }
    });
    Some((u, du_df, du_dth))
}

/// Residuals |t_k| − g (infinite when θ is not admissible).
fn residuals(th: &[f64; NP], f: &[Vector3<f64>], g: f64) -> Vec<f64> {
    f.iter()
        .map(|x| corrected(th, x).map_or(f64::INFINITY, |t| t.norm() - g))
        .collect()
}

/// The analytic Jacobian of the residuals w.r.t. the `idx` parameters (K × p).
fn jacobian(th: &[f64; NP], f: &[Vector3<f64>], idx: &[usize]) -> DMatrix<f64> {
    let l = l_of(th);
    let linv = l.try_inverse().unwrap_or_else(Matrix3::identity);
    DMatrix::from_fn(f.len(), idx.len(), |k, c| {
        let t = corrected(th, &f[k]).unwrap_or_else(|| f[k]);
        let u = t / t.norm().max(f64::MIN_POSITIVE);
        let w = linv.transpose() * u;
        let p = idx[c];
        if p < 3 {
            -w[p]
        } else {
            let (i, j) = LIJ[p - 3];
            -w[i] * t[j]
        }
    })
}

/// Condition number of the column-normalised Jacobian at the nominal calibration, with a
/// constant column beside it unless the scale group is in the model: a constant shift of every
/// residual is what an error in g does, so a model without scales must not explain one (with
/// the scales in, their sum is that column exactly, and the common scale is relative to the g
/// given, as the module docs say).
pub fn condition(f: &[Vector3<f64>], active: &[bool; NP]) -> f64 {
    let idx: Vec<usize> = (0..NP).filter(|&i| active[i]).collect();
    let constant = !active[3];
    let cols = idx.len() + usize::from(constant);
    if idx.is_empty() || f.len() < cols {
        return f64::INFINITY;
    }
    let j = jacobian(&nominal(), f, &idx);
    let m = DMatrix::from_fn(
        f.len(),
        cols,
        |k, c| if c < idx.len() { j[(k, c)] } else { 1.0 },
    );
    scaled_condition(m)
}

/// Condition number of `m` with its columns scaled to unit norm (∞ when singular).
pub(crate) fn scaled_condition(mut m: DMatrix<f64>) -> f64 {
    for mut col in m.column_iter_mut() {
        let n = col.norm();
        if n > 0.0 {
            col /= n;
        }
    }
    let sv = m.singular_values();
    let (mx, mn) = (sv.max(), sv.min());
    if mn > 0.0 { mx / mn } else { f64::INFINITY }
}

/// A least-squares fit of the `active` parameters.
#[derive(Clone, Debug)]
pub(crate) struct Fit {
    pub theta: [f64; NP],
    /// Covariance of θ: (JᵀJ)⁻¹ times the residual variance (0 in the rows and columns of
    /// inactive entries; NaN when there are no spare degrees of freedom).
    pub cov: Cov9,
    /// The residual variance over `observations − p` degrees of freedom: the factor `cov`
    /// carries (≈ 1 for whitened residuals whose noise is modelled right; NaN with none spare).
    pub residual_variance: f64,
}

impl Fit {
    /// 1-σ of each θ.
    pub fn sd(&self) -> [f64; NP] {
        std::array::from_fn(|i| self.cov[(i, i)].sqrt())
    }
}

fn sse(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Levenberg–Marquardt (Marquardt's diagonal scaling) over the `active` entries of θ from
/// `theta`: `resid(θ)` the residuals (non-finite where θ is not admissible), `jac(θ, idx)`
/// their Jacobian w.r.t. the `idx` entries; `observations` the independent components the
/// residuals carry (their number, unless they are constrained: a difference of two unit vectors
/// has 2 of its 3). Returns θ and its covariance, (JᵀJ)⁻¹ times the residual variance over
/// `observations − p` degrees of freedom (0 for inactive entries; NaN with none spare).
pub(crate) fn levenberg_marquardt(
    mut th: [f64; NP],
    active: &[bool; NP],
    observations: usize,
    resid: impl Fn(&[f64; NP]) -> Vec<f64>,
    jac: impl Fn(&[f64; NP], &[usize]) -> DMatrix<f64>,
) -> Result<Fit, AnalysisError> {
    let idx: Vec<usize> = (0..NP).filter(|&i| active[i]).collect();
    let mut r = resid(&th);
    let variance = |r: &[f64]| {
        let dof = observations as f64 - idx.len() as f64;
        if dof > 0.0 { sse(r) / dof } else { f64::NAN }
    };
    if idx.is_empty() {
        return Ok(Fit {
            theta: th,
            cov: Cov9::zeros(),
            residual_variance: variance(&r),
        });
    }
    if r.len() < idx.len() {
        return Err(AnalysisError::bad("fewer residuals than parameters"));
    }
    let mut lambda = 1e-3;
    for _ in 0..200 {
        let j = jac(&th, &idx);
        let jtj = j.transpose() * &j;
        let jtr = j.transpose() * DVector::from_column_slice(&r);
        let s0 = sse(&r);
        let mut improved = false;
        while lambda < 1e12 {
            let mut a = jtj.clone();
            for d in 0..idx.len() {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(ch) = a.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = ch.solve(&(-&jtr));
            let mut trial = th;
            for (d, &p) in idx.iter().enumerate() {
                trial[p] += step[d];
            }
            let rt = resid(&trial);
            let s1 = sse(&rt);
            if s1.is_finite() && s1 < s0 {
                th = trial;
                r = rt;
                lambda = (lambda / 10.0).max(1e-12);
                improved = s0 - s1 > 1e-15 * s0.max(1e-300);
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let j = jac(&th, &idx);
    let s2 = variance(&r);
    let cov = (j.transpose() * &j)
        .try_inverse()
        .ok_or_else(|| AnalysisError::singular("calibration normal equations"))?;
    let mut full = Cov9::zeros();
    for (d, &p) in idx.iter().enumerate() {
        for (e, &q) in idx.iter().enumerate() {
            full[(p, q)] = s2 * cov[(d, e)];
        }
    }
    Ok(Fit {
        theta: th,
        cov: full,
        residual_variance: s2,
    })
}

/// The accelerometer fit of the `active` parameters from the nominal calibration.
fn fit(f: &[Vector3<f64>], active: &[bool; NP], g: f64) -> Result<Fit, AnalysisError> {
    levenberg_marquardt(
        nominal(),
        active,
        f.len(),
        |th| residuals(th, f, g),
        |th, idx| jacobian(th, f, idx),
    )
}

/// Backward elimination over parameter groups (module docs, test 2): `model` the groups in
/// the model (left holding those kept); `test(model, k, round, level)` tests group `k` of it.
/// Each round the weakest group that fails is removed, until every group left passes.
pub(crate) fn eliminate(
    model: &mut Vec<usize>,
    alpha: f64,
    mut test: impl FnMut(&[usize], usize, usize, f64) -> Result<Candidate, AnalysisError>,
) -> Result<Vec<Candidate>, AnalysisError> {
    let mut out: Vec<Candidate> = Vec::new();
    let mut round = 0;
    while !model.is_empty() {
        round += 1;
        let level = alpha / model.len() as f64;
        let first = out.len();
        for &k in model.iter() {
            out.push(test(model, k, round, level)?);
        }
        let weakest = (first..out.len())
            .filter(|&i| !out[i].passed)
            .max_by(|&a, &b| out[a].test.p_value.total_cmp(&out[b].test.p_value));
        let Some(w) = weakest else { break };
        out[w].removed = true;
        model.remove(w - first);
    }
    Ok(out)
}

/// Mean held-out residual of each attitude group: the model fitted on the other groups.
fn held_out_by_group(
    f: &[Vector3<f64>],
    groups: &[usize],
    n_groups: usize,
    active: &[bool; NP],
    g: f64,
) -> Result<Vec<f64>, AnalysisError> {
    (0..n_groups)
        .map(|h| {
            let train: Vec<Vector3<f64>> = f
                .iter()
                .zip(groups)
                .filter(|(_, gr)| **gr != h)
                .map(|(x, _)| *x)
                .collect();
            let th = fit(&train, active, g)?.theta;
            let test: Vec<Vector3<f64>> = f
                .iter()
                .zip(groups)
                .filter(|(_, gr)| **gr == h)
                .map(|(x, _)| *x)
                .collect();
            let r = residuals(&th, &test, g);
            Ok(r.iter().sum::<f64>() / r.len() as f64)
        })
        .collect()
}

/// One group's test in a round of the backward elimination: the model with it against the
/// model without it.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// Round (1, 2, 3).
    pub round: usize,
    /// Parameter group tested.
    pub group: String,
    /// The held-out test (without the group → with it).
    pub test: HeldOutTest,
    /// Largest change of a stretch's corrected specific force the group makes, m/s².
    pub effect_m_s2: f64,
    /// The group passed this round (held-out test and quantisation).
    pub passed: bool,
    /// Removed in this round (the weakest that did not pass).
    pub removed: bool,
    /// Why it did not pass, if so.
    pub reason: String,
}

/// A model that could not be fitted: not identifiable from these stretches.
#[derive(Clone, Debug, Serialize)]
pub struct NotIdentifiable {
    /// Its groups.
    pub model: String,
    /// Parameters.
    pub parameters: usize,
    /// Condition number (see [`condition`]).
    pub condition: f64,
    /// Why.
    pub reason: String,
}

/// The fitted calibration in the bias stage's form.
#[derive(Clone, Debug, Serialize)]
pub struct FittedCalibration {
    /// Groups in it.
    pub groups: Vec<String>,
    /// The `[bias.settings.accel]` values.
    pub settings: CalibrationSettings,
    /// 1-σ of bias (m/s²), of scale (dimensionless) and of the misalignment L entries
    /// (yx, zx, zy; ≈ rad), from the fit's residuals.
    pub bias_sd_m_s2: [f64; 3],
    pub scale_sd: [f64; 3],
    pub misalignment_sd_rad: [f64; 3],
    /// θ (bias, scale, L below the diagonal) and its covariance, for what the gyro fit takes
    /// from this calibration (`calib::gyro_noise`).
    #[serde(skip)]
    pub(crate) theta: [f64; NP],
    #[serde(skip)]
    pub(crate) cov: Cov9,
    /// Misalignment angles N_yx, N_zx, N_zy, mrad (small-angle: the sensitivity of each axis to
    /// the earlier ones' input).
    pub misalignment_mrad: [f64; 3],
}

/// The result of [`calibrate_accel`].
#[derive(Clone, Debug, Serialize)]
pub struct AccelCalibration {
    /// Gravity used, m/s².
    pub gravity_m_s2: f64,
    /// The still stretches (with the attitude group of each).
    pub stretches: Vec<AccelStretch>,
    pub groups: Vec<usize>,
    pub spread: AttitudeSpread,
    /// LSB of the accelerometers (the largest of the three), if quantised.
    pub lsb_m_s2: Option<f64>,
    /// Models too large for these stretches, largest first (the first identifiable one is
    /// where the elimination starts).
    pub not_identifiable: Vec<NotIdentifiable>,
    /// Every test of the backward elimination, round by round.
    pub candidates: Vec<Candidate>,
    /// The kept calibration, if any group was kept.
    pub fitted: Option<FittedCalibration>,
    /// RMS of |f| − g over the stretches, without and with the kept calibration (in-sample).
    pub fit_rms_before_m_s2: f64,
    pub fit_rms_after_m_s2: f64,
    /// RMS of the groups' held-out mean residuals, without and with it.
    pub held_out_rms_before_m_s2: f64,
    pub held_out_rms_after_m_s2: f64,
    /// Residual |f| − g of each stretch before and after (in-sample), m/s².
    pub residual_before_m_s2: Vec<f64>,
    pub residual_after_m_s2: Vec<f64>,
    /// One line: what was found.
    pub verdict: String,
}

/// Root mean square (NaN when empty).
pub(crate) fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    (sse(x) / x.len() as f64).sqrt()
}

/// The bias stage's form of θ: scale = diag L, N = diag(scale)⁻¹ L.
fn to_settings(th: &[f64; NP]) -> CalibrationSettings {
    let l = l_of(th);
    let scale = [th[3], th[4], th[5]];
    CalibrationSettings {
        bias: [th[0], th[1], th[2]],
        scale,
        misalignment: std::array::from_fn(|i| std::array::from_fn(|j| l[(i, j)] / scale[i])),
    }
}

/// Whether the model `active` is identifiable (module docs, test 1): `Err` says why not.
fn identifiable(
    f: &[Vector3<f64>],
    n_groups: usize,
    active: &[bool; NP],
    s: &CalibSettings,
) -> Result<(), NotIdentifiable> {
    let p = active.iter().filter(|a| **a).count();
    let cond = condition(f, active);
    let fail = |reason: String| NotIdentifiable {
        model: names(active).join(" + "),
        parameters: p,
        condition: cond,
        reason,
    };
    if n_groups < p + 2 {
        return Err(fail(format!(
            "{n_groups} attitude group(s), {} needed for {p} parameters",
            p + 2
        )));
    }
    if cond.is_nan() || cond > s.max_condition {
        return Err(fail(format!(
            "the stretch directions leave the parameters ill-conditioned (condition number {cond:.3e} > {})",
            s.max_condition
        )));
    }
    Ok(())
}

/// Group `k` tested in `current` (module docs, tests 2–3): `e1` the held-out errors with it.
#[allow(clippy::too_many_arguments)]
fn test_group(
    f: &[Vector3<f64>],
    groups: &[usize],
    n_groups: usize,
    current: &[bool; NP],
    e1: &[f64],
    k: usize,
    round: usize,
    level: f64,
    lsb: Option<f64>,
    g: f64,
) -> Result<Candidate, AnalysisError> {
    let without: [bool; NP] = std::array::from_fn(|i| current[i] && !group_mask(k)[i]);
    let e0 = held_out_by_group(f, groups, n_groups, &without, g)?;
    let desc = format!("{} in [{}]", GROUPS[k], names(current).join(", "));
    let test = held_out_test(
        "calibration",
        desc,
        &e0,
        e1,
        |_| true,
        level,
        GainNoise::WHITE,
    );
    let th_with = fit(f, current, g)?.theta;
    let th_without = fit(f, &without, g)?.theta;
    let effect = f
        .iter()
        .filter_map(|x| Some((corrected(&th_with, x)? - corrected(&th_without, x)?).norm()))
        .fold(0.0, f64::max);
    let mut c = Candidate {
        round,
        group: GROUPS[k].into(),
        effect_m_s2: effect,
        passed: test.kept,
        removed: false,
        reason: test.reason.clone(),
        test,
    };
    if let Some(q) = lsb.filter(|q| c.passed && effect < *q) {
        c.passed = false;
        c.reason = format!(
            "below quantisation: changes the corrected specific force by at most {effect:.3e} m/s² < 1 LSB ({q:.3e})"
        );
    }
    Ok(c)
}

/// The θ mask of the groups `m`.
fn mask_of(m: &[usize]) -> [bool; NP] {
    std::array::from_fn(|i| m.contains(&(i / 3)))
}

fn names(active: &[bool; NP]) -> Vec<&'static str> {
    (0..3)
        .filter(|&g| active[3 * g])
        .map(|g| GROUPS[g])
        .collect()
}

/// Calibrate the accelerometer triad from its still `stretches` (see the module docs); `lsb`
/// the accelerometers' quantisation step, if known.
pub fn calibrate_accel(
    stretches: Vec<AccelStretch>,
    lsb: Option<f64>,
    s: &CalibSettings,
) -> Result<AccelCalibration, AnalysisError> {
    let g = s.gravity_m_s2;
    let f: Vec<Vector3<f64>> = stretches.iter().map(|x| x.mean()).collect();
    let groups = attitude_groups(&stretches, s.group_deg);
    let spread = attitude_spread(&stretches, &groups);
    let n_groups = spread.groups;
    // The largest identifiable model: all three groups, else two, else one.
    let mut not_identifiable = Vec::new();
    let mut current = [false; NP];
    let mut models: Vec<[bool; NP]> = (1..8usize)
        .map(|m| std::array::from_fn(|i| m & (1 << (i / 3)) != 0))
        .collect();
    models.sort_by_key(|m| std::cmp::Reverse(m.iter().filter(|a| **a).count()));
    for m in models {
        match identifiable(&f, n_groups, &m, s) {
            Ok(()) => {
                current = m;
                break;
            }
            Err(why) => not_identifiable.push(why),
        }
    }
    // Backward elimination from there.
    let mut model: Vec<usize> = (0..3).filter(|&k| current[3 * k]).collect();
    let candidates = eliminate(&mut model, s.alpha, |m, k, round, level| {
        let active = mask_of(m);
        let e1 = held_out_by_group(&f, &groups, n_groups, &active, g)?;
        test_group(&f, &groups, n_groups, &active, &e1, k, round, level, lsb, g)
    })?;
    let mut current = mask_of(&model);
    let e_after = held_out_by_group(&f, &groups, n_groups, &current, g)?;
    let e_none = held_out_by_group(&f, &groups, n_groups, &[false; NP], g)?;
    let mut full = fit(&f, &current, g)?;
    // Test 4: a calibration the bias stage would refuse is not written.
    let mut implausible = Vec::new();
    to_settings(&full.theta).validate_into("bias.settings.accel", &mut implausible);
    if !implausible.is_empty() {
        current = [false; NP];
        full = fit(&f, &current, g)?;
    }
    let residual_before = residuals(&nominal(), &f, g);
    let residual_after = residuals(&full.theta, &f, g);
    let kept = names(&current);
    let fitted = (!kept.is_empty()).then(|| {
        let settings = to_settings(&full.theta);
        let n = settings.misalignment;
        let sd = full.sd();
        FittedCalibration {
            groups: kept.iter().map(|s| s.to_string()).collect(),
            settings,
            bias_sd_m_s2: [sd[0], sd[1], sd[2]],
            scale_sd: [sd[3], sd[4], sd[5]],
            misalignment_sd_rad: [sd[6], sd[7], sd[8]],
            theta: full.theta,
            cov: full.cov,
            misalignment_mrad: [n[1][0] * 1e3, n[2][0] * 1e3, n[2][1] * 1e3],
        }
    });
    let verdict = if !implausible.is_empty() {
        format!("implausible, not written: {}", implausible.join("; "))
    } else if !kept.is_empty() {
        format!("calibration kept: {}", kept.join(" + "))
    } else if stretches.is_empty() {
        "not identifiable: no still stretch found".into()
    } else if candidates.is_empty() {
        let why = not_identifiable.last().map_or("", |n| n.reason.as_str());
        format!("not identifiable: not even one group ({why})")
    } else {
        "nothing kept: no identifiable group lowers the held-out error by more than its noise"
            .into()
    };
    Ok(AccelCalibration {
        gravity_m_s2: g,
        groups,
        spread,
        lsb_m_s2: lsb,
        fit_rms_before_m_s2: rms(&residual_before),
        fit_rms_after_m_s2: rms(&residual_after),
        held_out_rms_before_m_s2: rms(&e_none),
        held_out_rms_after_m_s2: rms(&e_after),
        residual_before_m_s2: residual_before,
        residual_after_m_s2: residual_after,
        stretches,
        not_identifiable,
        candidates,
        fitted,
        verdict,
    })
}
