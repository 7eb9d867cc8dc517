//! `imuprep navtest`: imuprep's own GNSS/INS filter ([`crate::nav::eskf`]) on the real
//! rtklibexplorer drive and walk, with simulated GNSS outages, fed (a) the raw IMU, (b) imuprep's
//! default-cleaned IMU (the embedded config's pipeline, run in-process), and (d) the raw IMU
//! with the filter's bias process augmented by a first-order Gauss–Markov part per axis whose σ
//! and correlation time come from imuprep's Allan terms ([`crate::analysis::allan_export::bias_model`])
//! of the recording's longest still stretch (the random-walk part keeps the reference's density);
//! plus, on the static benches, the drift of a free-inertial solution, raw against cleaned.
//!
//! **What is copied from the reference filter's setup** (rtklibexplorer's GNSS_IMU, its
//! `drive_config.py` / `walk_config.py`; values, not code): the IMU-to-body rotation, the lever
//! arm, the drive's IMU time offset (−0.125 s), the noise densities with the tool's
//! per-state factors and its per-step discretisation (`(v·√rate·factor)²` per second, i.e.
//! √100·factor times the datasheet density, see [`reference_noise`]), ZUPT/ZARU thresholds
//! (50 still epochs, 0.25 m/s², 0.25 °/s, σ 0.01 m/s and 0.01 °/s), the initial uncertainties,
//! the yaw alignment to the GNSS course above 1 m/s, GNSS σ from the `.pos` file (×2 float,
//! ×5 single), accelerations read in g and scaled by the local gravity. What differs: the initial
//! roll and pitch come from levelling the first second of IMU data (the tool starts level with
//! 10° σ); the still test runs on 10-epoch moving averages (the tool's input is low-passed at
//! 10 Hz by its converter, the IMU here is used as recorded); mechanisation in a local-level
//! NED frame (the tool: ECEF).
//!
//! **Outages** as the Python harness (`tests/reference/navtest/`, scheme (ii)): 10, 30 and 60 s,
//! start times `start_coast + i·3L/K` s after the first GNSS epoch for the smallest K that gives
//! ≥ 20 scorable outages up to 1 s before the GNSS ends; scored at the last RTK epoch the filter
//! did not get, which must be fixed. Each outage is a copy of the no-outage filter at its start
//! that runs without GNSS (ZUPT still active) to its end — one outage per run. Errors: the
//! antenna position against the RTK position (horizontal, vertical), and heading and tilt
//! against the raw no-outage run at the same epoch (the logs hold no independent attitude).

use std::fmt;
use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::analysis::{allan_export, allan_report, allan_terms::FitSettings};
use crate::config::Config;
use crate::frame::Descriptor;
use crate::nav::earth::{self, LocalFrame, euler_to_ctm};
use crate::nav::eskf::*;
use crate::nav::pos::{self, PosEpoch};
use crate::report::audit::{load_recording, run_config};
use crate::sample::Sample;

/// Standard gravity the importer uses to turn g into m/s².
const G0: f64 = 9.80665;
/// Outage lengths, s.
pub const LENGTHS: [f64; 3] = [10.0, 30.0, 60.0];
/// Minimum number of scored outages per length.
pub const MIN_STARTS: usize = 20;
/// Scored epoch: the last RTK epoch at or before the outage end minus this, s (as the harness).
const END_MARGIN: f64 = 0.02;

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
        },
    ]
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
            gyro_bias: 0.2f64.to_radians(),
        },
        lever_arm_b: spec.lever_arm_b,
        zupt: Some(ZuptConfig {
            window: 50,
            smooth: 10,
            accel_thresh: 0.25,
            gyro_thresh: 0.25f64.to_radians(),
            vel_sd: 0.01,
            rate_sd: 0.01f64.to_radians(),
        }),
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

fn mount(spec: &RecordSpec) -> Matrix3<f64> {
    let r = spec.mount_rpy_deg.map(f64::to_radians);
    euler_to_ctm(r[0], r[1], r[2])
}

