//! Sensor classes we do not have (issue 12): the embedded default pipeline on seeded, physically
//! meaningful transformations of every real recording under `../shared/data/real`, scored with
//! the audit's own do-no-harm targets (`imuprep::report::audit::score_harm`). A threshold that
//! follows the sensor's own noise, or time in seconds, gives the same decisions on a copy with a
//! large gyro bias, more white noise, a lower rate, a coarser LSB or other gyro units; an absolute
//! number or a constant in samples shows up here before an unseen sensor finds it.
//!
//! Transformations (why each, and where it applies, in docs/real-data.md, "Sensor classes we do
//! not have"):
//! - `bias+2`, `bias-5`: +2 °/s or −5 °/s added to all three gyro axes (comma2k19's uncalibrated
//!   gyro carries ~3.9 °/s);
//! - `noise×3`: seeded Gaussian white noise of 3× each channel's own measured noise σ added;
//! - `rate/2`, `rate/4`: non-overlapping pairs or quads averaged (time stamps too), the
//!   descriptor's rate divided; only where the copy keeps the audit's 6000 samples;
//! - `lsb×4`: every channel rounded to 4× the recording's datasheet LSB (where its NOTES state
//!   one: the ADIS16405, the MPU6050, the rtklibexplorer drive and walk);
//! - `gyro×0.25`, `gyro×4`: the gyro channels (and the descriptor's gyro range) in other units.
//!   Accelerometers are tied to g and are not scaled.
//!
//! Skipped (visibly, on stderr) when `../shared/data/real` is absent.
//! `cargo test --release --test sensor_classes -- --nocapture` prints the table.

mod common;

use std::path::Path;

use imuprep::config::Config;
use imuprep::frame::Descriptor;
use imuprep::report::audit::{
    Class, HarmScore, classify, find_recordings, load_recording, run_config, score_harm,
};
use imuprep::rng::Rng;
use imuprep::sample::{N_CHANNELS, Sample, flags};
use imuprep::stats::robust::robust_sigma;

/// Seed of every random draw in this file.
const SEED: u64 = 12;
/// Shortest record scored (the audit's own rule: 3 × the gross-error warm-up of 2000 samples).
const MIN_SAMPLES: usize = 6000;
const G: f64 = 9.80665;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Transform {
    Original,
    GyroBias(f64),
    Noise(f64),
    Decimate(usize),
    Quantise(f64),
    GyroScale(f64),
}

impl Transform {
    fn label(&self) -> String {
        match self {
            Transform::Original => "original".into(),
            Transform::GyroBias(b) => format!("bias{b:+}"),
            Transform::Noise(k) => format!("noise×{k}"),
            Transform::Decimate(k) => format!("rate/{k}"),
            Transform::Quantise(k) => format!("lsb×{k}"),
            Transform::GyroScale(k) => format!("gyro×{k}"),
        }
    }

    /// Replacements and stillness are compared sample by sample with the original's.
    fn equivariant(&self) -> bool {
        matches!(self, Transform::GyroBias(_) | Transform::GyroScale(_))
    }
}

/// Datasheet LSBs (gyro °/s, accel g) of the recordings whose NOTES.txt state one.
fn lsb_of(name: &str) -> Option<(f64, f64)> {
    if name.starts_with("adis16405") {
        Some((0.05, 0.00333))
    } else if name.starts_with("mpu6050") {
        Some((1.0 / 131.0, 1.0 / 4096.0))
    } else if name.starts_with("rtklibexplorer") {
        Some((0.0076, 0.001))
    } else {
        None
    }
}

/// A channel's own white-noise σ: the robust spread of its first differences / √2 (motion is
/// smooth at the sample scale, so this reads the noise on moving recordings too).
fn noise_sigma(raw: &[Sample], c: usize) -> f64 {
    let d: Vec<f64> = raw
        .windows(2)
        .map(|w| w[1].channel(c) - w[0].channel(c))
        .filter(|v| v.is_finite())
        .collect();
    robust_sigma(&d) / std::f64::consts::SQRT_2
}

