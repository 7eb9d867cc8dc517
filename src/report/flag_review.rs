//! What did the gross-error stage flag on a recording without labels? Each flagged event (a run
//! of consecutive replaced samples of one channel) is put in one class by tests that do not use
//! the stage's own forecast, so that "every flagged sample explained" can be checked on real
//! drives:
//!
//! - **impulse** — a lone sample more than 5 robust σ₂ from the mean of its two neighbours while
//!   the neighbours agree within 2 σ₂ (σ₂ = robust σ of `x[i] − (x[i−1] + x[i+1])/2` over the whole
//!   channel). For Gaussian noise P(> 5σ) ≈ 6e-7: a glitch of the sensor, a gross error.
//! - **level change** — the event ended in the stage's `LEVEL_CHANGE` (it lasted longer than
//!   `max_run`): a genuine step of the signal (a shock, a manoeuvre onset) that the stage replaced
//!   for `max_run` samples before accepting it.
//! - **burst** — within ±`BURST_HALF_WIDTH` samples the signal's deviation from its local median
//!   changes sign at least 3 times with excursions above 3 local robust σ: an oscillation
//!   (a shock ringing, engine or road vibration), genuine motion, not a gross error.
//! - **excursion** — none of these, and the event's peak is within 5 local robust σ (±100
//!   samples) of the local median: a tail of the signal's own local variability (heavy-tailed
//!   motion), not an outstanding sample.
//! - **other** — none of these.

use crate::sample::{N_CHANNELS, Sample, flags};
use crate::stats::robust::{sigma_from_abs_dev, upper_median};
use serde::Serialize;

/// Half-width of the neighbourhood searched for an oscillation, samples.
pub const BURST_HALF_WIDTH: usize = 10;
/// Half-width of the window of the local median and robust σ, samples.
const LOCAL_HALF_WIDTH: usize = 100;

/// Class of one flagged event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EventClass {
    Impulse,
    LevelChange,
    Burst,
    Excursion,
    Other,
}

/// One flagged event of one channel.
#[derive(Debug, Clone, Serialize)]
pub struct FlaggedEvent {
    pub channel: usize,
    /// Index of the first replaced sample and the number of replaced samples.
    pub start: usize,
    pub len: usize,
    pub class: EventClass,
    /// Largest |raw − local median| over the event, in local robust σ.
    pub size_sigma: f64,
}

/// Independent impulse test (module docs): true at lone samples > `k` σ₂ from their neighbours'
/// mean while the neighbours agree within 2 σ₂.
pub fn isolated_impulses(x: &[f64], k: f64) -> Vec<bool> {
    let n = x.len();
    let mut m = vec![false; n];
    if n < 3 {
        return m;
    }
    let dev: Vec<f64> = (1..n - 1)
        .map(|i| x[i] - 0.5 * (x[i - 1] + x[i + 1]))
        .collect();
    let mut a: Vec<f64> = dev.iter().map(|d| d.abs()).collect();
    let s = sigma_from_abs_dev(&mut a);
    for i in 1..n - 1 {
        m[i] = dev[i - 1].abs() > k * s && (x[i + 1] - x[i - 1]).abs() < 2.0 * s;
    }
    m
}

/// Local median and robust σ of `x` around `i` (±`LOCAL_HALF_WIDTH`).
fn local_scale(x: &[f64], i: usize, buf: &mut Vec<f64>) -> (f64, f64) {
    let lo = i.saturating_sub(LOCAL_HALF_WIDTH);
    let hi = (i + LOCAL_HALF_WIDTH + 1).min(x.len());
    buf.clear();
    buf.extend(x[lo..hi].iter().copied().filter(|v| v.is_finite()));
    if buf.is_empty() {
        return (0.0, 0.0);
    }
    let med = upper_median(buf);
    for v in buf.iter_mut() {
        *v = (*v - med).abs();
    }
    (med, sigma_from_abs_dev(buf))
}

/// Classify every flagged event of the stage output `out` against the raw input `raw` (same
/// length and order).
pub fn review(raw: &[Sample], out: &[Sample]) -> Vec<FlaggedEvent> {
    let n = raw.len().min(out.len());
    let mut events = Vec::new();
    let mut buf = Vec::with_capacity(2 * LOCAL_HALF_WIDTH + 1);
    for c in 0..N_CHANNELS {
        let x: Vec<f64> = raw[..n].iter().map(|s| s.channel(c)).collect();
        let imp = isolated_impulses(&x, 5.0);
        let mut i = 0;
        while i < n {
            if out[i].flags & flags::replaced_ch(c) == 0 {
                i += 1;
                continue;
            }
            let start = i;
            while i < n && out[i].flags & flags::replaced_ch(c) != 0 {
                i += 1;
            }
            let len = i - start;
            let (med, s) = local_scale(&x, start, &mut buf);
            let s = s.max(f64::MIN_POSITIVE);
            let size_sigma = x[start..i]
                .iter()
                .map(|v| (v - med).abs() / s)
                .fold(0.0, f64::max);
            let level_change = i < n && out[i].flags & flags::LEVEL_CHANGE != 0;
            let class = if len == 1 && imp[start] {
                EventClass::Impulse
            } else if level_change {
                EventClass::LevelChange
            } else {
                let lo = start.saturating_sub(BURST_HALF_WIDTH);
                let hi = (i + BURST_HALF_WIDTH).min(n);
                let mut sign_changes = 0;
                let mut last = 0.0f64;
                for v in &x[lo..hi] {
                    let d = v - med;
                    if d.abs() > 3.0 * s {
                        if last != 0.0 && d.signum() != last {
                            sign_changes += 1;
                        }
                        last = d.signum();
                    }
                }
                if sign_changes >= 3 {
                    EventClass::Burst
                } else if size_sigma < 5.0 {
                    EventClass::Excursion
                } else {
                    EventClass::Other
                }
            };
            events.push(FlaggedEvent {
                channel: c,
                start,
                len,
                class,
                size_sigma,
            });
        }
    }
    events
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn a_lone_spike_is_an_impulse_and_gaussian_noise_has_almost_none() {
        let mut r = Rng::new(5);
        let mut x: Vec<f64> = (0..100_000).map(|_| r.normal()).collect();
        // Gaussian noise: the 5σ test fires with P ≈ 6e-7 per sample (0.06 expected here).
        assert!(isolated_impulses(&x, 5.0).iter().filter(|m| **m).count() <= 2);
        x[500] += 12.0;
        let m = isolated_impulses(&x, 5.0);
        assert!(m[500]);
        // Its neighbours are not impulses (they are not > 5σ from their own neighbours' mean
        // while those agree: one of their neighbours is the spike).
        assert!(!m[499] && !m[501]);
    }
}
