//! The offline commands end to end on the bundled static bench: `fit` writes models that the
//! daemon loads, `compare --detectors` scores the online gate, `diagnose` writes its report and
//! a bias model the daemon loads.
mod common;

use std::path::Path;

fn run(args: &[&str]) -> String {
    common::run_cli(args)
}

/// `fit replay/static_bench.log --out-dir DIR FIT_ARGS...`, then `replay` of the same log with
/// both fitted models in the config. Returns the directory (kept alive), fit's output and the
/// replay's health summary.
fn fit_and_replay(fit_args: &[&str]) -> (tempfile::TempDir, String, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let mut args = vec!["fit", "replay/static_bench.log", "--out-dir", d];
    args.extend_from_slice(fit_args);
    let fit_out = run(&args);
    assert!(Path::new(d).join("arima.toml").exists() && Path::new(d).join("bias.toml").exists());
    let cfg = dir.path().join("c.toml");
    std::fs::write(
        &cfg,
        format!(
            "[source]\nkind = \"stdin\"\n[gross_error]\nenabled = true\nmodel = \"{d}/arima.toml\"\n[bias]\nenabled = true\nmodel = \"{d}/bias.toml\"\n"
        ),
    )
    .unwrap();
    let h = replay_summary("replay/static_bench.log", &cfg);
    (dir, fit_out, h)
}

/// `replay LOG --config CFG`: the health summary (JSON, written beside CFG).
fn replay_summary(log: &str, cfg: &Path) -> serde_json::Value {
    let summary = cfg.with_extension("summary.json");
    run(&[
        "replay",
        log,
        "--config",
        cfg.to_str().unwrap(),
        "--summary-json",
        summary.to_str().unwrap(),
    ]);
    common::read_json(summary)
}

/// What a replay with fitted models must show.
fn assert_fitted_models_applied(h: &serde_json::Value) {
    // Fitted models: nothing warms up, and the bias stage removes a bias from every sample.
    assert_eq!(h["flagged_warming_up"], 0, "{h}");
    assert_eq!(h["flagged_bias_removed"], h["samples_out"], "{h}");
    // The static bench carries gross errors: some are replaced.
    assert!(h["flagged_replaced"].as_u64().unwrap() > 0, "{h}");
}

#[test]
fn fit_writes_models_that_the_daemon_loads_and_applies() {
    // The bench's longest still stretch in its first 60 s is 58.5 s: allow 30 s.
    let (_dir, out, h) = fit_and_replay(&[
        "--train-s",
        "60",
        "--bias-order",
        "8",
        "--min-still-s",
        "30",
    ]);
    assert!(out.contains("on the longest still stretch"), "{out}");
    assert_fitted_models_applied(&h);
}

#[test]
fn fit_on_a_moving_log_learns_no_motion_as_bias() {
    // The bundled drive has no still stretch of 60 s in its first 180 s: a bias model fitted
    // there would take the drive's motion for bias. fit must say so and write no channel
    // model, so the stage learns each gyro's bias at warm-up as with the default config.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let out = run(&["fit", "replay/drive.log", "--out-dir", d]);
    assert!(out.contains("bias model: NOT FITTED"), "{out}");
    let m = imuprep::model::bias_model::BiasModelFile::load(&dir.path().join("bias.toml"))
        .expect("the file written still loads");
    assert!(m.channels.is_empty(), "{m:?}");
    // A shorter minimum admits the drive's stops: the model is then fitted on one of them.
    let out = run(&[
        "fit",
        "replay/drive.log",
        "--out-dir",
        d,
        "--min-still-s",
        "5",
    ]);
    assert!(out.contains("on the longest still stretch"), "{out}");
    let m = imuprep::model::bias_model::BiasModelFile::load(&dir.path().join("bias.toml")).unwrap();
    assert_eq!(m.channels.len(), imuprep::sample::CHANNEL_NAMES.len());
}

#[test]
fn fit_with_fos_writes_a_bias_model_that_the_daemon_loads_and_applies() {
    // Default span (180 s) and L (10): long enough for FOS to select lags on several channels
    // of the bench, so the FOS -> AR conversion is exercised, not only the white case.
    let (dir, out, h) = fit_and_replay(&["--bias-method", "fos"]);
    assert!(out.contains("FOS CP=1 L=10"), "{out}");
    let m = imuprep::model::bias_model::BiasModelFile::load(&dir.path().join("bias.toml"))
        .expect("fit --bias-method fos writes a valid bias model");
    assert_eq!(m.channels.len(), imuprep::sample::CHANNEL_NAMES.len());
    for name in imuprep::sample::CHANNEL_NAMES {
        let c = m.channel(name).unwrap_or_else(|| panic!("{name} missing"));
        assert_eq!(c.method, "fos", "{name}");
        assert!(c.ar.len() <= 10, "{name}: {:?}", c.ar);
    }
    assert!(
        m.channels.iter().any(|c| !c.ar.is_empty()),
        "no channel has a lag term: {m:?}"
    );
    assert_fitted_models_applied(&h);
}

