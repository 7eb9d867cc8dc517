//! The commands' drivers: each runs library code over recordings (or simulations) and returns a
//! report type (`Display` for people, `Serialize` for machines); `main.rs` only parses the
//! command line and dispatches here. This is the application layer: like `main.rs` it reports
//! errors with `anyhow` (context strings for people), while the floors below return typed errors.

pub mod allan;
pub mod audit;
pub mod calibrate;
pub mod compare;
pub mod convert;
pub mod daemon;
pub mod detector_compare;
pub mod diagnose;
pub mod diagnose_whole;
pub mod evaluate;
pub mod fit;
pub mod flag_review;
pub mod gate_sweep;
pub mod navtest;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, ensure};

use crate::frame::detect::{ProtocolArgs, ProtocolConfig};
use crate::sample::{Channels, Sample, SampleSink};
use convert::ImportArgs;

/// Exit status of an offline command whose input decoded to nothing or was mostly garbage.
pub const INPUT_PROBLEM_EXIT: u8 = 3;

/// An input that decoded to nothing or was mostly garbage: the command failed, loudly, with
/// exit status [`INPUT_PROBLEM_EXIT`].
#[derive(Debug)]
pub struct InputProblem(pub String);

impl std::fmt::Display for InputProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputProblem {}

/// Fail with [`InputProblem`] when `samples` decoded from `what` with `stats` say the input
/// held nothing usable.
pub fn check_input(what: &Path, samples: u64, stats: &crate::frame::DecoderStats) -> Result<()> {
    match stats.input_problem(samples) {
        Some(problem) => Err(
            InputProblem(match crate::frame::detect::foreign_file(what) {
                Some(what_it_is) if samples == 0 => format!("{}: {what_it_is}", what.display()),
                _ => format!("{}: {problem}", what.display()),
            })
            .into(),
        ),
        None => Ok(()),
    }
}

/// A recording as a command is asked to read it: its path, and the flags that say how a file
/// imuprep imports is read (none given: as `imuprep import` reads it with no flags). It is its
/// path where a path is wanted.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct Recording {
    /// The recording: an imuprep log, or any recording `import` reads (a CSV or other text
    /// table, UBX, MAVLink, ULog, MCAP, a bag), read as `import` reads it with the import flags
    /// given, none by default (what the import found is said on stderr).
    #[arg(value_name = "LOG")]
    pub path: PathBuf,
    #[command(flatten)]
    pub proto: ProtocolArgs,
    #[command(flatten)]
    pub import: ImportArgs,
}

impl Recording {
    /// `path`, read with no flags.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Recording {
            path: path.into(),
            ..Default::default()
        }
    }

    /// The flags given, by name.
    pub fn flags(&self) -> Vec<&'static str> {
        [self.proto.given(), self.import.given()].concat()
    }
}

