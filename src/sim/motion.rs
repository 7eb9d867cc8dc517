//! True motion: the angular rate and specific force an ideal IMU would measure, in the body
//! frame (FRD: x forward, y right, z down), gravity included.
//!
//! **Static** at attitude (φ roll, θ pitch, ψ yaw; C_nb = R_z(ψ) R_y(θ) R_x(φ), NED):
//!   f_b = −C_bn g_n,  g_n = [0, 0, g]ᵀ,   ω_b = C_bn ω_ie_n,  ω_ie_n = Ω [cos L, 0, −sin L]ᵀ.
//!
//! **Drive** (a land vehicle without side-slip or body roll, on a flat non-rotating Earth;
//! the optional Earth rate is added to the gyros but its Coriolis term is neglected, as is the
//! transport rate v/R ≈ 3e-6 rad/s): body velocity v_b = [v, 0, 0]ᵀ, heading rate ψ̇ about the
//! vertical, road pitch θ = atan(grade). With roll φ = 0 the body rates are
//!   ω_b = [ −ψ̇ sin θ,  θ̇,  ψ̇ cos θ ]ᵀ                            (ZYX Euler kinematics)
//! and the specific force f_b = dv_b/dt + ω_b × v_b − g_b is
//!   f_b = [ v̇ + g sin θ,  ψ̇ cos θ · v,  −θ̇ v − g cos θ ]ᵀ,
//! i.e. longitudinal acceleration plus the slope's gravity, centripetal acceleration v·ω_z, and
//! the crest/dip term with gravity on z (Titterton & Weston, *Strapdown Inertial Navigation
//! Technology*, 2nd ed., ch. 3; Groves, *Principles of GNSS, Inertial, and Multisensor
//! Integrated Navigation Systems*, 2nd ed., §2.3 and §5.1).
//!
//! **Tumble** (still stops joined by rotations about body-fixed axes): see `super::tumble`.
//!
//! **Gait** (a foot-mounted IMU on a walking pedestrian): see `super::gait`.
//!
//! Transitions are jerk-limited: a rate that goes from 0 to its plateau R does so along
//! w(t) = (1 − cos(π t/τ))/2 over the edge time τ (and back down symmetrically), so
//! acceleration and yaw rate are continuous with bounded derivative (max jerk = π R / (2τ)).
//! The integral of w is closed-form, so speed and heading are exact at every instant:
//!   I(t) = t/2 − τ/(2π) sin(π t/τ)  on the rising edge,  total over the segment = T − τ.
//! A hill pitches the road along θ(t) = Θ (x − sin(2πx)/(2π)), x = t / transition (θ̇ is a
//! raised cosine, continuous with its derivative), holds Θ, and comes back the same way.

use super::gait::GaitPlan;
use super::scenario::{Checker, EARTH_RATE_RAD_S, MotionConfig, STANDARD_GRAVITY_M_S2, Segment};
use super::tumble::{TumblePlan, scheme_attitudes_deg};
use nalgebra::{Rotation3, Vector3};
use std::f64::consts::PI;

/// Largest horizontal (longitudinal or lateral) acceleration a car's tyres can hold, m/s²;
/// a scenario asking for more is physically inconsistent for a land vehicle.
pub const MAX_TYRE_ACCEL_M_S2: f64 = STANDARD_GRAVITY_M_S2;

/// The true kinematic state at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueMotion {
    /// Angular rate, body frame, rad/s.
    pub gyro_rad_s: Vector3<f64>,
    /// Specific force, body frame, m/s².
    pub accel_m_s2: Vector3<f64>,
    /// Forward speed, m/s.
    pub speed_m_s: f64,
    /// Heading, rad (unwrapped: a full right turn adds 2π).
    pub heading_rad: f64,
    /// Pitch (road grade angle), rad.
    pub pitch_rad: f64,
}

/// Jerk-limited plateau shape on [0, T] with edge time τ ≤ T/2: returns (w, ∫₀ᵗ w).
pub(super) fn plateau(t: f64, total_s: f64, edge_s: f64) -> (f64, f64) {
    let t = t.clamp(0.0, total_s);
    let rise = |u: f64| {
        (
            0.5 * (1.0 - (PI * u / edge_s).cos()),
            0.5 * u - edge_s / (2.0 * PI) * (PI * u / edge_s).sin(),
        )
    };
    if t < edge_s {
        rise(t)
    } else if t <= total_s - edge_s {
        (1.0, 0.5 * edge_s + (t - edge_s))
    } else {
        // Mirror of the rising edge: the area still to come is that of a rising edge of
        // length (T − t).
        let (w, rest) = rise(total_s - t);
        (w, (total_s - edge_s) - rest)
    }
}

