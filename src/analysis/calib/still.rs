//! Still stretches of a moving recording, for multi-position calibration without a turntable.
//!
//! At rest the accelerometer triad measures gravity alone, so every still stretch is one
//! "position" of a multi-position calibration (Tedaldi, Pretto & Menegatti, "A robust and easy to
//! implement method for IMU calibration without external equipments", ICRA 2014; the six-position
//! laboratory form in Titterton & Weston, *Strapdown Inertial Navigation Technology*, 2nd ed.,
//! §8.5): the constraint is
//!
//! ```text
//!   | A⁻¹ (f̄_k − b) | = g        for every still stretch k,
//! ```
//!
//! with f̄_k the stretch's mean specific force (m/s²), A = diag(scale)·N and b the triad's
//! calibration (`analysis::calib::fit`).
//!
//! **Which samples are still** is the bias stage's own detector (`stage::bias::stillness`, its
//! default settings): windows whose gyro and accelerometer spread sit within a factor of the
//! sensor's own learned noise floor, no sample far from the window mean, |f| near g. Nothing
//! here is a threshold in m/s² or rad/s that fits one sensor class. A stretch is a run of still
//! samples of at least `min_still_s`, with `trim_s` dropped at each end (the detector enters
//! STILL only after its window and entry time have passed, and leaves at the first sample that
//! fails, so the ends are where a motion's tail or onset could leak in).
//!
//! **Attitude groups.** Two stretches whose gravity directions lie within `group_deg` of each
//! other measure nearly the same thing (a car stopping at lights on the same street), so the
//! held-out test leaves out a whole group at a time, never a stretch whose twin stays in the
//! fit. The spread of the directions is reported as the eigenvalues of their scatter matrix
//! (1/K) Σ u_k u_kᵀ (they sum to 1; ⅓ each for directions that fill the sphere evenly, one
//! eigenvalue ≈ 1 for a single attitude).

use std::ops::Range;

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use serde::Serialize;

use crate::sample::Channels;
use crate::stage::bias::stillness::{StillnessDetector, StillnessSettings};

/// Settings of the stretch finder.
#[derive(Clone, Debug)]
pub struct StillSettings {
    /// Shortest still stretch used, s (after trimming). Default 2: the mean of 200 samples at
    /// 100 Hz averages the white noise down by 14×, and a stop shorter than that is rarely rest.
    pub min_still_s: f64,
    /// Dropped at each end of a still run, s. Default 0.25 (half the detector's window).
    pub trim_s: f64,
    /// Stretches whose directions lie within this angle form one attitude group, degrees.
    /// Default 10.
    pub group_deg: f64,
}

impl Default for StillSettings {
    fn default() -> Self {
        StillSettings {
            min_still_s: 2.0,
            trim_s: 0.25,
            group_deg: 10.0,
        }
    }
}

/// One still stretch: its place and its mean specific force.
#[derive(Clone, Debug, Serialize)]
pub struct AccelStretch {
    /// First sample (index into the analysed samples).
    pub start: usize,
    /// Samples.
    pub len: usize,
    /// Start time, s from the first analysed sample.
    pub t0_s: f64,
    /// Mean specific force per axis, m/s².
    pub mean_m_s2: [f64; 3],
    /// Sample standard deviation per axis, m/s².
    pub sd_m_s2: [f64; 3],
    /// 1-σ of the stretch's mean |f| if the noise were white: sd of |f| / √len, m/s².
    pub norm_mean_sd_m_s2: f64,
}

impl AccelStretch {
    /// The mean specific force.
    pub fn mean(&self) -> Vector3<f64> {
        Vector3::from(self.mean_m_s2)
    }

    /// Its duration at `rate_hz`, s.
    pub fn duration_s(&self, rate_hz: f64) -> f64 {
        self.len as f64 / rate_hz
    }
}

/// Mean and sample variance per axis of `v(i)` over the samples `i` of `range`.
pub(crate) fn mean_var(
    range: Range<usize>,
    v: impl Fn(usize) -> Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let n = range.len().max(1) as f64;
    let mean = range.clone().map(&v).sum::<Vector3<f64>>() / n;
    let var = range
        .map(|i| (v(i) - mean).component_mul(&(v(i) - mean)))
        .sum::<Vector3<f64>>()
        / (n - 1.0).max(1.0);
    (mean, var)
}

/// Mean, per-axis sd and the white-noise σ of the mean norm over the samples `range` of `ch`.
fn stretch_stats(ch: &Channels, range: Range<usize>) -> ([f64; 3], [f64; 3], f64) {
    let n = range.len().max(1) as f64;
    let (mean, var) = mean_var(range.clone(), |i| ch.accel(i));
    let norm_mean = range.clone().map(|i| ch.accel(i).norm()).sum::<f64>() / n;
    let norm_var = range
        .map(|i| (ch.accel(i).norm() - norm_mean).powi(2))
        .sum::<f64>()
        / (n - 1.0).max(1.0);
    let sd = var.map(f64::sqrt);
    (mean.into(), sd.into(), (norm_var / n).sqrt())
}

