//! Slow effects over the whole log — bias steps, temperature, g-sensitivity — chosen on the
//! decimated series (1-s means) with a Gauss–Markov / random-walk wander as the stochastic part
//! (`diagnose::wander`), by rounds of "all candidates in, then backward elimination" ([`select`]).
//!
//!   z_k = c + Σ β_j x_{j,k} + g_k + v_k
//!
//! **Fit** (selection points only; held-out points are predicted through without an update):
//! OLS for (c, β); the wander by maximum likelihood on the residual; then GLS — OLS of the
//! Kalman one-step-error filter applied to z and to every column (the filter is linear for given
//! wander parameters) — and the wander again (two passes). So a slow regressor is not credited
//! with the wander's excursions, and a step is judged as a jump, not as a level the wander could
//! reach.
//!
//! **Candidates** (from the selection points only): a step at the strongest change point of the
//! selection points' open-loop residual (CUSUM with a long-run variance from the lowest
//! periodogram ordinates: calibrated against slow wander; `changepoint`), placed mid-gap when it
//! falls between two selection blocks; temperature through a first-order lag (the model file's
//! form) with the lag of best fit; g-sensitivity when the specific force varies.
//!
//! **Test**: a term's one-step errors on the held-out points against those of the model without
//! it, both under the same wander (`diagnose::blocks::held_out_test`; see [`select`]).
//! Also not kept: a step smaller than one LSB, a temperature term whose whole effect over the
//! range seen is smaller than one LSB (the quantisation floor).
//!
//! **Steps** are tested on another split ([`step_test`]). Under a wander the one-step predictor
//! absorbs a step within seconds, so its gain lies in those few points after it: in the
//! selection blocks when the step is there, where no held-out point sees it, and a step inside a
//! held-out block is placed from the selection blocks alone, seconds off. Measured before (a
//! 150 °/h gz step, 20-min bench, seeds 1–12): kept 0 times at 700 s, 2 at 800 s. So a step is
//! placed and fitted on the 1-s points of one parity within two blocks of the candidate, and
//! scored by the one-step errors of the other parity (each predicted from every point before it,
//! the full model's wander), both ways round; the smaller z decides. The point of the other
//! parity between the two fitting points across the step places it (by the level it is nearer)
//! and is not scored. A smooth wander excursion fitted as a step makes the errors after it worse,
//! whichever half scores it. With this: 10 of 12 at 700 s, 10 at 800 s, 12 at 1200 s of 30 min,
//! and still no step on the clean benches (`tests/diagnose_whole.rs`).
//!
//! **Contiguous spans (temperature).** The temperature column is smooth on the block scale
//! (a warm-up or a ramp over minutes), and so is a slow wander (Gauss–Markov τ of minutes): a curve
//! fitted on the selection blocks through a wander excursion also predicts the interleaved held-out
//! blocks next to them, and the held-out test cannot tell: its z scores the model without the term
//! under the full model's wander, fitted after the term has taken the excursion (near white on the
//! simulated bench, τ̂ ≈ 2 s), and the guard with the smaller model's own wander (which does find
//! the slow component) passes whenever the curve fits the excursion, since a wander that tracks an
//! excursion lags it. A second, slow wander component (`docs/experiments/`) changes neither on
//! records of 5–20 min: the likelihood does not ask for it there, and a wander fitted without the
//! term follows a smooth warm-up of any size at little cost, so no test of levels on one such
//! record separates the two (docs/results-diagnose-real.md). So a temperature term that passed
//! also has to hold where it must be
//! extrapolated: the record is cut into [`FOLDS`] contiguous spans; for each, the models with and
//! without the term are fitted (OLS, every point) on the other spans, and the term must lower the
//! open-loop SSE of **every** span (a span on which either fit is not determined, e.g. a step lying
//! in it, is skipped). A real effect of temperature repeats as a function of temperature wherever
//! it is left out; a wander excursion the curve happened to follow usually does not. Steps were
//! held to the same check until the parity test replaced both for them: it compares levels on
//! spans a step does not touch, under a wander, and so refused true steps (a 0.05 °/s gz step at
//! 1200 s of a 30-min bench, found at 1200.0 s with z = 3.4: "span 2 of 5"). (g-sensitivity is not
//! span-checked: its column is the measured specific force; not tried.)

use super::blocks::{GainNoise, HeldOutTest, held_out_test};
use super::wander::{WanderFit, WanderParams, fit as wander_fit, innovations};
use crate::analysis::changepoint::{ChangePointSettings, binary_segmentation};
use nalgebra::{DMatrix, DVector};

