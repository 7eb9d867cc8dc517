//! Tumble: the true motion of a multi-position calibration without a turntable (a hand or a
//! fixture turning the IMU from one resting attitude to the next).
//!
//! The record is a sequence of legs: a still dwell at attitude C_k (C_nb, body to NED), then a
//! rotation to C_{k+1} about the fixed body axis a of the relative rotation
//! R = C_kᵀ C_{k+1} = exp(θ [a]×) (axis-angle, θ ∈ [0, π]):
//!
//! ```text
//!   C_nb(t) = C_k · exp(α(t) [a]×),   ω_b = α̇(t) a,   f_b = −C_nbᵀ g_n,   g_n = [0, 0, g]ᵀ
//! ```
//!
//! (Ċ_nb = C_nb [ω_b]×, so a rotation about a body-fixed axis has a body rate along that axis.)
//! The IMU sits at the centre of rotation: no lever-arm (centripetal or tangential) term.
//! α̇ follows the drive's jerk-limited plateau (`motion::plateau`): it rises from 0 to the rate r
//! over the edge time τ along a raised cosine and comes back down the same way, so α(T) = θ with
//! T = θ/r + τ (τ shortened to θ/r for a short rotation). The last leg has no rotation.
//!
//! Generated schemes put the specific force along chosen body directions d (unit): at rest
//! f_b = g d needs C_nbᵀ e_z = −d, i.e. pitch = asin(d_x), roll = atan2(−d_y, −d_z), yaw 0.
//! They are visited nearest-neighbour first from level (d = −z), ties in list order, so each
//! rotation is short (gravity turns by 35–90° for `cube26`) and never a half turn.

use super::motion::plateau;
use super::scenario::{Checker, TumbleScheme};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};

/// One dwell and the rotation that follows it.
#[derive(Clone, Debug)]
struct Leg {
    /// Start of the dwell, s.
    t0_s: f64,
    dwell_s: f64,
    /// Attitude during the dwell (C_nb).
    c_nb: Rotation3<f64>,
    /// Rotation axis, body frame (unit; zero when there is no rotation).
    axis: Vector3<f64>,
    /// Plateau rate, rad/s.
    rate_rad_s: f64,
    /// Edge time, s.
    edge_s: f64,
    /// Rotation time, s (0 for the last leg).
    rot_s: f64,
}

/// A still stop of a tumble: its time span and attitude, for checks and tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TumbleStop {
    pub t0_s: f64,
    pub t1_s: f64,
    /// C_nb (body to NED).
    pub c_nb: Rotation3<f64>,
}

/// A tumble turned into a time-indexed plan (built once).
#[derive(Clone, Debug)]
pub struct TumblePlan {
    legs: Vec<Leg>,
    gravity_m_s2: f64,
    duration_s: f64,
}

/// The unit specific-force directions of a scheme, in list order.
pub fn scheme_directions(s: TumbleScheme) -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for i in -1i32..=1 {
        for j in -1i32..=1 {
            for k in -1i32..=1 {
                let n = i.abs() + j.abs() + k.abs();
                if n == 0 || (s == TumbleScheme::Faces6 && n != 1) {
                    continue;
                }
                out.push(Vector3::new(i as f64, j as f64, k as f64).normalize());
            }
        }
    }
    out
}

/// The scheme's attitudes `[roll, pitch, yaw]` (deg), in the order they are visited.
pub fn scheme_attitudes_deg(s: TumbleScheme) -> Vec<[f64; 3]> {
    let mut left = scheme_directions(s);
    let mut d = -Vector3::z();
    let mut out = Vec::with_capacity(left.len());
    while !left.is_empty() {
        // Nearest first (largest dot product); the first of equals wins.
        let mut best = 0;
        for (i, v) in left.iter().enumerate() {
            if v.dot(&d) > left[best].dot(&d) + 1e-12 {
                best = i;
            }
        }
        d = left.remove(best);
        let pitch = d.x.clamp(-1.0, 1.0).asin();
        // 0 − y, not −y: along ±x both are zero, and atan2(−0, −0) = −π would roll the stop by
        // a needless half turn.
        let roll = (0.0 - d.y).atan2(0.0 - d.z);
        out.push([roll.to_degrees(), pitch.to_degrees(), 0.0]);
    }
    out
}

/// Axis (unit, or zero for no rotation) and angle in [0, π] of a rotation, through its unit
/// quaternion: robust at a half turn, where the rotation matrix's antisymmetric part (what
/// `Rotation3::axis_angle` uses) vanishes and gives no axis.
fn axis_angle(r: &Rotation3<f64>) -> (Vector3<f64>, f64) {
    let q = UnitQuaternion::from_rotation_matrix(r);
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        (w, v) = (-w, -v);
    }
    let n = v.norm();
    if n == 0.0 {
        return (Vector3::zeros(), 0.0);
    }
    (v / n, 2.0 * n.atan2(w))
}

