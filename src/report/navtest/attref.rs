//! Heading and tilt at the outage end against an attitude reference independent of the
//! filter (issue 15: "the same for heading error where a reference heading exists"):
//! comma2k19's post-processed pose orientation (heading and tilt), and on the rtklibexplorer
//! drive the RTK velocity's course over ground where the car is fast enough (heading only).
//!
//! The reference and the filter's body frame differ by a constant rotation nobody states
//! (comma2k19: the camera frame of the pose against the IMU's axes; the drive: side-slip and
//! the mounting yaw left after the tool's `imu_misalign`). It is estimated once per record as
//! the **median difference between the GNSS-aided raw-IMU filter (a) and the reference** over
//! the epochs from the first outage start on, reported, and removed from every error. What is
//! left is independent of the filter but for that one constant per axis.

use nalgebra::Vector3;
use serde::Serialize;

use super::comma::read_pose_attitude;
use super::outages::{OutageError, median_p95, percentile, wrap_deg};
use super::setup::{AttRefSource, GnssSource, RecordSpec};
use crate::nav::pos::PosEpoch;

/// The reference attitude at one GNSS epoch, rad.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefAttitude {
    /// Roll and pitch, where the reference has them.
    pub tilt: Option<[f64; 2]>,
    pub yaw: f64,
}

/// The reference attitude at every GNSS epoch (`None` where it has none), or `None` when the
/// record has no independent reference.
pub fn reference_attitude(
    spec: &RecordSpec,
    gnss: &[PosEpoch],
) -> Result<Option<Vec<Option<RefAttitude>>>, String> {
    match spec.att_ref {
        AttRefSource::None => Ok(None),
        AttRefSource::Course { min_speed_mps } => Ok(Some(
            gnss.iter()
                .map(|e| {
                    let (vn, ve) = (e.v_neu[0], e.v_neu[1]);
                    (e.q == 1 && vn.hypot(ve) >= min_speed_mps).then(|| RefAttitude {
                        tilt: None,
                        yaw: ve.atan2(vn),
                    })
                })
                .collect(),
        )),
        AttRefSource::Pose => {
            let GnssSource::ReferencePose { every, .. } = spec.gnss else {
                return Err("a pose attitude reference needs the pose as the GNSS".into());
            };
            let att = read_pose_attitude(&spec.pos, every)?;
            if att.len() != gnss.len() {
                return Err(format!(
                    "{} pose attitudes for {} pose epochs",
                    att.len(),
                    gnss.len()
                ));
            }
            Ok(Some(
                att.iter()
                    .map(|a| {
                        Some(RefAttitude {
                            tilt: Some([a[0], a[1]]),
                            yaw: a[2],
                        })
                    })
                    .collect(),
            ))
        }
    }
}

/// Heading and tilt errors of one variant and outage length against the reference.
#[derive(Clone, Debug, Serialize)]
pub struct AttRefRow {
    pub variant: String,
    pub length_s: f64,
    /// Outages whose scored epoch has a reference attitude.
    pub outages: usize,
    pub heading_median_deg: f64,
    pub heading_p95_deg: f64,
    /// NaN where the reference has no tilt.
    pub tilt_median_deg: f64,
    pub tilt_p95_deg: f64,
}

/// A record's heading and tilt against its independent reference.
#[derive(Clone, Debug, Serialize)]
pub struct AttRefReport {
    pub source: AttRefSource,
    /// GNSS epochs with a reference attitude (from the first outage start on).
    pub epochs: usize,
    /// The constant removed: median (aided (a) − reference) roll, pitch, yaw, degrees (roll and
    /// pitch NaN without a tilt reference).
    pub offset_deg: [f64; 3],
    /// How closely the GNSS-aided (a) filter follows the reference once the offset is removed:
    /// median and p95 of its heading error, and of its tilt error (NaN without tilt).
    pub aided_heading_deg: [f64; 2],
    pub aided_tilt_deg: [f64; 2],
    pub rows: Vec<AttRefRow>,
}