/// A slow term.
#[derive(Clone, Debug, PartialEq)]
pub enum SlowTerm {
    /// Level change from decimated point `k` on.
    Step { k: usize },
    /// c1 ΔT + c2 ΔT², ΔT = T_lag − t0, T_lag through a first-order lag of `lag_s`.
    Temperature { lag_s: f64, t0_c: f64 },
    /// Σ k_j f_j (gyro).
    GSensitivity,
}

impl SlowTerm {
    /// Family name.
    pub fn family(&self) -> &'static str {
        match self {
            SlowTerm::Step { .. } => "bias_step",
            SlowTerm::Temperature { .. } => "temperature",
            SlowTerm::GSensitivity => "g_sensitivity",
        }
    }
}

/// First-order lag of `t` (step `dt_s`, time constant `lag_s`; 0 = none), started at t[0].
pub fn lagged(t: &[f64], dt_s: f64, lag_s: f64) -> Vec<f64> {
    if lag_s <= 0.0 || t.is_empty() {
        return t.to_vec();
    }
    let a = 1.0 - (-dt_s / lag_s).exp();
    let mut l = t[0];
    t.iter()
        .map(|v| {
            l += a * (v - l);
            l
        })
        .collect()
}

/// The decimated inputs.
pub struct SlowCtx<'a> {
    /// Decimated residual (lines removed), units.
    pub z: &'a [f64],
    /// Decimated temperature, °C.
    pub temp: Option<&'a [f64]>,
    /// Decimated specific force (gyro channels).
    pub sf: Option<[&'a [f64]; 3]>,
    /// Step, s.
    pub dt_s: f64,
    /// Per point: held out.
    pub held: &'a [bool],
    /// LSB of the channel, if quantised.
    pub lsb: Option<f64>,
    /// Points per block (selection and held-out blocks alternate).
    pub block: usize,
}

/// A fitted slow model.
#[derive(Clone, Debug)]
pub struct SlowFit {
    /// Intercept.
    pub c: f64,
    /// Coefficients in column order.
    pub beta: Vec<f64>,
    /// Wander.
    pub wander: WanderFit,
}

fn lstsq(x: &DMatrix<f64>, y: &DVector<f64>) -> Option<DVector<f64>> {
    let k = x.ncols();
    let g = x.transpose() * x;
    let d: Vec<f64> = (0..k).map(|j| g[(j, j)].max(0.0).sqrt()).collect();
    if d.contains(&0.0) {
        return None;
    }
    let gs = DMatrix::from_fn(k, k, |i, j| g[(i, j)] / (d[i] * d[j]));
    let b = x.transpose() * y;
    let bs = DVector::from_fn(k, |i, _| b[i] / d[i]);
    // Near-collinear columns (a regressor constant on the fit points) are refused.
    let ch = gs.clone().cholesky()?;
    if gs.determinant() < 1e-10 {
        return None;
    }
    let z = ch.solve(&bs);
    Some(DVector::from_fn(k, |i, _| z[i] / d[i]))
}

