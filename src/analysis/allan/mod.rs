//! Overlapping Allan deviation at octave averaging times, and the noise coefficients read off
//! it (IEEE Std 952 / El-Sheimy, Hou & Niu 2008; used by the Sensors 2012 Nu-SVR paper, eq 10).
//!
//! For rate samples `y_i` (i = 0..N-1) at interval `tau0 = 1/rate`, the "phase" is the running
//! integral `x_0 = 0`, `x_k = tau0 sum_{i<k} (y_i - mean(y))` (k = 0..N; the mean is removed
//! first, which leaves the statistic unchanged and keeps the cumulative sum small). For
//! `tau = m tau0`, with `n = N + 1 - 2m` terms (NIST SP1065 eq 11):
//!
//! `sigma^2(tau) = 1 / (2 tau^2 n) * sum_{k=0}^{n-1} (x_{k+2m} - 2 x_{k+m} + x_k)^2`,
//!
//! i.e. half the mean squared difference of adjacent overlapping tau-averages. One pass over
//! the phase per tau: O(N) per tau. Averaging factors are m = 1, 2, 4, ... while n >= 2 (the
//! same set as allantools `oadev(..., taus="octave")`).
//!
//! Readings (log-log slopes of sigma(tau)):
//! * white noise (ARW for a gyro, VRW for an accelerometer): slope -1/2,
//!   `sigma = N_c / sqrt(tau)`; `N_c` is the value of the -1/2 line at tau = 1 s. Fitted
//!   (slope fixed, least squares in log) on the "white region": the points before the minimum
//!   whose local slope to both neighbours lies in [-0.75, -0.25]; if none, the point before the
//!   minimum with local slope closest to -1/2.
//! * bias instability: the flat bottom, `B = min sigma / sqrt(2 ln 2 / pi) = min / 0.664`.
//! * rate random walk: slope +1/2, `sigma = K sqrt(tau / 3)`; `K` is the value of the +1/2 line at
//!   tau = 3 s, fitted on the points after the minimum with local slopes in [0.25, 0.75]; absent
//!   if there is none.
//!
//! Units: `adev` has the units of y (rad/s or m/s^2); `N_c` in y * sqrt(s) (rad/sqrt(s),
//! m/s/sqrt(s)); `B` in y; `K` in y / sqrt(s).
//!
//! The IEEE-952 terms with their intervals are fitted in [`terms`], gathered per channel in
//! [`report`], exported in [`export`] and plotted in [`plot`]; [`check`] reads the deviation of a
//! model's residual.

pub mod check;
pub mod export;
pub mod plot;
pub mod report;
pub mod terms;

use serde::{Deserialize, Serialize};

/// Overlapping Allan deviation at octave taus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AllanResult {
    /// Averaging times, s.
    pub tau_s: Vec<f64>,
    /// Overlapping Allan deviation at each tau, units of the input.
    pub adev: Vec<f64>,
    /// Number of second differences averaged at each tau.
    pub n_terms: Vec<usize>,
}

/// Noise coefficients read off an Allan deviation curve (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AllanReadings {
    /// White-noise coefficient (ARW / VRW): the -1/2 line at tau = 1 s, units of y * sqrt(s).
    pub white: Option<f64>,
    /// Bias instability: min adev / 0.664, units of y.
    pub bias_instability: f64,
    /// Tau of the minimum, s.
    pub tau_min_s: f64,
    /// Rate random walk: the +1/2 line at tau = 3 s, units of y / sqrt(s).
    pub rate_random_walk: Option<f64>,
}

/// `sqrt(2 ln 2 / pi)`: the flicker-floor factor linking bias instability and the minimum.
pub const BIAS_INSTABILITY_FACTOR: f64 = 0.664;

