//! The recordings and the reference filter's settings for them, and the IMU in the body frame.

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::nav::earth::euler_to_ctm;
use crate::nav::eskf::*;
use crate::sample::Sample;

/// Standard gravity the importer uses to turn g into m/s².
pub(super) const G0: f64 = 9.80665;

/// One recording of the navigation test and the reference filter's settings for it.
#[derive(Clone, Debug, Serialize)]
pub struct RecordSpec {
    pub name: String,
    pub imu_csv: PathBuf,
    pub pos: PathBuf,
    /// IMU → body rotation as roll, pitch, yaw, degrees.
    pub mount_rpy_deg: [f64; 3],
    /// IMU → antenna, body (forward, right, down), m.
    pub lever_arm_b: [f64; 3],
    /// Added to the IMU time stamps, s.
    pub t_off: f64,
    /// First outage start, s after the first GNSS epoch.
    pub start_coast: f64,
    /// The tool's `imu_noise_factors` for attitude, velocity, accel bias, gyro bias.
    pub noise_factors: [f64; 4],
    /// The stretch variant (c)'s models are fitted on (`imuprep fit --skip-s --train-s`), as the
    /// Python harness: drive the first 180 s, walk 88 s to the end (its RTK is float there).
    pub fit_skip_s: f64,
    pub fit_train_s: f64,
    /// The sensor: (c) also tries the models fitted on another record of the same sensor.
    pub sensor: String,
    /// Where the GNSS (and the scoring reference) comes from.
    pub gnss: GnssSource,
    /// The IMU file's accelerations were in g (the importer made them g × 9.80665; the filter
    /// reads them as g × local gravity, as the reference filter does); `false`: m/s² as is.
    pub accel_in_g: bool,
    /// Initial 1-σ of the gyro biases, °/s.
    pub init_gyro_bias_dps: f64,
    /// What heading and tilt at an outage's end are also scored against ([`super::attref`]).
    pub att_ref: AttRefSource,
}

/// An attitude reference independent of the filter, for heading and tilt errors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum AttRefSource {
    /// None: heading and tilt only against the filter's own raw no-outage run.
    None,
    /// Heading from the GNSS velocity's course over ground at fixed epochs whose horizontal
    /// speed is at least this (m/s); no tilt reference. For a car the course is the heading up
    /// to the side-slip and the IMU-to-body yaw the mounting leaves (a constant, removed as the
    /// median offset, [`super::attref`]).
    Course { min_speed_mps: f64 },
    /// comma2k19's pose orientation (heading and tilt) at the GNSS epochs, from the same rows
    /// as [`GnssSource::ReferencePose`], [`super::comma::read_pose_attitude`].
    Pose,
}

/// The GNSS a record's filter gets, which is also what its outages are scored against.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum GnssSource {
    /// An RTKLIB `.pos` solution (σ from the file, ×2 float, ×5 single; scored on fixed epochs).
    RtkPos,
    /// comma2k19's post-processed pose (`reference_pose.csv`: ECEF position and velocity at
    /// 20 Hz), every `every`-th epoch, with these σ (position north/east/down m, velocity
    /// m/s); all epochs count as fixed.
    ReferencePose {
        every: usize,
        pos_sd: [f64; 3],
        vel_sd: f64,
    },
}

/// The rtklibexplorer drive and walk in `data` (`../shared/data/real/rtklibexplorer_drive_walk`).
pub fn default_records(data: &Path) -> Vec<RecordSpec> {
    vec![
        RecordSpec {
            name: "drive".into(),
            imu_csv: data.join("drive_0708_imu.csv"),
            pos: data.join("drive_0708_gnss_rtk.pos"),
            mount_rpy_deg: [180.0, -6.79, 185.35],
            lever_arm_b: [0.0, 0.05, 0.0],
            t_off: -0.125,
            start_coast: 40.0,
            noise_factors: [1.0, 2.0, 4.0, 2.0],
            fit_skip_s: 0.0,
            fit_train_s: 180.0,
            sensor: "rtklibexplorer".into(),
            gnss: GnssSource::RtkPos,
            accel_in_g: true,
            init_gyro_bias_dps: 0.2,
            att_ref: AttRefSource::Course { min_speed_mps: 5.0 },
        },
        RecordSpec {
            name: "walk".into(),
            imu_csv: data.join("walk_0827_imu.csv"),
            pos: data.join("walk_0827_gnss_rtk.pos"),
            mount_rpy_deg: [180.0, 0.0, -90.0],
            lever_arm_b: [0.0, 0.05, 0.0],
            t_off: 0.0,
            start_coast: 25.0,
            noise_factors: [4.0, 4.0, 4.0, 4.0],
            fit_skip_s: 88.0,
            fit_train_s: 50.0,
            sensor: "rtklibexplorer".into(),
            gnss: GnssSource::RtkPos,
            accel_in_g: true,
            init_gyro_bias_dps: 0.2,
            // Handheld at 1.25 m/s: the device's yaw is not the walking course.
            att_ref: AttRefSource::None,
        },
    ]
}

