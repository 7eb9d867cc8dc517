//! `imuprep import`: a recording read as the importer reads it (a text table, a sensor
//! protocol's file, a bag), in memory or written as a log; `export` and `simulate` in
//! `export.rs`, the flags every reader takes in `args.rs`.

mod args;
mod export;
mod streamed;

pub use args::{ImportArgs, for_import, parse_columns, parse_positions, protocol_config};
pub use export::{ExportReport, SimulateReport, export, simulate};

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, ensure};
use serde::Serialize;

use super::{InputProblem, check_input};
use crate::frame::detect::{ProtocolArgs, ProtocolChoice, ProtocolConfig};
use crate::io::convert::{read_any_whole, read_files_whole};
use crate::io::csv::{self as csvio, ImportOptions};
use crate::text::count;

/// `input` read as `imuprep import` reads it with the protocol flags `proto` and the import
/// flags `a`.
pub fn load_with(input: &Path, proto: &ProtocolArgs, a: &ImportArgs) -> Result<Loaded> {
    load_as(input, &protocol_config(proto), a)
}

/// `input` read as [`load`] reads it with the protocol options `pc` and the importer's options
/// the flags `a` set (with `--accel-file`: the gyro's and the accelerometer's tables merged).
pub fn load_as(input: &Path, pc: &ProtocolConfig, a: &ImportArgs) -> Result<Loaded> {
    let o = a.options()?;
    match &a.accel_file {
        Some(accel) => {
            let (d, s, report) = csvio::read_per_sensor_report(input, accel, &o)?;
            Ok(loaded(
                input,
                Some(accel),
                (d, s),
                None,
                Some(report.to_string()),
            ))
        }
        None => load(input, pc, &o),
    }
}

/// `.csv` or `.csv.gz`: read as a table whatever the content.
pub fn is_csv_name(p: &Path) -> bool {
    let n = p.to_string_lossy().to_ascii_lowercase();
    n.ends_with(".csv") || n.ends_with(".csv.gz")
}

/// Whether a command that streams recordings (`replay`, `export`) reads `log` through `import`
/// instead: not a native log (nor a file `choice` names a sensor protocol's), and text, a
/// directory, or a bag only `import` reads.
pub fn through_import(log: &Path, choice: ProtocolChoice) -> bool {
    if !matches!(choice, ProtocolChoice::Native | ProtocolChoice::Auto) {
        return false;
    }
    if log.is_dir() {
        return true;
    }
    let head = crate::frame::detect::file_head(log, 16).unwrap_or_default();
    if head.starts_with(&crate::frame::LOG_MAGIC) {
        return false;
    }
    // Text that is no table goes to `import` too: it says why it is none.
    crate::frame::detect::import_only(&head)
        || is_csv_name(log)
        || !matches!(
            crate::io::csv::sniff_file(log),
            crate::io::csv::Sniffed::Binary
        )
}

/// What `import` wrote.
#[derive(Debug, Clone, Serialize)]
pub struct ImportReport {
    pub input: PathBuf,
    /// The accelerometer's own table (`--accel-file`; `input` is then the gyro's).
    pub accel_input: Option<PathBuf>,
    pub output: PathBuf,
    /// `"<protocol> input: <what was found>"` when the input went through a protocol decoder.
    pub decoded: Option<String>,
    /// What a CSV import found in the time stamps (rate, gaps, duplicates, steps backwards).
    pub timing: Option<String>,
    pub samples: usize,
    pub duration_s: f64,
    pub sample_rate_hz: f64,
}

/// A recording read as `import` reads it, held in memory: the samples and what was found.
#[derive(Debug)]
pub struct Loaded {
    pub input: PathBuf,
    pub accel_input: Option<PathBuf>,
    /// `"<protocol> input: <what was found>"` when the input went through a protocol decoder.
    pub decoded: Option<String>,
    /// What the import found in the time stamps (and, for a table, its units and columns).
    pub timing: Option<String>,
    pub descriptor: crate::frame::Descriptor,
    pub samples: Vec<crate::sample::Sample>,
}

