//! The gyroscope's scale factor about the vertical, seen in motion: the heading change the gyro
//! integrates over each turn of a drive against the change of the GNSS course over ground.
//!
//! A land vehicle at speed moves along its heading (sideslip is small and returns to its straight
//! value once the wheel is straight), so between two moments of straight driving the course
//! change Δψ equals the heading change. The gyro reads `ω_m = (1 + s) ω + b` about the vertical,
//! so over a segment from a straight moment to the next
//!
//!   ∫ω_m dt = (1 + s) Δψ + b Δt   ⇒   Δψ = k ∫ω_m dt − k b Δt,   k = 1/(1 + s),
//!
//! an ordinary least-squares fit of (k, kb) over all segments, with the residual variance as the
//! noise (course noise, sideslip left at the anchors, bias drift). Straight moments: speed ≥
//! `min_speed_m_s` and the vertical rate's mean over ±`straight_window_s` below
//! `straight_rate_rad_s`; anchors at least `min_anchor_gap_s` apart; a segment is used only if
//! every GNSS epoch inside it has a velocity and the speed stays ≥ `min_speed_m_s` (so the course
//! is defined all along and unwraps correctly), with no GNSS gap over 2 s and no IMU interval over
//! 5× the median (the integral would bridge it blind). The vertical is the mean specific force over the
//! record (a car's accelerations average out; a tilt error θ changes the projected scale by
//! cos θ − 1, 1.5e-4 at 1°). Headings are north-to-east (clockwise seen from above), so the
//! rate about the up axis enters with a minus sign.
//!
//! Significance: the scale error is kept as a finding only if |s|/σ_s exceeds the two-sided
//! normal quantile at `alpha` and at least `min_turns` segments turn by more than 20° (a scale
//! error is seen only in turning; the bias in Δt alone). It is a report, not a correction: a
//! scale about the vertical mixes the three axes' scale and misalignment terms whenever the
//! sensor is tilted in the vehicle, so it is not written as one axis's scale.

use serde::Serialize;

use crate::stats::robust::upper_median;
use crate::stats::special::normal_sf;

/// Longest time between two GNSS epochs inside a segment, s: across a longer gap the course
/// cannot be unwrapped with certainty.
const MAX_GNSS_GAP_S: f64 = 2.0;

/// Settings of the course fit.
#[derive(Clone, Debug)]
pub struct CourseSettings {
    /// Least speed for a defined course, m/s.
    pub min_speed_m_s: f64,
    /// A moment is straight when the mean vertical rate over ±`straight_window_s` is below this, rad/s.
    pub straight_rate_rad_s: f64,
    /// Half width of that mean, s.
    pub straight_window_s: f64,
    /// Least time between two anchors, s.
    pub min_anchor_gap_s: f64,
    /// Two-sided level of the scale test.
    pub alpha: f64,
    /// Least number of segments turning by more than 20°.
    pub min_turns: usize,
}

impl Default for CourseSettings {
    fn default() -> Self {
        CourseSettings {
            min_speed_m_s: 4.0,
            straight_rate_rad_s: 1f64.to_radians(),
            straight_window_s: 1.0,
            min_anchor_gap_s: 3.0,
            alpha: 1e-3,
            min_turns: 5,
        }
    }
}

/// One GNSS velocity epoch.
#[derive(Clone, Copy, Debug)]
pub struct CourseEpoch {
    /// Time on the IMU's clock, s.
    pub t: f64,
    /// Velocity north and east, m/s (`None`: the epoch has no velocity).
    pub v_ne: Option<[f64; 2]>,
}

/// What the fit found.
#[derive(Clone, Debug, Serialize)]
pub struct CourseScale {
    /// The vertical in body axes (unit vector, from the mean specific force).
    pub up_body: [f64; 3],
    /// Segments fitted, and those turning by more than 20°.
    pub segments: usize,
    pub turns: usize,
    /// Largest course change of a segment, °.
    pub largest_turn_deg: f64,
    /// Scale error s of the rate about the vertical (ω_m = (1 + s) ω + b), and its σ.
    pub scale_error: f64,
    pub scale_error_sd: f64,
    /// Bias about the vertical, rad/s, and its σ.
    pub bias_rad_s: f64,
    pub bias_sd_rad_s: f64,
    /// Residual sd of the course change per segment, rad.
    pub residual_sd_rad: f64,
    /// z = s/σ_s, its two-sided p, the level, and the verdict.
    pub z: f64,
    pub p_value: f64,
    pub alpha: f64,
    pub significant: bool,
}