/// Rotate into the body frame; accelerations were g × 9.80665 (the importer) and become
/// g × local gravity (the reference filter's reading of the sensor's g).
pub fn to_body(spec: &RecordSpec, samples: &[Sample], g_local: f64) -> BodyImu {
    let c = mount(spec);
    let k = g_local / G0;
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

/// One scheduled outage (GPST s) and its scored RTK epoch.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Outage {
    pub length_s: f64,
    /// s after the first GNSS epoch (the nominal start).
    pub start_rel_s: f64,
    pub start: f64,
    pub end: f64,
    /// Index of the scored RTK epoch.
    pub scored: usize,
}

/// The scored epoch of an outage (start, end] in GPST, if fixed.
fn scored_epoch(gnss: &[PosEpoch], start: f64, end: f64) -> Option<usize> {
    let k = gnss.partition_point(|e| e.t <= end - END_MARGIN);
    if k == 0 {
        return None;
    }
    let k = k - 1;
    (gnss[k].t > start && gnss[k].q == 1).then_some(k)
}

/// Outages of `length` on the harness's grid (module docs). Outage windows are in GPST; as in
/// the reference filter, whose outage flags are set on the IMU clock before its offset, they
/// are shifted by the record's `t_off`.
pub fn schedule(gnss: &[PosEpoch], spec: &RecordSpec, length: f64) -> Vec<Outage> {
    let (g0, g1) = (gnss[0].t, gnss[gnss.len() - 1].t);
    let t_min = spec.start_coast;
    let last = g1 - g0 - length - 1.0;
    if last < t_min {
        return vec![];
    }
    let mut best = vec![];
    for k in 1..100_000 {
        let step = 3.0 * length / k as f64;
        let n = ((last - t_min) / step + 1e-9).floor() as usize + 1;
        let ok: Vec<Outage> = (0..n)
            .filter_map(|i| {
                let s = t_min + step * i as f64;
                let (a, b) = (g0 + s + spec.t_off, g0 + s + length + spec.t_off);
                scored_epoch(gnss, a, b).map(|scored| Outage {
                    length_s: length,
                    start_rel_s: s,
                    start: a,
                    end: b,
                    scored,
                })
            })
            .collect();
        if ok.len() >= MIN_STARTS {
            return ok;
        }
        best = ok;
        if step < 0.01 {
            break;
        }
    }
    best
}

fn fix_of(e: &PosEpoch) -> Option<GnssFix> {
    let gain = match e.q {
        1 => 1.0,
        2 => 2.0,
        5 => 5.0,
        _ => return None,
    };
    Some(GnssFix {
        lat: e.lat,
        lon: e.lon,
        h: e.h,
        v: Vector3::new(e.v_neu[0], e.v_neu[1], -e.v_neu[2]),
        pos_sd: Vector3::new(e.sd[0], e.sd[1], e.sd[2]) * gain,
        vel_sd: e.sdv.map(|s| Vector3::new(s[0], s[1], s[2]) * gain),
    })
}

/// Errors at the end of one outage.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct OutageError {
    pub length_s: f64,
    pub start_rel_s: f64,
    pub horiz_m: f64,
    pub vert_m: f64,
    pub heading_deg: f64,
    pub tilt_deg: f64,
}

/// What one filter run over a record produced.
#[derive(Clone, Debug)]
pub struct RunResult {
    pub errors: Vec<OutageError>,
    /// Attitude (roll, pitch, yaw) of the no-outage filter at each GNSS epoch it processed.
    pub attitude_at_epoch: Vec<Option<Vector3<f64>>>,
    pub stats: EskfStats,
    /// Median gyro bias estimate over the GNSS epochs, body axes, °/s.
    pub median_gyro_bias_dps: [f64; 3],
}