/// Average non-overlapping groups of `k` samples (time stamps, channels, temperature); flags and
/// absent masks are or-ed, sequence numbers renumbered.
fn decimate(raw: &[Sample], k: usize) -> Vec<Sample> {
    raw.chunks_exact(k)
        .enumerate()
        .map(|(i, g)| {
            let mut s = g[0];
            s.seq = i as u32;
            s.t_ns = g.iter().map(|x| u128::from(x.t_ns)).sum::<u128>() as u64 / k as u64;
            let mut v = [0.0; N_CHANNELS];
            for x in g {
                for (c, vc) in v.iter_mut().enumerate() {
                    *vc += x.channel(c) / k as f64;
                }
            }
            s.set_channels(&v);
            let temps: Vec<f64> = g.iter().filter_map(|x| x.temp_c).collect();
            s.temp_c = (!temps.is_empty()).then(|| temps.iter().sum::<f64>() / temps.len() as f64);
            s.flags = g.iter().fold(0, |a, x| a | x.flags);
            s.absent = g.iter().fold(0, |a, x| a | x.absent);
            s
        })
        .collect()
}

/// The transformed copy of one recording, or `None` where the transformation is not meaningful.
fn transform(
    name: &str,
    desc: &Descriptor,
    raw: &[Sample],
    t: Transform,
    stream: u64,
) -> Option<(Descriptor, Vec<Sample>)> {
    let mut d = *desc;
    let mut x = raw.to_vec();
    match t {
        Transform::Original => {}
        Transform::GyroBias(dps) => {
            for s in &mut x {
                for c in 0..3 {
                    s.set_channel(c, s.channel(c) + dps.to_radians());
                }
            }
        }
        Transform::Noise(k) => {
            let sig: Vec<f64> = (0..N_CHANNELS).map(|c| noise_sigma(raw, c)).collect();
            let mut rng = Rng::fork(SEED, stream);
            for s in &mut x {
                for (c, sc) in sig.iter().enumerate() {
                    s.set_channel(c, s.channel(c) + k * sc * rng.normal());
                }
            }
        }
        Transform::Decimate(k) => {
            x = decimate(raw, k);
            d.sample_rate_hz /= k as f64;
        }
        Transform::Quantise(k) => {
            let (g_lsb, a_lsb) = lsb_of(name)?;
            let q = [
                (k * g_lsb).to_radians(),
                (k * g_lsb).to_radians(),
                (k * g_lsb).to_radians(),
                k * a_lsb * G,
                k * a_lsb * G,
                k * a_lsb * G,
            ];
            for s in &mut x {
                for (c, qc) in q.iter().enumerate() {
                    s.set_channel(c, (s.channel(c) / qc).round() * qc);
                }
            }
        }
        Transform::GyroScale(k) => {
            for s in &mut x {
                for c in 0..3 {
                    s.set_channel(c, s.channel(c) * k);
                }
            }
            d.gyro_range_rad_s *= k as f32;
        }
    }
    (x.len() >= MIN_SAMPLES).then_some((d, x))
}

const TRANSFORMS: &[Transform] = &[
    Transform::GyroBias(2.0),
    Transform::GyroBias(-5.0),
    Transform::Noise(3.0),
    Transform::Decimate(2),
    Transform::Decimate(4),
    Transform::Quantise(4.0),
    Transform::GyroScale(0.25),
    Transform::GyroScale(4.0),
];

/// One scored copy.
struct Row {
    recording: String,
    transform: Transform,
    class: Class,
    score: HarmScore,
    /// Channel-samples whose REPLACED bit differs from the original's, and samples whose STILL
    /// flag differs (equivariant transformations only).
    replaced_diff: Option<usize>,
    still_diff: Option<usize>,
    samples: usize,
}

fn diffs(a: &[Sample], b: &[Sample]) -> (usize, usize) {
    let rep = a
        .iter()
        .zip(b)
        .map(|(x, y)| ((x.flags ^ y.flags) & flags::REPLACED_ANY).count_ones() as usize)
        .sum();
    let still = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.has(flags::STILL) != y.has(flags::STILL))
        .count();
    (rep, still)
}

