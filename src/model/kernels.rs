//! Inner sums of the AR fitters, written so the compiler can vectorise them.
//!
//! A plain `iter().sum()` of f64 runs through one accumulator: every add waits for the previous
//! one (floating-point addition is not reassociated by the compiler), so a long sum runs at one
//! add per add-latency. Here every sum is split over `LANES` independent accumulators, filled
//! from fixed-size chunks (no loop-carried dependency between lanes, so the chunk body maps onto
//! SIMD registers), and reduced once at the end. Multi-lag products are blocked so that a block
//! of the series stays in L1 while every lag is summed over it.
//!
//! The summation order differs from a sequential sum, so results agree with it to rounding
//! (a few ulp per block, relative to the sum of |terms|), not bit for bit.

/// Independent accumulators per sum (8 f64 = two AVX or four SSE2 registers).
const LANES: usize = 8;

/// Elements per block of the blocked loops (2 048 f64 = 16 KiB: a block and its lag window fit
/// in a 32 KiB L1 data cache).
pub(crate) const BLOCK: usize = 2048;

#[inline]
fn reduce(acc: [f64; LANES]) -> f64 {
    // pairwise
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]))
}

/// Σ x.
pub(crate) fn sum(x: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let c = x.chunks_exact(LANES);
    let rest = c.remainder();
    for ch in c {
        for l in 0..LANES {
            acc[l] += ch[l];
        }
    }
    reduce(acc) + rest.iter().sum::<f64>()
}

/// Σ a·b over the common length.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; LANES];
    let ca = a.chunks_exact(LANES);
    let cb = b.chunks_exact(LANES);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..LANES {
            acc[l] += x[l] * y[l];
        }
    }
    reduce(acc) + ra.iter().zip(rb).map(|(x, y)| x * y).sum::<f64>()
}

/// Running sums of Burg's reflection coefficient: Σ f·b and Σ (f² + b²) over pairs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CrossEnergy {
    cross: [f64; LANES],
    energy: [f64; LANES],
    tail_cross: f64,
    tail_energy: f64,
}

impl CrossEnergy {
    pub(crate) fn new() -> Self {
        CrossEnergy {
            cross: [0.0; LANES],
            energy: [0.0; LANES],
            tail_cross: 0.0,
            tail_energy: 0.0,
        }
    }

    /// Add the pairs (f[i], b[i]) over the common length.
    #[inline]
    pub(crate) fn add(&mut self, f: &[f64], b: &[f64]) {
        let n = f.len().min(b.len());
        let (f, b) = (&f[..n], &b[..n]);
        let cf = f.chunks_exact(LANES);
        let cb = b.chunks_exact(LANES);
        let (rf, rb) = (cf.remainder(), cb.remainder());
        for (x, y) in cf.zip(cb) {
            for l in 0..LANES {
                self.cross[l] += x[l] * y[l];
                self.energy[l] += x[l] * x[l] + y[l] * y[l];
            }
        }
        for (x, y) in rf.iter().zip(rb) {
            self.tail_cross += x * y;
            self.tail_energy += x * x + y * y;
        }
    }

    /// (Σ f·b, Σ f² + b²).
    pub(crate) fn finish(&self) -> (f64, f64) {
        (
            reduce(self.cross) + self.tail_cross,
            reduce(self.energy) + self.tail_energy,
        )
    }
}

/// Lagged products `s[k] = Σ_{n=k}^{N-1} d[n] d[n-k]` for k = 0..=max_lag (zero for k ≥ N),
/// in one blocked pass over `d`.
pub(crate) fn lagged_products(d: &[f64], max_lag: usize) -> Vec<f64> {
    let n = d.len();
    let mut s = vec![0.0; max_lag + 1];
    let top = max_lag.min(n.saturating_sub(1));
    let mut start = 0;
    while start < n {
        let end = (start + BLOCK).min(n);
        for (k, sk) in s.iter_mut().enumerate().take(top + 1) {
            let lo = start.max(k);
            if lo < end {
                *sk += dot(&d[lo..end], &d[lo - k..end - k]);
            }
        }
        start = end;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn series(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        (0..n).map(|_| rng.normal() + 0.3).collect()
    }

    /// Sequential reference sums in f64 with compensated (Kahan) addition, so the reference
    /// is accurate to ~1 ulp of the sum.
    fn kahan(it: impl Iterator<Item = f64>) -> (f64, f64) {
        let (mut s, mut c, mut abs) = (0.0f64, 0.0f64, 0.0f64);
        for v in it {
            abs += v.abs();
            let y = v - c;
            let t = s + y;
            c = (t - s) - y;
            s = t;
        }
        (s, abs)
    }

    // Blocked / laned summation vs an exact-ish sum: the rounding error of a sum of n terms in
    // any order is below n ε Σ|terms|; with n ≤ 5 000 that bound is ~1.1e-12 Σ|terms|, so
    // 1e-12 relative to Σ|terms| is the bound these checks use (they pass by a wide margin).
    const REL: f64 = 1e-12;

    #[test]
    fn sums_match_compensated_reference_for_every_length_remainder() {
        for n in [0usize, 1, 7, 8, 9, 15, 17, 100, 2047, 2048, 2049, 4999] {
            let x = series(n, n as u64 + 1);
            let y = series(n, n as u64 + 99);
            let (s, a) = kahan(x.iter().copied());
            assert!((sum(&x) - s).abs() <= REL * a.max(1e-300), "sum n={n}");
            let (s, a) = kahan(x.iter().zip(&y).map(|(u, v)| u * v));
            assert!((dot(&x, &y) - s).abs() <= REL * a.max(1e-300), "dot n={n}");
            let mut ce = CrossEnergy::new();
            // split in two uneven calls, as the blocked Burg loop does
            let h = n / 3;
            ce.add(&x[..h], &y[..h]);
            ce.add(&x[h..], &y[h..]);
            let (c, e) = ce.finish();
            let (s, a) = kahan(x.iter().zip(&y).map(|(u, v)| u * v));
            assert!((c - s).abs() <= REL * a.max(1e-300), "cross n={n}");
            let (s, a) = kahan(x.iter().zip(&y).map(|(u, v)| u * u + v * v));
            assert!((e - s).abs() <= REL * a.max(1e-300), "energy n={n}");
        }
    }

    #[test]
    fn lagged_products_match_direct_sums() {
        for n in [1usize, 5, 2048, 4500] {
            let d = series(n, 3 + n as u64);
            let s = lagged_products(&d, 12);
            for (k, sk) in s.iter().enumerate() {
                if k >= n {
                    assert_eq!(*sk, 0.0);
                    continue;
                }
                let (r, a) = kahan((k..n).map(|i| d[i] * d[i - k]));
                assert!((sk - r).abs() <= REL * a.max(1e-300), "n={n} k={k}");
            }
        }
    }
}