/// Smooth step 0 → 1 over x ∈ [0, 1] with a raised-cosine derivative: (s, ds/dx).
fn smooth_step(x: f64) -> (f64, f64) {
    let x = x.clamp(0.0, 1.0);
    (
        x - (2.0 * PI * x).sin() / (2.0 * PI),
        1.0 - (2.0 * PI * x).cos(),
    )
}

/// A segment turned into closed-form profiles.
#[derive(Clone, Debug)]
struct PlannedSegment {
    t0_s: f64,
    duration_s: f64,
    v0_m_s: f64,
    v1_m_s: f64,
    speed_edge_s: f64,
    heading0_rad: f64,
    yaw_rate_rad_s: f64,
    yaw_edge_s: f64,
    grade_rad: f64,
    grade_transition_s: f64,
}

/// A drive turned into a time-indexed plan (one entry per segment, built once).
#[derive(Clone, Debug)]
pub struct DrivePlan {
    segs: Vec<PlannedSegment>,
    gravity_m_s2: f64,
    duration_s: f64,
}

/// The true trajectory of a scenario.
#[derive(Clone, Debug)]
pub enum Trajectory {
    Static {
        gyro_rad_s: Vector3<f64>,
        accel_m_s2: Vector3<f64>,
        heading_rad: f64,
        pitch_rad: f64,
        duration_s: f64,
    },
    Drive {
        plan: DrivePlan,
        /// Earth rate in NED, rad/s (zero when off).
        earth_n_rad_s: Vector3<f64>,
    },
    /// Still stops joined by rotations (`super::tumble`).
    Tumble {
        plan: TumblePlan,
        /// Earth rate in NED, rad/s (zero when off).
        earth_n_rad_s: Vector3<f64>,
    },
    /// A foot-mounted IMU on a walking pedestrian (`super::gait`).
    Gait {
        plan: GaitPlan,
        /// Earth rate in NED, rad/s (zero when off).
        earth_n_rad_s: Vector3<f64>,
    },
}

fn earth_rate_n(on: bool, latitude_deg: f64) -> Vector3<f64> {
    if !on {
        return Vector3::zeros();
    }
    let lat = latitude_deg.to_radians();
    Vector3::new(
        EARTH_RATE_RAD_S * lat.cos(),
        0.0,
        -EARTH_RATE_RAD_S * lat.sin(),
    )
}

