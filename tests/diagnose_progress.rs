//! The close-the-loop iteration always makes progress: a term that only replaces an earlier one
//! which polishing then moves back (a bias step re-found next to itself) ends the loop instead of
//! being reported again and again until `max_iterations`.
//!
//! Reproduction (found while testing issue 6): the committed bench recorded at ambient 15 °C,
//! warming up by 15 °C, with gyro temperature coefficients three times the scenario's. Before the
//! fix gy's report listed "bias step at t = 162.30 s" eight times.

mod common;

use std::process::Command;

#[test]
fn diagnose_never_reports_the_same_effect_twice() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bench.log");
    let out = dir.path().join("d");
    let sim = Command::new(common::bin())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["simulate", "replay/static_bench.toml", "-o"])
        .arg(&log)
        .args([
            "--set",
            "temperature.profile.ambient_c=15.0",
            "--set",
            "temperature.profile.rise_c=15.0",
            "--set",
            "errors.temperature.gyro_deg_s_per_c=[0.06, -0.045, 0.036]",
        ])
        .output()
        .unwrap();
    assert!(sim.status.success(), "{sim:?}");
    let diag = Command::new(common::bin())
        .arg("diagnose")
        .arg(&log)
        .args(["--paper-split", "--channel", "gy", "--out-dir"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(diag.status.success(), "{diag:?}");
    let report: serde_json::Value = common::read_json(out.join("report.json"));
    let its = report["channels"][0]["iterations"].as_array().unwrap();
    let effects: Vec<String> = its.iter().map(|i| i["effect"].to_string()).collect();
    eprintln!("gy iterations: {effects:#?}");
    for (i, e) in effects.iter().enumerate() {
        assert!(
            !effects[..i].contains(e),
            "effect {e} reported again at iteration {}",
            i + 1
        );
    }
    assert!(effects.len() < 8, "ran to max_iterations: {effects:?}");
}
