//! From a fitted signal model to the bias state-space model the online Kalman filter runs.
//!
//! **The problem.** `fit` models the calibrated static signal `y = b + v` of a channel by an
//! AR(P): `A_y(z) y = e`, `var(e) = s2`. The online stage needs the bias `b` alone, as a small
//! AR(p) (`p <= MAX_AR_ORDER`), `A_b(z) b = w`, `var(w) = q`, plus the white measurement noise
//! `v`, `var(v) = R` (from the file, e.g. an Allan ARW), because only `b` may be propagated through
//! motion. Since `v` is white and independent of `b`, autocovariances and spectra add:
//!
//! ```text
//!   gamma_y(k) = gamma_b(k) + R delta_k,        S_y(w) = q / |A_b(e^{iw})|^2 + R.
//! ```
//!
//! **Autocovariances of the fit.** `gamma_y(0..=K)` follow exactly from the AR(P): reflection
//! coefficients by the step-down (reverse Levinson) recursion, `gamma_y(0) = s2 / prod (1 - k_m^2)`,
//! `gamma_y(m) = sum_{i<=m} phi^(m)_i gamma_y(m-i)` by step-up, the AR recursion beyond P
//! (Kay, *Modern Spectral Estimation*, 1988, §6.3).
//!
//! **Candidate bias models**, for every order p = 1..=min(P, 4):
//! 1. *short-lag moment matching*: Yule–Walker (Levinson) on `gamma_b(0..=p)`, `gamma_b(0) =
//!    gamma_y(0) - R`: reproduces the bias autocovariances at lags 0..=p exactly;
//! 2. *long-lag fit*: the modified Yule–Walker equations `gamma_y(k) = sum_i phi_i gamma_y(k-i)`,
//!    `k = p+1..K`, which hold exactly for an AR(p) bias in white noise (the noise only touches
//!    lag 0) — least squares over lags up to where the autocorrelation has decayed below 2 %
//!    (at most 20 000) — with q set so that the bias variance is `gamma_b(0)`. A slow bias (a
//!    10-s correlation time is 1000 samples at 100 Hz) is invisible at lags 0..=4 under white
//!    noise, but not at long lags.
//!
//! **Selection.** Each candidate's optimal one-step predictor, applied to data with the fitted
//! spectrum `S_y`, has prediction-error variance `sigma_inn^2(cand) * mean_w [S_y / S_cand]`
//! (Whittle's criterion; the error filter has gain `sigma_inn^2 / S_cand`); the candidate with
//! the smallest one is chosen. This is exactly the quantity the online filter's innovations
//! measure, so the filter reaches the one-step optimum of the fitted model as closely as an
//! order-4 bias allows; when the truth is "AR(p) bias + white noise" and the fit is good, both
//! candidate families are consistent. A bias model given directly (`ar_of = "bias"`, p <= 4) is
//! used as is.
//!
//! **Admissible R.** `R` must leave a positive bias variance: `0 < R < gamma_y(0)`. `R = 0` in the
//! file means "unknown", and an R not below `0.999 gamma_y(0)` is rejected; both are replaced by
//! `0.999 min_w S_y(w)`, the largest white noise the fitted spectrum admits (the bias spectrum
//! `S_y - R` then stays positive), and reported as clamped.
//!
//! **Optimum.** For the model `b` + `v` the best one-step predictor of `y` from its infinite past
//! has the prediction-error variance of the Kolmogorov–Szegő formula
//! `sigma_inn^2 = exp( (1/2 pi) ∫ ln S_y(w) dw )`; with `S_y = (q + R |A_b|^2) / |A_b|^2` and
//! `∫ ln |A_b|^2 = 0` for a minimum-phase monic `A_b` (Jensen), `sigma_inn^2 =
//! exp(mean_w ln(q + R |A_b(e^{iw})|^2))` — a smooth integrand that the trapezoidal rule on the
//! circle integrates to machine precision. The steady-state Kalman innovation variance (discrete
//! algebraic Riccati equation, iterated here in [`riccati_innovation_var`]) must equal it.

