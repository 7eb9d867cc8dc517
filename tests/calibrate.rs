//! `imuprep calibrate` end to end: a tumbled record with known accelerometer errors (still stops
//! at attitudes reached by rotations about random axes) through the stretch finder, the
//! command, its config file and the daemon's calibration; and every real recording.

mod common;

use common::{descriptor, real_data, run_cli, skipped};
use imuprep::analysis::calib::gyro::{calibrate_gyro, gyro_intervals};
use imuprep::analysis::calib::still::{StillSettings, still_stretches};
use imuprep::config::Config;
use imuprep::io::log::write_log;
use imuprep::rng::Rng;
use imuprep::sample::{Channels, Sample};
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::path::Path;

const G: f64 = 9.80665;
const RATE: f64 = 100.0;
/// White noise per sample: gyro rad/s, accel m/s² (a consumer MEMS IMU at 100 Hz).
const GYRO_SD: f64 = 0.005;
const ACCEL_SD: f64 = 0.02;

/// A still stop: its time span, s, and its true specific force.
struct Stop {
    t0_s: f64,
    t1_s: f64,
    f: Vector3<f64>,
}

/// The sensor's errors: raw = A·true + b for each triad.
struct Errors {
    accel_a: Matrix3<f64>,
    accel_b: Vector3<f64>,
    gyro_a: Matrix3<f64>,
    gyro_b: Vector3<f64>,
}

const NO_ERRORS: Errors = Errors {
    accel_a: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    accel_b: Vector3::new(0.0, 0.0, 0.0),
    gyro_a: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    gyro_b: Vector3::new(0.0, 0.0, 0.0),
};

/// `stops` still stops of `still_s` each, joined by 70° rotations about a random body axis over
/// 1.5 s, measured with errors `e` and white noise.
fn tumbling(stops: usize, still_s: f64, seed: u64, e: &Errors) -> (Vec<Sample>, Vec<Stop>) {
    let dt = 1.0 / RATE;
    let mut rng = Rng::new(seed);
    let mut c_bn = Rotation3::identity();
    let g_n = Vector3::new(0.0, 0.0, -G);
    let (mut out, mut truth) = (Vec::new(), Vec::new());
    let push = |w: Vector3<f64>, c: &Rotation3<f64>, rng: &mut Rng, out: &mut Vec<Sample>| {
        let mut noise = |sd: f64| Vector3::from_fn(|_, _| sd * rng.normal());
        let gyro = e.gyro_a * w + e.gyro_b + noise(GYRO_SD);
        let accel = e.accel_a * (c * g_n) + e.accel_b + noise(ACCEL_SD);
        out.push(Sample {
            seq: out.len() as u32,
            t_ns: (out.len() as f64 * dt * 1e9).round() as u64,
            gyro,
            accel,
            ..Sample::default()
        });
    };
    for _ in 0..stops {
        let t0_s = out.len() as f64 * dt;
        for _ in 0..(still_s * RATE) as usize {
            push(Vector3::zeros(), &c_bn, &mut rng, &mut out);
        }
        truth.push(Stop {
            t0_s,
            t1_s: out.len() as f64 * dt,
            f: c_bn * g_n,
        });
        let axis = Vector3::from_fn(|_, _| rng.normal()).normalize();
        let w = axis * 70f64.to_radians() / 1.5;
        for _ in 0..(1.5 * RATE) as usize {
            c_bn = Rotation3::new(-w * dt) * c_bn;
            push(w, &c_bn, &mut rng, &mut out);
        }
    }
    (out, truth)
}

fn write(dir: &Path, samples: &[Sample]) -> String {
    let p = dir.join("tumble.log");
    let d = imuprep::frame::Descriptor {
        sample_rate_hz: RATE,
        ..descriptor()
    };
    write_log(&p, &d, samples).unwrap();
    p.display().to_string()
}

#[test]
fn the_finder_returns_one_stretch_per_stop_with_its_mean() {
    let (samples, truth) = tumbling(12, 10.0, 21, &NO_ERRORS);
    let st = still_stretches(&samples.iter().collect(), RATE, &StillSettings::default());
    assert_eq!(st.len(), truth.len(), "{st:#?}");
    for (s, stop) in st.iter().zip(&truth) {
        // Inside its stop (no motion sample), and most of it (≥ 7 of 10 s: the detector needs
        // its 0.5-s window and 1-s entry time, then 0.25 s is trimmed at each end).
        let end = s.t0_s + s.duration_s(RATE);
        assert!(s.t0_s >= stop.t0_s && end <= stop.t1_s + 1e-9, "{s:?}");
        assert!(s.duration_s(RATE) >= 7.0);
        // Its mean within 4.5 σ of the truth per axis (σ = sd/√n; 36 axis means).
        let sm = ACCEL_SD / (s.len as f64).sqrt();
        assert!(
            (s.mean() - stop.f).amax() < 4.5 * sm,
            "{:?} vs {:?}",
            s.mean(),
            stop.f
        );
    }
}

