//! The whole-log diagnosis's data layout and its held-out test (issue 17).
//!
//! **Interleaved blocks.** The log is cut into blocks of `block_s` (about 1/40 of the record,
//! 10–120 s, a whole number of decimation steps); even blocks are the *selection* part (every
//! candidate effect is proposed and fitted there: its structure and its coefficients), odd
//! blocks are *held out* (only scored). So both parts span the whole record: an effect that
//! starts at 2/3 of it is seen by the selection part and scored on held-out data after it, which
//! a split into a first and a last part cannot do.
//!
//! **Held-out test.** A candidate model M₁ (current model + the effect) is compared with the
//! current model M₀ by their one-step prediction errors e₀, e₁ on the held-out samples, each
//! predicted from its true past. The held-out gain is G = Σ(e₀² − e₁²). If M₀ is true, e₀ is
//! white with variance σ² and e₁ = e₀ − δ (δ = e₀ − e₁ is fixed by the selection part), so
//! G = Σ(2e₀δ − δ²) has mean −Σδ² and standard deviation 2σ√Σδ². The effect is kept when
//! z = G / (2σ̂√Σδ²) exceeds the normal quantile at α/m (one-sided; m the candidates of that
//! round, Bonferroni): since the null mean is negative, the level is at most α/m. Unlike a
//! per-block paired t-test this also scores an effect whose gain sits in one block (a step seen
//! through a tracked wander gains only in its transient), and G > 0 is implied: nothing that
//! worsens held-out error passes.

use crate::analysis::AnalysisError;
use crate::stats::NumError;
use crate::stats::special::normal_sf;
use serde::Serialize;
use std::ops::Range;

/// Block layout of one channel.
#[derive(Clone, Debug, Serialize)]
pub struct Blocks {
    /// Samples in the log.
    pub n: usize,
    /// Samples per decimation step (the slow analyses work on their means).
    pub dec: usize,
    /// Samples per block (a multiple of `dec`).
    pub len: usize,
    /// Number of blocks (the last one takes the tail).
    pub count: usize,
}

impl Blocks {
    /// Layout for `n` samples at `rate_hz`: about `target` blocks of `min_s..=max_s` s, each a
    /// whole number of `dec_s` steps. At least 20 blocks (10 held out) are required.
    pub fn new(
        n: usize,
        rate_hz: f64,
        dec_s: f64,
        target: usize,
        (min_s, max_s): (f64, f64),
    ) -> Result<Blocks, AnalysisError> {
        let dec = ((dec_s * rate_hz).round() as usize).max(1);
        let total_s = n as f64 / rate_hz;
        let block_s = (total_s / target as f64).clamp(min_s, max_s);
        let steps = ((block_s * rate_hz / dec as f64).round() as usize).max(1);
        let len = steps * dec;
        let count = n / len;
        if count < 20 || len < 64 {
            return Err(NumError::TooShort {
                needed: 20 * len.max(64),
                got: n,
            }
            .into());
        }
        Ok(Blocks { n, dec, len, count })
    }

    /// Sample range of block `b`; the last block runs to the end of the log.
    pub fn range(&self, b: usize) -> Range<usize> {
        let a = b * self.len;
        if b + 1 == self.count {
            a..self.n
        } else {
            a..a + self.len
        }
    }

    /// Whether block `b` is held out (odd blocks).
    pub fn held_out(b: usize) -> bool {
        b % 2 == 1
    }

    /// Block of sample `i`.
    pub fn block_of(&self, i: usize) -> usize {
        (i / self.len).min(self.count - 1)
    }

    /// Number of decimated points (the tail shorter than `dec` is dropped).
    pub fn n_dec(&self) -> usize {
        self.n / self.dec
    }

    /// Per decimated point: whether it lies in a held-out block.
    pub fn dec_held_out(&self) -> Vec<bool> {
        (0..self.n_dec())
            .map(|k| Self::held_out(self.block_of(k * self.dec)))
            .collect()
    }

    /// The samples of the selection blocks, concatenated.
    pub fn selection(&self, x: &[f64]) -> Vec<f64> {
        let mut v = Vec::with_capacity(self.n / 2 + self.len);
        for b in (0..self.count).filter(|b| !Self::held_out(*b)) {
            v.extend_from_slice(&x[self.range(b)]);
        }
        v
    }

    /// Mean of `x²` over the held-out samples.
    pub fn held_out_mse(&self, x: &[f64]) -> f64 {
        self.held_out_mse_of(|i| x[i])
    }

    /// Mean of `x(i)²` over the held-out samples `i`, for a series computed on the fly.
    pub fn held_out_mse_of(&self, x: impl Fn(usize) -> f64) -> f64 {
        let (mut s, mut k) = (0.0, 0usize);
        for b in (0..self.count).filter(|b| Self::held_out(*b)) {
            let r = self.range(b);
            k += r.len();
            s += r.map(&x).map(|v| v * v).sum::<f64>();
        }
        s / k.max(1) as f64
    }
}

/// Means of `x` over consecutive steps of `m` samples (a shorter tail is dropped).
pub fn step_means(x: &[f64], m: usize) -> Vec<f64> {
    x.chunks_exact(m.max(1))
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect()
}

