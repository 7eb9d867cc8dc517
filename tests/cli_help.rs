//! Every command-line flag carries a help text (issue 13, small items).
mod common;

const COMMANDS: [&str; 12] = [
    "run",
    "replay",
    "import",
    "export",
    "simulate",
    "fit",
    "evaluate",
    "diagnose",
    "compare",
    "audit",
    "allan",
    "calibrate",
];

#[test]
fn every_flag_and_argument_has_a_help_text() {
    let mut missing = Vec::new();
    for cmd in COMMANDS {
        let out = std::process::Command::new(common::bin())
            .args([cmd, "-h"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{cmd} -h failed");
        let text = String::from_utf8_lossy(&out.stdout);
        let lines: Vec<&str> = text.lines().collect();
        let mut section = "";
        let mut sections = 0;
        for (i, line) in lines.iter().enumerate() {
            if !line.starts_with(' ') && line.ends_with(':') {
                section = line;
                sections += 1;
                continue;
            }
            // Every section of arguments: "Arguments:", "Options:" and the headed groups
            // (import's flags on the commands that read a recording).
            if section.is_empty() {
                continue;
            }
            let body = line.trim();
            if !(body.starts_with('-') || body.starts_with('<') || body.starts_with('[')) {
                continue; // a description line
            }
            // The text is on the flag's line (after two or more spaces) or, when long, on the
            // next line, indented deeper.
            let inline = body.split("  ").filter(|p| !p.trim().is_empty()).count() >= 2;
            let indent = |l: &str| l.len() - l.trim_start().len();
            let next = lines.get(i + 1).is_some_and(|n| {
                let t = n.trim();
                !t.is_empty() && !t.starts_with('-') && indent(n) > indent(line)
            });
            if !inline && !next {
                missing.push(format!("{cmd}: {body}"));
            }
        }
        assert!(sections >= 1, "{cmd} -h: no section of arguments read");
    }
    assert!(
        missing.is_empty(),
        "flags without a help text:\n{}",
        missing.join("\n")
    );
}
