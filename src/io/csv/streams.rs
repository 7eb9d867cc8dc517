//! A table that holds two streams: the gyro on some rows, the accelerometer on others — what a
//! logger writes that records each sensor event as it comes (phone sensor apps, a merged export
//! of two ROS topics, two sensors on one bus). Read row by row, every sample would miss one of
//! its triads; instead the rows are merged onto one stream's time stamps.
//!
//! - **Which rows.** A row holds the gyro when any present gyro cell has a value, the
//!   accelerometer likewise. The table is two streams when rows with only the gyro and rows with
//!   only the accelerometer are both there and together make at least half the rows (a few
//!   holes in an otherwise whole table stay missing values, as before).
//! - **Onto which.** The stream with more rows (the gyro on a tie) is the base: its rows are the
//!   samples, at their own time stamps, so no base value is altered or moved.
//! - **The other triad** at a base row is its own when the row holds both, else the linear
//!   other stream's row next to it in the file when that has the same time stamp, else the linear
//!   interpolation between the other stream's rows just before and just after it in the file,
//!   when their time stamps bracket the base row's and are at most [`BRACKET_INTERVALS`] of
//!   that stream's median intervals apart. Otherwise (before its first row, after its last, across
//!   a gap, where time runs backwards) it is left missing (NaN, flagged non-finite by the
//!   pipeline) and counted: a value is never carried over a gap or made up past the ends.
//! - Rows with neither triad are left out and counted; temperature comes from the base row,
//!   else from the nearer of the two rows interpolated between.

use crate::sample::Sample;

/// The most median intervals of the interpolated stream that two bracketing rows may be apart:
/// one missing row between them (2 intervals) is bridged with jitter to spare; a longer gap is
/// not (an interpolation across it would invent the motion in between).
pub const BRACKET_INTERVALS: f64 = 2.5;

/// The two groups of channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Triad {
    Gyro,
    Accel,
}

impl Triad {
    fn name(self) -> &'static str {
        match self {
            Triad::Gyro => "gyro",
            Triad::Accel => "accel",
        }
    }

    fn other(self) -> Triad {
        match self {
            Triad::Gyro => Triad::Accel,
            Triad::Accel => Triad::Gyro,
        }
    }

    /// The channel indices of the triad.
    fn channels(self) -> std::ops::Range<usize> {
        match self {
            Triad::Gyro => 0..3,
            Triad::Accel => 3..6,
        }
    }
}

/// What a merge of two streams did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StreamMerge {
    /// Rows read from the table.
    pub rows_read: u64,
    /// Rows holding only the gyro, only the accelerometer, both, neither.
    pub gyro_only: u64,
    pub accel_only: u64,
    pub both: u64,
    pub neither: u64,
    /// The stream whose rows are the samples.
    pub base: Triad,
    /// Base rows whose other triad was taken from a row at the same time stamp, interpolated,
    /// and left without it.
    pub same_time: u64,
    pub interpolated: u64,
    pub unpaired: u64,
    /// The interpolated stream's median interval, in the time column's unit.
    pub other_interval: f64,
    /// Each triad from a file of its own (`import --accel-file`), not one table.
    pub two_files: bool,
}

impl std::fmt::Display for StreamMerge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (b, o) = (self.base.name(), self.base.other().name());
        let c = crate::text::count;
        write!(
            f,
            "two streams {} ({} read: {} with only the gyro, {} with only the accel, {} with both): merged onto the {b}'s time stamps, the {o} taken from its row at the same time stamp ({} samples) or interpolated linearly between its rows on each side ({})",
            if self.two_files {
                "in two files"
            } else {
                "in one table"
            },
            c(self.rows_read, "row", "rows"),
            self.gyro_only,
            self.accel_only,
            self.both,
            self.same_time,
            self.interpolated,
        )?;
        if self.unpaired > 0 {
            write!(
                f,
                "; {} with no {o} row on each side within {BRACKET_INTERVALS} of its median intervals ({} in the time column's unit): {o} left missing (NaN), flagged non-finite by the pipeline",
                c(self.unpaired, "sample", "samples"),
                crate::text::trim_decimals(self.other_interval, 9)
            )?;
        }
        if self.neither > 0 {
            write!(
                f,
                "; {} with no value left out",
                c(self.neither, "row", "rows")
            )?;
        }
        Ok(())
    }
}

fn holds(s: &Sample, triad: Triad, present: u8) -> bool {
    let v = s.channels();
    triad
        .channels()
        .any(|c| present & (1 << c) != 0 && !v[c].is_nan())
}

