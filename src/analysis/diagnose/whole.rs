//! `diagnose` over the whole recording, one model (issue 17): lines, slow effects and wander
//! chosen on the selection blocks, scored on the held-out blocks that interleave with them
//! (`diagnose::blocks`), then refitted on the whole log for the model file.
//!
//! Order, per channel:
//! 1. **Lines** (`diagnose::lines`): candidates from the selection blocks' averaged spectrum; each
//!    tracked block by block, scored on held-out blocks by its prediction from the neighbouring
//!    selection blocks (open-loop error at the full rate; its noise is the local level near the
//!    line).
//! 2. **Slow effects** (`diagnose::slow`) on 1-s means of what the lines leave: steps,
//!    temperature, g-sensitivity, all candidates in then backward elimination, with a GM/RW wander
//!    as the stochastic part
//!    (one-step errors of the decimated series on held-out points).
//! 3. **Wander** (`diagnose::wander`): Gauss–Markov, random walk or undecided; a random walk that
//!    passes the held-out test (wander predictor vs none) is written as the rate-random-walk
//!    effect; a Gauss–Markov wander that passes it is written as the channel's bias process
//!    (`ar_of = "bias"`: AR(1) with φ = e^{−1/(τ fs)}, stationary σ², the rest of the residual's
//!    variance as white noise), so the online filter tracks the wander it was shown (on the
//!    ADIS16405 bench the gyro outputs' Allan deviation falls to 0.48–0.89 of the model-less
//!    one at τ = 41–2621 s, docs/results-diagnose-real.md).
//! 4. **AR(p)** of the full-rate residual on the selection blocks (Burg, every order in one pass,
//!    AIC), for the one-step held-out error before/after and the model file.
//! 5. **Deployment**: the chosen structure refitted on every block (a step's time re-located at
//!    the full rate within a block of its selection-part place; each line's frequency and
//!    amplitude the medians of the blocks where it is present). The held-out numbers never see
//!    this refit.
//!
//! Cost: a handful of passes over the full-rate series (FFTs of the selection blocks, 10 phasor
//! passes per candidate line and one AR lattice) and everything slow on the decimated series.

use super::blocks::{Blocks, GainNoise, HeldOutTest, held_out_test, step_means};
use super::lines::{BlockLine, contribution, contribution_in_sample, line_candidates, track};
use super::paper_split::ChannelInput;
use super::result::{DeploymentFit, ResidualPlots};
use super::slow::{SlowCtx, SlowTerm, lagged, locate_step, select};
use super::wander::{WanderKind, WanderParams, classify, innovations};
use crate::analysis::AnalysisError;
use crate::analysis::quantisation::{Quantisation, quantisation};
use crate::model::bias_model::{Effect, TemperatureTerm};
use crate::model::{ArFit, burg, burg_orders};
use crate::stats::check_series;
use crate::stats::robust::upper_median;
use serde::Serialize;

/// Settings of the whole-log diagnosis.
#[derive(Clone, Debug)]
pub struct WholeSettings {
    /// Significance level of each round (Bonferroni over its candidates).
    pub alpha: f64,
    /// Blocks aimed at.
    pub blocks_target: usize,
    /// Shortest and longest block, s.
    pub block_s: (f64, f64),
    /// Decimation step of the slow analyses, s.
    pub dec_s: f64,
    /// Largest AR order.
    pub max_ar_order: usize,
    /// Most line candidates.
    pub max_lines: usize,
    /// Most slow effects.
    pub max_slow_terms: usize,
}

impl Default for WholeSettings {
    fn default() -> Self {
        WholeSettings {
            alpha: 0.001,
            blocks_target: 40,
            block_s: (10.0, 120.0),
            dec_s: 1.0,
            max_ar_order: 20,
            max_lines: 3,
            max_slow_terms: 6,
        }
    }
}

