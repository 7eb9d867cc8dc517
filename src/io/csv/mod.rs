//! CSV import (canonical and vendor column layouts) and export.
//!
//! Canonical CSV: header `t,gx,gy,gz,ax,ay,az,temp` in s, rad/s, m/s², °C; `temp` may be empty
//! or missing; extra columns are ignored. A channel column empty in every row is an absent
//! channel; an empty cell in a column with values elsewhere is a missing value (NaN, counted).
//! Other layouts are matched by column name tokens ([`columns`]: `gyro_x_dps`, `Accelerometer X
//! (g)`, EuRoC's `w_RS_S_x [rad s^-1]`, ROS's `field.angular_velocity.x`, `accX`, `gX`, `wx`,
//! `rotationRateX`, ...). Units come from an option, else the column name; a unit neither
//! states is checked against the data ([`units`]: the accelerometer's median |f|, the gyro's
//! range and its agreement with the turning of gravity's direction, the time column's rate),
//! never silently assumed; canonical and ROS names keep SI when the data cannot tell. Every
//! decision is in [`ImportReport::units`], every contradiction of a stated unit a warning.

use crate::frame::Descriptor;
use crate::io::format::{CSV_HEADER, write_csv_row};
/// The log reader and writer live in [`crate::io::log`]; re-exported here for older callers.
pub use crate::io::log::{read_descriptor, read_log, read_log_span, write_log};
use crate::io::timing::{TimeFaults, derive_sequence};
use crate::sample::{ALL_CHANNELS, Sample, channel_names_of};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};

/// Standard gravity, m/s² per g.
pub const G0: f64 = 9.80665;

/// Angular-rate unit of the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GyroUnit {
    #[value(name = "rad/s")]
    RadS,
    #[value(name = "deg/s")]
    DegS,
}
/// Specific-force unit of the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AccelUnit {
    #[value(name = "m/s2")]
    MS2,
    #[value(name = "g")]
    G,
}
/// Time unit of the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TimeUnit {
    S,
    Ms,
    Us,
    Ns,
}

impl TimeUnit {
    fn ns_per_unit(self) -> f64 {
        match self {
            TimeUnit::S => 1e9,
            TimeUnit::Ms => 1e6,
            TimeUnit::Us => 1e3,
            TimeUnit::Ns => 1.0,
        }
    }
}

/// How to read a CSV. `None` fields are detected from the header.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// Column names for t, gx, gy, gz, ax, ay, az, temp (in that order); `None` = detect.
    pub columns: [Option<String>; 8],
    /// The columns by position (`--columns t,gx,gy,gz,ax,ay,az`): for each column of the file in
    /// order, the key it holds (0..8 as in `columns`) or `None` (`_`, skipped); columns past the
    /// list are skipped too. Empty: the header names them. A header line, if the file has one,
    /// is then skipped and its names not used.
    pub positions: Vec<Option<usize>>,
    pub gyro_unit: Option<GyroUnit>,
    pub accel_unit: Option<AccelUnit>,
    pub time_unit: Option<TimeUnit>,
    /// Ignore the time column and use index / rate (for bursty host timestamps).
    pub time_from_index_hz: Option<f64>,
    /// Subtract the first time stamp so the log starts at t = 0.
    pub rebase_time: bool,
    pub gyro_range_rad_s: f32,
    pub accel_range_m_s2: f32,
    pub device_id: u32,
}

/// Why an import or export failed.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    #[error("{path}: {err}")]
    Io { path: PathBuf, err: std::io::Error },
    #[error("{path}: empty file (no header line)")]
    Empty { path: PathBuf },
    #[error("{path}: {msg}; header columns are: {header}")]
    Columns {
        path: PathBuf,
        msg: String,
        header: String,
    },
    #[error(
        "{path}:{line}: no header: the first row is all numbers ({row}); name the columns by position with --columns, e.g. --columns {example} (keys t gx gy gz ax ay az temp, `_` skips a column)"
    )]
    Headerless {
        path: PathBuf,
        line: usize,
        row: String,
        example: String,
    },
    #[error("{path}:{line}:{col}: cannot read {cell:?} as a number ({})", column_words(.name))]
    Cell {
        path: PathBuf,
        line: usize,
        col: usize,
        cell: String,
        name: String,
    },
    #[error("{path}:{line}: {msg}")]
    Row {
        path: PathBuf,
        line: usize,
        msg: String,
    },
}