/// Why there is no fit.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CourseError {
    #[error(
        "the GNSS epochs do not overlap the IMU samples in time (IMU {0:.1}..{1:.1} s, GNSS {2:.1}..{3:.1} s)"
    )]
    NoOverlap(f64, f64, f64, f64),
    #[error(
        "not identifiable: {0} segments turn by more than 20° between straight moments at ≥ {1} m/s (need {2})"
    )]
    TooFewTurns(usize, f64, usize),
}

/// Fit the scale error about the vertical. `t` (s), `gyro` (rad/s) and `accel` (m/s²) are the
/// IMU samples in time order; `gnss` the velocity epochs on the same clock.
pub fn course_scale(
    t: &[f64],
    gyro: &[[f64; 3]],
    accel: &[[f64; 3]],
    gnss: &[CourseEpoch],
    s: &CourseSettings,
) -> Result<CourseScale, CourseError> {
    let (Some(&t0), Some(&t1)) = (t.first(), t.last()) else {
        return Err(CourseError::NoOverlap(
            f64::NAN,
            f64::NAN,
            f64::NAN,
            f64::NAN,
        ));
    };
    let (g0, g1) = (
        gnss.first().map_or(f64::NAN, |e| e.t),
        gnss.last().map_or(f64::NAN, |e| e.t),
    );
    let inside: Vec<&CourseEpoch> = gnss.iter().filter(|e| e.t >= t0 && e.t <= t1).collect();
    if inside.len() < 2 {
        return Err(CourseError::NoOverlap(t0, t1, g0, g1));
    }
    let mut up = [0.0; 3];
    for a in accel {
        for k in 0..3 {
            up[k] += a[k];
        }
    }
    let norm = up.iter().map(|v| v * v).sum::<f64>().sqrt();
    up.iter_mut().for_each(|v| *v /= norm);
    // Cumulative integral of the rate about the up axis (trapezoid), at the sample times.
    let rate: Vec<f64> = gyro
        .iter()
        .map(|g| g[0] * up[0] + g[1] * up[1] + g[2] * up[2])
        .collect();
    let mut cum = vec![0.0; t.len()];
    for i in 1..t.len() {
        cum[i] = cum[i - 1] + 0.5 * (rate[i] + rate[i - 1]) * (t[i] - t[i - 1]);
    }
    let integral = |x: f64| interp(t, &cum, x);
    // Per epoch: course (unwrapped over consecutive moving epochs) and whether it is straight.
    let w = s.straight_window_s;
    let mut course = Vec::with_capacity(inside.len());
    let mut prev: Option<f64> = None;
    for e in &inside {
        let c = e
            .v_ne
            .filter(|v| v[0].hypot(v[1]) >= s.min_speed_m_s)
            .map(|v| {
                let mut c = v[1].atan2(v[0]);
                if let Some(p) = prev {
                    c = p + wrap(c - p);
                }
                c
            });
        prev = c;
        let straight = c.is_some()
            && e.t - w >= t0
            && e.t + w <= t1
            && ((integral(e.t + w) - integral(e.t - w)) / (2.0 * w)).abs() < s.straight_rate_rad_s;
        course.push((c, straight));
    }
    let mut anchors: Vec<usize> = Vec::new();
    for (i, e) in inside.iter().enumerate() {
        if course[i].1
            && anchors
                .last()
                .is_none_or(|&j| e.t - inside[j].t >= s.min_anchor_gap_s)
        {
            anchors.push(i);
        }
    }
    // IMU gaps (an interval over 5× the median): the trapezoid would bridge them blind.
    let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let long = 5.0 * upper_median(&mut dts);
    let gaps: Vec<(f64, f64)> = t
        .windows(2)
        .filter(|w| w[1] - w[0] > long)
        .map(|w| (w[0], w[1]))
        .collect();
    let unbroken = |i: usize, j: usize| {
        let (a, b) = (inside[i].t, inside[j].t);
        inside[i..=j]
            .windows(2)
            .all(|w| w[1].t - w[0].t <= MAX_GNSS_GAP_S)
            && !gaps.iter().any(|&(g0, g1)| g1 > a && g0 < b)
    };
    // Rows (Δψ, ∫ω_m, Δt) of segments whose course is defined all along, without a gap in
    // either stream.
    let rows: Vec<[f64; 3]> = anchors
        .windows(2)
        .filter(|p| course[p[0]..=p[1]].iter().all(|c| c.0.is_some()) && unbroken(p[0], p[1]))
        .map(|p| {
            let (a, b) = (inside[p[0]], inside[p[1]]);
            [
                course[p[1]].0.unwrap() - course[p[0]].0.unwrap(),
                integral(b.t) - integral(a.t),
                b.t - a.t,
            ]
        })
        .collect();
    let turn = 20f64.to_radians();
    let turns = rows.iter().filter(|r| r[0].abs() > turn).count();
    if turns < s.min_turns || rows.len() < 3 {
        return Err(CourseError::TooFewTurns(
            turns,
            s.min_speed_m_s,
            s.min_turns,
        ));
    }
    // OLS of Δψ on (−∫ω_m, −Δt): heading is clockwise, the rate is about the up axis.
    let (mut sxx, mut sxy, mut syy, mut sx_y, mut sy_y) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for r in &rows {
        let (x, y, d) = (-r[1], -r[2], r[0]);
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        sx_y += x * d;
        sy_y += y * d;
    }
    let det = sxx * syy - sxy * sxy;
    let k = (syy * sx_y - sxy * sy_y) / det;
    let kb = (sxx * sy_y - sxy * sx_y) / det;
    let rss: f64 = rows
        .iter()
        .map(|r| (r[0] - (k * -r[1] + kb * -r[2])).powi(2))
        .sum();
    let s2 = rss / (rows.len() - 2) as f64;
    let (var_k, var_kb) = (s2 * syy / det, s2 * sxx / det);
    // s = 1/k − 1 (delta method: σ_s = σ_k / k²); the second coefficient is −k b.
    let scale_error = 1.0 / k - 1.0;
    let scale_error_sd = var_k.sqrt() / (k * k);
    let z = scale_error / scale_error_sd;
    let p_value = 2.0 * normal_sf(z.abs());
    Ok(CourseScale {
        up_body: up,
        segments: rows.len(),
        turns,
        largest_turn_deg: rows
            .iter()
            .map(|r| r[0].abs())
            .fold(0.0, f64::max)
            .to_degrees(),
        scale_error,
        scale_error_sd,
        bias_rad_s: -kb / k,
        bias_sd_rad_s: var_kb.sqrt() / k.abs(),
        residual_sd_rad: s2.sqrt(),
        z,
        p_value,
        alpha: s.alpha,
        significant: p_value < s.alpha,
    })
}

