//! Free-inertial drift on the static benches (seed 003, Figs 9–10), raw against cleaned.

use std::path::Path;

use nalgebra::Vector3;
use serde::Serialize;

use super::clean;
use super::outages::median_p95;
use crate::config::Config;
use crate::nav::earth::{self, euler_to_ctm};
use crate::nav::eskf::{NavState, level};
use crate::report::audit::load_recording;
use crate::sample::Sample;

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
            let [horiz_pos_median_m, horiz_pos_p95_m] = median_p95(r.iter().map(|x| x.0).collect());
            let [horiz_vel_median_m_s, horiz_vel_p95_m_s] =
                median_p95(r.iter().map(|x| x.1).collect());
            out.push(DriftRow {
                bench: name.into(),
                variant: variant.into(),
                window_s: w,
                windows: r.len(),
                horiz_pos_median_m,
                horiz_pos_p95_m,
                horiz_vel_median_m_s,
                horiz_vel_p95_m_s,
            });
        }
    }
    Ok(out)
}
