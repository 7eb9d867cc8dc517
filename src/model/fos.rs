//! Korenberg's fast orthogonal search (FOS), as in Tamazin, Noureldin & Korenberg 2013, eqs 14-28
//! (after Korenberg 1989, "A robust orthogonal algorithm for system identification and
//! time-series analysis", Biol. Cybern. 60:267-276).
//!
//! Model: `y(n) = sum_{m=0}^{M} a_m P_m(n) + e(n)` (eq 14), with the P_m chosen one at a time
//! from a candidate set p_k. Bars are means over the N fit samples. FOS builds the orthogonal
//! expansion `y = sum g_m w_m + e` (eq 16) *implicitly*: the Gram-Schmidt functions w_m are never
//! formed; only their correlations are, for the selected terms r = 0..M-1 and every candidate m:
//!
//! * `D(m,0) = mean(p_m p_0)` (eq 18),
//!   `D(m,r) = mean(p_m p_r) - sum_{i<r} alpha_{r,i} D(m,i)` (eq 19),
//!   `alpha_{m,r} = D(m,r) / D(r,r)` (eq 20);
//! * `C(0) = mean(y p_0)` (eq 21), `C(m) = mean(y p_m) - sum_{r<m} alpha_{m,r} C(r)` (eq 22);
//! * `g_m = C(m) / D(m,m)` (eq 23), and the MSE reduction of candidate m is
//!   `Q_m = g_m^2 D(m,m) = C(m)^2 / D(m,m)` (eq 27); `MSE_M = MSE_{M-1} - Q_M` (eq 28), starting
//!   from `MSE_0 = mean(y^2)` (eq 26 with no term).
//!
//! Every step evaluates `D(m,m)` and `C(m)` of every remaining candidate as if it were the next
//! term, selects the largest Q, then extends the stored `D(m, r)` of all candidates by one
//! column (eq 19 for the new r) and updates their `D(m,m)` and `C(m)` incrementally:
//! `D(m,m) -= alpha_{m,r} D(m,r)`, `C(m) -= alpha_{m,r} C(r)` — the same sums as eqs 19 and 22,
//! accumulated one r at a time. The cost is one pass of inner products `mean(p_m p_r)` per
//! selected term (done by a [`Correlator`], which may exploit structure, see
//! `fos_model::ShiftCorrelator`) plus O(K M) scalar work.
//!
//! The coefficients in the original basis follow from eqs 24-25 (back-substitution):
//! `a_m = sum_{i=m}^{M} g_i v_i`, `v_m = 1`, `v_i = -sum_{r=m}^{i-1} alpha_{i,r} v_r`.
//!
//! # Stopping rules (any one ends the search)
//! 1. `max_terms` terms selected, or no candidate left;
//! 2. `MSE / mean(y^2) < min_mse_ratio` (Korenberg's ratio to the mean-square of the input);
//! 3. `noise_test`: the best remaining candidate must reduce the MSE by more than a white
//!    Gaussian noise candidate plausibly would. For a WGN candidate independent of the current
//!    residual, after M terms `Q / MSE_M` is the squared cosine between the residual and a random
//!    direction in N - M dimensions, ~ chi2_1 / (N - M). Korenberg's rule
//!    `Q > 4/(N+1) MSE` is the ~95 % point of that law for ONE candidate (chi2_1 at 0.95 is
//!    3.84). We search the best of K_rem candidates, so a single-candidate level would admit a
//!    spurious term on pure noise almost every step (1 - 0.95^66 = 97 % for CP=2, L=10). We
//!    therefore use the Sidak-corrected level: accept the best candidate only if
//!    `Q_best > MSE_M * chi2_1^{-1}(1 - a_K) / (N - M)`, `a_K = 1 - (1 - alpha)^(1/K_rem)`,
//!    with the family-wise `alpha` = [`NOISE_TEST_ALPHA`] = 0.05. With K_rem = 1 this is
//!    Korenberg's rule (3.84 instead of 4).
//!
//! Independently of the settings the search stops when the residual MSE has reached rounding
//! level (`MSE <= 64 eps mean(y^2)`, an exact fit), and a candidate whose orthogonal part
//! `D(m,m)` has fallen below `1e-11 mean(p_m^2)` is dropped as linearly dependent on the selected
//! terms (fewer than ~5 significant digits would be left in its g_m).

use super::ModelError;
use crate::stats::special::normal_quantile;
use crate::stats::{NumError, check_finite, check_same_len};