impl Trajectory {
    /// Build from the motion config; issues are reported under `motion.`.
    pub(crate) fn build(m: &MotionConfig, ck: &mut Checker) -> Option<Trajectory> {
        match m {
            MotionConfig::Static {
                duration_s,
                roll_deg,
                pitch_deg,
                yaw_deg,
                gravity_m_s2,
                earth_rate,
                latitude_deg,
                vibration: _,
            } => {
                ck.positive("motion.duration_s", *duration_s);
                ck.finite("motion.roll_deg", *roll_deg);
                ck.finite("motion.pitch_deg", *pitch_deg);
                ck.finite("motion.yaw_deg", *yaw_deg);
                ck.positive("motion.gravity_m_s2", *gravity_m_s2);
                check_latitude(ck, *latitude_deg);
                let c_nb = Rotation3::from_euler_angles(
                    roll_deg.to_radians(),
                    pitch_deg.to_radians(),
                    yaw_deg.to_radians(),
                );
                let c_bn = c_nb.inverse();
                let g_n = Vector3::new(0.0, 0.0, *gravity_m_s2);
                Some(Trajectory::Static {
                    gyro_rad_s: c_bn * earth_rate_n(*earth_rate, *latitude_deg),
                    accel_m_s2: -(c_bn * g_n),
                    heading_rad: yaw_deg.to_radians(),
                    pitch_rad: pitch_deg.to_radians(),
                    duration_s: *duration_s,
                })
            }
            MotionConfig::Drive {
                initial_heading_deg,
                gravity_m_s2,
                earth_rate,
                latitude_deg,
                segments,
                vibration: _,
            } => {
                ck.finite("motion.initial_heading_deg", *initial_heading_deg);
                ck.positive("motion.gravity_m_s2", *gravity_m_s2);
                check_latitude(ck, *latitude_deg);
                let plan = DrivePlan::build(
                    segments,
                    initial_heading_deg.to_radians(),
                    *gravity_m_s2,
                    ck,
                )?;
                Some(Trajectory::Drive {
                    plan,
                    earth_n_rad_s: earth_rate_n(*earth_rate, *latitude_deg),
                })
            }
            MotionConfig::Tumble {
                scheme,
                attitudes_deg,
                dwell_s,
                rate_deg_s,
                edge_s,
                gravity_m_s2,
                earth_rate,
                latitude_deg,
                vibration: _,
            } => {
                check_latitude(ck, *latitude_deg);
                let att = match (scheme, attitudes_deg.is_empty()) {
                    (Some(s), true) => scheme_attitudes_deg(*s),
                    (None, false) => attitudes_deg.clone(),
                    _ => {
                        ck.push("motion", "give exactly one of scheme, attitudes_deg");
                        return None;
                    }
                };
                let plan =
                    TumblePlan::build(&att, *dwell_s, *rate_deg_s, *edge_s, *gravity_m_s2, ck)?;
                Some(Trajectory::Tumble {
                    plan,
                    earth_n_rad_s: earth_rate_n(*earth_rate, *latitude_deg),
                })
            }
            MotionConfig::Gait {
                earth_rate,
                latitude_deg,
                ..
            } => {
                check_latitude(ck, *latitude_deg);
                let plan = GaitPlan::build(m, ck)?;
                Some(Trajectory::Gait {
                    plan,
                    earth_n_rad_s: earth_rate_n(*earth_rate, *latitude_deg),
                })
            }
        }
    }

    /// Record length, s.
    pub fn duration_s(&self) -> f64 {
        match self {
            Trajectory::Static { duration_s, .. } => *duration_s,
            Trajectory::Drive { plan, .. } => plan.duration_s,
            Trajectory::Tumble { plan, .. } => plan.duration_s(),
            Trajectory::Gait { plan, .. } => plan.duration_s(),
        }
    }

    /// Physical transients that are real motion but not part of the smooth rigid-body motion
    /// (`true_*`), on gx gy gz ax ay az: the gait's impacts; zero for the other kinds. They go
    /// to the truth's `road_vibration_*` columns.
    pub fn transient(&self, t_s: f64) -> Option<[f64; 6]> {
        match self {
            Trajectory::Gait { plan, .. } if plan.has_impacts() => Some(plan.impact(t_s)),
            _ => None,
        }
    }

    /// The true motion at time `t_s` (clamped to the record).
    pub fn at(&self, t_s: f64) -> TrueMotion {
        match self {
            Trajectory::Static {
                gyro_rad_s,
                accel_m_s2,
                heading_rad,
                pitch_rad,
                ..
            } => TrueMotion {
                gyro_rad_s: *gyro_rad_s,
                accel_m_s2: *accel_m_s2,
                speed_m_s: 0.0,
                heading_rad: *heading_rad,
                pitch_rad: *pitch_rad,
            },
            Trajectory::Drive {
                plan,
                earth_n_rad_s,
            } => {
                let mut m = plan.at(t_s);
                if *earth_n_rad_s != Vector3::zeros() {
                    let c_nb = Rotation3::from_euler_angles(0.0, m.pitch_rad, m.heading_rad);
                    m.gyro_rad_s += c_nb.inverse() * earth_n_rad_s;
                }
                m
            }
            Trajectory::Tumble {
                plan,
                earth_n_rad_s,
            } => {
                let (c_nb, w) = plan.at(t_s);
                let (_, pitch, yaw) = c_nb.euler_angles();
                TrueMotion {
                    gyro_rad_s: w + c_nb.inverse() * earth_n_rad_s,
                    accel_m_s2: plan.specific_force(&c_nb),
                    speed_m_s: 0.0,
                    heading_rad: yaw,
                    pitch_rad: pitch,
                }
            }
            Trajectory::Gait {
                plan,
                earth_n_rad_s,
            } => {
                let (w, f, pose) = plan.at(t_s);
                TrueMotion {
                    gyro_rad_s: w + pose.c_nb().inverse() * earth_n_rad_s,
                    accel_m_s2: f,
                    speed_m_s: pose.v.norm(),
                    heading_rad: pose.euler[2],
                    pitch_rad: pose.euler[1],
                }
            }
        }
    }
}

