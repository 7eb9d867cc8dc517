//! Gait: the true motion of an IMU strapped to the instep of a walking pedestrian's shoe (a
//! foot-mounted, "ZUPT" IMU), and the heel-strike and toe-off impacts it feels.
//!
//! **Timeline.** Stand still (`initial_still_s`), then `bouts` walking bouts of
//! `strides_per_bout` strides, each bout after the first preceded by standing still (`pause_s`)
//! and a turn of `turn_deg` in ⌈|turn|/90°⌉ pivot steps, then stand still (`final_still_s`).
//! A stride of the instrumented foot (two steps) lasts T = 120 / cadence s (cadence in steps per
//! minute) and is a *foot-flat* phase of T_ff = `foot_flat_fraction`·T followed by the moving
//! phase of T_m = T − T_ff: heel-off → toe-off (share 0.35 of T_m, t_A), swing (0.45, t_B), heel
//! strike → foot flat (foot slap, 0.20, t_C). Each stride's T, length L and pitch amplitudes are
//! multiplied by 1 + j·clamp(n, ±2.5), n ~ N(0, 1) from a stream fixed by the scenario (not by
//! the noise seed), j = `stride_jitter`: real strides are not identical.
//!
//! **Pose.** Position p (NED, m) and ZYX Euler angles (roll φ, pitch θ, yaw ψ; C_nb = R_z(ψ)
//! R_y(θ) R_x(φ)) are closed-form functions of time, built from two shapes on x ∈ [0, 1] whose
//! first and second derivatives vanish at both ends (so rate, velocity and acceleration are
//! continuous, and so is the rate's slope):
//!
//! ```text
//!   S(x) = x − sin(2πx)/(2π)      (smooth step 0 → 1; S' = 1 − cos 2πx, peak 2)
//!   B(x) = sin⁴(πx)               (bump 0 → 1 → 0)
//!   W(x) = sin⁴(πx) cos(πx) / W*  (odd wobble, peak ±1; W* = 0.8² √0.2)
//! ```
//!
//! In the moving phase of a stride (u ∈ [0, T_m], x = u/T_m), heading ψ₀ of the bout,
//! d = [cos ψ₀, sin ψ₀, 0]:
//!
//! ```text
//!   θ(u) = −Θ_to S(u/t_A)                                    heel-off → toe-off (plantar flexion)
//!        = −Θ_to + (Θ_to + Θ_hs) S((u − t_A)/t_B)            swing (the foot pitches toe-up)
//!        = Θ_hs (1 − S((u − t_A − t_B)/t_C))                 heel strike → foot flat
//!   φ(u) = φ_st (1 − S(x)) + A_roll B(x)                     inversion bump; the stance roll given back
//!   ψ(u) = ψ₀ + A_yaw W(x)                                   toe-in / toe-out
//!   p(u) = p₀ + L S(u/(t_A + t_B)) d − H B(x) e_z            forward until heel strike, lifted by ≤ H
//! ```
//!
//! so the peak pitch rates are 2Θ_to/t_A (toe-off, negative), 2(Θ_to + Θ_hs)/t_B (swing) and
//! 2Θ_hs/t_C (foot slap, negative), the peak forward speed 2L/(t_A + t_B) and acceleration
//! 2πL/(t_A + t_B)². In the foot-flat phase (u ∈ [0, T_ff]) the foot does not move (p, θ, ψ
//! fixed) but rolls slowly under load: φ(u) = φ_st S(u/T_ff), φ_st = −`stance_roll_deg_s`·T_ff,
//! a mean roll rate of −`stance_roll_deg_s` (peak twice that) — a stance is not perfectly still,
//! and that is exactly what a bias estimator must not learn. A pivot step (u ∈ [0, T_m]) turns
//! the foot in place: ψ = ψ₀ + α S(u/T_m), lifted by 3 cm·B(u/T_m); a foot-flat phase of T_ff
//! without roll follows it. Standing still, nothing moves.
//!
//! **What the IMU reads** (the body rates from the Euler rates, the specific force from the
//! position's second derivative; Titterton & Weston, *Strapdown Inertial Navigation
//! Technology*, 2nd ed., §3.6):
//!
//! ```text
//!   ω_b = [ φ̇ − ψ̇ sin θ,  θ̇ cos φ + ψ̇ sin φ cos θ,  −θ̇ sin φ + ψ̇ cos φ cos θ ]ᵀ
//!   f_b = C_nbᵀ (p̈ − g_n),   g_n = [0, 0, g]ᵀ
//! ```
//!
//! (+ the Earth rate C_nbᵀ ω_ie when enabled), one trajectory for both triads, so a strapdown
//! integration of the truth reproduces the pose (tests/sim_gait.rs).
//!
//! **Impacts.** At heel strike (u = t_A + t_B) and, `toe_off_share` as large, at toe-off (u =
//! t_A) the foot feels a short, sharp, multi-axis transient: the IMU's mount on the shoe is
//! deflected and springs back, ringing. With s = t/τ (τ = `impact_tau_ms`), ω_r =
//! 2π·`impact_ring_hz`, the deflection and what the sensor reads are
//!
//! ```text
//!   x(t) = s³ e^(−s) (1 + 0.3 sin ω_r t),   q(t) = ẍ(t) / max|ẍ|,   t ≥ 0
//!   f_imp = g·impact_g · a_dir · q(t − t_i),   ω_imp = impact_deg_s · w_dir · q(t − t_i)
//! ```
//!
//! a_dir = [−0.35, 0.2, −1] (the ground stops the foot: up and back, some sideways),
//! w_dir = [0.3, 1, 0.3] (mostly a pitch jolt). With the defaults (τ = 6 ms, 40 Hz) q rises
//! from 0 to its peak +1 in 2 ms, stays positive for 6.5 ms, rebounds to −0.95 until 15 ms and
//! rings out (+0.45, −0.49, +0.27; below 5 % after 47 ms). x, ẋ and ẍ start at 0 (the transient
//! builds up, it does not jump) and x and ẋ return to 0, so its integral and double integral
//! vanish: it changes no velocity, no position and no angle. It is real motion, kept apart from
//! `true_*` in the truth's `road_vibration_*` columns as every vibration is (`true_*` stays the
//! smooth rigid-body motion the strapdown check integrates); it is cut after 25 τ (s³e⁻ˢ <
//! 2e-7 there). The sensor samples it at its instants (no anti-alias filter is modelled): at
//! 100 Hz the 6.5-ms main pulse falls on one sample or none.

