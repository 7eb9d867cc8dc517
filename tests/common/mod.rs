//! Helpers shared by the integration tests.
#![allow(dead_code)]

use imuprep::frame::Descriptor;
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use std::path::PathBuf;

/// `../shared/data/real/<rel>` beside the repo, or `None` (and a message) when absent, so a
/// fresh clone elsewhere still passes.
pub fn real_data(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/real")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        skipped(&format!(
            "real recording {} not found (../shared/data/real is absent here)",
            p.display()
        ));
        None
    }
}

/// Say that a test skipped, where `cargo test` shows it: written to the process's stderr
/// directly, because the test harness captures `eprintln!` (shown only on failure or with
/// `--nocapture`) but not raw writes to the stderr handle.
pub fn skipped(why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED: {why}");
}

/// A seeded stream of plausible samples at 200 Hz.
pub fn samples(n: usize, seed: u64) -> Vec<Sample> {
    let mut r = Rng::new(seed);
    (0..n)
        .map(|i| {
            let mut s = Sample {
                temp_c: if i % 7 == 0 {
                    None
                } else {
                    Some(25.0 + r.normal())
                },
                ..Sample::nth(i, 5_000_000)
            };
            s.set_channels(&[
                0.01 * r.normal(),
                0.01 * r.normal(),
                0.3 + 0.01 * r.normal(),
                0.05 * r.normal(),
                0.05 * r.normal(),
                -9.80665 + 0.05 * r.normal(),
            ]);
            s
        })
        .collect()
}

pub fn descriptor() -> Descriptor {
    Descriptor {
        sample_rate_hz: 200.0,
        gyro_range_rad_s: 8.7,
        accel_range_m_s2: 156.9,
        axes: imuprep::frame::AxisConvention::Frd,
        device_id: 7,
        absent: 0,
    }
}

pub fn bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_imuprep"))
}

/// A TCP sink on a free local port writing native frames, client queues of 8 batches; the
/// handle and the address it listens on.
pub async fn tcp_native_sink() -> (imuprep::io::sink::SinkHandle, std::net::SocketAddr) {
    let h = imuprep::io::sink::start(&imuprep::config::Sink::Tcp {
        bind: "127.0.0.1:0".parse().unwrap(),
        format: imuprep::config::Format::Native,
        queue: 8,
    })
    .await
    .unwrap();
    let addr = h.name.trim_start_matches("tcp:").parse().unwrap();
    (h, addr)
}

/// `imuprep import <input> -o <log>` with the default units; its output, success or not.
pub fn import(input: &std::path::Path, log: &std::path::Path) -> std::process::Output {
    std::process::Command::new(bin())
        .arg("import")
        .arg(input)
        .arg("-o")
        .arg(log)
        .output()
        .unwrap()
}

/// Run the built `imuprep` with `args`; its output, success or not.
pub fn imuprep(args: &[&str]) -> std::process::Output {
    std::process::Command::new(bin())
        .args(args)
        .output()
        .unwrap()
}

/// Asserts `text` holds every one of `parts` (the text shown when not).
pub fn assert_says(text: &str, parts: &[&str]) {
    for p in parts {
        assert!(text.contains(p), "{p:?} not in:\n{text}");
    }
}

/// `imuprep import INPUT -o LOG`, asserted to succeed; what it said (stdout, then stderr).
pub fn import_ok(input: &str, log: &std::path::Path) -> String {
    let out = imuprep(&["import", input, "-o", log.to_str().unwrap()]);
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "import {input}:\n{said}");
    said
}

/// The decoder counters a clean input leaves at zero: CRC errors, bad payloads, unknown types,
/// garbage bytes.
pub fn faults(st: &imuprep::frame::DecoderStats) -> [u64; 4] {
    [
        st.crc_errors,
        st.bad_payload,
        st.unknown_type,
        st.garbage_bytes,
    ]
}

/// A bag's topic options: `topic` (`None`: the first Imu topic) and `time` ("header" or "log").
pub fn bag_opts(topic: Option<&str>, time: &str) -> imuprep::frame::ros2::McapOptions {
    imuprep::frame::ros2::McapOptions {
        topic: topic.map(str::to_string),
        time: time.into(),
        ..Default::default()
    }
}