fn check_latitude(ck: &mut Checker, lat: f64) {
    if !(lat.is_finite() && (-90.0..=90.0).contains(&lat)) {
        ck.push(
            "motion.latitude_deg",
            format!("must be in [-90, 90], got {lat}"),
        );
    }
}

impl DrivePlan {
    /// Plan the segments, checking each for physical consistency. Returns `None` when any
    /// segment is unusable (the issues say why).
    fn build(
        segments: &[Segment],
        heading0_rad: f64,
        gravity_m_s2: f64,
        ck: &mut Checker,
    ) -> Option<DrivePlan> {
        let n_issues = ck.issues.len();
        if segments.is_empty() {
            ck.push("motion.segments", "a drive needs at least one segment");
        }
        let mut segs = Vec::with_capacity(segments.len());
        let (mut t, mut v, mut psi) = (0.0_f64, 0.0_f64, heading0_rad);
        for (i, s) in segments.iter().enumerate() {
            let p = format!("motion.segments[{i}]");
            let mut seg = PlannedSegment {
                t0_s: t,
                duration_s: 0.0,
                v0_m_s: v,
                v1_m_s: v,
                speed_edge_s: 1.0,
                heading0_rad: psi,
                yaw_rate_rad_s: 0.0,
                yaw_edge_s: 1.0,
                grade_rad: 0.0,
                grade_transition_s: 1.0,
            };
            match s {
                Segment::Stop { duration_s } => {
                    ck.positive(&format!("{p}.duration_s"), *duration_s);
                    if v != 0.0 {
                        ck.push(
                            format!("{p}.kind"),
                            format!("stop while moving at {v} m/s: brake to 0 first"),
                        );
                    }
                    seg.duration_s = *duration_s;
                }
                Segment::Cruise { duration_s } => {
                    ck.positive(&format!("{p}.duration_s"), *duration_s);
                    seg.duration_s = *duration_s;
                }
                Segment::Accelerate {
                    to_speed_m_s,
                    duration_s,
                    jerk_time_s,
                } => {
                    ck.positive(&format!("{p}.duration_s"), *duration_s);
                    ck.positive(&format!("{p}.jerk_time_s"), *jerk_time_s);
                    ck.non_negative(&format!("{p}.to_speed_m_s"), *to_speed_m_s);
                    seg.duration_s = *duration_s;
                    seg.v1_m_s = *to_speed_m_s;
                    seg.speed_edge_s = jerk_time_s.min(0.5 * duration_s);
                    let peak = (to_speed_m_s - v).abs() / (duration_s - seg.speed_edge_s);
                    if peak > MAX_TYRE_ACCEL_M_S2 {
                        ck.push(
                            format!("{p}.duration_s"),
                            format!(
                                "peak acceleration {peak:.2} m/s² exceeds what tyres hold \
                                 ({MAX_TYRE_ACCEL_M_S2} m/s²): lengthen the segment"
                            ),
                        );
                    }
                    v = *to_speed_m_s;
                }
                Segment::Turn {
                    yaw_rate_deg_s,
                    angle_deg,
                    duration_s,
                    steer_time_s,
                } => {
                    ck.positive(&format!("{p}.steer_time_s"), *steer_time_s);
                    let tau = *steer_time_s;
                    let given = [yaw_rate_deg_s, angle_deg, duration_s]
                        .iter()
                        .filter(|x| x.is_some())
                        .count();
                    let mut rate = 0.0;
                    match (yaw_rate_deg_s, angle_deg, duration_s) {
                        _ if given != 2 => ck.push(
                            p.clone(),
                            "give exactly two of yaw_rate_deg_s, angle_deg, duration_s",
                        ),
                        (Some(r), None, Some(d)) => {
                            ck.positive(&format!("{p}.duration_s"), *d);
                            ck.finite(&format!("{p}.yaw_rate_deg_s"), *r);
                            seg.duration_s = *d;
                            seg.yaw_edge_s = tau.min(0.5 * d);
                            rate = r.to_radians();
                        }
                        (Some(r), Some(a), None) => {
                            if !(r.is_finite() && *r != 0.0) {
                                ck.push(
                                    format!("{p}.yaw_rate_deg_s"),
                                    "must be finite and non-zero",
                                );
                            } else if !(a.is_finite() && a * r > 0.0) {
                                ck.push(
                                    format!("{p}.angle_deg"),
                                    "must be finite, non-zero and of the same sign as yaw_rate_deg_s",
                                );
                            } else {
                                // Plateau time a/r plus one edge; if the turn is too short for
                                // full edges, use a pure raised cosine (T = 2τ', τ' = a/r).
                                let plateau_s = a / r;
                                let edge = tau.min(plateau_s);
                                seg.yaw_edge_s = edge;
                                seg.duration_s = plateau_s + edge;
                                rate = r.to_radians();
                            }
                        }
                        (None, Some(a), Some(d)) => {
                            ck.positive(&format!("{p}.duration_s"), *d);
                            ck.finite(&format!("{p}.angle_deg"), *a);
                            seg.duration_s = *d;
                            seg.yaw_edge_s = tau.min(0.5 * d);
                            rate = a.to_radians() / (d - seg.yaw_edge_s);
                        }
                        _ => unreachable!("exactly two of three options are set"),
                    }
                    if rate != 0.0 && v == 0.0 {
                        ck.push(
                            p.clone(),
                            "turn at standstill: a land vehicle cannot yaw without speed",
                        );
                    }
                    let lateral = (rate * v).abs();
                    if lateral > MAX_TYRE_ACCEL_M_S2 {
                        ck.push(
                            p.clone(),
                            format!(
                                "lateral acceleration {lateral:.2} m/s² exceeds what tyres hold \
                                 ({MAX_TYRE_ACCEL_M_S2} m/s²)"
                            ),
                        );
                    }
                    seg.yaw_rate_rad_s = rate;
                    psi += rate * (seg.duration_s - seg.yaw_edge_s);
                }
                Segment::Hill {
                    grade_percent,
                    duration_s,
                    transition_s,
                } => {
                    ck.positive(&format!("{p}.duration_s"), *duration_s);
                    ck.positive(&format!("{p}.transition_s"), *transition_s);
                    if !(grade_percent.is_finite() && grade_percent.abs() <= 40.0) {
                        ck.push(
                            format!("{p}.grade_percent"),
                            format!(
                                "must be within ±40 % (steepest paved roads), got {grade_percent}"
                            ),
                        );
                    }
                    if transition_s.is_finite()
                        && duration_s.is_finite()
                        && 2.0 * transition_s > *duration_s
                    {
                        ck.push(
                            format!("{p}.transition_s"),
                            "two transitions (in and out) must fit in duration_s",
                        );
                    }
                    if v == 0.0 {
                        ck.push(p.clone(), "hill at standstill: the vehicle must be moving");
                    }
                    seg.duration_s = *duration_s;
                    seg.grade_rad = (grade_percent / 100.0).atan();
                    seg.grade_transition_s = *transition_s;
                }
            }
            if !seg.duration_s.is_finite() || seg.duration_s <= 0.0 {
                seg.duration_s = 0.0;
            }
            t += seg.duration_s;
            segs.push(seg);
        }
        if ck.issues.len() > n_issues {
            return None;
        }
        Some(DrivePlan {
            segs,
            gravity_m_s2,
            duration_s: t,
        })
    }