/// Evidence of a rail: many samples at an extreme, more than on the code next to it.
#[derive(Clone, Debug, Serialize)]
pub struct Rail {
    pub max: f64,
    pub min: f64,
    pub at_max: usize,
    pub at_min: usize,
    /// Samples one LSB inside each extreme (quantised channels).
    pub next_to_max: usize,
    pub next_to_min: usize,
    pub railed_high: bool,
    pub railed_low: bool,
}

/// A rail needs at least `max(10, n/10⁵)` samples at the extreme and, on a quantised channel,
/// twice as many as on the next code inside (a Gaussian tail has fewer at the extreme than next
/// to it; a clipped one piles up there).
pub fn rail(x: &[f64], lsb: Option<f64>) -> Rail {
    let max = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = x.iter().copied().fold(f64::INFINITY, f64::min);
    let count = |v: f64, tol: f64| x.iter().filter(|s| (**s - v).abs() <= tol).count();
    let at_max = x.iter().filter(|v| **v == max).count();
    let at_min = x.iter().filter(|v| **v == min).count();
    let (next_to_max, next_to_min) = match lsb {
        Some(q) => (count(max - q, 0.25 * q), count(min + q, 0.25 * q)),
        None => (0, 0),
    };
    let need = 10.max(x.len() / 100_000);
    Rail {
        max,
        min,
        at_max,
        at_min,
        next_to_max,
        next_to_min,
        railed_high: at_max >= need && at_max >= 2 * next_to_max,
        railed_low: at_min >= need && at_min >= 2 * next_to_min,
    }
}

/// One effect in the model, with where it acts and its held-out test.
#[derive(Clone, Debug, Serialize)]
pub struct FoundEffect {
    /// As written to the model file (deployment refit).
    pub effect: Effect,
    /// Where it acts, s from the start of the log.
    pub span_s: [f64; 2],
    /// The held-out test it passed.
    pub test: HeldOutTest,
    /// Lines: the track, one point per block.
    pub track: Vec<BlockLine>,
}

/// The wander finding.
#[derive(Clone, Debug, Serialize)]
pub struct WanderReport {
    pub kind: WanderKind,
    /// Best finite correlation time, s.
    pub tau_s: f64,
    /// GM standard deviation of the 1-s means (units).
    pub gm_sigma: f64,
    /// Random-walk intensity, units²/s.
    pub rw_q_per_s: f64,
    /// 2(ℓ_GM − ℓ_RW).
    pub lr_gm_vs_rw: f64,
    /// Wander predictor vs none on held-out points.
    pub test: HeldOutTest,
    /// Written to the model file (module docs, step 3), having passed the held-out test.
    pub written: bool,
    /// Variance of the full-rate deployment residual about its level (units²).
    pub residual_var: f64,
}

impl WanderReport {
    /// A written Gauss–Markov wander as the model file's bias process at `fs`:
    /// `(ar, innovation_var, white_noise_var)` of `ar_of = "bias"`.
    pub fn bias_process(&self, fs: f64) -> Option<(Vec<f64>, f64, f64)> {
        (self.written && self.kind == WanderKind::GaussMarkov).then(|| {
            let phi = (-1.0 / (self.tau_s * fs)).exp();
            let var = self.gm_sigma * self.gm_sigma;
            // The white part: what the residual holds beyond the wander, floored at a tenth of
            // the residual (the 1-s means' σ is a different estimate of the same level).
            let white = (self.residual_var - var).max(0.1 * self.residual_var);
            (vec![phi], var * (1.0 - phi * phi), white)
        })
    }
}

/// Held-out errors before (intercept, or AR on it) and after (every kept effect).
#[derive(Clone, Debug, Serialize)]
pub struct HeldOutErrors {
    pub samples: usize,
    pub open_loop_before: f64,
    pub open_loop_after: f64,
    pub ar_order_before: usize,
    pub ar_order_after: usize,
    pub one_step_before: f64,
    pub one_step_after: f64,
}

