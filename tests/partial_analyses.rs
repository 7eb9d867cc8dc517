//! `fit`, `allan` and `compare` on partial sensors (issue 13 item 10): a gyro-only or
//! accel-only log's absent channels get no model and no analysis, are named in the report and
//! the files written, put no NaN anywhere, and leave the present channels' results exactly as
//! the same data gives with all six channels. A log (or a `--channel` choice) with nothing
//! present is a clear error.

mod common;

use imuprep::rng::Rng;
use std::path::Path;
use std::process::Command;

const FS: f64 = 100.0;
/// 200 s: `fit`'s default training span (180 s) and the Allan τ grid fit in it.
const N: usize = 20_000;
const NAMES: [&str; 6] = ["gx", "gy", "gz", "ax", "ay", "az"];

/// A static recording: gyro bias + 1e-3 rad/s white noise, accel gravity + 0.02 m/s² noise.
fn data() -> Vec<[f64; 6]> {
    let mut r = Rng::new(1313);
    (0..N)
        .map(|_| {
            [
                0.01 + 1e-3 * r.normal(),
                -0.02 + 1e-3 * r.normal(),
                0.005 + 1e-3 * r.normal(),
                0.05 + 0.02 * r.normal(),
                -0.03 + 0.02 * r.normal(),
                9.81 + 0.02 * r.normal(),
            ]
        })
        .collect()
}

/// Import the channels `cols` of the data as a log `name.log` in `dir`.
fn log_of(dir: &Path, name: &str, cols: &[usize]) -> String {
    let csv = common::channels_csv(&data(), cols, FS);
    let log = common::import_csv(dir, name, &csv);
    log.to_str().unwrap().to_string()
}

fn fails(args: &[&str]) -> String {
    let out = Command::new(common::bin()).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "imuprep {args:?} succeeded:\n{err}");
    err
}

/// No NaN (nor inf) in any file of `dir` and its folders.
fn no_nan_in(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            no_nan_in(&p);
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        for w in text.split(|c: char| !c.is_ascii_alphanumeric()) {
            assert!(
                !w.eq_ignore_ascii_case("nan") && !w.eq_ignore_ascii_case("inf"),
                "{}: {w}",
                p.display()
            );
        }
    }
}

/// The `[[channels]]` blocks of a model file, by channel name.
fn blocks(path: &Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(path).unwrap();
    text.split("[[channels]]")
        .skip(1)
        .map(|b| {
            let name = b
                .lines()
                .find_map(|l| l.strip_prefix("channel = \""))
                .unwrap()
                .trim_end_matches('"')
                .to_string();
            (name, b.trim().to_string())
        })
        .collect()
}

#[test]
fn fit_models_only_the_present_channels_and_says_which_are_absent() {
    let dir = tempfile::tempdir().unwrap();
    let full = log_of(dir.path(), "full", &[0, 1, 2, 3, 4, 5]);
    let full_out = dir.path().join("fit_full");
    common::run_cli(&["fit", &full, "--out-dir", full_out.to_str().unwrap()]);
    for (label, cols) in [("gyro", [0usize, 1, 2]), ("accel", [3, 4, 5])] {
        let log = log_of(dir.path(), label, &cols);
        let out = dir.path().join(format!("fit_{label}"));
        let text = common::run_cli(&["fit", &log, "--out-dir", out.to_str().unwrap()]);
        no_nan_in(&out);
        let absent: Vec<&str> = (0..6)
            .filter(|c| !cols.contains(c))
            .map(|c| NAMES[c])
            .collect();
        for file in ["arima.toml", "bias.toml"] {
            let got = blocks(&out.join(file));
            let names: Vec<&str> = got.iter().map(|(n, _)| n.as_str()).collect();
            let want: Vec<&str> = cols.iter().map(|c| NAMES[*c]).collect();
            assert_eq!(names, want, "{label} {file}");
            let head = std::fs::read_to_string(out.join(file)).unwrap();
            for a in &absent {
                assert!(head.contains(&format!("# imuprep fit: {a}: no model: absent")));
                assert!(
                    text.contains(&format!("{a:<4} not fitted: absent")),
                    "{text}"
                );
            }
            // The ARIMA identification of a present channel does not depend on the absent
            // ones: the same block as from the six-channel log. (The bias model is fitted on
            // the still stretch, which the full log's accelerometers also vote on.)
            if file == "arima.toml" {
                let full_blocks = blocks(&full_out.join(file));
                for (n, b) in &got {
                    let f = &full_blocks.iter().find(|(m, _)| m == n).unwrap().1;
                    assert_eq!(b, f, "{label}: {n}");
                }
            }
        }
        // The files load as models (comments and a subset of channels are valid).
        let cfg = dir.path().join(format!("{label}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "[source]\nkind = \"replay\"\npath = \"{log}\"\n[gross_error]\nenabled = true\nmodel = \"{}\"\n[bias]\nenabled = true\nmodel = \"{}\"\n",
                out.join("arima.toml").display(),
                out.join("bias.toml").display()
            ),
        )
        .unwrap();
        let clean = dir.path().join(format!("{label}_clean.log"));
        common::run_cli(&[
            "replay",
            &log,
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            &format!("file:{}", clean.display()),
        ]);
    }
}

