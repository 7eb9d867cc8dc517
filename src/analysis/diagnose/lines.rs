//! Vibration lines over the whole log: candidates from the selection blocks' averaged spectrum,
//! the line tracked block by block (frequency, amplitude, phase), and its held-out prediction.
//!
//! **Candidates.** The Hann periodograms of the selection blocks (mean removed) are averaged:
//! with K blocks, P̂(f)/S(f) ~ χ²_{2K}/(2K). S is the running median over ±32 bins (±3 bins
//! excluded, the main lobe) divided by the median of χ²_{2K}/(2K) (Wilson–Hilferty,
//! (1 − 1/(9K))³). A local maximum is a candidate when its Bonferroni tail over the scanned bins
//! is below α; bins below 4 (slow effects, not lines) are not scanned. Quantisation noise is
//! white and lies in this floor, so a line that passes is above the quantisation.
//!
//! **Tracking.** In every block the frequency is the maximum of |X(f)|² = |Σ x_n e^{−iωn}|²
//! over ±1 bin of the candidate (¼-bin grid, parabolic refinement), computed by a rotating
//! phasor (no trigonometric call per sample); then (a, b) of a sin + b cos are least squares at
//! that frequency, time from the start of the log. The line is *present* in a block when
//! |X|²/(L σ²_f) — Exp(1) under noise, σ²_f = S(f) f_s/2 the white-equivalent variance near f —
//! exceeds ln(9 · blocks / α) (Bonferroni over the grid and the blocks).
//!
//! **Held-out prediction.** A held-out block is predicted by the mean of its two neighbouring
//! selection blocks' sinusoids, each continued with its own frequency and phase: no held-out
//! sample is used, and a phase that wandered between them shrinks the prediction instead of
//! inventing one.

use super::blocks::Blocks;
use crate::stats::line::{dft_at, neighbour_median, pair_ls, peak_on_grid};
use crate::stats::special::chi2_sf;
use rustfft::{FftPlanner, num_complex::Complex};
use serde::Serialize;
use std::f64::consts::PI;

/// A candidate line from the selection blocks.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LineCandidate {
    /// Frequency of the averaged spectrum's peak, Hz.
    pub freq_hz: f64,
    /// Peak over the local floor.
    pub ratio: f64,
    /// Bonferroni p-value over the scanned bins.
    pub p_value: f64,
    /// White-equivalent noise variance near the line, σ²_f = S(f) f_s / 2 (units²).
    pub noise_var: f64,
}

/// The line in one block.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BlockLine {
    /// Block centre, s.
    pub t_s: f64,
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Amplitude, units.
    pub amplitude: f64,
    /// Phase at t = 0 of this block's sinusoid, rad (x ≈ A sin(2πft + φ)).
    pub phase_rad: f64,
    /// |X|²/(L σ²_f).
    pub snr: f64,
    /// Significant in this block.
    pub present: bool,
    #[serde(skip)]
    a: f64,
    #[serde(skip)]
    b: f64,
}

impl BlockLine {
    fn value(&self, w: f64, i: usize) -> f64 {
        let (s, c) = (w * i as f64).sin_cos();
        self.a * s + self.b * c
    }
}

/// Candidate lines from the selection blocks of `y`, strongest first, at most `max`.
pub fn line_candidates(
    y: &[f64],
    blocks: &Blocks,
    rate_hz: f64,
    alpha: f64,
    max: usize,
) -> Vec<LineCandidate> {
    let l = blocks.len;
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(l);
    let w: Vec<f64> = (0..l)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / l as f64).cos())
        .collect();
    let sw2: f64 = w.iter().map(|v| v * v).sum();
    let half = l / 2;
    let mut avg = vec![0.0; half + 1];
    let mut k = 0usize;
    let mut buf = vec![Complex::new(0.0, 0.0); l];
    for b in (0..blocks.count).filter(|b| !Blocks::held_out(*b)) {
        let r = b * l..(b + 1) * l;
        let x = &y[r];
        let mean = x.iter().sum::<f64>() / l as f64;
        for ((o, v), wv) in buf.iter_mut().zip(x).zip(&w) {
            *o = Complex::new((v - mean) * wv, 0.0);
        }
        fft.process(&mut buf);
        for (j, a) in avg.iter_mut().enumerate() {
            *a += 2.0 * buf[j].norm_sqr() / (rate_hz * sw2);
        }
        k += 1;
    }
    if k == 0 {
        return vec![];
    }
    for a in &mut avg {
        *a /= k as f64;
    }
    let kf = k as f64;
    let med_corr = (1.0 - 1.0 / (9.0 * kf)).powi(3);
    let (hw, guard, lo) = (32usize, 3usize, 4usize);
    let hi = half.saturating_sub(2);
    if hi <= lo + 2 * guard {
        return vec![];
    }
    let m = (hi - lo) as f64;
    let mut scratch = Vec::with_capacity(2 * hw + 1);
    let mut floor_at =
        |j: usize| -> f64 { neighbour_median(&avg, j, hw, guard, half, &mut scratch) / med_corr };
    let mut out: Vec<LineCandidate> = Vec::new();
    for j in lo..hi {
        if !(avg[j] >= avg[j - 1] && avg[j] > avg[j + 1]) {
            continue;
        }
        let s = floor_at(j);
        if s.is_nan() || s <= 0.0 {
            continue;
        }
        let ratio = avg[j] / s;
        // Quick reject before the χ² tail: a ratio below 2 is never significant here.
        if ratio < 2.0 {
            continue;
        }
        let p = (m * chi2_sf(2.0 * kf * ratio, 2.0 * kf)).min(1.0);
        if p < alpha {
            out.push(LineCandidate {
                freq_hz: j as f64 * rate_hz / l as f64,
                ratio,
                p_value: p,
                noise_var: s * rate_hz / 2.0,
            });
        }
    }
    out.sort_by(|a, b| b.ratio.total_cmp(&a.ratio));
    let df = rate_hz / l as f64;
    let mut kept: Vec<LineCandidate> = Vec::new();
    for c in out {
        if kept.len() < max
            && kept
                .iter()
                .all(|k| (k.freq_hz - c.freq_hz).abs() > 3.0 * df)
        {
            kept.push(c);
        }
    }
    kept
}