/// The whole-log diagnosis of one channel.
#[derive(Clone, Debug, Serialize)]
pub struct WholeDiagnosis {
    pub channel: String,
    pub sample_rate_hz: f64,
    pub n: usize,
    pub blocks: Blocks,
    pub quantisation: Option<Quantisation>,
    pub rail: Rail,
    /// Kept effects (lines first, then slow effects in the order added).
    pub effects: Vec<FoundEffect>,
    /// Candidates not kept, with why.
    pub rejected: Vec<HeldOutTest>,
    pub wander: Option<WanderReport>,
    pub held_out: HeldOutErrors,
    /// Deployment refit: intercept, AR, innovation variance.
    #[serde(flatten)]
    pub refit: DeploymentFit,
    /// Welch spectra (first, final) of the open-loop residual and its Allan deviation (1-s means).
    #[serde(skip)]
    pub plots: ResidualPlots,
}

/// AR(p) of `x` with p by AIC over 1..=max (one Burg lattice).
fn ar_aic(x: &[f64], max: usize) -> Result<ArFit, AnalysisError> {
    let fits = burg_orders(x, max)?;
    let n = x.len() as f64;
    fits.into_iter()
        .min_by(|a, b| {
            let aic = |f: &ArFit| n * f.noise_var.max(1e-300).ln() + 2.0 * f.order() as f64;
            aic(a).total_cmp(&aic(b))
        })
        .ok_or_else(|| AnalysisError::singular("no AR fit"))
}

/// One-step AR error of `x` (mean `ar.mean`) at sample `i`.
fn ar_innovation(x: &[f64], ar: &ArFit, i: usize) -> f64 {
    let p = ar.coeffs.len();
    let m = ar.mean;
    let mut pred = m;
    for (j, phi) in ar.coeffs.iter().enumerate().take(i.min(p)) {
        pred += phi * (x[i - 1 - j] - m);
    }
    x[i] - pred
}

/// Mean squared one-step AR error of `x` over the held-out blocks (no full-length copy).
fn held_out_ar_mse(blocks: &Blocks, x: &[f64], ar: &ArFit) -> f64 {
    blocks.held_out_mse_of(|i| ar_innovation(x, ar, i))
}

/// Subtract `beta ·` the full-rate columns of a slow term (step at full-rate index `at`) from
/// `r` in place; returns the number of columns. Only a lagged temperature allocates (its lag).
fn subtract_term(
    r: &mut [f64],
    t: &SlowTerm,
    at: usize,
    input: &ChannelInput,
    beta: &[f64],
) -> usize {
    match t {
        SlowTerm::Step { .. } => {
            for (i, o) in r.iter_mut().enumerate() {
                *o -= beta[0] * f64::from(u8::from(i >= at));
            }
            1
        }
        SlowTerm::Temperature { lag_s, t0_c } => {
            let tl = lagged(
                input.exogenous.temperature_c.unwrap_or(&[]),
                1.0 / input.rate_hz,
                *lag_s,
            );
            let (b1, b2) = (beta[0], beta[1]);
            for (o, v) in r.iter_mut().zip(&tl) {
                *o -= b1 * (v - t0_c);
            }
            for (o, v) in r.iter_mut().zip(&tl) {
                let d = v - t0_c;
                *o -= b2 * (d * d);
            }
            2
        }
        SlowTerm::GSensitivity => match input.exogenous.specific_force_m_s2 {
            Some(f) => {
                for (c, col) in f.iter().enumerate() {
                    for (o, v) in r.iter_mut().zip(col.iter()) {
                        *o -= beta[c] * v;
                    }
                }
                3
            }
            None => 0,
        },
    }
}

