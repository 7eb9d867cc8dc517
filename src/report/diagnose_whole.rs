//! `imuprep diagnose LOG` (default): the whole-log diagnosis of every chosen channel, one report
//! (`report.txt`, `report.json`), one model (`bias.toml`) and the plots, with a progress bar on
//! stderr (hidden when stderr is not a terminal).

use std::io::Write;

use anyhow::{Result, anyhow};
use serde::Serialize;

use super::diagnose::{
    Added, Prepared, Stretch, channel_input, channel_model, effects_text, others_of, write_outputs,
    write_plots,
};
use crate::analysis::diagnose::whole::{WholeDiagnosis, WholeSettings, diagnose_whole};
use crate::analysis::diagnose::whole_report::{effect_lines, whole_plots, whole_text};
use crate::model::bias_model::{ArOf, BiasModelFile};
use crate::sample::CHANNEL_NAMES;

/// The report of one run.
#[derive(Debug, Serialize)]
pub struct WholeReport {
    /// What was analysed.
    pub source: String,
    /// How effects were chosen and tested.
    pub method: &'static str,
    /// One diagnosis per channel.
    pub channels: Vec<WholeDiagnosis>,
    /// What makes the effects doubtful (a record not at rest), one line each.
    pub warnings: Vec<String>,
}

const METHOD: &str = "whole log: effects proposed and fitted on the even blocks, kept only if their held-out gain on the odd blocks beats its noise (z-test at alpha = 0.001 / candidates; for slow effects the noise of the gain from the held-out innovations' autocovariance; a step is placed and fitted on the 1-s points of one parity near its candidate time and scored on the other, both ways round), then refitted on every block";

impl WholeReport {
    /// The text report.
    pub fn to_text(&self) -> String {
        let mut o = format!("diagnose: {}\nmethod: {}\n", self.source, self.method);
        for w in &self.warnings {
            o.push_str(&format!("WARNING: {w}\n"));
        }
        for c in &self.channels {
            o.push_str(&whole_text(c));
        }
        o
    }
}

/// The whole-log diagnosis of one stretch.
pub fn diagnose_whole_samples(
    st: &Stretch,
    p: Prepared,
    progress: &mut dyn Write,
) -> Result<Added> {
    let (rate, out_dir) = (st.rate, st.out_dir);
    let mut model = BiasModelFile::default();
    let mut added_all: Added = Vec::new();
    let settings = WholeSettings::default();
    let warnings: Vec<String> = st.motion.iter().cloned().collect();
    let mut report = WholeReport {
        source: p.source.clone(),
        method: METHOD,
        channels: vec![],
        warnings,
    };
    let bar = crate::progress::bar(7 * p.chans.len() as u64);
    for &c in &p.chans {
        let name = CHANNEL_NAMES[c];
        let others = others_of(&p.series, c);
        let input = channel_input(&p.series, p.temp.as_deref(), &others, rate, c);
        let start = bar.position();
        let d = match diagnose_whole(&input, &settings, &mut |stage| {
            bar.set_message(format!("{name}: {stage}"));
            bar.inc(1);
        }) {
            Ok(d) => d,
            Err(e) => {
                bar.suspend(|| {
                    writeln!(
                        progress,
                        "{name}: cannot diagnose: {}",
                        super::diagnose::why_not(&e, rate)
                    )
                })?;
                bar.set_position(start + 7);
                continue;
            }
        };
        bar.set_position(start + 7);
        let h = &d.held_out;
        let lines = effect_lines(&d);
        bar.suspend(|| {
            writeln!(
                progress,
                "{name}: held-out open-loop MSE {:.4e} → {:.4e}, one-step {:.4e} → {:.4e} ({:.1} % lower); model: {}",
                h.open_loop_before,
                h.open_loop_after,
                h.one_step_before,
                h.one_step_after,
                100.0 * (1.0 - h.one_step_after / h.one_step_before),
                effects_text(&lines)
            )
        })?;
        write_plots(out_dir, whole_plots(&d).map_err(anyhow::Error::msg)?)?;
        let effects: Vec<_> = d.effects.iter().map(|e| e.effect.clone()).collect();
        let mut m = channel_model(name, rate, &d.refit, effects.clone());
        if let Some((ar, q, white)) = d.wander.as_ref().and_then(|w| w.bias_process(rate)) {
            m.ar = ar;
            m.innovation_var = q;
            m.white_noise_var = white;
            m.ar_of = ArOf::Bias;
        }
        model.channels.push(m);
        added_all.push((name.to_string(), effects));
        report.channels.push(d);
    }
    bar.finish_and_clear();
    super::diagnose::none_diagnosed(st.log, model.channels.is_empty())?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| anyhow!(e.to_string()))?;
    write_outputs(st, &report.to_text(), &json, &model, progress)?;
    Ok(added_all)
}