/// The held-out comparison of two models (see the module docs).
#[derive(Clone, Debug, Serialize)]
pub struct HeldOutTest {
    /// Effect family.
    pub family: String,
    /// What the candidate is (frequency, time, lag ...).
    pub description: String,
    /// Held-out samples (or decimated points) scored.
    pub n: usize,
    /// Held-out MSE without the effect, units².
    pub mse_before: f64,
    /// Held-out MSE with it, units².
    pub mse_after: f64,
    /// Share of the held-out MSE removed, (before − after)/before.
    pub share_removed: f64,
    /// z = G / (2σ̂√Σδ²).
    pub z: f64,
    /// One-sided p-value of z.
    pub p_value: f64,
    /// The level it had to beat (α / candidates of the round).
    pub level: f64,
    /// Kept in the model.
    pub kept: bool,
    /// Why not, when not kept.
    pub reason: String,
}

/// How [`held_out_test`] estimates the noise of the gain G beyond white innovations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainNoise {
    /// σ² at least this (a line's local noise level when the residual is coloured: the gain's
    /// noise is set by the noise near the line's frequency).
    pub min_var: f64,
    /// With `hac_lags` > 0, the noise of G from the innovations' autocovariance up to that lag
    /// (Bartlett weights, Newey & West 1987): var G = 4 Σ_h w_h γ̂(h) Σ_k δ_k δ_{k+h}, never
    /// below the white value — for a stochastic model that leaves the innovations somewhat
    /// coloured.
    pub hac_lags: usize,
}

impl GainNoise {
    /// White innovations, σ² as measured.
    pub const WHITE: GainNoise = GainNoise {
        min_var: 0.0,
        hac_lags: 0,
    };
}

/// Compare the held-out one-step errors `e0` (without) and `e1` (with the effect) over the points
/// where `held[i]`; `level` is the per-candidate significance level, `noise` how the gain's
/// noise is estimated.
pub fn held_out_test(
    family: &str,
    description: String,
    e0: &[f64],
    e1: &[f64],
    held: impl Fn(usize) -> bool,
    level: f64,
    noise: GainNoise,
) -> HeldOutTest {
    let GainNoise { min_var, hac_lags } = noise;
    let (mut s0, mut s1, mut dd, mut k) = (0.0, 0.0, 0.0, 0usize);
    for (i, (a, b)) in e0.iter().zip(e1).enumerate() {
        if held(i) {
            s0 += a * a;
            s1 += b * b;
            dd += (a - b) * (a - b);
            k += 1;
        }
    }
    let kf = k.max(1) as f64;
    let sigma = (s1 / kf).max(min_var).sqrt();
    let g = s0 - s1;
    let white = 4.0 * sigma * sigma * dd;
    let mut var = white;
    if hac_lags > 0 {
        let n = e1.len();
        let mut extra = 0.0;
        for h in 1..=hac_lags.min(n.saturating_sub(1)) {
            let (mut gam, mut sd) = (0.0, 0.0);
            for k in 0..n - h {
                if held(k) && held(k + h) {
                    gam += e1[k] * e1[k + h];
                    sd += (e0[k] - e1[k]) * (e0[k + h] - e1[k + h]);
                }
            }
            let w = 1.0 - h as f64 / (hac_lags + 1) as f64;
            extra += 2.0 * w * (gam / kf) * sd;
        }
        var = (white + 4.0 * extra).max(white);
    }
    let z = if var > 0.0 { g / var.sqrt() } else { 0.0 };
    let p = normal_sf(z);
    let kept = p < level && g > 0.0;
    HeldOutTest {
        family: family.into(),
        description,
        n: k,
        mse_before: s0 / kf,
        mse_after: s1 / kf,
        share_removed: if s0 > 0.0 { g / s0 } else { 0.0 },
        z,
        p_value: p,
        level,
        kept,
        reason: if kept {
            String::new()
        } else if g <= 0.0 {
            "worsens held-out error".into()
        } else {
            format!("held-out gain within its noise (p = {p:.2e} ≥ {level:.2e})")
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn layout_interleaves_and_covers_the_log() {
        // 20 min at 100 Hz: 1200/40 = 30-s blocks of 3000 samples, 40 of them.
        let b = Blocks::new(120_000, 100.0, 1.0, 40, (10.0, 120.0)).unwrap();
        assert_eq!((b.len, b.count, b.dec), (3000, 40, 100));
        assert_eq!(b.range(39), 117_000..120_000);
        assert!(!Blocks::held_out(0) && Blocks::held_out(1));
        assert_eq!(b.selection(&vec![1.0; 120_000]).len(), 60_000);
        assert!(Blocks::new(10_000, 100.0, 1.0, 40, (10.0, 120.0)).is_err());
    }

    #[test]
    fn held_out_test_keeps_a_real_gain_and_rejects_noise() {
        // e1 white, unit variance; δ a fixed offset of 0.05 on 20 000 points: G ≈ Σδ² = 50 with
        // noise 2√50 ≈ 14 when the effect is real (z ≈ 3.5); when it is not (e0 white), G has
        // mean −50 and the test must not pass.
        let mut rng = Rng::new(3);
        let e: Vec<f64> = (0..20_000).map(|_| rng.normal()).collect();
        let real0: Vec<f64> = e.iter().map(|v| v + 0.05).collect();
        let t = held_out_test(
            "x",
            String::new(),
            &real0,
            &e,
            |_| true,
            0.01,
            GainNoise::WHITE,
        );
        assert!(t.kept && t.z > 2.5, "{t:?}");
        let fake1: Vec<f64> = e.iter().map(|v| v - 0.05).collect();
        let t = held_out_test(
            "x",
            String::new(),
            &e,
            &fake1,
            |_| true,
            0.01,
            GainNoise::WHITE,
        );
        assert!(!t.kept && t.mse_after > t.mse_before, "{t:?}");
    }
}
