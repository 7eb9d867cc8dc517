//! Gyroscope scale factor and misalignment from the rotations between still stretches (the
//! gyroscope half of Tedaldi, Pretto & Menegatti, ICRA 2014): integrate the corrected gyro over
//! the motion between two consecutive still stretches and compare where that rotation carries
//! the first stretch's gravity direction with where the second one measured it.
//!
//! ```text
//!   ω_i = K (ω_raw,i − b),        K = A⁻¹, A = diag(scale)·N        (the bias stage's model)
//!   ΔR  = Π_i exp([ω_i Δt_i]×)    over the samples from the end of stretch k to the start of k+1
//!   r_k = u_{k+1} − ΔRᵀ u_k       (3 components; ≈ the direction error, rad)
//! ```
//!
//! u_k is stretch k's mean specific force through the accelerometer calibration (if one was
//! kept), normalised, so the gyro's misalignment is relative to the accelerometer's frame. b is
//! the gyro's mean over the two flanking still stretches (at rest it reads its bias; the daemon's
//! bias stage estimates it online, so no gyro bias is written). A rotation about gravity leaves u
//! unchanged: each interval sees only its rotation's horizontal part, and intervals whose
//! rotations differ make K identifiable.
//!
//! Groups: scale (K's diagonal) and misalignment (the six entries off it), with the tests of
//! `calib::fit`: identifiable (2(n − 1) ≥ p + 2 for n intervals, so a fit without one interval is
//! over-determined, and the column-normalised Jacobian's condition number ≤ `max_condition`),
//! then backward elimination by leave-one-interval-out with `diagnose`'s paired z-test on each
//! left-out interval's residual in the fit's form (its two in-plane components, whitened with
//! their modelled covariance: the fit's noise model, the accelerometer calibration's error and
//! the error of the refit without the interval, `calib::gyro_noise`), and the bias stage's
//! validation of the result.
//! No LSB floor here: an interval integrates hundreds of samples, which dithers the gyro's
//! quantisation into noise that the held-out test already sees.
//!
//! The fit is generalised least squares over the residuals' modelled noise, and K's σ include
//! the accelerometer calibration's error (`calib::gyro_noise`): consecutive motions share a still
//! stretch, and every direction goes through the accelerometer calibration.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector2, Vector3};
use serde::Serialize;

use super::fit::{
    Candidate, Fit, FittedCalibration, NotIdentifiable, eliminate, levenberg_marquardt, rms,
    scaled_condition,
};
use super::gyro_noise::{
    HeldOutWhitener, MotionNoise, MotionRates, Selected, Whitener, motion_noise, stretch_noise,
};
use super::still::AccelStretch;
use crate::analysis::AnalysisError;
use crate::analysis::diagnose::blocks::{GainNoise, held_out_test};
use crate::sample::Channels;
use crate::stage::bias::settings::CalibrationSettings;

/// Parameters: K row-major.
const NP: usize = 9;
/// Groups: 0 scale, 1 misalignment.
const GROUPS: [&str; 2] = ["scale", "misalignment"];

fn in_group(i: usize, g: usize) -> bool {
    i.is_multiple_of(4) == (g == 0)
}

fn mask_of(m: &[usize]) -> [bool; NP] {
    std::array::from_fn(|i| m.iter().any(|&g| in_group(i, g)))
}

fn names(m: &[usize]) -> String {
    m.iter().map(|&g| GROUPS[g]).collect::<Vec<_>>().join(" + ")
}

