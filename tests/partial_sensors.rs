//! Partial sensors (issue 13 item 10): a gyro-only or accel-only CSV imports, its absent
//! channels travel as absent (descriptor mask, NaN, empty CSV cell, JSON null + `absent` key,
//! health `absent_channels`), and the default pipeline never treats them as data: no bias,
//! no gross-error verdict, no stillness vote, no non-finite count. The present channels are
//! cleaned as they are when all six channels are there.

mod common;

use imuprep::io::log::read_log;
use imuprep::rng::Rng;
use imuprep::sample::{Sample, flags};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

const FS: f64 = 100.0;
const N: usize = 9000; // 90 s
/// True gyro bias, rad/s.
const GYRO_BIAS: [f64; 3] = [0.01, -0.02, 0.005];
/// Motion between these sample indices (40–50 s): a turn about z and a push along x.
const MOTION: (usize, usize) = (4000, 5000);
/// Single-channel spikes: (sample, channel, size).
const SPIKES: [(usize, usize, f64); 6] = [
    (3000, 0, 0.5),
    (6000, 1, -0.5),
    (7500, 2, 0.5),
    (3100, 3, 5.0),
    (6100, 4, -5.0),
    (7600, 5, 5.0),
];

/// Six channels of a bench-then-turn-then-bench recording with spikes.
fn scenario() -> Vec<[f64; 6]> {
    let mut r = Rng::new(1313);
    (0..N)
        .map(|i| {
            // A smooth bump over the motion window (zero outside it).
            let bump = if (MOTION.0..MOTION.1).contains(&i) {
                let x = (i - MOTION.0) as f64 / (MOTION.1 - MOTION.0) as f64;
                (std::f64::consts::PI * x).sin().powi(2)
            } else {
                0.0
            };
            let vib = if (MOTION.0..MOTION.1).contains(&i) {
                1.0
            } else {
                0.0
            };
            let mut v = [
                GYRO_BIAS[0] + 1e-3 * r.normal(),
                GYRO_BIAS[1] + 1e-3 * r.normal(),
                GYRO_BIAS[2] + 0.5 * bump + 1e-3 * r.normal(),
                // A push, and road vibration (5 Hz) an accelerometer alone sees as motion.
                0.05 + 1.0 * bump
                    + 0.5 * vib * (2.0 * std::f64::consts::PI * 5.0 * i as f64 / FS).sin()
                    + 0.02 * r.normal(),
                -0.03 + 0.02 * r.normal(),
                9.81 + 0.02 * r.normal(),
            ];
            for (k, c, a) in SPIKES {
                if k == i {
                    v[c] += a;
                }
            }
            v
        })
        .collect()
}

/// The scenario as CSV with time column `t_s` and the channels `cols` (indices into gx..az).
fn write_csv(path: &Path, data: &[[f64; 6]], cols: &[usize]) {
    std::fs::write(path, common::channels_csv(data, cols, FS)).unwrap();
}

/// What one import + replay produced.
struct Run {
    import_text: String,
    replay_text: String,
    imported: Vec<Sample>,
    imported_absent: u8,
    out: Vec<Sample>,
    out_absent: u8,
    csv: String,
    jsonl: String,
}

fn import_and_replay(dir: &Path, name: &str, cols: &[usize]) -> Run {
    let data = scenario();
    let csv_in = dir.join(format!("{name}.csv"));
    write_csv(&csv_in, &data, cols);
    let log = dir.join(format!("{name}.log"));
    let import_text = common::run_cli(&[
        "import",
        csv_in.to_str().unwrap(),
        "-o",
        log.to_str().unwrap(),
    ]);
    let (d, imported, _) = read_log(&log).unwrap();
    let out_log = dir.join(format!("{name}_clean.log"));
    let out_csv = dir.join(format!("{name}_clean.csv"));
    let out_jsonl = dir.join(format!("{name}_clean.jsonl"));
    let replay_text = common::run_cli(&[
        "replay",
        log.to_str().unwrap(),
        "--out",
        &format!("file:{}", out_log.display()),
        "--out",
        &format!("csv:{}", out_csv.display()),
        "--out",
        &format!("jsonl:{}", out_jsonl.display()),
    ]);
    let (od, out, _) = read_log(&out_log).unwrap();
    Run {
        import_text,
        replay_text,
        imported,
        imported_absent: d.unwrap().absent,
        out,
        out_absent: od.unwrap().absent,
        csv: std::fs::read_to_string(out_csv).unwrap(),
        jsonl: std::fs::read_to_string(out_jsonl).unwrap(),
    }
}

fn mask(cols: &[usize]) -> u8 {
    0x3f & !cols.iter().fold(0u8, |m, c| m | 1 << c)
}

