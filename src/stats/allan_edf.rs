//! Equivalent degrees of freedom (EDF) of the overlapping Allan variance and its chi-squared
//! confidence interval (Greenhall & Riley 2003, "Uncertainty of stability variances based on
//! finite differences", Proc. 35th PTTI; NIST SP1065 §5.3–5.4).
//!
//! **Why EDF and not `1/sqrt(n)`.** The overlapping estimator averages `n = N_phase − 2m` second
//! differences that overlap by up to `2m − 1` samples, so they are strongly correlated: the
//! naive `σ/sqrt(n)` band is too narrow by a factor that depends on the noise type and on `m`
//! (for white FM at `m ≫ 1` the EDF is about `1.5 N/m`, not `N`). The EDF `ν` makes
//! `ν σ̂²/σ² ~ χ²(ν)` a good approximation, and it is what the term fit weights by.
//!
//! **Greenhall–Riley.** For a variance built from a `d`-th difference (Allan: `d = 2`) of phase,
//! with filter factor `F` (`F = m`: unmodified) and stride factor `S` (`S = m`: fully
//! overlapped), and a power-law noise `S_y(f) ∝ f^α`, the inverse EDF is (their eq. 10, 13)
//!
//! `1/ν = [ sz(0)² + (1 − J/M) sz(J/S)² + 2 Σ_{j=1}^{J−1} (1 − j/M) sz(j/S)² ] / (M sz(0)²)`
//!
//! with `M = N_phase − 2m` terms, `J = min(M, 3S)`, and the generalised autocovariances
//! `sw(t)` (α = 2: `−|t|`; α = 0: `|t|³`; α = −1: `t⁴ ln|t|`; α = −2: `|t|⁵`, signs immaterial
//! because only squares enter), `sx(t) = F² (2 sw(t) − sw(t − 1/F) − sw(t + 1/F))` (`F = ∞`:
//! `sx(t) = sw_{α+2}(t)`), `sz(t) = 6 sx(t) − 4 sx(t±1) + sx(t±2)`.
//! For `α ≤ 0`: the sum directly when `J ≤ 100`; for `r = M/m > 3` their large-`r` form
//! `1/ν = (a₀ − a₁/r)/r` with their Table 2 (`d = 2`); otherwise the sum with `J = M = 100` and
//! `S = 100/r`, all with `F = ∞`. Greenhall & Riley (and allantools) take `F = m` in the direct
//! sum when `3m ≤ 100`; for rate samples — the phase is their running sum, i.e. exact samples of
//! the integrated rate, not averages — `F = ∞` is the right model: for white FM it reproduces
//! the Monte-Carlo scatter at m = 1 (EDF 2730 vs 2720 measured over 3000 records of 4096
//! samples) where `F = m` gives 3205 (+18 %), and it is as close or closer for the other types
//! (tests below; `F = m` and `F = ∞` agree within 1–5 % from m ≈ 16 on).
//! For white PM (α = 2, `F = m`) `sx` is non-zero on the grid `j/m` only at `t = 0`, so the sum
//! has three terms and is exact in closed form for every `r`:
//! `1/ν = (1/M) [1 + (8/9)(1 − 1/r)₊ + (1/18)(1 − 2/r)₊]` (→ their `(a₀ − a₁/r)/M`,
//! `a₀ = C(8,4)/C(4,2)² = 35/18`, `a₁ = 1`, for `r > 2`).
//!
//! **Interval.** `σ² ∈ [ν σ̂²/χ²_ν(1 − p), ν σ̂²/χ²_ν(p)]`, `p = (1 − confidence)/2`
//! (NIST SP1065 eq. 45).

use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Power-law noise types an IEEE-952 term produces in the Allan variance of a rate signal,
/// named by the exponent α of the rate (frequency) PSD `S_y(f) ∝ f^α`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseType {
    /// α = 2, σ² ∝ τ⁻²: quantisation noise (white angle/velocity noise).
    WhitePm,
    /// α = 0, σ² ∝ τ⁻¹: angle / velocity random walk.
    WhiteFm,
    /// α = −1, σ² flat: bias instability (flicker).
    FlickerFm,
    /// α = −2, σ² ∝ τ: rate random walk (also stands in for a rate ramp, whose α = −3 the
    /// Allan variance's second difference does not admit: Greenhall requires α + 2d > 1).
    RandomWalkFm,
}