fn nominal() -> [f64; NP] {
    [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
}

fn k_of(th: &[f64; NP]) -> Matrix3<f64> {
    Matrix3::from_row_slice(th)
}

/// One motion between two consecutive still stretches.
#[derive(Clone, Debug, Serialize)]
pub struct GyroInterval {
    /// Its samples: [from, to).
    pub from: usize,
    pub to: usize,
    /// Duration, s.
    pub duration_s: f64,
    /// Gyro bias taken for it (mean of the flanking still stretches), rad/s.
    pub bias_rad_s: [f64; 3],
    /// Angle between the two stretches' gravity directions, degrees.
    pub tilt_change_deg: f64,
    /// The two gravity directions (unit).
    pub u0: [f64; 3],
    pub u1: [f64; 3],
    /// The two still stretches it joins (indices into the stretches given): consecutive
    /// motions share one.
    pub stretches: [usize; 2],
    /// The modelled 1-σ of each of its residual's two components, rad (`calib::gyro_noise`).
    pub noise_sd_rad: f64,
    /// Bias-free raw rate and time step of each sample (not serialised).
    #[serde(skip)]
    pub rates: Vec<(Vector3<f64>, f64)>,
    /// Its residual's noise (`calib::gyro_noise`).
    #[serde(skip)]
    pub(crate) noise: MotionNoise,
}

/// Parts of the gyro fit's noise model (`calib::gyro_noise`), to switch off one by one and see
/// what each does to the σ (`tests/calibrate_sigma.rs`); `calibrate` uses them all.
#[derive(Clone, Copy, Debug)]
pub struct NoiseParts {
    /// Weight the motions by their modelled noise (else all alike, as independent).
    pub weights: bool,
    /// Correlate consecutive motions through their shared still stretch.
    pub shared_stretches: bool,
    /// Add the accelerometer calibration's error to K's covariance.
    pub accel_frame: bool,
}

impl GyroInterval {
    /// Drop the parts of its noise model that `keep` does not keep.
    pub fn reduce_noise_model(&mut self, keep: NoiseParts) {
        if !keep.shared_stretches || !keep.weights {
            self.noise.next = None;
        }
        if !keep.weights {
            self.noise.own = nalgebra::Matrix2::identity();
        }
        if !keep.accel_frame {
            self.noise.accel = Default::default();
        }
    }
}

/// The motions between consecutive `stretches` of the samples of `ch` that last at most
/// `max_interval_s`, have no gap (a step over 2.5 nominal intervals) and change the gravity
/// direction by at least `min_tilt_deg` (the attitude-group angle: between two stretches of one
/// attitude there is no rotation to check, only noise, whose random columns would pass any
/// condition-number test); `accel` the kept accelerometer calibration, if any (the directions
/// go through it, and its covariance into the gyro's σ).
pub fn gyro_intervals(
    ch: &Channels,
    stretches: &[AccelStretch],
    accel: Option<&FittedCalibration>,
    rate_hz: f64,
    max_interval_s: f64,
    min_tilt_deg: f64,
) -> Vec<GyroInterval> {
    let st = stretch_noise(ch, stretches, accel);
    let mut out: Vec<GyroInterval> = stretches
        .windows(2)
        .enumerate()
        .filter_map(|(k, w)| {
            let (a, b) = (&w[0], &w[1]);
            let (from, to) = (a.start + a.len, b.start);
            let dur = (to - from) as f64 / rate_hz;
            if to <= from || dur > max_interval_s {
                return None;
            }
            let (na, nb) = (st[k].n as f64, st[k + 1].n as f64);
            let bias = (st[k].gyro_mean * na + st[k + 1].gyro_mean * nb) / (na + nb);
            let mut rates = Vec::with_capacity(to - from);
            for i in from..to {
                let dt = (ch.t_ns[i].saturating_sub(ch.t_ns[i - 1])) as f64 * 1e-9;
                let w = ch.gyro(i) - bias;
                if !(dt > 0.0 && dt < 2.5 / rate_hz && w.iter().all(|v| v.is_finite())) {
                    return None;
                }
                rates.push((w, dt));
            }
            let (u0, u1) = (st[k].u, st[k + 1].u);
            let tilt_change_deg = u0.dot(&u1).clamp(-1.0, 1.0).acos().to_degrees();
            if tilt_change_deg < min_tilt_deg {
                return None;
            }
            Some(GyroInterval {
                from,
                to,
                duration_s: dur,
                bias_rad_s: bias.into(),
                tilt_change_deg,
                u0: u0.into(),
                u1: u1.into(),
                stretches: [k, k + 1],
                noise_sd_rad: f64::NAN,
                rates,
                noise: MotionNoise::default(),
            })
        })
        .collect();
    let motions: Vec<MotionRates> = out
        .iter()
        .map(|iv| MotionRates {
            stretches: iv.stretches,
            rates: &iv.rates,
        })
        .collect();
    let noise = motion_noise(&motions, &st);
    for (iv, n) in out.iter_mut().zip(noise) {
        iv.noise_sd_rad = (n.own.trace() / 2.0).sqrt();
        iv.noise = n;
    }
    out
}

/// The motions' noise for the whitening, each with whether it shares a stretch with the one
/// before it in `ivs`.
fn selected<'a>(ivs: &[&'a GyroInterval]) -> Vec<Selected<'a>> {
    ivs.iter()
        .enumerate()
        .map(|(k, iv)| {
            let shares = k > 0 && ivs[k - 1].stretches[1] == iv.stretches[0];
            (&iv.noise, shares)
        })
        .collect()
}