use crate::model::bias_model::{ArOf, ChannelBiasModel};
use crate::stats::ar_poly::{self, ar_is_stationary, levinson};

/// Largest bias AR order the online filter carries (state dimension = this + 1 with the
/// random-constant state).
pub const MAX_AR_ORDER: usize = 4;

/// Why a model cannot be turned into a bias state-space model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateSpaceError {
    /// The AR polynomial has a root on or outside the unit circle.
    #[error("AR model is not stationary")]
    NotStationary,
    /// A variance is non-positive or non-finite.
    #[error("invalid variance {name} = {value}")]
    BadVariance { name: &'static str, value: f64 },
    /// The bias autocovariances are not positive definite (numerically).
    #[error("bias autocovariance is not positive definite at order {order}")]
    NotPositiveDefinite { order: usize },
}

/// The bias process of one channel in the form the online Kalman filter uses.
#[derive(Debug, Clone, PartialEq)]
pub struct BiasStateSpace {
    /// Level the bias wanders around (unit; the model's `mean`).
    pub mean: f64,
    /// Bias AR order p (0..=MAX_AR_ORDER); 0 = no stochastic bias dynamics.
    pub order: usize,
    /// phi_b,1..phi_b,p (entries past `order` are 0).
    pub phi: [f64; MAX_AR_ORDER],
    /// Variance of the bias driving noise per sample, unit².
    pub q: f64,
    /// White measurement noise variance per sample, unit² (the KF's R).
    pub r: f64,
    /// Bias autocovariances gamma_b(0..=MAX_AR_ORDER), unit²; `gamma[0]` is the stationary
    /// bias variance and `Toeplitz(gamma[0..order])` the stationary state covariance.
    pub gamma: [f64; MAX_AR_ORDER + 1],
    /// True if the file's white-noise variance was unknown (0) or too large and was set to the
    /// admissible maximum.
    pub white_noise_clamped: bool,
    /// Sample rate of the model, Hz.
    pub sample_rate_hz: f64,
}

/// Autocovariances gamma(0..=max_lag) of the stationary AR(p) `x[n] = sum phi_i x[n-i] + e[n]`,
/// `var(e) = sigma2` ([`crate::stats::ar_poly::ar_autocovariance`] with this module's errors).
pub fn ar_autocovariance(
    phi: &[f64],
    sigma2: f64,
    max_lag: usize,
) -> Result<Vec<f64>, StateSpaceError> {
    if !(sigma2.is_finite() && sigma2 > 0.0) {
        return Err(StateSpaceError::BadVariance {
            name: "innovation_var",
            value: sigma2,
        });
    }
    ar_poly::ar_autocovariance(phi, sigma2, max_lag).ok_or(StateSpaceError::NotStationary)
}

/// `|A(e^{iw})|^2` for `A(z) = 1 - sum phi_i z^-i`.
pub fn ar_poly_mag2(phi: &[f64], w: f64) -> f64 {
    let (mut re, mut im) = (1.0, 0.0);
    for (i, p) in phi.iter().enumerate() {
        let a = w * (i + 1) as f64;
        re -= p * a.cos();
        im += p * a.sin();
    }
    re * re + im * im
}

/// Minimum over w in [0, pi] of the AR spectrum `sigma2 / |A(e^{iw})|^2` (variance units),
/// on a 4096-point grid refined by golden-section search around the best grid point.
pub fn ar_spectrum_min(phi: &[f64], sigma2: f64) -> f64 {
    if phi.is_empty() {
        return sigma2;
    }
    // The minimum of S is the maximum of |A|^2.
    let n = 4096;
    let dw = std::f64::consts::PI / n as f64;
    let (mut best_w, mut best) = (0.0, f64::MIN);
    for j in 0..=n {
        let w = j as f64 * dw;
        let m = ar_poly_mag2(phi, w);
        if m > best {
            best = m;
            best_w = w;
        }
    }
    // Golden-section refinement of the maximum of |A|^2 in the neighbouring cells.
    let (mut lo, mut hi) = (
        (best_w - dw).max(0.0),
        (best_w + dw).min(std::f64::consts::PI),
    );
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..60 {
        let w1 = hi - g * (hi - lo);
        let w2 = lo + g * (hi - lo);
        if ar_poly_mag2(phi, w1) > ar_poly_mag2(phi, w2) {
            hi = w2;
        } else {
            lo = w1;
        }
    }
    let refined = ar_poly_mag2(phi, 0.5 * (lo + hi));
    sigma2 / best.max(refined)
}

