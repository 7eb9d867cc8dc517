//! `imuprep run` and `replay`: the daemon's pipeline from a config until the source ends (or
//! SIGINT/SIGTERM), returning the final health summary.

use std::path::Path;

use anyhow::{Result, anyhow, ensure};

use crate::config::{Config, SourceConfig};
use crate::frame::LogHeaderError;
use crate::frame::detect::ProtocolChoice;
use crate::runtime::Health;

/// `--out SPEC` flags → extra sinks of `cfg`; every bad spec is reported at once.
pub fn add_outs(cfg: &mut Config, outs: &[String]) -> Result<()> {
    let mut errs = Vec::new();
    for o in outs {
        match crate::runtime::parse_out_spec(o) {
            Ok(s) => cfg.sinks.push(s),
            Err(e) => errs.push(format!("--out {o}: {e}")),
        }
    }
    ensure!(errs.is_empty(), "{}", errs.join("\n"));
    Ok(())
}

/// A replay's config, and the temporary directory holding the log `import` made of its input
/// when the input was imported (removed when this is dropped: keep it until the run ends).
pub struct Replay {
    pub cfg: Config,
    pub imported: Option<tempfile::TempDir>,
}

/// `cfg` turned into a replay of `log` at `speed` (0 = as fast as possible), with the protocol
/// flags applied, then made ready as [`replay_source`] says. With `--protocol` naming a sensor
/// protocol the file is that protocol's, as ever; `--protocol native` keeps the refusal of a
/// file that is no native log.
pub fn replay_config(
    mut cfg: Config,
    log: &super::Recording,
    speed: f64,
    summary: Option<&Path>,
) -> Result<Replay> {
    log.proto.apply(&mut cfg.protocol);
    cfg.source = SourceConfig::Replay {
        path: log.path.clone(),
        speed,
    };
    replay_source(cfg, log.proto.protocol.is_some(), &log.import, summary)
}

/// A config whose source replays a file (`imuprep replay`, or `imuprep run` with `[source]
/// kind = "replay"`) made ready to run, the same way for both. A recording no streaming decoder
/// reads but `import` does (a CSV or other text table, a bag directory, a ROS 1 or SQLite bag
/// in a build that imports them) is imported with the source's protocol options and the import
/// flags `import` into a temporary log, what the import found said on stderr, and that log
/// replayed; so is any file that is no imuprep log when import flags are given (they are
/// refused for a log).
/// Unless `protocol_named`, a native source whose file is no native log but decodes as a
/// sensor protocol is replayed as that protocol, said. The log's declared rate is given to the
/// stages. Any other source is returned as it is.
///
/// First of all the outputs are checked ([`outputs_apart`], with `summary`, the health
/// summary's JSON file): a CSV or a bag is imported whole and then replayed from a temporary
/// log, so an output onto the recording would otherwise pass the check in [`run`] and
/// overwrite it with the cleaned samples.
pub fn replay_source(
    mut cfg: Config,
    protocol_named: bool,
    import: &super::convert::ImportArgs,
    summary: Option<&Path>,
) -> Result<Replay> {
    outputs_apart(&cfg, summary)?;
    let SourceConfig::Replay { path: log, speed } = cfg.source.clone() else {
        return Ok(Replay {
            cfg,
            imported: None,
        });
    };
    let errs = cfg.protocol.validate();
    ensure!(errs.is_empty(), "{errs:?}");
    ensure!(speed.is_finite() && speed >= 0.0, "--speed must be ≥ 0");
    let flags = import.given();
    super::no_import_flags_on_a_log(&log, &flags)?;
    if !protocol_named
        && cfg.protocol.protocol == ProtocolChoice::Native
        && let Err(crate::io::log::LogError::Header {
            err: LogHeaderError::LooksLike(p, _),
            ..
        }) = crate::io::csv::read_descriptor(&log)
    {
        tracing::info!(
            "{}: not an imuprep log: it decodes as {p}, replayed as that (as `--protocol auto` does; `--protocol NAME` names one)",
            log.display()
        );
        cfg.protocol.protocol = ProtocolChoice::Auto;
    }
    let imports = !flags.is_empty() || super::convert::through_import(&log, cfg.protocol.protocol);
    let (log, imported) = if imports {
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("imported.log");
        let pc = super::convert::for_import(&cfg.protocol, protocol_named);
        let loaded = super::convert::load_as(&log, &pc, import)?;
        super::say_imported(&log, &loaded, &flags);
        loaded.write(&path)?;
        (path, Some(dir))
    } else {
        (log, None)
    };
    // The log declares its rate: the stages use it rather than the config's nominal one.
    if let Ok(Some(d)) = crate::io::csv::read_descriptor(&log) {
        cfg.stages.set_sample_rate(d.sample_rate_hz)?;
    }
    cfg.source = SourceConfig::Replay { path: log, speed };
    Ok(Replay { cfg, imported })
}

