//! Sequence numbers and time faults of an imported recording, derived from its time stamps.
//!
//! A CSV has no frame counter, so the sequence is rebuilt from time: the nominal interval `P` is
//! the mean of the positive intervals within (0.5, 2) medians (a long gap cannot move it, where it
//! moves the plain mean: 10 s missing from 100 s at 100 Hz gives a mean rate of 90 Hz; and
//! one-sided jitter cannot bias it, where it biases the median), and each interval `dt` advances
//! the sequence by `round(dt / P)`. So
//!
//! * `dt > 1.5 P` — a **gap**: `round(dt/P) − 1` samples missing, the sample after it flagged
//!   [`flags::GAP`];
//! * `dt = 0` — a **duplicate** time stamp: same sequence number, flagged [`flags::DUPLICATE`];
//! * `dt < 0` — time ran **backwards**: within [`BACKWARD_WINDOW`] intervals a late repeat (same
//!   sequence number, flagged duplicate), further back a **restart** (flagged gap, time base
//!   taken afresh).
//!
//! The replay decoder re-derives the same gap and duplicate flags from these sequence numbers, so
//! the faults survive the round trip through a log.
//!
//! Bursty host time stamps (a logger that stamps samples when a USB packet arrives: many within
//! a millisecond, then a pause) break the median: it measures the spacing inside a burst, not the
//! sensor. They are recognised when median-spaced samples would cover less than half of the
//! recording's span ([`BURSTY_COVERAGE`]; pauses beyond [`BURSTY_GAP_FACTOR`] mean intervals,
//! gaps under either rule, left out of the span: a 50-s stop in an 80-s log is a gap, not a
//! burst pattern); the interval is then the mean, and only pauses longer
//! than [`BURSTY_GAP_FACTOR`] mean intervals count as gaps (a pause between bursts is not one).

use crate::sample::{Sample, flags};
use serde::Serialize;

/// Backward steps up to this many nominal intervals are late repeats; longer ones restarts.
pub const BACKWARD_WINDOW: f64 = 1024.0;
/// Median-spaced samples covering less than this fraction of the span mean bursty time stamps.
pub const BURSTY_COVERAGE: f64 = 0.5;
/// With bursty time stamps, a pause counts as a gap beyond this many mean intervals.
pub const BURSTY_GAP_FACTOR: f64 = 10.0;

/// What [`derive_sequence`] found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct TimeFaults {
    pub samples: u64,
    /// Nominal rate, Hz (0 when fewer than two distinct time stamps).
    pub nominal_rate_hz: f64,
    /// Median and mean of the positive intervals, s.
    pub median_interval_s: f64,
    pub mean_interval_s: f64,
    /// The time stamps come in bursts (see the module docs): rate from the mean interval.
    pub bursty: bool,
    pub gaps: u64,
    pub missing: u64,
    pub duplicates: u64,
    /// Samples stamped behind the latest time stamp so far (restarts included): one step back
    /// of k intervals puts the next k samples behind it, so this counts samples, not steps.
    pub backwards: u64,
    pub restarts: u64,
}

impl TimeFaults {
    /// Any fault at all.
    pub fn any(&self) -> bool {
        self.gaps + self.duplicates + self.backwards + self.restarts > 0
    }
}

impl std::fmt::Display for TimeFaults {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "time: {:.3} Hz nominal from the {} interval ({:.3} ms; median {:.3} ms, mean {:.3} ms){}; {} ({} of them {})",
            self.nominal_rate_hz,
            if self.bursty {
                "mean"
            } else {
                "near-median mean"
            },
            1e3 / self.nominal_rate_hz,
            self.median_interval_s * 1e3,
            self.mean_interval_s * 1e3,
            if self.bursty {
                format!(
                    ", bursty time stamps: only pauses over {BURSTY_GAP_FACTOR} intervals count as gaps"
                )
            } else {
                String::new()
            },
            crate::text::time_faults(
                self.gaps,
                self.missing,
                (
                    self.duplicates,
                    "duplicate time stamp",
                    "duplicate time stamps"
                ),
                self.backwards
            ),
            self.restarts,
            if self.restarts == 1 {
                "a restart"
            } else {
                "restarts"
            }
        )
    }
}

/// Set every sample's `seq` from its time stamp and flag the time faults (see the module docs).
pub fn derive_sequence(samples: &mut [Sample]) -> TimeFaults {
    let mut stamps = Stamps::default();
    for s in samples.iter() {
        stamps.push(s.t_ns);
    }
    let mut q = stamps.sequencer();
    for s in samples.iter_mut() {
        q.next(s);
    }
    q.faults()
}