#[test]
fn compare_detectors_scores_every_detector_on_the_truth() {
    let out = run(&[
        "compare",
        "--detectors",
        "--scenario",
        "replay/static_bench.toml",
    ]);
    for d in [
        "online ARIMA gate",
        "global 3-sigma",
        "Grubbs",
        "Chauvenet",
        "Dixon",
        "Hampel",
    ] {
        assert!(out.contains(d), "{d} missing:\n{out}");
    }
}

/// `diagnose replay/static_bench.log --channel gz` with `extra` into a fresh directory.
fn diagnose_gz(extra: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let mut args = vec!["diagnose", "replay/static_bench.log", "--channel", "gz"];
    args.extend(extra);
    args.extend(["--out-dir", d]);
    run(&args);
    dir
}

#[test]
fn diagnose_writes_report_plots_and_a_loadable_bias_model() {
    let dir = diagnose_gz(&[]);
    for f in ["report.txt", "report.json", "bias.toml"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    assert!(std::fs::read_dir(dir.path().join("plots")).unwrap().count() > 0);
    let m = std::fs::read_to_string(dir.path().join("bias.toml")).unwrap();
    imuprep::model::bias_model::BiasModelFile::from_toml_str(&m)
        .expect("diagnose writes a valid bias model");
    let plots = dir.path().join("plots");
    let legend = ["intercept only", "with the effects"];
    common::assert_plot(
        &plots.join("gz_spectrum.svg"),
        &[
            &["gz: open-loop residual spectrum (Welch)", "frequency (Hz)"],
            &legend[..],
        ]
        .concat(),
        2,
    );
    common::assert_plot(
        &plots.join("gz_allan.svg"),
        &[&["tau (s)", "Allan deviation"], &legend[..]].concat(),
        2,
    );
}

#[test]
fn diagnose_paper_split_writes_a_well_formed_plot_of_each_series() {
    let dir = diagnose_gz(&["--paper-split"]);
    let plots = dir.path().join("plots");
    let (first, last) = ("first model", "final model");
    common::assert_plot(
        &plots.join("gz_spectrum.svg"),
        &[
            "gz: residual spectrum (test, Welch)",
            "PSD (units²/Hz)",
            first,
            last,
        ],
        2,
    );
    common::assert_plot(
        &plots.join("gz_allan.svg"),
        &["tau (s)", first, last, "white (slope -1/2)"],
        3,
    );
    // Each added effect over the residual before it (this log adds at least one).
    let effects: Vec<_> = std::fs::read_dir(&plots)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_str().unwrap().contains("gz_effect"))
        .collect();
    assert!(!effects.is_empty());
    for p in effects {
        common::assert_plot(&p, &["t (s)", "residual", "residual before"], 2);
    }
}

/// `replay replay/drive.log` with the gross-error stage's look-ahead set to `lookahead`; the
/// health summary.
fn replay_drive(lookahead: usize) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    std::fs::write(
        &cfg,
        format!("[source]\nkind = \"stdin\"\n[gross_error]\nenabled = true\n[gross_error.settings]\nlookahead_samples = {lookahead}\n[bias]\nenabled = true\n"),
    )
    .unwrap();
    replay_summary("replay/drive.log", &cfg)
}

#[test]
fn replay_publishes_every_sample_and_only_the_look_ahead_replaces() {
    // The samples the stage still holds at the end of the input are flushed, so out = in, with
    // and without a look-ahead. Causal (0), nothing but bad values can be replaced: candidates
    // pass, flagged suspect. With the look-ahead the confirmed ones are replaced.
    let causal = replay_drive(0);
    let ahead = replay_drive(16);
    for h in [&causal, &ahead] {
        assert_eq!(h["samples_out"], h["samples_in"], "{h}");
        assert!(h["samples_in"].as_u64().unwrap() > 10_000, "{h}");
    }
    assert_eq!(causal["flagged_replaced"], 0, "{causal}");
    assert!(causal["flagged_suspect"].as_u64().unwrap() > 0, "{causal}");
    assert!(ahead["flagged_replaced"].as_u64().unwrap() > 0, "{ahead}");
}