impl TumblePlan {
    /// Plan the legs; issues are reported under `motion.`. `None` when any value is unusable.
    pub(crate) fn build(
        attitudes_deg: &[[f64; 3]],
        dwell_s: f64,
        rate_deg_s: f64,
        edge_s: f64,
        gravity_m_s2: f64,
        ck: &mut Checker,
    ) -> Option<TumblePlan> {
        let n_issues = ck.issues.len();
        ck.positive("motion.dwell_s", dwell_s);
        ck.positive("motion.rate_deg_s", rate_deg_s);
        ck.positive("motion.edge_s", edge_s);
        ck.positive("motion.gravity_m_s2", gravity_m_s2);
        if attitudes_deg.is_empty() {
            ck.push(
                "motion.attitudes_deg",
                "a tumble needs at least one attitude",
            );
        }
        for (i, a) in attitudes_deg.iter().enumerate() {
            ck.finite3(&format!("motion.attitudes_deg[{i}]"), a);
        }
        if ck.issues.len() > n_issues {
            return None;
        }
        let rate = rate_deg_s.to_radians();
        let c: Vec<Rotation3<f64>> = attitudes_deg
            .iter()
            .map(|a| {
                Rotation3::from_euler_angles(
                    a[0].to_radians(),
                    a[1].to_radians(),
                    a[2].to_radians(),
                )
            })
            .collect();
        let mut legs = Vec::with_capacity(c.len());
        let mut t = 0.0;
        for (k, c_k) in c.iter().enumerate() {
            // No next attitude, or the same one again: no rotation.
            let (axis, angle) = c.get(k + 1).map_or((Vector3::zeros(), 0.0), |next| {
                axis_angle(&(c_k.inverse() * next))
            });
            let (edge, rot_s) = if angle > 0.0 {
                let plateau_s = angle / rate;
                let edge = edge_s.min(plateau_s);
                (edge, plateau_s + edge)
            } else {
                (edge_s, 0.0)
            };
            legs.push(Leg {
                t0_s: t,
                dwell_s,
                c_nb: *c_k,
                axis,
                rate_rad_s: rate,
                edge_s: edge,
                rot_s,
            });
            t += dwell_s + rot_s;
        }
        Some(TumblePlan {
            legs,
            gravity_m_s2,
            duration_s: t,
        })
    }

    /// Total length, s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Local gravity, m/s².
    pub fn gravity_m_s2(&self) -> f64 {
        self.gravity_m_s2
    }

    /// The still stops, in time order.
    pub fn stops(&self) -> Vec<TumbleStop> {
        self.legs
            .iter()
            .map(|l| TumbleStop {
                t0_s: l.t0_s,
                t1_s: l.t0_s + l.dwell_s,
                c_nb: l.c_nb,
            })
            .collect()
    }

    /// Attitude C_nb and body rate (rad/s, no Earth rate) at `t_s` (clamped to the record).
    pub fn at(&self, t_s: f64) -> (Rotation3<f64>, Vector3<f64>) {
        let i = self
            .legs
            .partition_point(|l| l.t0_s <= t_s)
            .saturating_sub(1);
        let l = &self.legs[i];
        let u = t_s - l.t0_s - l.dwell_s;
        if u <= 0.0 || l.rot_s == 0.0 {
            return (l.c_nb, Vector3::zeros());
        }
        let (w, iw) = plateau(u, l.rot_s, l.edge_s);
        let c = l.c_nb * Rotation3::from_scaled_axis(l.axis * (l.rate_rad_s * iw));
        (c, l.axis * (l.rate_rad_s * w))
    }

