//! The time column's unit: stated (an option, the column name) or decided from the rate its
//! median interval gives.

use super::{Decided, TIME_RATE_HZ, UnitFinding, num, stated_by};
use crate::io::csv::TimeUnit;
use crate::stats::robust::median;

/// The median positive interval of a time series (NaN when there is none).
pub fn median_interval(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0 && d.is_finite())
        .collect();
    median(&mut d)
}

fn secs_per(u: TimeUnit) -> f64 {
    u.ns_per_unit() * 1e-9
}

/// The rate a median interval (in the file's numbers) gives read in unit `u`, Hz.
pub fn rate_as(median_raw: f64, u: TimeUnit) -> f64 {
    1.0 / (median_raw * secs_per(u))
}

/// The first of s, ms, µs, ns that makes a median interval a plausible IMU rate.
pub fn plausible_time_unit(median_raw: f64) -> Option<TimeUnit> {
    [TimeUnit::S, TimeUnit::Ms, TimeUnit::Us, TimeUnit::Ns]
        .into_iter()
        .find(|u| {
            let r = rate_as(median_raw, *u);
            r >= TIME_RATE_HZ.0 && r <= TIME_RATE_HZ.1
        })
}

/// The `--time-unit` spelling.
pub fn time_name(u: TimeUnit) -> &'static str {
    match u {
        TimeUnit::S => "s",
        TimeUnit::Ms => "ms",
        TimeUnit::Us => "us",
        TimeUnit::Ns => "ns",
        TimeUnit::Tick100Us => "100us",
    }
}

/// Decide the time unit from the median interval `d` of the time column's numbers (NaN when
/// fewer than two distinct stamps): an option or a unit in the name wins (warned about when
/// the rate it gives is no IMU's and another unit's is); else the first of s, ms, µs, ns giving
/// [`TIME_RATE_HZ`]; else s.
pub fn decide_time(
    opt: Option<TimeUnit>,
    named: Option<&(TimeUnit, String)>,
    d: f64,
) -> Decided<TimeUnit> {
    let plausible = plausible_time_unit(d);
    let rate = |u: TimeUnit| format!("{} Hz", num(rate_as(d, u)));
    let fits = |u: TimeUnit| (TIME_RATE_HZ.0..=TIME_RATE_HZ.1).contains(&rate_as(d, u));
    let stated = match (opt, named) {
        (Some(u), _) => Some((u, stated_by(true, "", "--time-unit"), "option")),
        // Xsens' `SampleTimeFine` counts 100-µs ticks on the MTi family and µs on Xsens DOT
        // (≤ 120 Hz, so ≥ 8333 µs apart: below 2 Hz as 100-µs ticks); the rate picks.
        (None, Some((TimeUnit::Tick100Us, col))) => {
            let (u, which) = if !fits(TimeUnit::Tick100Us) && fits(TimeUnit::Us) {
                (TimeUnit::Us, "µs, as Xsens DOT counts it")
            } else {
                (
                    TimeUnit::Tick100Us,
                    "100-µs ticks, as the Xsens MTi counts it",
                )
            };
            Some((
                u,
                format!(
                    "{} ({which}: the MTi's 100-µs ticks give {}, DOT's µs {})",
                    stated_by(false, col, ""),
                    rate(TimeUnit::Tick100Us),
                    rate(TimeUnit::Us)
                ),
                "name",
            ))
        }
        (None, Some((u, col))) => Some((*u, stated_by(false, col, ""), "name")),
        _ => None,
    };
    if let Some((u, by, source)) = stated {
        // Only when the stated unit gives no IMU's rate: another unit giving one too (a 2 kHz
        // file stamped in ms reads as 2 Hz in s) contradicts nothing.
        let warning = plausible.filter(|v| *v != u && !fits(u)).map(|v| {
            format!(
                "time: {by} says {}, but then the median interval {} {} gives {}, no IMU's rate; as {} it gives {}: if so, pass --time-unit {}",
                time_name(u),
                num(d),
                time_name(u),
                rate(u),
                time_name(v),
                rate(v),
                time_name(v)
            )
        });
        return Decided {
            unit: u,
            finding: UnitFinding {
                quantity: "time",
                unit: time_name(u),
                source,
                how: format!("stated by {by}"),
            },
            warning,
        };
    }
    let (unit, how) = match plausible {
        _ if d.is_nan() || d <= 0.0 => (
            TimeUnit::S,
            "not stated; read as s (fewer than two distinct time stamps to check it)".to_string(),
        ),
        Some(TimeUnit::S) => (
            TimeUnit::S,
            format!(
                "not stated; the median interval {} s gives {}",
                num(d),
                rate(TimeUnit::S)
            ),
        ),
        Some(v) => (
            v,
            format!(
                "not stated; read as s the median interval {} would give {}, no IMU's rate; as {} it gives {}",
                num(d),
                rate(TimeUnit::S),
                time_name(v),
                rate(v)
            ),
        ),
        None => (
            TimeUnit::S,
            format!(
                "not stated; read as s: no unit gives {}–{} Hz (median interval {}, {} as s)",
                num(TIME_RATE_HZ.0),
                num(TIME_RATE_HZ.1),
                num(d),
                rate(TimeUnit::S)
            ),
        ),
    };
    Decided {
        unit,
        finding: UnitFinding {
            quantity: "time",
            unit: time_name(unit),
            source: "data",
            how,
        },
        warning: None,
    }
}
