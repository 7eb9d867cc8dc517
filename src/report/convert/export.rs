//! `imuprep export` and `simulate`: recordings written in another format, and simulated ones.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;

use super::{for_import, protocol_config, through_import};
use crate::io::convert::{ExportFormat, encode_stream, read_any};
use crate::io::csv as csvio;
use crate::io::sim_log::SimLogSummary;
use crate::report::check_input;
use crate::text::count;

/// What `export` wrote.
#[derive(Debug, Clone, Serialize)]
pub struct ExportReport {
    pub output: PathBuf,
    pub samples: usize,
    pub crc_errors: u64,
    pub resyncs: u64,
}

/// Write the samples of `log` (any protocol, or any recording `import` reads, with the
/// recording's import flags) to `output` as `to`.
pub fn export(
    log: &crate::report::Recording,
    output: &Path,
    to: ExportFormat,
) -> Result<ExportReport> {
    let pc = protocol_config(&log.proto);
    let import_flags = log.import.given();
    crate::report::no_import_flags_on_a_log(log, &import_flags)?;
    // Import flags given: the file is read as `import` reads it with them, whatever it is.
    let imports = !import_flags.is_empty() || through_import(log, pc.protocol);
    let (descriptor, samples, stats) = if imports {
        let pc = for_import(&pc, log.proto.protocol.is_some());
        crate::report::imported_log(log, &pc, &log.import, &log.flags())?
    } else {
        let f = read_any(log, &pc)?;
        check_input(log, f.samples.len() as u64, &f.stats)?;
        (f.descriptor, f.samples, f.stats)
    };
    if to == ExportFormat::Csv {
        csvio::write_csv(output, &samples)?;
    } else {
        let d = descriptor.unwrap_or_default();
        let b = encode_stream(to, &d, &samples)?;
        std::fs::write(output, &b).with_context(|| format!("writing {}", output.display()))?;
    }
    Ok(ExportReport {
        output: output.to_path_buf(),
        samples: samples.len(),
        crc_errors: stats.crc_errors,
        resyncs: stats.resyncs,
    })
}

impl fmt::Display for ExportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "exported {} to {} ({}, {} in the log)",
            count(self.samples as u64, "sample", "samples"),
            self.output.display(),
            count(self.crc_errors, "CRC error", "CRC errors"),
            count(self.resyncs, "resync", "resyncs")
        )
    }
}

/// What `simulate` wrote.
#[derive(Debug, Clone, Serialize)]
pub struct SimulateReport {
    pub output: PathBuf,
    pub seed: u64,
    /// What the run wrote (its fields stand beside `output` and `seed` in the JSON).
    #[serde(flatten)]
    pub written: SimLogSummary,
}

/// Simulate `scenario` (with `--set` overrides) into a replay log and an optional truth sidecar.
pub fn simulate(
    scenario: &Path,
    sets: &[String],
    seed: Option<u64>,
    output: &Path,
    truth: Option<&Path>,
) -> Result<SimulateReport> {
    let scn = crate::report::read_scenario(scenario, sets)?;
    let seed = crate::sim::log::effective_seed(&scn, seed);
    let written = crate::io::sim_log::write_sim_log(&scn, seed, output, truth)?;
    Ok(SimulateReport {
        output: output.to_path_buf(),
        seed,
        written,
    })
}

impl fmt::Display for SimulateReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = &self.written;
        writeln!(
            f,
            "simulated {} (seed {}): {} ({} dropped, {} duplicated), {} → {}",
            count(w.instants, "instant", "instants"),
            self.seed,
            count(w.frames, "frame", "frames"),
            w.dropped,
            w.duplicated,
            count(w.bytes, "byte", "bytes"),
            self.output.display()
        )?;
        if w.clipped > 0 {
            writeln!(
                f,
                "clipped at the sensor's range: {} of {} (flagged saturated)",
                count(w.clipped, "channel-sample", "channel-samples"),
                6 * w.instants
            )?;
        }
        Ok(())
    }
}
