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

/// The most median intervals a wrapped step may span: a counter that wraps runs on (a sample or
/// a few lost at the wrap aside); a logger restarting from a small count does not.
const WRAP_STEP_INTERVALS: f64 = 10.0;

/// A 32-bit counter's wraps taken out of `t`, when every stamp lies in [0, 2³²): a step back by
/// more than 2³¹ that, with 2³² added, is a step forward of at most [`WRAP_STEP_INTERVALS`]
/// median intervals adds 2³² to every later stamp (any other step back stays, for the time
/// checks to flag). How many.
pub fn unwrap_u32(t: &mut [f64]) -> u64 {
    const M: f64 = 4_294_967_296.0;
    if !t.iter().all(|v| (0.0..M).contains(v)) {
        return 0;
    }
    let d = median_interval(t);
    if d.is_nan() || d <= 0.0 {
        return 0;
    }
    let (mut add, mut wraps, mut prev) = (0.0, 0u64, f64::NAN);
    for v in t.iter_mut() {
        let step = *v + M - prev;
        if *v < prev - M / 2.0 && step > 0.0 && step <= WRAP_STEP_INTERVALS * d {
            add += M;
            wraps += 1;
        }
        prev = *v;
        *v += add;
    }
    wraps
}

#[cfg(test)]
mod tests {
    use super::unwrap_u32;

    const M: f64 = 4_294_967_296.0;

    #[test]
    fn a_32_bit_counter_that_wraps_and_runs_on_is_unwrapped() {
        // µs at 200 Hz across the wrap, one sample lost at it.
        let mut t = vec![M - 10_000.0, M - 5_000.0, 5_000.0 - 1.0, 10_000.0 - 1.0];
        assert_eq!(unwrap_u32(&mut t), 1);
        assert_eq!(t, [M - 10_000.0, M - 5_000.0, M + 4_999.0, M + 9_999.0]);
    }

    #[test]
    fn a_restart_or_a_stamp_past_32_bits_is_left_for_the_time_checks() {
        // A logger restarting from a small count: 2³² added would be a step of 0.4 s at 5 ms.
        let before = vec![M - 10_000.0, M - 5_000.0, 400_000.0, 405_000.0];
        let mut t = before.clone();
        assert_eq!(unwrap_u32(&mut t), 0);
        assert_eq!(t, before);
        // ns since 1970: not a 32-bit counter.
        let before = vec![1.7e18, 1.7e18 + 5e6, 1.0, 5e6 + 1.0];
        let mut t = before.clone();
        assert_eq!(unwrap_u32(&mut t), 0);
        assert_eq!(t, before);
    }
}