/// r = u1 − ΔRᵀ u0 with the rates through K.
fn residual(th: &[f64; NP], iv: &GyroInterval) -> Vector3<f64> {
    let k = k_of(th);
    let mut r = Rotation3::identity();
    for (w, dt) in &iv.rates {
        r *= Rotation3::new(k * w * *dt);
    }
    Vector3::from(iv.u1) - r.inverse() * Vector3::from(iv.u0)
}

/// The residuals projected on each motion's plane and whitened (2 per motion).
fn residuals(th: &[f64; NP], ivs: &[&GyroInterval], w: &Whitener) -> Vec<f64> {
    let x: Vec<Vector2<f64>> = ivs
        .iter()
        .map(|iv| iv.noise.basis.transpose() * residual(th, iv))
        .collect();
    w.apply(&x).iter().flat_map(|v| [v.x, v.y]).collect()
}

/// The Jacobian w.r.t. the `idx` entries, in one pass per interval. With R_i the rotation up
/// to and including sample i and δφ_i = δK w_i Δt_i, first order in the per-sample angle
/// (≤ 0.01 rad at 1 rad/s and 100 Hz; only the step direction and the σ use it, never the
/// residual):  δ(ΔRᵀu0) = ΔRᵀ [u0]× Σ_i R_i δφ_i,  so  ∂r/∂K_ab = −ΔRᵀ [u0]× (M_b)_{:,a},
/// M_b = Σ_i R_i w_i[b] Δt_i. Unprojected: 3 rows per interval.
fn raw_jacobian(th: &[f64; NP], ivs: &[&GyroInterval], idx: &[usize]) -> DMatrix<f64> {
    let k = k_of(th);
    let mut j = DMatrix::zeros(3 * ivs.len(), idx.len());
    for (n, iv) in ivs.iter().enumerate() {
        let mut r = Rotation3::identity();
        let mut m = [Matrix3::zeros(); 3];
        for (w, dt) in &iv.rates {
            r *= Rotation3::new(k * w * *dt);
            for (b, mb) in m.iter_mut().enumerate() {
                *mb += r.matrix() * (w[b] * dt);
            }
        }
        let lead = -(r.inverse().matrix() * Vector3::from(iv.u0).cross_matrix());
        for (c, &p) in idx.iter().enumerate() {
            let col = lead * m[p % 3].column(p / 3);
            for row in 0..3 {
                j[(3 * n + row, c)] = col[row];
            }
        }
    }
    j
}

