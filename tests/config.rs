//! Every shipped config validates; mistakes are all reported, with their key paths.

mod common;

use imuprep::config::Config;
use std::ffi::OsStr;
use std::path::Path;

/// The binary run with `args`, its output collected.
fn imuprep<const N: usize>(args: [&OsStr; N]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_imuprep"))
        .args(args)
        .output()
        .unwrap()
}

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
    // By key path (issue 13 item 6): the unknown key itself, not only its section.
    assert!(paths.contains(&"source.sped"), "{e}");
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
    let out = imuprep(["run".as_ref(), "--config".as_ref(), p.as_os_str()]);
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

/// The stage sections of a user file are laid over the embedded defaults: a file that names one
/// gross-error setting keeps both stages enabled with every other default (issue 13, item 1:
/// such a file used to run with no stage at all and publish raw data as if cleaned).
#[test]
fn a_user_file_changes_only_what_it_names() {
    let text = "[source]\nkind = \"stdin\"\n\n[gross_error.settings]\nk = 5.0\n";
    let c = Config::from_toml_str(text, Path::new(".")).unwrap_or_else(|e| panic!("{e}"));
    let d = Config::default_embedded().unwrap();
    let g = c
        .stages
        .gross_error
        .as_ref()
        .expect("gross_error inherits enabled = true");
    assert_eq!(g.settings.k, 5.0);
    let dg = &d.stages.gross_error.as_ref().unwrap().settings;
    let expected = imuprep::stage::gross_error::GrossErrorSettings {
        k: 5.0,
        ..dg.clone().into_inner()
    };
    assert_eq!(g.settings, expected, "only k differs from the defaults");
    let b = c
        .stages
        .bias
        .as_ref()
        .expect("bias inherits enabled = true");
    assert_eq!(b.settings, d.stages.bias.as_ref().unwrap().settings);
    assert_eq!(c.health, d.health);
    assert_eq!(
        c.stages.build().unwrap().cleaning_stage_names(),
        ["gross_error", "bias"]
    );
    // Switching a stage off is said in the file, and only that stage goes.
    let off = "[source]\nkind = \"stdin\"\n[bias]\nenabled = false\n";
    let c = Config::from_toml_str(off, Path::new(".")).unwrap();
    assert_eq!(
        c.stages.build().unwrap().cleaning_stage_names(),
        ["gross_error"]
    );
}

/// A pipeline with no cleaning stage is said in the summary and the health data (issue 13,
/// item 1: it used to publish raw data with no word about it).
#[test]
fn a_run_without_cleaning_stages_says_so_in_the_summary_and_the_health_data() {
    let dir = tempfile::tempdir().unwrap();
    let summary = dir.path().join("s.json");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_imuprep"))
        .arg("replay")
        .arg(root.join("replay/static_bench.log"))
        .arg("--config")
        .arg(root.join("config/passthrough.toml"))
        .arg("--summary-json")
        .arg(&summary)
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cleaning   : NONE — no cleaning stage is enabled"),
        "{err}"
    );
    let h: serde_json::Value = common::read_json(&summary);
    assert_eq!(h["cleaning_stages"], serde_json::json!([]), "{h}");
    // With the defaults the stages are listed and nothing is said.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_imuprep"))
        .arg("replay")
        .arg(root.join("replay/static_bench.log"))
        .arg("--summary-json")
        .arg(&summary)
        .output()
        .unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("cleaning   : NONE"));
    let h: serde_json::Value = common::read_json(&summary);
    assert_eq!(
        h["cleaning_stages"],
        serde_json::json!(["gross_error", "bias"])
    );
}