use super::scenario::{Checker, MotionConfig};
use crate::rng::Rng;
use crate::sample::N_CHANNELS;
use nalgebra::{Rotation3, Vector3};
use std::f64::consts::PI;

/// Shares of a stride's moving phase: heel-off → toe-off, swing, heel strike → foot flat.
pub const MOVING_SHARES: [f64; 3] = [0.35, 0.45, 0.20];
/// Largest turn of one pivot step, deg.
pub const MAX_PIVOT_DEG: f64 = 90.0;
/// Lift of the foot in a pivot step, m.
const PIVOT_LIFT_M: f64 = 0.03;
/// Seed of the stride-to-stride variability (part of the scenario's motion, not of its noise).
const JITTER_SEED: u64 = 0x6A17_5EED;
/// Largest stride deviation, in units of `stride_jitter`.
const JITTER_CLAMP: f64 = 2.5;
/// Body-frame directions of the impact (peak component 1).
const IMPACT_ACCEL_DIR: [f64; 3] = [-0.35, 0.2, -1.0];
const IMPACT_GYRO_DIR: [f64; 3] = [0.3, 1.0, 0.3];
/// The transient is cut after this many envelope time constants.
const IMPACT_CUT_TAU: f64 = 25.0;
/// Relative size of the ringing in the impact's deflection.
const IMPACT_RING: f64 = 0.3;
/// Peak of sin⁴(πx) cos(πx) on [0, 1] (at sin² = 0.8).
const WOBBLE_PEAK: f64 = 0.64 * 0.447_213_595_499_958;

