//! Reading a text table of a known format into samples, step by step: its records opened past the
//! preamble, the columns named (header or `--columns`), each row checked and read, the missing
//! values judged, the units applied, and the report made.

use super::datetime::{DateTimeStamps, parse_datetime_s};
use super::layout::{Layout, detect};
use super::options::positions_example;
use super::report::{ColumnUse, EmptyCells, ImportReport};
use super::scale::decide_units;
use super::sniff::{self, Delimiter, TableFormat};
use super::{CANON, CsvError, ImportOptions, units};
use crate::frame::Descriptor;
use crate::io::timing::derive_sequence;
use crate::sample::{ALL_CHANNELS, Sample, channel_names_of};
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// [`read_csv_report`](super::read_csv_report) with the table's format given.
pub fn read_table_report(
    path: &Path,
    o: &ImportOptions,
    fmt: &TableFormat,
) -> Result<(Descriptor, Vec<Sample>, ImportReport), CsvError> {
    let mut rd = Records::open(path, fmt)?;
    let mut rec = csv::StringRecord::new();
    let first = first_record(&mut rd, &mut rec, fmt)?;
    let (header, named) = name_columns(path, o, fmt, first)?;
    let o = &named;
    let lay = detect(&header, o, path)?;
    let instance = super::instance::instance_of(path, o, &header)?;
    let t = Table {
        path,
        fmt,
        o,
        lay: &lay,
        header: &header,
        instance,
    };
    let rows = read_rows(&t, &mut rd, &mut rec)?;
    super::instance::one_sensor(&t, &rows)?;
    conclude(&t, rows)
}

/// The rows read, concluded: two streams merged ([`two_streams`]), the missing values judged,
/// the units decided and applied, the report made.
pub(super) fn conclude(
    t: &Table,
    mut rows: Rows,
) -> Result<(Descriptor, Vec<Sample>, ImportReport), CsvError> {
    let (header, lay, o, path) = (t.header, t.lay, t.o, t.path);
    // A 32-bit counter's wraps: Arduino's `micros()` after 71.6 min, `millis()` after 49.7 days,
    // Xsens DOT's SampleTimeFine after 1.2 h.
    let wraps = if o.time_from_index_hz.is_none() && rows.datetime.is_none() {
        super::units::unwrap_u32(&mut rows.raw_t)
    } else {
        0
    };
    let streams = two_streams(t, &mut rows);
    let missing = missing_values(t, &rows)?;
    // No rows, nothing to decide (the caller says there is nothing to import).
    let units = if rows.out.is_empty() {
        Default::default()
    } else {
        decide_units(
            header,
            lay,
            o,
            missing.absent,
            (&rows.raw_t, rows.datetime.as_ref()),
            &rows.lines,
            &mut rows.out,
            path,
        )?
    };
    for s in rows.out.iter_mut() {
        s.absent = missing.absent;
    }
    let selected = t.o.select.as_ref().map(|(c, v)| {
        format!(
            "rows where {c} = {v}: {} read, {} of other values left out ({})",
            rows.out.len(),
            rows.left_out,
            rows.instances.said()
        )
    });
    let (mut d, mut out, mut report) = finish(t, rows, missing, units);
    report
        .notes
        .extend(super::rails::infer_ranges(&mut out, &mut d));
    report.streams = streams;
    report.selected = selected;
    if wraps > 0 {
        report.notes.push(format!(
            "time: the 32-bit counter {:?} wrapped {} (stepped back by about 2³² counts and ran on): unwrapped",
            header[lay.idx[0].unwrap_or(0)],
            crate::text::count(wraps, "time", "times")
        ));
    }
    Ok((d, out, report))
}

/// A table holding two streams (the gyro on some rows, the accelerometer on others) merged onto
/// one's time stamps ([`super::streams`]); the empty cells recounted over the merged samples.
/// Not with `--rate`: rows timed by their index have no time to merge on.
pub(super) fn two_streams(t: &Table, rows: &mut Rows) -> Option<super::streams::StreamMerge> {
    if t.o.time_from_index_hz.is_some() {
        return None;
    }
    let present = !t.lay.absent & crate::sample::ALL_CHANNELS;
    let r = super::streams::merge(&mut rows.out, &mut rows.raw_t, &mut rows.lines, present)?;
    rows.empty = [0; 6];
    rows.first_empty = [None; 6];
    rows.holey_rows.clear();
    for (s, &line) in rows.out.iter().zip(&rows.lines) {
        let v = s.channels();
        let mut m = 0u8;
        for c in (0..6).filter(|c| present & (1 << c) != 0 && v[*c].is_nan()) {
            rows.empty[c] += 1;
            rows.first_empty[c].get_or_insert(line);
            m |= 1 << c;
        }
        if m != 0 {
            rows.holey_rows.push((line, m));
        }
    }
    Some(r)
}

