//! The IEEE Std 952-1997 (Annex C) noise terms of an inertial sensor, fitted to its overlapping
//! Allan variance.
//!
//! **Model.** For a rate signal (gyro rad/s, accelerometer m/s²) the Allan variance of
//! independent noise terms adds (IEEE 952 Annex C; El-Sheimy, Hou & Niu 2008, IEEE TIM 57(1)):
//!
//! `σ²(τ) = 3Q²/τ² + N²/τ + (2 ln2/π) B² + K² τ/3 + R² τ²/2`
//!
//! | term | slope of σ(τ) | unit (gyro / accel) | read off the curve at |
//! |---|---|---|---|
//! | Q quantisation | −1 | rad / m/s | τ = √3 (the −1 line) |
//! | N angle / velocity random walk | −½ | rad/√s / m/s/√s | τ = 1 s (the −½ line) |
//! | B bias instability | 0 | rad/s / m/s² | the flat floor, σ = 0.664 B |
//! | K rate random walk | +½ | rad/s/√s / m/s²/√s | τ = 3 s (the +½ line) |
//! | R rate ramp | +1 | rad/s² / m/s³ | τ = √2 (the +1 line) |
//!
//! (`(2 ln 2/π)^½ = 0.6643`: IEEE's 0.664; the flicker floor is this level only asymptotically.)
//!
//! **Fit.** Weighted least squares of σ̂²(τᵢ) on the five basis functions with non-negative
//! coefficients `c = (Q², N², B², K², R²)` (a non-negative least-squares problem; with five
//! unknowns it is solved exactly by trying every support set and keeping the best feasible one —
//! the NNLS optimum is the unconstrained optimum on its own support). Each point is weighted by
//! the inverse of its standard deviation, `sd(σ̂²ᵢ) = σ²ᵢ sqrt(2/νᵢ + ε²)`, with `νᵢ` the
//! Greenhall–Riley EDF ([`crate::stats::allan_edf`]) of the noise type that dominates at τᵢ and ε a
//! model-error floor. Weights and noise types depend on the fit, so it is iterated: pass 0 uses
//! σ̂²ᵢ, white-FM EDFs and ε = 0; pass k ≥ 1 uses the previous model's σ²ᵢ, the noise type of
//! its largest term at each τᵢ and the previous ε, until every coefficient and ε change by less
//! than `tol` (relative) or `max_passes` is reached. The relative weighting is what lets a curve
//! spanning 8 decades in σ² be fitted at all; using the model's σ² rather than the measured one
//! removes the bias towards points that happen to fall low.
//!
//! **Model-error floor.** A real curve is not exactly the IEEE sum (a sensor's anti-alias filter
//! bends the shortest τ, a temperature drift the longest), and with 10⁶ samples the statistical
//! error of the short-τ points is 0.1 %: statistically exact weights would let the few shortest
//! τ decide every term. So a relative error ε of the model is added in quadrature and chosen
//! after each pass so that the residuals' χ² = dof (the "intrinsic scatter" of a fit; ε = 0 when
//! the statistics alone explain the residuals), measured in logs where a low-EDF point's
//! chi-squared scatter is nearly symmetric (see `model_error_floor`). It is reported: it says
//! how well the five-term model describes the curve.
//!
//! **Which terms.** Backward elimination: after the passes converge, the positive term with the
//! fewest formal standard errors (covariance of the weighted fit on the active support) is
//! removed if that is below `min_z`, and the fit is redone without it, until every positive
//! term is at least `min_z` standard errors from zero. (Without it two neighbouring terms, say K
//! and R, can share a short rising end so that neither alone is significant although the rise
//! is.) A term is reported as resolved when it survives, is positive, and is the largest of the
//! five contributions at one measured τ at least. Otherwise the report says why (eliminated as
//! not significant / fitted to zero / never the largest) and gives an upper bound: the largest
//! coefficient whose line stays under the upper confidence limit at every measured τ,
//! `min_i hiᵢ / sqrt(fⱼ(τᵢ))`.

use super::AllanResult;
use crate::analysis::AnalysisError;
use crate::stats::NumError;
use crate::stats::allan_edf::{NoiseType, chi2_interval, edf_oadev};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use statrs::function::gamma::digamma;
use std::f64::consts::{LN_2, PI};

