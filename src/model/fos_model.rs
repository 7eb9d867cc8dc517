//! A fitted FOS difference-equation model ([`FosModel`]) and the fast fit that produces it.
//!
//! Model, in standardised units `u = (y - center) / scale` (and likewise for each exogenous
//! series): `u(n) = sum_m a_m P_m(n)` with the P_m chosen by fast orthogonal search
//! ([`super::fos`]) among candidate families ([`super::fos_candidates`]). The prediction in
//! sensor units is `center + scale * sum_m a_m P_m(n)`.
//!
//! Why standardise: FOS works on raw (uncentred) moments. On a gyro with a 4.5 deg/s bias, or
//! an accelerometer reading 9.8 m/s^2 with mg noise, `y(n-1) y(n-2)` is nearly collinear with
//! the constant and the lags, and the orthogonal remainder D(m,m) is ~1e-10 of mean(p_m^2):
//! the Gram-Schmidt recursion would keep only a few digits. Centring and scaling first spans
//! the same function space (products of affine maps of y expand into constant, lags and
//! products) while keeping D(m,m) of order one. The selected *terms* refer to `u`.
//!
//! Fast inner products ([`ShiftCorrelator`]): every candidate is a shifted base series
//! `P_m(n) = B_m(n - s_m)` (see [`BaseKey`]). Over the fit rows `n = n0..N` with `n0 >= s_max`,
//! `sum_n B_1(n - s_1) B_2(n - s_2) = sum_{t=n0-s_1}^{N-1-s_1} B_1(t) B_2(t - e)`, `e = s_2 - s_1`.
//! The middle part `t = n0..N-s_max` depends only on (B_1, B_2, e) and is cached; the at most
//! 2 s_max end terms are added per pair. A CP=2, L=10 search therefore computes one length-N
//! dot product per new (base, base, e) triple instead of one per (candidate, selected term).

use super::fos::{Correlator, FosFit, FosSettings, dot, fos_search_with};
use super::fos_candidates::{BaseKey, Family, TermSpec, family_terms};
use super::{ModelError, mean};
use crate::stats::{NumError, check_finite, check_same_len};
use serde::{Deserialize, Serialize};

/// What to fit: the candidate families and whether to standardise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FosModelSpec {
    /// Candidate families (see [`Family::paper_set`]).
    pub families: Vec<Family>,
    /// Centre and scale y (and each exogenous series) by its fit-data mean and standard
    /// deviation before the search (recommended; see the module docs).
    pub standardize: bool,
}

impl FosModelSpec {
    /// The paper's set: constant, lags 1..=L, and for `cp_degree == 2` the cross-products;
    /// standardised.
    pub fn paper(max_lag: usize, cp_degree: usize) -> Self {
        FosModelSpec {
            families: Family::paper_set(max_lag, cp_degree, 0, 0),
            standardize: true,
        }
    }
}

/// A fitted FOS model, ready to predict. Serialises to TOML.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FosModel {
    /// Selected terms, in selection order (over the standardised series).
    pub terms: Vec<TermSpec>,
    /// Coefficient of each term in the original (non-orthogonal) basis.
    pub coefficients: Vec<f64>,
    /// Offset removed from y before the model, sensor units.
    pub center: f64,
    /// Scale dividing y before the model, sensor units (1 if not standardised).
    pub scale: f64,
    /// Offset of each exogenous series (empty if none).
    #[serde(default)]
    pub exo_center: Vec<f64>,
    /// Scale of each exogenous series.
    #[serde(default)]
    pub exo_scale: Vec<f64>,
}

