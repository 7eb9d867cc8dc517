//! import canonical CSV → replay with pass-through → export CSV equals the input.
mod common;

use std::process::Command;

#[test]
fn import_replay_export_round_trips_canonical_csv() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.csv");
    let samples = common::samples(2000, 11);
    // Canonical CSV with full f64 precision; the wire keeps f32, so equality is checked at f32.
    let mut text = String::from("t,gx,gy,gz,ax,ay,az,temp,extra\n");
    for s in &samples {
        let c = s.channels();
        text += &format!(
            "{},{},{},{},{},{},{},{},ignored\n",
            imuprep::io::format::t_seconds(s.t_ns),
            c[0],
            c[1],
            c[2],
            c[3],
            c[4],
            c[5],
            s.temp_c.map(|t| t.to_string()).unwrap_or_default()
        );
    }
    std::fs::write(&input, text).unwrap();
    let log = dir.path().join("in.log");
    let clean = dir.path().join("clean.log");
    let out = dir.path().join("out.csv");
    let st = common::import(&input, &log).status;
    assert!(st.success());
    let passthrough =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("config/passthrough.toml");
    let st = Command::new(common::bin())
        .arg("replay")
        .arg(&log)
        .arg("--config")
        .arg(&passthrough)
        .arg("--out")
        .arg(format!("file:{}", clean.display()))
        .status()
        .unwrap();
    assert!(st.success());
    let st = Command::new(common::bin())
        .arg("export")
        .arg(&clean)
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());

    let got = std::fs::read_to_string(&out).unwrap();
    let mut lines = got.lines();
    assert_eq!(lines.next(), Some(imuprep::io::format::CSV_HEADER));
    let mut n = 0;
    for (line, want) in lines.zip(&samples) {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(
            cells[0],
            imuprep::io::format::t_seconds(want.t_ns),
            "time exact to the ns"
        );
        for (c, w) in want.channels().iter().enumerate() {
            let g: f32 = cells[1 + c].parse().unwrap();
            assert_eq!(g, *w as f32, "row {n} channel {c}: f32 bit-exact");
        }
        match want.temp_c {
            Some(t) => assert_eq!(cells[7].parse::<f32>().unwrap(), t as f32),
            None => assert_eq!(cells[7], "", "absent temperature stays absent"),
        }
        assert_eq!(cells[8].parse::<u32>().unwrap(), want.seq);
        assert_eq!(cells[9], "0", "pass-through sets no flags");
        n += 1;
    }
    assert_eq!(n, samples.len());
}

#[test]
fn import_reports_bad_cell_with_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("bad.csv");
    std::fs::write(
        &input,
        "t,gx,gy,gz,ax,ay,az,temp\n0,1,2,3,4,5,6,\n0.01,1,2,abc,4,5,6,\n",
    )
    .unwrap();
    let out = common::import(&input, &dir.path().join("x.log"));
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.csv:3:4") && err.contains("\"abc\""),
        "{err}"
    );
}

#[test]
fn import_names_an_absent_channel_and_refuses_a_file_without_any() {
    // A missing channel column is an absent channel (issue 13 item 10: partial sensors), said
    // on stderr by name; a file with no channel column at all is an error listing the header.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("five.csv");
    std::fs::write(&input, "t,gx,gy,gz,ax,ay\n0,1,2,3,4,5\n0.01,1,2,3,4,5\n").unwrap();
    let out = common::import(&input, &dir.path().join("x.log"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("channels absent") && err.contains(": az"),
        "{err}"
    );

    let input = dir.path().join("bad.csv");
    std::fs::write(&input, "t,temp,pressure\n0,25,1013\n").unwrap();
    let out = common::import(&input, &dir.path().join("y.log"));
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no sensor column") && err.contains("t,temp,pressure"),
        "{err}"
    );
}

#[test]
fn nan_values_are_flagged_and_passed_on() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("nan.csv");
    std::fs::write(
        &input,
        "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,9.8\n0.01,NaN,0,0,0,inf,9.8\n0.02,0,0,0,0,0,9.8\n",
    )
    .unwrap();
    let log = dir.path().join("nan.log");
    let out = dir.path().join("nan_out.csv");
    assert!(common::import(&input, &log).status.success());
    assert!(
        Command::new(common::bin())
            .arg("replay")
            .arg(&log)
            .arg("--out")
            .arg(format!("csv:{}", out.display()))
            .status()
            .unwrap()
            .success()
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 3, "no sample lost");
    let flags: u32 = rows[1].rsplit(',').next().unwrap().parse().unwrap();
    assert_ne!(flags & imuprep::flags::NON_FINITE, 0);
}