/// Angle into (−π, π].
fn wrap(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    a - two_pi * ((a + std::f64::consts::PI) / two_pi).floor()
}

/// Linear interpolation of `y` at `x` over increasing `t` (clamped at the ends).
fn interp(t: &[f64], y: &[f64], x: f64) -> f64 {
    let i = t.partition_point(|v| *v < x);
    if i == 0 {
        return y[0];
    }
    if i >= t.len() {
        return y[t.len() - 1];
    }
    let (ta, tb) = (t[i - 1], t[i]);
    if tb <= ta {
        return y[i];
    }
    y[i - 1] + (y[i] - y[i - 1]) * (x - ta) / (tb - ta)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A drive at 10 m/s, 100 Hz IMU and 4 Hz GNSS: straight stretches of 10–30 s and turns of
    /// ±30–120° at up to 15 °/s; the gyro reads (1 + s)ω + b + noise about a tilted up axis.
    /// Sample times, gyro, accel, GNSS epochs.
    type Drive = (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<CourseEpoch>);

    fn drive(seed: u64, scale: f64) -> Drive {
        let mut rng = Rng::new(seed);
        let up = {
            let u = [0.05f64, -0.03, 1.0];
            let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
            [u[0] / n, u[1] / n, u[2] / n]
        };
        let (dt, bias, noise) = (0.01, 0.003, 0.002);
        let (mut t, mut gyro, mut accel, mut gnss) = (vec![], vec![], vec![], vec![]);
        let (mut psi, mut k) = (0.3f64, 0usize);
        for _ in 0..20 {
            let straight = 10.0 + 20.0 * rng.uniform();
            let turn = (30.0 + 90.0 * rng.uniform()).to_radians()
                * if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            let turn_s = turn.abs() / 15f64.to_radians();
            let n = ((straight + turn_s) / dt) as usize;
            for i in 0..n {
                let in_turn = i as f64 * dt >= straight;
                // Heading rate (clockwise) → rate about the up axis is its negative.
                let psi_dot = if in_turn { turn / turn_s } else { 0.0 };
                let w_up = -psi_dot;
                let m = (1.0 + scale) * w_up + bias + noise * rng.normal();
                let time = k as f64 * dt;
                t.push(time);
                gyro.push([m * up[0], m * up[1], m * up[2]]);
                accel.push([9.8 * up[0], 9.8 * up[1], 9.8 * up[2]]);
                if k % 25 == 0 {
                    let v = [
                        10.0 * psi.cos() + 0.02 * rng.normal(),
                        10.0 * psi.sin() + 0.02 * rng.normal(),
                    ];
                    gnss.push(CourseEpoch {
                        t: time,
                        v_ne: Some(v),
                    });
                }
                psi += psi_dot * dt;
                k += 1;
            }
        }
        (t, gyro, accel, gnss)
    }

    #[test]
    fn a_scale_error_is_recovered_and_none_is_not_claimed() {
        // Recovery within 4σ of the fit's own σ (a 4σ miss has p = 6e-5 per seed), and with no
        // scale error nothing significant at α = 0.001 on any of 10 seeds (P(any) ≈ 1 %).
        for seed in 1..=10u64 {
            let (t, g, a, e) = drive(seed, 0.005);
            let r = course_scale(&t, &g, &a, &e, &CourseSettings::default()).unwrap();
            assert!(
                r.significant && (r.scale_error - 0.005).abs() < 4.0 * r.scale_error_sd,
                "{seed}: {r:?}"
            );
            assert!(
                (r.bias_rad_s - 0.003).abs() < 4.0 * r.bias_sd_rad_s,
                "{seed}: {r:?}"
            );
            let (t, g, a, e) = drive(seed, 0.0);
            let r = course_scale(&t, &g, &a, &e, &CourseSettings::default()).unwrap();
            assert!(!r.significant, "{seed}: {r:?}");
        }
    }

    #[test]
    fn a_segment_across_an_imu_gap_is_left_out() {
        // 3 s of IMU samples cut out of the record's middle: the segment around it goes (its
        // integral would bridge the gap blind), the rest still recovers the scale within 4σ.
        let (mut t, mut g, mut a, e) = drive(2, 0.005);
        let full = course_scale(&t, &g, &a, &e, &CourseSettings::default()).unwrap();
        let mid = t.len() / 2;
        t.drain(mid..mid + 300);
        g.drain(mid..mid + 300);
        a.drain(mid..mid + 300);
        let cut = course_scale(&t, &g, &a, &e, &CourseSettings::default()).unwrap();
        assert!(
            cut.segments < full.segments,
            "{} vs {}",
            cut.segments,
            full.segments
        );
        assert!(
            (cut.scale_error - 0.005).abs() < 4.0 * cut.scale_error_sd,
            "{cut:?}"
        );
    }

    #[test]
    fn no_turns_or_no_overlap_is_said() {
        let (t, g, a, e) = drive(3, 0.0);
        let slow: Vec<CourseEpoch> = e
            .iter()
            .map(|e| CourseEpoch {
                t: e.t,
                v_ne: Some([1.0, 0.0]),
            })
            .collect();
        assert!(matches!(
            course_scale(&t, &g, &a, &slow, &CourseSettings::default()),
            Err(CourseError::TooFewTurns(0, _, _))
        ));
        let late: Vec<CourseEpoch> = e
            .iter()
            .map(|e| CourseEpoch { t: e.t + 1e5, ..*e })
            .collect();
        assert!(matches!(
            course_scale(&t, &g, &a, &late, &CourseSettings::default()),
            Err(CourseError::NoOverlap(..))
        ));
    }
}