impl Loaded {
    /// The samples written to `output` as a native log, and the report of it.
    pub fn write(self, output: &Path) -> Result<ImportReport> {
        let (file, f) = Replacing::new(output)?;
        let mut w = crate::io::log::LogWriter::new(
            std::io::BufWriter::with_capacity(1 << 16, f),
            &self.descriptor,
        );
        let written =
            |r: std::io::Result<()>| r.with_context(|| format!("writing {}", output.display()));
        let mut bar = crate::progress::Delayed::steps(self.samples.len() as u64, "samples written");
        for (k, s) in self.samples.iter().enumerate() {
            written(w.sample(s))?;
            bar.sample_done(k as u64 + 1);
        }
        drop(bar);
        written(w.finish().map(drop))?;
        file.done()?;
        Ok(ImportReport {
            output: output.to_path_buf(),
            samples: self.samples.len(),
            // The span of the stamps: first to last would be negative across a restart.
            duration_s: span_s(&self.samples),
            sample_rate_hz: self.descriptor.sample_rate_hz,
            input: self.input,
            accel_input: self.accel_input,
            decoded: self.decoded,
            timing: self.timing,
        })
    }
}

/// Read `input` as [`import`] does (a text table as `o` says, else any protocol the decoders
/// read, a bag or a bag directory), without writing it. `pc.protocol` other than `Auto` names
/// the protocol (a file is then never read as a table); its options pick the stream (a bag's
/// topic, a ULog instance, …).
pub fn load(input: &Path, pc: &ProtocolConfig, o: &ImportOptions) -> Result<Loaded> {
    match load_or_leave(input, pc, o, false)? {
        Read::Whole(r) => Ok(r),
        // Only with `leave_protocol_file`.
        Read::ProtocolFile => Err(anyhow::anyhow!(
            "{}: left to be streamed, not read",
            input.display()
        )),
    }
}

/// `imuprep import`: `input` read as [`load_with`] reads it, written to `output` as a native
/// log. A single file the protocol decoders read (a native log, UBX, MAVLink, ULog, MCAP) is
/// streamed to the log ([`streamed::import_file`], the same log [`Loaded::write`] writes, never
/// held whole); anything else (a table, a bag, a bag directory) is read whole and written.
pub fn import(
    input: &Path,
    proto: &ProtocolArgs,
    a: &ImportArgs,
    output: &Path,
) -> Result<ImportReport> {
    let pc = protocol_config(proto);
    let o = a.options()?;
    if a.accel_file.is_none() {
        match load_or_leave(input, &pc, &o, true)? {
            Read::Whole(r) => r.write(output),
            Read::ProtocolFile => streamed::import_file(input, &pc, &o, output),
        }
    } else {
        load_as(input, &pc, a)?.write(output)
    }
}

/// What [`read_recording`] did with a recording.
enum Read {
    /// Read it whole.
    Whole(Loaded),
    /// Left it, a single file the protocol decoders read, to be streamed (when asked to).
    ProtocolFile,
}

/// [`load`], or with `leave_protocol_file` [`Read::ProtocolFile`] for a single file the
/// protocol decoders read.
fn load_or_leave(
    input: &Path,
    pc: &ProtocolConfig,
    o: &ImportOptions,
    leave_protocol_file: bool,
) -> Result<Read> {
    if let Some(r) = o.time_from_index_hz {
        ensure!(r.is_finite() && r > 0.0, "--rate must be > 0 Hz");
    }
    let mut r = match read_recording(input, pc, o, leave_protocol_file)? {
        Read::Whole(r) => r,
        left => return Ok(left),
    };
    // `--rebase-time` for every input (a table's reader has already done it: then a no-op):
    // the earliest stamp, the first in any record whose time does not run backwards.
    if o.rebase_time
        && let Some(t0) = r.samples.iter().map(|s| s.t_ns).min()
    {
        for s in &mut r.samples {
            s.t_ns -= t0;
        }
    }
    Ok(Read::Whole(r))
}

/// The flags set in `o` that only a text table's reader reads (its columns, units, rows and
/// time column), by name.
fn table_only_flags(o: &ImportOptions) -> Vec<&'static str> {
    crate::text::flags_set([
        ("--col", o.columns.iter().any(Option::is_some)),
        ("--columns", !o.positions.is_empty()),
        ("--where", o.select.is_some()),
        ("--gyro-unit", o.gyro_unit.is_some()),
        ("--accel-unit", o.accel_unit.is_some()),
        ("--time-unit", o.time_unit.is_some()),
        ("--rate", o.time_from_index_hz.is_some()),
    ])
}