impl FosModel {
    /// Fit by fast orthogonal search on `y` (and exogenous series `exo`, each as long as `y`).
    /// Returns the model and the search record (indices refer to
    /// `family_terms(&spec.families)`).
    pub fn fit(
        y: &[f64],
        exo: &[&[f64]],
        spec: &FosModelSpec,
        settings: &FosSettings,
    ) -> Result<(FosModel, FosFit), ModelError> {
        check_finite(y)?;
        for x in exo {
            check_same_len(y.len(), x.len())?;
            check_finite(x)?;
        }
        let terms = family_terms(&spec.families);
        if terms.is_empty() {
            return Err(ModelError::bad("no candidate terms"));
        }
        for t in &terms {
            t.validate(exo.len())?;
        }
        let (center, scale) = if spec.standardize {
            centre_scale(y)?
        } else {
            (0.0, 1.0)
        };
        let mut exo_center = Vec::with_capacity(exo.len());
        let mut exo_scale = Vec::with_capacity(exo.len());
        for x in exo {
            let (c, s) = if spec.standardize {
                // a constant exogenous series is legal (it is just useless); keep scale 1
                centre_scale(x).unwrap_or((mean(x), 1.0))
            } else {
                (0.0, 1.0)
            };
            exo_center.push(c);
            exo_scale.push(s);
        }
        let u: Vec<f64> = y.iter().map(|v| (v - center) / scale).collect();
        let ux: Vec<Vec<f64>> = exo
            .iter()
            .enumerate()
            .map(|(i, x)| {
                x.iter()
                    .map(|v| (v - exo_center[i]) / exo_scale[i])
                    .collect()
            })
            .collect();
        let mut corr = ShiftCorrelator::new(&u, &ux, &terms)?;
        let fit = fos_search_with(&mut corr, settings)?;
        let model = FosModel {
            terms: fit.selected.iter().map(|&i| terms[i]).collect(),
            coefficients: fit.coefficients.clone(),
            center,
            scale,
            exo_center,
            exo_scale,
        };
        Ok((model, fit))
    }

    /// Largest output lag the model reads.
    pub fn max_lag(&self) -> usize {
        self.terms.iter().map(|t| t.max_y_lag()).max().unwrap_or(0)
    }

    /// One-step prediction of y(n) in sensor units.
    ///
    /// `history_newest_last` holds past outputs, the last being y(n-1). `exo_newest_last[i]`
    /// holds exogenous series i up to and including the predicted instant n (its last element
    /// is x_i(n)). A missing value (history too short, series absent) counts as the series'
    /// centre, i.e. contributes zero in standardised units. No allocation, no panic.
    #[inline]
    pub fn predict_next(&self, history_newest_last: &[f64], exo_newest_last: &[&[f64]]) -> f64 {
        let h = history_newest_last;
        let y_lag = |l: usize| match h.len().checked_sub(l) {
            Some(i) if l >= 1 => (h[i] - self.center) / self.scale,
            _ => 0.0,
        };
        let x_lag = |input: usize, l: usize| {
            let (Some(x), Some(c), Some(s)) = (
                exo_newest_last.get(input),
                self.exo_center.get(input),
                self.exo_scale.get(input),
            ) else {
                return 0.0;
            };
            match x.len().checked_sub(l + 1) {
                Some(i) => (x[i] - c) / s,
                None => 0.0,
            }
        };
        let mut acc = 0.0;
        for (t, a) in self.terms.iter().zip(&self.coefficients) {
            acc += a * t.eval(y_lag, x_lag);
        }
        self.center + self.scale * acc
    }

    /// One-step residuals `y(n) - predict(y[..n], exo[..=n])` for `n` in `range`, each using the
    /// full true past.
    pub fn residuals(&self, y: &[f64], exo: &[&[f64]], range: std::ops::Range<usize>) -> Vec<f64> {
        let end = range.end.min(y.len());
        let mut ex: Vec<&[f64]> = Vec::with_capacity(exo.len());
        (range.start.min(end)..end)
            .map(|n| {
                ex.clear();
                ex.extend(exo.iter().map(|x| &x[..(n + 1).min(x.len())]));
                y[n] - self.predict_next(&y[..n], &ex)
            })
            .collect()
    }

