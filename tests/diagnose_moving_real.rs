//! `diagnose` on a real drive writes no model (do no harm).
//!
//! On the rtklibexplorer drive `diagnose` once wrote a bias.toml whose gz "g-sensitivity",
//! −0.16 (rad/s)/(m/s²) on ay, is the car's turning seen through its centripetal acceleration
//! (a = v·ω, so the coefficient is 1/speed), and whose "wander" was the turns themselves. Loaded
//! as `[bias] model` it changed the replay's gz by 9.7 °/s rms (the raw gz is 9.3 °/s rms) and
//! the integrated heading by 850°. A record not at rest now gets the report only; the model
//! needs `--allow-motion`. Data beside the project (skipped with a message when absent).

mod common;

#[test]
fn diagnose_on_the_real_drive_reports_but_writes_no_model() {
    let Some(csv) = common::real_data("rtklibexplorer_drive_walk/drive_0708_imu.csv") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("drive.log");
    let imported = common::import(&csv, &log);
    assert!(imported.status.success(), "{imported:?}");
    let out_dir = dir.path().join("d");
    std::fs::create_dir_all(&out_dir).unwrap();
    // An earlier run's model in the folder must not survive to pass for this run's.
    std::fs::write(out_dir.join("bias.toml"), "# an earlier run\n").unwrap();
    let out = common::run_cli(&[
        "diagnose",
        log.to_str().unwrap(),
        "--out-dir",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.contains("WARNING: the record is not at rest"), "{out}");
    assert!(out.contains("no bias.toml"), "{out}");
    assert!(!out_dir.join("bias.toml").exists(), "{out}");
    // The report is still there for the user to read, with every channel diagnosed.
    let j: serde_json::Value = common::read_json(out_dir.join("report.json"));
    assert_eq!(j["channels"].as_array().map(Vec::len), Some(6), "{j}");
    assert_eq!(j["warnings"].as_array().map(Vec::len), Some(1), "{j}");
}
