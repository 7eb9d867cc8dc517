//! Time stamps written as date-times — ISO 8601 / RFC 3339 (`2024-05-01T12:00:00.010`, a space
//! for the `T`, an optional `Z` or `±hh:mm`), as loggers and spreadsheet or pandas exports write
//! them — read as seconds since 1970-01-01 UTC. One without a zone is taken as UTC (and said).

/// How a file's date-time stamps were read: the finding's words, the same for every row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct DateTimeStamps {
    /// Rows whose stamp gave no zone (taken as UTC).
    pub(super) without_zone: usize,
    pub(super) rows: usize,
}

impl DateTimeStamps {
    /// Count one row's stamp.
    pub(super) fn add(&mut self, zoned: bool) {
        self.rows += 1;
        self.without_zone += usize::from(!zoned);
    }

    /// How the time unit was decided, for the import report.
    pub(super) fn how(&self) -> String {
        let zone = match self.without_zone {
            0 => "each with its zone".to_string(),
            n if n == self.rows => "no zone given: taken as UTC".to_string(),
            n => format!(
                "{} without a zone, taken as UTC",
                crate::text::count(n as u64, "stamp", "stamps")
            ),
        };
        format!("date-time text (ISO 8601), read as seconds since 1970-01-01 UTC; {zone}")
    }
}

/// A date-time cell's seconds since 1970-01-01 UTC, and whether it gave its zone; `None` for
/// anything else (a number is no date-time).
pub(super) fn parse_datetime_s(cell: &str) -> Option<(f64, bool)> {
    use chrono::{DateTime, NaiveDateTime};
    let c = cell.trim();
    // `YYYY-MM-DD?hh:mm:ss` at the least: nothing shorter is worth trying.
    if c.len() < 19 || c.as_bytes()[4] != b'-' {
        return None;
    }
    let secs = |s: i64, ns: u32| s as f64 + f64::from(ns) * 1e-9;
    if let Ok(t) = DateTime::parse_from_rfc3339(c) {
        return Some((secs(t.timestamp(), t.timestamp_subsec_nanos()), true));
    }
    ["%Y-%m-%dT%H:%M:%S%.f", "%Y-%m-%d %H:%M:%S%.f"]
        .iter()
        .find_map(|f| NaiveDateTime::parse_from_str(c, f).ok())
        .map(|t| {
            let t = t.and_utc();
            (secs(t.timestamp(), t.timestamp_subsec_nanos()), false)
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_and_rfc3339_stamps_read_as_utc_seconds() {
        // 2024-05-01T12:00:00Z = 1714564800 s.
        let t0 = 1_714_564_800.0;
        let near = |c: &str, want: f64, zoned: bool| {
            let (s, z) = parse_datetime_s(c).unwrap_or_else(|| panic!("{c}"));
            // f64 holds 1.7e9 s to 2.4e-7 s.
            assert!((s - want).abs() < 5e-7, "{c}: {s} vs {want}");
            assert_eq!(z, zoned, "{c}");
        };
        near("2024-05-01T12:00:00", t0, false);
        near("2024-05-01T12:00:00.010", t0 + 0.010, false);
        near("2024-05-01 12:00:00.010000", t0 + 0.010, false);
        near("2024-05-01T12:00:00.5Z", t0 + 0.5, true);
        near("2024-05-01T14:00:00.250+02:00", t0 + 0.25, true);
        near(" 2024-05-01 12:00:00.000001+00:00 ", t0 + 1e-6, true);
        for bad in [
            "1714564800.0",
            "2024-05-01",
            "12:00:00.010",
            "2024-13-01T12:00:00",
            "2024-05-01T25:00:00",
            "",
            "gx",
        ] {
            assert_eq!(parse_datetime_s(bad), None, "{bad}");
        }
    }

    #[test]
    fn the_finding_says_how_zones_were_read() {
        let mut d = DateTimeStamps::default();
        d.add(false);
        d.add(false);
        assert!(d.how().ends_with("no zone given: taken as UTC"));
        d.add(true);
        assert!(d.how().ends_with("2 stamps without a zone, taken as UTC"));
        let mut z = DateTimeStamps::default();
        z.add(true);
        assert!(z.how().ends_with("each with its zone"));
    }
}
