//! The strongest vibration line in a series, when there is one: a sinusoid of fixed frequency,
//! amplitude and phase on top of the series' own noise.
//!
//! **Found.** The Hann periodogram of the series (mean removed) is compared bin by bin with its
//! local floor: the median over ±[`FLOOR_HALF_WIDTH`] bins, the main lobe's ±[`GUARD`] bins
//! excluded, divided by ln 2 (the median of Exp(1)). Under noise whose spectrum is smooth over
//! the floor's span, a bin over its floor is Exp(1) — over its estimated floor, of ν bins'
//! worth of information, nearer F(2, 2ν), tail (1 + r/ν)^{−ν}; the local maximum with the
//! smallest tail is tested against all M scanned bins at once, p = 1 − (1 − tail)^M (bins below
//! [`LOWEST_BIN`] are slow effects, not lines, and are not scanned).
//!
//! **Stationary.** A line keeps its amplitude and phase: the sinusoid fitted to each half of the
//! series at the line's frequency must agree with the other half's within half their amplitude
//! (a phase drift of under ~29°). A gait, a manoeuvre or a drifting tone that happens to make a
//! narrow peak does not.
//!
//! **Fitted.** The frequency is the maximum of the unwindowed periodogram |Σ (x_i − x̄)
//! e^{−iωi}|² over ±1 bin of the peak (⅛-bin grid, then a parabola through the grid's three
//! best points) — for one sinusoid in white noise, the least-squares frequency — and (a, b) of
//! a sin ωi + b cos ωi are least squares at that frequency, with an intercept.

use nalgebra::{Matrix3, Vector3};
use rustfft::{FftPlanner, num_complex::Complex};
use std::f64::consts::TAU;

/// Half-width of the local floor, bins.
pub const FLOOR_HALF_WIDTH: usize = 32;
/// Bins either side of a peak left out of its floor (the Hann main lobe is ±2 bins).
pub const GUARD: usize = 3;
/// The lowest bin scanned: below, a peak is a slow effect (a drift), not a line.
pub const LOWEST_BIN: usize = 4;
/// The shortest series searched (the floor needs its span of bins on each side).
pub const MIN_LEN: usize = 256;

/// A sinusoid in sample time: `a sin(ω i) + b cos(ω i)` at sample index `i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sinusoid {
    /// Angular frequency, rad per sample (0 < ω < π).
    pub omega: f64,
    pub a: f64,
    pub b: f64,
}

impl Sinusoid {
    /// Its value at sample index `i`.
    #[inline]
    pub fn value(&self, i: f64) -> f64 {
        let (s, c) = (self.omega * i).sin_cos();
        self.a * s + self.b * c
    }

    /// Its amplitude √(a² + b²).
    pub fn amplitude(&self) -> f64 {
        self.a.hypot(self.b)
    }

    /// The same sinusoid with its index origin moved `k` samples later: `shifted(k).value(i) ==
    /// value(i + k)`.
    pub fn shifted(&self, k: f64) -> Sinusoid {
        let (sd, cd) = (self.omega * k).sin_cos();
        Sinusoid {
            omega: self.omega,
            a: self.a * cd - self.b * sd,
            b: self.a * sd + self.b * cd,
        }
    }
}

/// The strongest line of `x` (finite values) if its test's p-value is below `alpha` and it is
/// stationary over `x` (module docs); `None` otherwise, or for a series shorter than
/// [`MIN_LEN`] or with a non-finite value.
pub fn strongest_line(x: &[f64], alpha: f64) -> Option<Sinusoid> {
    let n = x.len();
    if n < MIN_LEN || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let w = 0.5 - 0.5 * (TAU * i as f64 / n as f64).cos();
            Complex::new((v - mean) * w, 0.0)
        })
        .collect();
    FftPlanner::<f64>::new()
        .plan_fft_forward(n)
        .process(&mut buf);
    let half = n / 2;
    let p: Vec<f64> = buf[..=half].iter().map(|z| z.norm_sqr()).collect();
    let hi = half - 2;
    let mut scratch = Vec::with_capacity(2 * FLOOR_HALF_WIDTH + 1);
    let mut best: Option<(usize, f64)> = None;
    for j in LOWEST_BIN..hi {
        if !(p[j] >= p[j - 1] && p[j] > p[j + 1]) {
            continue;
        }
        scratch.clear();
        let lo_k = j.saturating_sub(FLOOR_HALF_WIDTH).max(1);
        let hi_k = (j + FLOOR_HALF_WIDTH).min(half);
        scratch.extend(
            (lo_k..=hi_k)
                .filter(|k| k.abs_diff(j) > GUARD)
                .map(|k| p[k]),
        );
        let floor = crate::stats::robust::median(&mut scratch) / std::f64::consts::LN_2;
        if floor > 0.0 {
            // The floor is an estimate: with ν bins' worth of information the ratio's tail is
            // (1 + r/ν)^{−ν} rather than e^{−r}. The median of Exp(1) has 2.08/m relative
            // variance (the mean's 1/m), and the Hann window's neighbouring bins are
            // correlated (1.5 bins of equivalent noise bandwidth): ν = m/3.
            let nu = scratch.len() as f64 / 3.0;
            let tail = -nu * (p[j] / floor / nu).ln_1p();
            if best.is_none_or(|(_, t)| tail < t) {
                best = Some((j, tail));
            }
        }
    }
    let (j, ln_tail) = best?;
    let scanned = (hi - LOWEST_BIN) as f64;
    // 1 − (1 − tail)^M, computed without cancellation.
    let p_value = -(scanned * (-ln_tail.exp()).ln_1p()).exp_m1();
    if p_value.is_nan() || p_value >= alpha {
        return None;
    }
    let omega = refine(x, mean, TAU * j as f64 / n as f64, TAU / n as f64);
    let whole = fit_at(x, omega, 0..n)?;
    let first = fit_at(x, omega, 0..n / 2)?;
    let second = fit_at(x, omega, n / 2..n)?;
    let gap = (first.a - second.a).hypot(first.b - second.b);
    (gap <= 0.5 * first.amplitude().max(second.amplitude())).then_some(whole)
}

