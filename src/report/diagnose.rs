//! `imuprep diagnose`: the close-the-loop bias diagnosis
//! ([`crate::analysis::diagnose::diagnose_channel`]) on a stretch of a log ([`diagnose`]) or on
//! overlapping windows of a long one ([`diagnose_windows`]), each writing its report, plots and
//! bias model into a folder.

use std::fmt;
use std::io::Write;
use std::path::Path;

use anyhow::{Result, anyhow, ensure};
use serde::Serialize;

use super::{load_span, load_span_to, parse_channels};
use crate::analysis::diagnose::{ChannelInput, DiagnoseSettings, diagnose_channel};
use crate::analysis::diagnose_report::{DiagnoseReport, channel_plots, effect_text};
use crate::analysis::exogenous::Exogenous;
use crate::model::bias_model::{BiasModelFile, ChannelBiasModel, Effect};
use crate::sample::{CHANNEL_NAMES, Sample};

/// What one run added, per channel: (channel, effects chosen by the loop, with times from the
/// start of the analysed stretch).
pub type Added = Vec<(String, Vec<Effect>)>;

/// Effect texts joined with "; ", or "nothing".
pub fn effects_text(v: &[String]) -> String {
    if v.is_empty() {
        "nothing".to_string()
    } else {
        v.join("; ")
    }
}

/// Start times (s) of the windows of `window_s` every `hop_s` over `from_s..end_s`; a window
/// shorter than half its length (the log's tail) is dropped, since its split would leave too
/// little to fit and test on (the first is always kept).
pub fn window_starts(from_s: f64, end_s: f64, window_s: f64, hop_s: f64) -> Vec<f64> {
    let mut starts = Vec::new();
    let mut t = from_s;
    while t < end_s && (end_s - t >= 0.5 * window_s || starts.is_empty()) {
        starts.push(t);
        t += hop_s;
    }
    starts
}

/// `diagnose` on one stretch `from_s..to_s` of a log; progress lines go to `progress`.
pub fn diagnose(
    log: &Path,
    channels: &[String],
    from_s: f64,
    to_s: Option<f64>,
    out_dir: &Path,
    progress: &mut dyn Write,
) -> Result<Added> {
    let (rate, samples) = load_span_to(log, from_s, to_s.map(|t| (t - from_s).max(0.0)))?;
    let end = match to_s {
        Some(t) => (((t - from_s) * rate).round() as usize).min(samples.len()),
        None => samples.len(),
    };
    diagnose_samples(
        log,
        &samples[..end],
        rate,
        from_s,
        channels,
        out_dir,
        progress,
    )
}

/// One window of [`diagnose_windows`]: its span (s from the log's start) and what it added.
#[derive(Debug, Clone, Serialize)]
pub struct WindowResult {
    pub from_s: f64,
    pub to_s: f64,
    pub added: Added,
}

/// What `diagnose --window-s` found: each window's additions (the summary).
#[derive(Debug, Clone, Serialize)]
pub struct WindowsReport {
    pub windows: Vec<WindowResult>,
}

/// The windows of a scan: their length and start-to-start spacing, s.
#[derive(Debug, Clone, Copy)]
pub struct Windows {
    pub window_s: f64,
    pub hop_s: f64,
}

/// `diagnose --window-s W`: the loop on overlapping windows of a long log, each written to
/// `out_dir/window_<start>s/`; each window's progress goes to `progress`.
pub fn diagnose_windows(
    log: &Path,
    channels: &[String],
    (from_s, to_s): (f64, Option<f64>),
    w: Windows,
    out_dir: &Path,
    progress: &mut dyn Write,
) -> Result<WindowsReport> {
    let Windows { window_s, hop_s } = w;
    ensure!(
        window_s > 0.0 && hop_s > 0.0 && hop_s <= window_s,
        "--window-s and --hop-s must be > 0, with the hop no longer than the window"
    );
    let (rate, samples) = load_span(log, from_s)?;
    let total_s = samples.len() as f64 / rate;
    let end_s = to_s.map_or(from_s + total_s, |t| t.min(from_s + total_s));
    let mut windows = Vec::new();
    for a in window_starts(from_s, end_s, window_s, hop_s) {
        let b = (a + window_s).min(end_s);
        writeln!(progress, "== window {a:.0}–{b:.0} s")?;
        let dir = out_dir.join(format!("window_{a:.0}s"));
        let i0 = (((a - from_s) * rate).round() as usize).min(samples.len());
        let i1 = (((b - from_s) * rate).round() as usize).clamp(i0, samples.len());
        let added = diagnose_samples(log, &samples[i0..i1], rate, a, channels, &dir, progress)?;
        windows.push(WindowResult {
            from_s: a,
            to_s: b,
            added,
        });
    }
    Ok(WindowsReport { windows })
}