    /// Serialise to TOML.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(self)
    }

    /// Parse from TOML, checking the terms and coefficient counts agree.
    pub fn from_toml(s: &str) -> Result<Self, ModelError> {
        let m: FosModel = toml::from_str(s).map_err(|e| ModelError::bad(e.to_string()))?;
        if m.terms.len() != m.coefficients.len() {
            return Err(ModelError::bad(format!(
                "{} terms but {} coefficients",
                m.terms.len(),
                m.coefficients.len()
            )));
        }
        if m.exo_center.len() != m.exo_scale.len() {
            return Err(ModelError::bad("exo_center and exo_scale differ in length"));
        }
        for t in &m.terms {
            t.validate(m.exo_center.len())?;
        }
        if !(m.scale.is_finite() && m.scale != 0.0 && m.center.is_finite()) {
            return Err(ModelError::bad("bad center/scale"));
        }
        Ok(m)
    }
}

/// Mean and (population) standard deviation; error if the series is constant.
fn centre_scale(x: &[f64]) -> Result<(f64, f64), ModelError> {
    let mu = mean(x);
    let var = x.iter().map(|v| (v - mu) * (v - mu)).sum::<f64>() / x.len().max(1) as f64;
    if var.is_nan() || var <= 0.0 {
        return Err(ModelError::Numeric(NumError::Constant));
    }
    Ok((mu, var.sqrt()))
}

/// [`Correlator`] over shifted base series with cached lagged products (module docs).
pub struct ShiftCorrelator {
    bases: Vec<Vec<f64>>,
    /// (base index, shift) per candidate.
    items: Vec<(usize, usize)>,
    /// (base index, shift) of the target y(n).
    target: (usize, usize),
    n0: usize,
    n: usize,
    s_max: usize,
    /// cache[(b1 * nb + b2) * (2 s_max + 1) + e + s_max], NaN = not yet computed.
    cache: Vec<f64>,
    /// Length-N dot products computed (for benchmarks and tests).
    pub core_dots: usize,
}

impl ShiftCorrelator {
    /// Build the base series of `terms` over the standardised output `u` and inputs `ux`.
    pub fn new(u: &[f64], ux: &[Vec<f64>], terms: &[TermSpec]) -> Result<Self, ModelError> {
        let n = u.len();
        let mut keys: Vec<BaseKey> = vec![BaseKey::Y];
        let mut items = Vec::with_capacity(terms.len());
        for t in terms {
            let (k, s) = t.shift_form();
            let b = match keys.iter().position(|x| *x == k) {
                Some(b) => b,
                None => {
                    keys.push(k);
                    keys.len() - 1
                }
            };
            items.push((b, s));
        }
        // First fit row: every term's full history must exist (a product's gap included).
        let n0 = terms.iter().map(|t| t.history_needed()).max().unwrap_or(0);
        let s_max = items.iter().map(|&(_, s)| s).max().unwrap_or(0);
        if n < n0 + s_max + 2 {
            return Err(NumError::TooShort {
                needed: n0 + s_max + 2,
                got: n,
            }
            .into());
        }
        let bases: Vec<Vec<f64>> = keys
            .iter()
            .map(|k| match *k {
                BaseKey::One => vec![1.0; n],
                BaseKey::Y => u.to_vec(),
                BaseKey::YProd { gap } => (0..n)
                    .map(|t| if t >= gap { u[t] * u[t - gap] } else { 0.0 })
                    .collect(),
                BaseKey::Exo { input } => ux[input].clone(),
            })
            .collect();
        let nb = bases.len();
        Ok(ShiftCorrelator {
            bases,
            items,
            target: (0, 0),
            n0,
            n,
            s_max,
            cache: vec![f64::NAN; nb * nb * (2 * s_max + 1)],
            core_dots: 0,
        })
    }

    fn cache_index(&self, b1: usize, b2: usize, e: isize) -> usize {
        (b1 * self.bases.len() + b2) * (2 * self.s_max + 1) + (e + self.s_max as isize) as usize
    }