fn fmt_row(r: &Row) -> String {
    let s = &r.score;
    let worst_rep = s
        .channels
        .iter()
        .map(|c| c.replaced_rate)
        .fold(0.0, f64::max);
    let worst_angle = s
        .channels
        .iter()
        .filter_map(|c| c.invented_angle_deg)
        .fold(0.0, f64::max);
    let missed: Vec<String> = s
        .targets
        .iter()
        .filter(|t| !t.met)
        .map(|t| format!("{} {} = {:.3e}", t.channel, t.target, t.measured))
        .collect();
    let opt = |v: Option<usize>| v.map_or("–".to_string(), |v| v.to_string());
    format!(
        "| {} | {} | {:?} | {:.1e} | {:.3} | {} | {:.1} | {:.1} | {:.2} | {} | {} | {} |",
        r.recording,
        r.transform.label(),
        r.class,
        worst_rep,
        worst_angle,
        s.bias_first_engaged_s
            .map_or("never".to_string(), |t| format!("{t:.1}")),
        100.0 * s.bias_engaged_share,
        100.0 * s.still_share,
        s.onset_worst_move_3sigma,
        opt(r.replaced_diff),
        opt(r.still_diff),
        if missed.is_empty() {
            "all met".to_string()
        } else {
            missed.join("; ")
        }
    )
}

/// Targets a transformed copy misses, bounded at the measured value (rounded at the second
/// significant digit, away from the target: the bound is the measurement, no slack): (recording
/// prefix, transformations, channel, target prefix, bound). Causes in docs/real-data.md,
/// "Sensor classes we do not have". A listed miss that is met now fails too, so the list stays
/// true.
const KNOWN_MISSES: &[(&str, &[&str], &str, &str, f64)] = &[
    // Inherited from the original recordings (tests/audit_real.rs bounds them there at 2e-4 and
    // 3e-4): the equivariant copies replace exactly the same samples.
    (
        "px4_sensor_combined",
        &["bias+2", "bias-5", "gyro×0.25", "gyro×4"],
        "gx",
        "replaced per channel-sample",
        2e-4,
    ),
    (
        "px4_ulog/sample.ulg",
        &["bias+2", "bias-5", "gyro×0.25", "gyro×4"],
        "gx",
        "replaced per channel-sample",
        2e-4,
    ),
    (
        "ximu3",
        &["bias+2", "bias-5", "gyro×0.25", "gyro×4"],
        "az",
        "replaced per channel-sample",
        3e-4,
    ),
    // Lower rate, moving: 1–3-sample real transients whose shape the confirmation cannot tell
    // from a glitch (docs/real-data.md, "Sensor classes we do not have", item 3, with every
    // event: `cargo run --release --example lowrate_events -- RECORDING K`). Measured drive
    // rate/4 gy 5.10e-4, ax 1.46e-4, az 2.92e-4 (aliased engine vibration: bursts the 4-sample
    // average leaves in one 25-Hz sample, some as period-2 patterns); walk rate/2 ax 1.96e-4,
    // ay 2.93e-4, az 2.93e-4 (a step's rise in 3 judged samples); x-IMU3 rate/2 ay 1.48e-4;
    // drive rate/2 gz 1.46e-4: two 2-sample road bumps (4 samples at 100 Hz), at 36.97 s and
    // 332.35 s, the first one replaced since the warm-up ends at warmup_max_s = 30 s instead of
    // 40 s, 7 s before it, so the gate's model, not the warm-up's guard, judges it. The counts in
    // samples (context, scale window, max_run) are not the cause: in seconds they replace as
    // much or more. The opt-in level test halves them (`the_opt_in_level_test_...` below).
    (
        "rtklibexplorer_drive_walk/drive",
        &["rate/2"],
        "gz",
        "replaced per channel-sample",
        1.5e-4,
    ),
    (
        "rtklibexplorer_drive_walk/drive",
        &["rate/4"],
        "gy",
        "replaced per channel-sample",
        5.2e-4,
    ),
    (
        "rtklibexplorer_drive_walk/drive",
        &["rate/4"],
        "ax",
        "replaced per channel-sample",
        1.5e-4,
    ),
    (
        "rtklibexplorer_drive_walk/drive",
        &["rate/4"],
        "az",
        "replaced per channel-sample",
        3.0e-4,
    ),
    (
        "rtklibexplorer_drive_walk/walk",
        &["rate/2"],
        "ax",
        "replaced per channel-sample",
        2.0e-4,
    ),
    (
        "rtklibexplorer_drive_walk/walk",
        &["rate/2"],
        "ay",
        "replaced per channel-sample",
        3.0e-4,
    ),
    (
        "rtklibexplorer_drive_walk/walk",
        &["rate/2"],
        "az",
        "replaced per channel-sample",
        3.0e-4,
    ),
    (
        "ximu3",
        &["rate/2"],
        "ay",
        "replaced per channel-sample",
        1.5e-4,
    ),
    // Coarse LSB on the walk: with the confirmation's scale floored at the learned LSB/√12
    // (was: only min_sigma_accel_m_s2 = 1e-3 m/s²; ax 5.77e-3, ay 1.22e-3, az 2.59e-3 then),
    // 2-LSB jumps of its accelerometers (noise ≈ 0.5 new LSB) at rest were still replaced: ax
    // 3.422e-4, ay 4.889e-4, az 3.422e-4. With the LSB read from the warm-up's 10th sample on
    // (was the 100th) and the gate's and guard's scales floored at it too, ax and az are met and
    // ay measures 2.933e-4 (3 of 10227).
    (
        "rtklibexplorer_drive_walk/walk",
        &["lsb×4"],
        "ay",
        "replaced per channel-sample",
        3.0e-4,
    ),
];