#[test]
fn replay_refuses_a_file_that_is_not_a_log() {
    let dir = tempfile::tempdir().unwrap();
    let replay = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let out = Command::new(common::bin())
            .arg("replay")
            .arg(&p)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        (out.status.code(), err)
    };
    // Binary that no decoder knows: the magic is wrong, and the flag that detects a sensor
    // protocol is named.
    let (code, err) = replay("x.log", &[0xFE; 64]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("wrong magic"), "{err}");
    assert!(
        err.contains("--protocol auto"),
        "the way out is named: {err}"
    );
    // Text goes to `import`, which reads a table (below) and says why other text is none.
    let (code, err) = replay("y.log", b"this is not an imuprep log");
    assert_eq!(code, Some(3), "an input problem: {err}");
    assert!(err.contains("text, but not a table of numbers"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// The static bench simulated for `secs` at `rate_hz` as `s.log` in `dir`, exported as `s.csv`;
/// the path maker of `dir`.
fn simulated_bench(dir: &std::path::Path, secs: u32, rate_hz: u32) -> impl Fn(&str) -> String {
    let p = move |n: &str| dir.join(n).to_str().unwrap().to_string();
    let scn = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/static_bench.toml");
    let duration = format!("motion.duration_s={secs}");
    let rate = format!("sensor.sample_rate_hz={rate_hz}");
    let log = p("s.log");
    common::run_cli(&[
        "simulate", scn, "--set", &duration, "--set", &rate, "-o", &log,
    ]);
    common::run_cli(&["export", &log, "-o", &p("s.csv")]);
    p
}

/// `imuprep replay INPUT --out csv:OUT` (asserted to succeed): what it said, and the cleaned CSV.
fn replayed(input: &str, out: &str) -> (String, Vec<u8>) {
    let said = common::run_cli(&["replay", input, "--out", &format!("csv:{out}")]);
    (said, std::fs::read(out).unwrap())
}

/// A CSV given to `replay` is imported with no flags into a temporary log and that log replayed:
/// the cleaned output is the replay of the log `import` writes, byte for byte.
#[test]
fn replay_of_a_csv_is_the_replay_of_its_import() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulated_bench(dir.path(), 60, 100);
    common::run_cli(&["import", &p("s.csv"), "-o", &p("i.log")]);
    let (said, a) = replayed(&p("s.csv"), &p("a.csv"));
    assert!(
        said.contains("not an imuprep log: read as `imuprep import` reads it"),
        "{said}"
    );
    let (_, b) = replayed(&p("i.log"), &p("b.csv"));
    assert!(
        a.len() > 6000 * 40,
        "the whole minute was replayed: {} bytes",
        a.len()
    );
    assert!(
        a == b,
        "replay of the CSV differs from replay of its import"
    );
}

/// `imuprep run` whose `[source]` replays a file reads it as `imuprep replay FILE` does: a CSV
/// imported, and a log's declared rate (200 Hz here, the config's nominal rate is 100) given to
/// the stages (before, `run` kept the config's): the cleaned output matches `replay`'s byte for
/// byte.
#[test]
fn run_with_a_replay_source_is_replay_of_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulated_bench(dir.path(), 40, 200);
    for input in ["s.log", "s.csv"] {
        let (_, a) = replayed(&p(input), &p(&format!("replay-{input}.csv")));
        let config = p("run.toml");
        std::fs::write(
            &config,
            format!("[source]\nkind = \"replay\"\npath = {:?}\n", p(input)),
        )
        .unwrap();
        let ran = p(&format!("run-{input}.csv"));
        let said = common::run_cli(&["run", "--config", &config, "--out", &format!("csv:{ran}")]);
        if input.ends_with(".csv") {
            assert!(
                said.contains("not an imuprep log: read as `imuprep import` reads it"),
                "{said}"
            );
        }
        let b = std::fs::read(&ran).unwrap();
        assert!(a.len() > 8000 * 40, "{input}: replayed {} bytes", a.len());
        assert!(a == b, "{input}: `run` differs from `replay`");
    }
}