/// One IEEE-952 term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// Q, slope −1.
    Quantisation,
    /// N (ARW / VRW), slope −½.
    RandomWalk,
    /// B, flat.
    BiasInstability,
    /// K (RRW), slope +½.
    RateRandomWalk,
    /// R, slope +1.
    RateRamp,
}

impl Term {
    /// All terms in order of rising slope.
    pub const ALL: [Term; 5] = [
        Term::Quantisation,
        Term::RandomWalk,
        Term::BiasInstability,
        Term::RateRandomWalk,
        Term::RateRamp,
    ];

    /// `fⱼ(τ)`: the term's Allan variance per unit squared coefficient.
    pub fn basis(self, tau_s: f64) -> f64 {
        match self {
            Term::Quantisation => 3.0 / (tau_s * tau_s),
            Term::RandomWalk => 1.0 / tau_s,
            Term::BiasInstability => 2.0 * LN_2 / PI,
            Term::RateRandomWalk => tau_s / 3.0,
            Term::RateRamp => tau_s * tau_s / 2.0,
        }
    }

    /// Noise type the term produces (rate ramp: the nearest type the Allan variance admits).
    pub fn noise(self) -> NoiseType {
        match self {
            Term::Quantisation => NoiseType::WhitePm,
            Term::RandomWalk => NoiseType::WhiteFm,
            Term::BiasInstability => NoiseType::FlickerFm,
            Term::RateRandomWalk | Term::RateRamp => NoiseType::RandomWalkFm,
        }
    }

    /// IEEE letter.
    pub fn letter(self) -> &'static str {
        match self {
            Term::Quantisation => "Q",
            Term::RandomWalk => "N",
            Term::BiasInstability => "B",
            Term::RateRandomWalk => "K",
            Term::RateRamp => "R",
        }
    }

    /// Log-log slope of σ(τ).
    pub fn slope(self) -> f64 {
        match self {
            Term::Quantisation => -1.0,
            Term::RandomWalk => -0.5,
            Term::BiasInstability => 0.0,
            Term::RateRandomWalk => 0.5,
            Term::RateRamp => 1.0,
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// Fit settings.
#[derive(Clone, Debug, Serialize)]
pub struct FitSettings {
    /// Confidence of the bands (two-sided), e.g. 0.6827 for ±1σ.
    pub confidence: f64,
    /// Most reweighting passes after pass 0.
    pub max_passes: usize,
    /// Relative change of every coefficient below which the passes stop.
    pub tol: f64,
    /// Coefficient / formal standard error a resolved term needs.
    pub min_z: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            confidence: crate::stats::allan_edf::ONE_SIGMA_CONFIDENCE,
            max_passes: 50,
            tol: 1e-6,
            min_z: 2.0,
        }
    }
}

/// One averaging time of the curve, with its band and the fitted model.
#[derive(Clone, Debug, Serialize)]
pub struct CurvePoint {
    /// Averaging time, s.
    pub tau_s: f64,
    /// Averaging factor m (τ = m / rate).
    pub m: usize,
    /// Overlapping Allan deviation, channel unit.
    pub adev: f64,
    /// Lower confidence limit, channel unit.
    pub lo: f64,
    /// Upper confidence limit, channel unit.
    pub hi: f64,
    /// Equivalent degrees of freedom.
    pub edf: f64,
    /// Noise type assumed for the EDF (the fitted model's largest term here).
    pub noise: NoiseType,
    /// Fitted model's deviation, channel unit.
    pub model_adev: f64,
}

/// Why a term is not reported as resolved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Resolution {
    /// Shown by the record.
    Resolved,
    /// The non-negative fit puts it at zero.
    FittedZero,
    /// Positive, but another term is larger at every measured τ.
    NeverDominant,
    /// Fewer than `min_z` standard errors from zero: eliminated from the model.
    NotSignificant,
}