/// One-step optimal prediction-error variance of `y = b + v`, `A_b(z) b = w`, `var(w) = q`,
/// `var(v) = r`, by the Kolmogorov–Szegő formula (see module docs). `phi_b` must be stationary.
pub fn innovation_var_kolmogorov(phi_b: &[f64], q: f64, r: f64) -> f64 {
    // Mean of ln(q + r|A|^2) over the full circle: a smooth periodic integrand, for which the
    // N-point trapezoidal rule converges geometrically; 2^14 points is far past convergence for
    // orders <= MAX_AR_ORDER (checked against 2^16 in the tests).
    let n = 1usize << 14;
    let mut acc = 0.0;
    for j in 0..n {
        let w = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
        acc += (q + r * ar_poly_mag2(phi_b, w)).ln();
    }
    (acc / n as f64).exp()
}

/// Steady-state innovation variance `H P H' + R` of the Kalman filter for the bias AR(p) in
/// companion form plus white noise, by iterating the discrete Riccati recursion to convergence.
/// Independent of the online filter's structured code (plain dense `nalgebra::DMatrix`).
pub fn riccati_innovation_var(phi_b: &[f64], q: f64, r: f64) -> f64 {
    use nalgebra::{DMatrix, DVector};
    let p = phi_b.len();
    if p == 0 {
        return r;
    }
    let mut f = DMatrix::<f64>::zeros(p, p);
    for i in 0..p {
        f[(0, i)] = phi_b[i];
        if i + 1 < p {
            f[(i + 1, i)] = 1.0;
        }
    }
    let mut qm = DMatrix::<f64>::zeros(p, p);
    qm[(0, 0)] = q;
    let mut h = DVector::<f64>::zeros(p);
    h[0] = 1.0;
    let mut pm = DMatrix::<f64>::identity(p, p) * (q + r);
    let mut s_prev = f64::MAX;
    for _ in 0..2_000_000 {
        let ph = &pm * &h;
        let s = h.dot(&ph) + r;
        let post = &pm - &ph * ph.transpose() / s;
        pm = &f * post * f.transpose() + &qm;
        if (s - s_prev).abs() <= 1e-15 * s {
            return s;
        }
        s_prev = s;
    }
    s_prev
}

impl BiasStateSpace {
    /// Bias model given directly as an AR(p) with p <= MAX_AR_ORDER (driving variance `q`),
    /// white noise `r`, around `mean`.
    pub fn from_bias_ar(
        phi: &[f64],
        q: f64,
        r: f64,
        mean: f64,
        sample_rate_hz: f64,
    ) -> Result<Self, StateSpaceError> {
        let m = ChannelBiasModel {
            channel: "gx".into(),
            method: "truth".into(),
            sample_rate_hz,
            mean,
            ar: phi.to_vec(),
            innovation_var: q,
            white_noise_var: r,
            ar_of: ArOf::Bias,
            effects: Vec::new(),
        };
        state_space_from_model(&m)
    }

    /// The bias AR coefficients as a slice of length `order`.
    pub fn phi(&self) -> &[f64] {
        &self.phi[..self.order]
    }

    /// Steady-state one-step innovation variance of the model (Kolmogorov–Szegő).
    pub fn optimal_innovation_var(&self) -> f64 {
        if self.order == 0 {
            self.r
        } else {
            innovation_var_kolmogorov(self.phi(), self.q, self.r)
        }
    }
}

/// Longest lag used by the long-lag fit (samples).
const MAX_LONG_LAG: usize = 20_000;
/// Points of the frequency grid used to score candidate bias models.
const SCORE_POINTS: usize = 8192;