    /// Total drive length, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Kinematic motion at `t_s` (no Earth rate).
    pub fn at(&self, t_s: f64) -> TrueMotion {
        // Segments are few (tens): a binary search per sample is cheap and keeps this pure.
        let i = self
            .segs
            .partition_point(|s| s.t0_s <= t_s)
            .saturating_sub(1);
        let s = &self.segs[i];
        let u = (t_s - s.t0_s).clamp(0.0, s.duration_s);
        let tt = s.duration_s;

        // Speed: v0 + A ∫w, with A = Δv / (T − τ) so that ∫₀ᵀ = Δv exactly.
        let (v, vdot) = if s.v1_m_s != s.v0_m_s {
            let a = (s.v1_m_s - s.v0_m_s) / (tt - s.speed_edge_s);
            let (w, iw) = plateau(u, tt, s.speed_edge_s);
            (s.v0_m_s + a * iw, a * w)
        } else {
            (s.v0_m_s, 0.0)
        };
        // Heading rate about the vertical and heading.
        let (psi_dot, psi) = if s.yaw_rate_rad_s != 0.0 {
            let (w, iw) = plateau(u, tt, s.yaw_edge_s);
            (s.yaw_rate_rad_s * w, s.heading0_rad + s.yaw_rate_rad_s * iw)
        } else {
            (0.0, s.heading0_rad)
        };
        // Road pitch and its rate.
        let (theta, theta_dot) = if s.grade_rad != 0.0 {
            let tr = s.grade_transition_s;
            if u < tr {
                let (st, ds) = smooth_step(u / tr);
                (s.grade_rad * st, s.grade_rad * ds / tr)
            } else if u <= tt - tr {
                (s.grade_rad, 0.0)
            } else {
                let (st, ds) = smooth_step((u - (tt - tr)) / tr);
                (s.grade_rad * (1.0 - st), -s.grade_rad * ds / tr)
            }
        } else {
            (0.0, 0.0)
        };
        let g = self.gravity_m_s2;
        let (sth, cth) = theta.sin_cos();
        TrueMotion {
            gyro_rad_s: Vector3::new(-psi_dot * sth, theta_dot, psi_dot * cth),
            accel_m_s2: Vector3::new(vdot + g * sth, psi_dot * cth * v, -theta_dot * v - g * cth),
            speed_m_s: v,
            heading_rad: psi,
            pitch_rad: theta,
        }
    }