fn wrap_deg(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

/// Run the filter over the record: the no-outage filter, and a copy for each outage.
/// `att_ref`: the attitude reference for heading and tilt (`None`: this run's own).
pub fn run_filter(
    cfg: &EskfConfig,
    imu: &BodyImu,
    gnss: &[PosEpoch],
    outages: &[Outage],
    att_ref: Option<&[Option<Vector3<f64>>]>,
) -> Result<RunResult, String> {
    let g0 = gnss[0].t;
    let i0 = imu.t.partition_point(|&t| t < g0);
    let n_level = imu.t[i0..].partition_point(|&t| t < imu.t[i0.min(imu.t.len() - 1)] + 1.0);
    if imu.t.len() < i0 + 100 || n_level < 10 {
        return Err("fewer than 100 IMU epochs after the first GNSS epoch".into());
    }
    let f_mean = imu.f[i0..i0 + n_level].iter().sum::<Vector3<f64>>() / n_level as f64;
    let (roll, pitch) = level(&f_mean);
    let mut j = gnss.partition_point(|e| e.t <= imu.t[i0]).max(1) - 1;
    let e0 = &gnss[j];
    let nav0 = NavState {
        lat: e0.lat,
        lon: e0.lon,
        h: e0.h,
        v: Vector3::new(e0.v_neu[0], e0.v_neu[1], -e0.v_neu[2]),
        c_bn: euler_to_ctm(roll, pitch, 0.0).transpose(),
    };
    let mut kf = Eskf::new(cfg.clone(), nav0);
    let l = Vector3::from(cfg.lever_arm_b);
    // Put the antenna, not the IMU, at the first fix.
    let (la, lo, ha) = kf.antenna();
    kf.nav.lat -= la - e0.lat;
    kf.nav.lon -= lo - e0.lon;
    kf.nav.h -= ha - e0.h;
    let _ = l;
    let frame = LocalFrame::new(gnss[0].lat, gnss[0].lon, gnss[0].h);
    let mut order: Vec<usize> = (0..outages.len()).collect();
    order.sort_by(|&a, &b| outages[a].start.total_cmp(&outages[b].start));
    let mut next_outage = 0;
    let mut coasting: Vec<(usize, Eskf)> = vec![];
    let mut errors = vec![];
    let mut att = vec![None; gnss.len()];
    let mut bias_hist: Vec<Vector3<f64>> = vec![];
    j += 1;
    for i in i0..imu.t.len() {
        let dt = if i > i0 { imu.t[i] - imu.t[i - 1] } else { 0.0 };
        if !(0.0..1.0).contains(&dt) {
            return Err(format!("IMU time step {dt} s at epoch {i}"));
        }
        kf.propagate(dt, &imu.w[i], &imu.f[i]);
        for (_, c) in coasting.iter_mut() {
            c.propagate(dt, &imu.w[i], &imu.f[i]);
        }
        while j < gnss.len() && gnss[j].t <= imu.t[i] {
            let e = &gnss[j];
            // Outages starting before this epoch: a copy of the filter before the update.
            while next_outage < order.len() && outages[order[next_outage]].start < e.t {
                coasting.push((order[next_outage], kf.clone()));
                next_outage += 1;
            }
            att[j] = Some(kf.nav.euler());
            let mut k = 0;
            while k < coasting.len() {
                let o = &outages[coasting[k].0];
                if o.scored == j {
                    let c = &coasting[k].1;
                    let (la, lo, ha) = c.antenna();
                    // Back from the IMU epoch to the GNSS epoch along the velocity.
                    let p = frame.ned(la, lo, ha) - c.antenna_velocity() * (imu.t[i] - e.t);
                    let d = p - frame.ned(e.lat, e.lon, e.h);
                    let r = att_ref.and_then(|a| a[j]).unwrap_or(kf.nav.euler());
                    let da = (c.nav.euler() - r).map(|x| wrap_deg(x.to_degrees()));
                    errors.push(OutageError {
                        length_s: o.length_s,
                        start_rel_s: o.start_rel_s,
                        horiz_m: d.xy().norm(),
                        vert_m: d[2].abs(),
                        heading_deg: da[2].abs(),
                        tilt_deg: da[0].hypot(da[1]),
                    });
                    coasting.swap_remove(k);
                } else if e.t >= o.end {
                    coasting.swap_remove(k);
                } else {
                    k += 1;
                }
            }
            if let Some(fix) = fix_of(e) {
                kf.update_gnss(&fix);
                bias_hist.push(kf.gyro_bias());
            }
            j += 1;
        }
    }
    let median_gyro_bias_dps = [0, 1, 2].map(|a| {
        let mut v: Vec<f64> = bias_hist.iter().map(|b| b[a].to_degrees()).collect();
        percentile(&mut v, 50.0)
    });
    Ok(RunResult {
        errors,
        attitude_at_epoch: att,
        stats: kf.stats,
        median_gyro_bias_dps,
    })
}

/// numpy's default ("linear") percentile; NaN for an empty slice.
pub fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let x = (v.len() - 1) as f64 * p / 100.0;
    let (lo, hi) = (x.floor() as usize, x.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (x - lo as f64)
}

/// Median and 95th percentile of one error over a variant's outages of one length.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub record: String,
    pub variant: String,
    pub length_s: f64,
    pub outages: usize,
    pub horiz_median_m: f64,
    pub horiz_p95_m: f64,
    pub vert_median_m: f64,
    pub vert_p95_m: f64,
    pub heading_median_deg: f64,
    pub heading_p95_deg: f64,
    pub tilt_median_deg: f64,
}