#[test]
fn fit_judges_stillness_after_the_gross_error_stage() {
    // The static bench at 200 Hz carries gross errors (5e-5 per channel-sample: ~13 events in
    // the 180-s training span's 216 000 channel-samples). On the raw samples each spike breaks
    // the stillness test's run, and the longest still stretch is 59.3 s — under the default
    // --min-still-s 60, so fit wrote no bias model. After the gross-error stage (what the bias
    // stage sees in the daemon) the span is one still stretch from the detector's warm-up on,
    // as on the same bench without gross errors (178.5 s from 1.5 s).
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bench200.log");
    let log_s = log.to_str().unwrap();
    run(&[
        "simulate",
        "replay/static_bench.toml",
        "-o",
        log_s,
        "--set",
        "motion.duration_s=200",
        "--set",
        "sensor.sample_rate_hz=200",
    ]);
    // The premise: the raw span's stillness is broken by the gross errors.
    let (_, raw) = imuprep::report::audit::load_recording(&log).unwrap();
    let raw_still = imuprep::report::fit::longest_still_stretch(&raw[..36_000], 200.0);
    assert!(
        raw_still.len < 60 * 200,
        "the raw span has a 60-s still stretch: {raw_still:?}"
    );
    let o = imuprep::report::fit::FitOptions {
        train_s: 180.0,
        skip_s: 0.0,
        bias_method: imuprep::report::fit::BiasMethod::Burg,
        bias_order: 64,
        min_still_s: 60.0,
    };
    let r = imuprep::report::fit::fit(
        &imuprep::report::Recording::new(&log),
        &dir.path().join("m"),
        &o,
    )
    .unwrap();
    assert!(r.bias_skipped.is_none(), "{:?}", r.bias_skipped);
    assert_eq!(r.bias.len(), 6);
    // ≥ 175 s of the 180: the stillness detector's own warm-up (1.5 s) is the only gap on the
    // same bench without gross errors.
    assert!(r.still.len >= 175 * 200, "{:?}", r.still);
}

/// The summary's sensor line: a descriptor's range of 0 means unknown and is said so (it once
/// read "gyro range 0 rad/s", like a measured range), and the rate is printed to 1 mHz, not
/// as every digit of the float ("104.26409824381754 Hz").
#[test]
fn replay_summary_says_unknown_ranges_and_a_readable_rate() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("imu.csv");
    // 300 rows every 9.591 ms (104.264 Hz); no range given to import.
    let mut text = String::from("t,gx,gy,gz,ax,ay,az,temp\n");
    for k in 0..300 {
        text += &format!("{:.6},0.01,0.02,0.03,0.1,0.2,9.8,\n", k as f64 * 0.009591);
    }
    std::fs::write(&csv, text).unwrap();
    let log = dir.path().join("imu.log");
    run(&["import", csv.to_str().unwrap(), "-o", log.to_str().unwrap()]);
    let out = std::process::Command::new(common::bin())
        .args(["replay", log.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("sensor     : device 0 at 104.264 Hz, ranges unknown (no saturation flags), axes unknown"),
        "{err}"
    );
    // The bundled drive states its ranges and axes.
    let drive = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/drive.log");
    let out = std::process::Command::new(common::bin())
        .args(["replay", drive])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("at 100 Hz, gyro range 4.3633 rad/s, accel range 78.4532 m/s², axes FRD"),
        "{err}"
    );
}

/// `evaluate` on the bundled drive: the gyro axes without a manoeuvre (gx, gy: only the z axis
/// turns) say so instead of "0.00%, 0.00%, 0.00% of 0", which reads like a measured 0; gz keeps
/// its four manoeuvres' worst values.
#[test]
fn evaluate_says_none_where_an_axis_has_no_manoeuvre() {
    let out = run(&["evaluate", "--scenario", "replay/drive.toml"]);
    let line = |ch: &str| {
        out.lines()
            .find(|l| l.starts_with(&format!("{ch} ")))
            .unwrap_or_else(|| panic!("no {ch} line:\n{out}"))
            .to_string()
    };
    for ch in ["gx", "gy"] {
        assert!(line(ch).ends_with("none on this axis"), "{out}");
    }
    assert!(line("gz").ends_with("% of 4"), "{out}");
    assert!(!out.contains("of 0"), "{out}");
}