/// Fourteen mistakes in every section, structural and in value, with two missing model files:
/// all reported in one run, each once, each at its own key path, and nothing else — no
/// knock-on error at a key the file never set (issue 13, item 6).
#[test]
fn every_config_error_is_reported_in_one_run_once_by_key_path() {
    let text = r#"
[source]
kind = "serial"
port = ""
baud = 0

[health]
interval_s = -1.0

[[sinks]]
kind = "tcp"
bind = "nowhere"

[gross_error]
model = "missing/arima.toml"

[gross_error.settings]
k = "five"
kk = 3.0
jump_k = 0.0
post_samples = 1

[gross_error.settings.identify]
p_max = "three"

[bias]
model = "missing/bias.toml"

[bias.settings]
sample_rate = 100.0

[bias.settings.gyro]
scale = [0.1, 1.0, 1.0]

[bias.settings.stillness]
window_s = 0.0
"#;
    let e = Config::from_toml_str(text, Path::new("/nonexistent")).unwrap_err();
    let mut paths: Vec<&str> = e.0.iter().map(|x| x.path.as_str()).collect();
    paths.sort();
    let mut want = vec![
        "source.port",
        "source.baud",
        "health.interval_s",
        "sinks[0].bind",
        "gross_error.model",
        "gross_error.settings.k",
        "gross_error.settings.kk",
        "gross_error.settings.jump_k",
        "gross_error.settings.post_samples",
        "gross_error.settings.identify.p_max",
        "bias.model",
        "bias.settings.sample_rate",
        "bias.settings.gyro.scale[0]",
        "bias.settings.stillness.window_s",
    ];
    want.sort();
    assert_eq!(paths, want, "{e}");
}

/// Leaf key paths of a TOML table (`a.b.c`).
fn leaf_paths(t: &toml::Table, prefix: &str, out: &mut Vec<String>) {
    for (k, v) in t {
        let p = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(s) if !s.is_empty() && k != "adf_lag" => leaf_paths(s, &p, out),
            _ => out.push(p),
        }
    }
}

/// The value at a dotted path.
fn at<'a>(t: &'a toml::Table, path: &str) -> Option<&'a toml::Value> {
    let mut v: Option<&toml::Value> = None;
    let mut cur = t;
    for k in path.split('.') {
        v = cur.get(k);
        if let Some(toml::Value::Table(s)) = v {
            cur = s;
        }
    }
    v
}

