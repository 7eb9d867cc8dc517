//! Config errors come in one round (issue 13 item 6): an unknown key in a section no longer
//! hides a bad value in the same section until the next run; every key at fault is named once
//! by its path.

mod common;

use std::process::Command;

#[test]
fn an_unknown_key_does_not_hide_a_bad_value_of_its_section() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("bad.toml");
    std::fs::write(
        &cfg,
        r#"[source]
kind = "replay"
path = "x.log"
speed = -1.0
bogus = 1
other = 2
[health]
interval_s = "ten"
[gross_error]
enabled = true
[gross_error.settings]
k = -5.0
median_window = 4
"#,
    )
    .unwrap();
    let out = Command::new(common::bin())
        .args(["run", "--config"])
        .arg(&cfg)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    let keys: Vec<&str> = err
        .lines()
        .filter_map(|l| l.trim().strip_prefix("- "))
        .map(|l| l.split(':').next().unwrap())
        .collect();
    let mut want = vec![
        "source.bogus",
        "source.other",
        "source.speed",
        "health.interval_s",
        "gross_error.settings.k",
        "gross_error.settings.median_window",
    ];
    let mut got = keys.clone();
    got.sort_unstable();
    want.sort_unstable();
    assert_eq!(got, want, "{err}");
    assert!(err.contains("6 configuration error(s)"), "{err}");
}
