//! `imuprep audit`: the embedded default pipeline over every real recording under a folder, scored
//! against issue 12's "do no harm" targets, plus seeded injections that check gross errors are
//! still caught.
//!
//! Per recording (read with the same importer as `imuprep import`, nothing tuned):
//!
//! - **Class.** *Static* when the 1-s windows' three-axis gyro sd is stationary (99th percentile
//!   < 2 × the 1st: ADIS16405 1.2, MPU6050 1.1, every moving recording ≥ 5.7); else *moving*.
//!   The rule uses the data only, never the file name.
//! - **Replacements.** Channel-samples the pipeline replaced, per channel and per channel-sample.
//!   Target ≤ 1e-4 on every channel (static) and over each moving recording.
//! - **Invented angle.** `|Σ (out − raw + bias) dt|` per gyro axis: what replacements (not the
//!   bias) changed in the integrated angle. Target ≤ 0.5°.
//! - **Bias.** Share of samples with the bias removed by a running estimate (`BIAS_REMOVED` with a
//!   non-zero published bias, not `WARMING_UP`), the time to the first; on static recordings ≥ 95 % and ≤ 60 s. Around every
//!   motion onset (STILL → not STILL, and a 1-s window of the raw gyro 3× rougher than the
//!   recording's quietest within the next second) with an estimate running 2 s before it, the
//!   estimate may not move by more than its own published 3σ from then to 2 s after the onset
//!   (so motion that leaked in before the detector noticed it counts too).
//! - **Allan (static).** Overlapping ADEV of output and raw per channel at octave τ, from the
//!   first sample with a running bias estimate on (the step from 0 to the removed turn-on bias
//!   is the stage's job, not noise it adds); the output
//!   may exceed the raw by at most the estimate's 1σ, `1/√(2(K−1))` with `K = ⌊T/τ⌋`
//!   non-overlapping clusters (conservative: the overlapping estimate is tighter). At the longest
//!   τ with K ≥ 9 the gyro output must be ≥ 50 % lower than raw on records of an hour or more
//!   (where the model can see drift); shorter records report it without a target.
//! - **Injections** (seeded; each on a copy of the recording, scored after the gross-error stage's
//!   warm-up; made once per seed, by default the five seeds 12–16, and scored on the counts
//!   pooled over them: one seed's draw of 50–600 events moves a short recording's F1 by several
//!   hundredths):
//!   - moving: spikes and runs (2..=10 samples, one third of events) of 6–30 local σ, one
//!     channel at a time, ≥ 40 samples apart (gross errors are rare; each is judged on its own),
//!     local σ = robust spread of the raw channel within ±100 samples (the `flag_review` scale);
//!     F1 of the replaced flags against the labels ≥ 0.95;
//!   - static: 2 % isolated outliers of 8–30 robust σ on each gyro channel; recall and
//!     precision ≥ 0.9;
//!   - all: NaN, ±Inf, ±1e30 on random channels, a quarter of them inside the first 2000
//!     samples (the warm-up); none may reach the output unflagged or non-finite.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::analysis::allan::overlapping_adev;
use crate::config::Config;
use crate::frame::Descriptor;
use crate::io::csv::{ImportOptions, Sniffed, read_csv, read_log, sniff_file};
use crate::sample::{CHANNEL_NAMES, Sample, flags};

mod inject;
pub use inject::{
    Counts, inject_bad_values, inject_outliers, inject_spikes, score as score_injections,
};
use inject::{flagged_bad, score};

/// Samples skipped before scoring injections (the gross-error stage's default warm-up).
const SCORE_FROM: usize = 2000;

/// Static or moving, decided from the data (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    Static,
    Moving,
}

/// One target, measured.
#[derive(Debug, Clone, Serialize)]
pub struct TargetRow {
    pub recording: String,
    /// Channel name, or "all".
    pub channel: String,
    pub target: String,
    pub measured: f64,
    /// The limit, and whether the measured value must stay at most (true) or at least it.
    pub limit: f64,
    pub at_most: bool,
    pub met: bool,
}

