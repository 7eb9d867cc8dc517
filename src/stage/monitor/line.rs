//! A spectral line in a channel at rest: a Welch periodogram bin standing out from its
//! neighbours.
//!
//! Contiguous still segments of `N` samples (a power of two), Hann-windowed; after every segment
//! the last `K` are averaged (a moving Welch average, so a line is seen within `K` segments of
//! its start). Noise spectra are smooth, so each bin is compared with the median of its
//! neighbours (±`NEIGHBOURS` bins, the bin's own main lobe excluded): for noise the ratio is
//! `χ²(2K)/2K` over that distribution's median, whatever the noise's colour. A line is suspected
//! at a local maximum whose ratio is ≥ `k` (k = 6 with K = 6: P ≈ 1.4e-10 per bin and test).
//! A line is one event: it is active until absent from `K` consecutive tests (a whole average
//! without it), and a line that returns near a frequency already reported (within 3 bins or 10 %,
//! the last frequency seen: a line may drift, e.g. with a fan's speed) is the same effect,
//! tracked, not a new one.

use crate::stats::line::neighbour_median;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Neighbours each side of a bin that make its reference level.
const NEIGHBOURS: usize = 16;
/// Bins each side of a bin excluded from its reference (the Hann main lobe is ±2 bins).
const LOBE: usize = 2;
/// Lowest bin tested (below it: the bias's own slow wander, not a line).
const FIRST_BIN: usize = 4;

/// One line alarm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineEvent {
    /// Sensor time of the end of the average that raised it, ns.
    pub t_ns: u64,
    /// Frequency, Hz (bin centre).
    pub freq_hz: f64,
    /// The bin's power over its neighbours' median (noise ≈ 1).
    pub ratio: f64,
    /// Which line of the channel (index of [`LineDetector::known_hz`]).
    pub id: usize,
}

#[derive(Debug, Clone, Copy)]
struct Active {
    bin: usize,
    missing: u32,
    /// Index of the known line this is.
    id: usize,
}

/// Line detector of one channel.
pub struct LineDetector {
    n: usize,
    k_avg: usize,
    k: f64,
    fs: f64,
    fft: Arc<dyn Fft<f64>>,
    window: Vec<f64>,
    seg: Vec<f64>,
    buf: Vec<Complex<f64>>,
    /// Power spectra of the last `k_avg` segments (ring) and their sum.
    spectra: Vec<Vec<f64>>,
    next: usize,
    acc: Vec<f64>,
    segs: usize,
    active: Vec<Active>,
    /// Lines reported: their last frequency seen, Hz.
    known: Vec<f64>,
    pub events: u64,
    /// Median over the neighbours of the χ²(2K)/2K ratio's noise median (normalises the ratio).
    median_norm: f64,
}

impl std::fmt::Debug for LineDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LineDetector")
            .field("n", &self.n)
            .field("k_avg", &self.k_avg)
            .field("active", &self.active)
            .finish()
    }
}

/// Median of χ²(ν)/ν (Wilson–Hilferty; within 0.1 % for ν ≥ 4).
fn chi2_median_over_dof(dof: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    (1.0 - a).powi(3)
}

impl LineDetector {
    /// Segments of `n` samples (rounded up to a power of two) at `fs` Hz, `k_avg` per average,
    /// alarm at a bin-over-neighbours ratio of `k`.
    pub fn new(n: usize, k_avg: usize, k: f64, fs: f64) -> Self {
        let n = n.max(64).next_power_of_two();
        let fft = FftPlanner::new().plan_fft_forward(n);
        let window = (0..n)
            .map(|i| {
                let x = std::f64::consts::PI * i as f64 / n as f64;
                x.sin().powi(2)
            })
            .collect();
        let k_avg = k_avg.max(1);
        LineDetector {
            n,
            k_avg,
            k,
            fs,
            fft,
            window,
            seg: Vec::with_capacity(n),
            buf: vec![Complex::new(0.0, 0.0); n],
            spectra: vec![vec![0.0; n / 2 + 1]; k_avg],
            next: 0,
            acc: vec![0.0; n / 2 + 1],
            segs: 0,
            active: Vec::new(),
            known: Vec::new(),
            events: 0,
            median_norm: chi2_median_over_dof(2.0 * k_avg as f64),
        }
    }

    /// Last frequency of every line reported, Hz.
    pub fn known_hz(&self) -> &[f64] {
        &self.known
    }

    /// Frequencies of the lines present now, Hz.
    pub fn active_hz(&self) -> Vec<f64> {
        self.active.iter().map(|a| self.freq(a.bin)).collect()
    }

    /// Whether line `id` (see [`LineEvent::id`]) is present now.
    pub fn is_active(&self, id: usize) -> bool {
        self.active.iter().any(|a| a.id == id)
    }

    fn freq(&self, bin: usize) -> f64 {
        bin as f64 * self.fs / self.n as f64
    }

    /// The contiguous still run was broken: the partial segment is dropped (whole segments
    /// stay in the average: a line's power does not depend on the segments' phase).
    pub fn interrupt(&mut self) {
        self.seg.clear();
    }

