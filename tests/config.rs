//! Every shipped config validates; mistakes are all reported, with their key paths.
use imuprep::config::Config;
use std::path::Path;

#[test]
fn every_file_in_config_dir_validates() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("config");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            Config::from_file(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            n += 1;
        }
    }
    assert!(n >= 1);
    Config::default_embedded().expect("embedded default validates");
}

#[test]
fn a_config_with_three_mistakes_reports_all_three() {
    let text = r#"
[source]
kind = "replay"
path = "x.log"
sped = 2.0            # mistake 1: unknown key

[health]
interval_s = -1.0     # mistake 2: negative interval

[[sinks]]
kind = "tcp"
bind = "not-an-address"   # mistake 3
"#;
    let e = Config::from_toml_str(text, Path::new(".")).unwrap_err();
    let paths: Vec<&str> = e.0.iter().map(|x| x.path.as_str()).collect();
    assert_eq!(e.0.len(), 3, "{e}");
    assert!(paths.contains(&"source"), "{e}");
    assert!(e.to_string().contains("sped"), "{e}");
    assert!(paths.contains(&"health.interval_s"), "{e}");
    assert!(paths.contains(&"sinks[0].bind"), "{e}");
}

#[test]
fn unreadable_config_is_a_clear_error() {
    let e = Config::from_file(Path::new("/nonexistent/imuprep.toml")).unwrap_err();
    assert!(e.to_string().contains("cannot read config"), "{e}");
}

#[test]
fn binary_exits_non_zero_and_starts_nothing_on_a_bad_config() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(
        &p,
        "[source]\nkind = \"serial\"\nport = \"\"\nbaud = 0\n[bogus]\n",
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_imuprep"))
        .args(["run", "--config"])
        .arg(&p)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("source.port") && err.contains("source.baud") && err.contains("bogus"),
        "{err}"
    );
    assert!(!err.contains("pipeline ready"), "nothing may start: {err}");
}

#[test]
fn gross_error_tail_and_look_ahead_settings_out_of_range_are_named() {
    // The tail adaptation's two knobs: a negative gain would narrow the gate on heavy tails, a
    // window below 100 samples estimates a 0.27 % share from less than one expected exceedance.
    // A look-ahead beyond 1000 samples (5 s at 200 Hz) is a typo, not a lag anyone wants.
    // The section is not enabled: its settings are checked all the same.
    let text = r#"
[source]
kind = "stdin"

[gross_error.settings]
tail_gain = -0.5
tail_window_samples = 50.0
lookahead_samples = 5000
"#;
    let e = Config::from_toml_str(text, Path::new(".")).unwrap_err();
    let s = e.to_string();
    assert!(s.contains("tail_gain = -0.5"), "{s}");
    assert!(s.contains("tail_window_samples = 50"), "{s}");
    assert!(s.contains("lookahead_samples = 5000"), "{s}");
}