impl TargetRow {
    /// A target row, `met` when `measured` is on the right side of `limit`.
    pub fn new(
        recording: &str,
        channel: &str,
        target: &str,
        measured: f64,
        limit: f64,
        at_most: bool,
    ) -> TargetRow {
        let met = if at_most {
            measured <= limit
        } else {
            measured >= limit
        };
        TargetRow {
            recording: recording.to_string(),
            channel: channel.to_string(),
            target: target.to_string(),
            measured,
            limit,
            at_most,
            met,
        }
    }
}

/// Per-channel figures of the default run.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelFigures {
    pub replaced: u64,
    pub replaced_rate: f64,
    pub suspect: u64,
    /// Gyro only: invented angle, degrees.
    pub invented_angle_deg: Option<f64>,
    /// Static only: worst (out/raw ADEV) / (1 + 1σ) over τ (≤ 1 meets the target), and the
    /// output's ADEV change at the longest τ with ≥ 9 clusters, %.
    pub adev_worst_ratio: Option<f64>,
    pub adev_longest_change_pct: Option<f64>,
}

/// One recording's audit.
#[derive(Debug, Clone, Serialize)]
pub struct RecordingAudit {
    pub name: String,
    pub path: PathBuf,
    pub class: Class,
    pub samples: usize,
    pub rate_hz: f64,
    pub duration_s: f64,
    /// The do-no-harm figures of the default run; its `targets` also hold the injections' rows
    /// (flattened: the JSON keeps one object per recording).
    #[serde(flatten)]
    pub harm: HarmScore,
    /// The injections' seeds; every injection is made once per seed and the runs' counts are
    /// pooled (one seed's 50–600 events leave the F1 of a short recording uncertain by ±0.03).
    pub seeds: Vec<u64>,
    /// Moving: the injected spikes and runs, pooled over the seeds, and each seed's F1.
    pub injected: Option<Counts>,
    pub injected_f1: Option<f64>,
    pub injected_f1_per_seed: Vec<f64>,
    /// Static: the 2 % gyro outliers, pooled over the seeds, and each seed's recall.
    pub contamination: Option<Counts>,
    pub contamination_recall: Option<f64>,
    pub contamination_precision: Option<f64>,
    pub contamination_recall_per_seed: Vec<f64>,
    /// Bad values injected over all seeds (distinct positions per seed), and how many of them
    /// reached the output unflagged or non-finite.
    pub bad_values_injected: usize,
    pub bad_values_unflagged: usize,
}

/// A recording that could not be audited, and why.
#[derive(Debug, Clone, Serialize)]
pub struct Skipped {
    pub path: PathBuf,
    pub reason: String,
}

/// The whole audit.
#[derive(Debug, Clone, Serialize)]
pub struct AuditReport {
    pub dir: PathBuf,
    /// The config file whose pipeline was audited (`--config`, over the embedded default);
    /// `None`: the embedded default alone. The caller sets it: [`audit_dir`] takes the parsed
    /// config only.
    pub config: Option<PathBuf>,
    pub recordings: Vec<RecordingAudit>,
    pub skipped: Vec<Skipped>,
}

impl AuditReport {
    /// Every target row of every recording.
    pub fn targets(&self) -> impl Iterator<Item = &TargetRow> {
        self.recordings.iter().flat_map(|r| r.harm.targets.iter())
    }

    /// Targets missed.
    pub fn missed(&self) -> Vec<&TargetRow> {
        self.targets().filter(|t| !t.met).collect()
    }
}