fn rows(record: &str, variant: &str, errs: &[OutageError]) -> Vec<Row> {
    LENGTHS
        .iter()
        .map(|&l| {
            let e: Vec<&OutageError> = errs.iter().filter(|e| e.length_s == l).collect();
            let col = |f: fn(&OutageError) -> f64| e.iter().map(|x| f(x)).collect::<Vec<_>>();
            let (mut h, mut v, mut hd, mut t) = (
                col(|x| x.horiz_m),
                col(|x| x.vert_m),
                col(|x| x.heading_deg),
                col(|x| x.tilt_deg),
            );
            Row {
                record: record.into(),
                variant: variant.into(),
                length_s: l,
                outages: e.len(),
                horiz_median_m: percentile(&mut h, 50.0),
                horiz_p95_m: percentile(&mut h, 95.0),
                vert_median_m: percentile(&mut v, 50.0),
                vert_p95_m: percentile(&mut v, 95.0),
                heading_median_deg: percentile(&mut hd, 50.0),
                heading_p95_deg: percentile(&mut hd, 95.0),
                tilt_median_deg: percentile(&mut t, 50.0),
            }
        })
        .collect()
}

/// The Gauss–Markov part of variant (d), per body axis, with where it came from.
#[derive(Clone, Debug, Serialize)]
pub struct AugmentationSource {
    /// Still stretch the Allan terms were fitted on, s from the IMU start.
    pub still_from_s: f64,
    pub still_to_s: f64,
    pub augmentation: BiasAugmentation,
    /// Per IMU channel (gx gy gz ax ay az): correlation time s, σ (rad/s or m/s²), B resolved.
    pub channels: Vec<(String, f64, f64, bool)>,
}