/// Family-wise false-alarm level of the noise-level test (probability that pure white noise
/// adds a term at a given step).
pub const NOISE_TEST_ALPHA: f64 = 0.05;

/// Relative size of D(m,m) against mean(p_m^2) below which a candidate counts as dependent.
const DEPENDENT_REL: f64 = 1e-11;

/// Stopping rules of the search. See the module docs for the exact rules.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FosSettings {
    /// Maximum number of terms selected.
    pub max_terms: usize,
    /// Stop when `MSE / mean(y^2)` falls below this (0 disables).
    pub min_mse_ratio: f64,
    /// Stop when the best remaining candidate does not beat a white-noise candidate.
    pub noise_test: bool,
}

impl Default for FosSettings {
    /// 30 terms at most, no ratio rule, noise-level test on.
    fn default() -> Self {
        FosSettings {
            max_terms: 30,
            min_mse_ratio: 0.0,
            noise_test: true,
        }
    }
}

/// Result of a search.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FosFit {
    /// Indices into the candidate list, in selection order.
    pub selected: Vec<usize>,
    /// Coefficients of the selected candidates in the ORIGINAL (non-orthogonal) basis, in the
    /// same order as `selected`.
    pub coefficients: Vec<f64>,
    /// MSE reduction Q of each selected term, in selection order.
    pub q: Vec<f64>,
    /// Residual MSE after 0, 1, 2, ... terms (`mse_trace[0] = mean(y^2)`).
    pub mse_trace: Vec<f64>,
}

/// Supplies the correlations FOS needs, so that structured candidate sets can compute them
/// faster than column by column. All values are means over the N fit samples.
pub trait Correlator {
    /// Number of fit samples N.
    fn n_samples(&self) -> usize;
    /// Number of candidates K.
    fn n_candidates(&self) -> usize;
    /// `mean(y^2)`.
    fn yy(&mut self) -> f64;
    /// `mean(y p_m)` for every m (written into `out`, length K).
    fn yp(&mut self, out: &mut [f64]);
    /// `mean(p_m^2)` for every m.
    fn pp_diag(&mut self, out: &mut [f64]);
    /// `mean(p_m p_s)` for every m with `active[m]` (others may be left untouched).
    fn pp_row(&mut self, s: usize, active: &[bool], out: &mut [f64]);
}

/// Dot product with eight independent accumulators (lets the compiler vectorise; also a little
/// more accurate than one running sum).
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let ca = a.chunks_exact(8);
    let cb = b.chunks_exact(8);
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// Correlator over explicit candidate columns.
struct ColumnCorrelator<'a> {
    y: &'a [f64],
    cols: &'a [Vec<f64>],
}

impl Correlator for ColumnCorrelator<'_> {
    fn n_samples(&self) -> usize {
        self.y.len()
    }
    fn n_candidates(&self) -> usize {
        self.cols.len()
    }
    fn yy(&mut self) -> f64 {
        dot(self.y, self.y) / self.y.len() as f64
    }
    fn yp(&mut self, out: &mut [f64]) {
        let n = self.y.len() as f64;
        for (o, c) in out.iter_mut().zip(self.cols) {
            *o = dot(self.y, c) / n;
        }
    }
    fn pp_diag(&mut self, out: &mut [f64]) {
        let n = self.y.len() as f64;
        for (o, c) in out.iter_mut().zip(self.cols) {
            *o = dot(c, c) / n;
        }
    }
    fn pp_row(&mut self, s: usize, active: &[bool], out: &mut [f64]) {
        let n = self.y.len() as f64;
        let cs = &self.cols[s];
        for (m, c) in self.cols.iter().enumerate() {
            if active[m] {
                out[m] = dot(c, cs) / n;
            }
        }
    }
}

/// Fast orthogonal search over explicit candidate columns.
///
/// `y` and every candidate column have the same length N. Callers include a constant column if
/// wanted. Candidates are treated alike; the order of selection is by largest Q.
pub fn fos_search(
    y: &[f64],
    candidates: &[Vec<f64>],
    settings: &FosSettings,
) -> Result<FosFit, ModelError> {
    check_finite(y)?;
    for c in candidates {
        check_same_len(y.len(), c.len())?;
        check_finite(c)?;
    }
    let mut corr = ColumnCorrelator {
        y,
        cols: candidates,
    };
    fos_search_with(&mut corr, settings)
}