impl SlowCtx<'_> {
    fn block_points(&self) -> usize {
        self.block.max(1)
    }

    /// Index in β of the first column of term `i`.
    fn column_of(&self, terms: &[SlowTerm], i: usize) -> usize {
        terms[..i].iter().map(|t| self.columns(t).len()).sum()
    }

    /// Columns of a term at the decimated rate.
    pub fn columns(&self, t: &SlowTerm) -> Vec<Vec<f64>> {
        let n = self.z.len();
        match t {
            SlowTerm::Step { k } => vec![(0..n).map(|i| f64::from(u8::from(i >= *k))).collect()],
            SlowTerm::Temperature { lag_s, t0_c } => {
                let tl = lagged(self.temp.unwrap_or(&[]), self.dt_s, *lag_s);
                let d: Vec<f64> = tl.iter().map(|v| v - t0_c).collect();
                let d2 = d.iter().map(|v| v * v).collect();
                vec![d, d2]
            }
            SlowTerm::GSensitivity => self
                .sf
                .map(|f| f.iter().map(|c| c.to_vec()).collect())
                .unwrap_or_default(),
        }
    }

    fn all_columns(&self, terms: &[SlowTerm]) -> Vec<Vec<f64>> {
        terms.iter().flat_map(|t| self.columns(t)).collect()
    }

    fn fit_rows(
        &self,
        cols: &[Vec<f64>],
        rows: &[usize],
        y: &[f64],
        xc: &[Vec<f64>],
    ) -> Option<Vec<f64>> {
        let x = DMatrix::from_fn(rows.len(), cols.len() + 1, |i, j| {
            if j == 0 {
                xc[0][rows[i]]
            } else {
                xc[j][rows[i]]
            }
        });
        let yv = DVector::from_fn(rows.len(), |i, _| y[rows[i]]);
        lstsq(&x, &yv).map(|v| v.iter().copied().collect())
    }

    /// GLS of (c, β) under wander `p` on the observed rows (OLS when `p` has no wander).
    fn gls(&self, cols: &[Vec<f64>], p: &WanderParams, use_all: bool) -> Option<Vec<f64>> {
        self.gls_on(cols, p, &|k| use_all || !self.held[k])
    }

    /// [`Self::gls`] on the points where `obs`.
    fn gls_on(
        &self,
        cols: &[Vec<f64>],
        p: &WanderParams,
        obs: &dyn Fn(usize) -> bool,
    ) -> Option<Vec<f64>> {
        let n = self.z.len();
        let rows: Vec<usize> = (2..n).filter(|k| obs(*k)).collect();
        let mut xc = vec![vec![1.0; n]];
        xc.extend(cols.iter().cloned());
        if p.q == 0.0 {
            return self.fit_rows(cols, &rows, self.z, &xc);
        }
        let filt = |v: &[f64]| innovations(v, p, obs).0;
        let fx: Vec<Vec<f64>> = xc.iter().map(|c| filt(c)).collect();
        self.fit_rows(cols, &rows, &filt(self.z), &fx)
    }

    /// Fit the terms on the selection points (or on all, `use_all`, for deployment): OLS, the
    /// wander, then GLS and the wander again, twice.
    pub fn fit(&self, terms: &[SlowTerm], use_all: bool) -> Option<SlowFit> {
        let obs = |k: usize| use_all || !self.held[k];
        let cols = self.all_columns(terms);
        let coef = self.gls(&cols, &WanderParams::none(1.0), use_all)?;
        let mut f = SlowFit {
            c: coef[0],
            beta: coef[1..].to_vec(),
            wander: wander_fit(
                &self.open_loop_with(&cols, coef[0], &coef[1..]),
                self.dt_s,
                &obs,
            ),
        };
        for _ in 0..2 {
            if f.wander.best.q == 0.0 {
                break;
            }
            let Some(coef) = self.gls(&cols, &f.wander.best, use_all) else {
                break;
            };
            f.c = coef[0];
            f.beta = coef[1..].to_vec();
            f.wander = wander_fit(&self.open_loop_with(&cols, f.c, &f.beta), self.dt_s, &obs);
        }
        Some(f)
    }

    /// (c, β) of the terms by GLS under a given wander (selection points).
    pub fn fit_under(&self, terms: &[SlowTerm], wander: &WanderFit) -> Option<SlowFit> {
        let coef = self.gls(&self.all_columns(terms), &wander.best, false)?;
        Some(SlowFit {
            c: coef[0],
            beta: coef[1..].to_vec(),
            wander: *wander,
        })
    }

    fn open_loop_with(&self, cols: &[Vec<f64>], c: f64, beta: &[f64]) -> Vec<f64> {
        (0..self.z.len())
            .map(|k| self.z[k] - c - cols.iter().zip(beta).map(|(x, b)| b * x[k]).sum::<f64>())
            .collect()
    }

    /// Open-loop residual z − c − Xβ.
    pub fn open_loop(&self, terms: &[SlowTerm], f: &SlowFit) -> Vec<f64> {
        self.open_loop_with(&self.all_columns(terms), f.c, &f.beta)
    }

    /// One-step errors at every point (updates everywhere: each point predicted from its past).
    pub fn one_step(&self, terms: &[SlowTerm], f: &SlowFit, p: &WanderParams) -> Vec<f64> {
        innovations(&self.open_loop(terms, f), p, &|_| true).0
    }

    /// Candidates from the selection points' residual of the current model.
    /// Two steps within a block of each other are one.
    fn candidates(&self, terms: &[SlowTerm], f: &SlowFit) -> Vec<SlowTerm> {
        let min_gap = self.block;
        let d = self.open_loop(terms, f);
        let idx: Vec<usize> = (0..d.len()).filter(|k| !self.held[*k]).collect();
        let da: Vec<f64> = idx.iter().map(|k| d[*k]).collect();
        let mut out = Vec::new();
        let cps = ChangePointSettings {
            min_segment_s: 5.0,
            ..ChangePointSettings::default()
        };
        if let Ok(cps) = binary_segmentation(&da, 1.0 / self.dt_s, 0, &cps) {
            let mut ks: Vec<usize> = Vec::new();
            for c in cps.iter().filter(|c| c.index > 0 && c.index < idx.len()) {
                let (a, b) = (idx[c.index - 1], idx[c.index]);
                let k = if b > a + 1 { (a + 1 + b) / 2 } else { b };
                let near = |k0: usize| k0.abs_diff(k) <= min_gap;
                if !terms
                    .iter()
                    .any(|t| matches!(t, SlowTerm::Step { k: k0 } if near(*k0)))
                    && !ks.iter().any(|k0| near(*k0))
                {
                    ks.push(k);
                }
            }
            out.extend(ks.into_iter().map(|k| SlowTerm::Step { k }));
        }
        if let Some(t) = self.temp
            && !terms
                .iter()
                .any(|x| matches!(x, SlowTerm::Temperature { .. }))
        {
            let ta: Vec<f64> = idx.iter().map(|k| t[*k]).collect();
            let (lo, hi) = ta.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
                (a.0.min(*v), a.1.max(*v))
            });
            if hi - lo >= 0.2
                && let Some(t) = self.temperature_scan(&d, &idx)
            {
                out.push(t);
            }
        }
        if let Some(sf) = self.sf
            && !terms.contains(&SlowTerm::GSensitivity)
            && sf.iter().any(|c| {
                let m = idx.iter().map(|k| c[*k]).sum::<f64>() / idx.len() as f64;
                let v = idx.iter().map(|k| (c[*k] - m).powi(2)).sum::<f64>() / idx.len() as f64;
                v.sqrt() > 0.05
            })
        {
            out.push(SlowTerm::GSensitivity);
        }
        out
    }

    /// The temperature term (first-order lag of best least-squares fit, centred on the selection
    /// points' mean) for the residual `d` on the points `idx`.
    fn temperature_scan(&self, d: &[f64], idx: &[usize]) -> Option<SlowTerm> {
        let t = self.temp?;
        let mut best: Option<(f64, SlowTerm)> = None;
        for lag_s in [
            0.0, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 90.0, 120.0, 180.0, 240.0, 300.0,
        ] {
            let tl = lagged(t, self.dt_s, lag_s);
            let t0 = idx.iter().map(|k| tl[*k]).sum::<f64>() / idx.len() as f64;
            let term = SlowTerm::Temperature { lag_s, t0_c: t0 };
            let cols = self.columns(&term);
            let mut xc = vec![vec![1.0; d.len()]];
            xc.extend(cols.iter().cloned());
            let Some(coef) = self.fit_rows(&cols, idx, d, &xc) else {
                continue;
            };
            let sse: f64 = idx
                .iter()
                .map(|k| {
                    let e = d[*k] - coef[0] - coef[1] * cols[0][*k] - coef[2] * cols[1][*k];
                    e * e
                })
                .sum();
            if best.as_ref().is_none_or(|b| sse < b.0) {
                best = Some((sse, term));
            }
        }
        best.map(|b| b.1)
    }

    /// Re-scan the temperature lag of `terms[i]` with the other terms fitted (selection points).
    fn polish_temperature(&self, terms: &mut [SlowTerm], f: &SlowFit, i: usize) {
        let mut j = 0;
        for t in &terms[..i] {
            j += self.columns(t).len();
        }
        let cols = self.columns(&terms[i]);
        let mut d = self.open_loop(terms, f);
        for (ci, c) in cols.iter().enumerate() {
            for (x, v) in d.iter_mut().zip(c) {
                *x += f.beta[j + ci] * v;
            }
        }
        let idx: Vec<usize> = (0..d.len()).filter(|k| !self.held[*k]).collect();
        if let Some(t) = self.temperature_scan(&d, &idx) {
            terms[i] = t;
        }
    }

    /// Per contiguous span (the record cut into `k` equal spans): the open-loop SSE of the terms
    /// fitted (OLS, intercept and columns, every point) on the other spans; `None` where that fit
    /// is not determined (a column constant on the other spans).
    pub fn fold_sse(&self, terms: &[SlowTerm], k: usize) -> Vec<Option<f64>> {
        let n = self.z.len();
        let mut xc = vec![vec![1.0; n]];
        xc.extend(self.all_columns(terms));
        (0..k)
            .map(|f| {
                let span = f * n / k..(f + 1) * n / k;
                let rows: Vec<usize> = (0..n).filter(|i| !span.contains(i)).collect();
                let b = self.fit_rows(&xc[1..], &rows, self.z, &xc)?;
                Some(
                    span.map(|i| {
                        let e = self.z[i] - xc.iter().zip(&b).map(|(x, b)| b * x[i]).sum::<f64>();
                        e * e
                    })
                    .sum(),
                )
            })
            .collect()
    }

    /// Whole effect of a term over the selection points (max − min of its contribution).
    fn effect_range(&self, terms: &[SlowTerm], f: &SlowFit, pos: usize) -> f64 {
        let mut j = 0;
        for t in &terms[..pos] {
            j += self.columns(t).len();
        }
        let cols = self.columns(&terms[pos]);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in (0..self.z.len()).filter(|k| !self.held[*k]) {
            let v: f64 = cols
                .iter()
                .enumerate()
                .map(|(i, c)| f.beta[j + i] * c[k])
                .sum();
            lo = lo.min(v);
            hi = hi.max(v);
        }
        hi - lo
    }
}