/// Allan terms of the record's longest still stretch (consecutive GNSS epochs slower than
/// 0.3 m/s, less 1 s at either end; at least 10 s) → a Gauss–Markov bias per body axis.
pub fn augmentation_from_allan(
    spec: &RecordSpec,
    samples: &[Sample],
    rate: f64,
    gnss: &[PosEpoch],
) -> Result<AugmentationSource, String> {
    let t_imu0 = samples[0].t_s() + spec.t_off;
    let t_imu1 = samples[samples.len() - 1].t_s() + spec.t_off;
    let mut best = (0.0, 0.0);
    let mut run_start: Option<f64> = None;
    for (k, e) in gnss.iter().enumerate() {
        let still = e.v_neu[0].hypot(e.v_neu[1]) < 0.3;
        let last = k + 1 == gnss.len();
        match (still, run_start) {
            (true, None) => run_start = Some(e.t),
            (false, Some(a)) | (true, Some(a)) if !still || last => {
                let (a, b) = (a.max(t_imu0) + 1.0, e.t.min(t_imu1) - 1.0);
                if b - a > best.1 - best.0 {
                    best = (a, b);
                }
                run_start = None;
            }
            _ => {}
        }
    }
    let (from_s, to_s) = (best.0 - t_imu0, best.1 - t_imu0);
    if to_s - from_s < 10.0 {
        return Err(format!(
            "no still stretch of 10 s or more for Allan terms (longest {:.1} s)",
            to_s - from_s
        ));
    }
    let (i0, i1) = (
        (from_s * rate) as usize,
        ((to_s * rate) as usize).min(samples.len()),
    );
    let rep = allan_report::allan_report(
        &spec.name,
        &samples[i0..i1],
        rate,
        &[0, 1, 2, 3, 4, 5],
        &FitSettings::default(),
    )
    .map_err(|e| e.to_string())?;
    let (_, notes) = allan_export::bias_model(&rep);
    if notes.len() != 6 {
        return Err(format!("Allan terms for {} of 6 channels", notes.len()));
    }
    let c = mount(spec);
    // The mounting is an axis permutation with signs plus a few degrees: each body axis takes
    // the IMU axis it is closest to.
    let pick = |body: usize, off: usize| {
        let a = (0..3)
            .max_by(|&x, &y| c[(body, x)].abs().total_cmp(&c[(body, y)].abs()))
            .unwrap_or(body);
        let nt = &notes[off + a];
        GaussMarkov {
            sigma: nt.sigma_gm,
            tc_s: nt.tc_s,
        }
    };
    let aug = BiasAugmentation {
        gyro: [0, 1, 2].map(|b| pick(b, 0)),
        accel: [0, 1, 2].map(|b| pick(b, 3)),
    };
    Ok(AugmentationSource {
        still_from_s: from_s,
        still_to_s: to_s,
        augmentation: aug,
        channels: notes
            .iter()
            .map(|n| (n.channel.clone(), n.tc_s, n.sigma_gm, !n.b_is_bound))
            .collect(),
    })
}

/// One record's results.
#[derive(Clone, Debug, Serialize)]
pub struct RecordResult {
    pub name: String,
    pub imu_epochs: usize,
    pub gnss_epochs: usize,
    pub fixed_epochs: usize,
    pub duration_s: f64,
    /// Per length: count, first and last start (s after the first GNSS epoch), spacing.
    pub schedule: Vec<(f64, usize, f64, f64, f64)>,
    pub rows: Vec<Row>,
    pub outages: Vec<(String, OutageError)>,
    pub augmentation: Option<AugmentationSource>,
    pub augmentation_error: Option<String>,
    /// Variant → (ZUPT updates, median gyro bias estimate °/s body axes).
    pub filter: Vec<(String, usize, [f64; 3])>,
    /// imuprep (b): samples changed, mean (out − in) gyro °/s in body axes.
    pub cleaned_mean_change_dps: [f64; 3],
}