/// Refuses the table-only flags of `o` for `input`, a recording read as `label` (a protocol's,
/// a bag): its messages carry their own units and time stamps, and a flag it would ignore must
/// not be taken in silence.
fn no_table_flags(input: &Path, label: &str, o: &ImportOptions) -> Result<()> {
    let flags = table_only_flags(o);
    ensure!(
        flags.is_empty(),
        "{}: read as {label}, whose messages carry their own units and time stamps: {} read only a text table (its columns, units, rows and time column)",
        input.display(),
        flags.join(", ")
    );
    Ok(())
}

/// [`load_or_leave`] before `--rebase-time`.
fn read_recording(
    input: &Path,
    pc: &ProtocolConfig,
    o: &ImportOptions,
    leave_protocol_file: bool,
) -> Result<Read> {
    // A bag compressed whole (rosbag2's file compression): inflated, then read as what it is.
    #[cfg(any(feature = "ros2", feature = "ros2-sqlite"))]
    if let Some((dir, inflated, said)) = inflate_whole(input)? {
        // What the inflated copy's import says names the input, not the temporary copy.
        let mut r = load(&inflated, pc, o).map_err(|e| {
            let named = input.display().to_string();
            let text = format!("{e:#}")
                .replace(&inflated.display().to_string(), &named)
                .replace(&dir.path().display().to_string(), &named);
            match e.downcast_ref::<InputProblem>() {
                Some(_) => InputProblem(format!("{text} (inflated from zstd)")).into(),
                None => anyhow::anyhow!("{text} (inflated from zstd)"),
            }
        })?;
        r.input = input.to_path_buf();
        r.decoded = Some(match r.decoded {
            Some(d) => format!("{said}; {d}"),
            None => said,
        });
        return Ok(Read::Whole(r));
    }
    // Bags read whole by their own readers (each behind its feature).
    #[cfg(feature = "ros1")]
    if crate::io::ros1::is_bag(input) {
        let bag = crate::io::ros1::read_bag(input, &pc.mcap);
        return import_bag(
            input,
            o,
            "a ROS 1 bag that cannot be imported",
            "ROS 1 bag",
            bag,
        )
        .map(Read::Whole);
    }
    #[cfg(feature = "ros2-sqlite")]
    if crate::io::ros2_db3::is_db3(input) {
        let bag = crate::io::ros2_db3::read_db3(input, &pc.mcap);
        let what = "an SQLite file that cannot be imported as a ROS 2 bag";
        return import_bag(input, o, what, "ROS 2 bag (SQLite)", bag).map(Read::Whole);
    }
    // A directory (a rosbag2 bag is one): its MCAP file, or its files split as rosbag2 splits a
    // long recording, read as one; anything else is said.
    if input.is_dir() {
        let files = bag_dir_files(input)?;
        // One file, or a build that reads no MCAP (its first file then says so).
        if files.len() == 1 || !cfg!(feature = "ros2") {
            return load(&files[0], pc, o).map(Read::Whole);
        }
        let (d, samples, decoded, timing) = decoded(input, read_files_whole(&files, pc)?, o)?;
        let decoded = format!(
            "{} files read as one ({}); {decoded}",
            files.len(),
            names(&files)
        );
        return Ok(Read::Whole(loaded(
            input,
            None,
            (d, samples),
            Some(decoded),
            timing,
        )));
    }
    // A text table by its name (.csv, .csv.gz: read as one whatever its content, as always), or
    // by its content (any other name: text with a consistent delimiter; a binary file goes to
    // the protocol decoders, text that is no table is said to be so).
    let table = if pc.protocol != ProtocolChoice::Auto {
        None
    } else {
        match csvio::sniff_file(input) {
            csvio::Sniffed::Table(f) => Some(f),
            _ if is_csv_name(input) => Some(csvio::TableFormat::default()),
            csvio::Sniffed::Text(why) => {
                return Err(InputProblem(format!(
                    "{}: text, but not a table of numbers: {why} (a table: one row per line, cells separated by commas, semicolons, tabs or spaces, an optional header line)",
                    input.display()
                ))
                .into());
            }
            csvio::Sniffed::Binary => None,
        }
    };
    let (d, samples, decoded, timing) = if let Some(fmt) = table {
        let (d, s, report) = csvio::read_table_report(input, o, &fmt)?;
        if s.is_empty() {
            return Err(InputProblem(format!(
                "{}: no data rows after the header: nothing to import",
                input.display()
            ))
            .into());
        }
        (d, s, None, Some(report.to_string()))
    } else if leave_protocol_file {
        return Ok(Read::ProtocolFile);
    } else {
        // The whole file is at hand: time faults and rate derived over all of it, as for a CSV
        // (`read_any_whole`), not as the streaming decoder learned them.
        let (d, s, decoded, timing) = decoded(input, read_any_whole(input, pc)?, o)?;
        (d, s, Some(decoded), timing)
    };
    Ok(Read::Whole(loaded(
        input,
        None,
        (d, samples),
        decoded,
        timing,
    )))
}