/// Frequency grid on (0, pi) for the predictor score: `w = pi u^2` with `u` at midpoints of a
/// uniform grid, so that points crowd towards w = 0 where a slow bias concentrates its power;
/// `weights` make `sum weights f(w)` the mean of f over [0, pi] (`dw = 2 pi u du`).
fn score_grid() -> (Vec<f64>, Vec<f64>) {
    let n = SCORE_POINTS;
    let du = 1.0 / n as f64;
    (0..n)
        .map(|j| {
            let u = (j as f64 + 0.5) * du;
            (std::f64::consts::PI * u * u, 2.0 * u * du)
        })
        .unzip()
}

/// One-step prediction-error variance obtained when the optimal predictor of the model
/// "bias AR(phi_b, q) + white r" is applied to data whose spectrum is `s_y` (sampled on the score
/// grid): `sigma_inn^2(model) * mean_w [ S_y(w) / S_model(w) ]` — the predictor's error filter
/// has gain `sigma_inn^2 / S_model`. Minimal (= Kolmogorov of S_y) when S_model ∝ S_y.
pub fn predictor_mse_on_spectrum(
    phi_b: &[f64],
    q: f64,
    r: f64,
    grid: &(Vec<f64>, Vec<f64>),
    s_y: &[f64],
) -> f64 {
    let (w, wt) = grid;
    let mut acc = 0.0;
    for i in 0..w.len() {
        let a2 = ar_poly_mag2(phi_b, w[i]);
        acc += wt[i] * s_y[i] * a2 / (q + r * a2);
    }
    innovation_var_kolmogorov(phi_b, q, r) * acc
}

/// Long-lag (modified Yule-Walker) fit of an AR(p) to the autocovariances `gamma[1..]` of the
/// signal: least squares on `gamma(k) = sum_i phi_i gamma(k-i)` for `k = p+1..K`. These equations
/// hold exactly for "AR(p) bias + white noise" (the noise only touches lag 0, which they never
/// use), so R does not enter; using lags up to K captures slow poles that lags 0..p cannot.
fn long_lag_ar(gamma: &[f64], p: usize) -> Option<Vec<f64>> {
    use nalgebra::{DMatrix, DVector};
    let k_max = gamma.len() - 1;
    if k_max < 2 * p + 2 {
        return None;
    }
    let mut ata = DMatrix::<f64>::zeros(p, p);
    let mut atb = DVector::<f64>::zeros(p);
    for k in (p + 1)..=k_max {
        for i in 0..p {
            let gi = gamma[k - 1 - i];
            atb[i] += gi * gamma[k];
            for j in 0..p {
                ata[(i, j)] += gi * gamma[k - 1 - j];
            }
        }
    }
    let sol = ata.lu().solve(&atb)?;
    let phi: Vec<f64> = sol.iter().copied().collect();
    (phi.iter().all(|v| v.is_finite()) && ar_is_stationary(&phi)).then_some(phi)
}

