//! The audit's seeded injections (spikes and runs, isolated outliers, bad values) and their
//! scoring against the labels (definitions in the parent module's docs).

use super::SCORE_FROM;
use crate::rng::Rng;
use crate::sample::{N_CHANNELS, Sample, flags};
use crate::stats::robust::robust_sigma;
use serde::Serialize;

/// Least spacing of injected spikes and runs, samples (any channel).
const SPIKE_GAP: usize = 40;

/// Local robust spread of channel `c` around each sample (±100 samples, every 25th sample
/// computed and held: the scale changes slowly).
fn local_sigma(samples: &[Sample], c: usize) -> Vec<f64> {
    let n = samples.len();
    let x: Vec<f64> = samples.iter().map(|s| s.channel(c)).collect();
    let mut out = vec![0.0; n];
    let mut i = 0;
    while i < n {
        let lo = i.saturating_sub(100);
        let hi = (i + 101).min(n);
        let s = robust_sigma(&x[lo..hi]);
        for o in out.iter_mut().skip(i).take(25) {
            *o = s;
        }
        i += 25;
    }
    out
}

/// Seeded spikes and runs (module docs); returns the labels. Events land on a random channel at
/// 1.2e-2 per sample (2e-3 per channel-sample) and never within `SPIKE_GAP` samples of another
/// event on any channel: gross errors are rare in real data, and each one must be judged on its
/// own, not against a neighbour's.
pub fn inject_spikes(samples: &mut [Sample], seed: u64) -> Vec<[bool; N_CHANNELS]> {
    let n = samples.len();
    let mut labels = vec![[false; N_CHANNELS]; n];
    let sig: Vec<Vec<f64>> = (0..N_CHANNELS).map(|c| local_sigma(samples, c)).collect();
    let mut rng = Rng::new(seed);
    let mut i = SCORE_FROM.min(n);
    while i < n {
        if rng.uniform() < 6.0 * 2e-3 {
            let c = rng.below(N_CHANNELS as u64) as usize;
            let len = if rng.uniform() < 1.0 / 3.0 {
                2 + rng.below(9) as usize
            } else {
                1
            };
            let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            for j in i..(i + len).min(n) {
                let a = 6.0 + 24.0 * rng.uniform();
                let v = samples[j].channel(c) + sign * a * sig[c][i].max(1e-9);
                samples[j].set_channel(c, v);
                labels[j][c] = true;
            }
            i += len + SPIKE_GAP;
        } else {
            i += 1;
        }
    }
    labels
}

/// 2 % isolated outliers of 8–30 robust σ on each gyro channel; returns the labels.
#[allow(clippy::needless_range_loop)] // c indexes labels rows and the channel alike
pub fn inject_outliers(samples: &mut [Sample], seed: u64) -> Vec<[bool; N_CHANNELS]> {
    let n = samples.len();
    let mut labels = vec![[false; N_CHANNELS]; n];
    for c in 0..3 {
        let x: Vec<f64> = samples.iter().map(|s| s.channel(c)).collect();
        let s = robust_sigma(&x).max(1e-9);
        let mut rng = Rng::fork(seed, 100 + c as u64);
        let mut i = SCORE_FROM.min(n);
        while i < n {
            if rng.uniform() < 0.02 {
                let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                let a = 8.0 + 22.0 * rng.uniform();
                samples[i].set_channel(c, x[i] + sign * a * s);
                labels[i][c] = true;
                i += 2; // isolated
            } else {
                i += 1;
            }
        }
    }
    labels
}

/// Seeded bad values (module docs); returns their (index, channel).
pub fn inject_bad_values(samples: &mut [Sample], seed: u64) -> Vec<(usize, usize)> {
    let n = samples.len();
    let mut rng = Rng::new(seed);
    let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e30, -1e30];
    let mut at = Vec::new();
    for k in 0..40 {
        let i = if k % 4 == 0 {
            rng.below(SCORE_FROM.min(n) as u64) as usize
        } else {
            rng.below(n as u64) as usize
        };
        let c = rng.below(N_CHANNELS as u64) as usize;
        samples[i].set_channel(c, bad[k % bad.len()]);
        at.push((i, c));
    }
    at.sort();
    at.dedup();
    at
}

/// Channel `c` of `s` is flagged as bad or replaced.
pub(super) fn flagged_bad(s: &Sample, c: usize) -> bool {
    s.flags & (flags::NON_FINITE | flags::replaced_ch(c) | flags::sat_ch(c)) != 0
}

/// Replaced flags against labels, after `SCORE_FROM`: true and false positives, misses.
/// Counts, not ratios, so that several seeds' runs pool into one estimate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    pub tp: u64,
    pub fp: u64,
    #[serde(rename = "fn")]
    pub fn_: u64,
}

impl Counts {
    pub fn recall(&self) -> f64 {
        self.tp as f64 / (self.tp + self.fn_).max(1) as f64
    }
    pub fn precision(&self) -> f64 {
        self.tp as f64 / (self.tp + self.fp).max(1) as f64
    }
    pub fn f1(&self) -> f64 {
        let (p, r) = (self.precision(), self.recall());
        if p + r > 0.0 {
            2.0 * p * r / (p + r)
        } else {
            0.0
        }
    }
    pub fn add(&mut self, o: Counts) {
        self.tp += o.tp;
        self.fp += o.fp;
        self.fn_ += o.fn_;
    }
}

/// Count the replaced flags of `chans` in `out` against `labels`, after `SCORE_FROM`.
pub fn score(out: &[Sample], labels: &[[bool; N_CHANNELS]], chans: &[usize]) -> Counts {
    let mut k = Counts::default();
    for (s, l) in out.iter().zip(labels).skip(SCORE_FROM) {
        for &c in chans {
            let r = s.flags & flags::replaced_ch(c) != 0;
            match (r, l[c]) {
                (true, true) => k.tp += 1,
                (true, false) => k.fp += 1,
                (false, true) => k.fn_ += 1,
                _ => {}
            }
        }
    }
    k
}