/// Run the built `imuprep` with `args` from the crate root; its stdout and stderr, joined. Panics
/// (with that output) when it fails.
pub fn run_cli(args: &[&str]) -> String {
    let out = std::process::Command::new(bin())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "imuprep {args:?} failed:\n{text}");
    text
}

/// A white-noise ARIMA(0,0,0) model of `channel` with innovation σ `sigma`, mean 0.
pub fn white_arima(channel: &str, sigma: f64) -> imuprep::model::arima::ArimaChannelModel {
    imuprep::model::arima::ArimaChannelModel {
        channel: channel.to_string(),
        p: 0,
        d: 0,
        q: 0,
        constant: 0.0,
        ar: vec![],
        ma: vec![],
        sigma,
        line_per_sample: None,
        diagnostics: None,
    }
}

/// CSV text of the channels `cols` (indices into gx..az) of `data` at `fs` Hz: a `t_s` column
/// (2 decimals) and the channels (7 decimals), as a partial sensor's logger writes them.
pub fn channels_csv(data: &[[f64; 6]], cols: &[usize], fs: f64) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("t_s");
    for c in cols {
        s.push(',');
        s.push_str(imuprep::sample::CHANNEL_NAMES[*c]);
    }
    s.push('\n');
    for (i, v) in data.iter().enumerate() {
        let _ = write!(s, "{:.2}", i as f64 / fs);
        for c in cols {
            let _ = write!(s, ",{:.7}", v[*c]);
        }
        s.push('\n');
    }
    s
}

/// Write `csv` as `dir/name.csv` and import it (gyro in rad/s, accel in m/s²) into
/// `dir/name.log`, which is returned.
pub fn import_csv(dir: &std::path::Path, name: &str, csv: &str) -> PathBuf {
    let path = dir.join(format!("{name}.csv"));
    std::fs::write(&path, csv).unwrap();
    let log = dir.join(format!("{name}.log"));
    run_cli(&[
        "import",
        path.to_str().unwrap(),
        "-o",
        log.to_str().unwrap(),
        "--gyro-unit",
        "rad/s",
        "--accel-unit",
        "m/s2",
    ]);
    log
}

/// Identity inline re-encoding: every item back through the encoder with its own values.
pub fn inline_identity(
    p: imuprep::frame::Protocol,
    items: &[imuprep::frame::Decoded],
    gs: f64,
    as_: f64,
) -> Vec<u8> {
    let mut enc = imuprep::frame::inline::InlineEncoder::new(p, gs, as_);
    let mut out = bytes::BytesMut::new();
    for it in items {
        match it {
            imuprep::frame::Decoded::Sample(s, c) => enc.sample(c.as_ref(), s, &mut out),
            imuprep::frame::Decoded::Other(b) => enc.other(b, &mut out),
            imuprep::frame::Decoded::Descriptor(_) => {}
        }
    }
    enc.flush(&mut out);
    out.to_vec()
}