/// Heading and tilt (deg) of attitude `att` (rad) against `r` with `off` (deg) removed.
fn errors(att_deg: [f64; 3], r: &RefAttitude, off: &[f64; 3]) -> (f64, Option<f64>) {
    let d = |a: usize, v: f64| wrap_deg(att_deg[a] - v.to_degrees() - off[a]);
    let tilt = r.tilt.map(|t| d(0, t[0]).hypot(d(1, t[1])));
    (d(2, r.yaw).abs(), tilt)
}

/// The GNSS-aided filter's attitude and the reference's at one epoch.
type Pair = (Vector3<f64>, RefAttitude);

/// The report for one record: `aided` is the raw-IMU no-outage filter's attitude at each GNSS
/// epoch (rad, [`super::RunResult::attitude_at_epoch`]), `t_first` the first outage start
/// (GPST s; the offset uses the epochs from there on, after the filter's yaw alignment), and
/// `errs` every variant's outage errors, grouped by variant in order of first appearance.
pub fn att_ref_report(
    source: AttRefSource,
    refs: &[Option<RefAttitude>],
    gnss: &[PosEpoch],
    aided: &[Option<Vector3<f64>>],
    t_first: f64,
    errs: &[(String, OutageError)],
) -> AttRefReport {
    let pairs: Vec<Pair> = (0..refs.len().min(aided.len()))
        .filter(|&j| gnss[j].t >= t_first)
        .filter_map(|j| Some((aided[j]?, refs[j]?)))
        .collect();
    let med = |f: &dyn Fn(&Pair) -> Option<f64>| {
        let mut v: Vec<f64> = pairs.iter().filter_map(f).collect();
        percentile(&mut v, 50.0)
    };
    let offset_deg = [
        med(&|(a, r)| r.tilt.map(|t| wrap_deg((a[0] - t[0]).to_degrees()))),
        med(&|(a, r)| r.tilt.map(|t| wrap_deg((a[1] - t[1]).to_degrees()))),
        med(&|(a, r)| Some(wrap_deg((a[2] - r.yaw).to_degrees()))),
    ];
    let aided_errs: Vec<(f64, Option<f64>)> = pairs
        .iter()
        .map(|(a, r)| errors([a[0], a[1], a[2]].map(f64::to_degrees), r, &offset_deg))
        .collect();
    let mut variants: Vec<&str> = vec![];
    for (v, _) in errs {
        if !variants.contains(&v.as_str()) {
            variants.push(v);
        }
    }
    let mut rows = vec![];
    for v in variants {
        for l in super::LENGTHS {
            let e: Vec<(f64, Option<f64>)> = errs
                .iter()
                .filter(|(w, e)| w == v && e.outage.length_s == l)
                .filter_map(|(_, e)| {
                    let r = refs.get(e.outage.scored).copied().flatten()?;
                    Some(errors(e.att_end_deg, &r, &offset_deg))
                })
                .collect();
            if e.is_empty() {
                continue;
            }
            let [hm, hp] = median_p95(e.iter().map(|x| x.0).collect());
            let [tm, tp] = median_p95(e.iter().filter_map(|x| x.1).collect());
            rows.push(AttRefRow {
                variant: v.into(),
                length_s: l,
                outages: e.len(),
                heading_median_deg: hm,
                heading_p95_deg: hp,
                tilt_median_deg: tm,
                tilt_p95_deg: tp,
            });
        }
    }
    AttRefReport {
        source,
        epochs: pairs.len(),
        offset_deg,
        aided_heading_deg: median_p95(aided_errs.iter().map(|x| x.0).collect()),
        aided_tilt_deg: median_p95(aided_errs.iter().filter_map(|x| x.1).collect()),
        rows,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::navtest::outages::Outage;

    fn epoch(t: f64, vn: f64, ve: f64, q: u8) -> PosEpoch {
        PosEpoch {
            t,
            lat: 0.0,
            lon: 0.0,
            h: 0.0,
            q,
            sd: [0.01; 3],
            v_neu: [vn, ve, 0.0],
            sdv: None,
        }
    }

    fn spec(att_ref: AttRefSource) -> RecordSpec {
        let mut s =
            super::super::setup::default_records(std::path::Path::new("/nonexistent")).remove(0);
        s.att_ref = att_ref;
        s
    }

    /// The course is taken only at fixed epochs at or above the speed threshold, east of north.
    #[test]
    fn course_reference_needs_speed_and_a_fixed_epoch() {
        let g = vec![
            epoch(0.0, 10.0, 10.0, 1),
            epoch(1.0, 1.0, 1.0, 1),
            epoch(2.0, 0.0, -10.0, 2),
            epoch(3.0, -10.0, 0.0, 1),
        ];
        let r = reference_attitude(&spec(AttRefSource::Course { min_speed_mps: 5.0 }), &g)
            .unwrap()
            .unwrap();
        assert!((r[0].unwrap().yaw.to_degrees() - 45.0).abs() < 1e-9);
        assert!(r[1].is_none() && r[2].is_none());
        assert!((r[3].unwrap().yaw.to_degrees() - 180.0).abs() < 1e-9);
        assert!(r[0].unwrap().tilt.is_none());
        assert!(
            reference_attitude(&spec(AttRefSource::None), &g)
                .unwrap()
                .is_none()
        );
    }

    fn err(v: f64, scored: usize, att: [f64; 3]) -> OutageError {
        OutageError {
            outage: Outage {
                length_s: v,
                start_rel_s: 0.0,
                start: 0.0,
                end: 0.0,
                scored,
            },
            horiz_m: 0.0,
            vert_m: 0.0,
            heading_deg: 0.0,
            tilt_deg: 0.0,
            gyro_bias_start_dps: [0.0; 3],
            accel_bias_start: [0.0; 3],
            att_start_deg: [0.0; 3],
            att_end_deg: att,
        }
    }

    /// A constant offset between the aided filter and the reference is removed; what remains
    /// at the outage end is scored, with the yaw difference wrapped across ±180°.
    #[test]
    fn the_median_offset_is_removed_and_yaw_wraps() {
        let g: Vec<PosEpoch> = (0..5).map(|k| epoch(k as f64, 10.0, 0.0, 1)).collect();
        let refs: Vec<Option<RefAttitude>> = (0..5)
            .map(|_| {
                Some(RefAttitude {
                    tilt: Some([0.0, 0.0]),
                    yaw: 179f64.to_radians(),
                })
            })
            .collect();
        // The aided filter sits at roll +1°, pitch 0, yaw −179° (2° past the reference).
        let aided: Vec<Option<Vector3<f64>>> = (0..5)
            .map(|_| Some(Vector3::new(1.0, 0.0, -179.0).map(f64::to_radians)))
            .collect();
        let errs = vec![
            ("(a)".to_string(), err(10.0, 4, [4.0, 4.0, -175.0])),
            ("(a)".to_string(), err(10.0, 1, [1.0, 0.0, -179.0])),
            ("(b)".to_string(), err(30.0, 9, [0.0; 3])), // no reference there: skipped
        ];
        let r = att_ref_report(AttRefSource::Pose, &refs, &g, &aided, 1.0, &errs);
        assert_eq!(r.epochs, 4);
        assert!((r.offset_deg[0] - 1.0).abs() < 1e-9, "{:?}", r.offset_deg);
        assert!((r.offset_deg[2] - 2.0).abs() < 1e-9, "{:?}", r.offset_deg);
        assert!(r.aided_heading_deg[1].abs() < 1e-9);
        assert_eq!(r.rows.len(), 1);
        let row = &r.rows[0];
        assert_eq!(row.outages, 2);
        // Heading errors 4° and 0°; tilt errors hypot(3, 4) = 5° and 0°.
        assert!((row.heading_median_deg - 2.0).abs() < 1e-9);
        assert!((row.tilt_median_deg - 2.5).abs() < 1e-9);
        assert!((row.tilt_p95_deg - 4.75).abs() < 1e-9);
    }
}