/// S(x) = x − sin(2πx)/(2π) on [0, 1] (clamped), with S' and S''.
fn step(x: f64) -> [f64; 3] {
    let x = x.clamp(0.0, 1.0);
    let w = 2.0 * PI * x;
    [x - w.sin() / (2.0 * PI), 1.0 - w.cos(), 2.0 * PI * w.sin()]
}

/// B(x) = sin⁴(πx) on [0, 1] (clamped), with B' and B''.
fn bump(x: f64) -> [f64; 3] {
    let x = x.clamp(0.0, 1.0);
    let (s, c) = (PI * x).sin_cos();
    [
        s.powi(4),
        4.0 * PI * s.powi(3) * c,
        4.0 * PI * PI * s * s * (3.0 * c * c - s * s),
    ]
}

/// W(x) = sin⁴(πx) cos(πx) / W* on [0, 1] (clamped), with W'.
fn wobble(x: f64) -> [f64; 2] {
    let x = x.clamp(0.0, 1.0);
    let (s, c) = (PI * x).sin_cos();
    [
        s.powi(4) * c / WOBBLE_PEAK,
        PI * (4.0 * s.powi(3) * c * c - s.powi(5)) / WOBBLE_PEAK,
    ]
}

/// One stride's moving phase.
#[derive(Clone, Copy, Debug)]
struct Swing {
    length_m: f64,
    t_a: f64,
    t_b: f64,
    t_c: f64,
    toe_off_rad: f64,
    heel_strike_rad: f64,
    roll_amp_rad: f64,
    yaw_amp_rad: f64,
    clearance_m: f64,
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    /// Standing (or a foot flat after a pivot): nothing moves.
    Still,
    /// A stride's foot flat: the roll goes from 0 to `roll_rad`.
    FootFlat {
        roll_rad: f64,
    },
    Swing(Swing),
    /// A turn in place by `angle_rad`.
    Pivot {
        angle_rad: f64,
    },
}

#[derive(Clone, Copy, Debug)]
struct Phase {
    t0_s: f64,
    dur_s: f64,
    /// Position at the start, NED, m.
    p0: Vector3<f64>,
    /// Heading at the start, rad.
    psi0: f64,
    /// Roll at the start, rad (a swing starts from its stance's roll).
    roll0: f64,
    kind: Kind,
}

/// Pose and its derivatives at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaitPose {
    /// [roll, pitch, yaw], rad.
    pub euler: [f64; 3],
    /// Their time derivatives, rad/s.
    pub euler_rate: [f64; 3],
    /// Position, velocity, acceleration, NED.
    pub p: Vector3<f64>,
    pub v: Vector3<f64>,
    pub a: Vector3<f64>,
}

impl GaitPose {
    /// C_nb (body to NED).
    pub fn c_nb(&self) -> Rotation3<f64> {
        Rotation3::from_euler_angles(self.euler[0], self.euler[1], self.euler[2])
    }

    /// Body rate, rad/s (ZYX Euler kinematics; no Earth rate).
    pub fn body_rate(&self) -> Vector3<f64> {
        let [phi, theta, _] = self.euler;
        let [dphi, dtheta, dpsi] = self.euler_rate;
        let (sp, cp) = phi.sin_cos();
        let (st, ct) = theta.sin_cos();
        Vector3::new(
            dphi - dpsi * st,
            dtheta * cp + dpsi * sp * ct,
            -dtheta * sp + dpsi * cp * ct,
        )
    }
}

/// What kind of time span of the walk an instant is in ([`GaitPlan::spans`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpanKind {
    /// Standing still (before, between and after the bouts).
    Standing,
    /// A stride's foot-flat phase (zero velocity, a slow roll).
    FootFlat,
    /// A stride's moving phase.
    Moving,
    /// A pivot step of a turn, or the foot flat after it.
    Turning,
}

/// A time span of the walk, for checks and tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaitSpan {
    pub t0_s: f64,
    pub t1_s: f64,
    pub kind: SpanKind,
}