impl NoiseType {
    /// α of `S_y(f) ∝ f^α`.
    pub fn alpha(self) -> i32 {
        match self {
            NoiseType::WhitePm => 2,
            NoiseType::WhiteFm => 0,
            NoiseType::FlickerFm => -1,
            NoiseType::RandomWalkFm => -2,
        }
    }
}

/// Largest `J` for which the sum is evaluated directly (Greenhall & Riley's `J_max`).
const J_MAX: usize = 100;

/// `sw(t)` for exponent `alpha` (α + 2 for the `F = ∞` limit, so up to 0 + 2 = 2 and down to −2).
fn sw(t: f64, alpha: i32) -> f64 {
    let a = t.abs();
    match alpha {
        2 => -a,
        1 if a == 0.0 => 0.0,
        1 => t * t * a.ln(),
        0 => a * a * a,
        -1 if a == 0.0 => 0.0,
        -1 => a.powi(4) * a.ln(),
        -2 => a.powi(5),
        _ => f64::NAN,
    }
}

/// `sx(t)`; `f = None` is the `F = ∞` limit.
fn sx(t: f64, f: Option<f64>, alpha: i32) -> f64 {
    match f {
        None => sw(t, alpha + 2),
        Some(f) => f * f * (2.0 * sw(t, alpha) - sw(t - 1.0 / f, alpha) - sw(t + 1.0 / f, alpha)),
    }
}

/// `sz(t)` for the second difference (d = 2).
fn sz(t: f64, f: Option<f64>, alpha: i32) -> f64 {
    6.0 * sx(t, f, alpha) - 4.0 * (sx(t - 1.0, f, alpha) + sx(t + 1.0, f, alpha))
        + sx(t - 2.0, f, alpha)
        + sx(t + 2.0, f, alpha)
}

/// `1/ν` by the direct sum (their eq. 10 over eq. 13's normaliser).
fn inv_edf_sum(j_last: usize, big_m: f64, s: f64, f: Option<f64>, alpha: i32) -> f64 {
    let z0 = sz(0.0, f, alpha);
    let jl = j_last as f64;
    let mut sum = z0 * z0 + (1.0 - jl / big_m) * sz(jl / s, f, alpha).powi(2);
    for j in 1..j_last {
        let jf = j as f64;
        sum += 2.0 * (1.0 - jf / big_m) * sz(jf / s, f, alpha).powi(2);
    }
    sum / (big_m * z0 * z0)
}

/// Greenhall & Riley's Table 2, d = 2: `(a₀, a₁)` of the large-`r` form for α ≤ 0.
fn table2_d2(alpha: i32) -> (f64, f64) {
    match alpha {
        0 => (2.0 / 3.0, 1.0 / 3.0),
        -1 => (0.852, 0.375),
        _ => (1.079, 0.368),
    }
}

/// EDF of the overlapping Allan variance at averaging factor `m` from `n_phase` phase points
/// (`n_phase` = number of rate samples + 1), for noise `noise`. Returns NaN when `m = 0` or the
/// record has no second difference at `m` (`n_phase ≤ 2m`).
pub fn edf_oadev(noise: NoiseType, m: usize, n_phase: usize) -> f64 {
    if m == 0 || n_phase <= 2 * m {
        return f64::NAN;
    }
    let alpha = noise.alpha();
    let mf = m as f64;
    let big_m = (n_phase - 2 * m) as f64;
    let r = big_m / mf;
    let inv = if alpha == 2 {
        let pos = |v: f64| v.max(0.0);
        (1.0 + 8.0 / 9.0 * pos(1.0 - 1.0 / r) + 1.0 / 18.0 * pos(1.0 - 2.0 / r)) / big_m
    } else {
        let j = (n_phase - 2 * m).min(3 * m);
        if j <= J_MAX {
            inv_edf_sum(j, big_m, mf, None, alpha)
        } else if r > 3.0 {
            let (a0, a1) = table2_d2(alpha);
            (a0 - a1 / r) / r
        } else {
            inv_edf_sum(J_MAX, J_MAX as f64, J_MAX as f64 / r, None, alpha)
        }
    };
    1.0 / inv
}

/// Two-sided chi-squared interval `(lo, hi)` of a deviation `dev` estimated with `edf` degrees
/// of freedom at `confidence` (e.g. 0.6827 for ±1σ). NaN bounds for a non-positive or
/// non-finite EDF or a confidence outside (0, 1).
pub fn chi2_interval(dev: f64, edf: f64, confidence: f64) -> (f64, f64) {
    let Ok(chi) = ChiSquared::new(edf) else {
        return (f64::NAN, f64::NAN);
    };
    if !(confidence > 0.0 && confidence < 1.0) {
        return (f64::NAN, f64::NAN);
    }
    let p = 0.5 * (1.0 - confidence);
    let (q_lo, q_hi) = (chi.inverse_cdf(p), chi.inverse_cdf(1.0 - p));
    (dev * (edf / q_hi).sqrt(), dev * (edf / q_lo).sqrt())
}