/// `column NAME`, or the name alone when it says so already (`column 3`, a column named by
/// position).
fn column_words(name: &str) -> String {
    if name.starts_with("column ") {
        name.to_string()
    } else {
        format!("column {name}")
    }
}

/// The keys of `--col` and `--columns`, in the order of [`ImportOptions::columns`].
pub const CANON: [&str; 8] = ["t", "gx", "gy", "gz", "ax", "ay", "az", "temp"];

pub mod columns;
pub mod sniff;
pub mod units;

pub use sniff::{Delimiter, Sniffed, TableFormat, sniff_file};

/// `--columns t,gx,gy,gz,ax,ay,az`: the key of each column by position (`_` skips one); each key
/// at most once.
pub fn parse_positions(spec: &str) -> Result<Vec<Option<usize>>, String> {
    let mut out = Vec::new();
    for (i, k) in spec.split(',').map(str::trim).enumerate() {
        if k == "_" {
            out.push(None);
            continue;
        }
        let key = CANON.iter().position(|c| *c == k).ok_or_else(|| {
            format!(
                "--columns {spec:?}: {k:?} (column {}) is not one of t gx gy gz ax ay az temp or _",
                i + 1
            )
        })?;
        if out.contains(&Some(key)) {
            return Err(format!("--columns {spec:?}: {k} named twice"));
        }
        out.push(Some(key));
    }
    if out.iter().all(Option::is_none) {
        return Err(format!("--columns {spec:?}: names no column"));
    }
    Ok(out)
}

/// A `--columns` example for a row of `n` cells: t, gx..az in order, `_` for the rest.
fn positions_example(n: usize) -> String {
    (0..n.max(2))
        .map(|i| *CANON[..7].get(i).unwrap_or(&"_"))
        .collect::<Vec<_>>()
        .join(",")
}

use columns::NameUnit;

/// Resolved column indices and what the names say of the units.
#[derive(Debug, Clone)]
struct Layout {
    idx: [Option<usize>; 8],
    gyro: NameUnit<GyroUnit>,
    accel: NameUnit<AccelUnit>,
    time: Option<(TimeUnit, String)>,
    /// Channels without a column (bit `c` for channel `c`).
    absent: u8,
}

fn detect(header: &[String], o: &ImportOptions, path: &Path) -> Result<Layout, CsvError> {
    let err = |msg: String| CsvError::Columns {
        path: path.into(),
        msg,
        header: header.join(","),
    };
    let idx = columns::resolve(header, o).map_err(err)?;
    // A channel without a column is absent (a gyro-only or accel-only sensor, a single axis);
    // a file with none of the six has no sensor data at all.
    let absent = (0..6)
        .filter(|c| idx[c + 1].is_none())
        .fold(0u8, |m, c| m | 1 << c);
    let by_position = !o.positions.is_empty();
    if absent == ALL_CHANNELS {
        return Err(err(if by_position {
            "no sensor column: --columns names none of gx, gy, gz, ax, ay, az".into()
        } else {
            "no sensor column: none of gx, gy, gz, ax, ay, az found (name them so, or pass --col gx=NAME ...)"
                .into()
        }));
    }
    if idx[0].is_none() && o.time_from_index_hz.is_none() {
        return Err(err(if by_position {
            "missing time column (name one t in --columns, or pass --rate HZ to time by index)"
                .into()
        } else {
            "missing time column (name it \"t\", or pass --col t=NAME, or --rate HZ to time by index)".into()
        }));
    }
    Ok(Layout {
        gyro: columns::gyro_named(header, &idx),
        accel: columns::accel_named(header, &idx),
        time: columns::time_named(header, &idx),
        idx,
        absent,
    })
}

fn open_text(path: &Path) -> Result<Box<dyn BufRead>, CsvError> {
    let f = std::fs::File::open(path).map_err(|err| CsvError::Io {
        path: path.into(),
        err,
    })?;
    let r: Box<dyn Read> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(flate2::read::MultiGzDecoder::new(f))
    } else {
        Box::new(f)
    };
    Ok(Box::new(BufReader::with_capacity(1 << 16, r)))
}