/// What [`derive_sequence`] learns from a recording's time stamps before it sequences any
/// sample: their count and the positive intervals between consecutive ones (8 bytes a sample,
/// so a recording streamed twice need not be held: [`Stamps::sequencer`]).
#[derive(Debug, Default)]
pub struct Stamps {
    samples: u64,
    last: Option<u64>,
    positive: Vec<u64>,
}

impl Stamps {
    /// The next sample's stamp, ns.
    pub fn push(&mut self, t_ns: u64) {
        if let Some(l) = self.last
            && t_ns > l
        {
            self.positive.push(t_ns - l);
        }
        self.last = Some(t_ns);
        self.samples += 1;
    }

    /// The nominal interval learned from the stamps (the module docs' rule), and a sequencer
    /// that applies it to the same samples in the same order.
    pub fn sequencer(mut self) -> Sequencer {
        let mut tf = TimeFaults {
            samples: self.samples,
            ..TimeFaults::default()
        };
        let pos = &mut self.positive;
        if pos.is_empty() {
            // No time base: sequence by row; every repeat of a time stamp is still a duplicate.
            return Sequencer {
                tf,
                period: None,
                gap_at: 0.0,
                seq: 0,
                last: None,
            };
        }
        let mean = pos.iter().map(|&d| d as f64).sum::<f64>() / pos.len() as f64;
        let mid = pos.len() / 2;
        let median = *pos.select_nth_unstable(mid).1 as f64;
        // Span covered by forward time, and how much of it median-spaced samples would fill. A
        // pause that would be a gap even for bursty stamps (beyond BURSTY_GAP_FACTOR mean
        // intervals) is left out of the span: a logger that stopped for longer than it ran is
        // not bursty.
        let long = BURSTY_GAP_FACTOR * mean;
        let (span, n_span) = pos
            .iter()
            .map(|&d| d as f64)
            .filter(|&d| d <= long)
            .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
        let coverage = if span > 0.0 {
            median * n_span as f64 / span
        } else {
            1.0
        };
        tf.bursty = coverage < BURSTY_COVERAGE;
        tf.median_interval_s = median * 1e-9;
        tf.mean_interval_s = mean * 1e-9;
        let (period, gap_at) = if tf.bursty {
            (mean, BURSTY_GAP_FACTOR * mean)
        } else {
            // The mean of the intervals near the median: gaps (≥ 2 medians) cannot move it, and
            // one-sided jitter of millisecond host stamps (6, 7, 8, 9 ms at a median of 6) does
            // not bias it as it biases the median (the rtklibexplorer walk: 152 Hz, not 166.7 Hz).
            let (sum, n) = pos
                .iter()
                .map(|&d| d as f64)
                .filter(|&d| d > 0.5 * median && d < 2.0 * median)
                .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
            let period = if n > 0 { sum / n as f64 } else { median };
            (period, 1.5 * period)
        };
        tf.nominal_rate_hz = 1e9 / period;
        Sequencer {
            tf,
            period: Some(period),
            gap_at,
            seq: 0,
            last: None,
        }
    }
}

/// [`derive_sequence`]'s rule applied one sample at a time ([`Stamps::sequencer`]): each
/// sample's `seq` set and its time faults flagged and counted.
#[derive(Debug)]
pub struct Sequencer {
    tf: TimeFaults,
    /// The nominal interval, ns (`None`: no time base, the stamps never advance).
    period: Option<f64>,
    gap_at: f64,
    seq: u32,
    /// The latest stamp (`None` before the first sample).
    last: Option<u64>,
}

impl Sequencer {
    /// Sequence and flag the next sample.
    pub fn next(&mut self, s: &mut Sample) {
        let t = s.t_ns;
        let Some(last) = self.last else {
            s.seq = 0;
            self.last = Some(t);
            return;
        };
        let tf = &mut self.tf;
        let Some(period) = self.period else {
            s.seq = 0;
            s.flags |= flags::DUPLICATE;
            tf.duplicates += 1;
            return;
        };
        if t == last {
            s.flags |= flags::DUPLICATE;
            tf.duplicates += 1;
        } else if t < last {
            tf.backwards += 1;
            if ((last - t) as f64) < BACKWARD_WINDOW * period {
                s.flags |= flags::DUPLICATE;
                tf.duplicates += 1;
            } else {
                s.flags |= flags::GAP;
                tf.restarts += 1;
                // A restart: a clear jump in the sequence, which the decoder reads as a gap too.
                self.seq = self.seq.wrapping_add(2);
                self.last = Some(t);
            }
        } else {
            let dt = (t - last) as f64;
            let mut step = 1u64;
            if dt > self.gap_at {
                step = ((dt / period).round() as u64).max(2);
                s.flags |= flags::GAP;
                tf.gaps += 1;
                tf.missing += step - 1;
            }
            self.seq = self.seq.wrapping_add(step.min(u32::MAX as u64 / 2) as u32);
            self.last = Some(t);
        }
        s.seq = self.seq;
    }