    /// Segment boundaries (start times, s) and the speed planned at the end of each segment,
    /// for checks and plots.
    pub fn segment_ends(&self) -> Vec<(f64, f64)> {
        self.segs
            .iter()
            .map(|s| (s.t0_s + s.duration_s, s.v1_m_s))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateau_integral_is_continuous_and_totals_t_minus_tau() {
        // Closed form: ∫₀ᵀ w = T − τ; the integral must be continuous at both edges.
        let (tt, tau) = (5.0, 1.2);
        assert!((plateau(tt, tt, tau).1 - (tt - tau)).abs() < 1e-12);
        for x in [tau, tt - tau] {
            let a = plateau(x - 1e-9, tt, tau).1;
            let b = plateau(x + 1e-9, tt, tau).1;
            assert!((a - b).abs() < 1e-8, "jump at {x}: {a} vs {b}");
        }
        // Numerical integral of w matches I (midpoint rule, 1e5 steps: error ~1e-10).
        let n = 100_000;
        let h = tt / n as f64;
        let num: f64 = (0..n)
            .map(|k| plateau((k as f64 + 0.5) * h, tt, tau).0 * h)
            .sum();
        assert!((num - (tt - tau)).abs() < 1e-8);
    }

    /// One second at rest (g = 9.8 m/s², no roll), with Earth rate at `earth_rate_lat_deg` if given.
    fn static_at(pitch_deg: f64, yaw_deg: f64, earth_rate_lat_deg: Option<f64>) -> Trajectory {
        let m = MotionConfig::Static {
            duration_s: 1.0,
            roll_deg: 0.0,
            pitch_deg,
            yaw_deg,
            gravity_m_s2: 9.8,
            earth_rate: earth_rate_lat_deg.is_some(),
            latitude_deg: earth_rate_lat_deg.unwrap_or(0.0),
            vibration: vec![],
        };
        Trajectory::build(&m, &mut Checker::default()).unwrap()
    }

    #[test]
    fn level_static_reads_minus_g_on_z_in_frd() {
        let s = static_at(0.0, 30.0, None).at(0.3);
        assert_eq!(s.accel_m_s2, Vector3::new(0.0, 0.0, -9.8));
        assert_eq!(s.gyro_rad_s, Vector3::zeros());
    }

    #[test]
    fn nose_up_static_sees_gravity_forward_and_earth_rate_magnitude() {
        // Pitch 90° nose up: x points up, so f_x = +g; Earth rate magnitude is Ω for any
        // attitude, and at the pole it is all vertical (−x when x is up... i.e. |ω_x| = Ω).
        let s = static_at(90.0, 0.0, Some(90.0)).at(0.0);
        assert!((s.accel_m_s2.x - 9.8).abs() < 1e-12);
        assert!((s.gyro_rad_s.norm() - EARTH_RATE_RAD_S).abs() < 1e-18);
        assert!((s.gyro_rad_s.x.abs() - EARTH_RATE_RAD_S).abs() < 1e-15);
    }
}
