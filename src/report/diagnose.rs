//! `imuprep diagnose`: by default the whole-log diagnosis
//! ([`crate::analysis::diagnose::whole::diagnose_whole`]: effects chosen on interleaved selection
//! blocks, scored on the held-out blocks between them, one model for the whole recording);
//! with `--paper-split` the close-the-loop iteration of issue 6
//! ([`crate::analysis::diagnose::paper_split::diagnose_channel`]: 3 min train, 3 min validation,
//! the rest test).
//! Either writes one report, plots and one bias model into a folder.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, anyhow, ensure};

use super::{load_channels_to, parse_channels, present_channels_of};
use crate::analysis::AnalysisError;
use crate::analysis::diagnose::paper_split::{
    ChannelInput, DeploymentFit, DiagnoseSettings, diagnose_channel,
};
use crate::analysis::diagnose::report::{DiagnoseReport, channel_plots, effect_text};
use crate::analysis::exogenous::Exogenous;
use crate::model::bias_model::{BiasModelFile, ChannelBiasModel, Effect};
use crate::sample::{CHANNEL_NAMES, Channels};
use crate::stats::NumError;

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

/// `diagnose` on one stretch `from_s..to_s` of a log; progress lines go to `progress`. The whole
/// stretch is diagnosed as one ([`diagnose_whole_samples`]) unless `paper_split`. On a stretch
/// not at rest no `bias.toml` is written unless `allow_motion` ([`Stretch::motion`]).
pub fn diagnose(
    log: &super::Recording,
    channels: &[String],
    (from_s, to_s): (f64, Option<f64>),
    out_dir: &Path,
    (paper_split, allow_motion): (bool, bool),
    progress: &mut dyn Write,
) -> Result<Added> {
    // Held by channel, never as samples: the columns become the analyses' series as they are.
    let (rate, mut ch) = load_channels_to(log, from_s, to_s.map(|t| (t - from_s).max(0.0)))?;
    if let Some(t) = to_s {
        ch.truncate(((t - from_s) * rate).round() as usize);
    }
    let run = if paper_split {
        diagnose_samples
    } else {
        super::diagnose_whole::diagnose_whole_samples
    };
    let stretch = Stretch {
        log,
        len: ch.len(),
        rate,
        from_s,
        channels,
        out_dir,
        motion: motion_warning(&ch, rate, allow_motion),
        allow_motion,
    };
    if let Some(w) = &stretch.motion {
        writeln!(progress, "WARNING: {w}")?;
    }
    let p = prepare(&stretch, ch, progress)?;
    run(&stretch, p, progress)
}

/// What diagnosing a stretch not at rest means (`None` at rest, by [`super::not_at_rest`]):
/// every effect is fitted to the motion as well as to the sensor, and the model would subtract
/// it from real motion. Measured on the rtklibexplorer drive: its bias.toml, as `[bias] model`,
/// changed gz by 9.7 °/s rms (the raw gz is 9.3 °/s rms) and the integrated heading by 850°;
/// the "g-sensitivity" it held on gz, 0.16 (rad/s)/(m/s²) on ay, is the car's turning seen as
/// centripetal acceleration (1/speed).
fn motion_warning(ch: &Channels, rate: f64, allow_motion: bool) -> Option<String> {
    let w = super::not_at_rest_of(ch, rate)?;
    let what = if allow_motion {
        "written anyway (--allow-motion): load it only where that is what you want"
    } else {
        "bias.toml is therefore not written (--allow-motion writes it anyway); diagnose a recording at rest, or a still part (--from-s/--to-s)"
    };
    Some(format!(
        "{w}: the effects are fitted to the motion as well as to the sensor (a stride is a \"vibration line\", a turn's centripetal acceleration a \"g-sensitivity\"), and bias.toml as [bias] model would subtract them from real motion; {what}"
    ))
}

/// Fails with [`super::InputProblem`] when no channel could be diagnosed (each said why above):
/// an empty report and a `bias.toml` without channels would read as a model that found nothing.
pub fn none_diagnosed(log: &Path, none: bool) -> Result<()> {
    if none {
        return Err(super::InputProblem(format!(
            "no channel of {} could be diagnosed (why: the lines above); nothing written",
            log.display()
        ))
        .into());
    }
    Ok(())
}