#[test]
fn replay_of_a_sensor_recording_without_protocol_detects_it() {
    // With no --protocol a UBX or MAVLink file given to `replay` as it is is replayed as what it
    // decodes as, and said so: the same cleaned output as with its protocol named. With
    // `--protocol native` it is refused, naming what it looks like and the flag that reads it.
    // `run` with the file as its replay source detects it as `replay` does.
    let dir = env!("CARGO_MANIFEST_DIR");
    let tmp = tempfile::tempdir().unwrap();
    for (file, p) in [("ubx_stream.bin", "ubx"), ("mavlink_stream.bin", "mavlink")] {
        let path = format!("{dir}/tests/reference/{file}");
        let replay = |extra: &[&str], out: &str| {
            let csv = tmp.path().join(out);
            let mut args = vec!["replay", &path];
            args.extend_from_slice(extra);
            let spec = format!("csv:{}", csv.display());
            args.extend_from_slice(&["--out", &spec]);
            let o = Command::new(common::bin()).args(&args).output().unwrap();
            let err = String::from_utf8_lossy(&o.stderr).into_owned();
            (
                o.status.success(),
                err,
                std::fs::read(csv).unwrap_or_default(),
            )
        };
        let (ok, err, plain) = replay(&[], &format!("{p}-plain.csv"));
        assert!(ok, "{file}: {err}");
        assert!(
            err.contains(&format!("it decodes as {p}, replayed as that")),
            "{file}: {err}"
        );
        let (ok, err, named) = replay(&["--protocol", p], &format!("{p}-named.csv"));
        assert!(ok, "{file} --protocol {p}: {err}");
        assert!(named.len() > 100, "{file}: samples came out");
        assert!(
            plain == named,
            "{file}: detected and named give the same output"
        );
        // `run` with a config whose `[source]` replays the file (protocol left at its
        // "native" default) detects it the same way.
        let config = tmp.path().join(format!("{p}.toml"));
        std::fs::write(
            &config,
            format!("[source]\nkind = \"replay\"\npath = {path:?}\n"),
        )
        .unwrap();
        let ran = tmp.path().join(format!("{p}-run.csv"));
        let o = Command::new(common::bin())
            .args(["run", "--config", config.to_str().unwrap()])
            .args(["--out", &format!("csv:{}", ran.display())])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "run {file}: {err}");
        assert!(err.contains(&format!("it decodes as {p}, replayed as that")));
        assert!(
            std::fs::read(&ran).unwrap() == plain,
            "{file}: `run` gives `replay`'s output"
        );
        let (ok, err, _) = replay(&["--protocol", "native"], &format!("{p}-native.csv"));
        assert!(!ok, "{file} --protocol native");
        assert!(
            err.contains(&format!("looks like a {p} recording, pass --protocol {p}")),
            "{file}: {err}"
        );
    }
}

#[test]
fn every_real_recording_imports_with_one_command() {
    let files = [
        "adis16405_static/adis_16405_imu1.csv.gz",
        "mpu6050_static_10min_temp/mpu6050_static.csv",
        "rtklibexplorer_drive_walk/drive_0708_imu.csv",
        "rtklibexplorer_drive_walk/walk_0827_imu.csv",
        "comma2k19_car_segment/imu.csv",
        "ximu3_fusion_example/sensor_data.csv",
        "px4_sensor_combined_sample/sensor_combined.csv",
    ];
    let dir = tempfile::tempdir().unwrap();
    for f in files {
        let Some(p) = common::real_data(f) else {
            return;
        };
        if f.starts_with("adis") {
            continue; // 1 M rows: exercised by the fit/compare tests; keep this test quick
        }
        let log = dir.path().join("r.log");
        let out = common::import(&p, &log);
        assert!(
            out.status.success(),
            "{f}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (_, s, _) = imuprep::io::csv::read_log(&log).unwrap();
        assert!(s.len() > 6000, "{f}");
        // Every recording is of a sensor on Earth: the mean specific force is about 1 g.
        let m = s.iter().map(|x| x.accel.norm()).sum::<f64>() / s.len() as f64;
        assert!(
            (m - 9.81).abs() < 1.5,
            "{f}: mean |f| = {m} m/s² (units wrong?)"
        );
    }
}