/// `config/default.toml` lists every setting of both stages with the value the code uses by
/// default, and every value it documents in its comments parses (issue 13, item 7: it listed
/// 11 of 22 gross-error keys and documented a `replacement` value the parser rejected).
#[test]
fn default_toml_lists_every_setting_and_every_documented_value_parses() {
    use imuprep::stage::bias::settings::BiasSettings;
    use imuprep::stage::gross_error::GrossErrorSettings;
    let file: toml::Table = imuprep::config::DEFAULT_TOML.parse().unwrap();
    for (section, defaults) in [
        (
            "gross_error.settings",
            toml::Table::try_from(GrossErrorSettings::default()).unwrap(),
        ),
        (
            "bias.settings",
            toml::Table::try_from(BiasSettings::default()).unwrap(),
        ),
        (
            "health",
            toml::Table::try_from(imuprep::config::HealthConfig::default()).unwrap(),
        ),
        (
            "monitor.settings",
            toml::Table::try_from(imuprep::stage::monitor::MonitorSettings::default()).unwrap(),
        ),
        (
            "zenoh",
            toml::Table::try_from(imuprep::config::ZenohConfig::default()).unwrap(),
        ),
    ] {
        let mut keys = Vec::new();
        leaf_paths(&defaults, "", &mut keys);
        assert!(
            keys.len() > 10 || ["health", "monitor.settings", "zenoh"].contains(&section),
            "{section}: {keys:?}"
        );
        for k in keys {
            let full = format!("{section}.{k}");
            let got = at(&file, &full).unwrap_or_else(|| panic!("{full} is not in default.toml"));
            let want = at(&defaults, &k).unwrap();
            assert_eq!(
                got, want,
                "{full}: default.toml says {got}, the code uses {want}"
            );
        }
    }
    // Every documented alternative value.
    let base = imuprep::config::DEFAULT_TOML;
    let variants = [
        (
            "replacement = \"interpolation\"",
            "replacement = \"prediction\"",
        ),
        (
            "replacement = \"interpolation\"",
            "replacement = \"median\"",
        ),
        (
            "adf_lag = { rule = \"aic\" }",
            "adf_lag = { rule = \"aic\", max_lag = 8 }",
        ),
        (
            "adf_lag = { rule = \"aic\" }",
            "adf_lag = { rule = \"fixed\", lags = 4 }",
        ),
        ("median_window = 3", "median_window = 5"),
        ("lookahead_samples = 16", "lookahead_samples = 0"),
    ];
    for (from, to) in variants {
        let i = base
            .find(from)
            .unwrap_or_else(|| panic!("{from} not in default.toml"));
        let text = format!("{}{to}{}", &base[..i], &base[i + from.len()..]);
        Config::from_toml_str(&text, Path::new(".")).unwrap_or_else(|e| panic!("{to}: {e}"));
    }
    // The commented examples, uncommented: the serial source, the per-protocol tables and the
    // four sinks.
    let uncomment = |from: &str, to: &str| -> String {
        let (i, j) = (base.find(from).unwrap(), base.find(to).unwrap());
        let block: String = base[i..j]
            .lines()
            .map(|l| l.strip_prefix("# ").or(l.strip_prefix('#')).unwrap_or(l))
            .collect::<Vec<_>>()
            .join("\n");
        format!("{}{block}\n{}", &base[..i], &base[j..])
    };
    let serial = uncomment("# kind = \"serial\"", "# Wire protocol")
        .replace("kind = \"replay\"\npath = \"replay/drive.log\"", "");
    let serial = serial.replacen("speed = 0.0 ", "# speed ", 1);
    let zenoh_source = uncomment("#   kind = \"zenoh\"", "# For a live sensor")
        .replace("kind = \"replay\"\npath = \"replay/drive.log\"", "");
    let zenoh_source = zenoh_source.replacen("speed = 0.0 ", "# speed ", 1);
    for (name, text) in [
        ("serial source", serial),
        ("zenoh source", zenoh_source),
        ("protocol tables", uncomment("# [source.ubx]", "\n[health]")),
        ("sinks", uncomment("# [[sinks]]", "# Gross errors")),
    ] {
        // Without the `ros2` and `zenoh` features the documented mcap and zenoh sinks and the
        // zenoh source are refused, and only they, each with the build that has them.
        let mut refused = Vec::new();
        if name == "sinks" && !cfg!(feature = "ros2") {
            refused.push("sinks[4].kind: mcap needs a build with ROS 2 support");
        }
        if name == "sinks" && !cfg!(feature = "zenoh") {
            refused.push("sinks[5].kind: zenoh needs a build with Zenoh support");
        }
        if name == "zenoh source" && !cfg!(feature = "zenoh") {
            refused.push("source.kind: zenoh needs a build with Zenoh support");
        }
        match Config::from_toml_str(&text, Path::new(".")) {
            Ok(_) => assert!(refused.is_empty(), "{name}: {refused:?} not refused"),
            Err(e) => {
                let e = e.to_string();
                assert!(
                    !refused.is_empty()
                        && e.contains(&format!("{} configuration error", refused.len()))
                        && refused.iter().all(|r| e.contains(r)),
                    "{name}: {e}\n{text}"
                );
            }
        }
    }
}