/// Build the bias state-space model of a channel from its model-file entry (see module docs for
/// the decomposition). The AR order is reduced to at most [`MAX_AR_ORDER`].
pub fn state_space_from_model(m: &ChannelBiasModel) -> Result<BiasStateSpace, StateSpaceError> {
    if !(m.white_noise_var.is_finite() && m.white_noise_var >= 0.0) {
        return Err(StateSpaceError::BadVariance {
            name: "white_noise_var",
            value: m.white_noise_var,
        });
    }
    let p_file = m.ar.len();
    let order_max = p_file.min(MAX_AR_ORDER);
    let done = |order: usize,
                phi_v: &[f64],
                q: f64,
                r: f64,
                clamped: bool|
     -> Result<BiasStateSpace, StateSpaceError> {
        let mut phi = [0.0; MAX_AR_ORDER];
        phi[..order].copy_from_slice(&phi_v[..order]);
        let mut gamma = [0.0; MAX_AR_ORDER + 1];
        if order > 0 {
            gamma.copy_from_slice(&ar_autocovariance(&phi[..order], q, MAX_AR_ORDER)?);
        }
        Ok(BiasStateSpace {
            mean: m.mean,
            order,
            phi,
            q: if order > 0 { q } else { 0.0 },
            r,
            gamma,
            white_noise_clamped: clamped,
            sample_rate_hz: m.sample_rate_hz,
        })
    };
    // The bias itself, small enough: use it as is.
    if m.ar_of == ArOf::Bias && p_file <= MAX_AR_ORDER {
        ar_autocovariance(&m.ar, m.innovation_var, 0)?; // stationarity and variance checks
        return done(p_file, &m.ar, m.innovation_var, m.white_noise_var, false);
    }
    // Autocovariances of the whole signal y = b + v, to the long lags.
    let gamma_file = ar_autocovariance(&m.ar, m.innovation_var, MAX_LONG_LAG)?;
    let mut gamma_y = gamma_file.clone();
    let (r, clamped) = match m.ar_of {
        ArOf::Bias => {
            gamma_y[0] += m.white_noise_var;
            (m.white_noise_var, false)
        }
        ArOf::Signal => {
            // Largest admissible white variance; 0.999 keeps the bias spectrum strictly positive.
            let r_max = if p_file == 0 {
                m.innovation_var
            } else {
                0.999 * ar_spectrum_min(&m.ar, m.innovation_var)
            };
            if m.white_noise_var > 0.0 && m.white_noise_var < 0.999 * gamma_y[0] {
                (m.white_noise_var, false)
            } else {
                (r_max, true)
            }
        }
    };
    if order_max == 0 {
        // A white "bias" cannot be told from white noise: everything is measurement noise.
        return done(0, &[], 0.0, gamma_y[0], clamped);
    }
    let gamma_b0 = gamma_y[0] - r;
    // The signal spectrum on the score grid.
    let grid = score_grid();
    let s_file: Vec<f64> = grid
        .0
        .iter()
        .map(|w| m.innovation_var / ar_poly_mag2(&m.ar, *w))
        .collect();
    let s_y: Vec<f64> = match m.ar_of {
        ArOf::Bias => s_file.iter().map(|s| s + r).collect(),
        ArOf::Signal => s_file,
    };
    // Long-lag window: up to where the lag-k autocorrelation has decayed below 2 %.
    let k_end = (1..=MAX_LONG_LAG)
        .find(|&k| gamma_y[k].abs() < 0.02 * gamma_y[1].abs())
        .unwrap_or(MAX_LONG_LAG)
        .max(10 * MAX_AR_ORDER);
    // Candidates of every order 1..=order_max: short-lag moment matching (Levinson on
    // gamma_b(0..=p)) and the long-lag fit with q matching the bias variance gamma_b(0).
    let mut best: Option<(f64, usize, Vec<f64>, f64)> = None;
    let mut consider = |phi: Vec<f64>, q: f64| {
        if !(q.is_finite() && q > 0.0) {
            return;
        }
        let score = predictor_mse_on_spectrum(&phi, q, r, &grid, &s_y);
        if score.is_finite() && best.as_ref().is_none_or(|b| score < b.0) {
            best = Some((score, phi.len(), phi, q));
        }
    };
    let mut gamma_b = gamma_y[..=MAX_AR_ORDER].to_vec();
    gamma_b[0] = gamma_b0;
    for p in 1..=order_max {
        if let Some(l) = levinson(&gamma_b, p) {
            consider(l.phi, l.var);
        }
        if gamma_b0 > 0.0
            && let Some(phi) = long_lag_ar(&gamma_y[..=k_end], p)
            && let Ok(unit) = ar_autocovariance(&phi, 1.0, 0)
        {
            let q = gamma_b0 / unit[0];
            consider(phi, q);
        }
    }
    let (_, order, phi, q) =
        best.ok_or(StateSpaceError::NotPositiveDefinite { order: order_max })?;
    done(order, &phi, q, r, clamped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ar2_autocovariance_satisfies_yule_walker_and_levinson_inverts_it() {
        let phi = [1.2, -0.35];
        let g = ar_autocovariance(&phi, 0.5, 6).unwrap();
        // Yule-Walker: gamma(k) = phi1 gamma(k-1) + phi2 gamma(|k-2|), k >= 1; and
        // gamma(0) = phi1 gamma(1) + phi2 gamma(2) + s2.
        assert!((g[0] - (phi[0] * g[1] + phi[1] * g[2] + 0.5)).abs() < 1e-12 * g[0]);
        assert!((g[1] - (phi[0] * g[0] + phi[1] * g[1])).abs() < 1e-12 * g[0]);
        for k in 2..=6 {
            assert!((g[k] - (phi[0] * g[k - 1] + phi[1] * g[k - 2])).abs() < 1e-12 * g[0]);
        }
        let l = levinson(&g, 2).unwrap();
        let (a, e) = (l.phi, l.var);
        assert!(
            (a[0] - 1.2).abs() < 1e-12 && (a[1] + 0.35).abs() < 1e-12,
            "{a:?}"
        );
        assert!((e - 0.5).abs() < 1e-12);
        // Asking for a higher order of a true AR(2) gives zero extra coefficients.
        let l4 = levinson(&g, 4).unwrap();
        let (a4, e4) = (l4.phi, l4.var);
        assert!(a4[2].abs() < 1e-12 && a4[3].abs() < 1e-12 && (e4 - 0.5).abs() < 1e-12);
    }

    #[test]
    fn non_stationary_models_and_bad_variances_are_errors() {
        assert!(ar_autocovariance(&[1.01], 1.0, 2).is_err());
        assert!(ar_autocovariance(&[0.5], 0.0, 2).is_err());
    }

    #[test]
    fn decomposition_recovers_the_true_bias_from_a_long_exact_signal_model() {
        // True: bias AR(2) with poles 0.99 and 0.9 (phi = 1.89, -0.891), sd 0.5, white R = 1.
        // The signal model is the Yule-Walker AR(64) of the exact signal autocovariances (what a
        // long fit converges to). Decomposing it with the true R must give back a bias model whose
        // one-step predictor is within 0.1 % of the true optimum (the AR(64) itself is within
        // ~0.01 %: an ARMA(2,2) with these zeros is well approximated at order 64), and whose
        // bias variance is the true one (1 %).
        let (phi, r) = ([1.89, -0.891], 1.0);
        let q = 0.25 / ar_autocovariance(&phi, 1.0, 0).unwrap()[0];
        let gb = ar_autocovariance(&phi, q, 64).unwrap();
        let mut gy = gb.clone();
        gy[0] += r;
        let l = levinson(&gy, 64).unwrap();
        let (a_sig, e_sig) = (l.phi, l.var);
        let m = ChannelBiasModel {
            channel: "gz".into(),
            method: "yule_walker".into(),
            sample_rate_hz: 100.0,
            ar: a_sig,
            innovation_var: e_sig,
            white_noise_var: r,
            ..Default::default()
        };
        let ss = state_space_from_model(&m).unwrap();
        assert!(!ss.white_noise_clamped);
        let opt = innovation_var_kolmogorov(&phi, q, r);
        let grid = score_grid();
        let s_true: Vec<f64> = grid
            .0
            .iter()
            .map(|w| q / ar_poly_mag2(&phi, *w) + r)
            .collect();
        let got = predictor_mse_on_spectrum(ss.phi(), ss.q, ss.r, &grid, &s_true);
        assert!(
            got / opt < 1.001,
            "predictor MSE / optimum = {} ({:?}, q {})",
            got / opt,
            ss.phi(),
            ss.q
        );
        assert!(
            (ss.gamma[0] / 0.25 - 1.0).abs() < 0.01,
            "bias variance {}",
            ss.gamma[0]
        );
        assert_eq!(ss.r, r);
    }

    #[test]
    fn predictor_score_of_the_true_model_is_its_optimum() {
        // Closed form: applied to its own spectrum, a model's predictor error equals its
        // Kolmogorov innovation variance (1e-6: quadrature of a sharply peaked integrand).
        let (phi, q, r) = ([1.989, -0.98901], 1.674e-13, 3.05e-6);
        let grid = score_grid();
        let s: Vec<f64> = grid
            .0
            .iter()
            .map(|w| q / ar_poly_mag2(&phi, *w) + r)
            .collect();
        let got = predictor_mse_on_spectrum(&phi, q, r, &grid, &s);
        let want = innovation_var_kolmogorov(&phi, q, r);
        assert!((got / want - 1.0).abs() < 1e-6, "{got} vs {want}");
    }

    #[test]
    fn too_large_or_unknown_white_noise_is_clamped_to_the_spectrum_minimum() {
        // (An R not below gamma_y(0) leaves no bias variance: clamped.)
        // AR(1) signal phi=0.5, s2=1: S(w) = 1/|1-0.5 e^{-iw}|^2, minimum at w=pi: 1/2.25.
        let mut m = ChannelBiasModel {
            channel: "gx".into(),
            method: "burg".into(),
            sample_rate_hz: 100.0,
            ar: vec![0.5],
            innovation_var: 1.0,
            white_noise_var: 0.0,
            ..Default::default()
        };
        let ss = state_space_from_model(&m).unwrap();
        assert!(ss.white_noise_clamped);
        assert!((ss.r - 0.999 / 2.25).abs() < 1e-9, "r {}", ss.r);
        m.white_noise_var = 10.0;
        assert!(state_space_from_model(&m).unwrap().white_noise_clamped);
        m.white_noise_var = 0.2;
        let ss = state_space_from_model(&m).unwrap();
        assert!(!ss.white_noise_clamped && ss.r == 0.2);
        // Every candidate keeps the bias variance gamma_y(0) - R = 1/0.75 - 0.2.
        assert!((ss.gamma[0] - (1.0 / 0.75 - 0.2)).abs() < 1e-9, "{:?}", ss);
    }

    #[test]
    fn kolmogorov_and_riccati_innovation_variances_agree() {
        // Two independent computations of the same optimum (spectral formula vs iterated DARE):
        // they must agree to round-off (1e-9 relative).
        for (phi, q, r) in [
            (vec![0.95], 1e-3, 1.0),
            (vec![1.5, -0.56], 1e-4, 1.0),
            (vec![0.999], 1e-6, 3e-6),
            (vec![0.3, 0.2, 0.1, 0.05], 0.5, 0.1),
        ] {
            let k = innovation_var_kolmogorov(&phi, q, r);
            let d = riccati_innovation_var(&phi, q, r);
            assert!(
                (k - d).abs() < 1e-9 * d,
                "{phi:?}: kolmogorov {k} riccati {d}"
            );
        }
        // No white noise: the optimum is the bias innovation variance itself.
        let k = innovation_var_kolmogorov(&[0.7], 2.0, 0.0);
        assert!((k - 2.0).abs() < 1e-12);
    }

    #[test]
    fn innovation_variance_matches_scipy_dare() {
        // Values printed by tests/reference/innovation_var.py (scipy.linalg.solve_discrete_are);
        // 1e-9 relative: both are converged double-precision solutions of the same equation.
        let cases: [(&[f64], f64, f64, f64); 3] = [
            (&[1.5, -0.56], 1e-4, 1.0, SCIPY_CASE0),
            (&[0.999], 1e-6, 3e-6, SCIPY_CASE1),
            (&[1.6, -0.64], 4e-8, 3.0e-6, SCIPY_CASE2),
        ];
        for (phi, q, r, want) in cases {
            let got = innovation_var_kolmogorov(phi, q, r);
            assert!(
                (got - want).abs() < 1e-9 * want,
                "{phi:?}: {got} vs scipy {want}"
            );
        }
    }
    const SCIPY_CASE0: f64 = 1.0019166867792348;
    const SCIPY_CASE1: f64 = 5.29894780635939e-06;
    const SCIPY_CASE2: f64 = 3.6343599545867885e-06;
}
