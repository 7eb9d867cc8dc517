//! Which column holds what: the header resolved into a [`Layout`] (or an error naming what is
//! missing).

use super::columns::{self, NameUnit};
use super::{AccelUnit, CsvError, GyroUnit, ImportOptions, TimeUnit};
use crate::sample::ALL_CHANNELS;
use std::path::Path;

/// Resolved column indices and what the names say of the units.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    pub(super) idx: [Option<usize>; 8],
    pub(super) gyro: NameUnit<GyroUnit>,
    pub(super) accel: NameUnit<AccelUnit>,
    pub(super) time: Option<(TimeUnit, String)>,
    /// Channels without a column (bit `c` for channel `c`).
    pub(super) absent: u8,
}

pub(super) fn detect(
    header: &[String],
    o: &ImportOptions,
    path: &Path,
) -> Result<Layout, CsvError> {
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