/// Diagnose one channel over the whole log; `progress` gets a word per stage.
pub fn diagnose_whole(
    input: &ChannelInput,
    s: &WholeSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<WholeDiagnosis, AnalysisError> {
    let y = input.values;
    let fs = input.rate_hz;
    check_series(y, 1)?;
    if !crate::analysis::is_pos(fs) || !crate::analysis::in_open_unit(s.alpha) {
        return Err(AnalysisError::bad("rate_hz > 0 and alpha in (0, 1)"));
    }
    let n = y.len();
    let exo = &input.exogenous;
    if let Some(t) = exo.temperature_c {
        check_series(t, n)?;
    }
    if let Some(f) = exo.specific_force_m_s2 {
        for c in f {
            check_series(c, n)?;
        }
    }
    let blocks = Blocks::new(n, fs, s.dec_s, s.blocks_target, s.block_s)?;
    let held_sample = |i: usize| Blocks::held_out(blocks.block_of(i));
    progress("quantisation");
    let q = quantisation(y).ok();
    let lsb = q.as_ref().and_then(|q| q.lsb);
    let rail = rail(y, lsb);
    let sel = blocks.selection(y);
    let c_a = sel.iter().sum::<f64>() / sel.len() as f64;
    let base: Vec<f64> = y.iter().map(|v| v - c_a).collect();
    // What the model is scored against, taken now so that `base` can become the working series
    // (memory: a handful of full-length series at most are alive at once).
    let ar0 = ar_aic(&blocks.selection(&base), s.max_ar_order)?;
    let one_step_before = held_out_ar_mse(&blocks, &base, &ar0);
    let open_loop_before = blocks.held_out_mse(&base);
    let dec = blocks.dec;
    let dt = dec as f64 / fs;
    let seg = (n / 64).clamp(256, 8192);
    let spectrum_before = crate::analysis::spectrum::welch(&base, fs, seg).ok();
    let allan_before = crate::analysis::allan::oadev_octaves(&step_means(&base, dec), 1.0 / dt);
    // 1. Lines.
    progress("lines");
    // The kept lines' in-sample fit, allocated with the first kept line.
    let mut line_dep: Option<Vec<f64>> = None;
    let mut effects: Vec<FoundEffect> = Vec::new();
    let mut rejected: Vec<HeldOutTest> = Vec::new();
    let cands = line_candidates(&base, &blocks, fs, s.alpha, s.max_lines);
    let mut d_sel = base;
    let level = s.alpha / cands.len().max(1) as f64;
    for c in &cands {
        let tr = track(&d_sel, &blocks, fs, c, s.alpha);
        let mut e1 = contribution(&tr, &blocks, fs);
        for (o, a) in e1.iter_mut().zip(&d_sel) {
            *o = a - *o;
        }
        let desc = format!("line near {:.4} Hz", c.freq_hz);
        let t = held_out_test(
            "vibration_line",
            desc,
            &d_sel,
            &e1,
            held_sample,
            level,
            GainNoise {
                min_var: c.noise_var,
                hac_lags: 0,
            },
        );
        if !t.kept {
            rejected.push(t);
            continue;
        }
        let present: Vec<&BlockLine> = tr.iter().filter(|b| b.present).collect();
        if present.is_empty() {
            let mut t = t;
            t.kept = false;
            t.reason = "significant on average but present in no single block".into();
            rejected.push(t);
            continue;
        }
        let med = |mut v: Vec<f64>| upper_median(&mut v);
        let f = med(present.iter().map(|b| b.freq_hz).collect());
        let a = med(present.iter().map(|b| b.amplitude).collect());
        let first = present[0];
        let half = blocks.len as f64 / fs / 2.0;
        let span = [first.t_s - half, present[present.len() - 1].t_s + half];
        d_sel = e1;
        let dep = contribution_in_sample(&tr, &blocks, fs);
        match line_dep.as_mut() {
            Some(l) => {
                for (o, v) in l.iter_mut().zip(&dep) {
                    *o += v;
                }
            }
            // `0.0 + v` as the sum into zeros gave (−0 becomes +0).
            None => line_dep = Some(dep.into_iter().map(|v| 0.0 + v).collect()),
        }
        // Phase: the first present block's (it only seeds the online canceller, which tracks
        // the phase of a drifting line).
        let phase = first.phase_rad;
        effects.push(FoundEffect {
            effect: Effect::VibrationLine {
                freq_hz: f,
                amplitude: a,
                phase_rad: phase,
            },
            span_s: span,
            test: t,
            track: tr,
        });
    }
    // 2. Slow effects on 1-s means.
    progress("slow effects");
    let mut y_sel = d_sel;
    for v in &mut y_sel {
        *v += c_a;
    }
    let z = step_means(&y_sel, dec);
    let zt = exo.temperature_c.map(|t| step_means(t, dec));
    let zf = exo
        .specific_force_m_s2
        .map(|f| f.map(|c| step_means(c, dec)));
    let held = blocks.dec_held_out();
    let ctx = SlowCtx {
        z: &z,
        temp: zt.as_deref(),
        sf: zf
            .as_ref()
            .map(|f| [f[0].as_slice(), f[1].as_slice(), f[2].as_slice()]),
        dt_s: dt,
        held: &held,
        lsb,
        block: blocks.len / dec,
    };
    let slow = select(&ctx, s.alpha, s.max_slow_terms)
        .ok_or_else(|| AnalysisError::singular("slow model"))?;
    rejected.extend(slow.rejected.iter().cloned());
    // 3. Wander of what the slow model leaves.
    progress("wander");
    let t_rec = n as f64 / fs;
    let wf = slow.fit.wander;
    let wander = (wf.best.q > 0.0).then(|| {
        let d = ctx.open_loop(&slow.terms, &slow.fit);
        let e0 = innovations(&d, &WanderParams::none(wf.best.r), &|_| true).0;
        let e1 = innovations(&d, &wf.best, &|_| true).0;
        let kind = classify(&wf, t_rec);
        let test = held_out_test(
            "wander",
            format!("{kind:?}"),
            &e0,
            &e1,
            |k| held[k],
            s.alpha,
            GainNoise {
                min_var: 0.0,
                hac_lags: super::slow::HAC_LAGS,
            },
        );
        let gm = wf.gm;
        WanderReport {
            kind,
            tau_s: wf.gm_tau_s,
            gm_sigma: (gm.q / (1.0 - gm.phi * gm.phi).max(1e-12)).sqrt(),
            rw_q_per_s: wf.rw.q / dt,
            lr_gm_vs_rw: 2.0 * (wf.ll_gm - wf.ll_rw),
            written: kind != WanderKind::Undecided && test.kept,
            test,
            residual_var: 0.0,
        }
    });
    // 4. Full-rate residual of the selection model; AR before/after.
    progress("AR");
    let mut r_sel = y_sel;
    let mut j = 0;
    let mut at: Vec<usize> = Vec::new();
    for t in &slow.terms {
        let a = if let SlowTerm::Step { k } = t {
            k * dec
        } else {
            0
        };
        at.push(a);
        j += subtract_term(&mut r_sel, t, a, input, &slow.fit.beta[j..]);
    }
    // The intercept of the open-loop residual: its selection-block mean (the GLS intercept
    // under a wander is another estimate of the level; the open-loop error wants the mean).
    let c_sel = {
        let v = blocks.selection(&r_sel);
        v.iter().sum::<f64>() / v.len() as f64
    };
    for v in &mut r_sel {
        *v -= c_sel;
    }
    let ar1 = ar_aic(&blocks.selection(&r_sel), s.max_ar_order)?;
    let held_out = HeldOutErrors {
        samples: (0..blocks.count)
            .filter(|b| Blocks::held_out(*b))
            .map(|b| blocks.range(b).len())
            .sum(),
        open_loop_before,
        open_loop_after: blocks.held_out_mse(&r_sel),
        ar_order_before: ar0.order(),
        ar_order_after: ar1.order(),
        one_step_before,
        one_step_after: held_out_ar_mse(&blocks, &r_sel, &ar1),
    };
    drop(r_sel);
    // 5. Deployment refit on every block.
    progress("refit");
    let y_dep = match line_dep {
        Some(mut l) => {
            for (o, a) in l.iter_mut().zip(y) {
                *o = a - *o;
            }
            l
        }
        None => y.iter().map(|a| a - 0.0).collect(),
    };
    let mut terms = slow.terms.clone();
    let mut dep = ctx_all_fit(&ctx, &terms)?;
    for (ti, t) in slow.terms.iter().enumerate() {
        if let SlowTerm::Step { k } = t {
            // Re-locate at the full rate within a block of the selection-part place, on the
            // residual of the other terms.
            let others: Vec<SlowTerm> = terms
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != ti)
                .map(|(_, t)| t.clone())
                .collect();
            let fo = ctx_all_fit(&ctx, &others)?;
            let mut r = y_dep.clone();
            let mut jj = 0;
            for (oi, o) in others.iter().enumerate() {
                let oa = if let SlowTerm::Step { .. } = o {
                    at[if oi < ti { oi } else { oi + 1 }]
                } else {
                    0
                };
                jj += subtract_term(&mut r, o, oa, input, &fo.beta[jj..]);
            }
            let w = 2 * blocks.len;
            let (lo, hi) = ((k * dec).saturating_sub(w), (k * dec + w).min(n));
            let seg = &r[lo..hi];
            let loc = locate_step(
                seg,
                (k * dec).saturating_sub(lo).saturating_sub(blocks.len),
                (k * dec - lo) + blocks.len,
            );
            at[ti] = lo + loc;
            terms[ti] = SlowTerm::Step {
                k: (lo + loc).div_ceil(dec),
            };
        }
    }
    if terms != slow.terms {
        dep = ctx_all_fit(&ctx, &terms)?;
    }
    let mut r_dep = y_dep;
    let mut jj = 0;
    for (ti, t) in terms.iter().enumerate() {
        let ncols = subtract_term(&mut r_dep, t, at[ti], input, &dep.beta[jj..]);
        let b = &dep.beta[jj..jj + ncols];
        let effect = match t {
            SlowTerm::Step { .. } => Effect::Step {
                t_s: at[ti] as f64 / fs,
                size: b[0],
            },
            SlowTerm::Temperature { lag_s, t0_c } => Effect::Temperature(TemperatureTerm {
                t0_c: *t0_c,
                c1_per_c: b[0],
                c2_per_c2: b[1],
                lag_s: *lag_s,
            }),
            SlowTerm::GSensitivity => Effect::GSensitivity {
                coeffs_per_m_s2: [b[0], b[1], b[2]],
            },
        };
        let span_s = match t {
            SlowTerm::Step { .. } => [at[ti] as f64 / fs, t_rec],
            _ => [0.0, t_rec],
        };
        effects.push(FoundEffect {
            effect,
            span_s,
            test: slow.tests[ti].clone(),
            track: vec![],
        });
        jj += ncols;
    }
    if let Some(w) = &wander
        && w.written
        && w.kind == WanderKind::RandomWalk
    {
        effects.push(FoundEffect {
            effect: Effect::RateRandomWalk {
                q_per_s: w.rw_q_per_s,
            },
            span_s: [0.0, t_rec],
            test: w.test.clone(),
            track: vec![],
        });
    }
    for v in &mut r_dep {
        *v -= dep.c;
    }
    let mut wander = wander;
    if let Some(w) = wander.as_mut() {
        w.residual_var = r_dep.iter().map(|v| v * v).sum::<f64>() / n as f64;
    }
    let ar_dep = burg(&r_dep, ar1.order().max(1))?;
    progress("plots");
    let plots = ResidualPlots {
        spectrum_before,
        spectrum_after: crate::analysis::spectrum::welch(&r_dep, fs, seg).ok(),
        allan_before,
        allan_after: crate::analysis::allan::oadev_octaves(&step_means(&r_dep, dec), 1.0 / dt),
    };
    Ok(WholeDiagnosis {
        channel: input.name.into(),
        sample_rate_hz: fs,
        n,
        blocks,
        quantisation: q,
        rail,
        effects,
        rejected,
        wander,
        held_out,
        refit: DeploymentFit {
            intercept: dep.c,
            ar: ar_dep.coeffs.clone(),
            innovation_var: ar_dep.noise_var,
        },
        plots,
    })
}

fn ctx_all_fit(ctx: &SlowCtx, terms: &[SlowTerm]) -> Result<super::slow::SlowFit, AnalysisError> {
    ctx.fit(terms, true)
        .ok_or_else(|| AnalysisError::singular("slow model refit on the whole log"))
}