/// A record shorter than the 60-s drift window (a 1-s static bench) once scored "60s drift rad
/// -0.000e0 ... reduced NaN%": no 60-s window was there to measure. The drift and its reduction
/// are now "n/a" in the text and null in the JSON; the 1-s score, which has its blocks, stays.
#[test]
fn evaluate_on_a_record_shorter_than_a_drift_window_says_not_computed() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("ev.json");
    let out = run(&[
        "evaluate",
        "--scenario",
        "replay/static_bench.toml",
        "--set",
        "motion.duration_s=1",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(!out.contains("NaN"), "{out}");
    let gx = out.lines().find(|l| l.starts_with("gx ")).unwrap();
    assert_eq!(gx.matches("n/a").count(), 3, "{gx}");
    let v: serde_json::Value = common::read_json(&json);
    for ch in v.as_array().unwrap() {
        assert!(ch["drift_reduction"].is_null(), "{ch}");
        assert!(ch["pipeline"]["rms_60s_drift_rad"].is_null(), "{ch}");
        assert!(
            ch["pipeline"]["rms_1s_mean_error"].as_f64().unwrap() > 0.0,
            "{ch}"
        );
    }
}

/// A channel named twice (`allan --channel gx --channel gx`) was analysed twice and written
/// twice into bias.toml, which the daemon then refused ("`gx` appears more than once"): it is
/// analysed once, and the model loads.
#[test]
fn a_channel_named_twice_is_analysed_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let out = run(&[
        "allan",
        "replay/static_bench.log",
        "--channel",
        "gx",
        "--channel",
        "gx",
        "--out-dir",
        d,
    ]);
    assert_eq!(out.matches("\ngx (rad/s)").count(), 1, "{out}");
    let model = std::fs::read_to_string(dir.path().join("bias.toml")).unwrap();
    assert_eq!(model.matches("channel = \"gx\"").count(), 1, "{model}");
    let cfg = dir.path().join("c.toml");
    std::fs::write(
        &cfg,
        format!("[bias]\nenabled = true\nmodel = \"{d}/bias.toml\"\n"),
    )
    .unwrap();
    replay_summary("replay/static_bench.log", &cfg);
}

/// `allan` and `diagnose` assume a record at rest. On a walk (the simulated foot-mounted IMU)
/// they once said nothing: `allan` wrote a gyro noise density 24× the sensor's into imu.yaml,
/// and `diagnose` kept the stride (0.92 Hz, 2.4 rad/s on gy) as a "vibration line" and the
/// walk's accelerations as "g-sensitivity" in a bias.toml that, as `[bias] model`, multiplied
/// the replay's gyro error by 50–600. Both now warn, in the text, the JSON and the model files;
/// `diagnose` writes no bias.toml then (and removes an earlier run's) unless `--allow-motion`;
/// a record at rest gets no warning.
#[test]
fn allan_and_diagnose_on_a_record_not_at_rest_warn_in_every_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = d.join("walk.log");
    let log = log.to_str().unwrap();
    run(&[
        "simulate",
        "replay/gait.toml",
        "-o",
        log,
        "--set",
        "sensor.sample_rate_hz=100.0",
        "--set",
        "motion.bouts=10",
    ]);
    let (a, g) = (d.join("a"), d.join("g"));
    let out = run(&["allan", log, "--out-dir", a.to_str().unwrap()]);
    let warn = "WARNING: the record is not at rest";
    assert!(out.contains(warn), "{out}");
    // The model-error floor at the top of its search range is said as a bound (it was printed
    // as the value "10000.0 %").
    assert!(
        out.contains("model error floor above 10000 %") && !out.contains("10000.0 %"),
        "{out}"
    );
    for f in ["report.txt", "imu.yaml", "gnss_imu_config.txt", "bias.toml"] {
        let t = std::fs::read_to_string(a.join(f)).unwrap();
        assert!(t.contains(warn), "{f}: {t}");
    }
    let j: serde_json::Value = common::read_json(a.join("report.json"));
    assert_eq!(j["warnings"].as_array().map(Vec::len), Some(1), "{j}");
    let gd = g.to_str().unwrap();
    let out = run(&["diagnose", log, "--out-dir", gd, "--allow-motion"]);
    assert!(out.contains(warn), "{out}");
    for f in ["report.txt", "bias.toml"] {
        let t = std::fs::read_to_string(g.join(f)).unwrap();
        assert!(t.contains(warn), "{f}: {t}");
    }
    let j: serde_json::Value = common::read_json(g.join("report.json"));
    assert_eq!(j["warnings"].as_array().map(Vec::len), Some(1), "{j}");
    // Without --allow-motion: the report, no model, and the one above removed (not left to
    // pass for this run's).
    let out = run(&["diagnose", log, "--out-dir", gd]);
    assert!(out.contains(warn) && out.contains("no bias.toml"), "{out}");
    assert!(out.contains("removed the earlier run's"), "{out}");
    assert!(!g.join("bias.toml").exists());
    let t = std::fs::read_to_string(g.join("report.txt")).unwrap();
    assert!(t.contains("bias.toml is therefore not written"), "{t}");
    // The same from issue 6's loop (`--paper-split`), its JSON included.
    let out = run(&["diagnose", log, "--out-dir", gd, "--paper-split"]);
    assert!(out.contains(warn) && out.contains("no bias.toml"), "{out}");
    assert!(!g.join("bias.toml").exists());
    let j: serde_json::Value = common::read_json(g.join("report.json"));
    assert_eq!(j["warnings"].as_array().map(Vec::len), Some(1), "{j}");
    // The bundled static bench is at rest.
    let s = d.join("s");
    let out = run(&[
        "allan",
        "replay/static_bench.log",
        "--out-dir",
        s.to_str().unwrap(),
    ]);
    assert!(!out.contains("WARNING"), "{out}");
}