/// A protocol decoder's whole-file result as an import: checked for input that decodes to
/// nothing, the ranges from the options set; the descriptor, the samples, the first line
/// ("<protocol> input: <what was found>") and the time faults.
type Imported = (
    crate::frame::Descriptor,
    Vec<crate::sample::Sample>,
    String,
    Option<String>,
);

fn decoded(
    input: &Path,
    (f, time): (
        crate::frame::detect::DecodedFile,
        Option<crate::io::timing::TimeFaults>,
    ),
    o: &ImportOptions,
) -> Result<Imported> {
    let (f, samples) = f.split();
    let d = checked(input, &f, samples.len() as u64, o)?;
    Ok((d, samples, first_line(&f), Some(timing(&f.stats, time))))
}

/// A protocol decoder's file checked as an import (nothing decoded, mostly garbage, flags only
/// a table's reader reads), and its descriptor with the ranges the options set.
fn checked(
    input: &Path,
    f: &crate::frame::detect::FileDecoding,
    samples: u64,
    o: &ImportOptions,
) -> Result<crate::frame::Descriptor> {
    check_input(input, samples, &f.stats)?;
    no_table_flags(input, &format!("a {} recording", f.protocol), o)?;
    let mut d = f.descriptor.unwrap_or_default();
    d.gyro_range_rad_s = o.gyro_range_rad_s;
    d.accel_range_m_s2 = o.accel_range_m_s2;
    Ok(d)
}

/// The import's first line for a protocol decoder's file: "<protocol> input: <what was found>".
fn first_line(f: &crate::frame::detect::FileDecoding) -> String {
    format!("{} input: {}", f.protocol, f.found)
}

/// What the import says of the time stamps: the time faults derived over the whole file, or
/// (a native log, sequenced by its frame counter) the decoder's own.
fn timing(
    stats: &crate::frame::DecoderStats,
    time: Option<crate::io::timing::TimeFaults>,
) -> String {
    match time {
        Some(tf) => format!("{tf}{}", frame_faults(stats)),
        None => protocol_faults(stats),
    }
}

/// The files' names, comma separated.
fn names(files: &[PathBuf]) -> String {
    files
        .iter()
        .map(|p| p.file_name().unwrap_or_default().to_string_lossy())
        .collect::<Vec<_>>()
        .join(", ")
}

/// A bag read whole ([`crate::io::bag`]): its Imu topic's samples, with time faults and the
/// rate derived over the whole file as for every other import. `what` says the input's
/// error, `label` names it on the import's first line.
#[cfg(any(feature = "ros1", feature = "ros2-sqlite"))]
fn import_bag<E: std::fmt::Display>(
    input: &Path,
    o: &ImportOptions,
    what: &str,
    label: &str,
    bag: std::result::Result<crate::io::bag::BagRead, E>,
) -> Result<Loaded> {
    no_table_flags(input, &format!("a {label}"), o)?;
    let mut bag = bag.map_err(|e| InputProblem(format!("{}: {what}: {e}", input.display())))?;
    if bag.samples.is_empty() {
        return Err(InputProblem(format!(
            "{}: a {label}, but no Imu message could be read: {}",
            input.display(),
            bag.found
        ))
        .into());
    }
    let mut d = bag.descriptor;
    let tf = crate::io::convert::rederive_whole(&mut bag.samples, &mut d);
    d.gyro_range_rad_s = o.gyro_range_rad_s;
    d.accel_range_m_s2 = o.accel_range_m_s2;
    Ok(loaded(
        input,
        None,
        (d, bag.samples),
        Some(format!("{label} input: {}", bag.found)),
        Some(tf.to_string()),
    ))
}