/// Equivariance: an equivariant copy may differ from the original's STILL flags on at most this
/// share of samples. 1 %: the static targets leave 5 % slack (engaged ≥ 95 %), so a change of
/// 1 % cannot by itself move a bench that meets the target by a margin across it. (The
/// ADIS16405 gyro×0.25 uses 0.28 %: the stillness detector's gravity-path test compares the
/// gyro's integral with g, which a unit change does not leave alone; docs/real-data.md.)
const STILL_DIFF_SHARE: f64 = 0.01;

/// Equivariant copies beyond that, or with replacements differing from the original's, bounded
/// at the measured count: (recording prefix, transformation, differing replaced channel-samples,
/// differing STILL samples).
const KNOWN_DIFFS: &[(&str, &str, usize, usize)] = &[
    // ADIS16405 offsets: one 2-sample event created, one hidden (bias+2), one sample hidden
    // (bias-5) in 1e6 samples. Float rounding on a quantised signal breaks exact ties: an offset
    // of 1e-7 °/s already hides the gz event at 5160.0 s.
    ("adis16405", "bias+2", 4, 227),
    ("adis16405", "bias-5", 1, 311),
    // PX4 offsets: single-sample STILL flips scattered after the bias estimate starts (9.5 s):
    // the gyro-mean test compares each window with the bias estimate, whose warm-up is not
    // exactly offset-equivariant; 966 / 942 of 17070 samples (5.7 %, 5.5 %), the ULog as its CSV.
    ("px4_sensor_combined", "bias+2", 0, 966),
    ("px4_sensor_combined", "bias-5", 0, 942),
    ("px4_ulog/sample.ulg", "bias+2", 0, 966),
    ("px4_ulog/sample.ulg", "bias-5", 0, 942),
    // The drive ×4: its engine-idle gyro at rest (quietest 0.5-s windows 0.010–0.032 rad/s
    // three-axis sd) crosses the absolute ceiling gyro_sd_max_rad_s = 0.1 once scaled: STILL
    // on 1.9 % of samples instead of 7.0 %, the bias never engaged (2813 of 54860 differ).
    ("rtklibexplorer_drive_walk/drive", "gyro×4", 0, 2813),
];

