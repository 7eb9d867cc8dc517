//! Slow wander of the decimated residual: a first-order Gauss–Markov process (or its limit, a
//! random walk) seen through white noise, by its one-step Kalman predictor and maximum
//! likelihood on the selection part.
//!
//!   d_k = g_k + v_k,  g_k = φ g_{k−1} + w_k,  var w = q, var v = r,  φ = e^{−Δt/τ} (τ = ∞: RW).
//!
//! The scalar Kalman filter gives the one-step innovations ν_k and their variances S_k; a point
//! marked as not observed (a held-out point while fitting) is predicted through without an
//! update, so the fit never sees held-out data. r is concentrated out of the Gaussian likelihood
//! (r̂ = mean ν²/S̃ with S̃ = S/r), and (τ, q/r) are chosen on a grid: τ from 2Δt to 20 records
//! (log-spaced) plus τ = ∞, q/r from 1e-6 to 10 (log-spaced) plus q = 0 (no wander).
//!
//! **Gauss–Markov or random walk.** Λ = 2(ℓ_GM − ℓ_RW), the best finite τ against τ = ∞. The
//! wander is called Gauss–Markov when Λ > 3.84 (χ²₁ at 5 %; τ = ∞ is the boundary of the GM
//! family, so the χ²₁ reference is conservative) and τ̂ is at most half the record; a random walk
//! when the best GM's τ̂ is beyond half the record (the record cannot show it levelling off) and
//! Λ ≤ 3.84; otherwise undecided. So a GM with τ = 200 s on a 20-min record is never called a
//! random walk: either its levelling off is seen (GM), or the report says it cannot tell.
//!
//! **One component.** A bench usually has several (the simulated one: GM τ = 20 s and 200 s). A
//! second, slower component in a two-state filter, chosen by likelihood ratio, was tried
//! (`docs/experiments/diagnose_two_component_wander.patch`, numbers in
//! docs/results-diagnose-real.md): it finds the two on hours of record, but on the 5–20-min clean
//! logs the likelihood does not ask for it, it changed no finding, and it more than doubled the
//! whole-log diagnose's time; not kept.

use serde::Serialize;

/// Wander parameters in the decimated series' units.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct WanderParams {
    /// φ = e^{−Δt/τ} (1 for a random walk).
    pub phi: f64,
    /// q, units² per step.
    pub q: f64,
    /// r, units².
    pub r: f64,
}

impl WanderParams {
    /// No wander: the predictor is the mean.
    pub fn none(r: f64) -> Self {
        WanderParams {
            phi: 0.0,
            q: 0.0,
            r,
        }
    }
}

/// One-step innovations of `d` under `p` (q and r relative: only their ratio matters for ν);
/// updates only where `observe(k)`. Returns (ν, S/r).
pub fn innovations(
    d: &[f64],
    p: &WanderParams,
    observe: &dyn Fn(usize) -> bool,
) -> (Vec<f64>, Vec<f64>) {
    let qr = if p.r > 0.0 { p.q / p.r } else { 0.0 };
    let mut nu = Vec::with_capacity(d.len());
    let mut s = Vec::with_capacity(d.len());
    let mut g = 0.0;
    // Stationary start for a GM; for a random walk a diffuse prior (1e4 r; the likelihood skips
    // the first two points). Fixed by the parameters, so ν is linear in d (the GLS relies on it).
    let mut pp = if p.phi < 1.0 {
        qr / (1.0 - p.phi * p.phi).max(1e-12)
    } else {
        1e4
    };
    for (k, x) in d.iter().enumerate() {
        // Prediction for k (pp is already the predicted variance for k).
        let e = x - g;
        let sk = pp + 1.0;
        nu.push(e);
        s.push(sk);
        let (g_upd, p_upd) = if observe(k) {
            let kg = pp / sk;
            (g + kg * e, pp * (1.0 - kg))
        } else {
            (g, pp)
        };
        g = p.phi * g_upd;
        pp = p.phi * p.phi * p_upd + qr;
    }
    (nu, s)
}

/// Concentrated log-likelihood over the observed points, with r̂ (the filter of
/// [`innovations`], inline: no allocation, it runs a few hundred times per fit).
fn loglik<F: Fn(usize) -> bool + ?Sized>(d: &[f64], phi: f64, qr: f64, observe: &F) -> (f64, f64) {
    let mut g = 0.0;
    let mut pp = if phi < 1.0 {
        qr / (1.0 - phi * phi).max(1e-12)
    } else {
        1e4
    };
    // Σ ln S_k as ln Π S_k, the product taken to at most 1e250 before its log (S_k ≥ 1, so it
    // only grows; each S_k < 1e50 for q/r ≤ 10 and τ ≤ 20 records): a log per hundred points
    // instead of one per point, which was a third of the whole-log diagnose's time.
    let (mut a, mut l, mut prod, mut k) = (0.0, 0.0, 1.0f64, 0usize);
    for (i, x) in d.iter().enumerate() {
        let e = x - g;
        let sk = pp + 1.0;
        let (g_upd, p_upd) = if observe(i) {
            if i >= 2 {
                a += e * e / sk;
                prod *= sk;
                if prod > 1e250 {
                    l += prod.ln();
                    prod = 1.0;
                }
                k += 1;
            }
            let kg = pp / sk;
            (g + kg * e, pp * (1.0 - kg))
        } else {
            (g, pp)
        };
        g = phi * g_upd;
        pp = phi * phi * p_upd + qr;
    }
    l += prod.ln();
    let kf = k.max(1) as f64;
    let r = a / kf;
    (-0.5 * (kf * r.max(1e-300).ln() + l + kf), r)
}