/// Fast orthogonal search on any [`Correlator`] (the core of [`fos_search`]).
pub fn fos_search_with<C: Correlator + ?Sized>(
    corr: &mut C,
    settings: &FosSettings,
) -> Result<FosFit, ModelError> {
    if !(settings.min_mse_ratio >= 0.0 && settings.min_mse_ratio.is_finite()) {
        return Err(ModelError::bad(format!(
            "min_mse_ratio must be finite and >= 0, got {}",
            settings.min_mse_ratio
        )));
    }
    let n = corr.n_samples();
    if n < 2 {
        return Err(NumError::TooShort { needed: 2, got: n }.into());
    }
    let k = corr.n_candidates();
    let m_max = settings.max_terms.min(k);

    let yy = corr.yy();
    if !yy.is_finite() {
        return Err(ModelError::Numeric(NumError::NonFinite { index: 0 }));
    }
    // Per-candidate running state: C(m) (eq 22 partial sums), D(m,m) (eq 19 with r = m,
    // partial sums), the raw mean(p_m^2) for the dependence test, and the stored D(m, r) for
    // the selected r (row-major K x m_max).
    let mut c_m = vec![0.0; k];
    corr.yp(&mut c_m);
    let mut pmm = vec![0.0; k];
    corr.pp_diag(&mut pmm);
    let mut d_mm = pmm.clone();
    let mut d_mr = vec![0.0; k * m_max.max(1)];
    let mut active: Vec<bool> = pmm.iter().map(|&v| v > 0.0 && v.is_finite()).collect();
    let mut raw = vec![0.0; k];

    let mut selected: Vec<usize> = Vec::with_capacity(m_max);
    let mut g: Vec<f64> = Vec::with_capacity(m_max);
    let mut q_sel: Vec<f64> = Vec::with_capacity(m_max);
    let mut d_sel: Vec<f64> = Vec::with_capacity(m_max);
    let mut mse = yy;
    let mut mse_trace = vec![yy];
    let exact_floor = 64.0 * f64::EPSILON * yy;

    while selected.len() < m_max {
        let j = selected.len();
        if mse <= exact_floor {
            break; // exact fit to rounding: nothing left to model
        }
        if settings.min_mse_ratio > 0.0 && yy > 0.0 && mse / yy < settings.min_mse_ratio {
            break;
        }
        // Best remaining candidate by Q = C^2 / D (eq 27).
        let mut best: Option<(usize, f64)> = None;
        let mut k_rem = 0usize;
        for m in 0..k {
            if !active[m] {
                continue;
            }
            if d_mm[m].is_nan() || d_mm[m] <= DEPENDENT_REL * pmm[m] {
                active[m] = false; // numerically inside the span of the selected terms
                continue;
            }
            k_rem += 1;
            let q = c_m[m] * c_m[m] / d_mm[m];
            if best.is_none_or(|(_, bq)| q > bq) {
                best = Some((m, q));
            }
        }
        let Some((s, q)) = best else { break };
        if settings.noise_test && {
            let thr = mse * noise_threshold(n, j, k_rem, NOISE_TEST_ALPHA);
            q.is_nan() || q <= thr
        } {
            break;
        }
        // Select s as term j.
        active[s] = false;
        let d_ss = d_mm[s];
        let c_s = c_m[s];
        selected.push(s);
        g.push(c_s / d_ss); // eq 23
        q_sel.push(q);
        d_sel.push(d_ss);
        // Store alpha_{j,i} of the new term against the earlier ones: they are the D(s, i)
        // of candidate s divided by D(i, i). Copy s's row so the loop below can read it.
        let alpha_j: Vec<f64> = (0..j).map(|i| d_mr[s * m_max + i] / d_sel[i]).collect();
        mse -= q; // eq 28
        mse_trace.push(mse);
        if selected.len() == m_max {
            break; // the D(s, i), i < j, that the back-substitution needs are stored already
        }
        // New column r = j of D(m, r) for every remaining candidate (eq 19), then the
        // incremental updates of D(m,m) and C(m).
        corr.pp_row(s, &active, &mut raw);
        for m in 0..k {
            if !active[m] {
                continue;
            }
            let row = &mut d_mr[m * m_max..m * m_max + m_max];
            let mut d = raw[m];
            for i in 0..j {
                d -= alpha_j[i] * row[i];
            }
            row[j] = d;
            let alpha = d / d_ss; // eq 20
            d_mm[m] -= alpha * d;
            c_m[m] -= alpha * c_s;
        }
    }

    // Back-substitution (eqs 24-25) with alpha_{i,r} = D(s_i, r) / D(r, r).
    let mm = selected.len();
    let alpha = |i: usize, r: usize| d_mr[selected[i] * m_max + r] / d_sel[r];
    let mut coefficients = vec![0.0; mm];
    let mut v = vec![0.0; mm];
    for m in 0..mm {
        v[m] = 1.0;
        let mut a = g[m];
        for i in m + 1..mm {
            let vi = -(m..i).map(|r| alpha(i, r) * v[r]).sum::<f64>();
            v[i] = vi;
            a += g[i] * vi;
        }
        coefficients[m] = a;
    }
    Ok(FosFit {
        selected,
        coefficients,
        q: q_sel,
        mse_trace,
    })
}