/// A walk turned into a time-indexed plan (built once).
#[derive(Clone, Debug)]
pub struct GaitPlan {
    phases: Vec<Phase>,
    /// Impact instants and sizes (1 = heel strike), in time order.
    impacts: Vec<(f64, f64)>,
    /// Heel-strike instants (every stride's, impacts or not).
    heel_strikes: Vec<f64>,
    impact_accel: [f64; 3],
    impact_gyro: [f64; 3],
    impact_tau_s: f64,
    impact_omega: f64,
    /// max |ẍ| of the unnormalised shape (module docs).
    impact_peak: f64,
    gravity_m_s2: f64,
    duration_s: f64,
}

impl GaitPlan {
    /// Plan the walk of a `MotionConfig::Gait`; issues are reported under `motion.`. `None`
    /// when any value is unusable (or `m` is another kind).
    pub(crate) fn build(m: &MotionConfig, ck: &mut Checker) -> Option<GaitPlan> {
        let MotionConfig::Gait {
            initial_heading_deg,
            cadence_steps_min,
            stride_length_m,
            foot_flat_fraction,
            toe_off_pitch_deg,
            heel_strike_pitch_deg,
            clearance_m,
            roll_wobble_deg,
            yaw_wobble_deg,
            stance_roll_deg_s,
            impact_g,
            impact_deg_s,
            impact_tau_ms,
            impact_ring_hz,
            toe_off_share,
            stride_jitter,
            bouts,
            strides_per_bout,
            initial_still_s,
            pause_s,
            final_still_s,
            turn_deg,
            gravity_m_s2,
            ..
        } = m
        else {
            return None;
        };
        let n_issues = ck.issues.len();
        let mut within = |key: &str, v: f64, lo: f64, hi: f64, why: &str| {
            if !(v.is_finite() && v >= lo && v <= hi) {
                ck.push(
                    format!("motion.{key}"),
                    format!("must be in [{lo}, {hi}]{why}, got {v}"),
                );
            }
        };
        within(
            "cadence_steps_min",
            *cadence_steps_min,
            20.0,
            250.0,
            " (a slow walk to a sprint)",
        );
        within("stride_length_m", *stride_length_m, 0.05, 5.0, "");
        within(
            "foot_flat_fraction",
            *foot_flat_fraction,
            0.05,
            0.8,
            " (a stride needs a stance and a swing)",
        );
        within("toe_off_pitch_deg", *toe_off_pitch_deg, 0.0, 80.0, "");
        within(
            "heel_strike_pitch_deg",
            *heel_strike_pitch_deg,
            0.0,
            80.0,
            "",
        );
        within("clearance_m", *clearance_m, 0.0, 0.5, "");
        within("roll_wobble_deg", *roll_wobble_deg, -30.0, 30.0, "");
        within("yaw_wobble_deg", *yaw_wobble_deg, -30.0, 30.0, "");
        within("stance_roll_deg_s", *stance_roll_deg_s, -20.0, 20.0, "");
        within("impact_g", *impact_g, 0.0, 100.0, "");
        within("impact_deg_s", *impact_deg_s, 0.0, 5000.0, "");
        within("impact_tau_ms", *impact_tau_ms, 0.1, 100.0, "");
        within("impact_ring_hz", *impact_ring_hz, 1.0, 2000.0, "");
        within("toe_off_share", *toe_off_share, 0.0, 1.0, "");
        within("stride_jitter", *stride_jitter, 0.0, 0.2, "");
        within("initial_still_s", *initial_still_s, 0.0, 1e6, "");
        within("pause_s", *pause_s, 0.0, 1e6, "");
        within("final_still_s", *final_still_s, 0.0, 1e6, "");
        within("turn_deg", *turn_deg, -720.0, 720.0, "");
        ck.finite("motion.initial_heading_deg", *initial_heading_deg);
        ck.positive("motion.gravity_m_s2", *gravity_m_s2);
        if *bouts == 0 {
            ck.push("motion.bouts", "must be at least 1");
        }
        if *strides_per_bout == 0 {
            ck.push("motion.strides_per_bout", "must be at least 1");
        }
        if ck.issues.len() > n_issues {
            return None;
        }

        let period = 120.0 / cadence_steps_min;
        let ff_share = *foot_flat_fraction;
        let mut rng = Rng::new(JITTER_SEED);
        let mut jitter = || 1.0 + stride_jitter * rng.normal().clamp(-JITTER_CLAMP, JITTER_CLAMP);
        let mut plan = GaitPlan {
            phases: Vec::new(),
            impacts: Vec::new(),
            heel_strikes: Vec::new(),
            impact_accel: IMPACT_ACCEL_DIR.map(|d| d * impact_g * gravity_m_s2),
            impact_gyro: IMPACT_GYRO_DIR.map(|d| d * impact_deg_s.to_radians()),
            impact_tau_s: impact_tau_ms * 1e-3,
            impact_omega: 2.0 * PI * impact_ring_hz,
            impact_peak: 1.0,
            gravity_m_s2: *gravity_m_s2,
            duration_s: 0.0,
        };
        let mut p = Vector3::zeros();
        let mut psi = initial_heading_deg.to_radians();
        let mut t = 0.0;
        // Append a phase (none of zero length); its start time.
        let mut push =
            |plan: &mut GaitPlan, dur: f64, p0: Vector3<f64>, psi0: f64, roll0: f64, kind: Kind| {
                let t0 = t;
                if dur > 0.0 {
                    plan.phases.push(Phase {
                        t0_s: t0,
                        dur_s: dur,
                        p0,
                        psi0,
                        roll0,
                        kind,
                    });
                    t += dur;
                }
                t0
            };
        push(&mut plan, *initial_still_s, p, psi, 0.0, Kind::Still);
        for b in 0..*bouts {
            if b > 0 {
                push(&mut plan, *pause_s, p, psi, 0.0, Kind::Still);
                let n = (turn_deg.abs() / MAX_PIVOT_DEG).ceil() as usize;
                for _ in 0..n {
                    let alpha = turn_deg.to_radians() / n as f64;
                    let moving = (1.0 - ff_share) * period;
                    push(
                        &mut plan,
                        moving,
                        p,
                        psi,
                        0.0,
                        Kind::Pivot { angle_rad: alpha },
                    );
                    psi += alpha;
                    push(&mut plan, ff_share * period, p, psi, 0.0, Kind::Still);
                }
            }
            for _ in 0..*strides_per_bout {
                let (mt, ml, mp) = (jitter(), jitter(), jitter());
                let stride_s = period * mt;
                let ff = ff_share * stride_s;
                let moving = stride_s - ff;
                let roll_st = -stance_roll_deg_s.to_radians() * ff;
                push(
                    &mut plan,
                    ff,
                    p,
                    psi,
                    0.0,
                    Kind::FootFlat { roll_rad: roll_st },
                );
                let sw = Swing {
                    length_m: stride_length_m * ml,
                    t_a: MOVING_SHARES[0] * moving,
                    t_b: MOVING_SHARES[1] * moving,
                    t_c: MOVING_SHARES[2] * moving,
                    toe_off_rad: toe_off_pitch_deg.to_radians() * mp,
                    heel_strike_rad: heel_strike_pitch_deg.to_radians() * mp,
                    roll_amp_rad: roll_wobble_deg.to_radians(),
                    yaw_amp_rad: yaw_wobble_deg.to_radians(),
                    clearance_m: *clearance_m,
                };
                let t_sw = push(&mut plan, moving, p, psi, roll_st, Kind::Swing(sw));
                if *impact_g > 0.0 || *impact_deg_s > 0.0 {
                    if *toe_off_share > 0.0 {
                        plan.impacts.push((t_sw + sw.t_a, *toe_off_share));
                    }
                    plan.impacts.push((t_sw + sw.t_a + sw.t_b, 1.0));
                }
                plan.heel_strikes.push(t_sw + sw.t_a + sw.t_b);
                p += Vector3::new(psi.cos(), psi.sin(), 0.0) * sw.length_m;
            }
        }
        let t_end = push(&mut plan, *final_still_s, p, psi, 0.0, Kind::Still) + final_still_s;
        plan.duration_s = t_end;
        // The shape's peak, on a grid of τ/2000 (its relative error ≈ (ω·τ/2000)²/8 ≪ 1e-6).
        let n = (IMPACT_CUT_TAU * 2000.0) as usize;
        plan.impact_peak = (0..n)
            .map(|k| {
                plan.impact_shape(k as f64 * plan.impact_tau_s / 2000.0)
                    .abs()
            })
            .fold(0.0, f64::max);
        Some(plan)
    }