/// One fitted term.
#[derive(Clone, Debug, Serialize)]
pub struct TermResult {
    pub term: Term,
    /// Fitted coefficient `sqrt(cⱼ)` (unit: see the module table), 0 if fitted to zero.
    pub coefficient: f64,
    /// Formal standard error of the coefficient (delta method), when it is positive.
    pub std_error: Option<f64>,
    pub resolution: Resolution,
    /// Range of measured τ (s) where this term is the largest contribution.
    pub dominant_tau_s: Option<[f64; 2]>,
    /// Largest coefficient whose line stays under every upper confidence limit.
    pub upper_bound: f64,
}

impl TermResult {
    /// The coefficient if resolved.
    pub fn value(&self) -> Option<f64> {
        (self.resolution == Resolution::Resolved).then_some(self.coefficient)
    }
}

/// The fit of one channel.
#[derive(Clone, Debug, Serialize)]
pub struct TermFit {
    /// Every averaging time used, with band and model.
    pub points: Vec<CurvePoint>,
    /// Q, N, B, K, R in that order.
    pub terms: Vec<TermResult>,
    /// Reweighting passes run after pass 0 (summed over the elimination rounds).
    pub passes: usize,
    /// Whether the passes met `tol`.
    pub converged: bool,
    /// Model-error floor ε: relative error of σ² added in quadrature to the statistical one
    /// (module docs); 0 when the statistics explain the scatter.
    pub model_error: f64,
    /// Weighted sum of squared (linear) residuals at the end.
    pub chi2: f64,
    /// Points minus active terms.
    pub dof: usize,
}

impl TermFit {
    /// Result for term `t`.
    pub fn term(&self, t: Term) -> &TermResult {
        &self.terms[t.index()]
    }

    /// Model Allan variance at τ from the fitted coefficients.
    pub fn model_var(&self, tau_s: f64) -> f64 {
        model_var(&self.coefficients(), tau_s)
    }

    /// `cⱼ = coefficient²`.
    pub fn coefficients(&self) -> [f64; 5] {
        let mut c = [0.0; 5];
        for (ci, t) in c.iter_mut().zip(&self.terms) {
            *ci = t.coefficient * t.coefficient;
        }
        c
    }
}

fn model_var(c: &[f64; 5], tau_s: f64) -> f64 {
    Term::ALL
        .iter()
        .map(|t| c[t.index()] * t.basis(tau_s))
        .sum()
}

/// Term with the largest contribution at τ.
fn dominant(c: &[f64; 5], tau_s: f64) -> Term {
    let mut best = Term::RandomWalk;
    let mut v = -1.0;
    for t in Term::ALL {
        let x = c[t.index()] * t.basis(tau_s);
        if x > v {
            v = x;
            best = t;
        }
    }
    best
}

/// Non-negative least squares `min |A x − b|, x ≥ 0` over the `allowed` columns (the others are
/// held at 0) for a handful of columns, exactly: every support set's unconstrained solution, the
/// best feasible one kept. Columns are scaled to unit
/// norm first (the basis spans many decades). Returns the solution and the support's
/// `(AᵀA)⁻¹` in the original scaling (zero outside the support).
fn nnls_small(a: &DMatrix<f64>, b: &DVector<f64>, allowed: &[bool]) -> (Vec<f64>, DMatrix<f64>) {
    let (n, k) = a.shape();
    let norms: Vec<f64> = (0..k)
        .map(|j| a.column(j).norm().max(f64::MIN_POSITIVE))
        .collect();
    let mut a_s = a.clone();
    for (j, nj) in norms.iter().enumerate() {
        a_s.column_mut(j).scale_mut(1.0 / nj);
    }
    let mut best_x = vec![0.0; k];
    let mut best_r = b.norm_squared();
    let mut best_cols: Vec<usize> = vec![];
    for mask in 1u32..(1 << k) {
        let cols: Vec<usize> = (0..k).filter(|j| mask & (1 << j) != 0).collect();
        if cols.len() > n || cols.iter().any(|&j| !allowed[j]) {
            continue;
        }
        let sub = a_s.select_columns(&cols);
        let Ok(x) = sub.clone().svd(true, true).solve(b, 1e-12) else {
            continue;
        };
        if x.iter().any(|v| v.is_nan() || *v <= 0.0) {
            continue;
        }
        let r = (&sub * &x - b).norm_squared();
        if r < best_r {
            best_r = r;
            best_cols = cols.clone();
            best_x = vec![0.0; k];
            for (i, &j) in cols.iter().enumerate() {
                best_x[j] = x[i];
            }
        }
    }
    let mut cov = DMatrix::zeros(k, k);
    if !best_cols.is_empty() {
        let sub = a_s.select_columns(&best_cols);
        if let Some(inv) = (sub.transpose() * &sub).try_inverse() {
            for (i, &p) in best_cols.iter().enumerate() {
                for (j, &q) in best_cols.iter().enumerate() {
                    cov[(p, q)] = inv[(i, j)] / (norms[p] * norms[q]);
                }
            }
        }
    }
    let x = best_x.iter().zip(&norms).map(|(x, n)| x / n).collect();
    (x, cov)
}