/// Build the pipeline and run the daemon on a two-thread runtime until its source ends.
pub fn run(cfg: &Config) -> Result<Health> {
    no_output_overwrites(cfg)?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let pipeline = cfg.stages.build().map_err(|e| anyhow!(e))?;
    tracing::info!(stages = ?pipeline.stage_names(), "pipeline ready");
    let health = rt.block_on(crate::runtime::run(cfg, pipeline));
    // A stuck sink may still sit in a blocking write (stdout nobody reads): do not wait for it.
    rt.shutdown_timeout(std::time::Duration::from_secs(1));
    health
}

/// Refuses a sink whose file is the recording a replay source reads: the sink creates (so
/// truncates) its file before the source has read a byte (or, for an imported recording, writes
/// the cleaned samples over it), and the recording would be lost.
/// Two sinks onto one file are refused too: each creates it and both write, so the file holds
/// a mix of the two (it did, reported as two successes).
fn no_output_overwrites(cfg: &Config) -> Result<()> {
    outputs_apart(cfg, None)
}

/// [`no_output_overwrites`] with the health summary's JSON file (`--summary-json`, written when
/// the run ends) counted as one more output: onto the recording or a sink's file it replaced
/// them whole (it did).
fn outputs_apart(cfg: &Config, summary: Option<&Path>) -> Result<()> {
    use crate::config::Sink;
    let paths: Vec<&Path> = cfg
        .sinks
        .iter()
        .filter_map(|sink| match sink {
            Sink::File { path, .. } | Sink::Mcap { path, .. } => Some(path.as_path()),
            Sink::Inline { path } => path.as_deref(),
            _ => None,
        })
        .chain(summary)
        .collect();
    // A device or a pipe (`/dev/null`, `/dev/stdout`) is not overwritten: two may share one.
    let file = |p: &Path| std::fs::metadata(p).map_or(true, |m| m.is_file());
    for (i, a) in paths.iter().enumerate().filter(|(_, p)| file(p)) {
        if let Some(b) = paths[i + 1..].iter().find(|b| crate::io::same_file(a, b)) {
            return Err(super::InputProblem(format!(
                "two outputs write one file ({} and {}): each would overwrite the other's samples; give each its own",
                a.display(),
                b.display()
            ))
            .into());
        }
    }
    let SourceConfig::Replay { path: input, .. } = &cfg.source else {
        return Ok(());
    };
    // A recording that is not there is said as such where it is opened.
    if !input.exists() {
        return Ok(());
    }
    for p in paths {
        if crate::io::same_file(p, input) {
            return Err(super::InputProblem(format!(
                "the output {} is the recording being replayed: writing it would erase the recording before it is read; write to another file",
                p.display()
            ))
            .into());
        }
    }
    Ok(())
}

/// Write the health summary as JSON when asked.
pub fn write_summary(health: &Health, path: Option<&Path>) -> Result<()> {
    match path {
        Some(p) => super::write_json(p, health),
        None => Ok(()),
    }
}