/// Overlapping Allan deviation of rate samples `y` taken at `rate_hz`, at m = 1, 2, 4, ...
///
/// Returns empty vectors when fewer than 3 samples are given, or when `rate_hz` is not a
/// positive finite number. Non-finite samples make the affected taus NaN (the caller should
/// gap-fill or split first).
pub fn overlapping_adev(y: &[f64], rate_hz: f64) -> AllanResult {
    let mut out = AllanResult {
        tau_s: Vec::new(),
        adev: Vec::new(),
        n_terms: Vec::new(),
    };
    let n = y.len();
    if n < 3 || !(rate_hz > 0.0 && rate_hz.is_finite()) {
        return out;
    }
    let tau0 = 1.0 / rate_hz;
    let mean = y.iter().sum::<f64>() / n as f64;
    // phase, in units of y * s
    let mut x = Vec::with_capacity(n + 1);
    x.push(0.0);
    let mut acc = 0.0;
    for v in y {
        acc += (v - mean) * tau0;
        x.push(acc);
    }
    let mut m = 1usize;
    while n + 1 >= 2 * m + 2 {
        let terms = n + 1 - 2 * m;
        let (a, b, c) = (&x[..terms], &x[m..m + terms], &x[2 * m..2 * m + terms]);
        let mut s = [0.0f64; 4];
        let mut i = 0;
        while i + 4 <= terms {
            for k in 0..4 {
                let d = c[i + k] - 2.0 * b[i + k] + a[i + k];
                s[k] += d * d;
            }
            i += 4;
        }
        let mut tail = 0.0;
        for j in i..terms {
            let d = c[j] - 2.0 * b[j] + a[j];
            tail += d * d;
        }
        let sum = (s[0] + s[1]) + (s[2] + s[3]) + tail;
        let tau = m as f64 * tau0;
        out.tau_s.push(tau);
        out.adev.push((sum / (2.0 * terms as f64)).sqrt() / tau);
        out.n_terms.push(terms);
        m *= 2;
    }
    out
}

impl AllanResult {
    /// Local log-log slope between points i and i+1.
    fn slope(&self, i: usize) -> f64 {
        (self.adev[i + 1] / self.adev[i]).ln() / (self.tau_s[i + 1] / self.tau_s[i]).ln()
    }

    /// Read the noise coefficients (module docs). `None` if the curve has no finite point.
    pub fn readings(&self) -> Option<AllanReadings> {
        let k = self.adev.len();
        let (imin, &amin) = self
            .adev
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite() && **v > 0.0)
            .min_by(|a, b| a.1.total_cmp(b.1))?;
        let slopes: Vec<f64> = (0..k.saturating_sub(1)).map(|i| self.slope(i)).collect();
        // a point belongs to a region if the slopes on both sides (where they exist) do
        let in_region = |i: usize, lo: f64, hi: f64| {
            let left = if i > 0 { Some(slopes[i - 1]) } else { None };
            let right = slopes.get(i).copied();
            let ok = |s: Option<f64>| s.is_none_or(|s| (lo..=hi).contains(&s));
            (left.is_some() || right.is_some()) && ok(left) && ok(right)
        };
        // white region: before the minimum, slope about -1/2
        let white_pts: Vec<usize> = (0..imin).filter(|&i| in_region(i, -0.75, -0.25)).collect();
        let white_pts = if white_pts.is_empty() && imin > 0 {
            // fall back to the point whose right-hand slope is closest to -1/2
            (0..imin)
                .min_by(|&a, &b| (slopes[a] + 0.5).abs().total_cmp(&(slopes[b] + 0.5).abs()))
                .into_iter()
                .collect()
        } else {
            white_pts
        };
        // fixed slope -1/2 in log: log N = mean(log adev + 0.5 log tau)
        let white = geometric_mean(
            white_pts
                .iter()
                .map(|&i| self.adev[i] * self.tau_s[i].sqrt()),
        );
        let rrw_pts: Vec<usize> = (imin + 1..k)
            .filter(|&i| in_region(i, 0.25, 0.75))
            .collect();
        let rate_random_walk = geometric_mean(
            rrw_pts
                .iter()
                .map(|&i| self.adev[i] * (3.0 / self.tau_s[i]).sqrt()),
        );
        Some(AllanReadings {
            white,
            bias_instability: amin / BIAS_INSTABILITY_FACTOR,
            tau_min_s: self.tau_s[imin],
            rate_random_walk,
        })
    }
}

fn geometric_mean(it: impl Iterator<Item = f64>) -> Option<f64> {
    let (mut s, mut c) = (0.0, 0usize);
    for v in it {
        s += v.ln();
        c += 1;
    }
    (c > 0).then(|| (s / c as f64).exp())
}

