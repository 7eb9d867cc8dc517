//! Log lines carry no colour codes when stderr is not a terminal (issue 13, small items): a log
//! file or a pipe gets plain text.
mod common;

#[test]
fn log_lines_on_a_piped_stderr_have_no_escape_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("in.log");
    imuprep::io::log::write_log(&log, &common::descriptor(), &common::samples(400, 3)).unwrap();
    // A config with no cleaning stage makes the run log a WARN line besides the INFO ones.
    let cfg = dir.path().join("raw.toml");
    std::fs::write(
        &cfg,
        format!(
            "[source]\nkind = \"replay\"\npath = {:?}\n[gross_error]\nenabled = false\n[bias]\nenabled = false\n",
            log.to_str().unwrap()
        ),
    )
    .unwrap();
    for extra in [&[][..], &["--config", cfg.to_str().unwrap()][..]] {
        let out = std::process::Command::new(common::bin())
            .args(["--log-level", "debug", "replay", log.to_str().unwrap()])
            .args(extra)
            .args(["--out", "csv:/dev/null"])
            .output() // stdout and stderr are pipes here
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(err.contains("INFO"), "no log line to check: {err}");
        if !extra.is_empty() {
            assert!(err.contains("WARN"), "no WARN line to check: {err}");
        }
        assert!(
            !out.stderr.contains(&0x1b) && !out.stdout.contains(&0x1b),
            "ESC bytes in piped output: {err:?}"
        );
    }
}
