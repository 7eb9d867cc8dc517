//! The units decided over the whole file, applied: time stamps in ns, channels in rad/s and
//! m/s².

use super::datetime::DateTimeStamps;
use super::layout::Layout;
use super::{CsvError, ImportOptions, TimeUnit, units};
use crate::sample::Sample;
use std::path::Path;

/// Decide the time, gyro and accel units (options, names, then the data: [`units`]), stamp the
/// samples' time and scale their channels to rad/s and m/s². Returns how each was decided and
/// the warnings (data contradicting a stated unit).
#[allow(clippy::too_many_arguments)]
pub(super) fn decide_units(
    header: &[String],
    lay: &Layout,
    o: &ImportOptions,
    absent: u8,
    (raw_t, datetime): (&[f64], Option<&DateTimeStamps>),
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
        let t = match datetime {
            // Date-times are read in seconds; a unit for them is a mistake, not a choice.
            Some(_) if o.time_unit.is_some() => {
                return Err(col_err(
                    "--time-unit applies to numeric time stamps; this time column holds date-times (read as seconds since 1970 UTC): leave it out".to_string(),
                ));
            }
            Some(dt) => units::Decided {
                unit: TimeUnit::S,
                finding: units::UnitFinding {
                    quantity: "time",
                    unit: units::time_name(TimeUnit::S),
                    source: "date-time",
                    how: dt.how(),
                },
                warning: None,
            },
            None => units::decide_time(
                o.time_unit,
                lay.time.as_ref(),
                units::median_interval(raw_t),
            ),
        };
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
        gscale = g.unit.to_rad_s();
        found.push(g.finding);
        warnings.extend(g.warning);
    }
    let mut ascale = 1.0;
    if absent & 0b111_000 != 0b111_000 {
        let a = units::decide_accel(o.accel_unit, &lay.accel, first_col(4..=6), norm)
            .map_err(col_err)?;
        ascale = a.unit.to_m_s2();
        found.push(a.finding);
        warnings.extend(a.warning);
    }
    for s in out.iter_mut() {
        s.gyro *= gscale;
        s.accel *= ascale;
    }
    Ok((found, warnings))
}