/// Clipping said where it happens (third walkthrough): `simulate` with a ±0.5 g accelerometer
/// on a bench at 1 g printed its usual line only, and `replay` "N saturated" among the flags.
/// Now `simulate` counts the clipped channel-samples and `replay` warns when more than 1 % of
/// the samples are clipped; a sensor within its range gets neither line.
#[test]
fn clipping_is_counted_by_simulate_and_warned_by_replay() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("clip.log");
    let log = log.to_str().unwrap();
    let sim = |range_g: &str| {
        run(&[
            "simulate",
            "replay/static_bench.toml",
            "-o",
            log,
            "--set",
            "motion.duration_s=20",
            "--set",
            &format!("sensor.accel_range_g={range_g}"),
        ])
    };
    let out = sim("0.5");
    // The bench's az reads ≈ 1 g on every sample: one clipped channel-sample per instant.
    assert!(
        out.contains("clipped at the sensor's range: 2000 channel-samples of 12000"),
        "{out}"
    );
    let summary = run(&["replay", log]);
    assert!(
        summary.contains("WARNING    : 2000 of 2000 samples (100.0 %) clipped"),
        "{summary}"
    );
    let out = sim("16");
    assert!(!out.contains("clipped"), "{out}");
    let summary = run(&["replay", log]);
    assert!(!summary.contains("clipped"), "{summary}");
}

#[test]
fn a_replay_whose_output_is_its_own_recording_is_refused_and_the_recording_kept() {
    // The sink creates its file before the source reads: the recording would be erased.
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("d.log");
    std::fs::copy("replay/drive.log", &log).unwrap();
    let before = std::fs::read(&log).unwrap();
    for out in [
        format!("file:{}", log.display()),
        format!("csv:{}/./d.log", dir.path().display()),
    ] {
        let o = common::imuprep(&["replay", log.to_str().unwrap(), "--out", &out]);
        assert_eq!(o.status.code(), Some(3), "{out}");
        common::assert_says(
            &String::from_utf8_lossy(&o.stderr),
            &["is the recording being replayed", "write to another file"],
        );
        assert_eq!(
            std::fs::read(&log).unwrap(),
            before,
            "{out}: recording kept"
        );
    }
}