    /// Total length, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Local gravity, m/s².
    pub fn gravity_m_s2(&self) -> f64 {
        self.gravity_m_s2
    }

    /// Every phase as a span, in time order (a stride is a foot flat and a moving span).
    pub fn spans(&self) -> Vec<GaitSpan> {
        let mut out: Vec<GaitSpan> = Vec::with_capacity(self.phases.len());
        let mut after_pivot = false;
        for ph in &self.phases {
            let kind = match ph.kind {
                Kind::Still if after_pivot => SpanKind::Turning,
                Kind::Still => SpanKind::Standing,
                Kind::FootFlat { .. } => SpanKind::FootFlat,
                Kind::Swing(_) => SpanKind::Moving,
                Kind::Pivot { .. } => SpanKind::Turning,
            };
            after_pivot = matches!(ph.kind, Kind::Pivot { .. });
            out.push(GaitSpan {
                t0_s: ph.t0_s,
                t1_s: ph.t0_s + ph.dur_s,
                kind,
            });
        }
        out
    }

    /// Heel-strike instants, s.
    pub fn heel_strikes(&self) -> &[f64] {
        &self.heel_strikes
    }

    /// True when the walk has impact transients.
    pub fn has_impacts(&self) -> bool {
        !self.impacts.is_empty()
    }