impl std::ops::Deref for Recording {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

/// Refuses import `flags` for an imuprep log: it carries its own units, columns and rate, and
/// a flag it would ignore must not be taken in silence.
pub fn no_import_flags_on_a_log(path: &Path, flags: &[&str]) -> Result<()> {
    let is_log = crate::frame::detect::file_head(path, crate::frame::LOG_MAGIC.len())
        .is_some_and(|h| h.starts_with(&crate::frame::LOG_MAGIC));
    ensure!(
        flags.is_empty() || !is_log,
        "{}: an imuprep log, which carries its own units, columns and rate; the import flags given ({}) are for a recording imuprep imports (a CSV or other table, a sensor protocol's file, a bag)",
        path.display(),
        flags.join(", ")
    );
    Ok(())
}

/// Samples of a log after `skip_s`, with the log's sample rate.
pub fn load_span(log: &Recording, skip_s: f64) -> Result<(f64, Vec<Sample>)> {
    load_span_to(log, skip_s, None)
}

/// Samples of a log after `skip_s`, at most `span_s` seconds of them (streamed: the rest of the
/// file is not read), with the log's sample rate. A recording that is no imuprep log is read as
/// `imuprep import` reads it with the recording's flags; flags on a log are refused.
pub fn load_span_to(
    log: &Recording,
    skip_s: f64,
    span_s: Option<f64>,
) -> Result<(f64, Vec<Sample>)> {
    load_span_into(log, skip_s, span_s)
}

/// [`load_span_to`] held by channel ([`Channels`]): a log is streamed into its columns and
/// never held as samples (an imported recording is, while it is imported).
pub fn load_channels_to(
    log: &Recording,
    skip_s: f64,
    span_s: Option<f64>,
) -> Result<(f64, Channels)> {
    load_span_into(log, skip_s, span_s)
}

/// What [`load_span_into`] can fill.
trait Loaded: SampleSink + Default {
    fn from_samples(v: Vec<Sample>) -> Self;
    fn count(&self) -> usize;
}

impl Loaded for Vec<Sample> {
    fn from_samples(v: Vec<Sample>) -> Self {
        v
    }
    fn count(&self) -> usize {
        self.len()
    }
}

impl Loaded for Channels {
    fn from_samples(v: Vec<Sample>) -> Self {
        v.into()
    }
    fn count(&self) -> usize {
        self.len()
    }
}

fn load_span_into<S: Loaded>(
    log: &Recording,
    skip_s: f64,
    span_s: Option<f64>,
) -> Result<(f64, S)> {
    no_import_flags_on_a_log(log, &log.flags())?;
    // A negative start or a span of no length is a mistake in what was asked, said as such
    // (not as a log that "ends before that").
    ensure!(
        skip_s.is_finite() && skip_s >= 0.0 && span_s.is_none_or(|s| s.is_finite() && s > 0.0),
        "{}: a span must start at ≥ 0 s into the log and last > 0 s (asked: from {skip_s} s{})",
        log.display(),
        span_s.map(|s| format!(" for {s} s")).unwrap_or_default()
    );
    let imported = |log: &Recording| -> Result<_> {
        let (desc, v) = imported_span(log, skip_s, span_s)?;
        Ok((desc, S::from_samples(v)))
    };
    let (desc, samples) = if log.is_dir() {
        imported(log)?
    } else {
        let mut out = S::default();
        match crate::io::log::read_log_span_into(log, skip_s, span_s, &mut out) {
            Ok((desc, _)) => (desc, out),
            Err(crate::io::log::LogError::Header { err, .. }) if err.not_a_log() => {
                drop(out);
                imported(log)?
            }
            Err(e) => return Err(e.into()),
        }
    };
    let rate = desc.map(|d| d.sample_rate_hz).unwrap_or(0.0);
    ensure!(
        rate > 0.0,
        "{}: the log does not declare its sample rate",
        log.display()
    );
    // Named by what was asked, not by one command's flag: fit and compare say --skip-s,
    // diagnose and calibrate --from-s, fit's --train-s sets the span.
    ensure!(
        samples.count() > 0,
        "{}: no samples from {skip_s} s after its start{}: the log ends before that, or the span is empty",
        log.display(),
        span_s.map(|s| format!(" for {s} s")).unwrap_or_default()
    );
    Ok((rate, samples))
}

fn imported_span(
    rec: &Recording,
    skip_s: f64,
    span_s: Option<f64>,
) -> Result<(Option<crate::frame::Descriptor>, Vec<Sample>)> {
    let path = &rec.path;
    let pc = convert::protocol_config(&rec.proto);
    let (desc, mut samples, _) = imported_log(path, &pc, &rec.import, &rec.flags())?;
    let rate = desc.map_or(0.0, |d| d.sample_rate_hz);
    ensure!(
        rate > 0.0,
        "{}: {} imported, but its time stamps give no sample rate (`imuprep import` with --rate sets one)",
        path.display(),
        crate::text::count(samples.len() as u64, "sample", "samples")
    );
    let to_samples = |t: f64| (t * rate).round().max(0.0) as usize;
    let skip = to_samples(skip_s).min(samples.len());
    samples.drain(..skip);
    if let Some(span) = span_s {
        samples.truncate(to_samples(span));
    }
    Ok((desc, samples))
}

/// `path` read as `imuprep import` reads it with the protocol options `pc` and the import flags
/// `import`, what the import found said ([`say_imported`], naming the `flags` given), and the
/// samples taken through the log's frames and decoded again, in place
/// ([`crate::io::log::through_log`]): to the bit what the log `import` writes would give
/// (single-precision values, the decoder's flags), with that decoder's counters.
pub(crate) fn imported_log(
    path: &Path,
    pc: &ProtocolConfig,
    import: &ImportArgs,
    flags: &[&str],
) -> Result<crate::io::log::LogContents> {
    let mut loaded = convert::load_as(path, pc, import)?;
    say_imported(path, &loaded, flags);
    let (d, stats) = crate::io::log::through_log(&loaded.descriptor, &mut loaded.samples);
    Ok((d, loaded.samples, stats))
}

/// What an import of `path` made for a command that takes a log found, said on the log (stderr):
/// the import flags it was read with, and the import's own lines.
fn say_imported(path: &Path, r: &convert::Loaded, flags: &[&str]) {
    if flags.is_empty() {
        tracing::info!(
            "{}: not an imuprep log: read as `imuprep import` reads it, with no flags (`imuprep import {} -o OUT.log` keeps it as a log; the import flags, e.g. --gyro-unit, --columns, --rate, set its units, columns and rate here too)",
            path.display(),
            path.display()
        );
    } else {
        tracing::info!(
            "{}: not an imuprep log: read as `imuprep import` reads it, with {}",
            path.display(),
            flags.join(", ")
        );
    }
    for line in r.decoded.iter().chain(&r.timing).flat_map(|t| t.lines()) {
        // The import's warnings (a stated unit the data contradict, …) stay warnings.
        match line.strip_prefix("WARNING: ") {
            Some(w) => tracing::warn!("import: {w}"),
            None => tracing::info!("import: {line}"),
        }
    }
}

/// Channel names (gx gy gz ax ay az) → indices; none given = all six.
pub fn parse_channels(channels: &[String]) -> Result<Vec<usize>> {
    if channels.is_empty() {
        return Ok((0..6).collect());
    }
    let mut out = Vec::with_capacity(channels.len());
    for c in channels {
        let i = crate::sample::channel_index(c)
            .with_context(|| format!("unknown channel {c:?} (gx gy gz ax ay az)"))?;
        // A channel named twice is analysed once: twice, it was reported twice and written
        // twice into bias.toml, which the daemon then refused ("`gx` appears more than once").
        if !out.contains(&i) {
            out.push(i);
        }
    }
    Ok(out)
}

/// A channel left out of an analysis, and why.
pub type LeftOut = (String, String);

/// The non-finite samples (NaN/Inf: missing values, an all-NaN column) of channel `c` in
/// `samples`: their count and the first one's time, s; `None` when every value is finite.
pub fn non_finite(samples: &[Sample], c: usize) -> Option<(usize, f64)> {
    let bad = |s: &&Sample| !s.channel(c).is_finite();
    let first = samples.iter().find(bad)?;
    Some((samples.iter().filter(bad).count(), first.t_s()))
}

/// [`non_finite`] of a recording held by channel.
pub fn non_finite_of(ch: &Channels, c: usize) -> Option<(usize, f64)> {
    let v = &ch.values[c];
    let first = v.iter().position(|x| !x.is_finite())?;
    // As `Sample::t_s`.
    let t_s = ch.t_ns[first] as f64 * 1e-9;
    Some((v.iter().filter(|x| !x.is_finite()).count(), t_s))
}

/// The channels of `chans` a log's `samples` have, and why each other one is left out (a partial
/// sensor's absent channels: [`Sample::absent`]). A channel absent in any sample is left out:
/// the analyses need every sample of a channel. An error, naming the channels, when none of
/// `chans` is present.
pub fn present_channels(
    log: &Path,
    samples: &[Sample],
    chans: &[usize],
) -> Result<(Vec<usize>, Vec<LeftOut>)> {
    let mut absent_in = [0; 6];
    for (c, n) in absent_in.iter_mut().enumerate() {
        *n = samples.iter().filter(|s| s.is_absent(c)).count();
    }
    present_of(log, absent_in, samples.len(), chans)
}

/// [`present_channels`] of a recording held by channel.
pub fn present_channels_of(
    log: &Path,
    ch: &Channels,
    chans: &[usize],
) -> Result<(Vec<usize>, Vec<LeftOut>)> {
    present_of(log, ch.absent_in, ch.len(), chans)
}

/// [`present_channels`] from the samples in which each channel is absent, of `len`.
fn present_of(
    log: &Path,
    absent_in: [usize; 6],
    len: usize,
    chans: &[usize],
) -> Result<(Vec<usize>, Vec<LeftOut>)> {
    let mut present = Vec::new();
    let mut left_out = Vec::new();
    for &c in chans {
        let name = crate::sample::CHANNEL_NAMES[c];
        match absent_in[c] {
            0 => present.push(c),
            n if n == len => left_out.push((
                name.to_string(),
                "absent: the log has no such channel (a partial sensor); nothing to analyse".into(),
            )),
            n => left_out.push((
                name.to_string(),
                format!("absent in {n} of {len} samples: not analysed"),
            )),
        }
    }
    ensure!(
        !present.is_empty(),
        "{}: no channel to analyse: {} absent in this log (it has {})",
        log.display(),
        left_out
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        {
            let all = (0..6)
                .filter(|&c| absent_in[c] > 0)
                .fold(0u8, |m, c| m | 1 << c);
            let have = crate::sample::channel_names_of(!all & crate::sample::ALL_CHANNELS);
            if have.is_empty() {
                "no sensor channel".to_string()
            } else {
                have.join(", ")
            }
        }
    );
    Ok((present, left_out))
}

/// A scenario file with `--set KEY=VALUE` overrides applied.
pub fn read_scenario(p: &Path, sets: &[String]) -> Result<crate::sim::Scenario> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    let overrides = sets
        .iter()
        .map(|kv| {
            kv.split_once('=')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .with_context(|| format!("--set {kv:?}: expected KEY=VALUE"))
        })
        .collect::<Result<Vec<_>>>()?;
    crate::sim::Scenario::from_toml_str_with(&text, &overrides)
        .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))
}

