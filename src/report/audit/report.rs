//! The audit's results: the targets measured, the do-no-harm figures of a run, each recording's
//! audit, and the whole report (its text in [`super::text`]).

use std::path::PathBuf;

use serde::Serialize;

use super::{Class, Counts};

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
    /// static recording bias engagement and Allan deviation (the parent module's docs), in that
    /// order.
    pub targets: Vec<TargetRow>,
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

impl std::fmt::Display for Skipped {
    /// "skipped PATH: REASON", the path once (the reader's error often names the file already).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let path = self.path.display().to_string();
        let reason = self
            .reason
            .strip_prefix(&format!("{path}: "))
            .unwrap_or(&self.reason);
        write!(f, "skipped {path}: {reason}")
    }
}

/// The whole audit.
#[derive(Debug, Clone, Serialize)]
pub struct AuditReport {
    pub dir: PathBuf,
    /// The config file whose pipeline was audited (`--config`, over the embedded default);
    /// `None`: the embedded default alone. The caller sets it: [`audit_dir`](super::audit_dir)
    /// takes the parsed config only.
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
