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

use std::path::Path;

use crate::config::Config;
use crate::frame::Descriptor;
use crate::sample::Sample;

mod class;
mod harm;
mod inject;
mod parallel;
mod recordings;
mod report;
mod text;

pub use class::{Class, classify, gyro_roughness_ratio, gyro_roughness_ratio_of};
pub use harm::score_harm;
pub use inject::{
    Counts, inject_bad_values, inject_outliers, inject_spikes, score as score_injections,
};
use inject::{flagged_bad, score};
use parallel::for_each_parallel;
pub use recordings::{find_recordings, load_recording, run_config};
pub use report::{AuditReport, ChannelFigures, HarmScore, RecordingAudit, Skipped, TargetRow};

/// Samples skipped before scoring injections (the gross-error stage's default warm-up).
const SCORE_FROM: usize = 2000;

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
    let files = find_recordings(dir)?;
    let bar = crate::progress::bar(files.len() as u64);
    for p in files {
        let name = p
            .strip_prefix(dir)
            .unwrap_or(&p)
            .to_string_lossy()
            .into_owned();
        bar.set_message(name.clone());
        let res =
            load_recording(&p).and_then(|(d, s)| audit_recording(&name, &p, &d, &s, seeds, cfg));
        match res {
            Ok(r) => report.recordings.push(r),
            Err(reason) => report.skipped.push(Skipped { path: p, reason }),
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(report)
}