/// The empty cells of one present channel (a column with values in other rows): each imported
/// as a missing value (NaN), which the decoders and the pipeline flag `NON_FINITE`.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct EmptyCells {
    pub channel: String,
    pub cells: u64,
    /// Line in the file (1 = the header) of the first.
    pub first_line: usize,
}

/// Which column an import read for one of t, gx..az, temp.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ColumnUse {
    pub key: &'static str,
    pub column: String,
}

/// What an import found besides the samples.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ImportReport {
    /// How the text table was read when it is not a comma-separated file with its header on
    /// line 1: the delimiter, decimal commas, comment lines skipped, no header.
    pub table: Option<TableFormat>,
    /// Rows read (= samples).
    pub rows: u64,
    /// The columns read (absent channels and, with `--rate`, the time column left out).
    pub columns: Vec<ColumnUse>,
    /// How the time, gyro and accel units were decided (stated, convention or inferred from the
    /// data, with the evidence).
    pub units: Vec<units::UnitFinding>,
    /// The data contradicting a stated unit (never overridden: the flag to pass is named).
    pub warnings: Vec<String>,
    /// Sequence and time faults derived from the time stamps (all zero with `--rate`).
    pub time: TimeFaults,
    /// Channels the file does not have (no column, or a column empty in every row): written as
    /// absent (the descriptor's absent mask, NaN values), never as zeros.
    pub absent: Vec<String>,
    /// Present channels with some empty cells, in channel order (rows kept, values NaN).
    pub empty_cells: Vec<EmptyCells>,
    /// Rows whose every present channel is empty (counted in `empty_cells` too): kept as
    /// samples with no value, their time stamp holding the time base.
    pub empty_rows: u64,
    /// Line of the first such row.
    pub first_empty_row: Option<usize>,
}

impl std::fmt::Display for ImportReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(t) = &self.table {
            writeln!(f, "table: {t}")?;
        }
        write!(
            f,
            "{}; {}",
            crate::text::count(self.rows, "row", "rows"),
            self.time
        )?;
        if !self.absent.is_empty() {
            write!(
                f,
                "; channels absent (no column, or every cell empty): {} — written as absent, not as zeros",
                self.absent.join(", ")
            )?;
        }
        // Missing values on a line of their own: a user must see them, not find them at the
        // end of the time summary.
        if !self.empty_cells.is_empty() {
            let each: Vec<String> = self
                .empty_cells
                .iter()
                .map(|e| {
                    format!(
                        "{}: {} (first at line {})",
                        e.channel,
                        crate::text::count(e.cells, "empty cell", "empty cells"),
                        e.first_line
                    )
                })
                .collect();
            write!(
                f,
                "\n{} — imported as missing values (NaN), rows kept, flagged non-finite by the pipeline",
                each.join(", ")
            )?;
        }
        if let Some(line) = self.first_empty_row {
            write!(
                f,
                "\n{} with every channel empty (first at line {}) — kept, with no value (the time stamp holds the time base), flagged non-finite by the pipeline",
                crate::text::count(self.empty_rows, "row", "rows"),
                line
            )?;
        }
        if !self.columns.is_empty() {
            let each: Vec<String> = self
                .columns
                .iter()
                .map(|c| format!("{}={}", c.key, c.column))
                .collect();
            write!(f, "\ncolumns: {}", each.join(", "))?;
        }
        for u in &self.units {
            write!(f, "\n{u}")?;
        }
        for w in &self.warnings {
            write!(f, "\nWARNING: {w}")?;
        }
        Ok(())
    }
}

/// Read a CSV into samples and the descriptor it implies (see [`read_csv_report`]).
pub fn read_csv(path: &Path, o: &ImportOptions) -> Result<(Descriptor, Vec<Sample>), CsvError> {
    read_csv_report(path, o).map(|(d, s, _)| (d, s))
}