    /// Compute every not-yet-cached core `sum_{t=n0}^{N-1-s_max} B_1(t) B_2(t - e)` among the
    /// pairs of (base, shift) in `pairs`, in one pass over the data blocked into short
    /// stretches: the bases' blocks stay in cache while all requested lags are accumulated,
    /// so the pass is compute bound instead of memory bound.
    fn ensure_cores(&mut self, pairs: impl Iterator<Item = ((usize, usize), (usize, usize))>) {
        // Cores are computed only for b1 <= b2; core(b1, b2, e) with b1 > b2 is the same sum as
        // core(b2, b1, -e) over a window shifted by e, so it is derived from it with at most
        // 2|e| end terms (this halves the length-N work when all bases get selected).
        let mut req: Vec<(usize, usize, isize, usize)> = Vec::new();
        let mut derived: Vec<(usize, usize, isize, usize, usize)> = Vec::new();
        for ((b1, s1), (b2, s2)) in pairs {
            let e = s2 as isize - s1 as isize;
            let ci = self.cache_index(b1, b2, e);
            if !self.cache[ci].is_nan() {
                continue;
            }
            // mark as requested (0.0) so duplicates are not queued twice
            self.cache[ci] = 0.0;
            if b1 > b2 {
                let cj = self.cache_index(b2, b1, -e);
                if self.cache[cj].is_nan() {
                    self.cache[cj] = 0.0;
                    req.push((b2, b1, -e, cj));
                }
                derived.push((b1, b2, e, ci, cj));
            } else {
                req.push((b1, b2, e, ci));
            }
        }
        const BLOCK: usize = 512;
        let (n0, end) = (self.n0, self.n - self.s_max);
        if !req.is_empty() {
            let mut acc = vec![0.0; req.len()];
            let mut t0 = n0;
            while t0 < end {
                let t1 = (t0 + BLOCK).min(end);
                for (a, &(b1, b2, e, _)) in acc.iter_mut().zip(&req) {
                    let lo2 = (t0 as isize - e) as usize;
                    *a += dot(
                        &self.bases[b1][t0..t1],
                        &self.bases[b2][lo2..lo2 + (t1 - t0)],
                    );
                }
                t0 = t1;
            }
            for (a, &(_, _, _, ci)) in acc.iter().zip(&req) {
                self.cache[ci] = *a;
            }
            self.core_dots += req.len();
        }
        // core(b1,b2,e) = sum_{u=n0-e}^{end-1-e} B2(u) B1(u+e) = core(b2,b1,-e) + the terms of
        // that window outside [n0, end) - the terms of [n0, end) outside it.
        for (b1, b2, e, ci, cj) in derived {
            let (x1, x2) = (&self.bases[b1], &self.bases[b2]);
            let term = |u: usize| x2[u] * x1[(u as isize + e) as usize];
            let ea = e.unsigned_abs();
            let (add, sub) = if e >= 0 {
                (n0 - ea..n0, end - ea..end)
            } else {
                (end..end + ea, n0..n0 + ea)
            };
            let c = self.cache[cj] + add.map(term).sum::<f64>() - sub.map(term).sum::<f64>();
            self.cache[ci] = c;
        }
    }

    /// `sum_{n=n0}^{N-1} B_1(n - s_1) B_2(n - s_2)`; the core must have been ensured.
    fn inner(&self, (b1, s1): (usize, usize), (b2, s2): (usize, usize)) -> f64 {
        let (n0, n, sm) = (self.n0, self.n, self.s_max);
        let e = s2 as isize - s1 as isize;
        let (x1, x2) = (&self.bases[b1], &self.bases[b2]);
        // t runs over n - s1; B_2 index is t - e
        let at = |t: usize| x1[t] * x2[(t as isize - e) as usize];
        let mut s = self.cache[self.cache_index(b1, b2, e)];
        for t in n0 - s1..n0 {
            s += at(t);
        }
        for t in n - sm..n - s1 {
            s += at(t);
        }
        s
    }

    fn n_eff(&self) -> f64 {
        (self.n - self.n0) as f64
    }
}