/// Result of the selection.
pub struct SlowSelection {
    /// Terms kept, in the order added.
    pub terms: Vec<SlowTerm>,
    /// Their tests (same order).
    pub tests: Vec<HeldOutTest>,
    /// Every candidate not kept.
    pub rejected: Vec<HeldOutTest>,
    /// The model on the selection points.
    pub fit: SlowFit,
}

/// Describe a term for the report.
pub fn describe(t: &SlowTerm, dt_s: f64) -> String {
    match t {
        SlowTerm::Step { k } => format!("step at {:.1} s", *k as f64 * dt_s),
        SlowTerm::Temperature { lag_s, t0_c } => {
            format!("temperature, lag {lag_s:.0} s, about {t0_c:.2} °C")
        }
        SlowTerm::GSensitivity => "specific force x, y, z".into(),
    }
}

/// Autocovariance lags of the held-out test's noise (decimated points): the wander model is one
/// GM where a bench has several, so its innovations keep some colour over tens of seconds.
pub const HAC_LAGS: usize = 30;

/// Contiguous spans of the temperature and step check (module docs). Five: each span is a fifth of
/// the record (8 blocks at the default 40), so a wander must be extrapolated over several blocks,
/// while the term is still fitted on 80 % of the temperature range. Measured on the simulated bench
/// (`tests/diagnose_whole.rs`): 3 or 4 spans refuse true temperature terms of the late-ramp and
/// step logs (the left-out span then holds too much of the range to extrapolate); 5 and 6 keep
/// every one of them.
pub const FOLDS: usize = 5;