/// Read a CSV into samples, the descriptor it implies, and what the import found: sequence
/// numbers and time faults (gaps, duplicate time stamps, steps backwards) are derived from the
/// time stamps and the median interval ([`crate::io::timing`]) and flagged on the samples;
/// with `--rate` (time from the row index) the sequence is the row index.
///
/// Any text table: its delimiter, decimal commas, comment preamble and header are sniffed from
/// its first lines ([`sniff`]); a file that does not sniff as a table is read as a
/// comma-separated file with its header on line 1 (and fails as such).
pub fn read_csv_report(
    path: &Path,
    o: &ImportOptions,
) -> Result<(Descriptor, Vec<Sample>, ImportReport), CsvError> {
    let fmt = match sniff_file(path) {
        Sniffed::Table(f) => f,
        Sniffed::Text(_) | Sniffed::Binary => TableFormat::default(),
    };
    read_table_report(path, o, &fmt)
}

/// [`read_csv_report`] with the table's format given.
pub fn read_table_report(
    path: &Path,
    o: &ImportOptions,
    fmt: &TableFormat,
) -> Result<(Descriptor, Vec<Sample>, ImportReport), CsvError> {
    let io_err = |err| CsvError::Io {
        path: path.into(),
        err,
    };
    // The preamble (comment and blank lines) is skipped here, so the `csv` crate's line numbers
    // are `skip` short of the file's.
    let skip = fmt.skip_lines;
    let mut text = open_text(path)?;
    let mut line = Vec::new();
    for _ in 0..skip {
        line.clear();
        text.read_until(b'\n', &mut line).map_err(io_err)?;
    }
    let text: Box<dyn Read> = if fmt.delimiter == Delimiter::Whitespace {
        Box::new(sniff::WsReader::new(text))
    } else {
        Box::new(text)
    };
    // RFC 4180 records (quoted cells, CRLF) by the `csv` crate; rows may have any number of
    // cells here (a row whose count differs from the header's is reported below, at its line).
    let mut rd = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .delimiter(fmt.delimiter.byte())
        .from_reader(text);
    // A read error inside a .gz is the compressed stream ending early or corrupt: said as such,
    // with the line it stopped at (it once said only "incomplete deflate stream").
    let gz = path.extension().is_some_and(|e| e == "gz");
    let io = |err: csv::Error, line: u64| match err.kind() {
        csv::ErrorKind::Io(_) if gz => CsvError::Row {
            path: path.into(),
            line: line as usize + skip,
            msg: format!(
                "{err}: the compressed file ends early or is corrupt here (a truncated .gz? \
                 `gzip -t` checks it); nothing was imported"
            ),
        },
        _ => CsvError::Io {
            path: path.into(),
            err: err.into(),
        },
    };
    let mut rec = csv::StringRecord::new();
    if !rd
        .read_record(&mut rec)
        .map_err(|e| io(e, rd.position().line()))?
    {
        return Err(CsvError::Empty { path: path.into() });
    }
    let first: Vec<String> = rec
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let s = if i == 0 {
                s.trim_start_matches('\u{feff}')
            } else {
                s
            };
            s.trim().to_string()
        })
        .skip(usize::from(fmt.header && fmt.marker_cell))
        .collect();
    // The header, or (columns by position) names for the columns; the first data row when the
    // file has no header.
    let mut named = o.clone();
    let header: Vec<String> = if o.positions.is_empty() {
        if !fmt.header {
            let (line, row) = fmt
                .first_row
                .clone()
                .unwrap_or_else(|| (skip + 1, first.join(",")));
            return Err(CsvError::Headerless {
                path: path.into(),
                line,
                row,
                example: positions_example(first.len()),
            });
        }
        first
    } else {
        let n = first.len();
        if let Some(k) = o.columns.iter().position(Option::is_some) {
            return Err(CsvError::Columns {
                path: path.into(),
                msg: format!(
                    "--columns names the columns by position, --col {}=NAME by header name: give one of them",
                    CANON[k]
                ),
                header: first.join(","),
            });
        }
        if o.positions.len() > n {
            return Err(CsvError::Columns {
                path: path.into(),
                msg: format!(
                    "--columns names {} columns, the {} has {}",
                    o.positions.len(),
                    if fmt.header { "header" } else { "first row" },
                    n
                ),
                header: first.join(","),
            });
        }
        for (p, k) in o.positions.iter().enumerate() {
            if let Some(k) = k {
                named.columns[*k] = Some(format!("column {}", p + 1));
            }
        }
        (1..=n).map(|p| format!("column {p}")).collect()
    };
    let o = &named;
    let lay = detect(&header, o, path)?;
    let mut out = Vec::new();
    // The time column's numbers and each row's line (for errors), in the file's unit.
    let mut raw_t: Vec<f64> = Vec::new();
    let mut lines: Vec<usize> = Vec::new();
    // Empty cells per channel, and the line of the first; the rows with any empty channel cell
    // (line, mask of the empty channels), to find those left with no value at all.
    let mut empty = [0usize; 6];
    let mut first_empty: [Option<usize>; 6] = [None; 6];
    let mut holey_rows: Vec<(usize, u8)> = Vec::new();
    // A row must have the header's cells (trailing empty ones aside): a short row, or one with
    // cells past the header, is a line cut short, another delimiter or decimal commas in a
    // comma-separated file — an error at its line, never a row read askew or dropped.
    let want = header
        .iter()
        .rposition(|h| !h.is_empty())
        .map_or(0, |p| p + 1);
    let against = if fmt.header { "header" } else { "first row" };
    // Headerless with --columns: the first record read is the first data row.
    let mut have_row = !fmt.header;
    // The file's last row when it was cut short: (line, cells).
    let mut cut_last: Option<(usize, usize)> = None;
    loop {
        if have_row {
            have_row = false;
        } else if !rd
            .read_record(&mut rec)
            .map_err(|e| io(e, rd.position().line()))?
        {
            break;
        }
        let lineno = rec.position().map_or(0, |p| p.line() as usize) + skip;
        if rec.len() == 1 && rec[0].trim().is_empty() {
            continue;
        }
        let beyond =
            rec.len() > header.len() && rec.iter().skip(header.len()).any(|c| !c.trim().is_empty());
        if rec.len() < want && !beyond && cut_last.is_none() {
            // A short row that is the file's last is a write cut off (a logger stopped, a copy
            // interrupted): left out, said, counted; the rows before it are whole. Anywhere
            // else a short row is an error (below).
            let short = (lineno, rec.len());
            let mut more = false;
            while rd
                .read_record(&mut rec)
                .map_err(|e| io(e, rd.position().line()))?
            {
                if !(rec.len() == 1 && rec[0].trim().is_empty()) {
                    more = true;
                    break;
                }
            }
            if !more {
                cut_last = Some(short);
                break;
            }
            return Err(CsvError::Row {
                path: path.into(),
                line: short.0,
                msg: format!(
                    "{} where the {against} has {} (a line cut short, another delimiter, or decimal commas in a comma-separated file?); nothing was imported",
                    crate::text::count(short.1 as u64, "cell", "cells"),
                    want
                ),
            });
        }
        if rec.len() < want || beyond {
            return Err(CsvError::Row {
                path: path.into(),
                line: lineno,
                msg: format!(
                    "{} where the {against} has {} (a line cut short, another delimiter, or decimal commas in a comma-separated file?); nothing was imported",
                    crate::text::count(rec.len() as u64, "cell", "cells"),
                    want
                ),
            });
        }
        let cells = &rec;
        let get = |k: usize| -> Result<Option<f64>, CsvError> {
            let Some(p) = lay.idx[k] else { return Ok(None) };
            let cell = cells
                .get(p)
                .map(|c| c.trim())
                .ok_or_else(|| CsvError::Row {
                    path: path.into(),
                    line: lineno,
                    msg: format!(
                        "{}, column {} ({}) missing",
                        crate::text::count(cells.len() as u64, "cell", "cells"),
                        p + 1,
                        header[p]
                    ),
                })?;
            if cell.is_empty() && k != 0 {
                // Temperature may be empty; an empty channel cell is a missing value, judged
                // after the last row (a column empty in every row is an absent channel).
                return Ok(None);
            }
            // A byte-order mark before a headerless file's first cell.
            let cell = if p == 0 {
                cell.trim_start_matches('\u{feff}')
            } else {
                cell
            };
            sniff::parse_number(cell, fmt.decimal_comma)
                .map(Some)
                .ok_or_else(|| CsvError::Cell {
                    path: path.into(),
                    line: lineno,
                    col: p + 1,
                    cell: cell.to_string(),
                    name: header[p].clone(),
                })
        };
        let mut s = Sample {
            seq: out.len() as u32,
            ..Sample::default()
        };
        // Time and channels are kept as the file has them until their units are decided over
        // the whole file (below); the scaling is then the same product as before, value by value.
        if let Some(hz) = o.time_from_index_hz {
            s.t_ns = (out.len() as f64 / hz * 1e9).round() as u64;
        } else {
            raw_t.push(get(0)?.expect("time column resolved"));
            lines.push(lineno);
        }
        let mut ch = [f64::NAN; 6];
        let mut empty_here = 0u8;
        for (c, v) in ch.iter_mut().enumerate() {
            if lay.absent & (1 << c) != 0 {
                continue;
            }
            match get(c + 1)? {
                Some(x) => *v = x,
                None => {
                    empty[c] += 1;
                    first_empty[c].get_or_insert(lineno);
                    empty_here |= 1 << c;
                }
            }
        }
        if empty_here != 0 {
            holey_rows.push((lineno, empty_here));
        }
        s.set_channels(&ch);
        s.temp_c = get(7)?;
        out.push(s);
    }
    // A channel column empty in every row is an absent channel (the sensor has no such
    // channel); an empty cell in a column with values elsewhere is a missing value: the row is
    // kept (its other channels are measurements), the value NaN, which the decoders and the
    // pipeline flag `NON_FINITE` (and the pipeline replaces), and the import counts it.
    let mut absent = lay.absent;
    let mut empty_cells = Vec::new();
    for c in 0..6 {
        let Some(first_line) = first_empty[c] else {
            continue;
        };
        if empty[c] == out.len() {
            absent |= 1 << c;
        } else {
            empty_cells.push(EmptyCells {
                channel: crate::sample::CHANNEL_NAMES[c].to_string(),
                cells: empty[c] as u64,
                first_line,
            });
        }
    }
    // A row with every present channel empty is kept too (decided so: its time stamp is real
    // and holds the time base, where a dropped row would be a gap the file does not have, and
    // with `--rate` would shift every later time stamp; one rule for any number of empty
    // cells), and counted on its own.
    let no_value = |m: u8| (m | absent) == ALL_CHANNELS;
    let empty_rows = holey_rows.iter().filter(|r| no_value(r.1)).count() as u64;
    let first_empty_row = holey_rows.iter().find(|r| no_value(r.1)).map(|r| r.0);
    if absent == ALL_CHANNELS {
        return Err(CsvError::Columns {
            path: path.into(),
            msg:
                "no sensor data: every channel column (gx, gy, gz, ax, ay, az) is empty or missing"
                    .into(),
            header: header.join(","),
        });
    }
    // No rows, nothing to decide (the caller says there is nothing to import).
    let units = if out.is_empty() {
        Default::default()
    } else {
        decide_units(&header, &lay, o, absent, &raw_t, &lines, &mut out, path)?
    };
    for s in out.iter_mut() {
        s.absent = absent;
    }
    let mut report = ImportReport {
        table: (!fmt.is_plain()).then(|| fmt.clone()),
        columns: (0..8)
            .filter_map(|k| {
                let p = lay.idx[k]?;
                let unused = (k == 0 && o.time_from_index_hz.is_some())
                    || ((1..7).contains(&k) && absent & (1 << (k - 1)) != 0);
                (!unused).then(|| ColumnUse {
                    key: CANON[k],
                    column: header[p].clone(),
                })
            })
            .collect(),
        units: units.0,
        warnings: units
            .1
            .into_iter()
            .chain(cut_last.map(|(line, cells)| {
                format!(
                    "line {line}, the file's last, has {} where the {against} has {want}: a write cut off, left out (the rows before it are imported)",
                    crate::text::count(cells as u64, "cell", "cells")
                )
            }))
            .collect(),
        rows: out.len() as u64,
        absent: channel_names_of(absent)
            .into_iter()
            .map(str::to_string)
            .collect(),
        empty_cells,
        empty_rows,
        first_empty_row,
        ..ImportReport::default()
    };
    let rate = match o.time_from_index_hz {
        Some(hz) => hz,
        None => {
            report.time = derive_sequence(&mut out);
            report.time.nominal_rate_hz
        }
    };
    let d = Descriptor {
        sample_rate_hz: rate,
        gyro_range_rad_s: o.gyro_range_rad_s,
        accel_range_m_s2: o.accel_range_m_s2,
        axes: Default::default(),
        device_id: o.device_id,
        absent,
    };
    Ok((d, out, report))
}