impl fmt::Display for WindowsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Each window is tested at the loop's own significance level, so a scan of many windows
        // adds more false findings than one run (slow wander read as a step, say): a finding is
        // a place to look, to be confirmed with --from-s/--to-s around it.
        writeln!(
            f,
            "\nsummary: what each window's loop added (step times from the log's start; each window is tested on its own, so expect some findings from slow wander)"
        )?;
        for w in &self.windows {
            let (a, b) = (w.from_s, w.to_s);
            for (ch, effects) in &w.added {
                let text: Vec<String> = effects
                    .iter()
                    .map(|e| match *e {
                        Effect::Step { t_s, size } => {
                            effect_text(&Effect::Step { t_s: t_s + a, size })
                        }
                        ref other => effect_text(other),
                    })
                    .collect();
                writeln!(f, "  {a:>7.0}–{b:<7.0} {ch}: {}", effects_text(&text))?;
            }
        }
        Ok(())
    }
}

/// The exogenous inputs of channel `c`: temperature, the specific force (gyro channels) and
/// the other five axes.
fn exogenous<'a>(
    series: &'a [Vec<f64>],
    temp: Option<&'a [f64]>,
    others: &'a [(String, &'a [f64])],
    c: usize,
) -> Exogenous<'a> {
    Exogenous {
        temperature_c: temp,
        specific_force_m_s2: (c < 3).then(|| {
            [
                series[3].as_slice(),
                series[4].as_slice(),
                series[5].as_slice(),
            ]
        }),
        other_axes: others,
    }
}

/// The loop on `samples` (already cut to the stretch that starts `from_s` into `log`): per
/// channel a line on `progress`; `report.txt`, `report.json`, `bias.toml` and `plots/` in
/// `out_dir`.
pub fn diagnose_samples(
    log: &Path,
    samples: &[Sample],
    rate: f64,
    from_s: f64,
    channels: &[String],
    out_dir: &Path,
    progress: &mut dyn Write,
) -> Result<Added> {
    let end = samples.len();
    ensure!(end > 0, "the chosen stretch is empty");
    let chans = parse_channels(channels)?;
    let series: Vec<Vec<f64>> = (0..6)
        .map(|c| samples.iter().map(|s| s.channel(c)).collect())
        .collect();
    let temp: Option<Vec<f64>> = samples.iter().map(|s| s.temp_c).collect();
    std::fs::create_dir_all(out_dir.join("plots"))?;
    let settings = DiagnoseSettings::default();
    let mut report = DiagnoseReport {
        source: format!(
            "{} [{from_s} s .. +{:.1} s at {rate} Hz]",
            log.display(),
            end as f64 / rate
        ),
        channels: vec![],
    };
    let mut model = BiasModelFile::default();
    let mut added_all: Added = Vec::new();
    for c in chans {
        let name = CHANNEL_NAMES[c];
        let others: Vec<(String, &[f64])> = (0..6)
            .filter(|j| *j != c)
            .map(|j| (CHANNEL_NAMES[j].to_string(), series[j].as_slice()))
            .collect();
        let input = ChannelInput {
            name,
            values: &series[c],
            rate_hz: rate,
            exogenous: exogenous(&series, temp.as_deref(), &others, c),
        };
        let d = match diagnose_channel(&input, &settings) {
            Ok(d) => d,
            Err(e) => {
                writeln!(progress, "{name}: cannot diagnose: {e}")?;
                continue;
            }
        };
        let added: Vec<String> = d
            .iterations
            .iter()
            .map(|it| effect_text(&it.effect))
            .collect();
        // What the model file carries: the effects refitted on the whole log for deployment;
        // one the loop added may have been superseded by a later one (a step re-found nearby),
        // so this list can be shorter than the loop's.
        let written: Vec<String> = d.effects.iter().map(effect_text).collect();
        writeln!(
            progress,
            "{name}: first model AR({}) test MSE {:.4e}; added: {}; final test MSE {:.4e} ({:.1} % lower)",
            d.baseline.ar_order,
            d.baseline.mse_one_step,
            effects_text(&added),
            d.final_metrics.mse_one_step,
            100.0 * (1.0 - d.final_metrics.mse_one_step / d.baseline.mse_one_step)
        )?;
        writeln!(
            progress,
            "{name}: effects in the model file (refit on the whole log): {}",
            effects_text(&written)
        )?;
        for (stem, svg) in channel_plots(&d) {
            std::fs::write(out_dir.join("plots").join(format!("{stem}.svg")), svg)?;
        }
        model.channels.push(ChannelBiasModel {
            channel: name.to_string(),
            method: "burg".into(),
            sample_rate_hz: rate,
            mean: d.intercept,
            ar: d.ar.clone(),
            innovation_var: d.innovation_var,
            white_noise_var: 0.0,
            effects: d.effects.clone(),
            ..Default::default()
        });
        added_all.push((
            name.to_string(),
            d.iterations.iter().map(|it| it.effect.clone()).collect(),
        ));
        report.channels.push(d);
    }
    std::fs::write(out_dir.join("report.txt"), report.to_text())?;
    std::fs::write(
        out_dir.join("report.json"),
        report.to_json().map_err(|e| anyhow!(e.to_string()))?,
    )?;
    std::fs::write(
        out_dir.join("bias.toml"),
        model.to_toml_string().map_err(|e| anyhow!(e.to_string()))?,
    )?;
    writeln!(
        progress,
        "wrote {0}/report.txt, {0}/report.json, {0}/bias.toml and {0}/plots/",
        out_dir.display()
    )?;
    Ok(added_all)
}