/// The first contiguous span (of [`FOLDS`]) on which `terms` do not lower the open-loop SSE
/// against `without`, fitted on the other spans: `(span, SSE without, SSE with)`.
fn fold_failure(
    ctx: &SlowCtx,
    without: &[SlowTerm],
    terms: &[SlowTerm],
) -> Option<(usize, f64, f64)> {
    let g0 = ctx.fold_sse(without, FOLDS);
    let g1 = ctx.fold_sse(terms, FOLDS);
    g0.iter()
        .zip(&g1)
        .enumerate()
        .find_map(|(f, (a, b))| match (a, b) {
            (Some(a), Some(b)) if b >= a => Some((f, *a, *b)),
            _ => None,
        })
}

/// Least-squares location of one mean shift of `x` within `lo..hi` (prefix sums).
pub fn locate_step(x: &[f64], lo: usize, hi: usize) -> usize {
    let m = x.len();
    let mean = x.iter().sum::<f64>() / m as f64;
    let mut cs = vec![0.0; m + 1];
    for (k, v) in x.iter().enumerate() {
        cs[k + 1] = cs[k] + v - mean;
    }
    (lo.max(1)..hi.min(m - 1).max(lo.max(1) + 1))
        .max_by(|&a, &b| {
            let st = |k: usize| cs[k] * cs[k] / (k as f64 * (m - k) as f64);
            st(a).total_cmp(&st(b))
        })
        .unwrap_or(lo)
}

/// The step's test (module docs, "Steps"): the 1-s points split by parity, so that wherever the
/// step lies its signature in the one-step errors falls on both halves. On the even points the
/// step is placed (least squares within two blocks of the selection's place, `k`) and, with the
/// other terms, fitted (GLS under the full model's wander); it is scored by the one-step errors
/// of the odd points, predicted from every point before them, with and without it. The
/// quantisation floor applied.
fn step_test(
    ctx: &SlowCtx,
    terms: &[SlowTerm],
    full: &SlowFit,
    i: usize,
    k: usize,
    level: f64,
) -> HeldOutTest {
    let half = |par| step_test_half(ctx, (terms, i, k), full, level, par);
    let (a, b) = (half(0), half(1));
    if a.z <= b.z { a } else { b }
}