#[test]
fn a_tumbled_log_is_calibrated_and_the_daemon_applies_the_config() {
    // 30 stops of 10 s: 1.2 % / −0.8 % / 0.5 % scale, 4–6 mrad cross-axis, 0.05–0.15 m/s² bias.
    let a = Matrix3::new(1.012, 0.0, 0.0, 0.004, 0.992, 0.0, -0.006, 0.005, 1.005);
    let b = Vector3::new(0.15, -0.05, 0.1);
    // The gyro: 1.5 % / −1 % / 0.8 % scale, 3–8 mrad cross-axis (either side of the diagonal:
    // relative to the accelerometer frame all nine are identifiable), 0.02 rad/s bias.
    let ga = Matrix3::new(
        1.015, 0.004, -0.003, 0.006, 0.99, 0.008, -0.005, 0.003, 1.008,
    );
    let e = Errors {
        accel_a: a,
        accel_b: b,
        gyro_a: ga,
        gyro_b: Vector3::new(0.02, -0.01, 0.015),
    };
    let (samples, truth) = tumbling(30, 10.0, 5, &e);
    let dir = tempfile::tempdir().unwrap();
    let log = write(dir.path(), &samples);
    let out = dir.path().join("cal");
    let text = run_cli(&["calibrate", &log, "--out-dir", out.to_str().unwrap()]);
    // The report, for docs/calibrate.md (`-- --nocapture`).
    eprintln!("{text}");
    assert!(
        text.contains("result: calibration kept: bias + scale + misalignment"),
        "{text}"
    );
    let json: serde_json::Value = common::read_json(out.join("report.json"));
    let fitted = &json["accel"]["fitted"];
    assert!(
        text.contains("result (gyro): gyro calibration kept: scale + misalignment"),
        "{text}"
    );
    let gyro = &json["gyro"]["fitted"];
    let k_sd = |i: usize| gyro["k_sd"][i].as_f64().unwrap();
    // The config file is a user config: laid over the defaults, it sets [bias.settings.accel].
    let cfg = Config::from_file_source_replaced(&out.join("calibration.toml")).unwrap();
    let cal = cfg.stages.bias.as_ref().unwrap().settings.accel;
    let gcal = cfg.stages.bias.as_ref().unwrap().settings.gyro;
    for i in 0..3 {
        for j in 0..3 {
            // N = diag(scale)⁻¹ A; K = A⁻¹ ≈ 2I − A, so K's sd is that of scale and N to first
            // order; 4.5 σ over 9 entries.
            let (got, want) = if i == j {
                (gcal.scale[i], ga[(i, i)])
            } else {
                (gcal.misalignment[i][j], ga[(i, j)] / ga[(i, i)])
            };
            assert!(
                (got - want).abs() < 4.5 * k_sd(3 * i + j),
                "gyro ({i},{j}): {got} vs {want}"
            );
        }
    }
    for i in 0..3 {
        // The truth is lower triangular, so it is its own identifiable form; 4.5 σ of the
        // fit's own sd (9 parameters).
        let sd = fitted["scale_sd"][i].as_f64().unwrap();
        assert!(
            (cal.scale[i] - a[(i, i)]).abs() < 4.5 * sd,
            "scale {i}: {}",
            cal.scale[i]
        );
        let sd = fitted["bias_sd_m_s2"][i].as_f64().unwrap();
        assert!(
            (cal.bias[i] - b[i]).abs() < 4.5 * sd,
            "bias {i}: {}",
            cal.bias[i]
        );
    }
    // The daemon with that config: every stop's mean |f| is g within 5 σ of a stop mean's
    // noise plus the fit's error (the fitted in-sample RMS bounds the latter), where raw it was
    // off by up to a scale error times g.
    let (header, rows) = common::replay_csv(
        &log,
        &out.join("calibration.toml"),
        &dir.path().join("out.csv"),
    );
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    let (t, ax) = (col("t"), col("ax"));
    let fit_rms = json["accel"]["fit_rms_after_m_s2"].as_f64().unwrap();
    let mut worst_raw: f64 = 0.0;
    for stop in &truth {
        // The middle 6 s of the stop.
        let inside = |r: &&Vec<String>| {
            let ts: f64 = r[t].parse().unwrap();
            ts > stop.t0_s + 2.0 && ts < stop.t1_s - 2.0
        };
        let sel: Vec<Vector3<f64>> = rows
            .iter()
            .filter(inside)
            .map(|r| Vector3::from_fn(|i, _| r[ax + i].parse::<f64>().unwrap()))
            .collect();
        let mean = sel.iter().sum::<Vector3<f64>>() / sel.len() as f64;
        let sm = ACCEL_SD / (sel.len() as f64).sqrt();
        assert!(
            (mean.norm() - G).abs() < 5.0 * sm + 3.0 * fit_rms,
            "{mean:?}"
        );
        worst_raw = worst_raw.max(((a * stop.f + b).norm() - G).abs());
    }
    assert!(worst_raw > 0.08, "{worst_raw}");
}

