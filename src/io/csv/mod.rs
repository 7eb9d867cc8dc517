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
/// The log reader and writer live in [`crate::io::log`]; re-exported here for older callers.
pub use crate::io::log::{read_descriptor, read_log, read_log_span, write_log};
use crate::sample::Sample;
use std::path::Path;

pub mod columns;
mod datetime;
mod error;
mod instance;
mod layout;
mod options;
mod per_sensor;
mod rails;
mod read;
mod report;
mod scale;
pub mod sniff;
pub mod streams;
pub mod units;
mod write;

pub use error::CsvError;
pub use options::{AccelUnit, CANON, G0, GyroUnit, ImportOptions, TimeUnit, parse_positions};
pub use per_sensor::read_per_sensor_report;
pub use read::read_table_report;
pub use report::{ColumnUse, EmptyCells, ImportReport};
pub use sniff::{Delimiter, Sniffed, TableFormat, sniff_file};
pub use write::write_csv;

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