/// Recordings under `dir`, sorted by path: `.log` (native), `.csv`, `.csv.gz`, `.ulg` (PX4), and
/// `.txt`, `.tsv`, `.dat` (or their `.gz`) whose content is a text table of numbers (a
/// `NOTES.txt` is none, and is no recording).
pub fn find_recordings(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d)? {
            let p = e?.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let n = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                let known = [".log", ".ulg"].iter().any(|e| n.ends_with(e))
                    || super::convert::is_csv_name(&p);
                let lower = n.to_ascii_lowercase();
                let stem = lower.strip_suffix(".gz").unwrap_or(&lower);
                let text = [".txt", ".tsv", ".dat"].iter().any(|e| stem.ends_with(e))
                    && matches!(sniff_file(&p), Sniffed::Table(_));
                if known || text {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Read a recording as `imuprep import` (a text table or a ULog) or `imuprep replay` (native
/// log) would.
pub fn load_recording(path: &Path) -> Result<(Descriptor, Vec<Sample>), String> {
    let name = path.to_string_lossy();
    if name.ends_with(".log") {
        let (d, s, _) = read_log(path).map_err(|e| e.to_string())?;
        Ok((d.unwrap_or_default(), s))
    } else if name.ends_with(".ulg") {
        let pc = crate::frame::detect::ProtocolConfig::auto();
        // As `imuprep import` reads it: time faults and rate over the whole file.
        let (f, _) = crate::io::convert::read_any_whole(path, &pc).map_err(|e| e.to_string())?;
        if f.samples.is_empty() {
            return Err("no IMU samples decoded".into());
        }
        Ok((f.descriptor.unwrap_or_default(), f.samples))
    } else {
        read_csv(path, &ImportOptions::default()).map_err(|e| e.to_string())
    }
}

/// `cfg`'s pipeline over `samples` (the stages' rate from the descriptor).
pub fn run_config(
    cfg: &Config,
    desc: &Descriptor,
    samples: &[Sample],
) -> Result<Vec<Sample>, String> {
    let mut cfg = cfg.clone();
    cfg.stages
        .set_sample_rate(desc.sample_rate_hz)
        .map_err(|e| e.to_string())?;
    let mut p = cfg.stages.build()?;
    Ok(crate::stage::run_through(&mut p, samples))
}

/// Three-axis gyro sd of consecutive 1-s windows.
fn window_gyro_sd(samples: &[Sample], rate_hz: f64) -> Vec<f64> {
    let w = (rate_hz.round() as usize).max(10);
    samples
        .chunks_exact(w)
        .map(|c| {
            let n = c.len() as f64;
            (0..3)
                .map(|a| {
                    let m = c.iter().map(|s| s.gyro[a]).sum::<f64>() / n;
                    c.iter().map(|s| (s.gyro[a] - m).powi(2)).sum::<f64>() / n
                })
                .sum::<f64>()
                .sqrt()
        })
        .filter(|v| v.is_finite())
        .collect()
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// How unevenly a record's gyro roughness is spread: the 99th over the 1st percentile of the
/// three-axis gyro sd of its 1-s windows, the statistic [`classify`] calls static below 2.
/// `None` when it cannot tell: no gyro, or fewer than 10 whole windows.
pub fn gyro_roughness_ratio(samples: &[Sample], rate_hz: f64) -> Option<f64> {
    let mut sd = window_gyro_sd(samples, rate_hz);
    if sd.len() < 10 {
        return None;
    }
    let lo = percentile(&mut sd, 0.01);
    let hi = percentile(&mut sd, 0.99);
    Some(if hi == 0.0 { 1.0 } else { hi / lo })
}

/// Static or moving (module docs).
pub fn classify(samples: &[Sample], rate_hz: f64) -> Class {
    let mut sd = window_gyro_sd(samples, rate_hz);
    let lo = percentile(&mut sd, 0.01);
    let hi = percentile(&mut sd, 0.99);
    if hi < 2.0 * lo {
        Class::Static
    } else {
        Class::Moving
    }
}

/// The do-no-harm figures of one run of a pipeline: per channel, and for the bias stage.
#[derive(Debug, Clone, Serialize)]
pub struct HarmScore {
    pub channels: Vec<ChannelFigures>,
    pub bias_engaged_share: f64,
    pub bias_first_engaged_s: Option<f64>,
    pub still_share: f64,
    pub onsets: usize,
    pub onset_worst_move_3sigma: f64,
    /// Replacements and invented angle per channel, the bias across motion onsets, and on a
    /// static recording bias engagement and Allan deviation (module docs), in that order.
    pub targets: Vec<TargetRow>,
}

/// Score `out`, the pipeline's output for `raw` (same samples, same order), against the
/// do-no-harm targets of a `class` recording sampled at `rate` Hz; what `audit_recording`
/// measures before its injections.
pub fn score_harm(
    name: &str,
    class: Class,
    rate: f64,
    raw: &[Sample],
    out: &[Sample],
) -> HarmScore {
    let n = raw.len().min(out.len());
    let duration_s = if n > 0 {
        raw[n - 1].t_s() - raw[0].t_s()
    } else {
        0.0
    };
    let mut targets = Vec::new();
    let mut target = |channel: &str, what: &str, measured: f64, limit: f64, at_most: bool| {
        targets.push(TargetRow::new(
            name, channel, what, measured, limit, at_most,
        ));
    };

    // Replacements, suspects, invented angle.
    let max_dt = 5.0 / rate;
    let mut channels = Vec::new();
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let bit = flags::replaced_ch(c);
        let replaced = out.iter().filter(|s| s.flags & bit != 0).count() as u64;
        let suspect = out
            .iter()
            .filter(|s| s.flags & flags::suspect_ch(c) != 0)
            .count() as u64;
        let invented = (c < 3).then(|| {
            let mut acc = 0.0;
            for i in 1..n {
                let dt = ((out[i].t_ns as f64 - out[i - 1].t_ns as f64) * 1e-9).clamp(0.0, max_dt);
                let d = out[i].channel(c) - raw[i].channel(c) + f64::from(out[i].bias[c]);
                if d.is_finite() {
                    acc += d * dt;
                }
            }
            acc.abs().to_degrees()
        });
        let rate_c = replaced as f64 / n as f64;
        target(name, "replaced per channel-sample", rate_c, 1e-4, true);
        if let Some(a) = invented {
            target(name, "invented angle, deg", a, 0.5, true);
        }
        channels.push(ChannelFigures {
            replaced,
            replaced_rate: rate_c,
            suspect,
            invented_angle_deg: invented,
            adev_worst_ratio: None,
            adev_longest_change_pct: None,
        });
    }

    // Bias engagement and motion onsets.
    let engaged = |s: &Sample| s.bias_subtracted() && !s.has(flags::WARMING_UP);
    let n_engaged = out.iter().filter(|s| engaged(s)).count();
    let bias_first_engaged_s = out
        .iter()
        .position(engaged)
        .map(|i| out[i].t_s() - out[0].t_s());
    let still_share = out.iter().filter(|s| s.has(flags::STILL)).count() as f64 / n as f64;
    let w2 = (2.0 * rate).round() as usize;
    let mut onsets = 0;
    let mut worst_onset: f64 = 0.0;
    // A motion onset, independently of the detector: within 1 s after it a 1-s window of the raw
    // gyro is at least 3× as rough (three-axis sd) as the recording's quietest windows.
    let sd_1s = window_gyro_sd(raw, rate);
    let quiet = percentile(&mut sd_1s.clone(), 0.01);
    let w1 = (rate.round() as usize).max(10);
    let moving_after =
        |i: usize| (i / w1..=(i + w1) / w1).any(|k| sd_1s.get(k).is_some_and(|v| *v > 3.0 * quiet));
    for i in 1..n {
        if out[i - 1].has(flags::STILL)
            && !out[i].has(flags::STILL)
            && i > w2
            && i + w2 < n
            && moving_after(i)
        {
            // Only an estimate that existed before the onset can be moved by it.
            if !(engaged(&out[i - w2]) && out[i - w2].bias_sd[..3].iter().all(|v| *v > 0.0)) {
                continue;
            }
            onsets += 1;
            for c in 0..3 {
                let b0 = f64::from(out[i - w2].bias[c]);
                for s in &out[i - w2..=i + w2] {
                    let sd = f64::from(s.bias_sd[c]);
                    let mv = (f64::from(s.bias[c]) - b0).abs();
                    if sd > 0.0 && engaged(s) {
                        worst_onset = worst_onset.max(mv / (3.0 * sd));
                    }
                }
            }
        }
    }
    if onsets > 0 {
        target(
            "gyro",
            "bias move across a motion onset / own 3σ",
            worst_onset,
            1.0,
            true,
        );
    }
    let bias_engaged_share = n_engaged as f64 / n as f64;
    if class == Class::Static {
        target(
            "gyro",
            "bias engaged, share",
            bias_engaged_share,
            0.95,
            false,
        );
        target(
            "gyro",
            "bias engaged after, s",
            bias_first_engaged_s.unwrap_or(f64::INFINITY),
            60.0,
            true,
        );
        // Allan deviation, output against raw, from the first sample with a running estimate
        // on: removing a turn-on bias is a step from 0 to the bias, the stage doing its job, not
        // noise it adds.
        let from = out.iter().position(engaged).unwrap_or(n);
        let span_s = if from < n {
            out[n - 1].t_s() - out[from].t_s()
        } else {
            0.0
        };
        for (c, fig) in channels.iter_mut().enumerate() {
            if n - from < 1000 {
                break;
            }
            let x: Vec<f64> = raw[from..].iter().map(|s| s.channel(c)).collect();
            let y: Vec<f64> = out[from..].iter().map(|s| s.channel(c)).collect();
            if x.iter().chain(&y).any(|v| !v.is_finite()) {
                continue;
            }
            let a = overlapping_adev(&x, rate);
            let b = overlapping_adev(&y, rate);
            let mut worst: f64 = 0.0;
            let mut longest = None;
            for i in 0..a.tau_s.len().min(b.tau_s.len()) {
                let k = (span_s / a.tau_s[i]).floor();
                if k < 2.0 {
                    break;
                }
                let one_sigma = 1.0 / (2.0 * (k - 1.0)).sqrt();
                worst = worst.max(b.adev[i] / a.adev[i] / (1.0 + one_sigma));
                if k >= 9.0 {
                    longest = Some(100.0 * (b.adev[i] / a.adev[i] - 1.0));
                }
            }
            fig.adev_worst_ratio = Some(worst);
            fig.adev_longest_change_pct = longest;
            target(
                CHANNEL_NAMES[c],
                "ADEV out/raw / (1 + 1σ), worst τ",
                worst,
                1.0,
                true,
            );
            if c < 3
                && duration_s >= 3600.0
                && let Some(l) = longest
            {
                target(
                    CHANNEL_NAMES[c],
                    "ADEV change at the longest τ (≥ 9 clusters), %",
                    l,
                    -50.0,
                    true,
                );
            }
        }
    }

    HarmScore {
        channels,
        bias_engaged_share,
        bias_first_engaged_s,
        still_share,
        onsets,
        onset_worst_move_3sigma: worst_onset,
        targets,
    }
}

/// The injections' seeds: `first`, `first + 1`, … (`count` of them, at least one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Seeds {
    pub first: u64,
    pub count: u64,
}

impl Seeds {
    /// `imuprep audit`'s default: seeds 12 to 16.
    pub const DEFAULT: Seeds = Seeds {
        first: 12,
        count: 5,
    };

    /// One seed alone.
    pub fn one(seed: u64) -> Seeds {
        Seeds {
            first: seed,
            count: 1,
        }
    }

    fn all(self) -> Vec<u64> {
        (0..self.count.max(1))
            .map(|k| self.first.wrapping_add(k))
            .collect()
    }
}

/// What one seed's injections gave.
struct SeedRuns {
    counts: Counts,
    bad: usize,
    unflagged: usize,
}

/// `f` of every item, on as many worker threads as the machine has cores (at most one per
/// item); results in the items' order.
fn for_each_parallel<T: Send>(items: &[u64], f: impl Fn(u64) -> T + Sync) -> Vec<T> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let workers = std::thread::available_parallelism()
        .map_or(1, usize::from)
        .min(items.len());
    let next = AtomicUsize::new(0);
    let out: Vec<Mutex<Option<T>>> = items.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&item) = items.get(i) else { break };
                    let r = f(item);
                    *out[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                }
            });
        }
    });
    out.into_iter()
        .map(|m| {
            m.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .expect("every item was processed")
        })
        .collect()
}