/// The Jacobian projected on each motion's plane (2 rows per motion).
fn projected_jacobian(th: &[f64; NP], ivs: &[&GyroInterval], idx: &[usize]) -> DMatrix<f64> {
    let j = raw_jacobian(th, ivs, idx);
    DMatrix::from_fn(2 * ivs.len(), idx.len(), |row, c| {
        let (k, e) = (row / 2, row % 2);
        let col = ivs[k].noise.basis.column(e);
        (0..3).map(|a| col[a] * j[(3 * k + a, c)]).sum()
    })
}

/// The Jacobian of [`residuals`]: projected and whitened as they are.
fn jacobian(th: &[f64; NP], ivs: &[&GyroInterval], idx: &[usize], w: &Whitener) -> DMatrix<f64> {
    w.apply_columns(&projected_jacobian(th, ivs, idx))
}

/// The fit of the `active` entries of K from `start` (inactive entries stay as there), and the
/// covariance of K from the residuals alone.
///
/// Generalised least squares (`calib::gyro_noise`): each residual u1 − ΔRᵀu0 is a difference of
/// two unit vectors, so to first order it lies in the plane orthogonal to u1 (2 degrees of
/// freedom per motion, not 3); the two components there are whitened with the modelled
/// block-tridiagonal covariance of consecutive motions, which share a still stretch. The
/// covariance is (JᵀJ)⁻¹ of the whitened Jacobian times the whitened residuals' variance over
/// 2n − p degrees of freedom (≈ 1 when the noise model is right).
fn fit(ivs: &[&GyroInterval], active: &[bool; NP], start: [f64; NP]) -> Result<Fit, AnalysisError> {
    let w = Whitener::new(&selected(ivs));
    levenberg_marquardt(
        start,
        active,
        2 * ivs.len(),
        |th| residuals(th, ivs, &w),
        |th, idx| jacobian(th, ivs, idx, &w),
    )
}

/// `fit`'s covariance (over all of `ivs`, whose whitener is `w`) plus what the accelerometer
/// calibration's error adds through the directions (`calib::gyro_noise`): D Cov(θ_a) Dᵀ,
/// D = (JᵀJ)⁻¹Jᵀ ∂r/∂θ_a, all whitened.
fn covariance(ivs: &[&GyroInterval], active: &[bool; NP], f: &Fit, w: &Whitener) -> Fit {
    let idx: Vec<usize> = (0..NP).filter(|&i| active[i]).collect();
    let mut out = f.clone();
    if idx.is_empty() {
        return out;
    }
    let j = jacobian(&f.theta, ivs, &idx, w);
    let a = w.apply_columns(&DMatrix::from_fn(2 * ivs.len(), 9, |row, c| {
        ivs[row / 2].noise.accel[(row % 2, c)]
    }));
    let Some(inv) = (j.transpose() * &j).try_inverse() else {
        return out;
    };
    let d = inv * j.transpose() * a;
    let add = &d * d.transpose();
    for (r, &p) in idx.iter().enumerate() {
        for (c, &q) in idx.iter().enumerate() {
            out.cov[(p, q)] += add[(r, c)];
        }
    }
    out
}

/// Condition number of the column-normalised Jacobian at K = I.
fn condition(ivs: &[&GyroInterval], active: &[bool; NP]) -> f64 {
    let idx: Vec<usize> = (0..NP).filter(|&i| active[i]).collect();
    scaled_condition(raw_jacobian(&nominal(), ivs, &idx))
}

/// Held-out residuals of each interval, projected on its plane (2 components each, rad, as the
/// fit sees them): K fitted on the others (started from the fit on all of them, which only saves
/// iterations: the training optimum is the same).
fn held_out(
    ivs: &[&GyroInterval],
    active: &[bool; NP],
) -> Result<Vec<Vector2<f64>>, AnalysisError> {
    let mut out = Vec::with_capacity(ivs.len());
    let all = fit(ivs, active, nominal())?.theta;
    for h in 0..ivs.len() {
        let train: Vec<&GyroInterval> =
            (0..ivs.len()).filter(|&i| i != h).map(|i| ivs[i]).collect();
        let th = fit(&train, active, all)?.theta;
        out.push(ivs[h].noise.basis.transpose() * residual(&th, ivs[h]));
    }
    Ok(out)
}