    /// The faults found so far, with the rate and intervals learned.
    pub fn faults(&self) -> TimeFaults {
        self.tf
    }
}

/// [`derive_sequence`] over a whole recording a streaming decoder has already sequenced from its
/// time stamps (UBX, MAVLink, ULog, MCAP: no sample counter). The decoder learns the period from
/// the first intervals of the stream (holding those samples meanwhile, so a gap among them is
/// flagged too), and its period is their median, not this module's rule, which can judge an
/// interval near 1.5 periods differently. With the whole recording at hand, the
/// `GAP` and `DUPLICATE` flags it set are cleared and derived afresh, exactly as for a CSV of
/// the same stream (no other code sets those two flags on these protocols' samples).
pub fn rederive_sequence(samples: &mut [Sample]) -> TimeFaults {
    for s in samples.iter_mut() {
        s.flags &= !(flags::GAP | flags::DUPLICATE);
    }
    derive_sequence(samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(ms: &[u64]) -> Vec<Sample> {
        ms.iter()
            .map(|&m| Sample {
                t_ns: m * 1_000_000,
                ..Sample::default()
            })
            .collect()
    }

    #[test]
    fn gap_duplicate_and_backward_step_are_flagged_and_sequenced() {
        let mut v = at(&[0, 10, 20, 20, 30, 60, 50, 70, 80, 90, 100, 110, 120]);
        let tf = derive_sequence(&mut v);
        let seqs: Vec<u32> = v.iter().map(|s| s.seq).collect();
        // 60 after 30: two missing; 50 after 60: a late repeat (kept at 6).
        assert_eq!(seqs, vec![0, 1, 2, 2, 3, 6, 6, 7, 8, 9, 10, 11, 12]);
        assert!(v[3].has(flags::DUPLICATE));
        assert!(v[5].has(flags::GAP));
        assert!(v[6].has(flags::DUPLICATE));
        assert_eq!(
            (tf.gaps, tf.missing, tf.duplicates, tf.backwards),
            (1, 2, 2, 1)
        );
        assert_eq!(tf.nominal_rate_hz, 100.0);
        // Counts of one read as one (it once printed "1 gaps").
        let text = tf.to_string();
        assert!(
            text.contains("; 1 gap (2 samples missing), 2 duplicate time stamps, 1 sample stamped behind the latest time (0 of them restarts)"),
            "{text}"
        );
    }

    #[test]
    fn one_long_gap_does_not_move_the_nominal_rate() {
        // 100 s at 100 Hz with 10 s missing: the mean would say 90 Hz.
        let ms: Vec<u64> = (0..10_000u64)
            .filter(|i| !(5_000..6_000).contains(i))
            .map(|i| i * 10)
            .collect();
        let mut v = at(&ms);
        let tf = derive_sequence(&mut v);
        assert_eq!(tf.nominal_rate_hz, 100.0);
        assert_eq!((tf.gaps, tf.missing), (1, 1000));
        assert!(!tf.bursty);
    }

    #[test]
    fn a_gap_longer_than_the_data_is_a_gap_not_bursty_stamps() {
        // 100 Hz: 20 s, a 50-s stop, 10 s more. Before, the stop made median-spaced samples
        // cover 37 % of the span: read as bursty at 37.49 Hz (the mean), the stop 1 gap of 0.
        let mut ms: Vec<u64> = (0..2000).map(|i| i * 10).collect();
        ms.extend((0..1000).map(|i| 70_000 + i * 10));
        let mut v = at(&ms);
        let tf = derive_sequence(&mut v);
        assert!(!tf.bursty, "{tf:?}");
        assert_eq!(tf.nominal_rate_hz, 100.0);
        // 50.01 s between the two samples around the stop: 5001 intervals, 5000 missing.
        assert_eq!((tf.gaps, tf.missing), (1, 5000), "{tf:?}");
    }

    #[test]
    fn bursty_host_stamps_take_the_mean_and_ignore_burst_pauses() {
        // Bursts of 5 samples 1 ms apart every 50 ms (a 100-Hz sensor read in packets), and one
        // real 2-s outage.
        let mut ms = Vec::new();
        for b in 0..200u64 {
            let t0 = b * 50 + if b >= 100 { 2000 } else { 0 };
            ms.extend((0..5).map(|k| t0 + k));
        }
        let mut v = at(&ms);
        let tf = derive_sequence(&mut v);
        assert!(tf.bursty);
        // Mean interval over the whole span: (199 × 50 + 2000 + 4) ms / 999 intervals.
        assert!((tf.nominal_rate_hz - 999.0 / 11.954).abs() < 1e-6, "{tf:?}");
        assert_eq!(tf.gaps, 1, "{tf:?}");
    }
}
