//! One table per sensor (`imuprep import GYRO.csv --accel-file ACCEL.csv`): phone sensor apps and
//! many loggers write the gyro and the accelerometer to files of their own, each with its own
//! time stamps. Each file is read as a table of its triad (bare `x`, `y`, `z` columns are that
//! triad's; the other triad's columns are not read), the rows of both are interleaved by time,
//! and the result is concluded as one table holding two streams ([`super::streams`]): merged onto
//! the stream with more rows, units decided on the merged samples, every count in the report.

use super::layout::{Layout, detect};
use super::read::{Records, Rows, Table, conclude, first_record, name_columns, read_rows};
use super::sniff::{Sniffed, TableFormat, sniff_file};
use super::streams::Triad;
use super::units::{median_interval, unwrap_u32};
use super::{CsvError, ImportOptions, ImportReport};
use crate::frame::Descriptor;
use crate::sample::Sample;
use std::path::Path;

/// The most the two files' median intervals may differ, ×: more is two time units, not two
/// rates (phones run their sensors within a few × of each other; units differ by 1000×).
const MAX_RATE_RATIO: f64 = 30.0;

/// File-name parts of a phone sensor app's exports that are no gyro or accelerometer
/// measurement: gravity and gravity-free (linear, user) acceleration, attitude, the magnetometer.
const NOT_A_SENSOR: [&str; 7] = [
    "gravity",
    "linear",
    "useracc",
    "orientation",
    "rotationvector",
    "magnet",
    "attitude",
];

/// One file read as the table of one triad.
struct Part {
    header: Vec<String>,
    lay: Layout,
    rows: Rows,
}

fn read_part(path: &Path, o: &ImportOptions, only: Triad) -> Result<Part, CsvError> {
    let fmt = match sniff_file(path) {
        Sniffed::Table(f) => f,
        _ => TableFormat::default(),
    };
    let mut o = o.clone();
    o.only = Some(only);
    let mut rd = Records::open(path, &fmt)?;
    let mut rec = csv::StringRecord::new();
    let first = first_record(&mut rd, &mut rec, &fmt)?;
    let (header, named) = name_columns(path, &o, &fmt, first)?;
    let mut lay = detect(&header, &named, path)?;
    // Not the other triad's, even by canonical name or `--col`: this file is this triad's.
    let other = if only == Triad::Gyro { 4..=6 } else { 1..=3 };
    for k in other {
        lay.idx[k] = None;
        lay.absent |= 1 << (k - 1);
    }
    let t = Table {
        path,
        fmt: &fmt,
        o: &named,
        lay: &lay,
        header: &header,
        instance: None,
    };
    let rows = read_rows(&t, &mut rd, &mut rec)?;
    Ok(Part { header, lay, rows })
}