/// Audit one recording (already loaded) with `cfg`'s pipeline; every injection is made once per
/// seed of `seeds` and scored on the pooled counts.
pub fn audit_recording(
    name: &str,
    path: &Path,
    desc: &Descriptor,
    raw: &[Sample],
    seeds: Seeds,
    cfg: &Config,
) -> Result<RecordingAudit, String> {
    let n = raw.len();
    if n < 3 * SCORE_FROM {
        return Err(format!("{n} samples: too short to audit"));
    }
    let rate = if desc.sample_rate_hz > 0.0 {
        desc.sample_rate_hz
    } else {
        100.0
    };
    let duration_s = raw[n - 1].t_s() - raw[0].t_s();
    let class = classify(raw, rate);
    let out = run_config(cfg, desc, raw)?;
    let mut harm = score_harm(name, class, rate, raw, &out);
    let mut target = |channel: &str, what: &str, measured: f64, limit: f64, at_most: bool| {
        harm.targets.push(TargetRow::new(
            name, channel, what, measured, limit, at_most,
        ));
    };

    // Injections, pooled over the seeds (each seed's runs are independent: one worker per core).
    let seed_list = seeds.all();
    let per_seed = for_each_parallel(&seed_list, |seed| -> Result<SeedRuns, String> {
        let mut x = raw.to_vec();
        let (labels, chans): (_, &[usize]) = match class {
            Class::Moving => (inject_spikes(&mut x, seed), &[0, 1, 2, 3, 4, 5]),
            Class::Static => (inject_outliers(&mut x, seed), &[0, 1, 2]),
        };
        let counts = score(&run_config(cfg, desc, &x)?, &labels, chans);
        let mut x = raw.to_vec();
        let bad = inject_bad_values(&mut x, seed);
        let o = run_config(cfg, desc, &x)?;
        let unflagged = bad
            .iter()
            .filter(|&&(i, c)| !flagged_bad(&o[i], c) || !o[i].channel(c).is_finite())
            .count();
        Ok(SeedRuns {
            counts,
            bad: bad.len(),
            unflagged,
        })
    })
    .into_iter()
    .collect::<Result<Vec<_>, _>>()?;
    let mut pooled = Counts::default();
    for r in &per_seed {
        pooled.add(r.counts);
    }
    let bad_injected = per_seed.iter().map(|r| r.bad).sum();
    let unflagged = per_seed.iter().map(|r| r.unflagged).sum::<usize>();
    let (injected, contamination) = match class {
        Class::Moving => (Some(pooled), None),
        Class::Static => (None, Some(pooled)),
    };
    let f1_per_seed = match class {
        Class::Moving => per_seed.iter().map(|r| r.counts.f1()).collect(),
        Class::Static => Vec::new(),
    };
    let recall_per_seed = match class {
        Class::Moving => Vec::new(),
        Class::Static => per_seed.iter().map(|r| r.counts.recall()).collect(),
    };
    let injected_f1 = injected.map(|k| k.f1());
    if let Some(f1) = injected_f1 {
        target("all", "injected spikes and runs, F1", f1, 0.95, false);
    }
    let (contamination_recall, contamination_precision) = match contamination {
        Some(k) => (Some(k.recall()), Some(k.precision())),
        None => (None, None),
    };
    if let (Some(r), Some(p)) = (contamination_recall, contamination_precision) {
        target("gyro", "2 % outliers > 8σ, recall", r, 0.9, false);
        target("gyro", "2 % outliers > 8σ, precision", p, 0.9, false);
    }
    target(
        "all",
        "NaN/Inf/1e30 passed unflagged or non-finite",
        unflagged as f64,
        0.0,
        true,
    );

    Ok(RecordingAudit {
        name: name.to_string(),
        path: path.to_path_buf(),
        class,
        samples: n,
        rate_hz: rate,
        duration_s,
        harm,
        seeds: seed_list,
        injected,
        injected_f1,
        injected_f1_per_seed: f1_per_seed,
        contamination,
        contamination_recall,
        contamination_precision,
        contamination_recall_per_seed: recall_per_seed,
        bad_values_injected: bad_injected,
        bad_values_unflagged: unflagged,
    })
}