/// One half of [`step_test`]: step `k` (term `i` of `terms`) placed and fitted on the points of
/// parity `par`, scored on the others.
fn step_test_half(
    ctx: &SlowCtx,
    (terms, i, k): (&[SlowTerm], usize, usize),
    full: &SlowFit,
    level: f64,
    par: usize,
) -> HeldOutTest {
    let n = ctx.z.len();
    let fits = |j: usize| j % 2 == par;
    let p = full.wander.best;
    let mut without = terms.to_vec();
    without.remove(i);
    // The residual of a model fitted on the fitting half (every point).
    let residual = |ts: &[SlowTerm]| -> Option<(Vec<f64>, Vec<f64>)> {
        let cols = ctx.all_columns(ts);
        let c = ctx.gls_on(&cols, &p, &fits)?;
        Some((ctx.open_loop_with(&cols, c[0], &c[1..]), c[1..].to_vec()))
    };
    let refused = |why: &str| HeldOutTest {
        family: terms[i].family().into(),
        description: describe(&terms[i], ctx.dt_s),
        n: 0,
        mse_before: 0.0,
        mse_after: 0.0,
        share_removed: 0.0,
        z: 0.0,
        p_value: 1.0,
        level,
        kept: false,
        reason: why.into(),
    };
    let Some((d0, _)) = residual(&without) else {
        return refused("the model without the step is not determined on the fitting half");
    };
    // Place the step on the fitting half's points of the residual without it.
    let w = 2 * ctx.block_points();
    let (lo, hi) = (k.saturating_sub(w), (k + w).min(n));
    let ev: Vec<usize> = (lo..hi).filter(|j| fits(*j)).collect();
    let x: Vec<f64> = ev.iter().map(|j| d0[*j]).collect();
    let m = x.len();
    if m < 4 {
        return refused("too few points around the step");
    }
    let q = locate_step(&x, 1, m);
    // The other half's point between the last fit point before and the first after places the
    // step (by the level it is nearer) and is not scored: it says where, not whether.
    let mid = ev[q] - 1;
    let lb = x[..q].iter().sum::<f64>() / q as f64;
    let la = x[q..].iter().sum::<f64>() / (m - q) as f64;
    let at = if (d0[mid] - la).abs() < (d0[mid] - lb).abs() {
        mid
    } else {
        ev[q]
    };
    let mut with = terms.to_vec();
    with[i] = SlowTerm::Step { k: at };
    let Some((d1, b1)) = residual(&with) else {
        return refused("the model with the step is not determined on the fitting half");
    };
    let e0 = innovations(&d0, &p, &|_| true).0;
    let e1 = innovations(&d1, &p, &|_| true).0;
    let mut t = held_out_test(
        terms[i].family(),
        describe(&with[i], ctx.dt_s),
        &e0,
        &e1,
        |j| !fits(j) && j != mid,
        level,
        GainNoise {
            min_var: 0.0,
            hac_lags: HAC_LAGS,
        },
    );
    if t.kept
        && let Some(lsb) = ctx.lsb
    {
        let size = b1[ctx.column_of(&with, i)].abs();
        if size < lsb {
            t.kept = false;
            t.reason = format!("below the quantisation: {size:.3e} < 1 LSB ({lsb:.3e})");
        }
    }
    t
}

