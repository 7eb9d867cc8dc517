//! Issue 12's "do no harm" targets on every real recording under `../shared/data/real`, with the
//! embedded default config and nothing tuned per recording: the same audit `imuprep audit` prints
//! (see `src/report/audit.rs` for what each target measures).
//!
//! Every target must be met, except the ones listed in `KNOWN_MISSES`: those the 2026-11-24
//! design does not reach, each bounded at its measured value (with a margin for the next
//! change's noise) so that it cannot get worse unnoticed, and each reported as missed in the
//! closing note and `docs/real-data.md`. A known miss that is met now fails too, so the list
//! stays true.
//!
//! Skipped (visibly, on stderr) when `../shared/data/real` is absent.

mod common;

use std::path::Path;

use imuprep::config::Config;
use imuprep::report::audit::{Seeds, audit_dir};

/// (recording prefix, channel, target text prefix, regression bound): the measured value must
/// stay on the right side of the bound (same direction as the target's limit).
const KNOWN_MISSES: &[(&str, &str, &str, f64)] = &[
    // Injections on moving recordings: weak single-sample evidence stays unreplaced by design.
    // Pooled over the audit's five seeds 12–16 (measured 2026-12-02): F1 comma2k19 0.921, drive
    // 0.921, walk 0.930, x-IMU3 0.888 (its seeds 0.83–0.94). The MPU6050's 2 % outlier recall,
    // 0.853 until the test against the resting level (`rest_k`), is 0.935 and met.
    ("comma2k19", "all", "injected spikes and runs, F1", 0.90),
    (
        "rtklibexplorer_drive_walk/drive",
        "all",
        "injected spikes and runs, F1",
        0.90,
    ),
    (
        "rtklibexplorer_drive_walk/walk",
        "all",
        "injected spikes and runs, F1",
        0.90,
    ),
    ("ximu3", "all", "injected spikes and runs, F1", 0.86),
    // Real samples the confirmation still calls breaks: one 2-sample event in the PX4 warm-up
    // (1.2e-4), one 3-sample wobble of the x-IMU3's az (2.2e-4).
    // The PX4 CSV and its ULog original (the same samples).
    (
        "px4_sensor_combined",
        "gx",
        "replaced per channel-sample",
        2e-4,
    ),
    (
        "px4_ulog/sample.ulg",
        "gx",
        "replaced per channel-sample",
        2e-4,
    ),
    ("ximu3", "az", "replaced per channel-sample", 3e-4),
];

#[test]
fn every_real_recording_meets_the_do_no_harm_targets_or_a_known_bound() {
    let dir = Path::new("../shared/data/real");
    if !dir.is_dir() {
        // Raw stderr write: the test harness captures eprintln!, so a skip would be invisible.
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "SKIPPED: {} is absent (real recordings live beside the repo)",
            dir.display()
        );
        return;
    }
    let cfg = Config::default_embedded().unwrap();
    let report = audit_dir(dir, Seeds::DEFAULT, &cfg).unwrap();
    eprint!("{report}");
    // 7 CSV recordings and the two PX4 ULog files long enough for the warm-ups (the other three
    // hold 1300–2400 samples and are listed as skipped).
    assert!(
        report.recordings.len() >= 9,
        "{} recordings",
        report.recordings.len()
    );
    let mut failures = Vec::new();
    for t in report.targets() {
        let known = KNOWN_MISSES.iter().find(|(rec, ch, what, _)| {
            t.recording.starts_with(rec) && t.channel == *ch && t.target.starts_with(what)
        });
        failures.extend(common::judge_target(
            t,
            &t.recording,
            known.map(|&(.., bound)| bound),
        ));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