/// One weighted solve: `sd[i]` is the standard deviation of point i's σ̂².
fn solve_weighted(
    tau: &[f64],
    avar: &[f64],
    sd: &[f64],
    allowed: &[bool; 5],
) -> ([f64; 5], DMatrix<f64>) {
    let n = tau.len();
    let a = DMatrix::from_fn(n, 5, |i, j| Term::ALL[j].basis(tau[i]) / sd[i]);
    let b = DVector::from_fn(n, |i, _| avar[i] / sd[i]);
    let (x, cov) = nnls_small(&a, &b, allowed);
    let mut c = [0.0; 5];
    c.copy_from_slice(&x);
    (c, cov)
}

/// Standard deviation of σ̂²ᵢ under model `c`: `σ²ᵢ sqrt(2/νᵢ + ε²)` (measured σ̂²ᵢ where the
/// model is zero).
fn sds(c: &[f64; 5], tau: &[f64], avar: &[f64], nu: &[(NoiseType, f64)], eps: f64) -> Vec<f64> {
    tau.iter()
        .zip(avar)
        .zip(nu)
        .map(|((&t, &v), (_, nu))| {
            let mv = model_var(c, t);
            (if mv > 0.0 { mv } else { v }) * (2.0 / nu + eps * eps).sqrt()
        })
        .collect()
}

/// χ² of model `c` with weights `sd`.
fn chi2(c: &[f64; 5], tau: &[f64], avar: &[f64], sd: &[f64]) -> f64 {
    (0..tau.len())
        .map(|i| ((avar[i] - model_var(c, tau[i])) / sd[i]).powi(2))
        .sum()
}

/// Trigamma ψ'(x), x > 0: the recurrence ψ'(x) = ψ'(x + 1) + 1/x² up to x ≥ 12, then the
/// asymptotic series (Abramowitz & Stegun 6.4.12), truncation error < 1e-13 there. (statrs has digamma but
/// not trigamma.)
fn trigamma(mut x: f64) -> f64 {
    let mut acc = 0.0;
    while x < 12.0 {
        acc += 1.0 / (x * x);
        x += 1.0;
    }
    let z = 1.0 / (x * x);
    acc + 1.0 / x + z / 2.0 + z / x * (1.0 / 6.0 - z * (1.0 / 30.0 - z * (1.0 / 42.0 - z / 30.0)))
}

/// Model-error floor ε: the relative error of the IEEE model itself, chosen so that the
/// log-domain residuals have χ² = dof (0 when the statistics alone explain them). In logs the
/// chi-squared scatter of a low-EDF point is nearly symmetric: `ln(σ̂²/σ²)` has mean
/// `ψ(ν/2) − ln(ν/2)` and variance `ψ'(ν/2)` for `ν σ̂²/σ² ~ χ²(ν)`, so one long-τ point that is
/// 3× off by chance (not rare at ν ≈ 2) does not pass for a model error; a linear-domain χ² would
/// let it set ε. The sum falls monotonically in ε², so bisection on ln ε² over [1e-12, 1e4]
/// finds it; [`MODEL_ERROR_MAX`] when even ε² = 1e4 leaves χ² above dof.
fn model_error_floor(
    c: &[f64; 5],
    tau: &[f64],
    avar: &[f64],
    nu: &[(NoiseType, f64)],
    dof: usize,
) -> f64 {
    let target = dof as f64;
    let r: Vec<(f64, f64)> = (0..tau.len())
        .map(|i| {
            let h = 0.5 * nu[i].1;
            let resid = (avar[i] / model_var(c, tau[i])).ln() - (digamma(h) - h.ln());
            (resid * resid, trigamma(h))
        })
        .collect();
    let at = |e2: f64| r.iter().map(|(r2, v)| r2 / (v + e2)).sum::<f64>();
    let at0 = at(0.0);
    if dof == 0 || at0.is_nan() || at0 <= target {
        return 0.0;
    }
    let (mut lo, mut hi) = ((1e-12f64).ln(), (MODEL_ERROR_MAX * MODEL_ERROR_MAX).ln());
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if at(mid.exp()) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp().sqrt()
}