/// rosbag2's file compression (`compression_mode: file`): `input` a file compressed whole with
/// zstd (`bag_0.mcap.zstd`, `bag_0.db3.zstd`; any name: it is told by its content), or a bag
/// directory holding such files (told by their names, `*.mcap.zstd`, `*.db3.zstd`). Each is
/// inflated into a temporary directory under its name without `.zstd`; returned are that
/// directory (removed when dropped), the path to import (the file, or the directory), and what
/// was done, for the import's first line. `None`: nothing compressed so.
#[cfg(any(feature = "ros2", feature = "ros2-sqlite"))]
fn inflate_whole(input: &Path) -> Result<Option<(tempfile::TempDir, PathBuf, String)>> {
    use crate::frame::inflate;
    let compressed =
        |p: &Path| crate::frame::detect::file_head(p, 4).is_some_and(|h| inflate::is_zstd(&h));
    // In a directory only a bag's storage files (another compressed file there is not the
    // bag's, and the directory's own `.mcap` is read as ever).
    let storage = |p: &Path| {
        let name = p.file_name().unwrap_or_default().to_string_lossy();
        name.ends_with(".mcap.zstd") || name.ends_with(".db3.zstd")
    };
    let files: Vec<PathBuf> = if input.is_dir() {
        let mut v: Vec<PathBuf> = std::fs::read_dir(input)
            .with_context(|| format!("{}", input.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && storage(p) && compressed(p))
            .collect();
        v.sort();
        v
    } else if compressed(input) {
        vec![input.to_path_buf()]
    } else {
        Vec::new()
    };
    if files.is_empty() {
        return Ok(None);
    }
    let dir = tempfile::tempdir().context("a temporary directory to inflate the bag into")?;
    let (mut zipped, mut bytes) = (0u64, 0u64);
    let mut last = PathBuf::new();
    for f in &files {
        let data = std::fs::read(f).with_context(|| format!("{}", f.display()))?;
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        let name = name.strip_suffix(".zstd").unwrap_or(&name).to_string();
        last = dir.path().join(&name);
        let mut out = std::io::BufWriter::new(
            std::fs::File::create(&last).with_context(|| format!("{}", last.display()))?,
        );
        let n = inflate::zstd_into(&data, u64::MAX, &mut out)
            .map_err(|e| InputProblem(format!("{}: {e}", f.display())))?;
        std::io::Write::flush(&mut out).with_context(|| format!("{}", last.display()))?;
        zipped += data.len() as u64;
        bytes += n;
    }
    let said = format!(
        "zstd-compressed whole (rosbag2 file compression): {} inflated, {zipped} → {bytes} bytes",
        count(files.len() as u64, "file", "files")
    );
    let path = if input.is_dir() {
        dir.path().to_path_buf()
    } else {
        last
    };
    Ok(Some((dir, path, said)))
}

/// The files to import from a directory: a rosbag2 bag's `.mcap` files, one or several (a
/// split bag, in the order of their split index). A directory of `.db3` files (read above in a
/// `ros2-sqlite` build) is said as the SQLite bag it is, and a directory with neither says so.
fn bag_dir_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let listed = |ext| {
        crate::io::convert::split_files(dir, ext).with_context(|| format!("{}", dir.display()))
    };
    let (mcap, db3) = (listed("mcap")?, listed("db3")?);
    let problem = |why: String| InputProblem(format!("{}: a directory: {why}", dir.display()));
    match (mcap.is_empty(), db3.first()) {
        (false, _) => Ok(mcap),
        (true, Some(db3)) => Err(problem(format!(
            "{}: {}",
            db3.display(),
            crate::frame::detect::foreign_format(b"SQLite format 3\0").unwrap_or("")
        ))
        .into()),
        (true, None) => {
            Err(problem("no .mcap or .db3 bag file in it; name the file to import".into()).into())
        }
    }
}

/// The imported samples and what was said of them.
fn loaded(
    input: &Path,
    accel_input: Option<&Path>,
    (descriptor, samples): (crate::frame::Descriptor, Vec<crate::sample::Sample>),
    decoded: Option<String>,
    timing: Option<String>,
) -> Loaded {
    Loaded {
        input: input.to_path_buf(),
        accel_input: accel_input.map(Path::to_path_buf),
        decoded,
        timing,
        descriptor,
        samples,
    }
}

/// A file written beside `output` (a temporary one in its folder) and put in its place only once
/// it is complete ([`Replacing::done`]): a failed import or export leaves no partial file and an
/// existing `output` as it was, and `output` may be the input itself, which a streamed import or
/// export reads twice and must still be there for the second pass. A link to a file has the file
/// it names replaced; an `output` that is no file (a device or a pipe: `-o /dev/stdout`) cannot
/// be replaced and is written directly, as before.
pub(super) struct Replacing {
    /// The temporary file and the path it is renamed to (`None`: written directly).
    tmp: Option<(tempfile::NamedTempFile, PathBuf)>,
    output: PathBuf,
}