/// Every property of an absent channel, on every output.
fn check_absent(run: &Run, cols: &[usize], label: &str) {
    let m = mask(cols);
    let absent: Vec<usize> = (0..6).filter(|c| m & (1 << c) != 0).collect();
    assert_eq!(run.imported_absent, m, "{label}: imported descriptor mask");
    assert_eq!(run.out_absent, m, "{label}: output descriptor mask");
    assert!(
        run.import_text.contains("channels absent"),
        "{label}: import says nothing about absent channels:\n{}",
        run.import_text
    );
    assert!(
        run.replay_text.contains("absent     :"),
        "{label}: the summary has no absent line:\n{}",
        run.replay_text
    );
    assert_eq!(run.out.len(), N, "{label}");
    for (i, s) in run.imported.iter().chain(&run.out).enumerate() {
        assert_eq!(s.absent, m, "{label} #{i}");
        assert!(
            !s.has(flags::NON_FINITE),
            "{label} #{i}: absent counted non-finite"
        );
        for &c in &absent {
            // Never a measured zero (nor any other number).
            assert!(
                s.channel(c).is_nan(),
                "{label} #{i} ch {c}: {}",
                s.channel(c)
            );
            assert_eq!(
                s.flags & flags::replaced_ch(c),
                0,
                "{label} #{i} ch {c} replaced"
            );
            assert_eq!(
                s.flags & flags::suspect_ch(c),
                0,
                "{label} #{i} ch {c} suspect"
            );
            assert_eq!(
                s.flags & flags::sat_ch(c),
                0,
                "{label} #{i} ch {c} saturated"
            );
            assert_eq!((s.bias[c], s.bias_sd[c]), (0.0, 0.0), "{label} #{i} ch {c}");
        }
    }
    // CSV: absent channels are empty cells in every row (not 0, not NaN).
    let mut rows = run.csv.lines();
    assert_eq!(rows.next(), Some("t,gx,gy,gz,ax,ay,az,temp,seq,flags"));
    for row in rows {
        let cells: Vec<&str> = row.split(',').collect();
        for c in 0..6 {
            let cell = cells[1 + c];
            if m & (1 << c) != 0 {
                assert_eq!(cell, "", "{label}: csv row {row}");
            } else {
                assert!(cell.parse::<f64>().unwrap().is_finite(), "{label}: {row}");
            }
        }
    }
    // JSON lines: null values plus the `absent` key; the health record's absent_channels.
    let names = ["gx", "gy", "gz", "ax", "ay", "az"];
    let want_names: Vec<&str> = absent.iter().map(|c| names[*c]).collect();
    let mut health = 0;
    for line in run.jsonl.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        if v["type"] == "health" {
            assert_eq!(v["absent_channels"], u64::from(m), "{label}: {line}");
            assert_eq!(v["flagged_non_finite"], 0, "{label}: {line}");
            health += 1;
            continue;
        }
        let got: Vec<&str> = v["absent"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_str().unwrap())
            .collect();
        assert_eq!(got, want_names, "{label}: {line}");
        for &c in &absent {
            let key = if c < 3 { "gyro" } else { "accel" };
            assert!(v[key][c % 3].is_null(), "{label}: {line}");
        }
    }
    assert!(health >= 1, "{label}: no health record");
}

/// Indices of the samples whose channel `c` was replaced.
fn replaced(out: &[Sample], c: usize) -> Vec<usize> {
    (0..out.len())
        .filter(|i| out[*i].flags & flags::replaced_ch(c) != 0)
        .collect()
}

fn still_in(out: &[Sample], r: std::ops::Range<usize>) -> usize {
    out[r].iter().filter(|s| s.has(flags::STILL)).count()
}

#[test]
fn gyro_only_and_accel_only_csvs_import_and_clean_without_touching_absent_channels() {
    let dir = tempfile::tempdir().unwrap();
    let full = import_and_replay(dir.path(), "full", &[0, 1, 2, 3, 4, 5]);
    assert_eq!(full.out_absent, 0);
    for (label, cols) in [("gyro-only", [0usize, 1, 2]), ("accel-only", [3, 4, 5])] {
        let run = import_and_replay(dir.path(), label, &cols);
        check_absent(&run, &cols, label);
        // Present channels are cleaned as with all six channels: every spike replaced, at the
        // same samples (the gross-error decision is per channel; the absent ones were never
        // partners of the several-axes test because the spikes are single-channel), and the
        // same output values where the bias stage only calibrates (accel).
        for &c in &cols {
            let (want, got) = (replaced(&full.out, c), replaced(&run.out, c));
            assert_eq!(
                got, want,
                "{label}: channel {c} replaced samples differ from the full run"
            );
            let spike = SPIKES.iter().find(|s| s.1 == c).unwrap().0;
            assert!(
                got.contains(&spike),
                "{label}: spike at {spike} on channel {c} not replaced"
            );
            if c >= 3 {
                for i in 0..N {
                    assert_eq!(
                        run.out[i].channel(c).to_bits(),
                        full.out[i].channel(c).to_bits(),
                        "{label} #{i} ch {c}"
                    );
                }
            }
        }
        // Stillness: the present triad votes — rest is found before and after the motion and
        // never during it — and the absent triad neither vetoes rest nor declares it.
        let before = still_in(&run.out, 1000..MOTION.0);
        let during = still_in(&run.out, MOTION.0 + 50..MOTION.1 - 50);
        let after = still_in(&run.out, MOTION.1 + 500..N);
        assert!(
            before > 2000,
            "{label}: only {before} still samples at rest before"
        );
        assert!(
            after > 2500,
            "{label}: only {after} still samples at rest after"
        );
        assert_eq!(during, 0, "{label}: still during the motion");
    }
    // The gyro-only run learns the gyro bias from its own stillness: at the end every gyro
    // channel's estimate is within 1e-3 rad/s of the truth (its noise is 1e-3 per sample; the
    // still-stretch mean over thousands of samples is ~100× tighter, the rest is the estimator's
    // lag) and the output is unbiased to the same bound.
    let run = import_and_replay(dir.path(), "gyro-only-bias", &[0, 1, 2]);
    let last = run.out.last().unwrap();
    assert!(last.has(flags::BIAS_REMOVED));
    for (c, truth) in GYRO_BIAS.iter().enumerate() {
        assert!(
            (f64::from(last.bias[c]) - truth).abs() < 1e-3,
            "gyro-only: channel {c} bias {} vs {truth}",
            last.bias[c],
        );
        let tail: f64 = run.out[N - 2000..]
            .iter()
            .map(|s| s.channel(c))
            .sum::<f64>()
            / 2000.0;
        assert!(
            tail.abs() < 1e-3,
            "gyro-only: channel {c} output mean {tail}"
        );
    }
}