/// Decide the time, gyro and accel units (options, names, then the data: [`units`]), stamp the
/// samples' time and scale their channels to rad/s and m/s². Returns how each was decided and
/// the warnings (data contradicting a stated unit).
#[allow(clippy::too_many_arguments)]
fn decide_units(
    header: &[String],
    lay: &Layout,
    o: &ImportOptions,
    absent: u8,
    raw_t: &[f64],
    lines: &[usize],
    out: &mut [Sample],
    path: &Path,
) -> Result<(Vec<units::UnitFinding>, Vec<String>), CsvError> {
    let mut found = Vec::new();
    let mut warnings = Vec::new();
    let col_err = |msg: String| CsvError::Columns {
        path: path.into(),
        msg,
        header: header.join(","),
    };
    // Time: the unit, then every stamp (rebased on the first if asked) as before.
    if o.time_from_index_hz.is_none() {
        let d = units::median_interval(raw_t);
        let t = units::decide_time(o.time_unit, lay.time.as_ref(), d);
        let k = t.unit.ns_per_unit();
        let base = match raw_t.first() {
            Some(first) if o.rebase_time => first * k,
            _ => 0.0,
        };
        for ((s, &raw), &line) in out.iter_mut().zip(raw_t).zip(lines) {
            let t_ns = (raw * k - base).round();
            if !(t_ns >= 0.0 && t_ns < u64::MAX as f64) {
                return Err(CsvError::Row {
                    path: path.into(),
                    line,
                    msg: format!(
                        "time {t_ns} ns is negative or not finite (use --rebase-time or --rate{})",
                        if lay.time.is_none() && o.time_unit.is_none() {
                            format!(
                                "; time unit {}: {}",
                                units::time_name(t.unit),
                                t.finding.how
                            )
                        } else {
                            String::new()
                        }
                    ),
                });
            }
            s.t_ns = t_ns as u64;
        }
        found.push(t.finding);
        warnings.extend(t.warning);
    }
    let t_s: Vec<f64> = out.iter().map(Sample::t_s).collect();
    let first_col = |ks: std::ops::RangeInclusive<usize>| {
        ks.into_iter()
            .find_map(|k| lay.idx[k])
            .map_or("", |p| header[p].as_str())
    };
    let norm = (absent & 0b111_000 == 0)
        .then(|| units::accel_median_norm(out))
        .flatten();
    let mut gscale = 1.0;
    if absent & 0b000_111 != 0b000_111 {
        let ev = units::gyro_evidence(out, &t_s, norm.map(|x| x.0));
        let g =
            units::decide_gyro(o.gyro_unit, &lay.gyro, first_col(1..=3), &ev).map_err(col_err)?;
        if g.unit == GyroUnit::DegS {
            gscale = std::f64::consts::PI / 180.0;
        }
        found.push(g.finding);
        warnings.extend(g.warning);
    }
    let mut ascale = 1.0;
    if absent & 0b111_000 != 0b111_000 {
        let a = units::decide_accel(o.accel_unit, &lay.accel, first_col(4..=6), norm)
            .map_err(col_err)?;
        if a.unit == AccelUnit::G {
            ascale = G0;
        }
        found.push(a.finding);
        warnings.extend(a.warning);
    }
    for s in out.iter_mut() {
        s.gyro *= gscale;
        s.accel *= ascale;
    }
    Ok((found, warnings))
}

/// Write samples as canonical CSV plus `seq` and `flags`.
pub fn write_csv(path: &Path, samples: &[Sample]) -> Result<(), CsvError> {
    let io = |err| CsvError::Io {
        path: path.into(),
        err,
    };
    let f = std::fs::File::create(path).map_err(io)?;
    let mut w = std::io::BufWriter::with_capacity(1 << 16, f);
    writeln!(w, "{CSV_HEADER}").map_err(io)?;
    let mut line = String::new();
    for s in samples {
        line.clear();
        write_csv_row(s, &mut line);
        w.write_all(line.as_bytes()).map_err(io)?;
    }
    w.flush().map_err(io)
}