/// The held-out test of term `i` of `terms` under the full model `full` (module docs); the
/// quantisation floor applied.
fn test_term(
    ctx: &SlowCtx,
    terms: &[SlowTerm],
    full: &SlowFit,
    i: usize,
    level: f64,
) -> Option<HeldOutTest> {
    let mut without = terms.to_vec();
    without.remove(i);
    // H0 under the full model's wander (GLS: the term judged by its coefficient, so a step is
    // not scored only by the transient of a wander inflated to absorb it) ...
    let f0 = ctx.fit_under(&without, &full.wander)?;
    if let SlowTerm::Step { k } = terms[i] {
        return Some(step_test(ctx, terms, full, i, k, level));
    }
    let e0 = ctx.one_step(&without, &f0, &full.wander.best);
    // ... and, as a guard, the two models each with its own wander fitted: the term must not
    // worsen held-out error then either (measured: without this guard a warm-up was credited
    // with Gauss-Markov wander on 4 of 300 clean 5-min channels).
    let own = ctx.fit(&without, false)?;
    let e0_own = ctx.one_step(&without, &own, &own.wander.best);
    let e1 = ctx.one_step(terms, full, &full.wander.best);
    let mut t = held_out_test(
        terms[i].family(),
        describe(&terms[i], ctx.dt_s),
        &e0,
        &e1,
        |k| ctx.held[k],
        level,
        GainNoise {
            min_var: 0.0,
            hac_lags: HAC_LAGS,
        },
    );
    if t.kept {
        let (mut g0, mut g1) = (0.0, 0.0);
        for k in (0..e1.len()).filter(|k| ctx.held[*k]) {
            g0 += e0_own[k] * e0_own[k];
            g1 += e1[k] * e1[k];
        }
        if g1 >= g0 {
            t.kept = false;
            t.reason = format!(
                "worsens held-out error against the model without it fitted with its own wander (MSE {:.4e} → {:.4e})",
                g0 / t.n.max(1) as f64,
                g1 / t.n.max(1) as f64
            );
        }
    }
    if t.kept
        && matches!(terms[i], SlowTerm::Temperature { .. })
        && let Some((f, a, b)) = fold_failure(ctx, &without, terms)
    {
        t.kept = false;
        t.reason = format!(
            "does not hold where extrapolated: fitted on the other spans, it does not lower the SSE of span {} of {FOLDS} ({a:.4e} → {b:.4e})",
            f + 1
        );
    }
    if t.kept
        && let Some(q) = ctx.lsb
        && !matches!(terms[i], SlowTerm::GSensitivity)
    {
        let size = ctx.effect_range(terms, full, i);
        if size < q {
            t.kept = false;
            t.reason = format!("below the quantisation: {size:.3e} < 1 LSB ({q:.3e})");
        }
    }
    Some(t)
}