/// The rows of a reference CSV (comment lines starting with `#` and the header skipped), as
/// strings.
pub fn csv_rows(csv: &str) -> Vec<Vec<String>> {
    csv.lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// What a plot file holds, read with an XML parser.
pub struct SvgParts {
    /// The text of every `<text>` element (titles, axis labels, ticks, legend), trimmed.
    pub texts: Vec<String>,
    /// The `points` attribute of every `<polyline>` (the series, axes and legend samples).
    pub polylines: Vec<String>,
}

/// Parse the SVG at `path`: a panic (naming the file) unless it is a well-formed XML document
/// whose root is `<svg>`, with every element closed.
pub fn svg_parts(path: &std::path::Path) -> SvgParts {
    use quick_xml::events::Event;
    let doc = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut r = quick_xml::Reader::from_str(&doc);
    let (mut open, mut root, mut text) = (Vec::<String>::new(), None, String::new());
    let mut parts = SvgParts {
        texts: Vec::new(),
        polylines: Vec::new(),
    };
    loop {
        let ev = r
            .read_event()
            .unwrap_or_else(|e| panic!("{}: not well-formed XML: {e}", path.display()));
        match &ev {
            Event::Start(e) | Event::Empty(e) => {
                if e.local_name().as_ref() == b"polyline" {
                    let pts = e.try_get_attribute("points").ok().flatten();
                    let pts = pts.map(|a| String::from_utf8_lossy(&a.value).into_owned());
                    parts.polylines.push(pts.unwrap_or_default());
                }
                if matches!(ev, Event::Start(_)) {
                    let name = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                    root.get_or_insert_with(|| name.clone());
                    open.push(name);
                    text.clear();
                }
            }
            Event::Text(t) => text.push_str(&t.decode().unwrap()),
            Event::GeneralRef(g) => {
                let name = g.decode().unwrap();
                text.push_str(quick_xml::escape::resolve_predefined_entity(&name).unwrap());
            }
            Event::End(_) => {
                if open.pop().as_deref() == Some("text") {
                    parts.texts.push(text.trim().to_string());
                }
                text.clear();
            }
            Event::Eof => break,
            _ => {}
        }
    }
    assert!(open.is_empty(), "{}: unclosed {open:?}", path.display());
    assert_eq!(root.as_deref(), Some("svg"), "{}", path.display());
    parts
}

/// The plot at `path` is well-formed SVG, shows every text of `texts` (title, axis labels,
/// legend) and draws at least `series` lines of three points or more (axes, ticks and legend
/// samples are two-point polylines).
pub fn assert_plot(path: &std::path::Path, texts: &[&str], series: usize) {
    let p = svg_parts(path);
    for t in texts {
        assert!(
            p.texts.iter().any(|x| x == t),
            "{}: no text {t:?} in {:?}",
            path.display(),
            p.texts
        );
    }
    let lines = p
        .polylines
        .iter()
        .filter(|l| l.split_whitespace().count() >= 3)
        .count();
    assert!(lines >= series, "{}: {lines} series lines", path.display());
}

/// `imuprep replay LOG --config CONFIG --out csv:OUT`: the CSV's header columns and its rows.
pub fn replay_csv(
    log: &str,
    config: &std::path::Path,
    out: &std::path::Path,
) -> (Vec<String>, Vec<Vec<String>>) {
    run_cli(&[
        "replay",
        log,
        "--config",
        config.to_str().unwrap(),
        "--out",
        &format!("csv:{}", out.display()),
    ]);
    let text = std::fs::read_to_string(out).unwrap();
    let header = text
        .lines()
        .find(|l| !l.starts_with('#'))
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    (header, csv_rows(&text))
}

/// One audit target row judged against the known misses a test lists: `bound` is the measured
/// bound of the known miss that matches the row, if one does; `what` names the row's recording
/// (and copy) in the message. The failure, if any: a miss not listed, a listed miss now met
/// (the list must stay true), or a listed miss beyond its bound.
pub fn judge_target(
    t: &imuprep::report::audit::TargetRow,
    what: &str,
    bound: Option<f64>,
) -> Option<String> {
    match (t.met, bound) {
        (true, None) => None,
        (true, Some(_)) => Some(format!(
            "known miss now met (update KNOWN_MISSES and the docs): {what} {} {} = {}",
            t.channel, t.target, t.measured
        )),
        (false, None) => Some(format!(
            "MISSED {what} {} {} = {} (limit {})",
            t.channel, t.target, t.measured, t.limit
        )),
        (false, Some(bound)) => {
            let ok = if t.at_most {
                t.measured <= bound
            } else {
                t.measured >= bound
            };
            (!ok).then(|| {
                format!(
                    "known miss got worse: {what} {} {} = {} (bound {bound})",
                    t.channel, t.target, t.measured
                )
            })
        }
    }
}

/// `replay/tumble.toml`: the simulated tumble `imuprep calibrate` is tested on.
pub const TUMBLE: &str = "replay/tumble.toml";

/// The [`TUMBLE`] scenario.
pub fn tumble_scenario() -> imuprep::sim::scenario::Scenario {
    let text = std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(TUMBLE))
        .expect("replay/tumble.toml");
    imuprep::sim::scenario::Scenario::from_toml_str(&text).unwrap()
}

/// raw = A·true for one triad: A = I + diag(scale ppm) + misalignment (mrad).
pub fn triad_a(ppm: [f64; 3], mrad: [[f64; 3]; 3]) -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::from_fn(|i, j| {
        f64::from(u8::from(i == j)) * (1.0 + ppm[i] * 1e-6) + mrad[i][j] * 1e-3
    })
}