/// Audit every recording under `dir` (a file that does not import is listed as skipped).
pub fn audit_dir(dir: &Path, seeds: Seeds, cfg: &Config) -> std::io::Result<AuditReport> {
    let mut report = AuditReport {
        dir: dir.to_path_buf(),
        config: None,
        recordings: Vec::new(),
        skipped: Vec::new(),
    };
    for p in find_recordings(dir)? {
        let name = p
            .strip_prefix(dir)
            .unwrap_or(&p)
            .to_string_lossy()
            .into_owned();
        let res =
            load_recording(&p).and_then(|(d, s)| audit_recording(&name, &p, &d, &s, seeds, cfg));
        match res {
            Ok(r) => report.recordings.push(r),
            Err(reason) => report.skipped.push(Skipped { path: p, reason }),
        }
    }
    Ok(report)
}

impl std::fmt::Display for AuditReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let config = match &self.config {
            None => "embedded default config".to_string(),
            Some(p) => format!("config {} over the embedded default", p.display()),
        };
        writeln!(f, "imuprep audit of {} ({config})", self.dir.display())?;
        for r in &self.recordings {
            writeln!(
                f,
                "\n## {} — {:?}, {} samples, {:.1} s at {:.2} Hz",
                r.name, r.class, r.samples, r.duration_s, r.rate_hz
            )?;
            writeln!(
                f,
                "still {:.1} %, bias engaged {:.1} % (first at {}), {} motion onsets (worst bias move {:.2} × 3σ)",
                100.0 * r.harm.still_share,
                100.0 * r.harm.bias_engaged_share,
                r.harm
                    .bias_first_engaged_s
                    .map_or("never".to_string(), |t| format!("{t:.1} s")),
                r.harm.onsets,
                r.harm.onset_worst_move_3sigma
            )?;
            writeln!(
                f,
                "| ch | replaced | per ch-sample | suspect | invented angle ° | ADEV worst out/raw/(1+1σ) | ADEV at longest τ |"
            )?;
            writeln!(f, "|---|---|---|---|---|---|---|")?;
            for (c, ch) in r.harm.channels.iter().enumerate() {
                let opt =
                    |v: Option<f64>, p: usize| v.map_or("–".to_string(), |v| format!("{v:.p$}"));
                writeln!(
                    f,
                    "| {} | {} | {:.1e} | {} | {} | {} | {} |",
                    CHANNEL_NAMES[c],
                    ch.replaced,
                    ch.replaced_rate,
                    ch.suspect,
                    opt(ch.invented_angle_deg, 3),
                    opt(ch.adev_worst_ratio, 3),
                    ch.adev_longest_change_pct
                        .map_or("–".to_string(), |v| format!("{v:+.1} %")),
                )?;
            }
            let seeds = seed_span(&r.seeds);
            if let (Some(k), Some(f1)) = (r.injected, r.injected_f1) {
                writeln!(
                    f,
                    "injected spikes and runs: F1 {f1:.4} ({seeds}: {} labelled channel-samples, {} missed, {} false; F1 per seed {})",
                    k.tp + k.fn_,
                    k.fn_,
                    k.fp,
                    range(&r.injected_f1_per_seed)
                )?;
            }
            if let (Some(k), Some(rc), Some(p)) = (
                r.contamination,
                r.contamination_recall,
                r.contamination_precision,
            ) {
                writeln!(
                    f,
                    "2 % gyro outliers: recall {rc:.4}, precision {p:.4} ({seeds}: {} outliers, {} missed, {} false; recall per seed {})",
                    k.tp + k.fn_,
                    k.fn_,
                    k.fp,
                    range(&r.contamination_recall_per_seed)
                )?;
            }
            writeln!(
                f,
                "bad values: {} injected, {} unflagged or non-finite in the output",
                r.bad_values_injected, r.bad_values_unflagged
            )?;
        }
        for s in &self.skipped {
            writeln!(f, "\nskipped {}: {}", s.path.display(), s.reason)?;
        }
        let missed = self.missed();
        let total = self.targets().count();
        writeln!(f, "\ntargets: {} of {} met", total - missed.len(), total)?;
        for t in missed {
            writeln!(
                f,
                "  MISSED {} {}: {} = {} (limit {} {})",
                t.recording,
                t.channel,
                t.target,
                four_figures(t.measured),
                if t.at_most { "≤" } else { "≥" },
                t.limit
            )?;
        }
        Ok(())
    }
}

/// "seed 12" or "seeds 12–16 pooled".
fn seed_span(seeds: &[u64]) -> String {
    match seeds {
        [one] => format!("seed {one}"),
        [first, .., last] => format!("seeds {first}–{last} pooled"),
        [] => "no seed".to_string(),
    }
}

/// "0.9012–0.9378" (the smallest and largest), or the one value.
fn range(v: &[f64]) -> String {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if v.len() < 2 {
        format!("{lo:.4}")
    } else {
        format!("{lo:.4}–{hi:.4}")
    }
}

/// A measured value to four significant figures: fixed below 1e-2 would print a rate of
/// 1.17e-4 as 0.0001, which reads as meeting a limit of 1e-4.
fn four_figures(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-2 {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}