    /// The pose at `t_s` (clamped to the record).
    pub fn pose(&self, t_s: f64) -> GaitPose {
        let i = self
            .phases
            .partition_point(|ph| ph.t0_s <= t_s)
            .saturating_sub(1);
        let ph = &self.phases[i];
        let u = (t_s - ph.t0_s).clamp(0.0, ph.dur_s);
        let mut pose = GaitPose {
            euler: [ph.roll0, 0.0, ph.psi0],
            euler_rate: [0.0; 3],
            p: ph.p0,
            v: Vector3::zeros(),
            a: Vector3::zeros(),
        };
        let z = Vector3::z();
        match ph.kind {
            Kind::Still => {}
            Kind::FootFlat { roll_rad } => {
                let s = step(u / ph.dur_s);
                pose.euler[0] = roll_rad * s[0];
                pose.euler_rate[0] = roll_rad * s[1] / ph.dur_s;
            }
            Kind::Pivot { angle_rad } => {
                let x = u / ph.dur_s;
                let s = step(x);
                let b = bump(x);
                pose.euler[2] = ph.psi0 + angle_rad * s[0];
                pose.euler_rate[2] = angle_rad * s[1] / ph.dur_s;
                let tt = ph.dur_s;
                pose.p -= z * (PIVOT_LIFT_M * b[0]);
                pose.v = -z * (PIVOT_LIFT_M * b[1] / tt);
                pose.a = -z * (PIVOT_LIFT_M * b[2] / (tt * tt));
            }
            Kind::Swing(sw) => {
                let tt = ph.dur_s;
                let x = u / tt;
                // Roll: the stance roll given back, plus the inversion bump.
                let (s, b) = (step(x), bump(x));
                pose.euler[0] = ph.roll0 * (1.0 - s[0]) + sw.roll_amp_rad * b[0];
                pose.euler_rate[0] = (-ph.roll0 * s[1] + sw.roll_amp_rad * b[1]) / tt;
                // Pitch, in three pieces.
                let (th, dth) = if u < sw.t_a {
                    let s = step(u / sw.t_a);
                    (-sw.toe_off_rad * s[0], -sw.toe_off_rad * s[1] / sw.t_a)
                } else if u < sw.t_a + sw.t_b {
                    let s = step((u - sw.t_a) / sw.t_b);
                    let span = sw.toe_off_rad + sw.heel_strike_rad;
                    (-sw.toe_off_rad + span * s[0], span * s[1] / sw.t_b)
                } else {
                    let s = step((u - sw.t_a - sw.t_b) / sw.t_c);
                    (
                        sw.heel_strike_rad * (1.0 - s[0]),
                        -sw.heel_strike_rad * s[1] / sw.t_c,
                    )
                };
                pose.euler[1] = th;
                pose.euler_rate[1] = dth;
                // Yaw wobble.
                let w = wobble(x);
                pose.euler[2] = ph.psi0 + sw.yaw_amp_rad * w[0];
                pose.euler_rate[2] = sw.yaw_amp_rad * w[1] / tt;
                // Position: forward until heel strike, lifted during the whole moving phase.
                let d = Vector3::new(ph.psi0.cos(), ph.psi0.sin(), 0.0);
                let tf = sw.t_a + sw.t_b;
                let f = step(u / tf);
                pose.p += d * (sw.length_m * f[0]) - z * (sw.clearance_m * b[0]);
                pose.v = d * (sw.length_m * f[1] / tf) - z * (sw.clearance_m * b[1] / tt);
                pose.a =
                    d * (sw.length_m * f[2] / (tf * tf)) - z * (sw.clearance_m * b[2] / (tt * tt));
            }
        }
        pose
    }