/// The largest model-error floor ε searched (ε² up to 1e4): ε = 100, a model 100× off.
pub const MODEL_ERROR_MAX: f64 = 100.0;

fn n_active(c: &[f64; 5]) -> usize {
    c.iter().filter(|v| **v > 0.0).count()
}

/// Noise type (the model's largest term; white FM before a model exists) and EDF per point.
fn edfs(c: Option<&[f64; 5]>, tau: &[f64], m: &[usize], n_phase: usize) -> Vec<(NoiseType, f64)> {
    tau.iter()
        .zip(m)
        .map(|(&t, &mi)| {
            let noise = c.map_or(NoiseType::WhiteFm, |c| dominant(c, t).noise());
            (noise, edf_oadev(noise, mi, n_phase))
        })
        .collect()
}

/// The reweighted passes with only the `allowed` terms (module docs).
struct Passes {
    c: [f64; 5],
    cov: DMatrix<f64>,
    eps: f64,
    passes: usize,
    converged: bool,
}

fn iterate(
    tau: &[f64],
    m: &[usize],
    avar: &[f64],
    n_phase: usize,
    allowed: &[bool; 5],
    settings: &FitSettings,
) -> Passes {
    let dof_of = |c: &[f64; 5]| tau.len().saturating_sub(n_active(c));
    // pass 0: measured variances, white-FM EDFs, no model-error floor
    let e0 = edfs(None, tau, m, n_phase);
    let (mut c, mut cov) = solve_weighted(tau, avar, &sds(&[0.0; 5], tau, avar, &e0, 0.0), allowed);
    let mut eps = model_error_floor(&c, tau, avar, &edfs(Some(&c), tau, m, n_phase), dof_of(&c));
    let mut passes = 0;
    let mut converged = false;
    let rel = |a: f64, b: f64| {
        let s = a.abs().max(b.abs());
        if s > 0.0 { (a - b).abs() / s } else { 0.0 }
    };
    while passes < settings.max_passes {
        passes += 1;
        let e = edfs(Some(&c), tau, m, n_phase);
        let (c_new, cov_new) = solve_weighted(tau, avar, &sds(&c, tau, avar, &e, eps), allowed);
        let e_new = edfs(Some(&c_new), tau, m, n_phase);
        let eps_new = model_error_floor(&c_new, tau, avar, &e_new, dof_of(&c_new));
        let change = c
            .iter()
            .zip(&c_new)
            .map(|(a, b)| rel(a.sqrt(), b.sqrt()))
            .fold(rel(eps, eps_new), f64::max);
        (c, cov, eps) = (c_new, cov_new, eps_new);
        if change < settings.tol {
            converged = true;
            break;
        }
    }
    Passes {
        c,
        cov,
        eps,
        passes,
        converged,
    }
}

