//! Rows of several sensors in one table: a multi-IMU rig or an ArduPilot log (`IMU.I`) writes
//! each sensor's rows into one file, told apart by an instance column. Read as one stream they
//! would interleave two sensors' values and time stamps, so:
//!
//! - `--where COL=VALUE` reads only the rows whose COL cell is VALUE (as text, or as numbers
//!   when both parse: `0` and `0.0` match); the others are left out and counted.
//! - Without it, a column named as an instance (`I` beside ArduPilot's `TimeUS`, `instance`,
//!   `imu`, `imu_id`, `sensor_id`, `device_id`, …) holding 2–[`MAX_INSTANCES`] values that each
//!   fill at least [`MIN_SHARE`] of the rows is an error naming the values and the flag. A
//!   sample counter (thousands of values) or a constant column is no instance column.

use super::read::{Rows, Table};
use super::sniff::parse_number;
use super::{CsvError, ImportOptions};
use std::collections::BTreeMap;
use std::path::Path;

/// More distinct values than this is a counter or a measurement, not sensor instances.
pub const MAX_INSTANCES: usize = 8;
/// Each instance's share of the rows: interleaved sensors each fill a good part of the table.
pub const MIN_SHARE: f64 = 0.1;

/// Names (lowercase, `_` and `-` dropped) an instance column goes by.
const NAMES: [&str; 8] = [
    "instance",
    "imu",
    "imuid",
    "imuindex",
    "sensorid",
    "sensorindex",
    "deviceid",
    "id",
];

/// The column of `header` that holds sensor instances by its name: `I` only beside ArduPilot's
/// `TimeUS`.
pub fn instance_column(header: &[String]) -> Option<usize> {
    let ardupilot = header.iter().any(|h| h.trim() == "TimeUS");
    header.iter().position(|h| {
        let h = h.trim();
        let n: String = h
            .chars()
            .filter(|c| !matches!(c, '_' | '-' | ' '))
            .collect::<String>()
            .to_ascii_lowercase();
        (ardupilot && h == "I") || NAMES.contains(&n.as_str())
    })
}

/// Whether a cell holds the value `want` (text, or equal numbers).
pub fn matches(cell: &str, want: &str, decimal_comma: bool) -> bool {
    let cell = cell.trim();
    cell == want
        || matches!(
            (parse_number(cell, decimal_comma), parse_number(want, decimal_comma)),
            (Some(a), Some(b)) if a == b
        )
}

/// The values of an instance column and their rows (the first [`MAX_INSTANCES`] + 1 values;
/// past that, only that there are more).
#[derive(Debug, Clone, Default)]
pub struct Instances {
    pub counts: BTreeMap<String, u64>,
    pub more: bool,
}

impl Instances {
    pub fn add(&mut self, cell: &str) {
        let cell = cell.trim();
        if let Some(n) = self.counts.get_mut(cell) {
            *n += 1;
        } else if self.counts.len() <= MAX_INSTANCES {
            self.counts.insert(cell.to_string(), 1);
        } else {
            self.more = true;
        }
    }

    /// "0: 4000 rows, 1: 3998 rows".
    pub fn said(&self) -> String {
        self.counts
            .iter()
            .map(|(v, n)| format!("{v}: {}", crate::text::count(*n, "row", "rows")))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Several sensors' rows (module docs): the values, to be said in the error.
    pub fn several(&self, rows: u64) -> bool {
        !self.more
            && (2..=MAX_INSTANCES).contains(&self.counts.len())
            && self
                .counts
                .values()
                .all(|n| *n as f64 >= MIN_SHARE * rows as f64)
    }
}

/// The column `--where` names (an error when there is none), else one named as an instance.
pub(super) fn instance_of(
    path: &Path,
    o: &ImportOptions,
    header: &[String],
) -> Result<Option<usize>, CsvError> {
    match &o.select {
        Some((col, _)) => header
            .iter()
            .position(|h| h.trim() == col)
            .map(Some)
            .ok_or_else(|| CsvError::Columns {
                path: path.into(),
                msg: format!("--where names no column {col:?}"),
                header: header.join(","),
            }),
        None => Ok(instance_column(header)),
    }
}

/// Rows of one sensor: with `--where`, some row must match; without it, an instance column
/// holding several sensors' rows is an error naming them and the flag (the module docs).
pub(super) fn one_sensor(t: &Table, rows: &Rows) -> Result<(), CsvError> {
    let Some(p) = t.instance else { return Ok(()) };
    let col = t.header[p].trim();
    let seen = &rows.instances;
    let msg = match &t.o.select {
        Some((_, want)) if rows.out.is_empty() => format!(
            "no row has {col} = {want:?} (values seen: {}{})",
            seen.said(),
            if seen.more { ", and more" } else { "" }
        ),
        None if seen.several(rows.out.len() as u64) => format!(
            "column {col:?} holds the rows of several sensors ({}): read as one stream they would interleave; pick one with --where {col}={}",
            seen.said(),
            seen.counts.keys().next().map_or("VALUE", String::as_str)
        ),
        _ => return Ok(()),
    };
    Err(CsvError::Columns {
        path: t.path.into(),
        msg,
        header: t.header.join(","),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h(s: &str) -> Vec<String> {
        s.split(',').map(str::to_string).collect()
    }

    #[test]
    fn instance_columns_by_name() {
        assert_eq!(instance_column(&h("timestamp,TimeUS,I,GyrX")), Some(2));
        // `I` alone is no instance (a current, an index).
        assert_eq!(instance_column(&h("t,I,gx")), None);
        assert_eq!(instance_column(&h("t,imu_id,gx")), Some(1));
        assert_eq!(instance_column(&h("t,Sensor-ID,gx")), Some(1));
        assert_eq!(instance_column(&h("t,gx,gy,gz")), None);
    }

    #[test]
    fn several_sensors_are_told_from_a_counter_and_a_constant() {
        let mut two = Instances::default();
        for i in 0..100 {
            two.add(if i % 2 == 0 { "0" } else { "1" });
        }
        assert!(two.several(100));
        assert_eq!(two.said(), "0: 50 rows, 1: 50 rows");
        let mut counter = Instances::default();
        for i in 0..100 {
            counter.add(&i.to_string());
        }
        assert!(!counter.several(100) && counter.more);
        let mut one = Instances::default();
        for _ in 0..100 {
            one.add("0");
        }
        assert!(!one.several(100));
        // A stray value in 5 % of the rows is not a second sensor.
        let mut stray = Instances::default();
        for i in 0..100 {
            stray.add(if i % 20 == 0 { "9" } else { "0" });
        }
        assert!(!stray.several(100));
        assert!(matches(" 0.0", "0", false) && !matches("1", "0", false));
    }
}