/// Run the three variants on one record.
pub fn run_record(spec: &RecordSpec, cfg: &Config) -> Result<RecordResult, String> {
    let (desc, raw) = load_recording(&spec.imu_csv)?;
    let gnss = pos::read(&spec.pos).map_err(|e| e.to_string())?;
    let g_local = earth::gravity(gnss[0].lat, gnss[0].h);
    let cleaned = clean(cfg, &desc, &raw)?;
    let outages: Vec<Outage> = LENGTHS
        .iter()
        .flat_map(|&l| schedule(&gnss, spec, l))
        .collect();
    let schedule_summary = LENGTHS
        .iter()
        .map(|&l| {
            let s: Vec<f64> = outages
                .iter()
                .filter(|o| o.length_s == l)
                .map(|o| o.start_rel_s)
                .collect();
            let step = if s.len() > 1 { s[1] - s[0] } else { f64::NAN };
            (
                l,
                s.len(),
                s.first().copied().unwrap_or(f64::NAN),
                s.last().copied().unwrap_or(f64::NAN),
                step,
            )
        })
        .collect();
    let raw_b = to_body(spec, &raw, g_local);
    let clean_b = to_body(spec, &cleaned, g_local);
    let base = filter_config(spec, None);
    let a = run_filter(&base, &raw_b, &gnss, &outages, None)?;
    let att_ref = a.attitude_at_epoch.clone();
    let b = run_filter(&base, &clean_b, &gnss, &outages, Some(&att_ref))?;
    let (aug, aug_err) = match augmentation_from_allan(spec, &raw, desc.sample_rate_hz, &gnss) {
        Ok(a) => (Some(a), None),
        Err(e) => (None, Some(e)),
    };
    let d = match &aug {
        Some(src) => Some(run_filter(
            &filter_config(spec, Some(src.augmentation)),
            &raw_b,
            &gnss,
            &outages,
            Some(&att_ref),
        )?),
        None => None,
    };
    let mut rows_all = rows(&spec.name, "(a) raw", &a.errors);
    rows_all.extend(rows(&spec.name, "(b) imuprep default", &b.errors));
    let mut all = vec![];
    let mut filt = vec![];
    for (v, r) in [("(a) raw", &a), ("(b) imuprep default", &b)] {
        all.extend(r.errors.iter().map(|e| (v.to_string(), *e)));
        filt.push((v.to_string(), r.stats.zupt_updates, r.median_gyro_bias_dps));
    }
    if let Some(d) = &d {
        let v = "(d) raw, Allan GM bias model";
        rows_all.extend(rows(&spec.name, v, &d.errors));
        all.extend(d.errors.iter().map(|e| (v.to_string(), *e)));
        filt.push((v.to_string(), d.stats.zupt_updates, d.median_gyro_bias_dps));
    }
    let n = raw_b.w.len().min(clean_b.w.len()).max(1);
    let mut chg = [0.0; 3];
    for i in 0..n {
        for (a, c) in chg.iter_mut().enumerate() {
            *c += (clean_b.w[i][a] - raw_b.w[i][a]).to_degrees() / n as f64;
        }
    }
    Ok(RecordResult {
        name: spec.name.clone(),
        imu_epochs: raw.len(),
        gnss_epochs: gnss.len(),
        fixed_epochs: gnss.iter().filter(|e| e.q == 1).count(),
        duration_s: gnss[gnss.len() - 1].t - gnss[0].t,
        schedule: schedule_summary,
        rows: rows_all,
        outages: all,
        augmentation: aug,
        augmentation_error: aug_err,
        filter: filt,
        cleaned_mean_change_dps: chg,
    })
}

/// `cfg`'s pipeline over the samples, in-process.
pub fn clean(cfg: &Config, desc: &Descriptor, raw: &[Sample]) -> Result<Vec<Sample>, String> {
    run_config(cfg, desc, raw)
}

/// Free-inertial drift on a static bench: per window length, over windows starting every
/// `hop` seconds.
#[derive(Clone, Debug, Serialize)]
pub struct DriftRow {
    pub bench: String,
    pub variant: String,
    pub window_s: f64,
    pub windows: usize,
    pub horiz_pos_median_m: f64,
    pub horiz_pos_p95_m: f64,
    pub horiz_vel_median_m_s: f64,
    pub horiz_vel_p95_m_s: f64,
}

/// Seconds at the start of each static window used to level (and, for the calibrated
/// variant, to take the gyro mean); the drift is measured over the `window_s` after them.
pub const STATIC_ALIGN_S: f64 = 10.0;