/// The whitening of the held-out residuals of the model `active`
/// (`calib::gyro_noise::HeldOutWhitener`): the fit's noise model over all the motions (each
/// motion's own covariance, consecutive motions correlated through their shared stretch), the
/// accelerometer calibration's error that all of them share, and each motion's share of the
/// error of the model refitted without it (linearised at the fit on all the motions; none
/// when nothing is fitted, K = I).
fn held_out_whitener(
    ivs: &[&GyroInterval],
    active: &[bool; NP],
) -> Result<HeldOutWhitener, AnalysisError> {
    let sel = selected(ivs);
    let idx: Vec<usize> = (0..NP).filter(|&i| active[i]).collect();
    if idx.is_empty() {
        return Ok(HeldOutWhitener::new(&sel, None));
    }
    let th = fit(ivs, active, nominal())?.theta;
    Ok(HeldOutWhitener::new(
        &sel,
        Some(&projected_jacobian(&th, ivs, &idx)),
    ))
}

/// The stacked held-out residuals whitened (`held_out_whitener`), so that the held-out test's
/// paired z sees components of unit variance, as its gain's noise assumes.
fn whitened(e: &[Vector2<f64>], w: &HeldOutWhitener) -> Vec<f64> {
    w.apply(e).iter().flat_map(|v| [v.x, v.y]).collect()
}

/// RMS of the held-out residuals' components, rad.
fn rms_rad(e: &[Vector2<f64>]) -> f64 {
    rms(&e.iter().flat_map(|v| [v.x, v.y]).collect::<Vec<_>>())
}

/// The kept gyroscope calibration in the bias stage's form (bias 0: estimated online).
#[derive(Clone, Debug, Serialize)]
pub struct FittedGyro {
    pub groups: Vec<String>,
    pub settings: CalibrationSettings,
    /// 1-σ of K's entries (row-major; ≈ of scale − 1 on the diagonal, of the misalignment in
    /// rad off it): the residuals' own, with the accelerometer calibration's error added.
    pub k_sd: [f64; NP],
    /// The whitened residuals' variance over their degrees of freedom: ≈ 1 when the modelled
    /// noise (`calib::gyro_noise`) is the residuals' real noise; the σ are scaled by it.
    pub noise_ratio: f64,
}

/// The result of [`calibrate_gyro`].
#[derive(Clone, Debug, Serialize)]
pub struct GyroCalibration {
    pub intervals: Vec<GyroInterval>,
    pub not_identifiable: Vec<NotIdentifiable>,
    pub candidates: Vec<Candidate>,
    pub fitted: Option<FittedGyro>,
    /// RMS of the held-out direction errors' two components (rad) without and with the kept
    /// calibration.
    pub held_out_rms_before_rad: f64,
    pub held_out_rms_after_rad: f64,
    /// The same whitened with the held-out residuals' modelled covariance (`held_out_whitener`;
    /// ≈ 1 where only the modelled noise is left): what the held-out test compares.
    pub held_out_white_rms_before: f64,
    pub held_out_white_rms_after: f64,
    pub verdict: String,
}