#[test]
fn a_clean_tumbled_log_keeps_nothing_and_writes_no_config() {
    let (samples, _) = tumbling(30, 10.0, 8, &NO_ERRORS);
    let dir = tempfile::tempdir().unwrap();
    let log = write(dir.path(), &samples);
    let out = dir.path().join("cal");
    let text = run_cli(&["calibrate", &log, "--out-dir", out.to_str().unwrap()]);
    assert!(text.contains("result: nothing kept"), "{text}");
    assert!(text.contains("result (gyro): nothing kept"), "{text}");
    assert!(!out.join("calibration.toml").exists());
}

#[test]
fn no_gyro_calibration_is_added_on_twenty_clean_tumbles() {
    // A gyro bias (taken from the still stretches) but no scale or misalignment: nothing may be
    // kept. 12 stops (11 motions, enough for all nine entries of K) per seed; α = 0.001 per
    // round, so a false keep over 20 seeds × 2 tests would be ≈ 4 % likely if the test is exact.
    let e = Errors {
        gyro_b: Vector3::new(0.02, -0.01, 0.015),
        ..NO_ERRORS
    };
    for seed in 0..20 {
        let (samples, _) = tumbling(12, 8.0, 300 + seed, &e);
        let samples: Channels = samples.iter().collect();
        let st = still_stretches(&samples, RATE, &StillSettings::default());
        let ivs = gyro_intervals(&samples, &st, None, RATE, 30.0, 10.0);
        // 70° about a random axis tilts gravity by less than 10° only when the axis is
        // within ~8° of vertical: most of the 11 motions count.
        assert!(ivs.len() >= 7, "seed {seed}: {}", ivs.len());
        let g = calibrate_gyro(ivs, 0.001, 100.0).unwrap();
        assert!(g.fitted.is_none(), "seed {seed}: {:#?}", g.candidates);
        assert!(
            g.verdict.starts_with("nothing kept"),
            "seed {seed}: {}",
            g.verdict
        );
    }
}

#[test]
fn the_simulators_static_bench_and_drive_are_not_identifiable_with_or_without_scale_errors() {
    // The simulator's scale factor and misalignment, on its two motion profiles: a static bench
    // rests at one attitude and a car's stops tilt it by a few degrees, so neither may be
    // calibrated, whatever the errors.
    let dir = tempfile::tempdir().unwrap();
    for scenario in ["replay/static_bench.toml", "replay/drive.toml"] {
        for sets in [
            vec![],
            vec![
                "errors.scale_factor.accel_ppm=[15000.0, -8000.0, 5000.0]",
                "errors.misalignment.accel_mrad=[[0.0, 3.0, -2.0], [4.0, 0.0, 1.0], [-5.0, 2.0, 0.0]]",
            ],
        ] {
            let log = dir.path().join("sim.log");
            let mut args = vec!["simulate", scenario, "-o", log.to_str().unwrap()];
            for s in &sets {
                args.extend(["--set", s]);
            }
            run_cli(&args);
            let out = dir.path().join("cal");
            let text = run_cli(&[
                "calibrate",
                log.to_str().unwrap(),
                "--out-dir",
                out.to_str().unwrap(),
            ]);
            assert!(
                text.contains("result: not identifiable"),
                "{scenario} {sets:?}: {text}"
            );
            // Nothing fitted prints a reason, never an undefined number.
            assert!(!text.contains("NaN"), "{scenario} {sets:?}: {text}");
            assert!(!out.join("calibration.toml").exists());
        }
    }
}

#[test]
fn every_real_recording_is_not_identifiable() {
    // Measured (docs/calibrate.md): every real recording rests at one attitude (within 3.3°),
    // so no calibration may be claimed from it.
    let Some(root) = real_data("") else { return };
    let files = [
        "ximu3_fusion_example/sensor_data.csv",
        "rtklibexplorer_drive_walk/walk_0827_imu.csv",
        "rtklibexplorer_drive_walk/drive_0708_imu.csv",
        "px4_sensor_combined_sample/sensor_combined.csv",
        "comma2k19_car_segment/imu.csv",
        "mpu6050_static_10min_temp/mpu6050_static.csv",
        "px4_ulog/sample.ulg",
        "px4_ulog/sample_px4_events.ulg",
    ];
    let dir = tempfile::tempdir().unwrap();
    for (k, f) in files.iter().enumerate() {
        let src = root.join(f);
        if !src.exists() {
            skipped(&format!("{} not found", src.display()));
            continue;
        }
        let log = dir.path().join(format!("{k}.log"));
        run_cli(&["import", src.to_str().unwrap(), "-o", log.to_str().unwrap()]);
        let out = dir.path().join(format!("out{k}"));
        let text = run_cli(&[
            "calibrate",
            log.to_str().unwrap(),
            "--out-dir",
            out.to_str().unwrap(),
        ]);
        assert!(text.contains("result: not identifiable"), "{f}: {text}");
        assert!(
            text.contains("result (gyro): not identifiable"),
            "{f}: {text}"
        );
        assert!(!out.join("calibration.toml").exists());
    }
}
