//! Shared by the monitor's integration tests (tests/model_health.rs, tests/model_whiteness.rs):
//! the simulated benches, the embedded default pipeline's cleaning stages and the monitor over
//! their output.
#![allow(dead_code)] // each test crate uses its own part

use std::path::Path;

use imuprep::config::Config;
use imuprep::frame::Descriptor;
use imuprep::report::audit::load_recording;
use imuprep::sample::Sample;
use imuprep::sim::Scenario;
use imuprep::stage::monitor::{Alarm, MonitorSettings, MonitorStage};
use imuprep::stage::{Stage, run_through};

/// The static bench scenario without any effect a bias model would lack: white noise, turn-on
/// bias, Gauss–Markov and AR bias, random walk, quantisation — no temperature term, steps, lines,
/// gross errors or saturation.
pub fn clean_bench(duration_s: f64) -> Scenario {
    bench_without(duration_s, &CLEAN, &[])
}

/// What [`clean_bench`] leaves out of the static bench's `[errors]`.
const CLEAN: [&str; 5] = [
    "temperature",
    "gross",
    "saturation",
    "steps",
    "vibration_lines",
];

/// The static bench without the `[errors]` tables `drop`, with further scenario overrides
/// (`key = value`, as `--set` takes them).
pub fn bench_without(duration_s: f64, drop: &[&str], set: &[(&str, &str)]) -> Scenario {
    let text = std::fs::read_to_string("replay/static_bench.toml").unwrap();
    let mut t: toml::Table = text.parse().unwrap();
    let errors = t.get_mut("errors").unwrap().as_table_mut().unwrap();
    for k in drop {
        errors.remove(*k);
    }
    let text = toml::to_string(&t).unwrap();
    let mut overrides = vec![("motion.duration_s".to_string(), duration_s.to_string())];
    overrides.extend(set.iter().map(|(k, v)| (k.to_string(), v.to_string())));
    Scenario::from_toml_str_with(&text, &overrides).unwrap()
}

/// The embedded default pipeline's cleaning stages over `samples` (their output) and its
/// monitor settings, with the wander test on when `wander`.
pub fn cleaned(samples: &[Sample], rate_hz: f64, wander: bool) -> (Vec<Sample>, MonitorSettings) {
    let mut cfg = Config::default_embedded().unwrap();
    let mut settings = cfg
        .stages
        .monitor
        .take()
        .expect("the default enables the monitor");
    settings.wander = wander;
    cfg.stages.set_sample_rate(rate_hz).unwrap();
    let mut p = cfg.stages.build().unwrap();
    (run_through(&mut p, samples), settings)
}

/// The monitor over the cleaned output.
pub fn watch(out: &[Sample], settings: MonitorSettings, rate_hz: f64) -> MonitorStage {
    let mut m = MonitorStage::new(settings, Some(rate_hz)).unwrap();
    let mut sink = Vec::with_capacity(1);
    for s in out {
        m.push(*s, &mut sink);
        sink.clear();
    }
    m
}

pub fn alarms(m: &MonitorStage) -> Vec<Alarm> {
    m.alarms().copied().collect()
}

/// The diagnose ladder's background (`tests/fixtures/wander_ladder.toml` with no wander: white
/// noise and quantisation only) for `duration_s`.
pub fn white_bench(duration_s: f64) -> Scenario {
    let text = std::fs::read_to_string("tests/fixtures/wander_ladder.toml").unwrap();
    let mut t: toml::Table = text.parse().unwrap();
    t["errors"].as_table_mut().unwrap().remove("gauss_markov");
    Scenario::from_toml_str_with(
        &toml::to_string(&t).unwrap(),
        &[("motion.duration_s".into(), duration_s.to_string())],
    )
    .unwrap()
}

/// A real recording under `root` (`rel` a file, or a directory whose first recording is used).
pub fn load_real(root: &Path, rel: &str) -> (Descriptor, Vec<Sample>) {
    let path = root.join(rel);
    let path = if path.is_dir() {
        imuprep::report::audit::find_recordings(&path).unwrap()[0].clone()
    } else {
        path
    };
    load_recording(&path).unwrap()
}

/// The real static benches (`../shared/data/real`): name, rate (Hz), hours and samples each; none,
/// with a `SKIPPED:` line on stderr, when that directory is absent.
pub fn real_static_benches() -> Vec<(&'static str, f64, f64, Vec<Sample>)> {
    let root = Path::new("../shared/data/real");
    if !root.exists() {
        eprintln!("SKIPPED: ../shared/data/real is absent");
        return Vec::new();
    }
    [
        "adis16405_static/adis_16405_imu1.csv.gz",
        "mpu6050_static_10min_temp",
    ]
    .into_iter()
    .map(|rel| {
        let (desc, samples) = load_real(root, rel);
        let rate = desc.sample_rate_hz;
        let hours = samples.len() as f64 / rate / 3600.0;
        (rel, rate, hours, samples)
    })
    .collect()
}