/// Frequencies tried per block (±1 bin at ¼ bin).
const GRID: usize = 9;

/// The line near `cand` tracked in every block of `y`.
pub fn track(
    y: &[f64],
    blocks: &Blocks,
    rate_hz: f64,
    cand: &LineCandidate,
    alpha: f64,
) -> Vec<BlockLine> {
    let thr = (GRID as f64 * blocks.count as f64 / alpha).ln();
    (0..blocks.count)
        .map(|b| {
            let r = blocks.range(b);
            let l = r.len();
            let x = &y[r.clone()];
            let mean = x.iter().sum::<f64>() / l as f64;
            let bin = rate_hz / l as f64;
            let pw = |f: f64| {
                let (re, im) = dft_at(x, mean, 2.0 * PI * f / rate_hz, r.start);
                re * re + im * im
            };
            let step = 2.0 * bin / (GRID - 1) as f64;
            let f = peak_on_grid(pw, cand.freq_hz, step, GRID);
            let w = 2.0 * PI * f / rate_hz;
            let (a, bb) = pair_ls(x, mean, w, r.start);
            let snr = pw(f) / (l as f64 * cand.noise_var);
            BlockLine {
                t_s: (r.start + l / 2) as f64 / rate_hz,
                freq_hz: f,
                amplitude: a.hypot(bb),
                phase_rad: bb.atan2(a),
                snr,
                present: snr > thr,
                a,
                b: bb,
            }
        })
        .collect()
}

/// The line's contribution per sample: a selection block its own fit; a held-out block the mean
/// of its selection neighbours' sinusoids continued into it (no held-out data used).
pub fn contribution(track: &[BlockLine], blocks: &Blocks, rate_hz: f64) -> Vec<f64> {
    let mut out = vec![0.0; blocks.n];
    for b in 0..blocks.count {
        let r = blocks.range(b);
        let srcs: Vec<&BlockLine> = if Blocks::held_out(b) {
            [b.checked_sub(1), (b + 1 < blocks.count).then_some(b + 1)]
                .into_iter()
                .flatten()
                .map(|k| &track[k])
                .collect()
        } else {
            vec![&track[b]]
        };
        let kf = srcs.len().max(1) as f64;
        for s in srcs {
            let w = 2.0 * PI * s.freq_hz / rate_hz;
            for i in r.clone() {
                out[i] += s.value(w, i) / kf;
            }
        }
    }
    out
}

/// The line fitted in every block (held-out ones included): the deployment view.
pub fn contribution_in_sample(track: &[BlockLine], blocks: &Blocks, rate_hz: f64) -> Vec<f64> {
    let mut out = vec![0.0; blocks.n];
    for (b, s) in track.iter().enumerate() {
        let w = 2.0 * PI * s.freq_hz / rate_hz;
        for i in blocks.range(b) {
            out[i] = s.value(w, i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn a_line_that_appears_half_way_is_a_candidate_and_tracked_from_there() {
        // 20 min at 100 Hz, unit white noise, a 3.217 Hz line of amplitude 0.2 from 600 s on.
        // Per 30-s block |X|²/(Lσ²) ≈ A²L/(4σ²) = 30: far above ln(17·40/0.01) ≈ 11.1, and 0 with
        // no line; the averaged spectrum's peak is K·30/2-fold above the floor.
        let mut rng = Rng::new(7);
        let n = 120_000;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let line = if i >= 60_000 {
                    0.2 * (2.0 * PI * 3.217 * i as f64 / 100.0 + 0.4).sin()
                } else {
                    0.0
                };
                rng.normal() + line
            })
            .collect();
        let blocks = Blocks::new(n, 100.0, 1.0, 40, (10.0, 120.0)).unwrap();
        let c = line_candidates(&y, &blocks, 100.0, 0.01, 3);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!((c[0].freq_hz - 3.217).abs() < 0.02, "{c:?}");
        let t = track(&y, &blocks, 100.0, &c[0], 0.01);
        let present: Vec<bool> = t.iter().map(|b| b.present).collect();
        assert!(present[..20].iter().all(|p| !p), "{present:?}");
        assert!(present[20..].iter().all(|p| *p), "{present:?}");
        for b in &t[20..] {
            // Frequency sd on 30 s at this SNR ≈ 1e-3 Hz; amplitude sd ≈ √(2/L) = 0.026.
            assert!((b.freq_hz - 3.217).abs() < 0.01, "{b:?}");
            assert!((b.amplitude - 0.2).abs() < 0.08, "{b:?}");
        }
        let pred = contribution(&t, &blocks, 100.0);
        let truth = |i: usize| 0.2 * (2.0 * PI * 3.217 * i as f64 / 100.0 + 0.4).sin();
        let r = blocks.range(31);
        let err: f64 =
            r.clone().map(|i| (pred[i] - truth(i)).powi(2)).sum::<f64>() / r.len() as f64;
        // The held-out prediction is continued from its neighbours: well inside the line's
        // power A²/2 = 0.02.
        assert!(err < 0.004, "{err}");
    }
}