/// Free-inertial drift of `samples` (static; equally spaced at `rate`), windows every `hop_s`
/// from `skip_s`: each starts at rest after [`STATIC_ALIGN_S`] s of alignment — levelled from
/// that span's mean specific force, yaw 0, gravity set to its mean magnitude, and with
/// `calibrate_gyro` its mean gyro subtracted — then runs free for `window_s` without Earth rate
/// (a bench's latitude and heading are unknown; the Earth rate stays in the data as part of the
/// gyro bias). Returns the horizontal position and velocity at each window's end.
pub fn static_drift(
    samples: &[Sample],
    rate: f64,
    window_s: f64,
    hop_s: f64,
    skip_s: f64,
    calibrate_gyro: bool,
) -> Vec<(f64, f64)> {
    let dt = 1.0 / rate;
    let (nw, nh, n0, na) = (
        (window_s * rate).round() as usize,
        (hop_s * rate).round() as usize,
        (skip_s * rate).round() as usize,
        (STATIC_ALIGN_S * rate).round() as usize,
    );
    let mut out = vec![];
    let mut s0 = n0;
    while s0 + na + nw <= samples.len() {
        let win = &samples[s0..s0 + na + nw];
        s0 += nh;
        if win
            .iter()
            .any(|s| !s.accel.iter().chain(s.gyro.iter()).all(|v| v.is_finite()))
        {
            continue;
        }
        let f_mean = win[..na].iter().map(|s| s.accel).sum::<Vector3<f64>>() / na as f64;
        let w_mean = if calibrate_gyro {
            win[..na].iter().map(|s| s.gyro).sum::<Vector3<f64>>() / na as f64
        } else {
            Vector3::zeros()
        };
        let (roll, pitch) = level(&f_mean);
        // Height chosen so that the model's gravity equals the measured magnitude.
        let lat = 0.0;
        let h = (earth::gravity(lat, 0.0) - f_mean.norm()) / 3.086e-6;
        let mut nav = NavState {
            lat,
            lon: 0.0,
            h,
            v: Vector3::zeros(),
            c_bn: euler_to_ctm(roll, pitch, 0.0).transpose(),
        };
        let start = nav;
        for s in &win[na..] {
            nav.mechanise(dt, &(s.gyro - w_mean), &s.accel, false);
        }
        let (rn, re) = earth::radii(lat);
        let dn = (nav.lat - start.lat) * (rn + h);
        let de = (nav.lon - start.lon) * (re + h) * lat.cos();
        out.push((dn.hypot(de), nav.v.xy().norm()));
    }
    out
}

/// Drift rows for one bench, raw and cleaned.
pub fn run_bench(
    name: &str,
    path: &Path,
    cfg: &Config,
    skip_s: f64,
) -> Result<Vec<DriftRow>, String> {
    let (desc, raw) = load_recording(path)?;
    let rate = desc.sample_rate_hz;
    if rate.is_nan() || rate <= 0.0 {
        return Err(format!("{}: no sample rate", path.display()));
    }
    let cleaned = clean(cfg, &desc, &raw)?;
    let mut out = vec![];
    for (variant, data, cal) in [
        ("raw", &raw, false),
        ("raw, gyro mean of the alignment removed", &raw, true),
        ("imuprep default", &cleaned, false),
    ] {
        for w in [60.0, 300.0] {
            let r = static_drift(data, rate, w, w, skip_s, cal);
            let mut p: Vec<f64> = r.iter().map(|x| x.0).collect();
            let mut v: Vec<f64> = r.iter().map(|x| x.1).collect();
            out.push(DriftRow {
                bench: name.into(),
                variant: variant.into(),
                window_s: w,
                windows: r.len(),
                horiz_pos_median_m: percentile(&mut p, 50.0),
                horiz_pos_p95_m: percentile(&mut p, 95.0),
                horiz_vel_median_m_s: percentile(&mut v, 50.0),
                horiz_vel_p95_m_s: percentile(&mut v, 95.0),
            });
        }
    }
    Ok(out)
}

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct NavtestReport {
    pub records: Vec<RecordResult>,
    pub record_errors: Vec<(String, String)>,
    pub drift: Vec<DriftRow>,
    pub drift_errors: Vec<(String, String)>,
}

/// Run everything found under `data` (`../shared/data/real`); a missing recording is listed
/// in the errors, not fatal.
pub fn navtest(data: &Path, cfg: &Config, with_static: bool) -> NavtestReport {
    let mut rep = NavtestReport {
        records: vec![],
        record_errors: vec![],
        drift: vec![],
        drift_errors: vec![],
    };
    for spec in default_records(&data.join("rtklibexplorer_drive_walk")) {
        match run_record(&spec, cfg) {
            Ok(r) => rep.records.push(r),
            Err(e) => rep.record_errors.push((spec.name.clone(), e)),
        }
    }
    if with_static {
        for (name, p, skip) in [
            (
                "ADIS16405",
                data.join("adis16405_static/adis_16405_imu1.csv.gz"),
                10.0,
            ),
            (
                "MPU6050",
                data.join("mpu6050_static_10min_temp/mpu6050_static.csv"),
                5.0,
            ),
        ] {
            match run_bench(name, &p, cfg, skip) {
                Ok(r) => rep.drift.extend(r),
                Err(e) => rep.drift_errors.push((name.into(), e)),
            }
        }
    }
    rep
}