/// The table being read: its file, format, options (with `--columns`' names), layout and header.
pub(super) struct Table<'a> {
    pub(super) path: &'a Path,
    pub(super) fmt: &'a TableFormat,
    pub(super) o: &'a ImportOptions,
    pub(super) lay: &'a Layout,
    pub(super) header: &'a [String],
    /// The column telling sensors apart (`--where`'s, or one named as an instance).
    pub(super) instance: Option<usize>,
}

fn open_text(path: &Path) -> Result<Box<dyn BufRead>, CsvError> {
    let io_err = |err| CsvError::Io {
        path: path.into(),
        err,
    };
    let f = std::fs::File::open(path).map_err(io_err)?;
    // A bar over the file's bytes (compressed, for a .gz) once the read has taken a second.
    let len = f.metadata().map_err(io_err)?.len();
    let f = crate::progress::ReadBar::new(f, len, "read");
    let r: Box<dyn Read> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(flate2::read::MultiGzDecoder::new(f))
    } else {
        Box::new(f)
    };
    Ok(Box::new(BufReader::with_capacity(1 << 16, r)))
}

/// The table's records after its preamble, read errors said at the file's line.
pub(super) struct Records<'a> {
    rd: csv::Reader<Box<dyn Read>>,
    path: &'a Path,
    /// The preamble's lines: the `csv` crate's line numbers are this short of the file's.
    skip: usize,
    gz: bool,
}