#[test]
fn allan_analyses_only_the_present_channels_and_says_which_are_absent() {
    let dir = tempfile::tempdir().unwrap();
    let full = log_of(dir.path(), "full", &[0, 1, 2, 3, 4, 5]);
    let full_out = dir.path().join("allan_full");
    let full_json = dir.path().join("full.json");
    common::run_cli(&[
        "allan",
        &full,
        "--out-dir",
        full_out.to_str().unwrap(),
        "--json",
        full_json.to_str().unwrap(),
    ]);
    let full_v: serde_json::Value = common::read_json(&full_json);
    for (label, cols) in [("gyro", [0usize, 1, 2]), ("accel", [3, 4, 5])] {
        let log = log_of(dir.path(), label, &cols);
        let out = dir.path().join(format!("allan_{label}"));
        let json = dir.path().join(format!("{label}.json"));
        let text = common::run_cli(&[
            "allan",
            &log,
            "--out-dir",
            out.to_str().unwrap(),
            "--json",
            json.to_str().unwrap(),
        ]);
        no_nan_in(&out);
        let v: serde_json::Value = common::read_json(&json);
        let chans = v["channels"].as_array().unwrap();
        assert_eq!(chans.len(), 3, "{label}");
        let skipped = v["skipped"].as_array().unwrap();
        assert_eq!(skipped.len(), 3, "{label}: {skipped:?}");
        for s in skipped {
            let why = s[1].as_str().unwrap();
            assert!(why.starts_with("absent"), "{label}: {why}");
            assert!(text.contains(&format!("{}: skipped: absent", s[0].as_str().unwrap())));
        }
        // A present channel's analysis is the six-channel log's, value for value.
        for (k, c) in chans.iter().enumerate() {
            let f = &full_v["channels"][cols[k]];
            assert_eq!(c, f, "{label}: channel {}", cols[k]);
        }
    }
    // Asking only for channels the log lacks: an error naming them and what the log has.
    let g = dir.path().join("gyro.log");
    let err = fails(&[
        "allan",
        g.to_str().unwrap(),
        "--channel",
        "ax",
        "--channel",
        "az",
        "--out-dir",
        dir.path().join("x").to_str().unwrap(),
    ]);
    assert!(
        err.contains("ax, az absent") && err.contains("it has gx, gy, gz"),
        "{err}"
    );
    let err = fails(&["compare", g.to_str().unwrap(), "--channel", "ay"]);
    assert!(
        err.contains("ay absent") && err.contains("it has gx, gy, gz"),
        "{err}"
    );
}

/// `diagnose` (whole-log and paper-split) on a gyro-only and an accel-only log: every present
/// channel is diagnosed (before, the absent triad's NaN made every channel "cannot diagnose:
/// non-finite input"), each absent one is named, and no file holds NaN.
#[test]
fn diagnose_works_on_the_present_channels_and_names_the_absent_ones() {
    let dir = tempfile::tempdir().unwrap();
    for (label, cols) in [("gyro", [0usize, 1, 2]), ("accel", [3, 4, 5])] {
        let log = log_of(dir.path(), label, &cols);
        for split in [false, true] {
            let out = dir.path().join(format!("diag_{label}_{split}"));
            let mut args = vec!["diagnose", &log, "--out-dir", out.to_str().unwrap()];
            if split {
                // The paper split needs 6 min + test; this log is 200 s: a clear per-channel
                // error is fine there, NaN-caused or absent-channel errors are not.
                args.push("--paper-split");
            }
            let text = common::run_cli(&args);
            no_nan_in(&out);
            for (c, n) in NAMES.iter().enumerate() {
                if cols.contains(&c) {
                    assert!(
                        !text.contains(&format!("{n}: cannot diagnose: non-finite")),
                        "{label} split={split}: {text}"
                    );
                    if !split {
                        assert!(text.contains(&format!("{n}: held-out")), "{label}: {text}");
                    }
                } else {
                    assert!(
                        text.contains(&format!("{n}: skipped: absent")),
                        "{label} split={split}: {text}"
                    );
                }
            }
        }
    }
}