impl Replacing {
    /// The temporary file (or `output` itself), and a handle to write it through.
    pub(super) fn new(output: &Path) -> Result<(Self, std::fs::File)> {
        let made = || format!("creating {}", output.display());
        if std::fs::metadata(output).is_ok_and(|m| !m.is_file()) {
            let f = std::fs::OpenOptions::new()
                .write(true)
                .open(output)
                .with_context(made)?;
            let direct = Replacing {
                tmp: None,
                output: output.to_path_buf(),
            };
            return Ok((direct, f));
        }
        let target = match std::fs::symlink_metadata(output) {
            Ok(m) if m.file_type().is_symlink() => {
                std::fs::canonicalize(output).unwrap_or_else(|_| output.to_path_buf())
            }
            _ => output.to_path_buf(),
        };
        let dir = target
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let mut b = tempfile::Builder::new();
        b.prefix(".imuprep-").suffix(".part");
        // As `File::create` makes it: read and write for all, less the umask.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            b.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let beside = || format!("creating {} (first as a file beside it)", output.display());
        let tmp = b.tempfile_in(dir).with_context(beside)?;
        let f = tmp.as_file().try_clone().with_context(beside)?;
        let r = Replacing {
            tmp: Some((tmp, target)),
            output: output.to_path_buf(),
        };
        Ok((r, f))
    }

    /// The complete file put in `output`'s place.
    pub(super) fn done(self) -> Result<()> {
        if let Some((tmp, target)) = self.tmp {
            let output = self.output;
            tmp.persist(&target)
                .map_err(|e| e.error)
                .with_context(|| format!("writing {}", output.display()))?;
        }
        Ok(())
    }
}

/// Latest minus earliest time stamp, s.
fn span_s(samples: &[crate::sample::Sample]) -> f64 {
    let (lo, hi) = samples
        .iter()
        .fold((u64::MAX, 0), |(l, h), s| (l.min(s.t_ns), h.max(s.t_ns)));
    if samples.is_empty() {
        0.0
    } else {
        (hi - lo) as f64 * 1e-9
    }
}

/// A native log's sequence and frame faults, said at import as a CSV's time faults are (they
/// are flagged on the samples and counted again on replay; a log whose writer dropped a quarter
/// of its samples must not import in silence).
fn protocol_faults(s: &crate::frame::DecoderStats) -> String {
    let t = format!(
        "{}, {}",
        crate::text::time_faults(
            s.gaps,
            s.missing_frames,
            (
                s.duplicates,
                "duplicate time stamp or sequence number",
                "duplicate time stamps or sequence numbers"
            ),
            s.time_backwards
        ),
        count(s.seq_restarts, "restart", "restarts")
    );
    t + &frame_faults(s)
}

/// `; N CRC errors, ...` when the decoder met any frame fault, else nothing.
fn frame_faults(s: &crate::frame::DecoderStats) -> String {
    let n = s.crc_errors + s.header_errors + s.bad_length + s.truncated + s.garbage_bytes;
    if n == 0 {
        return String::new();
    }
    format!(
        "; {}, {}, {}, {}, {}",
        count(s.crc_errors, "CRC error", "CRC errors"),
        count(s.header_errors, "header error", "header errors"),
        count(s.bad_length, "bad length", "bad lengths"),
        count(s.truncated, "truncated frame", "truncated frames"),
        count(s.garbage_bytes, "garbage byte", "garbage bytes")
    )
}

impl fmt::Display for ImportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(d) = &self.decoded {
            writeln!(f, "{d}")?;
        }
        if let Some(t) = &self.timing {
            for line in t.lines() {
                if line.starts_with("WARNING:") {
                    writeln!(f, "{line}")?;
                } else {
                    writeln!(f, "import: {line}")?;
                }
            }
        }
        writeln!(
            f,
            "imported {} ({:.1} s at {:.2} Hz) from {}{} into {}",
            count(self.samples as u64, "sample", "samples"),
            self.duration_s,
            self.sample_rate_hz,
            self.input.display(),
            self.accel_input
                .as_ref()
                .map_or(String::new(), |a| format!(" and {}", a.display())),
            self.output.display()
        )
    }
}