/// comma2k19's 60-s highway segment (`../shared/data/real/comma2k19_car_segment`): the
/// phone-grade IMU (axes forward, right, down = body), GNSS = its post-processed pose at 4 Hz
/// (as RTK for the rtklibexplorer records: the same solution aids and scores), σ 0.1 m
/// horizontal, 0.2 m vertical, 0.05 m/s. Settings that the reference filter does not give for
/// this car are chosen here: the drive's noise factors, no lever arm (the pose is the camera's,
/// the IMU sits in the same unit), initial gyro-bias σ 5 °/s (the gyro's uncalibrated z bias is
/// 3.9 °/s, NOTES.txt). (c)'s models are fitted on the first 14 s; outages start at 16 s.
pub fn comma_record(dir: &Path) -> RecordSpec {
    RecordSpec {
        name: "comma2k19".into(),
        imu_csv: dir.join("imu.csv"),
        pos: dir.join("reference_pose.csv"),
        mount_rpy_deg: [0.0, 0.0, 0.0],
        lever_arm_b: [0.0, 0.0, 0.0],
        t_off: 0.0,
        start_coast: 16.0,
        noise_factors: [1.0, 2.0, 4.0, 2.0],
        fit_skip_s: 0.0,
        fit_train_s: 14.0,
        sensor: "comma EON".into(),
        gnss: GnssSource::ReferencePose {
            every: 5,
            pos_sd: [0.1, 0.1, 0.2],
            vel_sd: 0.05,
        },
        accel_in_g: false,
        init_gyro_bias_dps: 5.0,
        att_ref: AttRefSource::Pose,
    }
}

/// The reference filter's process noise as continuous densities: its datasheet values
/// (gyro 0.0038 °/s/√Hz, accel 70 µg/√Hz, accel bias 7 µg/√s, gyro bias 3.8e-5 °/s/√s) times
/// √(its nominal 100 Hz) times its per-state factor — the tool adds `(v·√rate·factor)²·Δt`.
pub fn reference_noise(f: &[f64; 4]) -> ImuNoise {
    let root_hz = 10.0;
    let ug = 1e-6 * G0;
    ImuNoise {
        gyro_psd: 0.0038f64.to_radians() * root_hz * f[0],
        accel_psd: 70.0 * ug * root_hz * f[1],
        accel_bias_rw: 7.0 * ug * root_hz * f[2],
        gyro_bias_rw: 3.8e-5f64.to_radians() * root_hz * f[3],
    }
}

/// The filter settings for a record (see module docs).
pub fn filter_config(spec: &RecordSpec, augmentation: Option<BiasAugmentation>) -> EskfConfig {
    EskfConfig {
        noise: reference_noise(&spec.noise_factors),
        init: InitSd {
            att: [2f64.to_radians(), 2f64.to_radians(), 100f64.to_radians()],
            vel: [0.05, 0.05, 0.1],
            pos: [0.05, 0.05, 0.1],
            accel_bias: 0.2,
            gyro_bias: spec.init_gyro_bias_dps.to_radians(),
        },
        lever_arm_b: spec.lever_arm_b,
        zupt: Some(ZuptConfig::REFERENCE),
        yaw_align_speed: Some(1.0),
        yaw_align_sd: 5f64.to_radians(),
        augmentation,
    }
}

/// IMU epochs in the body frame, GPST time (with the record's offset), SI units.
#[derive(Clone, Debug)]
pub struct BodyImu {
    pub t: Vec<f64>,
    pub w: Vec<Vector3<f64>>,
    pub f: Vec<Vector3<f64>>,
}

pub(super) fn mount(spec: &RecordSpec) -> Matrix3<f64> {
    let r = spec.mount_rpy_deg.map(f64::to_radians);
    euler_to_ctm(r[0], r[1], r[2])
}

/// Rotate into the body frame; accelerations were g × 9.80665 (the importer) and become
/// g × local gravity (the reference filter's reading of the sensor's g).
pub fn to_body(spec: &RecordSpec, samples: &[Sample], g_local: f64) -> BodyImu {
    let c = mount(spec);
    let k = if spec.accel_in_g { g_local / G0 } else { 1.0 };
    let mut b = BodyImu {
        t: Vec::with_capacity(samples.len()),
        w: Vec::with_capacity(samples.len()),
        f: Vec::with_capacity(samples.len()),
    };
    for s in samples {
        if !(s.gyro.iter().chain(s.accel.iter()).all(|v| v.is_finite())) {
            continue;
        }
        b.t.push(s.t_s() + spec.t_off);
        b.w.push(c * s.gyro);
        b.f.push(c * s.accel * k);
    }
    b
}
