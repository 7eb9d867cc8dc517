//! `imuprep compare`: gross-error detectors against the simulator's truth
//! ([`detectors`]), or the bias models of the FOS paper on a recording ([`bias_models`]).

use std::fmt;
use std::path::Path;

use anyhow::{Context, Result, anyhow, ensure};
use serde::Serialize;

use super::detector_compare::{self as dc, DetectorReport};
use super::{parse_channels, read_scenario};
use crate::analysis::bias_compare::{CompareReport, CompareSettings, SensorKind, compare_channel};
use crate::config::Config;
use crate::sample::CHANNEL_NAMES;

/// `compare --detectors`: every detector on a simulated scenario, scored on its truth. The
/// online stage uses `cfg`'s `[gross_error.settings]` (and model).
pub fn detectors(
    scenario: &Path,
    seed: Option<u64>,
    cfg: &Config,
    sets: &[String],
) -> Result<DetectorReport> {
    let scn = read_scenario(scenario, sets)?;
    let seed = crate::sim::log::effective_seed(&scn, seed);
    let (settings, model) = cfg
        .stages
        .gross_error
        .clone()
        .map(|g| (g.settings.into_inner(), g.model))
        .unwrap_or_default();
    let (samples, truth) = dc::simulate_decoded(&scn, seed)?;
    // Without a fitted model the online stage spends its first `warmup_samples` identifying
    // one (passing samples through); every detector is scored on the samples after that.
    let from = if model.is_some() {
        0
    } else {
        settings.warmup_samples.min(samples.len())
    };
    let rows = dc::compare_detectors(&samples, &truth, &settings, model.as_ref(), from)
        .map_err(|e| anyhow!(e))?;
    Ok(DetectorReport {
        scenario: scenario.display().to_string(),
        seed,
        samples: samples.len(),
        scored_from: from,
        gross_samples: truth[from..]
            .iter()
            .map(|t| t.gross_mask.iter().filter(|m| **m).count() as u64)
            .sum(),
        rows,
    })
}

impl fmt::Display for DetectorReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text())
    }
}

/// `compare LOG`: the bias models of the FOS paper per channel.
#[derive(Debug, Clone, Serialize)]
#[serde(transparent)]
pub struct BiasCompareReport {
    pub channels: Vec<CompareReport>,
    /// Channels asked for but absent in the log (a partial sensor), with the reason; said in
    /// the text, left out of the JSON array (which lists the channels compared).
    #[serde(skip)]
    pub skipped: Vec<(String, String)>,
}

impl BiasCompareReport {
    /// CSV of every channel's rows (one header per channel, as each table is written).
    pub fn to_csv(&self) -> String {
        self.channels.iter().map(|r| r.to_csv()).collect()
    }
}

impl fmt::Display for BiasCompareReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for r in &self.channels {
            writeln!(f, "{}", r.to_text_table())?;
        }
        for (c, why) in &self.skipped {
            writeln!(f, "{c}: skipped: {why}")?;
        }
        Ok(())
    }
}

/// `compare LOG`: each channel's comparison, after `skip_s`; `temp_exo` adds the temperature as
/// an exogenous FOS input (the log must carry it on every sample).
pub fn bias_models(
    log: &super::Recording,
    channels: &[String],
    skip_s: f64,
    temp_exo: bool,
) -> Result<BiasCompareReport> {
    let (rate, samples) = super::load_channels_to(log, skip_s, None)?;
    let chans = parse_channels(channels)?;
    let (chans, mut skipped) = super::present_channels_of(log, &samples, &chans)?;
    // A channel with NaN/Inf cannot be fitted: left out with the reason, the others compared.
    let chans: Vec<usize> = chans
        .into_iter()
        .filter(|&c| match super::non_finite_of(&samples, c) {
            None => true,
            Some((k, first_s)) => {
                skipped.push((
                    CHANNEL_NAMES[c].to_string(),
                    format!(
                        "{} (first at {first_s:.3} s of the log): the model fits need a \
                         gap-free series",
                        crate::text::count(k as u64, "non-finite sample", "non-finite samples")
                    ),
                ));
                false
            }
        })
        .collect();
    ensure!(
        !chans.is_empty(),
        "{}: no channel to compare: {}",
        log.display(),
        skipped
            .iter()
            .map(|(c, why)| format!("{c}: {why}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    let temp = samples.temp_c.as_deref().filter(|_| temp_exo);
    ensure!(
        !temp_exo || temp.is_some(),
        "--temp-exo: the log has no complete temperature channel"
    );
    let settings = CompareSettings::paper(rate);
    let exo: Vec<&[f64]> = temp.into_iter().collect();
    let mut out = Vec::new();
    let bar = crate::progress::bar(chans.len() as u64);
    for c in chans {
        bar.set_message(CHANNEL_NAMES[c]);
        let y = &samples.values[c];
        let kind = if c < 3 {
            SensorKind::Gyro
        } else {
            SensorKind::Accel
        };
        let name = CHANNEL_NAMES[c];
        out.push(
            compare_channel(y, &exo, name, kind, &settings).with_context(|| {
                format!(
                    "{}: {name} ({:.1} s at {} Hz)",
                    log.display(),
                    y.len() as f64 / rate,
                    crate::text::trim_decimals(rate, 3),
                )
            })?,
        );
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(BiasCompareReport {
        channels: out,
        skipped,
    })
}
