//! Inputs that decode to nothing, or mostly to garbage (issue 13, item 8): offline commands say
//! so loudly and exit non-zero instead of publishing nothing with status 0.
mod common;

use imuprep::rng::Rng;
use std::path::Path;

/// Run imuprep; its exit code and stderr.
fn run(args: &[&str]) -> (i32, String) {
    let out = std::process::Command::new(common::bin())
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn header() -> Vec<u8> {
    let mut h = b"IMUPLOG\0".to_vec();
    h.extend_from_slice(&1u16.to_le_bytes());
    h.extend_from_slice(&0u16.to_le_bytes());
    h
}

fn garbage(n: usize, seed: u64) -> Vec<u8> {
    let mut r = Rng::new(seed);
    (0..n).map(|_| r.next_u64() as u8).collect()
}

fn write(p: &Path, b: &[u8]) -> String {
    std::fs::write(p, b).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn header_only_log_fails_replay_and_export_loudly() {
    let dir = tempfile::tempdir().unwrap();
    let log = write(&dir.path().join("h.log"), &header());
    let out = dir.path().join("o.csv");
    for args in [
        vec!["replay", &log],
        vec!["export", &log, "-o", out.to_str().unwrap()],
    ] {
        let (code, err) = run(&args);
        assert_eq!(code, 3, "{args:?}: {err}");
        assert!(err.contains("ERROR") && err.contains("no samples"), "{err}");
    }
}

#[test]
fn garbage_log_fails_replay_export_and_import_loudly() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = header();
    b.extend(garbage(100_000, 13));
    let log = write(&dir.path().join("g.log"), &b);
    let out = dir.path().join("o.log");
    for args in [
        vec!["replay", &log],
        vec!["export", &log, "-o", out.to_str().unwrap()],
        vec!["import", &log, "-o", out.to_str().unwrap()],
    ] {
        let (code, err) = run(&args);
        assert_eq!(code, 3, "{args:?}: {err}");
        assert!(err.contains("ERROR"), "{err}");
    }
}

#[test]
fn mostly_garbage_fails_and_a_clean_log_passes() {
    let dir = tempfile::tempdir().unwrap();
    let samples = common::samples(500, 4);
    let mut clean = bytes::BytesMut::new();
    imuprep::io::log::encode_log(&common::descriptor(), &samples, &mut clean);
    let good = write(&dir.path().join("good.log"), &clean);
    let (code, err) = run(&["replay", &good]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("ERROR"), "{err}");
    // The same 500 samples (28 kB) followed by 100 kB of garbage: most of the input is garbage.
    let mut bad = clean.to_vec();
    bad.extend(garbage(100_000, 21));
    let bad = write(&dir.path().join("bad.log"), &bad);
    let (code, err) = run(&["replay", &bad]);
    assert_eq!(code, 3, "{err}");
    assert!(err.contains("most of the input was garbage"), "{err}");
}

#[test]
fn csv_with_only_a_header_fails_import() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write(&dir.path().join("h.csv"), b"t,gx,gy,gz,ax,ay,az,temp\n");
    let out = dir.path().join("o.log");
    let (code, err) = run(&["import", &csv, "-o", out.to_str().unwrap()]);
    assert_eq!(code, 3, "{err}");
    assert!(err.contains("no data rows"), "{err}");
}

