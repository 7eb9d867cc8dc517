//! comma2k19's reference pose as the GNSS of [`super::setup::GnssSource::ReferencePose`], and
//! its orientation as an independent attitude reference ([`read_pose_attitude`]).

use std::path::Path;

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::nav::earth::{ctm_to_euler, ecef_to_llh, ecef_to_ned};
use crate::nav::pos::PosEpoch;

/// The named columns of every `every`-th data row of `reference_pose.csv` (the rows
/// [`read_reference_pose`] turns into epochs, in the same order), each value finite.
fn pose_rows(path: &Path, names: &[&str], every: usize) -> Result<Vec<Vec<f64>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines
        .next()
        .ok_or_else(|| format!("{}: empty", path.display()))?
        .split(',')
        .map(str::trim)
        .collect();
    let idx = names
        .iter()
        .map(|name| {
            head.iter()
                .position(|h| h == name)
                .ok_or_else(|| format!("{}: no column {name}", path.display()))
        })
        .collect::<Result<Vec<usize>, String>>()?;
    let mut out = vec![];
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() || n % every.max(1) != 0 {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let v = idx
            .iter()
            .map(|&i| {
                cells
                    .get(i)
                    .and_then(|c| c.trim().parse::<f64>().ok())
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("{}: line {}: bad value", path.display(), n + 2))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        out.push(v);
    }
    if out.len() < 2 {
        return Err(format!("{}: fewer than 2 pose epochs", path.display()));
    }
    Ok(out)
}

/// `reference_pose.csv` (header `t_boot_s, gps_week, gps_tow_s, ecef_x_m, ecef_y_m, ecef_z_m,
/// ecef_vx_mps, ecef_vy_mps, ecef_vz_mps, q0..q3`): every `every`-th row as a fixed epoch
/// at `t_boot_s` (the IMU's clock), position to geodetic, velocity rotated into NED.
pub fn read_reference_pose(
    path: &Path,
    every: usize,
    pos_sd: [f64; 3],
    vel_sd: f64,
) -> Result<Vec<PosEpoch>, String> {
    let names = [
        "t_boot_s",
        "ecef_x_m",
        "ecef_y_m",
        "ecef_z_m",
        "ecef_vx_mps",
        "ecef_vy_mps",
        "ecef_vz_mps",
    ];
    Ok(pose_rows(path, &names, every)?
        .into_iter()
        .map(|v| {
            let (lat, lon, h) = ecef_to_llh(&Vector3::new(v[1], v[2], v[3]));
            let vn = ecef_to_ned(lat, lon) * Vector3::new(v[4], v[5], v[6]);
            PosEpoch {
                t: v[0],
                lat,
                lon,
                h,
                q: 1,
                sd: pos_sd,
                v_neu: [vn[0], vn[1], -vn[2]],
                sdv: Some([vel_sd; 3]),
            }
        })
        .collect())
}

/// Roll, pitch, yaw (rad) of the pose's device frame (forward, right, down) in the local NED
/// frame, for the same rows as [`read_reference_pose`]. The quaternion `q0..q3` is read as
/// (w, x, y, z), Hamilton, as the rotation that takes device-frame vectors into ECEF
/// (`C_b^e`); the segment's NOTES leave the direction to check, and this reading gives a level
/// car (roll 1–2°, pitch −5…−1°) whose yaw follows the pose's own course over ground within 1°,
/// where the transpose gives roll −36°, pitch −30° (`read_pose_attitude_is_level_and_on_course`
/// in `tests/navtest_real.rs`).
pub fn read_pose_attitude(path: &Path, every: usize) -> Result<Vec<Vector3<f64>>, String> {
    let names = ["ecef_x_m", "ecef_y_m", "ecef_z_m", "q0", "q1", "q2", "q3"];
    pose_rows(path, &names, every)?
        .into_iter()
        .map(|v| {
            let q = Quaternion::new(v[3], v[4], v[5], v[6]);
            if !(0.9..1.1).contains(&q.norm()) {
                return Err(format!(
                    "{}: quaternion of norm {:.3}, not a rotation",
                    path.display(),
                    q.norm()
                ));
            }
            let c_be = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
            let (lat, lon, _) = ecef_to_llh(&Vector3::new(v[0], v[1], v[2]));
            Ok(ctm_to_euler(&(ecef_to_ned(lat, lon) * c_be.matrix())))
        })
        .collect()
}