    /// Specific force in the body frame of attitude `c_nb`: −C_bn g_n.
    pub fn specific_force(&self, c_nb: &Rotation3<f64>) -> Vector3<f64> {
        -(c_nb.inverse() * Vector3::new(0.0, 0.0, self.gravity_m_s2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(att: &[[f64; 3]]) -> TumblePlan {
        TumblePlan::build(att, 5.0, 45.0, 0.5, 9.8, &mut Checker::default()).unwrap()
    }

    #[test]
    fn cube26_visits_every_direction_once_with_short_rotations() {
        let att = scheme_attitudes_deg(TumbleScheme::Cube26);
        assert_eq!(att.len(), 26);
        let p = plan(&att);
        let stops = p.stops();
        let dirs: Vec<Vector3<f64>> = stops
            .iter()
            .map(|s| p.specific_force(&s.c_nb) / 9.8)
            .collect();
        // Each scheme direction is some stop's specific-force direction (to rounding).
        for d in scheme_directions(TumbleScheme::Cube26) {
            assert!(dirs.iter().any(|x| (x - d).norm() < 1e-12), "{d:?}");
        }
        assert_eq!(scheme_directions(TumbleScheme::Faces6).len(), 6);
        // Level first: f = (0, 0, −g).
        assert!((dirs[0] - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        // Between consecutive stops the gravity direction turns by 35–90°: never a half turn,
        // never the same attitude twice.
        for w in dirs.windows(2) {
            let ang = w[0].dot(&w[1]).clamp(-1.0, 1.0).acos().to_degrees();
            assert!((35.0..=90.0 + 1e-9).contains(&ang), "{ang}");
        }
    }

    #[test]
    fn integrating_the_rate_reaches_the_next_attitude_and_f_follows_the_attitude() {
        // Attitudes far apart (up to a 180° roll): the body rate, integrated sample by sample
        // (midpoint rule at 1 kHz), reproduces C_nb(t) to the integration error, and C_nb(t)
        // lands on each next attitude at the end of each rotation.
        let att = [
            [0.0, 0.0, 0.0],
            [180.0, 0.0, 0.0],
            [180.0, 0.0, 30.0],
            [10.0, 80.0, -45.0],
            [-60.0, -30.0, 170.0],
        ];
        let p = plan(&att);
        let dt = 1e-3;
        let n = (p.duration_s() / dt).round() as usize;
        let mut c = p.at(0.0).0;
        let mut worst: f64 = 0.0;
        for k in 0..n {
            let (_, w) = p.at((k as f64 + 0.5) * dt);
            c *= Rotation3::from_scaled_axis(w * dt);
            let truth = p.at((k + 1) as f64 * dt).0;
            worst = worst.max((c.inverse() * truth).angle());
        }
        // Midpoint rule: error O(dt²) per step on a smooth rate; 1e-6 rad over ~30 s is loose.
        assert!(worst < 1e-6, "{worst}");
        for (s, a) in p.stops().iter().zip(&att) {
            let want = Rotation3::from_euler_angles(
                a[0].to_radians(),
                a[1].to_radians(),
                a[2].to_radians(),
            );
            assert!((s.c_nb.inverse() * want).angle() < 1e-12);
            // Still during the dwell: zero rate, |f| = g.
            let (c_mid, w_mid) = p.at(0.5 * (s.t0_s + s.t1_s));
            assert_eq!(w_mid, Vector3::zeros());
            assert!((p.specific_force(&c_mid).norm() - 9.8).abs() < 1e-12);
        }
    }

    #[test]
    fn a_scenario_gives_exactly_one_of_scheme_and_attitudes() {
        let head = "[sensor]\nsample_rate_hz = 100.0\n[motion]\nkind = \"tumble\"\n\
                    dwell_s = 2.0\nrate_deg_s = 30.0\n";
        let issues =
            |extra: &str| match crate::sim::Scenario::from_toml_str(&format!("{head}{extra}")) {
                Ok(_) => vec![],
                Err(crate::sim::SimError::Invalid(v)) => v,
                Err(e) => panic!("{e}"),
            };
        for extra in [
            "",
            "scheme = \"faces6\"\nattitudes_deg = [[0.0, 0.0, 0.0]]\n",
        ] {
            let v = issues(extra);
            assert!(
                v.iter()
                    .any(|i| i.path == "motion" && i.message.contains("exactly one")),
                "{v:?}"
            );
        }
        assert!(issues("scheme = \"faces6\"\n").is_empty());
        assert!(issues("attitudes_deg = [[0.0, 0.0, 0.0], [90.0, 0.0, 0.0]]\n").is_empty());
        // Six stops of 2 s and five rotations of at least 90° (30 deg/s plus a 1-s edge: ≥ 4 s);
        // before the half-turn fix one of them took no time at all.
        let scn =
            crate::sim::Scenario::from_toml_str(&format!("{head}scheme = \"faces6\"\n")).unwrap();
        let sim = crate::sim::Simulator::new(&scn, 0).unwrap();
        assert!(sim.trajectory().duration_s() >= 6.0 * 2.0 + 5.0 * 4.0 - 1e-9);
    }

    #[test]
    fn bad_values_are_reported_with_their_keys() {
        let mut ck = Checker::default();
        assert!(TumblePlan::build(&[], 0.0, -1.0, 0.5, 9.8, &mut ck).is_none());
        let paths: Vec<&str> = ck.issues.iter().map(|i| i.path.as_str()).collect();
        assert_eq!(
            paths,
            [
                "motion.dwell_s",
                "motion.rate_deg_s",
                "motion.attitudes_deg"
            ]
        );
    }
}