/// The still stretches of the samples of `ch` (sample rate `rate_hz`) by the bias stage's
/// detector. The accelerometer axes must be present (the caller checks); samples with a
/// non-finite channel end a stretch.
pub fn still_stretches(ch: &Channels, rate_hz: f64, s: &StillSettings) -> Vec<AccelStretch> {
    let mut det = StillnessDetector::new(&StillnessSettings::default(), rate_hz);
    let trim = (s.trim_s * rate_hz).round() as usize;
    let min_len = ((s.min_still_s * rate_hz).ceil() as usize).max(2);
    let t0 = if ch.is_empty() { 0.0 } else { ch.t_s(0) };
    let mut out = Vec::new();
    let mut run_start: Option<usize> = None;
    let close = |from: usize, to: usize, out: &mut Vec<AccelStretch>| {
        // [from, to): the still run; trimmed at both ends.
        let (a, b) = (from + trim, to.saturating_sub(trim));
        if b > a && b - a >= min_len {
            let (mean_m_s2, sd_m_s2, norm_mean_sd_m_s2) = stretch_stats(ch, a..b);
            out.push(AccelStretch {
                start: a,
                len: b - a,
                t0_s: ch.t_s(a) - t0,
                mean_m_s2,
                sd_m_s2,
                norm_mean_sd_m_s2,
            });
        }
    };
    let mut bar = crate::progress::Delayed::steps(ch.len() as u64, "samples judged");
    for i in 0..ch.len() {
        bar.sample_done(i as u64 + 1);
        let (g, a) = (ch.gyro(i), ch.accel(i));
        // A gyro-less sensor is judged on its accelerometers (absent axes take no part).
        let still = det.update_present(&g.into(), &a.into(), &[None; 3], ch.absent_at(i))
            && a.iter().all(|v| v.is_finite());
        match (still, run_start) {
            (true, None) => run_start = Some(i),
            (false, Some(st)) => {
                close(st, i, &mut out);
                run_start = None;
            }
            _ => {}
        }
    }
    if let Some(st) = run_start {
        close(st, ch.len(), &mut out);
    }
    out
}

/// Attitude group of each stretch: greedy in time order, a stretch joins the first group whose
/// first member's direction is within `group_deg`, else starts a new group.
pub fn attitude_groups(stretches: &[AccelStretch], group_deg: f64) -> Vec<usize> {
    let cos_max = group_deg.to_radians().cos();
    let mut heads: Vec<Vector3<f64>> = Vec::new();
    stretches
        .iter()
        .map(|st| {
            let u = st.mean().normalize();
            match heads.iter().position(|h| h.dot(&u) >= cos_max) {
                Some(g) => g,
                None => {
                    heads.push(u);
                    heads.len() - 1
                }
            }
        })
        .collect()
}

/// How far the stretches' gravity directions spread.
#[derive(Clone, Debug, Serialize)]
pub struct AttitudeSpread {
    /// Stretches.
    pub stretches: usize,
    /// Attitude groups (directions more than `group_deg` apart).
    pub groups: usize,
    /// Eigenvalues of (1/K) Σ u uᵀ, largest first (sum 1; ⅓ each fills the sphere evenly).
    pub scatter_eigenvalues: [f64; 3],
    /// Largest angle between a stretch's direction and their mean direction, degrees.
    pub max_angle_from_mean_deg: f64,
}

/// The spread of `stretches` with their `groups`.
pub fn attitude_spread(stretches: &[AccelStretch], groups: &[usize]) -> AttitudeSpread {
    let k = stretches.len();
    let dirs: Vec<Vector3<f64>> = stretches.iter().map(|s| s.mean().normalize()).collect();
    let scatter = dirs.iter().map(|u| u * u.transpose()).sum::<Matrix3<f64>>() / k.max(1) as f64;
    let mut ev: Vec<f64> = SymmetricEigen::new(scatter)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    let mean_dir = dirs.iter().sum::<Vector3<f64>>();
    let max_angle = if mean_dir.norm() > 0.0 {
        let m = mean_dir.normalize();
        dirs.iter()
            .map(|u| u.dot(&m).clamp(-1.0, 1.0).acos().to_degrees())
            .fold(0.0, f64::max)
    } else {
        180.0
    };
    AttitudeSpread {
        stretches: k,
        groups: groups.iter().copied().max().map_or(0, |g| g + 1),
        scatter_eigenvalues: [ev[0], ev[1], ev[2]],
        max_angle_from_mean_deg: if k == 0 { 0.0 } else { max_angle },
    }
}