/// Read the gyro's table and the accelerometer's, and merge them (module docs).
pub fn read_per_sensor_report(
    gyro: &Path,
    accel: &Path,
    o: &ImportOptions,
) -> Result<(Descriptor, Vec<Sample>, ImportReport), CsvError> {
    let problem = |msg: String| CsvError::Pair {
        path: accel.into(),
        msg,
    };
    if !o.positions.is_empty() || o.time_from_index_hz.is_some() || o.select.is_some() {
        return Err(problem(
            "--accel-file reads each file's header and time column: --columns, --rate and --where do not apply"
                .into(),
        ));
    }
    if crate::io::same_file(gyro, accel) {
        return Err(problem(
            "--accel-file names the input itself: give the accelerometer's own table".into(),
        ));
    }
    // A phone app's other exports hold derived or other sensors' vectors in the same bare x, y,
    // z columns: refused by their file names, never read as the gyro or the accelerometer.
    for (path, what) in [(gyro, "gyro"), (accel, "accelerometer")] {
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().to_ascii_lowercase());
        if let Some(k) = NOT_A_SENSOR.iter().find(|k| name.contains(*k)) {
            return Err(CsvError::Pair {
                path: path.into(),
                msg: format!(
                    "the file name says {k:?}: a derived or another sensor's vector, not the {what}'s measurement (phone apps: Gyroscope and TotalAcceleration, or Accelerometer where it holds gravity)"
                ),
            });
        }
    }
    let mut g = read_part(gyro, o, Triad::Gyro)?;
    let mut a = read_part(accel, o, Triad::Accel)?;
    // A 32-bit counter's wraps undone in each file before the rows are interleaved by time
    // (after it, one file's wrapped rows would sort before the other's last ones).
    let wraps = [unwrap_u32(&mut g.rows.raw_t), unwrap_u32(&mut a.rows.raw_t)];
    for (p, path) in [(&g, gyro), (&a, accel)] {
        if p.rows.out.is_empty() {
            return Err(problem(format!("{}: no data rows", path.display())));
        }
    }
    if g.rows.datetime.is_some() != a.rows.datetime.is_some() {
        return Err(problem(
            "one file's time column holds date-times, the other's numbers: they cannot be interleaved".into(),
        ));
    }
    let (dg, da) = (
        median_interval(&g.rows.raw_t),
        median_interval(&a.rows.raw_t),
    );
    let ratio = (dg / da).max(da / dg);
    // NaN (a file with fewer than two distinct stamps) is refused too.
    if ratio.is_nan() || ratio > MAX_RATE_RATIO {
        return Err(problem(format!(
            "the two files' time stamps are {} vs {} apart (median, in each file's numbers): {}× — two time units? Both files' time columns must count in the same unit",
            super::units::num(dg),
            super::units::num(da),
            super::units::num(ratio)
        )));
    }
    let span = |r: &Rows| {
        r.raw_t
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| {
                (l.min(*t), h.max(*t))
            })
    };
    let (sg, sa) = (span(&g.rows), span(&a.rows));
    if sg.1 < sa.0 || sa.1 < sg.0 {
        return Err(problem(format!(
            "the two files' time stamps do not overlap (gyro {}…{}, accelerometer {}…{}): not one recording, or different clocks",
            super::units::num(sg.0),
            super::units::num(sg.1),
            super::units::num(sa.0),
            super::units::num(sa.1)
        )));
    }
    // One header: the gyro file's columns, then the accelerometer file's, each named with its
    // file (both may have an `x`).
    let shift = g.header.len();
    let file = |p: &Path| {
        p.file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned())
    };
    let header: Vec<String> = g
        .header
        .iter()
        .map(|h| format!("{}:{h}", file(gyro)))
        .chain(a.header.iter().map(|h| format!("{}:{h}", file(accel))))
        .collect();
    // Time and gyro from the gyro's file, accel from the accelerometer's, temperature from
    // either.
    let mut idx = g.lay.idx;
    for (k, v) in idx.iter_mut().enumerate().skip(4) {
        let theirs = a.lay.idx[k].map(|p| p + shift);
        *v = if k == 7 { v.or(theirs) } else { theirs };
    }
    let lay_a_time = a.lay.idx[0].map(|p| p + shift);
    let lay = Layout {
        idx,
        gyro: g.lay.gyro.clone(),
        accel: a.lay.accel.clone(),
        time: g.lay.time.clone().or(a.lay.time.clone()),
        absent: (g.lay.absent & 0b000111) | (a.lay.absent & 0b111000),
    };
    // The rows of both, interleaved by time (each file's own order kept).
    let (gr, ar) = (g.rows, a.rows);
    let n = gr.out.len() + ar.out.len();
    let mut rows = Rows {
        out: Vec::with_capacity(n),
        raw_t: Vec::with_capacity(n),
        lines: Vec::with_capacity(n),
        empty: [0; 6],
        first_empty: [None; 6],
        holey_rows: Vec::new(),
        want: gr.want,
        against: gr.against,
        cut_last: gr.cut_last.or(ar.cut_last),
        datetime: gr.datetime,
        instances: Default::default(),
        left_out: 0,
    };
    let (mut i, mut j) = (0, 0);
    while i < gr.out.len() || j < ar.out.len() {
        let take_g = j >= ar.out.len() || (i < gr.out.len() && gr.raw_t[i] <= ar.raw_t[j]);
        let (src, k) = if take_g { (&gr, i) } else { (&ar, j) };
        rows.out.push(src.out[k]);
        rows.raw_t.push(src.raw_t[k]);
        rows.lines.push(src.lines[k]);
        if take_g {
            i += 1;
        } else {
            j += 1;
        }
    }
    let fmt = TableFormat::default();
    let t = Table {
        path: gyro,
        fmt: &fmt,
        o,
        lay: &lay,
        header: &header,
        instance: None,
    };
    let (d, s, mut report) = conclude(&t, rows)?;
    if report.streams.is_none() {
        return Err(problem(
            "the gyro's and the accelerometer's rows could not be merged (one file holds no values?)"
                .into(),
        ));
    }
    report.table = None;
    // Said of the two files: each has its own time column, and the samples are the base
    // file's rows, so the lines named are that file's.
    let base = match report.streams.as_ref().map(|m| m.base) {
        Some(Triad::Accel) => accel,
        _ => gyro,
    };
    if let Some(m) = report.streams.as_mut() {
        m.two_files = true;
    }
    for e in &mut report.empty_cells {
        e.file = Some(file(base));
    }
    if let (Some(tg), Some(ta)) = (g.lay.idx[0], lay_a_time) {
        for c in report.columns.iter_mut().filter(|c| c.key == "t") {
            c.column = format!("{} (gyro rows), {} (accel rows)", header[tg], header[ta]);
        }
    }
    for (n, path) in wraps.into_iter().zip([gyro, accel]) {
        if n > 0 {
            report.notes.push(format!(
                "time: the 32-bit counter of {} wrapped {} (stepped back by about 2³² counts and ran on): unwrapped",
                path.display(),
                crate::text::count(n, "time", "times")
            ));
        }
    }
    Ok((d, s, report))
}