/// A scenario's truth in the form `calibrate` can identify (docs/calibrate.md): the
/// accelerometer's L = chol(A Aᵀ) (gravity fixes only A Aᵀ; its frame is the accelerometer's x
/// axis and x–y plane), the gyro's M = G Qᵀ with Q = L⁻¹A the rotation from the body to that
/// frame; and the accelerometer bias, m/s².
pub struct CalibTruth {
    pub l: nalgebra::Matrix3<f64>,
    pub gyro_m: nalgebra::Matrix3<f64>,
    pub bias: nalgebra::Vector3<f64>,
}

/// [`CalibTruth`] of a scenario with scale-factor, misalignment and turn-on bias errors.
pub fn calib_truth(scn: &imuprep::sim::scenario::Scenario) -> CalibTruth {
    let e = &scn.errors;
    let s = e.scale_factor.as_ref().unwrap();
    let m = e.misalignment.as_ref().unwrap();
    let a = triad_a(s.accel_ppm, m.accel_mrad);
    let g = triad_a(s.gyro_ppm, m.gyro_mrad);
    let l = (a * a.transpose()).cholesky().unwrap().l();
    let q = l.try_inverse().unwrap() * a;
    CalibTruth {
        l,
        gyro_m: g * q.transpose(),
        bias: nalgebra::Vector3::from(e.turn_on_bias.as_ref().unwrap().accel_mg) * 9.80665e-3,
    }
}

/// Root mean square of `v`.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// The JSON file at `path`, parsed (panics naming the file when it is missing or not that JSON).
pub fn read_json<T: serde::de::DeserializeOwned>(path: impl AsRef<std::path::Path>) -> T {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One truth row of [`rocking`]: time (s), gyro rad/s, specific force m/s².
pub struct TruthRow {
    pub t: f64,
    pub g: [f64; 3],
    pub f: [f64; 3],
}

/// `n` rows at `fs` Hz from `t0_s` of a sensor rolling φ = A sin(2πt/6 s) about x (`amp_deg` 0
/// is a static bench): ω = (φ', 0, 0) plus a small gyro bias, f = g (0, sin φ, cos φ), each with
/// seeded white noise (gyro 0.002 rad/s, accel 0.02 m/s²).
pub fn rocking(n: usize, fs: f64, t0_s: f64, amp_deg: f64, seed: u64) -> Vec<TruthRow> {
    const G0: f64 = 9.80665;
    let mut r = Rng::new(seed);
    let w0 = 2.0 * std::f64::consts::PI / 6.0;
    let a = amp_deg.to_radians();
    (0..n)
        .map(|i| {
            let t = t0_s + i as f64 / fs;
            let phi = a * (w0 * t).sin();
            TruthRow {
                t,
                g: [
                    a * w0 * (w0 * t).cos() + 0.002 * r.normal(),
                    0.003 + 0.002 * r.normal(),
                    -0.001 + 0.002 * r.normal(),
                ],
                f: [
                    0.02 * r.normal(),
                    G0 * phi.sin() + 0.02 * r.normal(),
                    G0 * phi.cos() + 0.02 * r.normal(),
                ],
            }
        })
        .collect()
}

/// Imported samples equal the truth rows: every channel within 1e-9 (one unit conversion's
/// rounding of shortest round-trip text), the rate `fs` within 1e-6 Hz.
pub fn assert_rows(label: &str, (rate, fs): (f64, f64), s: &[Sample], rows: &[TruthRow]) {
    assert!((rate - fs).abs() < 1e-6, "{label}: rate {rate}");
    assert_eq!(s.len(), rows.len(), "{label}");
    for (k, (s, r)) in s.iter().zip(rows).enumerate() {
        for c in 0..3 {
            assert!(
                (s.gyro[c] - r.g[c]).abs() < 1e-9,
                "{label} row {k} g{c}: {} vs {}",
                s.gyro[c],
                r.g[c]
            );
            assert!(
                (s.accel[c] - r.f[c]).abs() < 1e-9,
                "{label} row {k} a{c}: {} vs {}",
                s.accel[c],
                r.f[c]
            );
        }
    }
}