    /// One still value; appends the lines raised by the average this value completes, if any.
    pub fn push(&mut self, t_ns: u64, v: f64, events: &mut Vec<LineEvent>) {
        self.seg.push(v);
        if self.seg.len() < self.n {
            return;
        }
        let mean = self.seg.iter().sum::<f64>() / self.n as f64;
        for ((b, x), w) in self.buf.iter_mut().zip(&self.seg).zip(&self.window) {
            *b = Complex::new((x - mean) * w, 0.0);
        }
        self.seg.clear();
        self.fft.process(&mut self.buf);
        let slot = &mut self.spectra[self.next];
        for ((a, s), b) in self.acc.iter_mut().zip(slot.iter_mut()).zip(&self.buf) {
            let p = b.norm_sqr();
            *a += p - *s;
            *s = p;
        }
        self.next = (self.next + 1) % self.k_avg;
        self.segs += 1;
        if self.segs < self.k_avg {
            return;
        }
        let over = self.over_threshold();
        let k_avg = self.k_avg as u32;
        for a in &mut self.active {
            let seen = over.iter().any(|&(b, _)| b.abs_diff(a.bin) <= LOBE);
            a.missing = if seen { 0 } else { a.missing + 1 };
        }
        self.active.retain(|a| a.missing < k_avg);
        for &(bin, ratio) in &over {
            if self.active.iter().any(|a| a.bin.abs_diff(bin) <= LOBE) {
                continue;
            }
            let f = self.freq(bin);
            let tol = (3.0 * self.fs / self.n as f64).max(0.1 * f);
            let (id, new) = match self.known.iter().position(|k| (k - f).abs() <= tol) {
                // The same line, back (or drifted): tracked, not new.
                Some(id) => {
                    self.known[id] = f;
                    (id, false)
                }
                None => {
                    self.known.push(f);
                    (self.known.len() - 1, true)
                }
            };
            self.active.push(Active {
                bin,
                missing: 0,
                id,
            });
            if new {
                self.events += 1;
                events.push(LineEvent {
                    t_ns,
                    freq_hz: f,
                    ratio,
                    id,
                });
            }
        }
    }

    /// Local maxima over threshold in the current average: (bin, ratio).
    fn over_threshold(&self) -> Vec<(usize, f64)> {
        let last = self.n / 2 - 1;
        let mut out = Vec::new();
        let mut nb = Vec::with_capacity(2 * NEIGHBOURS);
        for bin in FIRST_BIN..=last {
            let p = self.acc[bin];
            if p <= 0.0 || p < self.acc[bin - 1] || p < self.acc[(bin + 1).min(last)] {
                continue;
            }
            let m = neighbour_median(&self.acc, bin, NEIGHBOURS + LOBE, LOBE, last, &mut nb);
            if nb.len() < NEIGHBOURS {
                continue;
            }
            let reference = m / self.median_norm;
            if reference > 0.0 && p / reference >= self.k {
                out.push((bin, p / reference));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn feed(det: &mut LineDetector, xs: &[f64], fs: f64) -> Vec<LineEvent> {
        let mut ev = Vec::new();
        for (i, &x) in xs.iter().enumerate() {
            det.push((i as f64 / fs * 1e9) as u64, x, &mut ev);
        }
        ev
    }

    #[test]
    fn noise_has_no_line_and_a_line_appearing_half_way_is_found_within_two_minutes() {
        let fs = 100.0;
        // Red-ish noise (AR(1), φ = 0.9): coloured, yet smooth — the neighbour test does not
        // mistake its slope for a line. 2 h, 1024-sample segments, 6 per average, k = 6:
        // ≈ 700 tests × 500 bins at P ≈ 1.4e-10 each — no alarm expected.
        let mut r = Rng::new(3);
        let mut x = 0.0;
        let n = 720_000;
        let mut xs: Vec<f64> = (0..n)
            .map(|_| {
                x = 0.9 * x + r.normal();
                x
            })
            .collect();
        let mut det = LineDetector::new(1000, 6, 6.0, fs);
        assert!(feed(&mut det, &xs, fs).is_empty());
        // A 3.3-Hz sine of amplitude 1 (noise sd ≈ 2.3: 0.43 σ; 8× the noise in its bin) from
        // half-way on.
        for (i, v) in xs.iter_mut().enumerate().skip(n / 2) {
            *v += 1.0 * (2.0 * std::f64::consts::PI * 3.3 * i as f64 / fs).sin();
        }
        let mut det = LineDetector::new(1000, 6, 6.0, fs);
        let ev = feed(&mut det, &xs, fs);
        assert_eq!(ev.len(), 1, "{ev:?}");
        assert!((ev[0].freq_hz - 3.3).abs() < 0.1, "{:?}", ev[0]);
        let delay = ev[0].t_ns as f64 * 1e-9 - 3600.0;
        // Within one average (6 × 10.24 s) and the segment it began in: ≤ 71.7 s.
        assert!(
            delay > 0.0 && delay <= 71.7,
            "found {delay} s after it appeared"
        );
        assert_eq!(det.active_hz().len(), 1);
    }
}