/// `(tau_s, adev)` pairs at every octave τ: the shape the residual diagnosis consumes.
pub fn oadev_octaves(y: &[f64], rate_hz: f64) -> Vec<(f64, f64)> {
    let r = overlapping_adev(y, rate_hz);
    r.tau_s.into_iter().zip(r.adev).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn white_noise_has_slope_minus_half_and_known_level() {
        // White noise of sd s at rate f: sigma(tau) = s / sqrt(f tau) exactly in expectation,
        // so N_c = s / sqrt(f). 2^20 samples: at m <= 64 each point has >= 16k effective
        // independent terms, relative sd < 1 %; 5 % bounds on the slope (+-0.5 * 0.1) and level.
        let (s, f) = (0.02, 100.0);
        let mut rng = Rng::new(1);
        let y: Vec<f64> = (0..1 << 20).map(|_| 3.0 + s * rng.normal()).collect();
        let r = overlapping_adev(&y, f);
        for i in 0..6 {
            let slope = r.slope(i);
            assert!((slope + 0.5).abs() < 0.05, "slope {i}: {slope}");
        }
        let rd = r.readings().unwrap();
        let want = s / f.sqrt();
        let got = rd.white.unwrap();
        assert!((got / want - 1.0).abs() < 0.05, "{got} vs {want}");
    }

    #[test]
    fn random_walk_has_slope_plus_half_and_known_level() {
        // Rate random walk y_k = y_{k-1} + q w_k at rate f: sigma^2(tau) = K^2 tau / 3 with
        // K = q sqrt(f). The -1/2 and +1/2 regions need white noise too: add it.
        let (q, f) = (1e-4, 100.0);
        let mut rng = Rng::new(2);
        let mut b = 0.0;
        let y: Vec<f64> = (0..1 << 20)
            .map(|_| {
                b += q * rng.normal();
                b + 0.01 * rng.normal()
            })
            .collect();
        let r = overlapping_adev(&y, f);
        let rd = r.readings().unwrap();
        let k = rd.rate_random_walk.expect("RRW region");
        // long taus have few independent terms (~N/m); 30 % covers the scatter of the last
        // octaves that enter the fit.
        assert!((k / (q * f.sqrt()) - 1.0).abs() < 0.3, "{k}");
        assert!((rd.white.unwrap() / (0.01 / f.sqrt()) - 1.0).abs() < 0.05);
    }

    #[test]
    fn octave_taus_and_term_counts() {
        let y: Vec<f64> = (0..100).map(|i| (i as f64).sin()).collect();
        let r = overlapping_adev(&y, 10.0);
        // N + 1 = 101 phase points: m = 1..32 have n = 101 - 2m >= 2; m = 64 does not
        assert_eq!(r.tau_s, vec![0.1, 0.2, 0.4, 0.8, 1.6, 3.2]);
        assert_eq!(r.n_terms, vec![99, 97, 93, 85, 69, 37]);
        assert!(overlapping_adev(&[1.0, 2.0], 1.0).tau_s.is_empty());
        assert!(overlapping_adev(&y, 0.0).tau_s.is_empty());
    }

    #[test]
    fn empirical_scatter_of_white_noise_adev_matches_the_edf() {
        // 2000 seeded white-noise records of 4096 samples: the spread of σ̂²/σ² at m has
        // variance 2/ν if ν is right. The sample variance of that ratio over 2000 replicas has a
        // relative sd of about sqrt((2 + excess kurtosis)/2000) ≈ 3–4 %; 12 % bounds it, and
        // still fails the F = m form of the sum at m = 1 (18 % off).
        let (n, reps) = (4096usize, 2000);
        let ms = [1usize, 4, 64];
        let mut rng = Rng::new(21);
        let mut ratios = vec![Vec::with_capacity(reps); ms.len()];
        for _ in 0..reps {
            let y: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            let r = overlapping_adev(&y, 1.0);
            for (k, &m) in ms.iter().enumerate() {
                let i = m.trailing_zeros() as usize;
                ratios[k].push(r.adev[i].powi(2) * m as f64); // σ²(τ) = 1/m at rate 1
            }
        }
        for (k, &m) in ms.iter().enumerate() {
            let v = &ratios[k];
            let mean = v.iter().sum::<f64>() / reps as f64;
            let var = v.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (reps - 1) as f64;
            let nu = crate::stats::allan_edf::edf_oadev(
                crate::stats::allan_edf::NoiseType::WhiteFm,
                m,
                n + 1,
            );
            let want = 2.0 / nu;
            assert!((mean - 1.0).abs() < 0.02, "m={m}: mean {mean}");
            assert!(
                (var / want - 1.0).abs() < 0.12,
                "m={m}: var {var} vs 2/ν {want} (ν {nu})"
            );
        }
    }
}