impl<'a> Records<'a> {
    pub(super) fn open(path: &'a Path, fmt: &TableFormat) -> Result<Records<'a>, CsvError> {
        let io_err = |err| CsvError::Io {
            path: path.into(),
            err,
        };
        // The preamble (comment and blank lines) is skipped here, so the `csv` crate's line
        // numbers are `skip` short of the file's.
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
        // cells here (a row whose count differs from the header's is reported below, at its
        // line).
        let rd = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .delimiter(fmt.delimiter.byte())
            .from_reader(text);
        Ok(Records {
            rd,
            path,
            skip,
            gz: path.extension().is_some_and(|e| e == "gz"),
        })
    }

    /// The next record into `rec`; `false` at the end of the file.
    fn read(&mut self, rec: &mut csv::StringRecord) -> Result<bool, CsvError> {
        self.rd
            .read_record(rec)
            .map_err(|e| self.error(e, self.rd.position().line()))
    }

    /// A read error inside a .gz is the compressed stream ending early or corrupt: said as such,
    /// with the line it stopped at (it once said only "incomplete deflate stream").
    fn error(&self, err: csv::Error, line: u64) -> CsvError {
        match err.kind() {
            csv::ErrorKind::Io(_) if self.gz => CsvError::Row {
                path: self.path.into(),
                line: line as usize + self.skip,
                msg: format!(
                    "{err}: the compressed file ends early or is corrupt here (a truncated .gz? \
                     `gzip -t` checks it); nothing was imported"
                ),
            },
            _ => CsvError::Io {
                path: self.path.into(),
                err: err.into(),
            },
        }
    }
}

/// The first record's cells, trimmed (a byte-order mark before the first dropped, a header's
/// marker cell skipped); left in `rec` too, the first data row of a headerless file.
pub(super) fn first_record(
    rd: &mut Records,
    rec: &mut csv::StringRecord,
    fmt: &TableFormat,
) -> Result<Vec<String>, CsvError> {
    if !rd.read(rec)? {
        return Err(CsvError::Empty {
            path: rd.path.into(),
        });
    }
    Ok(rec
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
        .collect())
}

/// The header, or (columns by position) names for the columns, and the options with the
/// positions' names; `first` is the first data row when the file has no header.
pub(super) fn name_columns(
    path: &Path,
    o: &ImportOptions,
    fmt: &TableFormat,
    first: Vec<String>,
) -> Result<(Vec<String>, ImportOptions), CsvError> {
    let mut named = o.clone();
    let header: Vec<String> = if o.positions.is_empty() {
        if !fmt.header {
            let (line, row) = fmt
                .first_row
                .clone()
                .unwrap_or_else(|| (fmt.skip_lines + 1, first.join(",")));
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
    Ok((header, named))
}

/// The rows read, channels as the file has them (the time stamped only with `--rate`).
pub(super) struct Rows {
    pub(super) out: Vec<Sample>,
    /// The time column's numbers and each row's line (for errors), in the file's unit.
    pub(super) raw_t: Vec<f64>,
    pub(super) lines: Vec<usize>,
    /// Empty cells per channel, and the line of the first; the rows with any empty channel cell
    /// (line, mask of the empty channels), to find those left with no value at all.
    pub(super) empty: [usize; 6],
    pub(super) first_empty: [Option<usize>; 6],
    pub(super) holey_rows: Vec<(usize, u8)>,
    /// The cells a row must have, and what has them ("header" or "first row").
    pub(super) want: usize,
    pub(super) against: &'static str,
    /// The file's last row when it was cut short: (line, cells).
    pub(super) cut_last: Option<(usize, usize)>,
    /// The time column's stamps when they are date-times (the first row decides; `raw_t` then
    /// holds seconds since 1970 UTC).
    pub(super) datetime: Option<DateTimeStamps>,
    /// The instance column's values over every row read (before `--where`), and the rows
    /// `--where` left out.
    pub(super) instances: super::instance::Instances,
    pub(super) left_out: u64,
}

/// Every row after the header (from the one in `rec` when the file has none), each checked for
/// its count of cells and read by [`read_row`].
pub(super) fn read_rows(
    t: &Table,
    rd: &mut Records,
    rec: &mut csv::StringRecord,
) -> Result<Rows, CsvError> {
    let (path, fmt, header) = (t.path, t.fmt, t.header);
    // A row must have the header's cells (trailing empty ones aside): a short row, or one with
    // cells past the header, is a line cut short, another delimiter or decimal commas in a
    // comma-separated file — an error at its line, never a row read askew or dropped.
    let want = header
        .iter()
        .rposition(|h| !h.is_empty())
        .map_or(0, |p| p + 1);
    let against = if fmt.header { "header" } else { "first row" };
    let mut rows = Rows {
        out: Vec::new(),
        raw_t: Vec::new(),
        lines: Vec::new(),
        empty: [0usize; 6],
        first_empty: [None; 6],
        holey_rows: Vec::new(),
        want,
        against,
        cut_last: None,
        datetime: None,
        instances: Default::default(),
        left_out: 0,
    };
    // Headerless with --columns: the first record read is the first data row.
    let mut have_row = !fmt.header;
    loop {
        if have_row {
            have_row = false;
        } else if !rd.read(rec)? {
            break;
        }
        let lineno = rec.position().map_or(0, |p| p.line() as usize) + rd.skip;
        if rec.len() == 1 && rec[0].trim().is_empty() {
            continue;
        }
        let beyond =
            rec.len() > header.len() && rec.iter().skip(header.len()).any(|c| !c.trim().is_empty());
        if rec.len() < want && !beyond && rows.cut_last.is_none() {
            // A short row that is the file's last is a write cut off (a logger stopped, a copy
            // interrupted): left out, said, counted; the rows before it are whole. Anywhere
            // else a short row is an error (below).
            let short = (lineno, rec.len());
            let mut more = false;
            while rd.read(rec)? {
                if !(rec.len() == 1 && rec[0].trim().is_empty()) {
                    more = true;
                    break;
                }
            }
            if !more {
                rows.cut_last = Some(short);
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
        if let Some(p) = t.instance {
            let cell = rec.get(p).unwrap_or("");
            rows.instances.add(cell);
            if let Some((_, want)) = &t.o.select
                && !super::instance::matches(cell, want, fmt.decimal_comma)
            {
                rows.left_out += 1;
                continue;
            }
        }
        read_row(t, rec, lineno, &mut rows)?;
    }
    Ok(rows)
}

/// One row's cells, at file line `lineno`, onto `rows`: its time cell (or, with `--rate`, its
/// index) and channels as the file has them, each empty channel cell counted.
fn read_row(
    t: &Table,
    cells: &csv::StringRecord,
    lineno: usize,
    rows: &mut Rows,
) -> Result<(), CsvError> {
    let (path, fmt, o, lay, header) = (t.path, t.fmt, t.o, t.lay, t.header);
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
        seq: rows.out.len() as u32,
        ..Sample::default()
    };
    // Time and channels are kept as the file has them until their units are decided over
    // the whole file (below); the scaling is then the same product as before, value by value.
    if let Some(hz) = o.time_from_index_hz {
        s.t_ns = (rows.out.len() as f64 / hz * 1e9).round() as u64;
    } else {
        let t_raw = time_cell(get(0), rows, lineno, path)?;
        rows.raw_t.push(t_raw);
        rows.lines.push(lineno);
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
                rows.empty[c] += 1;
                rows.first_empty[c].get_or_insert(lineno);
                empty_here |= 1 << c;
            }
        }
    }
    if empty_here != 0 {
        rows.holey_rows.push((lineno, empty_here));
    }
    s.set_channels(&ch);
    s.temp_c = get(7)?;
    rows.out.push(s);
    Ok(())
}

/// A row's time stamp from its cell as [`read_row`]'s `get` read it: a number, or — when the
/// file's first stamp was one — a date-time (seconds since 1970 UTC). Numbers and date-times
/// never mix in one column: the row that breaks the first row's kind is an error at its line.
fn time_cell(
    got: Result<Option<f64>, CsvError>,
    rows: &mut Rows,
    lineno: usize,
    path: &Path,
) -> Result<f64, CsvError> {
    let mixed = |cell: &str, is: &str, first: &str| CsvError::Row {
        path: path.into(),
        line: lineno,
        msg: format!(
            "time {cell:?} is {is}, but the column's first stamp was {first}; nothing was imported"
        ),
    };
    let first_row = rows.raw_t.is_empty();
    match got {
        Ok(v) => {
            let v = v.expect("time column resolved");
            if rows.datetime.is_some() {
                return Err(mixed(&v.to_string(), "a number", "a date-time"));
            }
            Ok(v)
        }
        Err(e) => {
            let CsvError::Cell { cell, .. } = &e else {
                return Err(e);
            };
            match parse_datetime_s(cell) {
                Some((secs, zoned)) if first_row || rows.datetime.is_some() => {
                    rows.datetime.get_or_insert_default().add(zoned);
                    Ok(secs)
                }
                Some(_) => Err(mixed(cell, "a date-time", "a number")),
                None => Err(e),
            }
        }
    }
}

/// The channels absent and the missing values, judged over the whole file.
pub(super) struct Missing {
    /// Channels without a column or with a column empty in every row (bit `c` for channel `c`).
    absent: u8,
    empty_cells: Vec<EmptyCells>,
    empty_rows: u64,
    first_empty_row: Option<usize>,
}

/// Which channels are absent, which cells and rows are missing values; an error when no
/// channel has any value.
pub(super) fn missing_values(t: &Table, rows: &Rows) -> Result<Missing, CsvError> {
    // A channel column empty in every row is an absent channel (the sensor has no such
    // channel); an empty cell in a column with values elsewhere is a missing value: the row is
    // kept (its other channels are measurements), the value NaN, which the decoders and the
    // pipeline flag `NON_FINITE` (and the pipeline replaces), and the import counts it.
    let mut absent = t.lay.absent;
    let mut empty_cells = Vec::new();
    for c in 0..6 {
        let Some(first_line) = rows.first_empty[c] else {
            continue;
        };
        if rows.empty[c] == rows.out.len() {
            absent |= 1 << c;
        } else {
            empty_cells.push(EmptyCells {
                channel: crate::sample::CHANNEL_NAMES[c].to_string(),
                cells: rows.empty[c] as u64,
                first_line,
                file: None,
            });
        }
    }
    // A row with every present channel empty is kept too (decided so: its time stamp is real
    // and holds the time base, where a dropped row would be a gap the file does not have, and
    // with `--rate` would shift every later time stamp; one rule for any number of empty
    // cells), and counted on its own.
    let no_value = |m: u8| (m | absent) == ALL_CHANNELS;
    let empty_rows = rows.holey_rows.iter().filter(|r| no_value(r.1)).count() as u64;
    let first_empty_row = rows.holey_rows.iter().find(|r| no_value(r.1)).map(|r| r.0);
    if absent == ALL_CHANNELS {
        return Err(CsvError::Columns {
            path: t.path.into(),
            msg:
                "no sensor data: every channel column (gx, gy, gz, ax, ay, az) is empty or missing"
                    .into(),
            header: t.header.join(","),
        });
    }
    Ok(Missing {
        absent,
        empty_cells,
        empty_rows,
        first_empty_row,
    })
}

/// The report of the import and the descriptor it implies, the samples' sequence and time
/// faults derived from their time stamps (with `--rate`, the rate given).
pub(super) fn finish(
    t: &Table,
    rows: Rows,
    missing: Missing,
    units: (Vec<units::UnitFinding>, Vec<String>),
) -> (Descriptor, Vec<Sample>, ImportReport) {
    let (o, lay, header) = (t.o, t.lay, t.header);
    let (want, against) = (rows.want, rows.against);
    let Missing {
        absent,
        empty_cells,
        empty_rows,
        first_empty_row,
    } = missing;
    let mut out = rows.out;
    let mut report = ImportReport {
        table: (!t.fmt.is_plain()).then(|| t.fmt.clone()),
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
            .chain(rows.cut_last.map(|(line, cells)| {
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
    report.index_rate_hz = o.time_from_index_hz;
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
    (d, out, report)
}