#[test]
fn a_single_gyro_axis_imports_with_five_absent_channels() {
    // `t_s,gyro_x`: the example (unit given: the name carries none).
    let dir = tempfile::tempdir().unwrap();
    let data = scenario();
    let mut s = String::from("t_s,gyro_x\n");
    for (i, v) in data.iter().enumerate() {
        let _ = writeln!(s, "{:.2},{:.7}", i as f64 / FS, v[0]);
    }
    let csv = dir.path().join("gx.csv");
    std::fs::write(&csv, s).unwrap();
    let log = dir.path().join("gx.log");
    let (csv_s, log_s) = (csv.to_str().unwrap(), log.to_str().unwrap());
    // Without a unit the import says what is missing instead of guessing.
    let out = Command::new(common::bin())
        .args(["import", csv_s, "-o", log_s])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--gyro-unit"));
    let text = common::run_cli(&["import", csv_s, "-o", log_s, "--gyro-unit", "rad/s"]);
    assert!(
        text.contains("channels absent") && text.contains("gy, gz, ax, ay, az"),
        "{text}"
    );
    let (d, samples, st) = read_log(&log).unwrap();
    assert_eq!(d.unwrap().absent, 0b111110);
    assert_eq!(st.non_finite, 0);
    assert_eq!(samples.len(), N);
    assert!(
        samples
            .iter()
            .all(|s| s.gyro[0].is_finite() && s.gyro[1].is_nan())
    );
    // The export of a partial log re-imports with the same channels absent (empty columns).
    let back = dir.path().join("back.csv");
    common::run_cli(&["export", log_s, "-o", back.to_str().unwrap()]);
    let log2 = dir.path().join("back.log");
    let text = common::run_cli(&[
        "import",
        back.to_str().unwrap(),
        "-o",
        log2.to_str().unwrap(),
    ]);
    assert!(text.contains("gy, gz, ax, ay, az"), "{text}");
    let (d2, s2, _) = read_log(&log2).unwrap();
    assert_eq!(d2.unwrap().absent, 0b111110);
    assert_eq!(s2.len(), N);
    for (a, b) in samples.iter().zip(&s2) {
        assert_eq!(a.gyro[0] as f32, b.gyro[0] as f32);
    }
}

#[test]
fn a_csv_without_any_channel_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text, want) in [
        ("none.csv", "t_s,temp\n0,25\n0.01,25\n", "no sensor column"),
        (
            "empty.csv",
            "t,gx,gy,gz,ax,ay,az,temp\n0,,,,,,,25\n0.01,,,,,,,25\n",
            "no sensor data",
        ),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let out = Command::new(common::bin())
            .args(["import", p.to_str().unwrap(), "-o"])
            .arg(dir.path().join("x.log"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}: {err}");
        assert!(err.contains(want), "{name}: {err}");
        assert!(
            !dir.path().join("x.log").exists(),
            "{name}: a log was written"
        );
    }
    // A channel with only some cells empty is present, its empty cells missing values: the
    // file imports, the cells counted with the line of the first (tests/import_empty_cells.rs).
    let p = dir.path().join("holes.csv");
    std::fs::write(&p, "t,gx,gy,gz\n0,1,2,3\n0.01,1,,3\n").unwrap();
    let out = Command::new(common::bin())
        .args(["import", p.to_str().unwrap(), "-o"])
        .arg(dir.path().join("y.log"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && err.contains("gy: 1 empty cell (first at line 3)"),
        "{err}"
    );
}