/// One stretch of a log to diagnose: its length in samples (the stretch that starts `from_s`
/// into `log`) at `rate` Hz, the channels asked for, the output folder.
pub struct Stretch<'a> {
    pub log: &'a Path,
    pub len: usize,
    pub rate: f64,
    pub from_s: f64,
    pub channels: &'a [String],
    pub out_dir: &'a Path,
    /// Why the stretch is not at rest, and what follows for `bias.toml` (`None` at rest).
    pub motion: Option<String>,
    /// Write `bias.toml` even when the stretch is not at rest.
    pub allow_motion: bool,
}

/// The other channels of `series` than `c`, named (candidate exogenous inputs).
pub fn others_of(series: &[Vec<f64>], c: usize) -> Vec<(String, &[f64])> {
    // An absent channel has no series (see [`prepare`]): no input to the others.
    (0..series.len().min(CHANNEL_NAMES.len()))
        .filter(|j| *j != c && !series[*j].is_empty())
        .map(|j| (CHANNEL_NAMES[j].to_string(), series[j].as_slice()))
        .collect()
}

/// Channel `c`'s input to the diagnose methods, with its exogenous series.
pub fn channel_input<'a>(
    series: &'a [Vec<f64>],
    temp: Option<&'a [f64]>,
    others: &'a [(String, &'a [f64])],
    rate_hz: f64,
    c: usize,
) -> ChannelInput<'a> {
    ChannelInput {
        name: CHANNEL_NAMES[c],
        values: &series[c],
        rate_hz,
        exogenous: exogenous(series, temp, others, c),
    }
}

/// The exogenous inputs of channel `c`: temperature, the specific force (gyro channels, when
/// the accelerometers are all present) and the other present axes.
pub fn exogenous<'a>(
    series: &'a [Vec<f64>],
    temp: Option<&'a [f64]>,
    others: &'a [(String, &'a [f64])],
    c: usize,
) -> Exogenous<'a> {
    Exogenous {
        temperature_c: temp,
        specific_force_m_s2: (c < 3 && series[3..6].iter().all(|v| !v.is_empty())).then(|| {
            [
                series[3].as_slice(),
                series[4].as_slice(),
                series[5].as_slice(),
            ]
        }),
        other_axes: others,
    }
}

