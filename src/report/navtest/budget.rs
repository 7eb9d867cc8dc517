//! The error budget of the 30-s outages on the raw IMU: the same outages replayed with one
//! error source removed at a time — the coasting filter takes its tilt, heading, gyro bias or
//! accelerometer bias from the GNSS-aided filter at every IMU epoch ([`Oracle`]) — so that
//! "the outage error is dominated by X" is measured, not inferred. Also the filter with its
//! gyro-bias estimate zeroed: what the filter's own bias estimate is worth, the most a bias
//! removed before the filter could add.

use nalgebra::Vector3;
use serde::Serialize;

use super::outages::{Oracle, Outage, OutageError, median_p95, run_filter_with};
use super::setup::BodyImu;
use crate::nav::eskf::EskfConfig;
use crate::nav::pos::PosEpoch;

/// Outage length of the budget, s (issue 15's aim is on the 30-s error).
pub const BUDGET_LENGTH_S: f64 = 30.0;

/// One replay of the budget.
#[derive(Clone, Debug, Serialize)]
pub struct BudgetRow {
    pub case: String,
    pub outages: usize,
    pub horiz_median_m: f64,
    pub horiz_p95_m: f64,
    pub tilt_median_deg: f64,
    pub heading_median_deg: f64,
}

/// The cases, in table order.
pub fn cases() -> Vec<(&'static str, Oracle)> {
    let o = Oracle::default();
    vec![
        ("filter as is (= (a))", o),
        (
            "tilt from the GNSS-aided filter",
            Oracle { tilt: true, ..o },
        ),
        (
            "heading from the GNSS-aided filter",
            Oracle { heading: true, ..o },
        ),
        (
            "attitude (tilt + heading) from the GNSS-aided filter",
            Oracle {
                tilt: true,
                heading: true,
                ..o
            },
        ),
        (
            "gyro bias from the GNSS-aided filter",
            Oracle {
                gyro_bias: true,
                ..o
            },
        ),
        (
            "accel bias from the GNSS-aided filter",
            Oracle {
                accel_bias: true,
                ..o
            },
        ),
        (
            "both biases from the GNSS-aided filter",
            Oracle {
                gyro_bias: true,
                accel_bias: true,
                ..o
            },
        ),
        (
            "gyro bias estimate zeroed",
            Oracle {
                zero_gyro_bias: true,
                ..o
            },
        ),
    ]
}

/// Summary of one case's errors.
pub fn budget_row(case: &str, errs: &[OutageError]) -> BudgetRow {
    let col = |f: fn(&OutageError) -> f64| median_p95(errs.iter().map(f).collect());
    let [horiz_median_m, horiz_p95_m] = col(|e| e.horiz_m);
    let [tilt_median_deg, _] = col(|e| e.tilt_deg);
    let [heading_median_deg, _] = col(|e| e.heading_deg);
    BudgetRow {
        case: case.into(),
        outages: errs.len(),
        horiz_median_m,
        horiz_p95_m,
        tilt_median_deg,
        heading_median_deg,
    }
}

/// Every case on the [`BUDGET_LENGTH_S`] outages of `outages`; heading and tilt against
/// `att_ref` (the raw no-outage run).
pub fn error_budget(
    cfg: &EskfConfig,
    imu: &BodyImu,
    gnss: &[PosEpoch],
    outages: &[Outage],
    att_ref: &[Option<Vector3<f64>>],
) -> Result<Vec<BudgetRow>, String> {
    let sel: Vec<Outage> = outages
        .iter()
        .filter(|o| o.length_s == BUDGET_LENGTH_S)
        .copied()
        .collect();
    cases()
        .into_iter()
        .map(|(name, oracle)| {
            let r = run_filter_with(cfg, imu, gnss, &sel, Some(att_ref), oracle)?;
            Ok(budget_row(name, &r.errors))
        })
        .collect()
}