/// The frequency within ±`bin` of `omega0` that maximises the unwindowed periodogram of `x`.
fn refine(x: &[f64], mean: f64, omega0: f64, bin: f64) -> f64 {
    const STEPS: i32 = 8;
    let power = |w: f64| {
        // Σ (x_i − x̄) e^{−iωi} by a rotating phasor, renormalised every 256 samples.
        let rot = Complex::from_polar(1.0, -w);
        let mut ph = Complex::new(1.0, 0.0);
        let mut acc = Complex::new(0.0, 0.0);
        for (i, v) in x.iter().enumerate() {
            acc += ph * (v - mean);
            ph *= rot;
            if i % 256 == 255 {
                ph /= ph.norm();
            }
        }
        acc.norm_sqr()
    };
    let grid: Vec<(f64, f64)> = (-STEPS..=STEPS)
        .map(|k| {
            let w = omega0 + bin * k as f64 / STEPS as f64;
            (w, power(w))
        })
        .collect();
    let k = (0..grid.len())
        .max_by(|&a, &b| grid[a].1.total_cmp(&grid[b].1))
        .unwrap_or(STEPS as usize);
    if k == 0 || k + 1 == grid.len() {
        return grid[k].0;
    }
    let (y0, y1, y2) = (grid[k - 1].1, grid[k].1, grid[k + 1].1);
    let den = y0 - 2.0 * y1 + y2;
    let shift = if den < 0.0 {
        0.5 * (y0 - y2) / den
    } else {
        0.0
    };
    grid[k].0 + shift.clamp(-0.5, 0.5) * bin / STEPS as f64
}

/// Least squares of `x[range]` on sin ωi, cos ωi and 1 (i the index in `x`).
fn fit_at(x: &[f64], omega: f64, range: std::ops::Range<usize>) -> Option<Sinusoid> {
    let mut g = Matrix3::<f64>::zeros();
    let mut r = Vector3::<f64>::zeros();
    for i in range {
        let (s, c) = (omega * i as f64).sin_cos();
        let u = Vector3::new(s, c, 1.0);
        g += u * u.transpose();
        r += u * x[i];
    }
    let sol = g.cholesky()?.solve(&r);
    Some(Sinusoid {
        omega,
        a: sol[0],
        b: sol[1],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn noise(n: usize, seed: u64, ar: f64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let mut prev = 0.0;
        (0..n)
            .map(|_| {
                prev = ar * prev + rng.normal();
                prev
            })
            .collect()
    }

    #[test]
    fn a_line_in_coloured_noise_is_found_and_fitted() {
        // A 0.22-cycle line of amplitude 1 on AR(1) noise of unit innovation σ (φ 0.6).
        let truth = Sinusoid {
            omega: TAU * 0.2213,
            a: 0.8,
            b: -0.6,
        };
        let mut x = noise(2000, 7, 0.6);
        for (i, v) in x.iter_mut().enumerate() {
            *v += truth.value(i as f64) + 3.0;
        }
        let l = strongest_line(&x, 1e-3).expect("found");
        // Cramér–Rao for n = 2000 at this SNR: σ_ω ≈ √(24/(n³ SNR)) ≈ 1e-4 rad; 10× that.
        assert!((l.omega - truth.omega).abs() < 1e-3, "{l:?}");
        // σ of a, b ≈ σ_noise(f) √(2/n) ≈ 0.05 here: 0.15 is three of them.
        assert!(
            (l.a - truth.a).abs() < 0.15 && (l.b - truth.b).abs() < 0.15,
            "{l:?}"
        );
        // The value continues: shifted by k is the value k samples on.
        let s = l.shifted(1234.0);
        assert!((s.value(5.0) - l.value(1239.0)).abs() < 1e-9);
    }

    #[test]
    fn noise_alone_rarely_holds_a_line() {
        // At α = 1e-3 the test should fire in about 1 of 1000 windows of pure noise; over 300
        // seeds each of white and AR(1) noise, more than 3 would be a miscalibrated test.
        let fired = (0..300u64)
            .flat_map(|s| [noise(2000, s, 0.0), noise(2000, 1000 + s, 0.9)])
            .filter(|x| strongest_line(x, 1e-3).is_some())
            .count();
        assert!(fired <= 3, "{fired} of 600 noise windows held a line");
    }

    #[test]
    fn a_tone_that_drifts_is_not_a_line() {
        // A chirp from 0.20 to 0.24 cycles per sample: a peak in the spectrum, but not a line.
        let n = 2000;
        let mut x = noise(n, 3, 0.0);
        let mut ph = 0.0;
        for (i, v) in x.iter_mut().enumerate() {
            ph += TAU * (0.20 + 0.04 * i as f64 / n as f64);
            *v += 3.0 * ph.sin();
        }
        assert_eq!(strongest_line(&x, 1e-3), None);
        // Too short, or not finite: no line, no panic.
        assert_eq!(strongest_line(&x[..100], 1e-3), None);
        let mut y = x.clone();
        y[10] = f64::NAN;
        assert_eq!(strongest_line(&y, 1e-3), None);
    }
}