/// The loop on one stretch: per channel a line on `progress`; `report.txt`, `report.json`, `bias.toml` and `plots/` in
/// `out_dir`.
pub fn diagnose_samples(st: &Stretch, p: Prepared, progress: &mut dyn Write) -> Result<Added> {
    let (rate, out_dir) = (st.rate, st.out_dir);
    let settings = DiagnoseSettings::default();
    let mut report = DiagnoseReport {
        source: p.source.clone(),
        channels: vec![],
        warnings: st.motion.iter().cloned().collect(),
    };
    let mut model = BiasModelFile::default();
    let mut added_all: Added = Vec::new();
    for &c in &p.chans {
        let name = CHANNEL_NAMES[c];
        let others = others_of(&p.series, c);
        let input = channel_input(&p.series, p.temp.as_deref(), &others, rate, c);
        let d = match diagnose_channel(&input, &settings) {
            Ok(d) => d,
            Err(e) => {
                writeln!(progress, "{name}: cannot diagnose: {}", why_not(&e, rate))?;
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
        write_plots(out_dir, channel_plots(&d).map_err(anyhow::Error::msg)?)?;
        model
            .channels
            .push(channel_model(name, rate, &d.refit, d.effects.clone()));
        added_all.push((
            name.to_string(),
            d.iterations.iter().map(|it| it.effect.clone()).collect(),
        ));
        report.channels.push(d);
    }
    none_diagnosed(st.log, model.channels.is_empty())?;
    let json = report.to_json().map_err(|e| anyhow!(e.to_string()))?;
    write_outputs(st, &report.to_text(), &json, &model, progress)?;
    Ok(added_all)
}

/// Why a channel could not be diagnosed, for people: a series too short also in seconds at
/// the log's `rate` (the sample counts alone leave the user to work out how long a recording
/// to make).
pub fn why_not(e: &AnalysisError, rate: f64) -> String {
    match *e {
        AnalysisError::Numeric(NumError::TooShort { needed, got }) => format!(
            "{e} (needs {:.0} s of the recording at {} Hz, has {:.1} s)",
            (needed as f64 / rate).ceil(),
            crate::text::trim_decimals(rate, 2),
            got as f64 / rate
        ),
        _ => e.to_string(),
    }
}

/// What both diagnose loops start from: the channels asked for that the log has, every
/// channel's series (empty for a channel absent in the log: a partial sensor) and the
/// temperature (when every sample has one), the report's source line; `out_dir/plots` made.
pub struct Prepared {
    pub chans: Vec<usize>,
    pub series: Vec<Vec<f64>>,
    pub temp: Option<Vec<f64>>,
    pub source: String,
}

/// [`Prepared`] for a stretch; each channel asked for
/// but left out is said on `progress` with why.
pub fn prepare(st: &Stretch, ch: Channels, progress: &mut dyn Write) -> Result<Prepared> {
    ensure!(!ch.is_empty(), "the chosen stretch is empty");
    let (chans, left_out) = present_channels_of(st.log, &ch, &parse_channels(st.channels)?)?;
    for (name, why) in &left_out {
        writeln!(progress, "{name}: skipped: {why}")?;
    }
    let absent = ch.absent();
    let Channels { values, temp_c, .. } = ch;
    let series: Vec<Vec<f64>> = values
        .into_iter()
        .enumerate()
        .map(|(c, v)| {
            if absent & (1 << c) != 0 {
                Vec::new()
            } else {
                v
            }
        })
        .collect();
    let temp = temp_c;
    let plots = st.out_dir.join("plots");
    std::fs::create_dir_all(&plots).with_context(|| format!("creating {}", plots.display()))?;
    let source = format!(
        "{} [{} s .. +{:.1} s at {} Hz]",
        st.log.display(),
        st.from_s,
        st.len as f64 / st.rate,
        st.rate
    );
    Ok(Prepared {
        chans,
        series,
        temp,
        source,
    })
}

/// Each `(stem, svg)` plot into `out_dir/plots/stem.svg`.
pub fn write_plots(out_dir: &Path, plots: Vec<(String, String)>) -> Result<()> {
    for (stem, svg) in plots {
        let p = out_dir.join("plots").join(format!("{stem}.svg"));
        std::fs::write(&p, svg).with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

/// One channel of the model file a diagnosis writes: its Burg AR part (the deployment refit)
/// and its effects.
pub fn channel_model(
    name: &str,
    rate: f64,
    refit: &DeploymentFit,
    effects: Vec<Effect>,
) -> ChannelBiasModel {
    ChannelBiasModel {
        channel: name.to_string(),
        method: "burg".into(),
        sample_rate_hz: rate,
        mean: refit.intercept,
        ar: refit.ar.clone(),
        innovation_var: refit.innovation_var,
        white_noise_var: 0.0,
        effects,
        ..Default::default()
    }
}

/// `report.txt`, `report.json` and `bias.toml` into the stretch's `out_dir`, said on
/// `progress`. On a stretch not at rest ([`Stretch::motion`]) `bias.toml` is headed by the
/// warning, or, without `allow_motion`, not written, and one left there by an earlier run
/// removed (a stale model must not pass for this run's).
pub fn write_outputs(
    st: &Stretch,
    text: &str,
    json: &str,
    model: &BiasModelFile,
    progress: &mut dyn Write,
) -> Result<()> {
    let out_dir = st.out_dir;
    let write = |name: &str, text: &str| {
        let p = out_dir.join(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))
    };
    write("report.txt", text)?;
    write("report.json", json)?;
    if st.motion.is_some() && !st.allow_motion {
        let stale = out_dir.join("bias.toml");
        let removed = if stale.exists() {
            std::fs::remove_file(&stale)
                .with_context(|| format!("removing the earlier {}", stale.display()))?;
            format!("; removed the earlier run's {}", stale.display())
        } else {
            String::new()
        };
        writeln!(
            progress,
            "wrote {0}/report.txt, {0}/report.json and {0}/plots/; no bias.toml (the record is not at rest){removed}",
            out_dir.display()
        )?;
        return Ok(());
    }
    let head: String = st
        .motion
        .iter()
        .map(|w| format!("# WARNING: {w}\n"))
        .collect();
    write(
        "bias.toml",
        &(head + &model.to_toml_string().map_err(|e| anyhow!(e.to_string()))?),
    )?;
    writeln!(
        progress,
        "wrote {0}/report.txt, {0}/report.json, {0}/bias.toml and {0}/plots/",
        out_dir.display()
    )?;
    Ok(())
}
