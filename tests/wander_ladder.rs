//! Issue 17's "an effect of the size `diagnose` can find", for the monitor's wander test: the
//! smallest Gauss–Markov wander that `imuprep diagnose LOG` (whole log, defaults) keeps on its
//! held-out test, in the monitor's units — multiples of the 1-s mean's white-noise σ.
//!
//! Logs: `tests/fixtures/wander_ladder.toml` (white noise, quantisation and one GM bias, 100 Hz,
//! static), each axis pair (gx/ax, gy/ay, gz/az) carrying one size of the ladder. The monitor's
//! time to flag a wander of the size found here is in `tests/model_health.rs`
//! (`wander_of_the_size_diagnose_finds`). Table and commands: docs/model-health.md.

mod common;

use std::path::{Path, PathBuf};

/// 1-s mean of the white noise: 0.005 °/s = 18 °/h (gyro), 0.3995 mg (accelerometer).
const W1_GYRO_DEG_H: f64 = 18.0;
const W1_ACCEL_MG: f64 = 0.3995;

/// A scratch directory of its own for this test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "imuprep-wander-ladder-{}-{name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The ladder scenario with GM `tau_s` and sizes `k` (× the 1-s white σ) on the three axis
/// pairs, written to `dir/scenario.toml`.
fn scenario(dir: &Path, tau_s: f64, k: [f64; 3]) -> PathBuf {
    let text = std::fs::read_to_string("tests/fixtures/wander_ladder.toml").unwrap();
    let mut t: toml::Table = text.parse().unwrap();
    let gm = &mut t["errors"]["gauss_markov"].as_array_mut().unwrap()[0];
    let gm = gm.as_table_mut().unwrap();
    gm.insert("tau_s".into(), tau_s.into());
    let arr = |w: f64| toml::Value::Array(k.iter().map(|x| (x * w).into()).collect());
    gm.insert("gyro_sigma_deg_h".into(), arr(W1_GYRO_DEG_H));
    gm.insert("accel_sigma_mg".into(), arr(W1_ACCEL_MG));
    let p = dir.join("scenario.toml");
    std::fs::write(&p, toml::to_string(&t).unwrap()).unwrap();
    p
}

/// Per channel (gx … az): whether `diagnose` kept (held-out test passed) and wrote a wander.
fn diagnose_wander(
    dir: &Path,
    tau_s: f64,
    k: [f64; 3],
    duration_s: f64,
    seed: u64,
) -> Vec<(bool, bool)> {
    let scn = scenario(dir, tau_s, k);
    let log = dir.join("x.log");
    let out = dir.join("out");
    let d = format!("motion.duration_s={duration_s}");
    let seed = seed.to_string();
    common::run_cli(&[
        "simulate",
        scn.to_str().unwrap(),
        "-o",
        log.to_str().unwrap(),
        "--seed",
        &seed,
        "--set",
        &d,
    ]);
    common::run_cli(&[
        "diagnose",
        log.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    let j: serde_json::Value = common::read_json(out.join("report.json"));
    j["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let w = &c["wander"];
            (
                w["test"]["kept"].as_bool().unwrap_or(false),
                w["written"].as_bool().unwrap_or(false),
            )
        })
        .collect()
}

#[test]
fn diagnose_keeps_a_wander_of_once_the_white_noise_and_none_on_white_logs() {
    // 20-min logs, GM τ = 20 s. Measured over 8 seeds (docs/model-health.md, the ignored ladder
    // below): at 1× the 1-s white σ diagnose keeps and writes the wander on 16 of 16 channels
    // (held-out p ≤ 2.4e-7 against its level 1e-3), on 0 of 48 white-only channels. Four seeds
    // here: a miss at 1× or a keep on white noise would move the number docs/model-health.md
    // gives as "the size diagnose can find".
    let dir = scratch("fast");
    for seed in 1..=4u64 {
        let one = diagnose_wander(&dir, 20.0, [1.0, 1.0, 1.0], 1200.0, seed);
        assert!(one.iter().all(|&(k, w)| k && w), "seed {seed}, 1×: {one:?}");
        let none = diagnose_wander(&dir, 20.0, [0.0, 0.0, 0.0], 1200.0, seed);
        assert!(
            none.iter().all(|&(k, _)| !k),
            "seed {seed}, white: {none:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The ladder behind docs/model-health.md (`--ignored`: 96 simulate + diagnose runs, ~3 min).
#[test]
#[ignore]
fn diagnose_wander_ladder() {
    let dir = scratch("ladder");
    for duration_s in [1200.0, 3600.0] {
        for tau_s in [20.0, 60.0] {
            for ks in [[0.0; 3], [0.25, 0.5, 1.0], [1.5, 2.0, 3.0]] {
                // Kept (of 8 seeds × gyro and accelerometer) per size.
                let mut kept = [0usize; 3];
                for seed in 1..=8u64 {
                    let r = diagnose_wander(&dir, tau_s, ks, duration_s, seed);
                    for (c, &(k, w)) in r.iter().enumerate() {
                        kept[c % 3] += usize::from(k && w);
                    }
                }
                for (k, n) in ks.iter().zip(kept) {
                    eprintln!(
                        "{:.0} min, τ {tau_s} s, {k}× the 1-s white σ: wander kept on {n} of 16",
                        duration_s / 60.0
                    );
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