/// A CSV or a protocol recording given to an analysis command (`fit`, `allan`, `diagnose`,
/// `calibrate`, `compare`), or a CSV to `export`, is read as `imuprep import` reads it, with no
/// flags: the command's results are those on the log `import` writes, to the byte, and stderr says what was done
/// and the way to keep it as a log. Once these commands refused such a file and named
/// `import` as the way in.
#[test]
fn analysis_commands_read_a_csv_or_a_recording_as_import_does() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let scn = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.toml");
    let sim = p("sim.log");
    let steps: [&[&str]; 5] = [
        &[
            "simulate",
            scn,
            "--set",
            "motion.duration_s=300",
            "-o",
            &sim,
        ],
        &["export", &sim, "-o", &p("sim.csv")],
        &["export", &sim, "--to", "ulog", "-o", &p("sim.ulg")],
        &["import", &p("sim.csv"), "-o", &p("csv.log")],
        &["import", &p("sim.ulg"), "-o", &p("ulg.log")],
    ];
    for args in steps {
        let (code, err) = run(args);
        assert_eq!(code, 0, "{args:?}: {err}");
    }
    for (direct, imported) in [("sim.csv", "csv.log"), ("sim.ulg", "ulg.log")] {
        let fit = |input: &str| {
            let out = p(&format!("fit-{input}"));
            let (code, err) = run(&["fit", &p(input), "--train-s", "250", "--out-dir", &out]);
            assert_eq!(code, 0, "fit {input}: {err}");
            let read = |f: &str| std::fs::read_to_string(format!("{out}/{f}")).unwrap();
            (read("arima.toml"), read("bias.toml"), err)
        };
        let (arima, bias, err) = fit(direct);
        assert!(
            err.contains("not an imuprep log: read as `imuprep import` reads it"),
            "{direct}: {err}"
        );
        assert!(err.contains("-o OUT.log` keeps it as a log"), "{err}");
        let (arima_log, bias_log, _) = fit(imported);
        assert_eq!(arima, arima_log, "{direct}: arima.toml");
        assert_eq!(bias, bias_log, "{direct}: bias.toml");
        assert!(
            bias.contains("[[channels]]"),
            "a bias model was fitted: {bias}"
        );
    }
    // `export` too: a CSV into a ULog, the bytes of the export of its import's log.
    for (input, out) in [("sim.csv", "direct.ulg"), ("csv.log", "of_log.ulg")] {
        let (code, err) = run(&["export", &p(input), "--to", "ulog", "-o", &p(out)]);
        assert_eq!(code, 0, "export {input}: {err}");
    }
    let direct = std::fs::read(p("direct.ulg")).unwrap();
    assert!(
        direct.len() > 30000 * 40,
        "every sample: {} bytes",
        direct.len()
    );
    assert!(
        direct == std::fs::read(p("of_log.ulg")).unwrap(),
        "export of the CSV"
    );
    // Every analysis command takes the CSV (the data is a short bench: each command's own
    // verdict on it, as on its log — compare's is "record too short" — but no refusal of the
    // file).
    for cmd in ["allan", "diagnose", "calibrate", "compare"] {
        let out = p(&format!("{cmd}-out"));
        let csv = p("sim.csv");
        let args: Vec<&str> = match cmd {
            "compare" => vec![cmd, &csv],
            _ => vec![cmd, &csv, "--out-dir", &out],
        };
        let (_, err) = run(&args);
        assert!(err.contains("not an imuprep log: read as"), "{cmd}: {err}");
        assert!(!err.contains("wrong magic"), "{cmd}: {err}");
        assert!(!err.contains("panicked"), "{cmd}: {err}");
    }
}

