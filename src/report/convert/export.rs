//! `imuprep export` and `simulate`: recordings written in another format, and simulated ones.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, ensure};
use serde::Serialize;

use super::{Replacing, for_import, protocol_config, through_import};
use crate::frame::Descriptor;
use crate::frame::detect::decode_file_into;
use crate::io::convert::{ExportFormat, ExportWriter, exportable};
use crate::io::sim_log::SimLogSummary;
use crate::report::check_input;
use crate::sample::{Sample, SampleSink};
use crate::text::count;
use std::fs::File;
use std::io::BufWriter;

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
///
/// A recording the decoders read (a native log, UBX, MAVLink, ULog, MCAP) is streamed, never
/// held: a first pass decodes it for its checks (input problems, the descriptor, the channels it
/// lacks, which ULog must be able to mark) before anything is written, a second writes each
/// sample as it is decoded ([`ExportWriter`]). A recording read as `import` reads it is held
/// whole, as the import needs it (time faults derived over the whole file). `output` is
/// written beside itself and put in place when complete ([`Replacing`]): it may be the input.
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
    let create =
        |d: &Descriptor, absent: u8| -> Result<(ExportWriter<BufWriter<File>>, Replacing)> {
            exportable(to, absent)?;
            let (file, f) = Replacing::new(output)?;
            Ok((ExportWriter::new(to, d, BufWriter::new(f))?, file))
        };
    let written =
        |r: std::io::Result<()>| r.with_context(|| format!("writing {}", output.display()));
    let (samples, stats) = if imports {
        let pc = for_import(&pc, log.proto.protocol.is_some());
        let (d, samples, stats) = crate::report::imported_log(log, &pc, &log.import, &log.flags())?;
        let d = d.unwrap_or_default();
        let (mut w, file) = create(&d, samples.iter().fold(d.absent, |m, s| m | s.absent))?;
        for s in &samples {
            written(w.push(s))?;
        }
        written(w.finish().map(drop))?;
        file.done()?;
        (samples.len(), stats)
    } else {
        let mut seen = Survey::default();
        let f = decode_file_into(log, &pc, &mut seen)?;
        check_input(log, seen.samples as u64, &f.stats)?;
        let d = f.descriptor.unwrap_or_default();
        let (w, file) = create(&d, seen.absent | d.absent)?;
        let bar = crate::progress::samples_bar(seen.samples as u64, "samples exported");
        let mut w = Writing {
            w,
            failed: None,
            bar,
        };
        decode_file_into(log, &pc, &mut w)?;
        w.bar.finish_and_clear();
        if let Some(e) = w.failed {
            written(Err(e))?;
        }
        // The same bytes decode to the same samples: a file changed under the export is said.
        ensure!(
            w.w.samples() == seen.samples as u64,
            "{} changed while it was exported ({} samples, then {}): {} is not a copy of it",
            log.display(),
            seen.samples,
            w.w.samples(),
            output.display()
        );
        written(w.w.finish().map(drop))?;
        file.done()?;
        (seen.samples, f.stats)
    };
    Ok(ExportReport {
        output: output.to_path_buf(),
        samples,
        crc_errors: stats.crc_errors,
        resyncs: stats.resyncs,
    })
}

/// What the first pass of an export learns: how many samples, and the channels any lacks.
#[derive(Default)]
struct Survey {
    samples: usize,
    absent: u8,
}

impl SampleSink for Survey {
    fn expect(&mut self, _: usize) {}
    fn push(&mut self, s: Sample) {
        self.samples += 1;
        self.absent |= s.absent;
    }
}

/// The second pass: each sample written; the first write error kept (and nothing more written).
struct Writing {
    w: ExportWriter<BufWriter<File>>,
    failed: Option<std::io::Error>,
    bar: indicatif::ProgressBar,
}

impl SampleSink for Writing {
    fn expect(&mut self, _: usize) {}
    fn push(&mut self, s: Sample) {
        if self.failed.is_none()
            && let Err(e) = self.w.push(&s)
        {
            self.failed = Some(e);
        }
        if self
            .w
            .samples()
            .is_multiple_of(crate::progress::SAMPLE_STEP)
        {
            self.bar.inc(crate::progress::SAMPLE_STEP);
        }
    }
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
    // Two of the files one: the log and the truth written into one file (unreadable), or the
    // scenario replaced by what was made of it.
    let files = [
        ("the scenario", Some(scenario)),
        ("-o", Some(output)),
        ("--truth", truth),
    ];
    for (i, (what, a)) in files.iter().enumerate() {
        for (other, b) in &files[i + 1..] {
            if let (Some(a), Some(b)) = (a, b)
                && crate::io::same_file(a, b)
            {
                return Err(crate::report::InputProblem(format!(
                    "{what} and {other} are one file ({}): give each its own",
                    b.display()
                ))
                .into());
            }
        }
    }
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