/// Write `value` as pretty JSON to `path`.
pub fn write_json<T: serde::Serialize + ?Sized>(path: &Path, value: &T) -> Result<()> {
    std::fs::write(path, serde_json::to_string_pretty(value)?)
        .with_context(|| format!("writing {}", path.display()))
}

/// `allan` and `diagnose` assume a record at rest; on one that is not (as `imuprep audit`
/// classifies: the gyro's 1-s roughness varies 2× or more over it) they model the motion as
/// sensor error. The first half of their warning, or `None` at rest or without a gyro to tell.
pub fn not_at_rest(samples: &[crate::sample::Sample], rate_hz: f64) -> Option<String> {
    at_rest_warning(audit::gyro_roughness_ratio(samples, rate_hz)?)
}

/// [`not_at_rest`] of a recording held by channel.
pub fn not_at_rest_of(ch: &Channels, rate_hz: f64) -> Option<String> {
    at_rest_warning(audit::gyro_roughness_ratio_of(ch, rate_hz)?)
}

fn at_rest_warning(r: f64) -> Option<String> {
    (r >= 2.0).then(|| {
        format!(
            "the record is not at rest: the gyro's roughness in 1-s windows varies {r:.1}x over it (99th over 1st percentile; a record at rest stays under 2x, as `imuprep audit` classifies)"
        )
    })
}
