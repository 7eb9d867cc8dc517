//! comma2k19's reference pose as the GNSS of [`super::setup::GnssSource::ReferencePose`].

use std::path::Path;

use nalgebra::Vector3;

use crate::nav::earth::{ecef_to_llh, ecef_to_ned};
use crate::nav::pos::PosEpoch;

/// `reference_pose.csv` (header `t_boot_s, gps_week, gps_tow_s, ecef_x_m, ecef_y_m, ecef_z_m,
/// ecef_vx_mps, ecef_vy_mps, ecef_vz_mps, q0..q3`): every `every`-th row as a fixed epoch
/// at `t_boot_s` (the IMU's clock), position to geodetic, velocity rotated into NED.
pub fn read_reference_pose(
    path: &Path,
    every: usize,
    pos_sd: [f64; 3],
    vel_sd: f64,
) -> Result<Vec<PosEpoch>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines
        .next()
        .ok_or_else(|| format!("{}: empty", path.display()))?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        head.iter()
            .position(|h| *h == name)
            .ok_or_else(|| format!("{}: no column {name}", path.display()))
    };
    let cols = [
        "t_boot_s",
        "ecef_x_m",
        "ecef_y_m",
        "ecef_z_m",
        "ecef_vx_mps",
        "ecef_vy_mps",
        "ecef_vz_mps",
    ]
    .map(col);
    let mut idx = [0usize; 7];
    for (i, c) in cols.into_iter().enumerate() {
        idx[i] = c?;
    }
    let mut out = vec![];
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() || n % every.max(1) != 0 {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let v: Result<Vec<f64>, String> = idx
            .iter()
            .map(|&i| {
                cells
                    .get(i)
                    .and_then(|c| c.trim().parse::<f64>().ok())
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("{}: line {}: bad value", path.display(), n + 2))
            })
            .collect();
        let v = v?;
        let (lat, lon, h) = ecef_to_llh(&Vector3::new(v[1], v[2], v[3]));
        let vn = ecef_to_ned(lat, lon) * Vector3::new(v[4], v[5], v[6]);
        out.push(PosEpoch {
            t: v[0],
            lat,
            lon,
            h,
            q: 1,
            sd: pos_sd,
            v_neu: [vn[0], vn[1], -vn[2]],
            sdv: Some([vel_sd; 3]),
        });
    }
    if out.len() < 2 {
        return Err(format!("{}: fewer than 2 pose epochs", path.display()));
    }
    Ok(out)
}