/// The import flags on the commands that read recordings: a headerless table in deg/s and g,
/// 1000 s into its clock, read with `--columns`, `--gyro-unit`, `--accel-unit` by `fit` and
/// `replay` gives, to the byte, what the log `import` writes with the same flags gives. A flag
/// a reader would ignore is refused, naming it: any import flag on an imuprep log, a table's flag
/// on a sensor protocol's file. `--rebase-time` applies to a protocol's file too (before, it was
/// ignored there).
#[test]
fn commands_take_import_flags_and_refuse_those_they_would_ignore() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let scn = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.toml");
    let ok = |args: &[&str]| {
        let (code, err) = run(args);
        assert_eq!(code, 0, "{args:?}: {err}");
        err
    };
    ok(&[
        "simulate",
        scn,
        "--set",
        "motion.duration_s=300",
        "-o",
        &p("sim.log"),
    ]);
    ok(&["export", &p("sim.log"), "-o", &p("sim.csv")]);
    // t + 1000 s, rad/s → deg/s, m/s² → g, no header, the temperature and flags left out.
    let text = std::fs::read_to_string(p("sim.csv")).unwrap();
    let mut table = String::new();
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line
            .split(',')
            .take(7)
            .map(|c| c.parse().unwrap())
            .collect();
        let g = 9.80665;
        table += &format!(
            "{:.6},{},{},{},{},{},{}\n",
            v[0] + 1000.0,
            v[1].to_degrees(),
            v[2].to_degrees(),
            v[3].to_degrees(),
            v[4] / g,
            v[5] / g,
            v[6] / g
        );
    }
    std::fs::write(p("deg.txt"), table).unwrap();
    let flags = [
        "--columns",
        "t,gx,gy,gz,ax,ay,az",
        "--gyro-unit",
        "deg/s",
        "--accel-unit",
        "g",
    ];
    fn with<'a>(head: &[&'a str], flags: &[&'a str]) -> Vec<&'a str> {
        [head, flags].concat()
    }
    ok(&with(
        &["import", &p("deg.txt"), "-o", &p("deg.log")],
        &flags,
    ));
    let fit = |input: &str, extra: &[&str]| {
        let (out, input) = (p(&format!("fit-{}", extra.len())), p(input));
        let args = [
            &["fit", &input, "--train-s", "250", "--out-dir", &out][..],
            extra,
        ]
        .concat();
        let err = ok(&args);
        let read = |f: &str| std::fs::read_to_string(format!("{out}/{f}")).unwrap();
        (read("arima.toml"), read("bias.toml"), err)
    };
    let (arima, bias, err) = fit("deg.txt", &flags);
    assert!(
        err.contains(
            "read as `imuprep import` reads it, with --columns, --gyro-unit, --accel-unit"
        ),
        "{err}"
    );
    let (arima_log, bias_log, _) = fit("deg.log", &[]);
    assert_eq!(arima, arima_log, "arima.toml");
    assert_eq!(bias, bias_log, "bias.toml");
    assert!(
        bias.contains("[[channels]]"),
        "a bias model was fitted: {bias}"
    );
    let replayed = |head: &[&str], out: &str| {
        ok(&[head, &["--out", &format!("csv:{}", p(out))][..]].concat());
        std::fs::read(p(out)).unwrap()
    };
    let direct = replayed(&with(&["replay", &p("deg.txt")], &flags), "direct.csv");
    assert!(direct.len() > 30000 * 40, "{} bytes", direct.len());
    assert!(
        direct == replayed(&["replay", &p("deg.log")], "of_log.csv"),
        "replay with the flags differs from replay of the log import writes with them"
    );
    // Import flags on a log: refused by every reader, naming the flags.
    for head in [
        &["fit", &p("deg.log"), "--out-dir", &p("x")][..],
        &["allan", &p("deg.log"), "--out-dir", &p("x")],
        &["replay", &p("deg.log")],
        &["export", &p("deg.log"), "-o", &p("x.csv")],
    ] {
        let (code, err) = run(&[head, &["--gyro-unit", "deg/s", "--rate", "100"][..]].concat());
        assert_ne!(code, 0, "{head:?}");
        assert!(
            err.contains("an imuprep log, which carries its own units")
                && err.contains("(--gyro-unit, --rate)"),
            "{head:?}: {err}"
        );
    }
    // A protocol's file: a table's flags refused, `--rebase-time` applied.
    ok(&["export", &p("deg.log"), "--to", "ulog", "-o", &p("deg.ulg")]);
    for head in [
        &["import", &p("deg.ulg"), "-o", &p("y.log")][..],
        &["fit", &p("deg.ulg"), "--out-dir", &p("y")],
        &["replay", &p("deg.ulg")],
    ] {
        let (code, err) = run(&[head, &["--gyro-unit", "deg/s"][..]].concat());
        assert_ne!(code, 0, "{head:?}");
        assert!(
            err.contains("read as a ulog recording, whose messages carry their own units")
                && err.contains("--gyro-unit read only a text table"),
            "{head:?}: {err}"
        );
    }
    // A protocol named with import flags is honoured: the table is read as that protocol (and
    // decodes to nothing, exit 3), not quietly read as a table instead.
    let (table, out) = (p("deg.txt"), p("z.csv"));
    for cmd in ["replay", "export"] {
        let mut args = vec![cmd, table.as_str()];
        args.extend(flags);
        args.extend(["--protocol", "ulog"]);
        if cmd == "export" {
            args.extend(["-o", out.as_str()]);
        }
        let (code, err) = run(&args);
        assert_eq!(code, 3, "{args:?}: {err}");
        assert!(err.contains("no samples decoded"), "{args:?}: {err}");
    }
    let first_t = |csv: &str| -> f64 {
        let text = std::fs::read_to_string(p(csv)).unwrap();
        text.lines()
            .nth(1)
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    ok(&["export", &p("deg.ulg"), "-o", &p("kept.csv")]);
    ok(&[
        "export",
        &p("deg.ulg"),
        "--rebase-time",
        "-o",
        &p("rebased.csv"),
    ]);
    // The ULog's stamps are whole microseconds: 1000 s within 1 µs.
    assert!(
        (first_t("kept.csv") - 1000.0).abs() < 1e-6,
        "{}",
        first_t("kept.csv")
    );
    assert_eq!(first_t("rebased.csv"), 0.0);
}

/// `compare` has two modes, and what one mode would ignore is refused, not taken in silence: a
/// LOG, a channel or `--skip-s` beside `--detectors` (which simulates its data), an import flag
/// there, and the simulation's `--seed`, `--set`, `--scenario`, `--config` beside a LOG.
#[test]
fn compare_refuses_what_its_mode_would_ignore() {
    let scn = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.toml");
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.log");
    for (args, says) in [
        (
            &["compare", log, "--detectors", "--scenario", scn][..],
            "cannot be used with",
        ),
        (
            &["compare", "--detectors", "--scenario", scn, "--skip-s", "5"],
            "cannot be used with",
        ),
        (&["compare", log, "--seed", "3"], "cannot be used with"),
        (
            &["compare", log, "--set", "motion.duration_s=60"],
            "cannot be used with",
        ),
        (
            &[
                "compare",
                "--detectors",
                "--scenario",
                scn,
                "--gyro-unit",
                "deg/s",
            ],
            "--detectors simulates its recording from --scenario: --gyro-unit read a recording",
        ),
    ] {
        let (code, err) = run(args);
        assert_ne!(code, 0, "{args:?}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

/// What cannot be read as a recording is still said: a one-row CSV has no sample rate, text
/// that is no table is an input problem (exit 3), a log from a newer imuprep is refused as
/// that, not taken for another format, and a gzipped log is named as gzip with `gunzip` as the
/// way.
#[test]
fn analysis_commands_say_what_they_cannot_read() {
    let dir = tempfile::tempdir().unwrap();
    let csv = write(
        &dir.path().join("imu.csv"),
        b"t,gx,gy,gz,ax,ay,az,temp\n0,0,0,0,0,0,9.8,20\n",
    );
    let text = write(
        &dir.path().join("notes.txt"),
        b"hello world\nthis is prose\n",
    );
    let mut newer = b"IMUPLOG\0".to_vec();
    newer.extend_from_slice(&[99, 0, 0, 0]);
    newer.extend_from_slice(&[0; 64]);
    let gzipped = {
        use std::io::Write;
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        z.write_all(&newer).unwrap();
        write(&dir.path().join("old.log.gz"), &z.finish().unwrap())
    };
    let newer = write(&dir.path().join("newer.log"), &newer);
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for cmd in ["fit", "allan", "diagnose", "calibrate"] {
        let (code, err) = run(&[cmd, &csv, "--out-dir", out]);
        assert_eq!(code, 1, "{cmd}: {err}");
        assert!(
            err.contains("1 sample imported, but its time stamps give no sample rate"),
            "{cmd}: {err}"
        );
        let (code, err) = run(&[cmd, &text, "--out-dir", out]);
        assert_eq!(code, 3, "{cmd}: {err}");
        assert!(
            err.contains("text, but not a table of numbers"),
            "{cmd}: {err}"
        );
        let (code, err) = run(&[cmd, &newer, "--out-dir", out]);
        assert_eq!(code, 1, "{cmd}: {err}");
        assert!(err.contains("unsupported log version 99"), "{cmd}: {err}");
        assert!(!err.contains("panicked"), "{cmd}: {err}");
        // A gzipped log: no table in it, said as what it is with the way (not "garbage").
        let (code, err) = run(&[cmd, &gzipped, "--out-dir", out]);
        assert_eq!(code, 3, "{cmd}: {err}");
        assert!(
            err.contains("a gzip-compressed file that holds no text table"),
            "{cmd}: {err}"
        );
    }
    for args in [
        vec!["replay", &gzipped],
        vec!["export", &gzipped, "-o", out],
    ] {
        let (code, err) = run(&args);
        assert_ne!(code, 0, "{args:?}: {err}");
        assert!(err.contains("gunzip"), "{args:?}: {err}");
    }
}

/// `simulate -o` into a place that cannot be written: one error line naming the file, with
/// the reason once (it once said "I/O error: No such file or directory (os error 2): No such
/// file or directory (os error 2)" and named no file).
#[test]
fn simulate_to_an_unwritable_path_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let scn = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.toml");
    let missing = dir.path().join("no/such/dir/s.log");
    let missing = missing.to_str().unwrap();
    let (code, err) = run(&["simulate", scn, "-o", missing]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(missing), "names the file: {err}");
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    let ok = dir.path().join("s.log");
    let truth = dir.path().join("no/such/dir/t.csv");
    let truth = truth.to_str().unwrap();
    let (code, err) = run(&[
        "simulate",
        scn,
        "-o",
        ok.to_str().unwrap(),
        "--truth",
        truth,
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(truth), "names the truth file: {err}");
}

/// A config with mistakes: the error says which file they are in.
#[test]
fn config_errors_name_the_config_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(
        &dir.path().join("mine.toml"),
        b"[health]\ninterval_s = -5\nbogus = 1\n",
    );
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/drive.log");
    let (code, err) = run(&["replay", log, "--config", &cfg]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!("config {cfg}: 2 configuration error(s)")),
        "{err}"
    );
    assert!(
        err.contains("health.interval_s") && err.contains("bogus"),
        "{err}"
    );
}

/// A span past the log's end (or of 0 s) names the log and what was asked, not a flag the
/// command does not have (`diagnose --from-s 1e9` and `fit --train-s 0` once said "--skip-s
/// removes the whole log"); an output folder that cannot be made is named.
#[test]
fn empty_spans_and_unwritable_output_folders_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.log");
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for args in [
        vec!["diagnose", log, "--from-s", "1e9", "--out-dir", out],
        vec!["allan", log, "--skip-s", "1e9", "--out-dir", out],
    ] {
        let (code, err) = run(&args);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(
            err.contains(log) && err.contains("no samples from"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("--skip-s"), "{args:?}: {err}");
    }
    // A span asked with a negative start or no length is said as such (a value after the flag,
    // negative numbers included, reaches this check instead of clap's "unexpected argument").
    for args in [
        vec!["fit", log, "--train-s", "0", "--out-dir", out],
        vec!["fit", log, "--train-s", "-5", "--out-dir", out],
        vec!["diagnose", log, "--from-s", "-5", "--out-dir", out],
        vec![
            "diagnose",
            log,
            "--from-s",
            "10",
            "--to-s",
            "5",
            "--out-dir",
            out,
        ],
    ] {
        let (code, err) = run(&args);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(
            err.contains(log) && err.contains("a span must start at ≥ 0 s"),
            "{args:?}: {err}"
        );
    }
    let (code, err) = run(&["replay", log, "--speed", "-1"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--speed must be ≥ 0"), "{err}");
    // A folder under a plain file cannot be made.
    let file = write(&dir.path().join("plain"), b"x");
    let bad = format!("{file}/sub");
    for cmd in ["fit", "diagnose", "allan", "calibrate"] {
        let (code, err) = run(&[cmd, log, "--out-dir", &bad]);
        assert_eq!(code, 1, "{cmd}: {err}");
        assert!(err.contains(&bad), "{cmd} names the folder: {err}");
    }
}

/// A stretch too short for every channel (1 s of the bundled bench: 100 samples, where the
/// whole-log loop needs 20 000 and the paper split its three spans) fails with the input-problem
/// status and writes no report or `bias.toml`: an empty model file would read as "nothing found".
#[test]
fn diagnose_with_no_channel_diagnosable_fails_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.log");
    for extra in [None, Some("--paper-split")] {
        let out = dir.path().join(format!("out{}", extra.is_some()));
        let out_s = out.to_str().unwrap();
        let mut args = vec!["diagnose", log, "--to-s", "1", "--out-dir", out_s];
        args.extend(extra);
        let (code, err) = run(&args);
        assert_eq!(code, 3, "{args:?}: {err}");
        assert!(
            err.contains("no channel of") && err.contains(log),
            "{args:?}: {err}"
        );
        assert!(!out.join("bias.toml").exists(), "{args:?}");
        assert!(!out.join("report.txt").exists(), "{args:?}");
    }
}

/// Run imuprep; its exit code, stdout and stderr.
fn run_out(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(common::bin())
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A native log of `n` synthetic samples in `dir`.
fn short_log(dir: &Path, n: usize) -> String {
    let mut b = bytes::BytesMut::new();
    imuprep::io::log::encode_log(&common::descriptor(), &common::samples(n, 5), &mut b);
    write(&dir.join(format!("short{n}.log")), &b)
}

/// `calibrate` on a log with no still stretch (10 samples) is "not identifiable", a result
/// (exit 0); it once printed "held-out RMS of |f| - g ...: NaN -> NaN m/s²" in the report.
#[test]
fn calibrate_without_a_still_stretch_prints_no_nan() {
    let dir = tempfile::tempdir().unwrap();
    let log = short_log(dir.path(), 10);
    let out = dir.path().join("cal");
    let (code, text, err) = run_out(&["calibrate", &log, "--out-dir", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(
        text.contains("result: not identifiable: no still stretch found"),
        "{text}"
    );
    assert!(
        text.contains("held-out RMS of |f| - g: not computed (no still stretch)"),
        "{text}"
    );
    let report = std::fs::read_to_string(out.join("report.txt")).unwrap();
    for t in [&text, &report] {
        assert!(!t.contains("NaN"), "{t}");
    }
}

/// `audit` of a folder with nothing auditable once exited 1 — the status of a missed do-no-harm
/// target — with "no recording under DIR could be audited" and no reason. Now it is an input
/// problem (status 3) that says why: no recording file at all, or each file left out with its
/// reason (a CSV that is not an IMU's; a log too short to audit).
#[test]
fn audit_of_a_folder_with_nothing_auditable_says_why_with_status_3() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (code, _, err) = run_out(&["audit", empty.to_str().unwrap()]);
    assert_eq!(code, 3, "{err}");
    assert!(
        err.contains("could be audited (no .log, .csv, .csv.gz or .ulg file in it)"),
        "{err}"
    );
    let some = dir.path().join("some");
    std::fs::create_dir(&some).unwrap();
    write(&some.join("people.csv"), b"name,age\nbob,3\n");
    short_log(&some, 200);
    let (code, out, err) = run_out(&["audit", some.to_str().unwrap()]);
    assert_eq!(code, 3, "{err}");
    assert!(out.is_empty(), "no report claims a result: {out}");
    assert!(err.contains("people.csv: no sensor column"), "{err}");
    assert!(
        err.contains("short200.log: 200 samples: too short to audit"),
        "{err}"
    );
}

/// A `.csv.gz` cut short (a copy interrupted): `import` once said only "FILE: incomplete
/// deflate stream". It now says where the compressed stream stopped, that the file is
/// truncated or corrupt, and that nothing was imported — and writes no log.
#[test]
fn import_of_a_truncated_gz_says_so_and_writes_nothing() {
    use std::io::Write as _;
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("t,gx,gy,gz,ax,ay,az,temp\n");
    let mut r = Rng::new(9);
    for i in 0..20_000 {
        csv += &format!(
            "{:.2},{:.6},{:.6},{:.6},0.01,0.02,9.81,25\n",
            i as f64 / 100.0,
            r.normal(),
            r.normal(),
            r.normal()
        );
    }
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(csv.as_bytes()).unwrap();
    let gz = gz.finish().unwrap();
    let cut = write(&dir.path().join("cut.csv.gz"), &gz[..gz.len() / 2]);
    let out = dir.path().join("cut.log");
    let (code, _, err) = run_out(&["import", &cut, "-o", out.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(&format!("{cut}:")), "names the file: {err}");
    assert!(
        err.contains("the compressed file ends early or is corrupt here (a truncated .gz?"),
        "{err}"
    );
    assert!(err.contains("nothing was imported"), "{err}");
    assert!(!out.exists());
    // The whole file imports.
    let whole = write(&dir.path().join("whole.csv.gz"), &gz);
    let (code, _, err) = run_out(&["import", &whole, "-o", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
}

/// `allan` and `fit` on a log too short for them (10 samples) once said only "series too
/// short: need at least 16 samples, got 10" (allan) and "gx: series too short: ..." (fit),
/// naming no file: the error now names the log and what it holds.
#[test]
fn allan_and_fit_on_a_too_short_log_name_it() {
    let dir = tempfile::tempdir().unwrap();
    let log = short_log(dir.path(), 10);
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let (code, _, err) = run_out(&["allan", &log, "--out-dir", out]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!("{log}: 10 samples (0.05 s at 200 Hz) after --skip-s 0: series too short: need at least 16")),
        "{err}"
    );
    let (code, _, err) = run_out(&["fit", &log, "--out-dir", out]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!(
            "{log}: ARIMA identification of gx on 10 samples (0.1 s at 200 Hz): series too short"
        )),
        "{err}"
    );
    assert!(!Path::new(out).join("report.txt").exists());
    assert!(!Path::new(out).join("arima.toml").exists());
    // `diagnose` said the sample counts only ("need at least 20000 samples, got 10"): it now
    // says how long a recording that is, at the log's rate.
    let (code, o, err) = run_out(&["diagnose", &log, "--channel", "gx", "--out-dir", out]);
    assert_ne!(code, 0, "{o}{err}");
    assert!(
        o.contains("gx: cannot diagnose: series too short: need at least")
            && o.contains("s of the recording at 200 Hz, has 0.1 s)"),
        "{o}{err}"
    );
}

/// `calibrate --gnss` with a file that does not exist once ran the whole calibration, put
/// "/x.pos: No such file or directory" in the report and exited 0: it now fails first, naming
/// the flag and the file, and writes no report.
#[test]
fn calibrate_with_a_missing_gnss_file_fails_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.log");
    let pos = dir.path().join("nope.pos");
    let pos = pos.to_str().unwrap();
    let out = dir.path().join("cal");
    let (code, _, err) = run_out(&[
        "calibrate",
        log,
        "--to-s",
        "30",
        "--gnss",
        pos,
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!("--gnss {pos}: No such file")),
        "{err}"
    );
    assert!(!out.join("report.txt").exists());
}

/// `audit --config C` once printed "imuprep audit of DIR (embedded default config)" over the
/// results of C's pipeline, and its JSON did not say which config ran. Both now name C; without
/// `--config` the header still says "embedded default config" and the JSON's `config` is null.
#[test]
fn audit_with_a_config_names_it_in_the_header_and_the_json() {
    let dir = tempfile::tempdir().unwrap();
    let recs = dir.path().join("recs");
    std::fs::create_dir(&recs).unwrap();
    std::fs::copy("replay/drive.log", recs.join("drive.log")).unwrap();
    let cfg = write(
        &dir.path().join("causal.toml"),
        b"[gross_error.settings]\nlookahead_samples = 0\n",
    );
    let json = dir.path().join("a.json");
    let recs = recs.to_str().unwrap();
    let (code, out, err) = run_out(&[
        "audit",
        recs,
        "--seeds",
        "1",
        "--config",
        &cfg,
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(code == 0 || code == 1, "{err}");
    let head = out.lines().next().unwrap_or("");
    assert_eq!(
        head,
        format!("imuprep audit of {recs} (config {cfg} over the embedded default)")
    );
    let j: serde_json::Value = common::read_json(&json);
    assert_eq!(j["config"], cfg.as_str(), "{j}");
    // Also (third walkthrough): a skipped file's path said once (was "skipped P: P: …"), seeds
    // that wrap past u64::MAX listed (was "seeds 18446744073709551615–0"), and the misses' JSON
    // key `fn` beside `tp` and `fp` (was the Rust field name `fn_`).
    write(&dir.path().join("recs/people.csv"), b"name,age\nbob,3\n");
    let (code, out, err) = run_out(&[
        "audit",
        recs,
        "--seed",
        "18446744073709551615",
        "--seeds",
        "2",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(code == 0 || code == 1, "{err}");
    assert!(
        out.starts_with(&format!(
            "imuprep audit of {recs} (embedded default config)\n"
        )),
        "{out}"
    );
    assert!(
        out.contains("seeds 18446744073709551615, 0 pooled"),
        "{out}"
    );
    let people = format!("{recs}/people.csv");
    assert!(
        out.contains(&format!("skipped {people}: no sensor column"))
            && out.matches(people.as_str()).count() == 1,
        "{out}"
    );
    let j: serde_json::Value = common::read_json(&json);
    assert!(j["config"].is_null(), "{j}");
    let injected = &j["recordings"][0]["injected"];
    assert!(
        injected["fn"].is_u64() && injected.get("fn_").is_none(),
        "{injected}"
    );
}

/// A live run stopped by SIGINT before any sample came (a silent stdin, a sensor never
/// connected) exits 0 by design — "a live daemon stopped by a signal only warns" — yet printed
/// `imuprep: ERROR: no samples decoded …`, an error line with a success status. It is now a
/// `WARNING:` line; a replay that ends by itself with nothing in it keeps `ERROR:` and status 3.
#[test]
fn a_live_run_stopped_by_a_signal_before_any_sample_warns_not_errors() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(
        &dir.path().join("stdin.toml"),
        b"[source]\nkind = \"stdin\"\n[health]\ninterval_s = 0.1\n",
    );
    let mut child = std::process::Command::new(common::bin())
        .args(["run", "--config", &cfg])
        .stdin(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let _stdin = child.stdin.take();
    let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    // The run loop is up (and its signal handler) once it reports health.
    let mut err = String::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        err.push_str(&line);
        err.push('\n');
        if line.contains("INFO health:") {
            break;
        }
    }
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    for line in lines {
        err.push_str(&line.unwrap());
        err.push('\n');
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "{err}");
    assert!(err.contains("imuprep summary (signal SIGINT"), "{err}");
    assert!(
        err.contains("imuprep: WARNING: no samples decoded from 0 bytes of input"),
        "{err}"
    );
    assert!(!err.contains("ERROR"), "{err}");
}

#[test]
fn a_recording_format_imuprep_does_not_read_is_named_with_the_way_in() {
    // A ROS 1 bag, a ROS 2 .db3, a phone app's zip, an HDF5 file and an ArduPilot DataFlash log
    // decoded to nothing but "garbage bytes"; each is now said for what it is, with what to do.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.log");
    for (name, magic, said) in [
        ("a.bag", &b"#ROSBAG V2.0\n"[..], "a ROS 1 bag"),
        ("a.db3", &b"SQLite format 3\0"[..], "SQLite"),
        ("a.zip", &b"PK\x03\x04"[..], "unpack it"),
        ("a.h5", &b"\x89HDF\r\n\x1a\n"[..], "an HDF5 file"),
        (
            "a.bin",
            &[0xA3, 0x95, 0x80, 0x80, 0x59][..],
            "mavlogdump.py",
        ),
    ] {
        let mut b = magic.to_vec();
        b.extend(garbage(4000, 21));
        let f = write(&dir.path().join(name), &b);
        for args in [
            vec!["import", &f, "-o", out.to_str().unwrap()],
            vec!["replay", &f, "--protocol", "auto"],
            vec!["replay", &f],
        ] {
            let (code, err) = run(&args);
            assert_ne!(code, 0, "{args:?}: {err}");
            assert!(err.contains(said), "{args:?}: {err}");
            assert!(!err.contains("garbage bytes"), "{args:?}: {err}");
        }
    }
}

#[test]
fn a_bag_directory_imports_its_bag_file_or_says_what_it_holds() {
    // A rosbag2 bag is a directory (metadata.yaml and its storage files); before, "Is a
    // directory (os error 21)".
    let root = tempfile::tempdir().unwrap();
    let out = root.path().join("o.log");
    let dir = |name: &str, files: &[(&str, &str)]| {
        let d = root.path().join(name);
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("metadata.yaml"), "rosbag2_bagfile_information: {}\n").unwrap();
        for (to, from) in files {
            std::fs::copy(from, d.join(to)).unwrap();
        }
        d.to_str().unwrap().to_string()
    };
    let mcap = "tests/reference/mcap_bag.mcap";
    let db3 = "tests/reference/db3_bag/db3_bag_0.db3";
    let one = dir("one", &[("one_0.mcap", mcap)]);
    let split = dir("split", &[("s_0.mcap", mcap), ("s_1.mcap", mcap)]);
    let sqlite = dir("sqlite", &[("q_0.db3", db3)]);
    let empty = dir("empty", &[]);
    let import = |d: &str| run(&["import", d, "-o", out.to_str().unwrap()]);

    let (code, err) = import(&one);
    if cfg!(feature = "ros2") {
        assert_eq!(code, 0, "{err}");
        assert!(err.contains("imported 60 samples"), "{err}");
    } else {
        assert_ne!(code, 0);
        assert!(
            err.contains("a ROS 2 bag (MCAP), which this build does not read"),
            "{err}"
        );
    }
    let (code, err) = import(&sqlite);
    if cfg!(feature = "ros2-sqlite") {
        assert_eq!(code, 0, "{err}");
        assert!(err.contains("ROS 2 bag (SQLite) input: 60"), "{err}");
    } else {
        assert_ne!(code, 0);
        assert!(
            err.contains("a directory") && err.contains("SQLite"),
            "{err}"
        );
    }
    // A split bag: its files read as one, in the order of their index (the same bag twice
    // here: its stamps start again, said as such).
    let (code, err) = import(&split);
    if cfg!(feature = "ros2") {
        assert_eq!(code, 0, "{err}");
        assert!(
            err.contains("2 files read as one (s_0.mcap, s_1.mcap)")
                && err.contains("imported 120 samples"),
            "{err}"
        );
    } else {
        assert_ne!(code, 0);
        assert!(
            err.contains("a ROS 2 bag (MCAP), which this build does not read"),
            "{err}"
        );
    }
    let (code, err) = import(&empty);
    assert_ne!(code, 0);
    assert!(err.contains("no .mcap or .db3 bag file in it"), "{err}");
}

/// `audit` finds a recording in a sensor protocol by its bytes, whatever its name, and reads it
/// as `import` does; a binary file no decoder knows and prose are not recordings.
#[test]
fn audit_finds_protocol_recordings_by_their_bytes() {
    use imuprep::report::audit::{find_recordings, load_recording};
    let dir = tempfile::tempdir().unwrap();
    let reference = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/reference");
    std::fs::copy(
        format!("{reference}/ubx_stream.bin"),
        dir.path().join("rover.raw"),
    )
    .unwrap();
    std::fs::copy(
        format!("{reference}/mavlink_stream.bin"),
        dir.path().join("flight.tlog"),
    )
    .unwrap();
    // Bytes of a fixed linear congruential sequence: binary that no decoder takes for frames.
    let mut x: u32 = 12345;
    let noise: Vec<u8> = (0..8192)
        .map(|_| {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            (x >> 24) as u8
        })
        .collect();
    write(&dir.path().join("photo.jpg"), &noise);
    write(
        &dir.path().join("README.md"),
        b"# Bench\nRecorded on a bench.\n",
    );
    let found: Vec<String> = find_recordings(dir.path())
        .unwrap()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(found, ["flight.tlog", "rover.raw"]);
    for name in found {
        let path = dir.path().join(&name);
        let (d, s) = load_recording(&path).unwrap();
        let pc = imuprep::frame::detect::ProtocolConfig::auto();
        let (want, _) = imuprep::io::convert::read_any_whole(&path, &pc).unwrap();
        assert!(!s.is_empty(), "{name}");
        assert_eq!(s, want.samples, "{name}: the samples import reads");
        assert!(d.sample_rate_hz > 0.0, "{name}");
    }
}