impl fmt::Display for NavtestReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for r in &self.records {
            writeln!(
                f,
                "### {}: {} IMU epochs, {} GNSS epochs ({} fixed), {:.1} s\n",
                r.name, r.imu_epochs, r.gnss_epochs, r.fixed_epochs, r.duration_s
            )?;
            for (l, n, a, b, s) in &r.schedule {
                writeln!(
                    f,
                    "- {l:.0} s: {n} outages, starts {a:.1}–{b:.1} s after the first GNSS epoch, {s:.2} s apart"
                )?;
            }
            writeln!(f)?;
            writeln!(
                f,
                "| outage s | variant | outages | horiz. median m | horiz. p95 m | vert. median m | vert. p95 m | heading median ° | heading p95 ° | tilt median ° |"
            )?;
            writeln!(f, "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")?;
            for l in LENGTHS {
                for w in r.rows.iter().filter(|w| w.length_s == l) {
                    writeln!(
                        f,
                        "| {:.0} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
                        w.length_s,
                        w.variant,
                        w.outages,
                        w.horiz_median_m,
                        w.horiz_p95_m,
                        w.vert_median_m,
                        w.vert_p95_m,
                        w.heading_median_deg,
                        w.heading_p95_deg,
                        w.tilt_median_deg
                    )?;
                }
            }
            writeln!(f)?;
            writeln!(
                f,
                "| variant | ZUPT updates | filter gyro bias, median over run (x, y, z) °/s, body |"
            )?;
            writeln!(f, "|---|---:|---|")?;
            for (v, z, b) in &r.filter {
                writeln!(
                    f,
                    "| {v} | {z} | {:+.3}, {:+.3}, {:+.3} |",
                    b[0], b[1], b[2]
                )?;
            }
            let c = r.cleaned_mean_change_dps;
            writeln!(
                f,
                "\n(b): imuprep's mean change of the gyros (out − in), body axes: {:+.3}, {:+.3}, {:+.3} °/s",
                c[0], c[1], c[2]
            )?;
            match (&r.augmentation, &r.augmentation_error) {
                (Some(a), _) => {
                    writeln!(
                        f,
                        "(d): Gauss–Markov bias parts from `allan` terms of {:.1}–{:.1} s after the IMU start (longest still stretch), per IMU channel (T_c s, σ, B resolved):",
                        a.still_from_s, a.still_to_s
                    )?;
                    for (ch, tc, s, ok) in &a.channels {
                        let (k, u) = if ch.starts_with('g') {
                            (1f64.to_degrees(), "°/s")
                        } else {
                            (1.0, "m/s²")
                        };
                        writeln!(
                            f,
                            "  {ch}: T_c {tc:.2} s, σ {:.4} {u}, B {}",
                            s * k,
                            if *ok { "resolved" } else { "upper bound" }
                        )?;
                    }
                }
                (None, Some(e)) => writeln!(f, "(d): not run: {e}")?,
                _ => {}
            }
            writeln!(f)?;
        }
        for (n, e) in &self.record_errors {
            writeln!(f, "{n}: not run: {e}")?;
        }
        if !self.drift.is_empty() {
            writeln!(f, "### Static drift of a free-inertial solution\n")?;
            writeln!(
                f,
                "| bench | variant | window s | windows | horiz. position median m | p95 m | horiz. velocity median m/s | p95 m/s |"
            )?;
            writeln!(f, "|---|---|---:|---:|---:|---:|---:|---:|")?;
            for d in &self.drift {
                writeln!(
                    f,
                    "| {} | {} | {:.0} | {} | {:.2} | {:.2} | {:.3} | {:.3} |",
                    d.bench,
                    d.variant,
                    d.window_s,
                    d.windows,
                    d.horiz_pos_median_m,
                    d.horiz_pos_p95_m,
                    d.horiz_vel_median_m_s,
                    d.horiz_vel_p95_m_s
                )?;
            }
        }
        for (n, e) in &self.drift_errors {
            writeln!(f, "{n}: not run: {e}")?;
        }
        Ok(())
    }
}