#[test]
fn a_tuning_only_file_works_where_the_command_brings_its_input_and_run_still_needs_a_source() {
    // `replay LOG` replaces the source, so a file holding only what the user tunes must run
    // there (it once failed "missing section [source]"); the daemon takes its source from the
    // file, so `run` must still refuse a file without one.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("tuning.toml");
    std::fs::write(&p, "[gross_error.settings]\nk = 5.0\n").unwrap();
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/replay/drive.log");
    let out = imuprep([
        "replay".as_ref(),
        log.as_ref(),
        "--config".as_ref(),
        p.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("29982 out"), "the whole log is cleaned: {err}");
    let out = imuprep(["run".as_ref(), "--config".as_ref(), p.as_os_str()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing section [source]"));
}

/// `[zenoh]` is checked in every build (raw → validated once): every mistake at its key path,
/// all in one run, with the source and sink keys that name Zenoh.
#[test]
fn zenoh_section_mistakes_are_all_reported_at_their_keys() {
    let text = r#"
[source]
kind = "zenoh"
key = "imuprep//raw"

[[sinks]]
kind = "zenoh"
key = "imuprep/*/imu"
format = "csv"
queue = 0

[zenoh]
mode = "router"
connect = ["tcp/127.0.0.1", "quic/10.0.0.1:7447", "127.0.0.1:7447"]
listen = ["udp/0.0.0.0:99999"]
scouting = false
"#;
    let e = Config::from_toml_str(text, Path::new("."))
        .unwrap_err()
        .to_string();
    for want in [
        "source.key: \"imuprep//raw\": a key has no leading, trailing or doubled '/'",
        "sinks[0].key: \"imuprep/*/imu\": a published key names one resource (no '*')",
        "sinks[0].format: a zenoh sink publishes \"native\" frames or \"jsonl\" lines, not csv",
        "sinks[0].queue: must be > 0",
        "zenoh.scouting: unknown field `scouting`",
        "zenoh.mode: must be \"peer\" or \"client\", got \"router\"",
        "zenoh.connect[0]: \"tcp/127.0.0.1\": the address needs HOST:PORT",
        "zenoh.connect[1]: \"quic/10.0.0.1:7447\": transport \"quic\" is not in this build",
        "zenoh.connect[2]: \"127.0.0.1:7447\" is not an endpoint (PROTO/HOST:PORT",
        "zenoh.listen[0]: \"udp/0.0.0.0:99999\": the address needs HOST:PORT",
    ] {
        assert!(e.contains(want), "missing {want:?} in:\n{e}");
    }
    // A client does not listen, and needs a router to reach.
    let e = Config::from_toml_str(
        "[source]\nkind = \"stdin\"\n[zenoh]\nmode = \"client\"\nlisten = [\"tcp/0.0.0.0:7447\"]\nmulticast_scouting = false\n",
        Path::new("."),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("zenoh.listen: a client does not listen"), "{e}");
    assert!(e.contains("zenoh.connect: a client needs a router"), "{e}");
}

/// An endpoint's `?metadata` or `#config` part that Zenoh's parser refuses (`tcp/…:7447#`, an
/// empty key, `?` after `#`) once passed the config check and failed at session open with
/// Zenoh's raw error (`zenoh config listen/endpoints = [...]: Json5Err(Message { msg: ... })`),
/// although a malformed endpoint is meant to be a config error at its key. Well-formed options
/// still pass through to Zenoh.
#[test]
fn zenoh_endpoint_options_zenoh_refuses_are_config_errors_at_their_keys() {
    let bad = [
        "tcp/127.0.0.1:7447#",
        "tcp/127.0.0.1:7447?",
        "tcp/127.0.0.1:7447#=1",
        "tcp/127.0.0.1:7447#;",
        "tcp/127.0.0.1:7447?a=1#",
        "tcp/127.0.0.1:7447#a=1?b=2",
    ];
    let good = [
        "tcp/127.0.0.1:7447#so_sndbuf=65536",
        "tcp/127.0.0.1:7447?prio=1-7#iface=lo",
        "udp/127.0.0.1:7447#rel=0;mtu=1400",
    ];
    let list = |v: &[&str]| serde_json::to_string(v).unwrap();
    let text = format!(
        "[source]\nkind = \"stdin\"\n[zenoh]\nconnect = {}\nlisten = {}\n",
        list(&bad),
        list(&good)
    );
    let e = Config::from_toml_str(&text, Path::new("."))
        .unwrap_err()
        .to_string();
    for (i, ep) in bad.iter().enumerate() {
        let want = format!("zenoh.connect[{i}]: {ep:?}: Zenoh's options after");
        assert!(e.contains(&want), "missing {want:?} in:\n{e}");
    }
    assert!(!e.contains("zenoh.listen"), "{e}");
}
