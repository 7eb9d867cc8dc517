//! `imuprep run` and `replay`: the daemon's pipeline from a config until the source ends (or
//! SIGINT/SIGTERM), returning the final health summary.

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, ensure};

use crate::config::{Config, SourceConfig};
use crate::frame::LogHeaderError;
use crate::frame::detect::{ProtocolArgs, ProtocolChoice};
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
/// flags applied and the log's declared rate given to the stages. A recording no streaming
/// decoder reads but `import` does (a CSV or other text table, a bag directory, a ROS 1 or
/// SQLite bag in a build that imports them) is imported with no flags into a temporary log,
/// what the import found said on stderr, and that log replayed; with `--protocol` naming a
/// sensor protocol the file is that protocol's, as ever, and with none a file that decodes as
/// one is replayed as it.
pub fn replay_config(
    mut cfg: Config,
    log: PathBuf,
    speed: f64,
    proto: &ProtocolArgs,
) -> Result<Replay> {
    proto.apply(&mut cfg.protocol);
    let errs = cfg.protocol.validate();
    ensure!(errs.is_empty(), "{errs:?}");
    ensure!(speed.is_finite() && speed >= 0.0, "--speed must be ≥ 0");
    // No --protocol and a file that is no native log but decodes as a sensor protocol: replayed
    // as that protocol (as `--protocol auto` does), said; `--protocol native` keeps the refusal
    // that names the flag.
    if proto.protocol.is_none()
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
    let (log, imported) = if super::convert::through_import(&log, cfg.protocol.protocol) {
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("imported.log");
        let loaded = super::convert::load(&log, proto, &Default::default())?;
        super::say_imported(&log, &loaded);
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

/// Write the health summary as JSON when asked.
pub fn write_summary(health: &Health, path: Option<&Path>) -> Result<()> {
    match path {
        Some(p) => super::write_json(p, health),
        None => Ok(()),
    }
}