/// Fit the IEEE-952 terms to an overlapping Allan deviation `curve` of `n_samples` rate samples
/// at `rate_hz` (module docs). Points with a non-finite or zero deviation are left out.
pub fn fit_terms(
    curve: &AllanResult,
    rate_hz: f64,
    n_samples: usize,
    settings: &FitSettings,
) -> Result<TermFit, AnalysisError> {
    if !crate::analysis::is_pos(rate_hz) || !rate_hz.is_finite() {
        return Err(AnalysisError::bad("allan terms: rate_hz must be > 0"));
    }
    if !crate::analysis::in_open_unit(settings.confidence) {
        return Err(AnalysisError::bad("allan terms: confidence in (0, 1)"));
    }
    let keep: Vec<usize> = (0..curve.adev.len())
        .filter(|&i| curve.adev[i].is_finite() && curve.adev[i] > 0.0)
        .collect();
    if keep.len() < 3 {
        return Err(NumError::TooShort {
            needed: 3,
            got: keep.len(),
        }
        .into());
    }
    let tau: Vec<f64> = keep.iter().map(|&i| curve.tau_s[i]).collect();
    let m: Vec<usize> = tau
        .iter()
        .map(|t| (t * rate_hz).round().max(1.0) as usize)
        .collect();
    let avar: Vec<f64> = keep.iter().map(|&i| curve.adev[i].powi(2)).collect();
    let n_phase = n_samples + 1;
    let dof_of = |c: &[f64; 5]| tau.len().saturating_sub(n_active(c));
    // backward elimination: refit without the least significant positive term until every
    // positive term is at least min_z standard errors from zero
    let mut allowed = [true; 5];
    let mut passes = 0;
    let (c, cov, eps, converged) = loop {
        let it = iterate(&tau, &m, &avar, n_phase, &allowed, settings);
        passes += it.passes;
        let weakest = (0..5)
            .filter(|&j| it.c[j] > 0.0)
            .map(|j| {
                let v = it.cov[(j, j)];
                (j, if v > 0.0 { it.c[j] / v.sqrt() } else { 0.0 })
            })
            .filter(|&(_, z)| z < settings.min_z)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match weakest {
            Some((j, _)) => allowed[j] = false,
            None => break (it.c, it.cov, it.eps, it.converged),
        }
    };
    // final points: noise type and EDF from the final model, bands around the measurement
    let e = edfs(Some(&c), &tau, &m, n_phase);
    let points: Vec<CurvePoint> = (0..tau.len())
        .map(|i| {
            let adev = avar[i].sqrt();
            let (lo, hi) = chi2_interval(adev, e[i].1, settings.confidence);
            CurvePoint {
                tau_s: tau[i],
                m: m[i],
                adev,
                lo,
                hi,
                edf: e[i].1,
                noise: e[i].0,
                model_adev: model_var(&c, tau[i]).sqrt(),
            }
        })
        .collect();
    let terms = Term::ALL
        .iter()
        .map(|&t| {
            let j = t.index();
            let cj = c[j];
            let var_c = cov[(j, j)];
            let dom: Vec<f64> = tau
                .iter()
                .copied()
                .filter(|&x| cj > 0.0 && dominant(&c, x) == t)
                .collect();
            let dominant_tau_s = (!dom.is_empty()).then(|| [dom[0], dom[dom.len() - 1]]);
            let resolution = if !allowed[j] {
                Resolution::NotSignificant
            } else if cj.is_nan() || cj <= 0.0 {
                Resolution::FittedZero
            } else if dom.is_empty() {
                Resolution::NeverDominant
            } else {
                Resolution::Resolved
            };
            let upper_bound = points
                .iter()
                .map(|p| p.hi / t.basis(p.tau_s).sqrt())
                .fold(f64::INFINITY, f64::min);
            TermResult {
                term: t,
                coefficient: cj.sqrt(),
                std_error: (cj > 0.0 && var_c > 0.0).then(|| var_c.sqrt() / (2.0 * cj.sqrt())),
                resolution,
                dominant_tau_s,
                upper_bound,
            }
        })
        .collect();
    let sd = sds(&c, &tau, &avar, &e, eps);
    Ok(TermFit {
        points,
        terms,
        passes,
        converged,
        model_error: eps,
        chi2: chi2(&c, &tau, &avar, &sd),
        dof: dof_of(&c),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trigamma_known_values() {
        // ψ'(1) = π²/6, ψ'(1/2) = π²/2, ψ'(x + 1) = ψ'(x) − 1/x²: closed forms, to 1e-12.
        let pi2 = PI * PI;
        assert!((trigamma(1.0) - pi2 / 6.0).abs() < 1e-12);
        assert!((trigamma(0.5) - pi2 / 2.0).abs() < 1e-12);
        for x in [0.3, 2.7, 7.5, 40.0] {
            assert!((trigamma(x + 1.0) - (trigamma(x) - 1.0 / (x * x))).abs() < 1e-12);
        }
    }
}
