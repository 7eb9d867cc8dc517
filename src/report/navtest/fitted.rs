//! Variant (c): imuprep's output with the models `imuprep fit` made on another stretch of the
//! same recording, or on the other recording — the ARIMA model for the gross-error stage and
//! the AR bias model for the bias stage, both loaded as `[gross_error] model` / `[bias] model`
//! would load them. `fit` fits the bias model only on the longest still stretch of its span;
//! when that is shorter than `--min-still-s` it writes no channel models ("NOT FITTED") and
//! the bias stage warms up as by default — the report says which happened. A model the
//! pipeline refuses (a bias model of another sample rate) is reported, not run.

use std::path::PathBuf;

use serde::Serialize;

use super::setup::RecordSpec;
use crate::config::Config;
use crate::frame::Descriptor;
use crate::model::arima::ArimaModelFile;
use crate::model::bias_model::BiasModelFile;
use crate::report::fit::{BiasMethod, FitOptions, fit};
use crate::sample::Sample;

/// `fit`'s `--min-still-s` values tried: its default (60 s), and 10 s, which lets it fit the
/// bias model on these recordings' short still stretches (drive 18.6 s, walk 13.4 s).
pub const MIN_STILL_CHOICES_S: [f64; 2] = [60.0, 10.0];

/// Models `fit` made on one stretch of one recording.
#[derive(Clone, Debug, Serialize)]
pub struct FittedModels {
    pub record: String,
    /// The `imuprep fit` options used (besides the log and `--out-dir`).
    pub options: String,
    pub min_still_s: f64,
    /// The fitted stretch, s after the IMU start, and in GPST (with the record's offset).
    pub span_s: (f64, f64),
    pub span_gpst: (f64, f64),
    /// Why the bias model was not fitted (`fit`'s own words), if so.
    pub bias_skipped: Option<String>,
    /// The longest still stretch `fit` found, s.
    pub still_s: f64,
    /// The bias model's per-channel means (channel, value in rad/s or m/s²).
    pub bias_means: Vec<(String, f64)>,
    #[serde(skip)]
    pub arima: ArimaModelFile,
    /// `None` when not fitted (the bias stage then warms up as by default).
    #[serde(skip)]
    pub bias: Option<BiasModelFile>,
}

impl FittedModels {
    /// A short name for tables: where the models come from and whether the bias was fitted.
    pub fn label(&self, on_record: &str) -> String {
        let from = if self.record == on_record {
            format!("{} s–{} s", self.span_s.0.round(), self.span_s.1.round())
        } else {
            format!("the {}", self.record)
        };
        let bias = if self.bias.is_some() {
            "bias fitted"
        } else {
            "bias NOT FITTED"
        };
        format!(
            "(c) fitted on {from}, min-still {} s: ARIMA + {bias}",
            self.min_still_s
        )
    }

    /// `cfg` with these models in place of its own (the ARIMA model always; the bias model
    /// only when fitted, else `cfg`'s bias stage as it is).
    pub fn config(&self, cfg: &Config) -> Config {
        let mut c = cfg.clone();
        if let Some(g) = c.stages.gross_error.as_mut() {
            g.model = Some(self.arima.clone());
        }
        if let (Some(b), Some(m)) = (c.stages.bias.as_mut(), &self.bias) {
            b.model = Some(m.clone());
        }
        c
    }
}

/// Run `imuprep fit`'s library function on the record's fit stretch
/// (`spec.fit_skip_s`, `spec.fit_train_s`; Burg AR(64), as the command's defaults) with
/// `--min-still-s min_still_s`. The samples are written to a temporary native log for it (in a
/// directory of its own, removed afterwards).
pub fn fit_models(
    spec: &RecordSpec,
    desc: &Descriptor,
    raw: &[Sample],
    min_still_s: f64,
) -> Result<FittedModels, String> {
    // One directory per call: two calls in one process (tests run in threads) on the same record
    // shared a name, and one removed it while the other wrote its models there.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "imuprep-navtest-{}-{call}-{}-{}",
        std::process::id(),
        spec.name,
        min_still_s
    ));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let result = fit_in(spec, desc, raw, min_still_s, &dir);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn fit_in(
    spec: &RecordSpec,
    desc: &Descriptor,
    raw: &[Sample],
    min_still_s: f64,
    dir: &std::path::Path,
) -> Result<FittedModels, String> {
    let log = dir.join("record.log");
    crate::io::log::write_log(&log, desc, raw).map_err(|e| e.to_string())?;
    let o = FitOptions {
        train_s: spec.fit_train_s,
        skip_s: spec.fit_skip_s,
        bias_method: BiasMethod::Burg,
        bias_order: BiasMethod::Burg.default_order(),
        min_still_s,
    };
    let rep = fit(
        &crate::report::Recording::new(&log),
        &dir.join("models"),
        &o,
    )
    .map_err(|e| format!("imuprep fit: {e:#}"))?;
    let read = |p: &std::path::Path| std::fs::read_to_string(p).map_err(|e| e.to_string());
    let arima =
        ArimaModelFile::from_toml_str(&read(&rep.arima_path)?).map_err(|e| e.to_string())?;
    let bias = match &rep.bias_skipped {
        Some(_) => None,
        None => {
            Some(BiasModelFile::from_toml_str(&read(&rep.bias_path)?).map_err(|e| e.to_string())?)
        }
    };
    let t0 = raw[0].t_s() + spec.t_off;
    let span_s = (
        spec.fit_skip_s,
        spec.fit_skip_s + rep.samples as f64 / rep.sample_rate_hz,
    );
    Ok(FittedModels {
        record: spec.name.clone(),
        options: format!(
            "--skip-s {} --train-s {} --min-still-s {min_still_s}",
            spec.fit_skip_s, spec.fit_train_s
        ),
        min_still_s,
        span_s,
        span_gpst: (t0 + span_s.0, t0 + span_s.1),
        bias_skipped: rep.bias_skipped.clone(),
        still_s: rep.still.len as f64 / rep.sample_rate_hz,
        bias_means: rep
            .bias
            .iter()
            .map(|b| (b.channel.clone(), b.mean))
            .collect(),
        arima,
        bias,
    })
}

/// Margin around a fitted stretch inside which an outage still counts as touching it, s (as
/// the harness's `HELD_OUT_MARGIN_S`).
pub const HELD_OUT_MARGIN_S: f64 = 1.0;

/// True when the outage window (GPST) lies outside the fitted stretch (with the margin).
pub fn held_out(m: &FittedModels, start: f64, end: f64) -> bool {
    end < m.span_gpst.0 - HELD_OUT_MARGIN_S || start > m.span_gpst.1 + HELD_OUT_MARGIN_S
}
