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
