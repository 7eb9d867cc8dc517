//! The outage schedule, the filter run with a coasting copy per outage, and the statistics.

use nalgebra::Vector3;
use serde::Serialize;

use super::setup::{BodyImu, RecordSpec};
use crate::nav::earth::{LocalFrame, euler_to_ctm};
use crate::nav::eskf::*;
use crate::nav::pos::PosEpoch;

/// Outage lengths, s.
pub const LENGTHS: [f64; 3] = [10.0, 30.0, 60.0];
/// Minimum number of scored outages per length.
pub const MIN_STARTS: usize = 20;
/// Scored epoch: the last RTK epoch at or before the outage end minus this, s (as the harness).
const END_MARGIN: f64 = 0.02;

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
    /// The outage (its fields stand beside the errors in the JSON).
    #[serde(flatten)]
    pub outage: Outage,
    pub horiz_m: f64,
    pub vert_m: f64,
    pub heading_deg: f64,
    pub tilt_deg: f64,
    /// The gyro bias estimate the filter coasted with (at the outage start), body axes, °/s.
    pub gyro_bias_start_dps: [f64; 3],
    /// Its accelerometer bias estimate at the outage start, body axes, m/s².
    pub accel_bias_start: [f64; 3],
    /// Its roll, pitch, yaw at the outage start, degrees.
    pub att_start_deg: [f64; 3],
    /// The coasting filter's roll, pitch, yaw at the scored epoch, degrees.
    pub att_end_deg: [f64; 3],
}

/// What a coasting copy takes from the GNSS-aided (no-outage) filter at every IMU epoch of
/// its outage — the error budget: with the reference's tilt, the position error left is what
/// everything but tilt makes; with its gyro bias, what a perfectly tracked bias would leave.
/// The reference is the same filter with GNSS (the recordings hold no independent attitude or
/// bias), so "perfect" means "as well as the GNSS-aided filter knows it".
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Oracle {
    /// Roll and pitch from the reference after each step.
    pub tilt: bool,
    /// Yaw from the reference after each step.
    pub heading: bool,
    /// Gyro bias (random-walk and Gauss–Markov parts) from the reference before each step.
    pub gyro_bias: bool,
    /// Accelerometer bias from the reference before each step.
    pub accel_bias: bool,
    /// Gyro bias estimate set to zero for the whole outage (what the filter's own estimate is
    /// worth; overrides `gyro_bias`).
    pub zero_gyro_bias: bool,
}

impl Oracle {
    fn before(&self, c: &mut Eskf, r: &Eskf) {
        if self.zero_gyro_bias {
            c.bg = Vector3::zeros();
            c.mg = Vector3::zeros();
        } else if self.gyro_bias {
            c.bg = r.bg;
            c.mg = r.mg;
        }
        if self.accel_bias {
            c.ba = r.ba;
            c.ma = r.ma;
        }
    }

    fn after(&self, c: &mut Eskf, r: &Eskf) {
        if self.tilt || self.heading {
            let (ec, er) = (c.nav.euler(), r.nav.euler());
            let (roll, pitch) = if self.tilt {
                (er[0], er[1])
            } else {
                (ec[0], ec[1])
            };
            let yaw = if self.heading { er[2] } else { ec[2] };
            c.nav.c_bn = euler_to_ctm(roll, pitch, yaw).transpose();
        }
    }
}

/// The GNSS-aided filter at an outage's start.
#[derive(Clone, Copy, Debug)]
struct Start {
    gyro_bias_dps: [f64; 3],
    accel_bias: [f64; 3],
    att_deg: [f64; 3],
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

pub(super) fn wrap_deg(a: f64) -> f64 {
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
    run_filter_with(cfg, imu, gnss, outages, att_ref, Oracle::default())
}

/// [`run_filter`] whose coasting copies take what `oracle` says from the GNSS-aided filter.
pub fn run_filter_with(
    cfg: &EskfConfig,
    imu: &BodyImu,
    gnss: &[PosEpoch],
    outages: &[Outage],
    att_ref: Option<&[Option<Vector3<f64>>]>,
    oracle: Oracle,
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
    // Put the antenna, not the IMU, at the first fix.
    let (la, lo, ha) = kf.antenna();
    kf.nav.lat -= la - e0.lat;
    kf.nav.lon -= lo - e0.lon;
    kf.nav.h -= ha - e0.h;
    let frame = LocalFrame::new(gnss[0].lat, gnss[0].lon, gnss[0].h);
    let mut order: Vec<usize> = (0..outages.len()).collect();
    order.sort_by(|&a, &b| outages[a].start.total_cmp(&outages[b].start));
    let mut next_outage = 0;
    // (outage, its filter, the filter it started as)
    let mut coasting: Vec<(usize, Eskf, Start)> = vec![];
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
        for (_, c, _) in coasting.iter_mut() {
            oracle.before(c, &kf);
            c.propagate(dt, &imu.w[i], &imu.f[i]);
            oracle.after(c, &kf);
        }
        while j < gnss.len() && gnss[j].t <= imu.t[i] {
            let e = &gnss[j];
            // Outages starting before this epoch: a copy of the filter before the update.
            while next_outage < order.len() && outages[order[next_outage]].start < e.t {
                let mut c = kf.clone();
                oracle.before(&mut c, &kf);
                let arr = |v: Vector3<f64>| [v[0], v[1], v[2]];
                let start = Start {
                    gyro_bias_dps: arr(kf.gyro_bias().map(f64::to_degrees)),
                    accel_bias: arr(kf.accel_bias()),
                    att_deg: arr(kf.nav.euler().map(f64::to_degrees)),
                };
                coasting.push((order[next_outage], c, start));
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
                    let end = c.nav.euler();
                    let da = (end - r).map(|x| wrap_deg(x.to_degrees()));
                    errors.push(OutageError {
                        outage: *o,
                        gyro_bias_start_dps: coasting[k].2.gyro_bias_dps,
                        accel_bias_start: coasting[k].2.accel_bias,
                        att_start_deg: coasting[k].2.att_deg,
                        att_end_deg: [end[0], end[1], end[2]].map(f64::to_degrees),
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

/// `[median, 95th percentile]` of `v` ([`percentile`]).
pub fn median_p95(mut v: Vec<f64>) -> [f64; 2] {
    [percentile(&mut v, 50.0), percentile(&mut v, 95.0)]
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

pub fn rows(record: &str, variant: &str, errs: &[OutageError]) -> Vec<Row> {
    LENGTHS
        .iter()
        .map(|&l| {
            let e: Vec<&OutageError> = errs.iter().filter(|e| e.outage.length_s == l).collect();
            let col = |f: fn(&OutageError) -> f64| median_p95(e.iter().map(|x| f(x)).collect());
            let [horiz_median_m, horiz_p95_m] = col(|x| x.horiz_m);
            let [vert_median_m, vert_p95_m] = col(|x| x.vert_m);
            let [heading_median_deg, heading_p95_deg] = col(|x| x.heading_deg);
            let [tilt_median_deg, _] = col(|x| x.tilt_deg);
            Row {
                record: record.into(),
                variant: variant.into(),
                length_s: l,
                outages: e.len(),
                horiz_median_m,
                horiz_p95_m,
                vert_median_m,
                vert_p95_m,
                heading_median_deg,
                heading_p95_deg,
                tilt_median_deg,
            }
        })
        .collect()
}