/// Merges the rows of a table that holds two streams (the module docs say when and how);
/// `None`, nothing changed, when it does not. `out` holds the rows' values as read (empty cells
/// NaN), `t` their time stamps in the file's unit, `lines` their lines; `present` the channels
/// with a column. All three are replaced by the merged samples'.
pub fn merge(
    out: &mut Vec<Sample>,
    t: &mut Vec<f64>,
    lines: &mut Vec<usize>,
    present: u8,
) -> Option<StreamMerge> {
    let n = out.len();
    if n != t.len() || present & 0b111 == 0 || present & 0b111000 == 0 {
        return None;
    }
    let has: Vec<(bool, bool)> = out
        .iter()
        .map(|s| {
            (
                holds(s, Triad::Gyro, present),
                holds(s, Triad::Accel, present),
            )
        })
        .collect();
    let count = |f: fn(&(bool, bool)) -> bool| has.iter().filter(|h| f(h)).count() as u64;
    let gyro_only = count(|h| h.0 && !h.1);
    let accel_only = count(|h| !h.0 && h.1);
    if gyro_only == 0 || accel_only == 0 || 2 * (gyro_only + accel_only) < n as u64 {
        return None;
    }
    let both = count(|h| h.0 && h.1);
    let base = if gyro_only >= accel_only {
        Triad::Gyro
    } else {
        Triad::Accel
    };
    let other = base.other();
    let holds_base = |i: usize| match base {
        Triad::Gyro => has[i].0,
        Triad::Accel => has[i].1,
    };
    let holds_other = |i: usize| match other {
        Triad::Gyro => has[i].0,
        Triad::Accel => has[i].1,
    };
    let other_rows: Vec<usize> = (0..n).filter(|&i| holds_other(i)).collect();
    let other_t: Vec<f64> = other_rows.iter().map(|&i| t[i]).collect();
    // No two distinct stamps: no interval, nothing bridged (only same-stamp rows are taken).
    let interval = Some(super::units::median_interval(&other_t))
        .filter(|d| !d.is_nan())
        .unwrap_or(0.0);
    let limit = BRACKET_INTERVALS * interval;
    let mut r = StreamMerge {
        rows_read: n as u64,
        gyro_only,
        accel_only,
        both,
        neither: count(|h| !h.0 && !h.1),
        base,
        same_time: 0,
        interpolated: 0,
        unpaired: 0,
        other_interval: interval,
        two_files: false,
    };
    let (mut mo, mut mt, mut ml) = (Vec::new(), Vec::new(), Vec::new());
    // `k`: the first of the other stream's rows after the row at hand, in file order.
    let mut k = 0;
    for i in 0..n {
        while k < other_rows.len() && other_rows[k] <= i {
            k += 1;
        }
        if !holds_base(i) {
            continue;
        }
        let mut s = out[i];
        if !holds_other(i) {
            let mut v = s.channels();
            // A row of the other stream at the same time stamp is taken as it is; else the two
            // on each side, close enough.
            let prev = k.checked_sub(1).map(|j| other_rows[j]);
            let next = other_rows.get(k).copied();
            let bracket = match (prev, next) {
                (Some(a), _) if t[a] == t[i] => Some((a, a)),
                (_, Some(b)) if t[b] == t[i] => Some((b, b)),
                (Some(a), Some(b)) => {
                    (t[a] < t[i] && t[i] < t[b] && t[b] - t[a] <= limit).then_some((a, b))
                }
                _ => None,
            };
            match bracket {
                Some((a, b)) => {
                    let w = if a == b {
                        r.same_time += 1;
                        0.0
                    } else {
                        r.interpolated += 1;
                        (t[i] - t[a]) / (t[b] - t[a])
                    };
                    let (va, vb) = (out[a].channels(), out[b].channels());
                    for c in other.channels() {
                        v[c] = va[c] + w * (vb[c] - va[c]);
                    }
                    if s.temp_c.is_none() {
                        s.temp_c = if w <= 0.5 {
                            out[a].temp_c
                        } else {
                            out[b].temp_c
                        };
                    }
                }
                None => {
                    for c in other.channels() {
                        v[c] = f64::NAN;
                    }
                    r.unpaired += 1;
                }
            }
            s.set_channels(&v);
        }
        s.seq = mo.len() as u32;
        mo.push(s);
        mt.push(t[i]);
        ml.push(lines[i]);
    }
    *out = mo;
    *t = mt;
    *lines = ml;
    Some(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every channel of a row, a triad per stream: `[g, g, g, a, a, a]`.
    fn row(g: Option<f64>, a: Option<f64>) -> [f64; 6] {
        let g = g.unwrap_or(f64::NAN);
        let a = a.unwrap_or(f64::NAN);
        [g, g, g, a, a, a]
    }

    fn table(rows: &[(f64, Option<f64>, Option<f64>)]) -> (Vec<Sample>, Vec<f64>, Vec<usize>) {
        let out = rows
            .iter()
            .map(|&(_, g, a)| {
                let mut s = Sample::default();
                s.set_channels(&row(g, a));
                s
            })
            .collect();
        let t = rows.iter().map(|r| r.0).collect();
        let lines = (2..rows.len() + 2).collect();
        (out, t, lines)
    }

    #[test]
    fn interleaved_rows_merge_onto_the_gyro_with_the_accel_interpolated() {
        // Gyro at 0, 10, 20, 30; accel at 5, 15, 25 (file time unit: ms). The gyro's first row
        // has no accel row before it and its last none after it: left missing, counted.
        let (mut out, mut t, mut lines) = table(&[
            (0.0, Some(1.0), None),
            (5.0, None, Some(10.0)),
            (10.0, Some(2.0), None),
            (15.0, None, Some(20.0)),
            (20.0, Some(3.0), None),
            (25.0, None, Some(40.0)),
            (30.0, Some(4.0), None),
        ]);
        let r = merge(&mut out, &mut t, &mut lines, 0b111111).expect("two streams");
        assert_eq!((r.gyro_only, r.accel_only, r.both, r.neither), (4, 3, 0, 0));
        assert_eq!(r.base, Triad::Gyro);
        assert_eq!((r.interpolated, r.unpaired), (2, 2));
        assert_eq!(t, vec![0.0, 10.0, 20.0, 30.0]);
        assert_eq!(lines, vec![2, 4, 6, 8]);
        let ax: Vec<f64> = out.iter().map(|s| s.accel[0]).collect();
        let gx: Vec<f64> = out.iter().map(|s| s.gyro[0]).collect();
        // Halfway between 10 and 20, and between 20 and 40.
        assert!(ax[0].is_nan() && ax[3].is_nan());
        assert_eq!((ax[1], ax[2]), (15.0, 30.0));
        assert_eq!(gx, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(out.iter().map(|s| s.seq).collect::<Vec<_>>(), [0, 1, 2, 3]);
        let said = r.to_string();
        assert!(
            said.contains("merged onto the gyro's time stamps"),
            "{said}"
        );
        assert!(said.contains("2 samples with no accel row"), "{said}");
    }

    #[test]
    fn the_stream_with_more_rows_is_the_base_and_a_gap_is_not_bridged() {
        // Accel every 10 from 0 to 200; gyro every 20 from 5, its row at 45 missing (bridged:
        // 40 apart, 2 of its intervals) and those at 85–125 (not: 80 apart, 4 intervals). The
        // gyro's value is its time, so a linear interpolation must give the accel row's time.
        let gyro_at = [5.0, 25.0, 65.0, 145.0, 165.0, 185.0];
        let mut rows = Vec::new();
        for i in 0..=20 {
            let tt = 10.0 * i as f64;
            rows.push((tt, None, Some(tt)));
            if gyro_at.contains(&(tt + 5.0)) {
                rows.push((tt + 5.0, Some(tt + 5.0), None));
            }
        }
        let (mut out, mut t, mut lines) = table(&rows);
        let r = merge(&mut out, &mut t, &mut lines, 0b111111).expect("two streams");
        assert_eq!(r.base, Triad::Accel);
        assert_eq!(r.other_interval, 20.0);
        assert_eq!(out.len(), 21);
        for (s, tt) in out.iter().zip(&t) {
            let g = s.gyro[0];
            let inside = (5.0..=65.0).contains(tt) || (145.0..=185.0).contains(tt);
            assert_eq!(!g.is_nan(), inside, "t = {tt}: {g}");
            if inside {
                assert!((g - tt).abs() < 1e-12, "t = {tt}: {g}");
            }
            assert_eq!(s.accel[0], *tt);
        }
        assert_eq!((r.interpolated, r.unpaired), (10, 11));
    }

    #[test]
    fn a_whole_table_or_a_few_holes_are_not_two_streams() {
        let rows: Vec<_> = (0..10)
            .map(|i| {
                let g = (i != 3).then_some(1.0);
                let a = (i != 6).then_some(2.0);
                (i as f64, g, a)
            })
            .collect();
        let (mut out, mut t, mut lines) = table(&rows);
        let before = (out.len(), t.clone());
        assert!(merge(&mut out, &mut t, &mut lines, 0b111111).is_none());
        assert_eq!((out.len(), t), before);
        // A gyro-only sensor is one stream whatever its holes.
        let (mut out, mut t, mut lines) = table(&[(0.0, Some(1.0), None), (1.0, Some(1.0), None)]);
        assert!(merge(&mut out, &mut t, &mut lines, 0b000111).is_none());
    }

    #[test]
    fn rows_with_both_keep_their_own_values_and_empty_rows_are_counted() {
        let (mut out, mut t, mut lines) = table(&[
            (0.0, Some(1.0), Some(7.0)),
            (1.0, None, Some(8.0)),
            (2.0, Some(2.0), None),
            (3.0, None, Some(9.0)),
            (4.0, None, None),
            (5.0, Some(3.0), None),
        ]);
        let r = merge(&mut out, &mut t, &mut lines, 0b111111).expect("two streams");
        assert_eq!((r.both, r.neither), (1, 1));
        assert_eq!(r.base, Triad::Gyro);
        assert_eq!(out[0].accel[0], 7.0);
        assert_eq!(out[1].accel[0], 8.5);
        // The accel rows at 3 and … none after: the gyro at 5 is unpaired.
        assert!(out[2].accel[0].is_nan());
        assert!(r.to_string().contains("1 row with no value left out"));
    }
}