/// The wander fits of one residual.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct WanderFit {
    /// Best of all (used as the predictor).
    pub best: WanderParams,
    /// Best finite-τ fit and its τ, s.
    pub gm: WanderParams,
    pub gm_tau_s: f64,
    /// Best random walk.
    pub rw: WanderParams,
    /// Log-likelihoods: no wander, GM, RW.
    pub ll_none: f64,
    pub ll_gm: f64,
    pub ll_rw: f64,
}

/// Fit the wander of `d` (step `dt_s`) on the points where `observe(k)`.
pub fn fit<F: Fn(usize) -> bool + ?Sized>(d: &[f64], dt_s: f64, observe: &F) -> WanderFit {
    let t_rec = d.len() as f64 * dt_s;
    let taus: Vec<f64> = (0..14)
        .map(|j| 2.0 * dt_s * (10.0 * t_rec / dt_s).powf(j as f64 / 13.0))
        .collect();
    let qrs: Vec<f64> = (0..15)
        .map(|j| 1e-6 * 10f64.powf(j as f64 * 7.0 / 14.0))
        .collect();
    let (ll_none, r0) = loglik(d, 0.0, 0.0, observe);
    let none = WanderParams::none(r0);
    let mut gm = (f64::NEG_INFINITY, none, f64::INFINITY);
    let mut rw = (f64::NEG_INFINITY, none);
    for &qr in &qrs {
        for &tau in &taus {
            let phi = (-dt_s / tau).exp();
            let (l, r) = loglik(d, phi, qr, observe);
            if l > gm.0 {
                gm = (l, WanderParams { phi, q: qr * r, r }, tau);
            }
        }
        let (l, r) = loglik(d, 1.0, qr, observe);
        if l > rw.0 {
            rw = (
                l,
                WanderParams {
                    phi: 1.0,
                    q: qr * r,
                    r,
                },
            );
        }
    }
    let best = if ll_none >= gm.0.max(rw.0) {
        none
    } else if gm.0 >= rw.0 {
        gm.1
    } else {
        rw.1
    };
    WanderFit {
        best,
        gm: gm.1,
        gm_tau_s: gm.2,
        rw: rw.1,
        ll_none,
        ll_gm: gm.0,
        ll_rw: rw.0,
    }
}

/// What the wander is.
#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum WanderKind {
    /// A first-order Gauss–Markov process with τ within the record.
    GaussMarkov,
    /// A random walk (or a GM whose τ is beyond the record: the same on it).
    RandomWalk,
    /// Wander, but GM and RW are not told apart by this record.
    Undecided,
}

/// Classify a fit (module docs); `t_rec_s` the record length.
pub fn classify(f: &WanderFit, t_rec_s: f64) -> WanderKind {
    let lr = 2.0 * (f.ll_gm - f.ll_rw);
    if lr > 3.84 && f.gm_tau_s <= 0.5 * t_rec_s {
        WanderKind::GaussMarkov
    } else if lr <= 3.84 && f.gm_tau_s > 0.5 * t_rec_s {
        WanderKind::RandomWalk
    } else {
        WanderKind::Undecided
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn series(seed: u64, n: usize, phi: f64, q: f64, r: f64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let mut g = 0.0;
        (0..n)
            .map(|_| {
                g = phi * g + q.sqrt() * rng.normal();
                g + r.sqrt() * rng.normal()
            })
            .collect()
    }

    #[test]
    fn gauss_markov_within_the_record_is_not_a_random_walk() {
        // τ = 200 s on 1 s steps for 20 min (6 τ), GM variance 4 over white 1: the levelling off is
        // seen, so the call must be GM (or, at worst, undecided — never RW), and τ̂ within a factor
        // of 3 (the grid is 13 steps per 5.8 decades and 6 τ holds few independent swings).
        for seed in 1..=5 {
            let phi = (-1.0f64 / 200.0).exp();
            let d = series(seed, 1200, phi, 4.0 * (1.0 - phi * phi), 1.0);
            let f = fit(&d, 1.0, &|_| true);
            let k = classify(&f, 1200.0);
            assert_ne!(k, WanderKind::RandomWalk, "seed {seed}: {f:?}");
        }
        let phi = (-1.0f64 / 200.0).exp();
        let d = series(11, 10_000, phi, 4.0 * (1.0 - phi * phi), 1.0);
        let f = fit(&d, 1.0, &|_| true);
        assert_eq!(classify(&f, 10_000.0), WanderKind::GaussMarkov, "{f:?}");
        assert!(f.gm_tau_s > 200.0 / 3.0 && f.gm_tau_s < 600.0, "{f:?}");
    }

    #[test]
    fn random_walk_is_called_a_random_walk() {
        let d = series(5, 3000, 1.0, 0.01, 1.0);
        let f = fit(&d, 1.0, &|_| true);
        assert_eq!(classify(&f, 3000.0), WanderKind::RandomWalk, "{f:?}");
    }
}
