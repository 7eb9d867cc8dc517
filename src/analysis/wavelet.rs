//! Daubechies-4 (db4, 8 taps) discrete wavelet transform with periodic extension
//! ("periodization", as PyWavelets `mode="periodization"`), and wavelet denoising by soft
//! thresholding — the traditional pre-step Tamazin et al. 2013 (sec 5) apply before the AR
//! methods ("wavelet denoising of up to 4 levels of decomposition").
//!
//! One level on an even-length signal x (length n): with the decomposition filters
//! `h` (low) and `g` (high) of length F = 8,
//! `a[i] = sum_j h[j] x[(2i + F/2 - j) mod n]`, `d[i] = sum_j g[j] x[(2i + F/2 - j) mod n]`,
//! i = 0..n/2. The transform is orthogonal, so the inverse is its transpose:
//! `x[(2i + F/2 - j) mod n] += h[j] a[i] + g[j] d[i]`. An odd-length input is first extended
//! by repeating its last sample (as PyWavelets does), and the reconstruction is truncated back.
//!
//! Denoising (Donoho-Johnstone universal threshold): decompose `levels` times,
//! `sigma = median(|d_1|) / 0.6745` from the finest details, `lambda = sigma sqrt(2 ln N)`,
//! soft-threshold every detail level `d <- sign(d) max(|d| - lambda, 0)`, keep the
//! approximation, reconstruct.

use crate::stats::{NumError, check_series};

/// db4 decomposition low-pass filter (PyWavelets `Wavelet("db4").dec_lo`).
pub const DB4_DEC_LO: [f64; 8] = [
    -0.010_597_401_785_069_032,
    0.032_883_011_666_885_2,
    0.030_841_381_835_560_764,
    -0.187_034_811_719_093_09,
    -0.027_983_769_416_859_854,
    0.630_880_767_929_858_9,
    0.714_846_570_552_915_7,
    0.230_377_813_308_896_5,
];

/// db4 decomposition high-pass filter: `g[j] = (-1)^(j+1) h[F-1-j]`.
pub fn db4_dec_hi() -> [f64; 8] {
    let mut g = [0.0; 8];
    for (j, gj) in g.iter_mut().enumerate() {
        let s = if j % 2 == 0 { -1.0 } else { 1.0 };
        *gj = s * DB4_DEC_LO[7 - j];
    }
    g
}

/// Why a wavelet operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WaveletError {
    /// Too short for the levels asked (`levels` levels need 2^(levels−1) + 1 samples), or
    /// non-finite (the shared numerical vocabulary, [`NumError`]).
    #[error(transparent)]
    Numeric(#[from] NumError),
    #[error("levels must be 1..=8, got {0}")]
    BadLevels(usize),
    #[error("coefficient lengths do not match the decomposition")]
    Inconsistent,
}

/// A multi-level decomposition: `details[0]` is the finest level (d_1).
#[derive(Debug, Clone, PartialEq)]
pub struct Decomposition {
    /// Approximation at the coarsest level.
    pub approx: Vec<f64>,
    /// Detail coefficients, finest first.
    pub details: Vec<Vec<f64>>,
    /// Length of the signal entering each level (before odd-length extension), finest first.
    pub lengths: Vec<usize>,
}

/// One periodised analysis step. `x` must have even length >= 2.
fn dwt_step(x: &[f64], a: &mut Vec<f64>, d: &mut Vec<f64>) {
    let n = x.len();
    let g = db4_dec_hi();
    let half = n / 2;
    a.clear();
    d.clear();
    for i in 0..half {
        let (mut sa, mut sd) = (0.0, 0.0);
        for j in 0..8 {
            // (2i + 4 - j) mod n, computed without negative intermediates
            let idx = (2 * i + 4 + 8 * n - j) % n;
            sa += DB4_DEC_LO[j] * x[idx];
            sd += g[j] * x[idx];
        }
        a.push(sa);
        d.push(sd);
    }
}

/// One synthesis step (transpose of [`dwt_step`]); output length `2 * a.len()`.
fn idwt_step(a: &[f64], d: &[f64]) -> Vec<f64> {
    let half = a.len();
    let n = 2 * half;
    let g = db4_dec_hi();
    let mut x = vec![0.0; n];
    for i in 0..half {
        for j in 0..8 {
            let idx = (2 * i + 4 + 8 * n - j) % n;
            x[idx] += DB4_DEC_LO[j] * a[i] + g[j] * d[i];
        }
    }
    x
}

/// Decompose `x` into `levels` levels of db4 (periodization).
pub fn wavedec(x: &[f64], levels: usize) -> Result<Decomposition, WaveletError> {
    if levels == 0 || levels > 8 {
        return Err(WaveletError::BadLevels(levels));
    }
    // Each level halves the length (rounding up) and needs at least 2 samples in.
    check_series(x, (1 << (levels - 1)) + 1)?;
    let mut cur = x.to_vec();
    let mut details = Vec::with_capacity(levels);
    let mut lengths = Vec::with_capacity(levels);
    for _ in 0..levels {
        debug_assert!(cur.len() >= 2);
        lengths.push(cur.len());
        if cur.len() % 2 == 1 {
            let last = cur[cur.len() - 1];
            cur.push(last);
        }
        let (mut a, mut d) = (Vec::new(), Vec::new());
        dwt_step(&cur, &mut a, &mut d);
        details.push(d);
        cur = a;
    }
    Ok(Decomposition {
        approx: cur,
        details,
        lengths,
    })
}

