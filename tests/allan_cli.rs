//! `imuprep allan` end to end on the bundled static bench: every file it promises, exports that
//! their readers accept (the bias model runs in the daemon), and a single-channel run that
//! leaves the per-sensor exports out and says so.
mod common;

use imuprep::model::bias_model::BiasModelFile;
use std::path::Path;

#[test]
fn allan_writes_report_plot_and_exports_the_daemon_loads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("out");
    let json = dir.path().join("r.json");
    let out = common::run_cli(&[
        "allan",
        "replay/static_bench.log",
        "--out-dir",
        d.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    for ch in ["gx", "gy", "gz", "ax", "ay", "az"] {
        assert!(out.contains(&format!("\n{ch} (")), "{ch} missing:\n{out}");
    }
    for f in [
        "report.txt",
        "report.json",
        "allan.svg",
        "imu.yaml",
        "gnss_imu_config.txt",
        "bias.toml",
    ] {
        assert!(d.join(f).exists(), "{f} not written:\n{out}");
    }
    let r: serde_json::Value = common::read_json(&json);
    assert_eq!(r["channels"].as_array().unwrap().len(), 6);
    let svg = std::fs::read_to_string(d.join("allan.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("Allan deviation"));
    let yaml = std::fs::read_to_string(d.join("imu.yaml")).unwrap();
    for key in [
        "accelerometer_noise_density:",
        "accelerometer_random_walk:",
        "gyroscope_noise_density:",
        "gyroscope_random_walk:",
        "update_rate:",
    ] {
        let line = yaml.lines().find(|l| l.starts_with(key)).unwrap();
        let v: f64 = line[key.len()..]
            .split('#')
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        assert!(v.is_finite() && v > 0.0, "{line}");
    }
    let model = BiasModelFile::load(&d.join("bias.toml")).unwrap();
    assert_eq!(model.channels.len(), 6);
    // the daemon runs with it as its [bias] model
    let cfg = dir.path().join("c.toml");
    std::fs::write(
        &cfg,
        format!(
            "[source]\nkind = \"stdin\"\n[bias]\nenabled = true\nmodel = \"{}\"\n",
            d.join("bias.toml").display()
        ),
    )
    .unwrap();
    let replay = common::run_cli(&[
        "replay",
        "replay/static_bench.log",
        "--config",
        cfg.to_str().unwrap(),
    ]);
    assert!(replay.contains("bias removed"), "{replay}");
}

#[test]
fn allan_on_one_channel_leaves_the_sensor_exports_out_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("gz");
    let out = common::run_cli(&[
        "allan",
        "replay/static_bench.log",
        "--channel",
        "gz",
        "--out-dir",
        d.to_str().unwrap(),
    ]);
    assert!(out.contains("\ngz (") && !out.contains("\ngx ("), "{out}");
    assert!(!Path::new(&d.join("imu.yaml")).exists());
    assert!(
        out.contains("need gyro and accelerometer channels"),
        "{out}"
    );
    assert!(d.join("bias.toml").exists() && d.join("allan.svg").exists());
}

/// A record too short for τ ≥ 10 s: the τ range's upper end keeps its decimals (it once read
/// "3 taus 0.010..0 s" for a 0.2-s record, whose largest τ is 0.04 s).
#[test]
fn allan_on_a_short_record_prints_its_tau_range_as_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("short.log");
    // 16 samples at 200 Hz (0.08 s): τ = 1, 2, 4 samples = 0.005 .. 0.020 s.
    imuprep::io::log::write_log(&log, &common::descriptor(), &common::samples(16, 3)).unwrap();
    let out = common::run_cli(&[
        "allan",
        log.to_str().unwrap(),
        "--channel",
        "gz",
        "--out-dir",
        dir.path().join("o").to_str().unwrap(),
    ]);
    assert!(out.contains("gz (rad/s): 3 taus 0.005..0.020 s"), "{out}");
}
