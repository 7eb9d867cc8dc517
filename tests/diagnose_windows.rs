//! `diagnose --window-s`: an effect that starts late in a long log is found by the windowed scan
//! and missed by one run, whose effects are chosen on the first six minutes (3 min train, 3 min
//! validation). Seeded simulation: the bundled static bench, 20 min, with a gz bias step of
//! 0.05 °/s (8.73e-4 rad/s) at 900 s and no gross errors.

mod common;

/// (time s, size) of every "bias step at t = T s, size S" in `text`.
fn steps(text: &str) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for part in text.split("bias step at t = ").skip(1) {
        let (t, rest) = part.split_once(" s, size ").unwrap();
        let size: String = rest
            .chars()
            .take_while(|c| c.is_ascii_digit() || "+-.e".contains(*c))
            .collect();
        out.push((t.parse().unwrap(), size.parse().unwrap()));
    }
    out
}

#[test]
fn a_late_bias_step_is_found_by_the_windowed_scan_only() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("late_step.log");
    let log_s = log.to_str().unwrap();
    common::run_cli(&[
        "simulate",
        "replay/static_bench.toml",
        "-o",
        log_s,
        "--set",
        "motion.duration_s=1200",
        "--set",
        "errors.steps=[{t_s = 900.0, gyro_deg_s = [0.0, 0.0, 0.05], accel_mg = [0.0, 0.0, 0.0]}]",
        "--set",
        "errors.gross.rate_per_sample=0",
    ]);
    let true_size = 0.05_f64.to_radians();
    let near = |v: &[(f64, f64)]| {
        v.iter()
            .copied()
            .filter(|(t, _)| (t - 900.0).abs() <= 1.0)
            .collect::<Vec<_>>()
    };
    // `diagnose LOG --channel gz EXTRA... --out-dir DIR/OUT`: its report.
    let diagnose_gz = |out: &str, extra: &[&str]| {
        let out_dir = dir.path().join(out);
        let mut args = vec!["diagnose", log_s, "--channel", "gz"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out-dir", out_dir.to_str().unwrap()]);
        common::run_cli(&args)
    };
    let text = diagnose_gz("one", &[]);
    // The step lies in the single run's test part: it can never be a candidate there.
    assert!(near(&steps(&text)).is_empty(), "{text}");
    let text = diagnose_gz("win", &["--window-s", "600"]);
    let summary = text.split("summary:").nth(1).expect("a summary");
    let found = near(&steps(summary));
    eprintln!("steps near 900 s in the windowed scan: {found:?} (true size {true_size:.4e})");
    // The tolerances for a step: time ± 1 s (the filter above), size ± 10 %.
    assert!(
        found
            .iter()
            .any(|(_, s)| (s - true_size).abs() <= 0.1 * true_size),
        "{summary}"
    );
    let win = dir.path().join("win");
    assert!(win.join("window_810s").join("bias.toml").exists());
}