    /// Body rate (rad/s, no Earth rate), specific force (m/s²) and the pose at `t_s`.
    pub fn at(&self, t_s: f64) -> (Vector3<f64>, Vector3<f64>, GaitPose) {
        let pose = self.pose(t_s);
        let c_nb = pose.c_nb();
        let g_n = Vector3::new(0.0, 0.0, self.gravity_m_s2);
        let f = c_nb.inverse() * (pose.a - g_n);
        (pose.body_rate(), f, pose)
    }

    /// ẍ of the impact's deflection `dt` after it (module docs), not normalised.
    fn impact_shape(&self, dt: f64) -> f64 {
        let (tau, w) = (self.impact_tau_s, self.impact_omega);
        let s = dt / tau;
        let e = (-s).exp();
        let g = s * s * s * e;
        let g1 = (3.0 * s * s - s * s * s) * e / tau;
        let g2 = (6.0 * s - 6.0 * s * s + s * s * s) * e / (tau * tau);
        let (sn, cs) = (w * dt).sin_cos();
        let c = 1.0 + IMPACT_RING * sn;
        let c1 = IMPACT_RING * w * cs;
        let c2 = -IMPACT_RING * w * w * sn;
        g2 * c + 2.0 * g1 * c1 + g * c2
    }

    /// The impact transients at `t_s` on gx gy gz ax ay az (rad/s, m/s²): physical vibration
    /// (module docs).
    pub fn impact(&self, t_s: f64) -> [f64; N_CHANNELS] {
        let mut out = [0.0; N_CHANNELS];
        let cut = IMPACT_CUT_TAU * self.impact_tau_s;
        let i = self.impacts.partition_point(|(t, _)| *t <= t_s);
        // The last two impacts cover any overlap (a toe-off and its heel strike are a swing
        // apart; with very short strides and long transients they may ring into each other).
        for &(t_i, k) in self.impacts[i.saturating_sub(2)..i].iter() {
            let dt = t_s - t_i;
            if !(0.0..cut).contains(&dt) {
                continue;
            }
            let q = self.impact_shape(dt) / self.impact_peak;
            for a in 0..3 {
                out[a] += k * q * self.impact_gyro[a];
                out[3 + a] += k * q * self.impact_accel[a];
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
