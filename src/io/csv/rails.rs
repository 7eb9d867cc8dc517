//! A clipped table's full scale, read from the data when no range is given.
//!
//! A text table carries no range, so no value in it was flagged saturated, and a sensor
//! clipped at its full scale hands the stages a flat top they take for a signal: the gross-error
//! stage judged the motion leaving the rail against the rail's zero roughness and replaced it
//! (`tests/import_clipped.rs`: 400 °/s turns clipped at ±250 °/s, 20 samples replaced at two
//! exits, up to 3.4 °/s off). Where a channel held
//! its extreme value as a rail ([`crate::stats::grid::rails`]) the triad's range is set to the
//! smallest rail's magnitude, every value at or beyond it is flagged saturated (the decoder's
//! rule for a stated range), and the import says so. `--gyro-range-dps` / `--accel-range-g`
//! state a range instead.

use crate::frame::Descriptor;
use crate::sample::{CHANNEL_NAMES, Sample, flags};
use crate::stats::grid::rails;

/// Set the ranges `d` leaves unknown (0) from the rails the channels of `samples` held, flag
/// the values at or beyond them saturated, and say what was found (one note per triad).
pub fn infer_ranges(samples: &mut [Sample], d: &mut Descriptor) -> Vec<String> {
    let mut notes = Vec::new();
    for (first, triad) in [(0usize, "gyro"), (3, "accel")] {
        let range = if first == 0 {
            &mut d.gyro_range_rad_s
        } else {
            &mut d.accel_range_m_s2
        };
        if *range > 0.0 {
            continue;
        }
        let mut held = Vec::new();
        for c in first..first + 3 {
            if samples.first().is_some_and(|s| s.is_absent(c)) {
                continue;
            }
            let x: Vec<f64> = samples.iter().map(|s| s.channel(c)).collect();
            for r in rails(&x).into_iter().flatten() {
                held.push((c, r));
            }
        }
        let Some(full) = held.iter().map(|(_, r)| r.value.abs()).reduce(f64::min) else {
            continue;
        };
        // The range as the descriptor stores it (f32), never above the rail it came from.
        let mut r = full as f32;
        while f64::from(r) > full {
            r = f32::from_bits(r.to_bits() - 1);
        }
        *range = r;
        let lim = f64::from(r);
        let mut flagged = 0u64;
        for s in samples.iter_mut() {
            for c in first..first + 3 {
                if !s.is_absent(c) && s.channel(c).abs() >= lim {
                    s.flags |= flags::sat_ch(c);
                    flagged += 1;
                }
            }
        }
        // Each value in SI and in the unit datasheets state ranges in.
        let show = |v: f64| {
            if first == 0 {
                format!("{v:+.6} rad/s ({:+.1} °/s)", v.to_degrees())
            } else {
                format!("{v:+.5} m/s² ({:+.2} g)", v / crate::io::csv::G0)
            }
        };
        let each: Vec<String> = held
            .iter()
            .map(|(c, r)| {
                format!(
                    "{} held {} for {} samples in {}",
                    CHANNEL_NAMES[*c],
                    show(r.value),
                    r.samples,
                    crate::text::count(r.runs as u64, "run", "runs")
                )
            })
            .collect();
        let flag = if first == 0 {
            "--gyro-range-dps"
        } else {
            "--accel-range-g"
        };
        notes.push(format!(
            "{triad} range: {} read from the rails the data hold ({}); {flagged} values at or \
             beyond it flagged saturated ({flag} states a range instead)",
            show(lim).replacen('+', "±", 2),
            each.join("; ")
        ));
    }
    notes
}