/// Selection (module docs): every candidate of a round goes into the model at once; then
/// backward elimination — each term is tested against the model without it, each model with
/// its own wander fitted on the selection points, and the weakest failing term is dropped, until every term passes at α / terms. Candidates that confound each other (a
/// warm-up and a step fitted in its place) are so judged together. A new round proposes
/// candidates on what the survivors leave; at most `max_terms` terms, three rounds.
pub fn select(ctx: &SlowCtx, alpha: f64, max_terms: usize) -> Option<SlowSelection> {
    let mut terms: Vec<SlowTerm> = Vec::new();
    let mut fit = ctx.fit(&terms, false)?;
    let mut tests: Vec<HeldOutTest> = Vec::new();
    let mut rejected: Vec<HeldOutTest> = Vec::new();
    for _ in 0..3 {
        let cands = ctx.candidates(&terms, &fit);
        if cands.is_empty() {
            break;
        }
        let n_old = terms.len();
        let mut full = terms.clone();
        full.extend(cands);
        full.truncate(max_terms.max(n_old));
        loop {
            let Some(f) = ctx.fit(&full, false) else {
                // Collinear: drop the newest.
                full.pop();
                if full.len() <= n_old {
                    break;
                }
                continue;
            };
            let level = alpha / full.len().max(1) as f64;
            let ts: Vec<Option<HeldOutTest>> = (0..full.len())
                .map(|i| test_term(ctx, &full, &f, i, level))
                .collect();
            let worst = ts
                .iter()
                .enumerate()
                .filter(|(_, t)| t.as_ref().is_none_or(|t| !t.kept))
                .min_by(|a, b| {
                    let z = |t: &Option<HeldOutTest>| t.as_ref().map_or(f64::NEG_INFINITY, |t| t.z);
                    z(a.1).total_cmp(&z(b.1))
                })
                .map(|(i, _)| i);
            match worst {
                Some(i) => {
                    if let Some(t) = ts[i].clone() {
                        rejected.push(t);
                    }
                    full.remove(i);
                    if full.is_empty() {
                        fit = ctx.fit(&full, false)?;
                        tests.clear();
                        break;
                    }
                }
                None => {
                    fit = f;
                    tests = ts.into_iter().flatten().collect();
                    break;
                }
            }
        }
        if let Some(i) = full
            .iter()
            .position(|t| matches!(t, SlowTerm::Temperature { .. }))
        {
            let before = full[i].clone();
            ctx.polish_temperature(&mut full, &fit, i);
            if full[i] != before {
                tests.clear();
            }
        }
        // Retest after a polish (or a collinear drop); a term that no longer passes goes, the
        // weakest first, so the model never carries a failed test.
        while tests.len() != full.len() || tests.iter().any(|t| !t.kept) {
            if tests.len() == full.len() {
                let worst = (0..tests.len())
                    .filter(|i| !tests[*i].kept)
                    .min_by(|a, b| tests[*a].z.total_cmp(&tests[*b].z))
                    .unwrap_or(0);
                rejected.push(tests[worst].clone());
                full.remove(worst);
            }
            fit = ctx.fit(&full, false)?;
            let level = alpha / full.len().max(1) as f64;
            let ts: Vec<Option<HeldOutTest>> = (0..full.len())
                .map(|i| test_term(ctx, &full, &fit, i, level))
                .collect();
            if let Some(i) = ts.iter().position(Option::is_none) {
                // Not testable (a fit not determined): dropped like a failed term.
                full.remove(i);
                tests.clear();
                if full.is_empty() {
                    fit = ctx.fit(&full, false)?;
                    break;
                }
                continue;
            }
            tests = ts.into_iter().flatten().collect();
        }
        let grew = full.len() > n_old || full.iter().zip(&terms).any(|(a, b)| a != b);
        terms = full;
        if terms.is_empty() {
            fit = ctx.fit(&terms, false)?;
        }
        if !grew {
            break;
        }
    }
    // Report each rejected candidate once (its last test), and none that was kept in the end.
    let mut seen = std::collections::HashSet::new();
    rejected.reverse();
    rejected.retain(|r| seen.insert(r.description.clone()));
    rejected.retain(|r| !tests.iter().any(|t| t.description == r.description));
    Some(SlowSelection {
        terms,
        tests,
        rejected,
        fit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A 300-s warm-up (the simulated bench's: 22.5 °C + 6 °C, τ = 240 s) at 1-s steps, every
    /// other 10-s block held out.
    fn ctx_on<'a>(z: &'a [f64], temp: &'a [f64], held: &'a [bool]) -> SlowCtx<'a> {
        SlowCtx {
            z,
            temp: Some(temp),
            sf: None,
            dt_s: 1.0,
            held,
            lsb: None,
            block: 10,
        }
    }

    #[test]
    fn temperature_terms_and_steps_must_hold_on_every_contiguous_span() {
        let n = 300;
        let temp: Vec<f64> = (0..n)
            .map(|k| 22.5 + 6.0 * (1.0 - (-(k as f64) / 240.0).exp()))
            .collect();
        let held: Vec<bool> = (0..n).map(|k| (k / 10) % 2 == 1).collect();
        let term = [SlowTerm::Temperature {
            lag_s: 0.0,
            t0_c: 25.0,
        }];
        let mut rng = Rng::new(7);
        let noise: Vec<f64> = (0..n).map(|_| 0.1 * rng.normal()).collect();
        // A real effect, 0.5 units/°C (3 units over the warm-up, 30× the noise): it lowers the
        // SSE of every span when fitted on the others.
        let real: Vec<f64> = (0..n).map(|k| 0.5 * (temp[k] - 25.0) + noise[k]).collect();
        assert_eq!(fold_failure(&ctx_on(&real, &temp, &held), &[], &term), None);
        // A wander of the same size that is no function of temperature (two slow swings over
        // the record): a quadratic in T fitted on four spans does not predict the fifth.
        let wander: Vec<f64> = (0..n)
            .map(|k| 1.5 * (2.0 * std::f64::consts::PI * k as f64 / 150.0).sin() + noise[k])
            .collect();
        assert!(fold_failure(&ctx_on(&wander, &temp, &held), &[], &term).is_some());
        // A step of 10× the noise at 100 s holds on every span; the same wander fitted as a step
        // at its first zero crossing (75 s) does not (span 3 of 5, where the wander is back up:
        // in a numpy check of this shape its SSE 53 → 61 with the step; the noise's SSE on a
        // span is 0.6, so the margin is not the noise's).
        let step = [SlowTerm::Step { k: 100 }];
        let real: Vec<f64> = (0..n)
            .map(|k| if k >= 100 { 1.0 } else { 0.0 } + noise[k])
            .collect();
        assert_eq!(fold_failure(&ctx_on(&real, &temp, &held), &[], &step), None);
        let step = [SlowTerm::Step { k: 75 }];
        assert!(fold_failure(&ctx_on(&wander, &temp, &held), &[], &step).is_some());
    }
}
