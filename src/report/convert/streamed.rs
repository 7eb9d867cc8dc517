//! `imuprep import` of a single file the protocol decoders read (a native log, UBX, MAVLink,
//! ULog, MCAP), streamed: the file is decoded twice and never held, neither its bytes nor its
//! samples. The first pass checks the input and learns what the whole-file import learns before
//! it writes anything — the descriptor, the earliest and latest stamp, and for a protocol whose
//! decoder derives the sequence from time the nominal interval ([`Stamps`], 8 bytes a sample);
//! the second sequences and flags each sample by that rule ([`Sequencer`]) as it is decoded and
//! writes it. The log is the one [`super::Loaded::write`] writes after [`super::load`]; only
//! the memory differs (`tests/streamed_convert.rs` compares the two).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use anyhow::{Context, Result, ensure};

use super::{ImportReport, Replacing, checked, first_line, timing};
use crate::frame::Protocol;
use crate::frame::detect::{ProtocolConfig, decode_file_into};
use crate::io::convert::time_counters_from;
use crate::io::csv::ImportOptions;
use crate::io::log::LogWriter;
use crate::io::timing::{Sequencer, Stamps};
use crate::sample::{Sample, SampleSink, flags};

/// `input` imported to the log `output` in two passes (see the module docs).
pub(super) fn import_file(
    input: &Path,
    pc: &ProtocolConfig,
    o: &ImportOptions,
    output: &Path,
) -> Result<ImportReport> {
    let mut seen = Survey::default();
    let f = decode_file_into(input, pc, &mut seen)?;
    let mut d = checked(input, &f, seen.samples, o)?;
    // A native log keeps its frame counter's sequence; any other protocol is sequenced from
    // its stamps over the whole file, as a CSV is (`read_any_whole`).
    let mut sequencer = (f.protocol != Protocol::Native).then(|| seen.stamps.sequencer());
    if let Some(q) = &sequencer {
        let rate = q.faults().nominal_rate_hz;
        if rate > 0.0 {
            d.sample_rate_hz = rate;
        }
    }
    let (lo, hi) = seen.span;
    // Written beside `output` and put in place when complete: `output` may be the input.
    let (file, out) = Replacing::new(output)?;
    let mut w = Writing {
        w: LogWriter::new(BufWriter::with_capacity(1 << 16, out), &d),
        sequencer: sequencer.as_mut(),
        // `--rebase-time`: the earliest stamp.
        t0: if o.rebase_time { lo } else { 0 },
        samples: 0,
        failed: None,
        bar: crate::progress::samples_bar(seen.samples, "samples imported"),
    };
    decode_file_into(input, pc, &mut w)?;
    w.bar.finish_and_clear();
    let written = w.samples;
    let failed = w.failed.take();
    let finished = w.w.finish();
    if let Some(e) = failed.map(Err).unwrap_or(finished.map(drop)).err() {
        return Err(e).with_context(|| format!("writing {}", output.display()));
    }
    // The same bytes decode to the same samples: a file changed under the import is said.
    ensure!(
        written == seen.samples,
        "{} changed while it was imported ({} samples, then {written}): {} is not a copy of it",
        input.display(),
        seen.samples,
        output.display()
    );
    file.done()?;
    let mut stats = f.stats;
    let time = sequencer.map(|q| {
        let tf = q.faults();
        time_counters_from(&mut stats, &tf);
        tf
    });
    Ok(ImportReport {
        input: input.to_path_buf(),
        accel_input: None,
        output: output.to_path_buf(),
        decoded: Some(first_line(&f)),
        timing: Some(timing(&stats, time)),
        samples: seen.samples as usize,
        // The span of the stamps: first to last would be negative across a restart.
        duration_s: (hi - lo) as f64 * 1e-9,
        sample_rate_hz: d.sample_rate_hz,
    })
}

/// The first pass: the samples counted, their stamps learned, the earliest and latest stamp.
struct Survey {
    samples: u64,
    stamps: Stamps,
    span: (u64, u64),
}

impl Default for Survey {
    fn default() -> Self {
        Survey {
            samples: 0,
            stamps: Stamps::default(),
            span: (u64::MAX, 0),
        }
    }
}

impl SampleSink for Survey {
    fn expect(&mut self, _: usize) {}
    fn push(&mut self, s: Sample) {
        self.samples += 1;
        self.stamps.push(s.t_ns);
        self.span = (self.span.0.min(s.t_ns), self.span.1.max(s.t_ns));
    }
}

/// The second pass: each sample sequenced and flagged afresh (the `GAP` and `DUPLICATE` flags
/// the decoder set are replaced, as [`crate::io::timing::rederive_sequence`] replaces them),
/// its time rebased, and written; the first write error kept (nothing more is written).
struct Writing<'a> {
    w: LogWriter<BufWriter<File>>,
    sequencer: Option<&'a mut Sequencer>,
    t0: u64,
    samples: u64,
    failed: Option<std::io::Error>,
    bar: indicatif::ProgressBar,
}

impl SampleSink for Writing<'_> {
    fn expect(&mut self, _: usize) {}
    fn push(&mut self, mut s: Sample) {
        self.samples += 1;
        if self.samples.is_multiple_of(crate::progress::SAMPLE_STEP) {
            self.bar.inc(crate::progress::SAMPLE_STEP);
        }
        if self.failed.is_some() {
            return;
        }
        if let Some(q) = self.sequencer.as_mut() {
            s.flags &= !(flags::GAP | flags::DUPLICATE);
            q.next(&mut s);
        }
        s.t_ns = s.t_ns.saturating_sub(self.t0);
        if let Err(e) = self.w.sample(&s) {
            self.failed = Some(e);
        }
    }
}