/// Threshold on `Q / MSE_M` for the noise-level test: the `1 - a_K` quantile of chi2_1 divided
/// by `N - M`, with the Sidak level `a_K = 1 - (1 - alpha)^(1/K_rem)` (see the module docs).
pub fn noise_threshold(n_samples: usize, m_selected: usize, k_remaining: usize, alpha: f64) -> f64 {
    let k_rem = k_remaining.max(1) as f64;
    // 1 - (1-alpha)^(1/K) computed without cancellation
    let a_k = -((1.0 - alpha).ln() / k_rem).exp_m1();
    // chi2_1 upper quantile = z^2 with z the (1 - a_K/2) normal quantile
    // (clamped below 1 so that a vanishing a_K gives a large finite threshold, not ∞)
    let z = normal_quantile((1.0 - 0.5 * a_k).min(1.0 - 1e-16));
    let dof = n_samples.saturating_sub(m_selected).max(1) as f64;
    z * z / dof
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use nalgebra::{DMatrix, DVector};

    /// 20 candidates: constant, 9 Gaussian columns and 10 smooth ones (sines / powers), which
    /// are strongly non-orthogonal to each other.
    fn candidates(n: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut rng = Rng::new(seed);
        let mut c = vec![vec![1.0; n]];
        for _ in 0..9 {
            c.push((0..n).map(|_| rng.normal()).collect());
        }
        for k in 0..10 {
            c.push(
                (0..n)
                    .map(|i| {
                        let t = i as f64 / n as f64;
                        (t * (k + 1) as f64 * 3.0).sin() + 0.3 * t.powi(k % 3)
                    })
                    .collect(),
            );
        }
        c
    }

    #[test]
    fn noise_threshold_reduces_to_korenberg_for_one_candidate() {
        // K_rem = 1, alpha = 0.05: chi2_1 95 % point 3.8415 over N - M, vs Korenberg's 4/(N+1).
        let t = noise_threshold(1001, 0, 1, 0.05);
        assert!((t * 1001.0 - 3.841_458_82).abs() < 1e-6);
    }

    #[test]
    fn fos_recovers_exact_terms_of_noiseless_sum() {
        let n = 2000;
        let c = candidates(n, 1);
        let truth = [(0usize, 0.7), (3, -1.3), (12, 2.5), (17, 0.05)];
        let y: Vec<f64> = (0..n)
            .map(|i| truth.iter().map(|&(m, a)| a * c[m][i]).sum())
            .collect();
        let fit = fos_search(
            &y,
            &c,
            &FosSettings {
                max_terms: 20,
                min_mse_ratio: 0.0,
                noise_test: false,
            },
        )
        .unwrap();
        let mut got: Vec<(usize, f64)> = fit
            .selected
            .iter()
            .copied()
            .zip(fit.coefficients.iter().copied())
            .collect();
        got.sort_by_key(|p| p.0);
        // exactly the four true terms (the exact-fit floor stops the search) ...
        assert_eq!(
            got.iter().map(|p| p.0).collect::<Vec<_>>(),
            vec![0, 3, 12, 17]
        );
        // ... with their coefficients: a noiseless system solved through the normal
        // equations of sines that overlap strongly keeps ~1e-11 accuracy; 1e-9 stated by the
        // brief leaves margin for the condition number (~1e3) squared by the Gram approach.
        for ((_, a), (_, b)) in got.iter().zip(truth.iter()) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        assert!(fit.mse_trace.last().unwrap().abs() < 1e-12 * fit.mse_trace[0]);
    }

    #[test]
    fn fos_linear_model_equals_least_squares_on_selected_terms() {
        // Noisy target: FOS's coefficients must be the LS solution restricted to its terms.
        let n = 3000;
        let c = candidates(n, 2);
        let mut rng = Rng::new(3);
        let y: Vec<f64> = (0..n)
            .map(|i| 0.4 * c[0][i] + 1.1 * c[5][i] - 0.8 * c[14][i] + 0.5 * rng.normal())
            .collect();
        let fit = fos_search(
            &y,
            &c,
            &FosSettings {
                max_terms: 8,
                min_mse_ratio: 0.0,
                noise_test: false,
            },
        )
        .unwrap();
        assert_eq!(fit.selected.len(), 8);
        let a = DMatrix::from_fn(n, 8, |r, j| c[fit.selected[j]][r]);
        let b = DVector::from_column_slice(&y);
        let ls = a.clone().svd(true, true).solve(&b, 1e-14).unwrap();
        for j in 0..8 {
            // conditioning of 8 overlapping smooth columns ~1e3: 1e-9 absolute is ~1e5 ulp
            assert!((fit.coefficients[j] - ls[j]).abs() < 1e-9, "{j}");
        }
        // and the MSE bookkeeping (eq 28) equals the LS residual MSE
        let res = &b - &a * &ls;
        let mse_ls = res.dot(&res) / n as f64;
        assert!((fit.mse_trace[8] - mse_ls).abs() < 1e-10 * fit.mse_trace[0]);
    }

    #[test]
    fn fos_selects_largest_q_first() {
        // y = 3 c1 + 0.1 c2 with c1, c2 independent: c1 must come first.
        let n = 1000;
        let c = candidates(n, 4);
        let y: Vec<f64> = (0..n).map(|i| 3.0 * c[1][i] + 0.1 * c[2][i]).collect();
        let fit = fos_search(&y, &c, &FosSettings::default()).unwrap();
        assert_eq!(fit.selected[0], 1);
        assert!(fit.q[0] > fit.q[1]);
    }

    #[test]
    fn noise_test_stops_on_white_noise() {
        // Pure zero-mean white noise against 20 candidates: with the Sidak family level of 5 %
        // the first step admits a term with probability 0.05; over 20 seeds the count of
        // searches that add any term is Binomial(20, 0.05) (mean 1); P(>= 5) = 0.3 %.
        let n = 4000;
        let c = candidates(n, 5);
        let mut with_terms = 0;
        for seed in 0..20 {
            let mut rng = Rng::new(100 + seed);
            let y: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            let fit = fos_search(&y, &c, &FosSettings::default()).unwrap();
            assert!(fit.selected.len() <= 2, "seed {seed}: {:?}", fit.selected);
            if !fit.selected.is_empty() {
                with_terms += 1;
            }
        }
        assert!(
            with_terms < 5,
            "{with_terms} of 20 noise searches added terms"
        );
    }

    #[test]
    fn max_terms_and_ratio_rules_stop_the_search() {
        let n = 1000;
        let c = candidates(n, 6);
        let mut rng = Rng::new(7);
        let y: Vec<f64> = (0..n)
            .map(|i| c[1][i] + 0.5 * c[2][i] + 0.25 * c[3][i] + 0.01 * rng.normal())
            .collect();
        let s = FosSettings {
            max_terms: 2,
            min_mse_ratio: 0.0,
            noise_test: false,
        };
        assert_eq!(fos_search(&y, &c, &s).unwrap().selected.len(), 2);
        // ratio rule: the three terms explain all but ~1e-4 / 1.3 of mean(y^2)
        let s = FosSettings {
            max_terms: 20,
            min_mse_ratio: 1e-3,
            noise_test: false,
        };
        let fit = fos_search(&y, &c, &s).unwrap();
        assert_eq!(fit.selected.len(), 3);
    }

    #[test]
    fn fos_rejects_mismatched_or_non_finite_input() {
        let c = vec![vec![1.0; 5]];
        assert!(matches!(
            fos_search(&[1.0; 4], &c, &FosSettings::default()),
            Err(ModelError::Numeric(NumError::LengthMismatch { .. }))
        ));
        assert!(matches!(
            fos_search(&[1.0, f64::NAN, 1.0, 1.0, 1.0], &c, &FosSettings::default()),
            Err(ModelError::Numeric(NumError::NonFinite { index: 1 }))
        ));
    }
}