/// A channel with a few missing values (empty cells, imported as NaN) once failed the whole fit
/// ("gz: non-finite value at index 500", no file named, no model for the whole channels): it
/// is left out with its count of non-finite samples, named in the report and both files'
/// headers, and the whole channels get exactly the models the same data gives without the gap.
#[test]
fn fit_leaves_out_a_channel_with_missing_values_and_fits_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let full = log_of(dir.path(), "full", &[0, 1, 2, 3, 4, 5]);
    let full_out = dir.path().join("fit_full");
    common::run_cli(&["fit", &full, "--out-dir", full_out.to_str().unwrap()]);
    // The same data with gz empty on three rows (5 s, 70 s, 150 s: all in the 180-s span).
    let csv = common::channels_csv(&data(), &[0, 1, 2, 3, 4, 5], FS);
    let holed: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if [501, 7001, 15001].contains(&i) {
                let mut f: Vec<&str> = l.split(',').collect();
                f[3] = "";
                f.join(",") + "\n"
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let log = common::import_csv(dir.path(), "holed", &holed);
    let out = dir.path().join("fit_holed");
    let text = common::run_cli(&[
        "fit",
        log.to_str().unwrap(),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert!(
        text.contains(
            "gz   not fitted: 3 non-finite samples in the training span (first at 5.000 s"
        ),
        "{text}"
    );
    for file in ["arima.toml", "bias.toml"] {
        let head = std::fs::read_to_string(out.join(file)).unwrap();
        assert!(
            head.starts_with("# imuprep fit: gz: no model: 3 non-finite samples"),
            "{file}: {head}"
        );
        let got = blocks(&out.join(file));
        let want: Vec<_> = blocks(&full_out.join(file))
            .into_iter()
            .filter(|(c, _)| c != "gz")
            .collect();
        assert_eq!(got, want, "{file}");
    }
    no_nan_in(&out);
}

/// `compare` on a log with two missing gz values once failed as a whole with "non-finite value
/// at index 1234" (no file, no channel); a log shorter than the paper's split said "record too
/// short" naming neither. Now gz is skipped with its count and the other channels are compared;
/// the short log's error names the log, the channel and its length.
#[test]
fn compare_skips_a_channel_with_missing_values_and_names_a_short_log() {
    let dir = tempfile::tempdir().unwrap();
    // 370 s at 100 Hz: the paper's split (3 min + 3 min + test) fits.
    let mut r = Rng::new(77);
    let long: Vec<[f64; 6]> = (0..37_000)
        .map(|_| std::array::from_fn(|c| if c == 5 { 9.81 } else { 0.0 } + 1e-2 * r.normal()))
        .collect();
    let csv = common::channels_csv(&long, &[0, 1, 2, 3, 4, 5], FS);
    let holed: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            let mut f: Vec<&str> = l.split(',').collect();
            if i == 1235 || i == 30001 {
                f[3] = "";
            }
            f.join(",") + "\n"
        })
        .collect();
    let log = common::import_csv(dir.path(), "holed", &holed);
    let text = common::run_cli(&["compare", log.to_str().unwrap()]);
    assert!(
        text.contains("gz: skipped: 2 non-finite samples (first at 12.340 s of the log)"),
        "{text}"
    );
    for c in ["gx", "gy", "ax", "ay", "az"] {
        assert!(text.contains(&format!("channel {c} (")), "{c}: {text}");
    }
    // 200 s: too short for the split; the error names the log and what it holds.
    let short = log_of(dir.path(), "short", &[0, 1, 2, 3, 4, 5]);
    let err = fails(&["compare", &short]);
    assert!(
        err.contains(&format!(
            "{short}: gx (200.0 s at 100 Hz): record too short"
        )),
        "{err}"
    );
}