/// Reconstruct the signal from a decomposition (exact inverse of [`wavedec`]).
pub fn waverec(dec: &Decomposition) -> Result<Vec<f64>, WaveletError> {
    if dec.details.len() != dec.lengths.len() {
        return Err(WaveletError::Inconsistent);
    }
    let mut cur = dec.approx.clone();
    for (d, &len) in dec.details.iter().zip(&dec.lengths).rev() {
        if d.len() != cur.len() || len.div_ceil(2) != d.len() {
            return Err(WaveletError::Inconsistent);
        }
        let mut x = idwt_step(&cur, d);
        x.truncate(len);
        cur = x;
    }
    Ok(cur)
}

/// Soft threshold: `sign(v) max(|v| - t, 0)`.
#[inline]
pub fn soft(v: f64, t: f64) -> f64 {
    if v > t {
        v - t
    } else if v < -t {
        v + t
    } else {
        0.0
    }
}

/// Result of a denoise: the signal and the threshold used.
#[derive(Debug, Clone, PartialEq)]
pub struct Denoised {
    /// Denoised signal, same length as the input.
    pub signal: Vec<f64>,
    /// Noise sd estimated from the finest details (MAD / 0.6745).
    pub sigma: f64,
    /// Universal threshold applied, `sigma sqrt(2 ln N)`.
    pub threshold: f64,
}

/// db4 universal-threshold soft denoising over `levels` levels (module docs).
pub fn denoise(x: &[f64], levels: usize) -> Result<Denoised, WaveletError> {
    let mut dec = wavedec(x, levels)?;
    let sigma = median_abs(&dec.details[0]) / 0.6745;
    let threshold = sigma * (2.0 * (x.len() as f64).ln()).sqrt();
    for d in dec.details.iter_mut() {
        for v in d.iter_mut() {
            *v = soft(*v, threshold);
        }
    }
    Ok(Denoised {
        signal: waverec(&dec)?,
        sigma,
        threshold,
    })
}

/// Median of |v| (as numpy's median); 0 for an empty slice.
fn median_abs(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut a: Vec<f64> = v.iter().map(|x| x.abs()).collect();
    crate::stats::robust::median(&mut a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn db4_filters_are_orthonormal() {
        // sum h^2 = 1, sum h = sqrt(2), h orthogonal to its even shifts and to g.
        let h = DB4_DEC_LO;
        let g = db4_dec_hi();
        let e: f64 = h.iter().map(|v| v * v).sum();
        assert!((e - 1.0).abs() < 1e-14);
        assert!((h.iter().sum::<f64>() - 2f64.sqrt()).abs() < 1e-14);
        for s in [2usize, 4, 6] {
            let c: f64 = (0..8 - s).map(|j| h[j] * h[j + s]).sum();
            assert!(c.abs() < 1e-14, "shift {s}: {c}");
        }
        let hg: f64 = h.iter().zip(&g).map(|(a, b)| a * b).sum();
        assert!(hg.abs() < 1e-14);
    }

    #[test]
    fn perfect_reconstruction_with_zero_threshold() {
        // Orthogonal transform: reconstruction to rounding (1e-12 on unit-scale data), for even,
        // odd and power-of-two lengths, 1..4 levels.
        let mut rng = Rng::new(1);
        for &n in &[64usize, 1000, 1001, 777] {
            let x: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            for levels in 1..=4 {
                let dec = wavedec(&x, levels).unwrap();
                let y = waverec(&dec).unwrap();
                assert_eq!(y.len(), n);
                let err = x
                    .iter()
                    .zip(&y)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(err < 1e-12, "n {n} levels {levels}: {err}");
            }
        }
    }

    #[test]
    fn energy_is_preserved_on_even_lengths() {
        // Parseval for an orthogonal transform (length divisible by 2^levels).
        let mut rng = Rng::new(2);
        let x: Vec<f64> = (0..512).map(|_| rng.normal()).collect();
        let dec = wavedec(&x, 4).unwrap();
        let ex: f64 = x.iter().map(|v| v * v).sum();
        let ec: f64 = dec.approx.iter().map(|v| v * v).sum::<f64>()
            + dec.details.iter().flatten().map(|v| v * v).sum::<f64>();
        assert!((ex - ec).abs() < 1e-10 * ex);
    }

    #[test]
    fn denoise_reduces_white_noise_on_a_smooth_signal() {
        let mut rng = Rng::new(3);
        let n = 4096;
        let clean: Vec<f64> = (0..n).map(|i| (i as f64 / 200.0).sin()).collect();
        let x: Vec<f64> = clean.iter().map(|c| c + 0.2 * rng.normal()).collect();
        let d = denoise(&x, 4).unwrap();
        let mse = |a: &[f64]| {
            a.iter()
                .zip(&clean)
                .map(|(p, q)| (p - q).powi(2))
                .sum::<f64>()
                / n as f64
        };
        // noise variance 0.04 before; 4 levels keep 1/16 of the band -> well under 0.01 after
        assert!(mse(&d.signal) < 0.01, "{}", mse(&d.signal));
        // the MAD estimate of the noise sd is within 10 % (finest details of a slow sine are
        // pure noise; 2048 coefficients give ~2 % sd)
        assert!((d.sigma / 0.2 - 1.0).abs() < 0.1, "{}", d.sigma);
    }
}
