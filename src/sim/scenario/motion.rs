//! `[motion]`: the true motion of the sensor — static, a drive of segments, a tumble, a gait —
//! and the mechanical vibration modes every kind of motion can carry.

use super::{STANDARD_GRAVITY_M_S2, default_true};
use serde::Deserialize;

fn default_gravity() -> f64 {
    STANDARD_GRAVITY_M_S2
}

/// `MotionConfig`, every kind of which also takes the same four keys: `gravity_m_s2`,
/// `earth_rate`, `latitude_deg` (written after the kind's own leading keys) and `vibration`
/// (last). They are fields of each variant, not a `#[serde(flatten)]`ed table: with `flatten`
/// the files parse the same, but a misspelt key's error loses its "expected one of …" list.
macro_rules! motion_config {
    ($(
        $(#[$doc:meta])*
        $kind:ident { $($lead:tt)* } then { $($tail:tt)* }
    )*) => {
        /// The true motion of the sensor.
        #[derive(Debug, Clone, Deserialize, PartialEq)]
        #[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
        pub enum MotionConfig {
            $(
                $(#[$doc])*
                $kind {
                    $($lead)*
                    /// Local gravity magnitude, m/s².
                    #[serde(default = "default_gravity")]
                    gravity_m_s2: f64,
                    /// Add the Earth rotation rate to the gyros.
                    #[serde(default)]
                    earth_rate: bool,
                    /// Latitude for the Earth rate, deg.
                    #[serde(default)]
                    latitude_deg: f64,
                    $($tail)*
                    /// Mechanical vibration modes (bench, engine, road): real motion, see
                    /// [`VibrationMode`].
                    #[serde(default)]
                    vibration: Vec<VibrationMode>,
                },
            )*
        }
    };
}

motion_config! {
    /// At rest at a fixed attitude.
    Static {
        /// Record length, s.
        duration_s: f64,
        /// Attitude (ZYX Euler angles of the body in NED), deg.
        #[serde(default)]
        roll_deg: f64,
        #[serde(default)]
        pitch_deg: f64,
        #[serde(default)]
        yaw_deg: f64,
    } then {}
    /// A land-vehicle drive made of consecutive segments.
    Drive {
        /// Heading at the start, deg (0 = north, positive clockwise seen from above).
        #[serde(default)]
        initial_heading_deg: f64,
    } then {
        /// The drive, in order. The vehicle starts at rest.
        segments: Vec<Segment>,
    }
    /// Multi-position calibration (a hand or a fixture tumbling the IMU): still stops at a
    /// sequence of attitudes, each reached from the last by a jerk-limited rotation about one
    /// body-fixed axis, the IMU at the centre of rotation (no lever arm). Give either `scheme`
    /// or `attitudes_deg`.
    Tumble {
        /// Generated attitudes, visited nearest-neighbour first from level (yaw 0).
        #[serde(default)]
        scheme: Option<TumbleScheme>,
        /// Explicit attitudes, `[roll, pitch, yaw]` ZYX Euler angles in NED, deg.
        #[serde(default)]
        attitudes_deg: Vec<[f64; 3]>,
        /// Still time at each attitude, s.
        dwell_s: f64,
        /// Plateau rate of each rotation, deg/s.
        rate_deg_s: f64,
        /// Time over which the rate builds up (and dies down), s.
        #[serde(default = "default_jerk_time")]
        edge_s: f64,
    } then {}
    /// A foot-mounted IMU on a pedestrian (`super::gait`): walking bouts of strides (foot flat,
    /// heel-off, swing, heel strike, foot slap) separated by standing still, a turn in pivot
    /// steps between bouts, heel-strike and toe-off impacts as physical vibration.
    Gait {
        /// Heading of the first bout, deg (0 = north, positive clockwise seen from above).
        #[serde(default)]
        initial_heading_deg: f64,
        /// Steps per minute (both feet; one stride of the instrumented foot is two steps).
        #[serde(default = "default_cadence")]
        cadence_steps_min: f64,
        /// Distance the foot moves per stride, m.
        #[serde(default = "default_stride_length")]
        stride_length_m: f64,
        /// Share of each stride the foot lies flat (zero velocity).
        #[serde(default = "default_foot_flat_fraction")]
        foot_flat_fraction: f64,
        /// Plantar flexion at toe-off (the foot pitched toe-down by this much), deg.
        #[serde(default = "default_toe_off_pitch")]
        toe_off_pitch_deg: f64,
        /// Dorsiflexion at heel strike (toe-up), deg.
        #[serde(default = "default_heel_strike_pitch")]
        heel_strike_pitch_deg: f64,
        /// Highest lift of the IMU during the swing, m.
        #[serde(default = "default_clearance")]
        clearance_m: f64,
        /// Roll (inversion) bump during the swing, deg.
        #[serde(default = "default_roll_wobble")]
        roll_wobble_deg: f64,
        /// Yaw (toe-in / toe-out) wobble during the swing, deg.
        #[serde(default = "default_yaw_wobble")]
        yaw_wobble_deg: f64,
        /// Mean roll rate while the foot lies flat in a stride (pronation under load), deg/s;
        /// the roll is given back during the next swing.
        #[serde(default = "default_stance_roll")]
        stance_roll_deg_s: f64,
        /// Peak specific force of the heel-strike transient, g (0 = no impacts).
        #[serde(default = "default_impact_g")]
        impact_g: f64,
        /// Peak angular rate of the heel-strike transient, deg/s.
        #[serde(default = "default_impact_deg_s")]
        impact_deg_s: f64,
        /// Time constant of the transient's envelope, ms (its main pulse lasts about as long).
        #[serde(default = "default_impact_tau_ms")]
        impact_tau_ms: f64,
        /// Ringing frequency of the transient, Hz.
        #[serde(default = "default_impact_ring_hz")]
        impact_ring_hz: f64,
        /// Size of the toe-off transient relative to the heel strike's.
        #[serde(default = "default_toe_off_share")]
        toe_off_share: f64,
        /// Relative sd of each stride's period, length and pitch amplitudes (fixed by the
        /// scenario, not by the noise seed).
        #[serde(default = "default_stride_jitter")]
        stride_jitter: f64,
        /// Walking bouts.
        #[serde(default = "default_bouts")]
        bouts: u32,
        /// Strides per bout.
        #[serde(default = "default_strides_per_bout")]
        strides_per_bout: u32,
        /// Standing still before the first bout, s.
        #[serde(default = "default_initial_still")]
        initial_still_s: f64,
        /// Standing still between bouts (before the turn), s.
        #[serde(default = "default_pause")]
        pause_s: f64,
        /// Standing still after the last bout, s.
        #[serde(default = "default_final_still")]
        final_still_s: f64,
        /// Turn between bouts, deg (positive = right), in pivot steps of at most 90°.
        #[serde(default = "default_turn")]
        turn_deg: f64,
    } then {}
}

fn default_cadence() -> f64 {
    110.0
}
fn default_stride_length() -> f64 {
    1.4
}
fn default_foot_flat_fraction() -> f64 {
    0.35
}
fn default_toe_off_pitch() -> f64 {
    35.0
}
fn default_heel_strike_pitch() -> f64 {
    20.0
}
fn default_clearance() -> f64 {
    0.12
}
fn default_roll_wobble() -> f64 {
    4.0
}
fn default_yaw_wobble() -> f64 {
    3.0
}
fn default_stance_roll() -> f64 {
    0.8
}
fn default_impact_g() -> f64 {
    4.0
}
fn default_impact_deg_s() -> f64 {
    60.0
}
fn default_impact_tau_ms() -> f64 {
    6.0
}
fn default_impact_ring_hz() -> f64 {
    40.0
}
fn default_toe_off_share() -> f64 {
    0.3
}
fn default_stride_jitter() -> f64 {
    0.03
}
fn default_bouts() -> u32 {
    3
}
fn default_strides_per_bout() -> u32 {
    20
}
fn default_initial_still() -> f64 {
    10.0
}
fn default_pause() -> f64 {
    5.0
}
fn default_final_still() -> f64 {
    5.0
}
fn default_turn() -> f64 {
    90.0
}
fn default_jerk_time() -> f64 {
    1.0
}
fn default_hill_transition() -> f64 {
    4.0
}

impl MotionConfig {
    /// The vibration modes of any motion kind, and whether the motion has no speed (static or
    /// tumble or gait: `speed_ref_m_s` is meaningless there).
    pub fn vibration(&self) -> (&[VibrationMode], bool) {
        match self {
            MotionConfig::Static { vibration, .. }
            | MotionConfig::Tumble { vibration, .. }
            | MotionConfig::Gait { vibration, .. } => (vibration, true),
            MotionConfig::Drive { vibration, .. } => (vibration, false),
        }
    }
}

/// Which attitudes a generated tumble visits (`motion.scheme`).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum TumbleScheme {
    /// Gravity along ± each body axis (the classic six-position test).
    Faces6,
    /// The 26 directions from the centre of a cube to its faces, edges and corners.
    Cube26,
}

/// One piece of a drive. Every segment starts where the previous one ended (speed, heading);
/// transitions are jerk-limited (see `sim/motion.rs`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// Standing still (requires the vehicle to be at rest).
    Stop { duration_s: f64 },
    /// Change speed to `to_speed_m_s` over `duration_s` (also spelt `brake`).
    #[serde(alias = "brake")]
    Accelerate {
        to_speed_m_s: f64,
        duration_s: f64,
        /// Time over which the acceleration builds up (and dies down), s.
        #[serde(default = "default_jerk_time")]
        jerk_time_s: f64,
    },
    /// Constant speed, straight, level.
    Cruise { duration_s: f64 },
    /// A turn at constant speed; give exactly two of `yaw_rate_deg_s`, `angle_deg`, `duration_s`.
    /// Positive = right turn (clockwise from above, FRD z down).
    Turn {
        #[serde(default)]
        yaw_rate_deg_s: Option<f64>,
        #[serde(default)]
        angle_deg: Option<f64>,
        #[serde(default)]
        duration_s: Option<f64>,
        /// Time to build up (and release) the yaw rate, s.
        #[serde(default = "default_jerk_time")]
        steer_time_s: f64,
    },
    /// A hill at constant speed: the road pitches to `grade_percent` over `transition_s`, stays,
    /// and returns to level over `transition_s` at the end of the segment.
    Hill {
        /// Road grade, % (100 · rise / run); negative = downhill.
        grade_percent: f64,
        duration_s: f64,
        #[serde(default = "default_hill_transition")]
        transition_s: f64,
    },
}