/// Equivalent degrees of freedom of an overlapping Allan variance of white noise, `n` rate
/// samples, averaging factor `m` (Howe, Allan & Barnes 1981, Table 1, white FM; the closed form
/// [`edf_oadev`] is checked against).
pub fn edf_white(n: usize, m: usize) -> f64 {
    let (nf, mf) = (n as f64, m as f64);
    ((3.0 * (nf - 1.0) / (2.0 * mf) - 2.0 * (nf - 2.0) / nf) * 4.0 * mf * mf
        / (4.0 * mf * mf + 5.0))
        .max(1.0)
}

/// ±1σ (68.27 %), the confidence of the bands (as in Stable32 and allantools' default).
pub const ONE_SIGMA_CONFIDENCE: f64 = 0.682_689_492_137_085_9;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_fm_edf_matches_the_howe_allan_barnes_formula() {
        // Two routes to the same quantity (HAB 1981's formula for white FM vs Greenhall's sum /
        // asymptote): they agree within 1 % at every m up to the last octaves, where HAB's fit is
        // coarser (2 %).
        let n = 100_001;
        for m in [1usize, 2, 4, 16, 64, 256, 1024, 4096] {
            let g = edf_oadev(NoiseType::WhiteFm, m, n);
            let h = edf_white(n - 1, m);
            let tol = if m >= 1024 { 0.02 } else { 0.01 };
            assert!((g / h - 1.0).abs() < tol, "m={m}: {g} vs {h}");
        }
    }

    #[test]
    fn table_form_continues_the_direct_sum() {
        // The large-r form is Greenhall's fit to the sum: at the switch point (J just above
        // J_MAX) the direct sum with F = ∞ and the table must agree within the table's 3-digit
        // precision and the Riemann-sum error of the sum at S = 40 (1 %).
        for noise in [
            NoiseType::WhiteFm,
            NoiseType::FlickerFm,
            NoiseType::RandomWalkFm,
        ] {
            let (m, n_phase) = (40usize, 40 * 400 + 80);
            let table = edf_oadev(noise, m, n_phase);
            let big_m = (n_phase - 2 * m) as f64;
            let direct = 1.0 / inv_edf_sum(3 * m, big_m, m as f64, None, noise.alpha());
            assert!(
                (table / direct - 1.0).abs() < 0.01,
                "{noise:?}: {table} vs {direct}"
            );
        }
    }

    #[test]
    fn white_pm_closed_form_equals_the_direct_sum() {
        // The closed form is the three-term sum evaluated by hand: equal to rounding.
        for (m, n_phase) in [(1usize, 50usize), (4, 50), (8, 30), (16, 40), (10, 25)] {
            let big_m = (n_phase - 2 * m) as f64;
            let j = (n_phase - 2 * m).min(3 * m);
            let direct = 1.0 / inv_edf_sum(j, big_m, m as f64, Some(m as f64), 2);
            let closed = edf_oadev(NoiseType::WhitePm, m, n_phase);
            assert!(
                (closed / direct - 1.0).abs() < 1e-9,
                "m={m}: {closed} vs {direct}"
            );
        }
    }

    #[test]
    fn interval_brackets_the_estimate_and_narrows_with_edf() {
        let (lo, hi) = chi2_interval(1.0, 10.0, ONE_SIGMA_CONFIDENCE);
        assert!(lo < 1.0 && hi > 1.0, "{lo} {hi}");
        let (lo2, hi2) = chi2_interval(1.0, 1000.0, ONE_SIGMA_CONFIDENCE);
        assert!(lo2 > lo && hi2 < hi);
        // For large ν, σ̂ has relative sd ≈ 1/sqrt(2ν): the ±1σ band is ≈ ±2.24 % at ν = 1000.
        assert!((hi2 - 1.0 - 1.0 / 2000f64.sqrt()).abs() < 2e-3, "{hi2}");
        assert!(chi2_interval(1.0, 0.0, 0.68).0.is_nan());
        assert!(edf_oadev(NoiseType::WhiteFm, 10, 20).is_nan());
    }
}