/// Calibrate the gyroscope triad from `intervals` (module docs) at significance `alpha`.
pub fn calibrate_gyro(
    intervals: Vec<GyroInterval>,
    alpha: f64,
    max_condition: f64,
) -> Result<GyroCalibration, AnalysisError> {
    let ivs: Vec<&GyroInterval> = intervals.iter().collect();
    let n = ivs.len();
    let mut not_identifiable = Vec::new();
    let mut model = Vec::new();
    for m in [vec![0, 1], vec![1], vec![0]] {
        let active = mask_of(&m);
        let p = active.iter().filter(|a| **a).count();
        let cond = if n > 0 {
            condition(&ivs, &active)
        } else {
            f64::INFINITY
        };
        let reason = if 2 * n < p + 4 {
            format!(
                "{n} interval(s) between still stretches, {} needed for {p} parameters",
                p.div_ceil(2) + 2
            )
        } else if cond.is_nan() || cond > max_condition {
            format!(
                "the rotations between still stretches leave the parameters ill-conditioned (condition number {cond:.3e} > {max_condition})"
            )
        } else {
            model = m;
            break;
        };
        not_identifiable.push(NotIdentifiable {
            model: names(&m),
            parameters: p,
            condition: cond,
            reason,
        });
    }
    let white = Whitener::new(&selected(&ivs));
    let candidates = eliminate(&mut model, alpha, |m, k, round, level| {
        let with = mask_of(m);
        let rest: Vec<usize> = m.iter().copied().filter(|&g| g != k).collect();
        let hw = held_out_whitener(&ivs, &with)?;
        let e1 = whitened(&held_out(&ivs, &with)?, &hw);
        let e0 = whitened(&held_out(&ivs, &mask_of(&rest))?, &hw);
        let desc = format!("gyro {} in [{}]", GROUPS[k], names(m));
        let test = held_out_test(
            "gyro calibration",
            desc,
            &e0,
            &e1,
            |_| true,
            level,
            GainNoise::WHITE,
        );
        Ok(Candidate {
            round,
            group: GROUPS[k].into(),
            effect_m_s2: f64::NAN,
            passed: test.kept,
            removed: false,
            reason: test.reason.clone(),
            test,
        })
    })?;
    let active = mask_of(&model);
    let full = covariance(&ivs, &active, &fit(&ivs, &active, nominal())?, &white);
    let (th, sd, noise_ratio) = (full.theta, full.sd(), full.residual_variance);
    let mut settings = CalibrationSettings::default();
    let mut implausible = Vec::new();
    if let Some(a) = k_of(&th).try_inverse() {
        settings.scale = [a[(0, 0)], a[(1, 1)], a[(2, 2)]];
        settings.misalignment =
            std::array::from_fn(|i| std::array::from_fn(|j| a[(i, j)] / a[(i, i)]));
        settings.validate_into("bias.settings.gyro", &mut implausible);
    } else {
        implausible.push("bias.settings.gyro: K is singular".into());
    }
    let kept = !model.is_empty() && implausible.is_empty();
    let e_none = if n > 0 {
        held_out(&ivs, &[false; NP])?
    } else {
        vec![]
    };
    let after = if kept { active } else { [false; NP] };
    let e_after = if kept {
        held_out(&ivs, &active)?
    } else {
        e_none.clone()
    };
    let verdict = if !implausible.is_empty() && !model.is_empty() {
        format!("implausible, not written: {}", implausible.join("; "))
    } else if kept {
        format!("gyro calibration kept: {}", names(&model))
    } else if candidates.is_empty() {
        let why = not_identifiable.last().map_or("", |x| x.reason.as_str());
        format!("not identifiable: not even one group ({why})")
    } else {
        "nothing kept: no identifiable group lowers the held-out error by more than its noise"
            .into()
    };
    Ok(GyroCalibration {
        held_out_rms_before_rad: rms_rad(&e_none),
        held_out_rms_after_rad: rms_rad(&e_after),
        held_out_white_rms_before: rms(&whitened(&e_none, &held_out_whitener(&ivs, &[false; NP])?)),
        held_out_white_rms_after: rms(&whitened(&e_after, &held_out_whitener(&ivs, &after)?)),
        intervals,
        not_identifiable,
        candidates,
        fitted: kept.then(|| FittedGyro {
            groups: model.iter().map(|&g| GROUPS[g].to_string()).collect(),
            settings,
            k_sd: sd,
            noise_ratio,
        }),
        verdict,
    })
}