/// A mechanical vibration mode: white noise through a resonant band-pass (poles at `freq_hz`
/// with damping `damping_ratio`, a zero at DC so the motion has no mean and no drift).
/// It is real motion, not sensor error: it appears in its own truth column `road_vibration_*`
/// and passes through the sensor errors (scale factor, misalignment, g-sensitivity, clipping).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VibrationMode {
    #[serde(default = "default_true")]
    pub enabled: bool,
    /// Resonance frequency, Hz (< Nyquist).
    pub freq_hz: f64,
    /// Damping ratio ζ, 0 < ζ < 1.
    pub damping_ratio: f64,
    /// RMS specific-force vibration per axis (x, y, z), m/s².
    #[serde(default)]
    pub accel_rms_m_s2: [f64; 3],
    /// RMS angular-rate vibration per axis, deg/s.
    #[serde(default)]
    pub gyro_rms_deg_s: [f64; 3],
    /// Drive only: the RMS values hold at and above this speed and scale down linearly below it
    /// to `idle_fraction` at rest (engine idling). Absent: constant amplitude.
    #[serde(default)]
    pub speed_ref_m_s: Option<f64>,
    /// Fraction of the amplitude left at standstill when `speed_ref_m_s` is set.
    #[serde(default)]
    pub idle_fraction: f64,
}