#[test]
fn an_imported_recording_is_refused_as_its_replays_output_before_it_is_read() {
    // A CSV is imported into a temporary log and that replayed: the check must be made on the
    // recording named, or the cleaned samples overwrite it (they did). A bad output is refused
    // before the import as well, naming the output.
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("d.csv");
    let o = common::imuprep(&[
        "export",
        "replay/static_bench.log",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let before = std::fs::read(&csv).unwrap();
    let out = format!("csv:{}", csv.display());
    // `run` with a config whose source replays the CSV and whose file sink is the CSV.
    let cfg = dir.path().join("run.toml");
    std::fs::write(
        &cfg,
        format!(
            "[source]\nkind = \"replay\"\npath = {:?}\n[[sinks]]\nkind = \"file\"\npath = {:?}\nformat = \"csv\"\n",
            csv.display().to_string(),
            csv.display().to_string()
        ),
    )
    .unwrap();
    for args in [
        vec!["replay", csv.to_str().unwrap(), "--out", &out],
        vec!["run", "--config", cfg.to_str().unwrap()],
    ] {
        let o = common::imuprep(&args);
        assert_eq!(o.status.code(), Some(3), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        common::assert_says(&err, &["is the recording being replayed"]);
        assert!(!err.contains("import:"), "refused before the import: {err}");
        assert_eq!(std::fs::read(&csv).unwrap(), before, "recording kept");
    }
    let o = common::imuprep(&["replay", csv.to_str().unwrap(), "--out", "null"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    common::assert_says(&err, &["--out null: unknown output"]);
    assert!(!err.contains("import:"), "refused before the import: {err}");
}

#[test]
fn two_outputs_onto_one_file_are_refused_before_anything_is_written() {
    // Both sinks created the file and wrote: a CSV with 35 727 JSON lines inside, reported as
    // two successes; the summary's JSON replaced a file whole. Devices may be shared (two
    // outputs to /dev/null run).
    let dir = tempfile::tempdir().unwrap();
    let o_csv = dir.path().join("o.csv");
    let (a, b) = (
        format!("csv:{}", o_csv.display()),
        format!("jsonl:{}/./o.csv", dir.path().display()),
    );
    let o = common::imuprep(&[
        "replay",
        "replay/static_bench.log",
        "--out",
        &a,
        "--out",
        &b,
    ]);
    assert_eq!(o.status.code(), Some(3));
    common::assert_says(
        &String::from_utf8_lossy(&o.stderr),
        &["two outputs write one file", "give each its own"],
    );
    assert!(!o_csv.exists(), "nothing written");
    // The health summary's JSON, written when the run ends, replaced a sink's file or the
    // recording itself whole.
    let log = dir.path().join("r.log");
    std::fs::copy("replay/static_bench.log", &log).unwrap();
    let before = std::fs::read(&log).unwrap();
    let l = log.to_str().unwrap();
    let csv = o_csv.to_str().unwrap();
    for (args, says) in [
        (
            vec!["replay", l, "--out", &a, "--summary-json", csv],
            "two outputs write one file",
        ),
        (
            vec!["replay", l, "--summary-json", l],
            "is the recording being replayed",
        ),
    ] {
        let o = common::imuprep(&args);
        assert_eq!(o.status.code(), Some(3), "{args:?}");
        common::assert_says(&String::from_utf8_lossy(&o.stderr), &[says]);
        assert!(!o_csv.exists(), "{args:?}: nothing written");
        assert_eq!(
            std::fs::read(&log).unwrap(),
            before,
            "{args:?}: recording kept"
        );
    }
    let o = common::imuprep(&[
        "replay",
        "replay/static_bench.log",
        "--out",
        "csv:/dev/null",
        "--out",
        "jsonl:/dev/null",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn simulate_refuses_two_of_its_files_being_one() {
    // `--truth` naming the log wrote both into one file (59 MB that decoded as 94 % garbage,
    // reported as a success); `-o` naming the scenario replaced it.
    let dir = tempfile::tempdir().unwrap();
    let scn = dir.path().join("s.toml");
    std::fs::copy("replay/static_bench.toml", &scn).unwrap();
    let before = std::fs::read(&scn).unwrap();
    let (s, log) = (scn.to_str().unwrap(), dir.path().join("x.log"));
    let log = log.to_str().unwrap();
    let same_log = format!("{}/./x.log", dir.path().display());
    for (args, says) in [
        (
            vec![s, "-o", log, "--truth", &same_log],
            "-o and --truth are one file",
        ),
        (vec![s, "-o", s], "the scenario and -o are one file"),
        (
            vec![s, "-o", log, "--truth", s],
            "the scenario and --truth are one file",
        ),
    ] {
        let o = common::imuprep(&[&["simulate"], &args[..]].concat());
        assert_eq!(o.status.code(), Some(3), "{args:?}");
        common::assert_says(
            &String::from_utf8_lossy(&o.stderr),
            &[says, "give each its own"],
        );
        assert!(
            !std::path::Path::new(log).exists(),
            "{args:?}: nothing written"
        );
        assert_eq!(
            std::fs::read(&scn).unwrap(),
            before,
            "{args:?}: scenario kept"
        );
    }
    let truth = dir.path().join("t.csv");
    let o = common::imuprep(&["simulate", s, "-o", log, "--truth", truth.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