#[test]
fn transformed_real_recordings_meet_the_do_no_harm_targets() {
    let start = std::time::Instant::now();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real");
    if !dir.is_dir() {
        common::skipped(&format!(
            "{} is absent (real recordings live beside the repo)",
            dir.display()
        ));
        return;
    }
    let cfg = Config::default_embedded().unwrap();
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for (k, p) in find_recordings(&dir).unwrap().iter().enumerate() {
        let name = p
            .strip_prefix(&dir)
            .unwrap_or(p)
            .to_string_lossy()
            .into_owned();
        // The audit's rule: files that are no IMU recording, or too short, are not scored.
        let Ok((desc, raw)) = load_recording(p) else {
            continue;
        };
        if raw.len() < MIN_SAMPLES {
            continue;
        }
        let rate = if desc.sample_rate_hz > 0.0 {
            desc.sample_rate_hz
        } else {
            100.0
        };
        // The class is the recording's (a bench stays a bench however it is transformed).
        let class = classify(&raw, rate);
        let base = run_config(&cfg, &desc, &raw).unwrap();
        rows.push(Row {
            recording: name.clone(),
            transform: Transform::Original,
            class,
            score: score_harm(&name, class, rate, &raw, &base),
            replaced_diff: None,
            still_diff: None,
            samples: raw.len(),
        });
        for (j, &t) in TRANSFORMS.iter().enumerate() {
            let Some((d, x)) = transform(&name, &desc, &raw, t, (k * 100 + j) as u64) else {
                continue;
            };
            if let (Transform::Noise(m), Class::Static) = (t, class) {
                // The transformation did what it says: on a bench, whose differences are
                // near-Gaussian noise, the channel's measured noise grows by √(1 + m²) (3.16 for
                // m = 3); ±10 % for the robust estimate on quantised data. (Not on the moving
                // recordings: the robust spread of a mixture of motion and noise does not add in
                // quadrature, and the walk's 34 % stale repeats make a third of its differences
                // zero.)
                for c in 0..N_CHANNELS {
                    let ratio = noise_sigma(&x, c) / noise_sigma(&raw, c);
                    let want = (1.0 + m * m).sqrt();
                    if (ratio / want - 1.0).abs() > 0.1 {
                        failures.push(format!(
                            "{name} noise×{m}: channel {c} noise grew ×{ratio:.2}, not ×{want:.2}"
                        ));
                    }
                }
            }
            let out = run_config(&cfg, &d, &x).unwrap();
            let (replaced_diff, still_diff) = if t.equivariant() {
                let (a, b) = diffs(&base, &out);
                (Some(a), Some(b))
            } else {
                (None, None)
            };
            rows.push(Row {
                recording: name.clone(),
                transform: t,
                class,
                score: score_harm(&name, class, d.sample_rate_hz, &x, &out),
                replaced_diff,
                still_diff,
                samples: x.len(),
            });
        }
    }
    eprintln!(
        "| recording | transform | class | worst replaced per ch-sample | worst invented angle ° | bias engaged after s | engaged % | still % | onset move / 3σ | replaced diff | still diff | targets missed |"
    );
    eprintln!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        eprintln!("{}", fmt_row(r));
    }
    // 7 CSV recordings and 2 ULog files are long enough; every one gets the offsets, the noise
    // and the units, so at least 9 × 6 rows.
    assert!(rows.len() >= 54, "{} rows", rows.len());

    for r in rows.iter().filter(|r| r.transform != Transform::Original) {
        let label = r.transform.label();
        for t in &r.score.targets {
            let known = KNOWN_MISSES.iter().find(|(rec, tr, ch, what, _)| {
                r.recording.starts_with(rec)
                    && tr.contains(&label.as_str())
                    && t.channel == *ch
                    && t.target.starts_with(what)
            });
            failures.extend(common::judge_target(
                t,
                &format!("{} {label}", r.recording),
                known.map(|&(.., bound)| bound),
            ));
        }
        if let (Some(rep), Some(still)) = (r.replaced_diff, r.still_diff) {
            let known = KNOWN_DIFFS
                .iter()
                .find(|(rec, tr, ..)| r.recording.starts_with(rec) && *tr == label);
            let (rep_max, still_max) = match known {
                Some(&(_, _, a, b)) => (a, b),
                None => (0, (STILL_DIFF_SHARE * r.samples as f64) as usize),
            };
            if rep > rep_max || still > still_max {
                failures.push(format!(
                    "{} {label}: {rep} replaced channel-samples and {still} STILL samples differ \
                     from the original (bounds {rep_max}, {still_max})",
                    r.recording
                ));
            }
            if let Some(&(_, _, a, b)) = known
                && rep == 0
                && still <= (STILL_DIFF_SHARE * r.samples as f64) as usize
                && (a > 0 || b > (STILL_DIFF_SHARE * r.samples as f64) as usize)
            {
                failures.push(format!(
                    "known difference gone (update KNOWN_DIFFS and the docs): {} {label}",
                    r.recording
                ));
            }
        }
    }
    eprintln!(
        "{} transformed copies scored in {:.1} s",
        rows.len(),
        start.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The embedded default with `keys` (TOML) laid over it.
fn default_with(keys: &str) -> Config {
    let text = format!("[source]\nkind = \"replay\"\npath = \"replay/drive.log\"\n{keys}");
    Config::from_toml_str(&text, Path::new(env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn first_engaged_s(out: &[Sample]) -> Option<f64> {
    out.iter()
        .position(|s| s.bias_subtracted() && !s.has(flags::WARMING_UP))
        .map(|i| out[i].t_s() - out[0].t_s())
}

/// The causes docs/real-data.md gives for the misses above, each shown by the one setting it
/// names: changed the way the cause says, the miss goes away (so the cause is that setting and
/// nothing else); and the offset ties are ties (a 1e-7 °/s offset, nothing physical, flips one).
#[test]
fn the_misses_have_the_causes_the_docs_give() {
    let Some(dir) = common::real_data("") else {
        return;
    };
    let load = |rel: &str| load_recording(&dir.join(rel)).unwrap();

    // The drive ×4: the gyro ceiling at rest, scaled with the units (0.1 → 0.4 rad/s), gives the
    // original's stillness back: STILL differs on ≤ 1 % of samples (2813 with the default
    // ceiling) and the bias engages within 1 s of the original's 20.5 s.
    let (desc, raw) = load("rtklibexplorer_drive_walk/drive_0708_imu.csv");
    let base = run_config(&Config::default_embedded().unwrap(), &desc, &raw).unwrap();
    let (d4, x4) = transform("drive", &desc, &raw, Transform::GyroScale(4.0), 0).unwrap();
    let cfg = default_with("[bias.settings.stillness]\ngyro_sd_max_rad_s = 0.4\n");
    let out = run_config(&cfg, &d4, &x4).unwrap();
    let (rep, still) = diffs(&base, &out);
    let (e0, e4) = (first_engaged_s(&base).unwrap(), first_engaged_s(&out));
    eprintln!(
        "drive ×4, ceiling ×4: {rep} replaced and {still} STILL differ; engaged {e0:.1} s vs {e4:?}"
    );
    assert_eq!(rep, 0);
    assert!(
        still as f64 <= STILL_DIFF_SHARE * raw.len() as f64,
        "{still}"
    );
    assert!(e4.is_some_and(|t| (t - e0).abs() <= 1.0), "{e4:?}");

    // The drive with 3× its own σ: both ceilings at rest keep it from ever being still; lifted
    // (10×), the bias engages within 60 s.
    let (dn, xn) = transform("drive", &desc, &raw, Transform::Noise(3.0), 7).unwrap();
    let cfg = default_with(
        "[bias.settings.stillness]\ngyro_sd_max_rad_s = 1.0\naccel_sd_max_m_s2 = 3.0\n",
    );
    let e = first_engaged_s(&run_config(&cfg, &dn, &xn).unwrap());
    eprintln!("drive noise×3, ceilings ×10: engaged {e:?}");
    assert!(e.is_some_and(|t| t <= 60.0), "{e:?}");

    let name = "adis16405_static/adis_16405_imu1.csv.gz";
    let (desc, raw) = load(name);

    // The ADIS16405 offsets: an offset of 1e-7 °/s (1.7e-9 rad/s, nothing a sensor could
    // show) already changes a replacement: the differences are ties broken by rounding.
    let base = run_config(&Config::default_embedded().unwrap(), &desc, &raw).unwrap();
    let (db, xb) = transform(name, &desc, &raw, Transform::GyroBias(1e-7), 0).unwrap();
    let out = run_config(&Config::default_embedded().unwrap(), &db, &xb).unwrap();
    let (rep, _) = diffs(&base, &out);
    eprintln!("ADIS16405 +1e-7 °/s: {rep} replaced channel-samples differ");
    assert!((1..=4).contains(&rep), "{rep}");

    // The benches at a quarter rate engage within 60 s with the default config (the table:
    // ADIS16405 30.8 s, MPU6050 31.2 s) because the warm-ups are bounded in time: without the
    // bounds (3600 s) they are counted in samples again and the bias engages late, as it did
    // before (ADIS16405 80.7 s, MPU6050 81.2 s: 2000 gross-error warm-up samples; 106.3 s and
    // 80.4 s before the stillness window had its 25-sample minimum).
    let cfg = default_with(
        "[gross_error.settings]\nwarmup_max_s = 3600.0\n[bias.settings.warmup]\nstill_max_s = 3600.0\n",
    );
    for name in [
        "adis16405_static/adis_16405_imu1.csv.gz",
        "mpu6050_static_10min_temp/mpu6050_static.csv",
    ] {
        let (desc, raw) = load(name);
        let (d, x) = transform(name, &desc, &raw, Transform::Decimate(4), 0).unwrap();
        let e = first_engaged_s(&run_config(&cfg, &d, &x).unwrap());
        eprintln!("{name} rate/4, warm-ups in samples only: engaged {e:?}");
        assert!(e.is_some_and(|t| t > 60.0), "{name}: {e:?}");
    }
    // Each bound alone. The gross-error bound is the one both benches need (the bias bound
    // alone: ADIS16405 80.7 s); the bias bound alone is not needed at 25 Hz any more (with the
    // gross-error bound alone: ADIS16405 30.8 s, MPU6050 31.2 s): STILL holds 99.8 % of the
    // ADIS16405 copy, so its 300 contiguous still samples (12 s) come early. Before the
    // stillness window's 25-sample minimum STILL held 73.5 % and the ADIS16405 needed both
    // bounds (the gross-error bound alone: 106.3 s).
    let name = "adis16405_static/adis_16405_imu1.csv.gz";
    let (desc, raw) = load(name);
    let (d, x) = transform(name, &desc, &raw, Transform::Decimate(4), 0).unwrap();
    let cfg = default_with("[gross_error.settings]\nwarmup_max_s = 3600.0\n");
    let e = first_engaged_s(&run_config(&cfg, &d, &x).unwrap());
    eprintln!("{name} rate/4, the bias bound alone: engaged {e:?}");
    assert!(e.is_some_and(|t| t > 60.0), "{name}: {e:?}");
    for name in [
        "adis16405_static/adis_16405_imu1.csv.gz",
        "mpu6050_static_10min_temp/mpu6050_static.csv",
    ] {
        let (desc, raw) = load(name);
        let (d, x) = transform(name, &desc, &raw, Transform::Decimate(4), 0).unwrap();
        let cfg = default_with("[bias.settings.warmup]\nstill_max_s = 3600.0\n");
        let e = first_engaged_s(&run_config(&cfg, &d, &x).unwrap());
        eprintln!("{name} rate/4, the gross-error bound alone: engaged {e:?}");
        assert!(e.is_some_and(|t| t <= 60.0), "{name}: {e:?}");
    }
}

/// The opt-in level test (`[gross_error.settings] level_window_s`, off by default) on the
/// lower-rate copies that miss the replacement target: replaced channel-samples per channel with
/// the default and with `level_window_s = 1`, printed with `-- --nocapture`. Measured: it never
/// replaces more on any channel, and replaces 14 instead of 29 channel-samples over the four
/// copies (drive rate/4 13 → 8, drive rate/2 7 → 2, walk rate/2 8 → 3, x-IMU3 rate/2 1 → 1;
/// the walk's were 9 → 4 before the several-axes test was also run where an event's judged
/// part starts: its gy event at 129.24 s breaks on its second sample, docs/real-data.md, "A
/// foot-mounted walker").
/// Why it stays off: docs/real-data.md, "Sensor classes we do not have".
#[test]
fn the_opt_in_level_test_on_the_lower_rate_copies() {
    let Some(dir) = common::real_data("") else {
        return;
    };
    let on = default_with("[gross_error.settings]\nlevel_window_s = 1.0\n");
    let off = Config::default_embedded().unwrap();
    let count = |out: &[Sample]| -> [usize; N_CHANNELS] {
        let mut n = [0; N_CHANNELS];
        for s in out {
            for (c, nc) in n.iter_mut().enumerate() {
                if s.flags & flags::replaced_ch(c) != 0 {
                    *nc += 1;
                }
            }
        }
        n
    };
    let (mut total_off, mut total_on) = (0, 0);
    for (name, k, want_off, want_on) in [
        ("rtklibexplorer_drive_walk/drive_0708_imu.csv", 4, 13, 8),
        ("rtklibexplorer_drive_walk/drive_0708_imu.csv", 2, 7, 2),
        ("rtklibexplorer_drive_walk/walk_0827_imu.csv", 2, 8, 3),
        ("ximu3_fusion_example/sensor_data.csv", 2, 1, 1),
    ] {
        let (desc, raw) = load_recording(&dir.join(name)).unwrap();
        let (d, x) = transform(name, &desc, &raw, Transform::Decimate(k), 0).unwrap();
        let a = count(&run_config(&off, &d, &x).unwrap());
        let b = count(&run_config(&on, &d, &x).unwrap());
        let (sa, sb) = (a.iter().sum::<usize>(), b.iter().sum::<usize>());
        eprintln!("{name} rate/{k}: replaced per channel {a:?} (default) → {b:?} (level test on)");
        assert!(
            a.iter().zip(&b).all(|(x, y)| y <= x),
            "{name} rate/{k}: {a:?} {b:?}"
        );
        assert_eq!(
            (sa, sb),
            (want_off, want_on),
            "{name} rate/{k}: {a:?} {b:?}"
        );
        total_off += sa;
        total_on += sb;
    }
    assert_eq!((total_off, total_on), (29, 14));
}

/// The walk rounded to 4× its LSB (docs/real-data.md, "Sensor classes we do not have", item 2):
/// its accelerometers at rest sit on one code for whole windows, so the minimum-statistics floor
/// alone would fall to round-off; the detector's floor is no lower than the learned LSB's
/// quantisation noise, and the windows at the original's rests lie within `noise_factor` of it.
/// The detector is replayed on the copy's samples (stale repeats skipped, as the bias stage
/// does); the numbers print with `-- --nocapture`.
#[test]
fn a_coarse_lsb_keeps_the_walks_rests_within_the_noise_floor() {
    use imuprep::stage::bias::stillness::{StillnessDetector, StillnessSettings};
    let Some(dir) = common::real_data("") else {
        return;
    };
    let name = "rtklibexplorer_drive_walk/walk_0827_imu.csv";
    let (desc, raw) = load_recording(&dir.join(name)).unwrap();
    let (d, x) = transform(name, &desc, &raw, Transform::Quantise(4.0), 0).unwrap();
    let base = run_config(&Config::default_embedded().unwrap(), &desc, &raw).unwrap();
    let out = run_config(&Config::default_embedded().unwrap(), &d, &x).unwrap();
    let s = StillnessSettings::default();
    let mut det = StillnessDetector::new(&s, d.sample_rate_hz);
    let (mut sd, mut min_floor) = (Vec::new(), f64::INFINITY);
    for ((v, o), b) in x.iter().zip(&out).zip(&base) {
        if o.has(flags::REPEATED) {
            continue;
        }
        let g = [v.channel(0), v.channel(1), v.channel(2)];
        let a = [v.channel(3), v.channel(4), v.channel(5)];
        det.update(&g, &a, &[None; 3]);
        let f = det.features();
        // Once every accel axis has shown its grid (before, its LSB is not known).
        if det.lsb()[3..].iter().all(|l| *l > 0.0) {
            min_floor = min_floor.min(f.accel_floor_m_s2);
        }
        if b.has(flags::STILL) {
            sd.push(f.accel_sd_m_s2);
        }
    }
    sd.sort_by(f64::total_cmp);
    let pct = |p: usize| sd[(sd.len() - 1) * p / 100];
    let lsb = det.lsb();
    let la = 4.0 * 0.001 * G;
    let quant = (3.0 * la * la / 12.0).sqrt();
    let (_, floor) = det.floors();
    eprintln!(
        "walk lsb×4: accel LSB learned {:.4e} {:.4e} {:.4e} m/s² (4 mg: {la:.4e}); accel floor \
         {floor:.4e} (lowest once the LSB is known {min_floor:.4e}, quantisation floor {quant:.4e}); accel window sd at \
         the original's {} STILL samples: p5 {:.4e} p50 {:.4e} p95 {:.4e} max {:.4e} m/s²",
        lsb[3],
        lsb[4],
        lsb[5],
        sd.len(),
        pct(5),
        pct(50),
        pct(95),
        pct(100)
    );
    for l in &lsb[3..] {
        assert!((l / la - 1.0).abs() < 1e-9, "{lsb:?}");
    }
    // Not below the quantisation noise (1e-12 relative: the floor is that value, recomputed).
    assert!(min_floor >= quant * (1.0 - 1e-12), "{min_floor} < {quant}");
    // The original's rests: at least 95 % of their windows within noise_factor of the floor.
    assert!(pct(95) <= s.noise_factor * floor, "{} > {}", pct(95), floor);
}