impl Correlator for ShiftCorrelator {
    fn n_samples(&self) -> usize {
        self.n - self.n0
    }
    fn n_candidates(&self) -> usize {
        self.items.len()
    }
    fn yy(&mut self) -> f64 {
        let t = self.target;
        self.ensure_cores(std::iter::once((t, t)));
        self.inner(t, t) / self.n_eff()
    }
    fn yp(&mut self, out: &mut [f64]) {
        let ne = self.n_eff();
        let t = self.target;
        let items = std::mem::take(&mut self.items);
        self.ensure_cores(items.iter().map(|&it| (it, t)));
        for (o, &it) in out.iter_mut().zip(&items) {
            *o = self.inner(it, t) / ne;
        }
        self.items = items;
    }
    fn pp_diag(&mut self, out: &mut [f64]) {
        let ne = self.n_eff();
        let items = std::mem::take(&mut self.items);
        self.ensure_cores(items.iter().map(|&it| (it, it)));
        for (o, &it) in out.iter_mut().zip(&items) {
            *o = self.inner(it, it) / ne;
        }
        self.items = items;
    }
    fn pp_row(&mut self, s: usize, active: &[bool], out: &mut [f64]) {
        let ne = self.n_eff();
        let items = std::mem::take(&mut self.items);
        let is = items[s];
        self.ensure_cores(
            items
                .iter()
                .zip(active)
                .filter(|(_, a)| **a)
                .map(|(&it, _)| (it, is)),
        );
        for m in 0..items.len() {
            if active[m] {
                out[m] = self.inner(items[m], is) / ne;
            }
        }
        self.items = items;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fos::fos_search;
    use crate::model::fos_candidates::CandidateSet;
    use crate::rng::Rng;

    /// A mildly nonlinear AR(2) series with a large offset, like a biased gyro. Noise 0.2 keeps
    /// |u| ~ 0.25, far from the ~3 where the bilinear term would make it explode.
    fn nonlinear_series(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let (mut a, mut b) = (0.0f64, 0.0f64);
        (0..n)
            .map(|_| {
                let v = 0.6 * a - 0.2 * b + 0.3 * a * b + 0.2 * rng.normal();
                b = a;
                a = v;
                5.0 + v
            })
            .collect()
    }

    #[test]
    fn shift_correlator_matches_explicit_columns() {
        // Same standardised data through both correlators: identical selections, coefficients
        // equal to rounding (different summation order: 1e-10 relative is ~1e6 ulp of slack).
        let y = nonlinear_series(5000, 1);
        let spec = FosModelSpec::paper(4, 2);
        let s = FosSettings {
            max_terms: 12,
            min_mse_ratio: 0.0,
            noise_test: false,
        };
        let (model, fit) = FosModel::fit(&y, &[], &spec, &s).unwrap();
        let u: Vec<f64> = y.iter().map(|v| (v - model.center) / model.scale).collect();
        let cs = CandidateSet::build(&u, &[], &spec.families).unwrap();
        let fit2 = fos_search(cs.target(&u), &cs.columns, &s).unwrap();
        assert_eq!(fit.selected, fit2.selected);
        for (a, b) in fit.coefficients.iter().zip(&fit2.coefficients) {
            assert!((a - b).abs() < 1e-10 * (1.0 + b.abs()), "{a} {b}");
        }
    }

    #[test]
    fn fos_model_finds_the_generating_terms() {
        // 50k samples of u(n) = 0.6u(n-1) - 0.2u(n-2) + 0.3u(n-1)u(n-2) + e: the three terms
        // must be selected among the 15 of CP=2, L=4 (plus a constant that absorbs the mean of
        // the product term).
        let y = nonlinear_series(50_000, 2);
        let (model, _) =
            FosModel::fit(&y, &[], &FosModelSpec::paper(4, 2), &FosSettings::default()).unwrap();
        for t in [
            TermSpec::Lag { lag: 1 },
            TermSpec::Lag { lag: 2 },
            TermSpec::CrossProduct { lag1: 1, lag2: 2 },
        ] {
            assert!(
                model.terms.contains(&t),
                "{t:?} missing from {:?}",
                model.terms
            );
        }
        // In standardised units the product coefficient is 0.3 * scale; its LS sd is
        // noise / (sd(u1 u2) sqrt(N)) = 0.2 / (0.06 * 224) = 0.015 in y units; 5 sd = 0.075.
        let i = model
            .terms
            .iter()
            .position(|t| *t == TermSpec::CrossProduct { lag1: 1, lag2: 2 })
            .unwrap();
        let c = model.coefficients[i] / model.scale;
        assert!((c - 0.3).abs() < 0.075, "{c}");
    }

    #[test]
    fn predict_next_equals_model_equation() {
        let m = FosModel {
            terms: vec![
                TermSpec::Constant,
                TermSpec::Lag { lag: 1 },
                TermSpec::CrossProduct { lag1: 1, lag2: 2 },
                TermSpec::ExoLag { input: 0, lag: 0 },
            ],
            coefficients: vec![0.1, 0.5, 0.2, -1.0],
            center: 10.0,
            scale: 2.0,
            exo_center: vec![25.0],
            exo_scale: vec![0.5],
        };
        // u(n-1) = (14-10)/2 = 2, u(n-2) = (12-10)/2 = 1, x(n) = (25.5-25)/0.5 = 1
        let p = m.predict_next(&[12.0, 14.0], &[&[25.5]]);
        let u = 0.1 + 0.5 * 2.0 + 0.2 * 2.0 * 1.0 - 1.0 * 1.0;
        assert!((p - (10.0 + 2.0 * u)).abs() < 1e-12);
        // short history and missing exogenous input count as centre (u = 0)
        let p0 = m.predict_next(&[], &[]);
        assert!((p0 - (10.0 + 2.0 * 0.1)).abs() < 1e-12);
    }

    #[test]
    fn fos_model_toml_round_trip() {
        let y = nonlinear_series(3000, 3);
        let (m, _) =
            FosModel::fit(&y, &[], &FosModelSpec::paper(3, 2), &FosSettings::default()).unwrap();
        let s = m.to_toml().unwrap();
        assert!(s.contains("kind = \"lag\""), "{s}");
        let back = FosModel::from_toml(&s).unwrap();
        assert_eq!(back, m);
        assert!(
            FosModel::from_toml("terms = []\ncoefficients = [1.0]\ncenter = 0.0\nscale = 1.0")
                .is_err()
        );
    }

    #[test]
    fn paper_cp2_l10_search_adds_no_terms_to_white_noise() {
        // 66 candidates, 36 000 samples of white noise, 5 seeds: the Sidak-corrected noise test
        // admits a first term with probability 0.05 per search, so at most one search in five
        // may add a term (P(>= 2 of 5) = 2 %), and none may add more than 2.
        let mut with_terms = 0;
        for seed in 0..5 {
            let mut rng = Rng::new(500 + seed);
            let y: Vec<f64> = (0..36_000).map(|_| 0.3 + 0.01 * rng.normal()).collect();
            let (m, _) = FosModel::fit(
                &y,
                &[],
                &FosModelSpec::paper(10, 2),
                &FosSettings::default(),
            )
            .unwrap();
            assert!(m.terms.len() <= 2, "seed {seed}: {:?}", m.terms);
            with_terms += usize::from(!m.terms.is_empty());
        }
        assert!(
            with_terms <= 1,
            "{with_terms} of 5 white-noise searches added terms"
        );
    }

    #[test]
    fn exogenous_input_is_found() {
        // y(n) = 0.8 x(n) + 0.5 y(n-1) + noise with x a temperature-like random walk.
        let mut rng = Rng::new(9);
        let n = 20_000;
        let mut x = vec![0.0; n];
        for i in 1..n {
            x[i] = x[i - 1] + 0.01 * rng.normal();
        }
        let mut y = vec![0.0; n];
        for i in 1..n {
            y[i] = 0.8 * x[i] + 0.5 * y[i - 1] + 0.01 * rng.normal();
        }
        let spec = FosModelSpec {
            families: Family::paper_set(2, 1, 1, 1),
            standardize: true,
        };
        let (m, _) = FosModel::fit(&y, &[&x], &spec, &FosSettings::default()).unwrap();
        assert!(
            m.terms.contains(&TermSpec::ExoLag { input: 0, lag: 0 }),
            "{:?}",
            m.terms
        );
        // the one-step residual on the fit data is at the noise level (0.01): MSE <= 1.1e-4
        let r = m.residuals(&y, &[&x], 2..n);
        let mse = r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64;
        assert!(mse < 1.1e-4, "{mse}");
    }
}
