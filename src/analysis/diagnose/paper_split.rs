//! Close the loop: find the residual's structure, trace it to an effect the model lacks, add it,
//! refit, repeat until nothing passes a significance test (issue 6).
//!
//! **Split** (Tamazin et al. 2013, §4): train = the first 3 min, validation = the next 3 min,
//! test = the rest. A log shorter than 7 min (3 + 3 + 1) is split 30 % / 30 % / 40 % — the same
//! proportions as the paper's 10-min record.
//!
//! **Model** (see `joint_model`): y = c + Σβ_j x_j + [ℓ] + u, u ~ AR(p) by Burg; the effects enter
//! as regressors fitted jointly with the AR errors by iterated feasible GLS, and a rate random walk
//! as a causally tracked random-walk level ℓ. The order p is the one of 1..=max_ar_order with the
//! least one-step MSE on validation.
//!
//! **Iteration.**
//! 1. Fit the current model on train; take its open-loop residual d = y − c − Xβ and its
//!    one-step innovation e.
//! 2. Generate candidates from train only (so that the validation test below is out of sample):
//!    vibration lines — significant peaks of the periodogram of d, refined between bins by FOS
//!    (`spectrum`); a bias step — the strongest change point of d (`changepoint`); temperature —
//!    the lag maximising R² of d on (T_lag − T0, (T_lag − T0)²) (`exogenous`); g-sensitivity — the
//!    specific-force components. A rate random walk (a tracked random-walk level) is offered
//!    only when no deterministic candidate passes and the Allan deviation of e shows excess power
//!    rising (+½) or flat (`allan::check`): in the one-step metric it competes with every slow
//!    effect, so it is the explanation of last resort, tested alone at α.
//! 3. Score each candidate by the FOS criterion on validation: Q = (SSE₀ − SSE₁)/N_val, the
//!    reduction of the one-step squared error when the candidate's terms are added and the model
//!    refitted on train (AR order held at the current p for the comparison).
//! 4. Test the best: the out-of-sample likelihood ratio Λ = N_val ln(SSE₀/SSE₁) against χ²(k),
//!    k = the candidate's parameter count, at α/m (Bonferroni over the m candidates scored in the
//!    iteration). Because the candidate's coefficients are fitted on train, not on validation, Λ
//!    is stochastically smaller than χ²(k) under H0 (with a fixed added prediction δ,
//!    Λ ≈ 2Σe δ/σ² − Σδ²/σ², whose tail is below half that of χ²(1)), so the test is conservative.
//! 5. If it passes: add it, re-select p, re-test every earlier effect with it in (backward
//!    step, repeated: the least significant one is dropped while one no longer passes at α), and
//!    report — with the previous and the new model both
//!    refitted on train ∪ validation — the test-set one-step MSE, the open-loop MSE and the
//!    Ljung–Box statistic before and after, and the share of the residual removed.
//!    Stop when nothing passes (or after `max_iterations`).
//!
//! Per-iteration parameters come from the train ∪ validation refit. The learned effects emitted
//! for the bias model come from a deployment refit on the whole log after the test is scored
//! (structure re-polished there too: line frequencies, temperature lag, step times) — the test
//! numbers never see it; the parameters gain the test part's data.

pub use super::result::{
    CandidateScore, ChannelDiagnosis, DeploymentFit, Findings, Iteration, Overlay, PlotData,
    ResidualPlots, TestMetrics,
};
use super::terms::{Ctx, Term, decimate, effects_of, polish_structure, term_contribution};
use crate::analysis::AnalysisError;
use crate::analysis::allan::check::{AllanKind, allan_check};
use crate::analysis::changepoint::{ChangePointSettings, binary_segmentation};
use crate::analysis::exogenous::{Exogenous, analyse as exo_analyse, lagged_polynomial_scan};
use crate::analysis::joint_model::{JointFit, mse};
use crate::analysis::quantisation::{quantisation, saturation};
use crate::analysis::spectrum::{PeakSettings, find_peaks, periodogram, refine_line, welch};
use crate::stats::acf::whiteness;
use crate::stats::special::chi2_sf;
use crate::stats::{NumError, check_series};
use serde::Serialize;
use std::ops::Range;

/// Settings of the loop.
#[derive(Clone, Debug)]
pub struct DiagnoseSettings {
    /// Training span, s (paper: 180).
    pub train_s: f64,
    /// Validation span, s (paper: 180).
    pub validation_s: f64,
    /// Least test span for the fixed split, s; shorter logs are split proportionally.
    pub min_test_s: f64,
    /// Train / validation / test fractions for short logs.
    pub short_log_fractions: [f64; 3],
    /// Largest AR order tried.
    pub max_ar_order: usize,
    /// Family-wise significance level of each iteration's test.
    pub alpha: f64,
    /// Most effects added.
    pub max_iterations: usize,
    /// Longest temperature lag scanned, s.
    pub max_temp_lag_s: f64,
    /// Ljung–Box lags.
    pub ljung_box_lags: usize,
    /// Most line candidates per iteration.
    pub max_line_candidates: usize,
    /// Line detector.
    pub peaks: PeakSettings,
    /// Step detector.
    pub changepoints: ChangePointSettings,
}

impl Default for DiagnoseSettings {
    fn default() -> Self {
        DiagnoseSettings {
            train_s: 180.0,
            validation_s: 180.0,
            min_test_s: 60.0,
            short_log_fractions: [0.3, 0.3, 0.4],
            max_ar_order: 20,
            alpha: 0.01,
            max_iterations: 8,
            max_temp_lag_s: 60.0,
            ljung_box_lags: 20,
            max_line_candidates: 3,
            peaks: PeakSettings::default(),
            changepoints: ChangePointSettings::default(),
        }
    }
}

impl DiagnoseSettings {
    /// Check the settings once.
    pub fn validate(&self) -> Result<(), AnalysisError> {
        let f = self.short_log_fractions;
        if !(self.train_s > 0.0 && self.validation_s > 0.0 && self.min_test_s > 0.0)
            || f.iter().any(|v| !crate::analysis::is_pos(*v))
            || (f.iter().sum::<f64>() - 1.0).abs() > 1e-9
            || self.max_ar_order == 0
            || !crate::analysis::in_open_unit(self.alpha)
            || self.ljung_box_lags == 0
        {
            return Err(AnalysisError::bad("diagnose settings out of range"));
        }
        Ok(())
    }
}

/// One channel to diagnose (every series has the channel's length).
#[derive(Clone, Copy, Debug)]
pub struct ChannelInput<'a> {
    /// Channel name (gx .. az).
    pub name: &'a str,
    /// Values after the gross-error stage (rad/s or m/s²).
    pub values: &'a [f64],
    /// Sample rate, Hz (time is index / rate).
    pub rate_hz: f64,
    /// Exogenous series.
    pub exogenous: Exogenous<'a>,
}

/// Sample ranges of the split.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Split {
    pub train: Range<usize>,
    pub validation: Range<usize>,
    pub test: Range<usize>,
    /// True when the proportional split for short logs was used.
    pub proportional: bool,
}

/// The split for `n` samples at `rate_hz`.
pub fn split(n: usize, rate_hz: f64, s: &DiagnoseSettings) -> Result<Split, AnalysisError> {
    let tr = (s.train_s * rate_hz).round() as usize;
    let va = (s.validation_s * rate_hz).round() as usize;
    let mt = (s.min_test_s * rate_hz).round() as usize;
    let (a, b, prop) = if n >= tr + va + mt {
        (tr, tr + va, false)
    } else {
        let a = (n as f64 * s.short_log_fractions[0]).round() as usize;
        (
            a,
            a + (n as f64 * s.short_log_fractions[1]).round() as usize,
            true,
        )
    };
    // Each part must hold a usable AR fit and spectrum.
    let need = 8 * s.max_ar_order + 200;
    if a < need || b - a < need || n.saturating_sub(b) < need {
        return Err(NumError::TooShort {
            needed: 3 * need,
            got: n,
        }
        .into());
    }
    Ok(Split {
        train: 0..a,
        validation: a..b,
        test: b..n,
        proportional: prop,
    })
}

fn test_metrics(
    ctx: &Ctx,
    terms: &[Term],
    split: &Split,
    p: usize,
    lb_lags: usize,
) -> Result<(TestMetrics, JointFit, Vec<Vec<f64>>), AnalysisError> {
    let fr = split.train.start..split.validation.end;
    let (f, cols) = ctx.fit(terms, fr, p)?;
    let r = f.residuals(ctx.y, &cols);
    let m = TestMetrics {
        ar_order: p,
        mse_one_step: mse(&r.innovation, split.test.clone()),
        mse_open_loop: mse(&r.open_loop, split.test.clone()),
        ljung_box: whiteness(&r.innovation[split.test.clone()], lb_lags, p).ok(),
    };
    Ok((m, f, cols))
}

fn findings(
    ctx: &Ctx,
    f: &JointFit,
    cols: &[Vec<f64>],
    split: &Split,
    s: &DiagnoseSettings,
) -> Findings {
    let r = f.residuals(ctx.y, cols);
    let t = split.test.clone();
    let d = &r.open_loop[t.clone()];
    let e = &r.innovation[t.clone()];
    Findings {
        ljung_box: whiteness(e, s.ljung_box_lags, f.ar.coeffs.len()).ok(),
        spectral_peaks: periodogram(d, ctx.rate_hz)
            .map(|p| find_peaks(&p, &s.peaks))
            .unwrap_or_default(),
        change_points: binary_segmentation(d, ctx.rate_hz, t.start, &s.changepoints)
            .unwrap_or_default(),
        exogenous: exo_analyse(d, t.start, ctx.rate_hz, &ctx.exo, s.max_temp_lag_s).ok(),
        allan: allan_check(e, ctx.rate_hz, s.alpha).ok(),
    }
}

/// Candidates generated from `d`, the current model's open-loop residual over the train part
/// (which starts at sample `t0` of the log).
fn candidates(ctx: &Ctx, terms: &[Term], d: &[f64], t0: usize, s: &DiagnoseSettings) -> Vec<Term> {
    let mut out = Vec::new();
    // Vibration lines.
    if let Ok(p) = periodogram(d, ctx.rate_hz) {
        let taken: Vec<f64> = terms
            .iter()
            .filter_map(|t| {
                if let Term::Line { freq_hz } = t {
                    Some(*freq_hz)
                } else {
                    None
                }
            })
            .collect();
        let mut n_lines = 0;
        for pk in find_peaks(&p, &s.peaks) {
            if n_lines >= s.max_line_candidates {
                break;
            }
            if taken
                .iter()
                .any(|f0| (f0 - pk.freq_hz).abs() < 3.0 * p.df_hz)
            {
                continue;
            }
            if let Ok(l) = refine_line(d, ctx.rate_hz, t0, pk.freq_hz, 1.5 * p.df_hz) {
                out.push(Term::Line { freq_hz: l.freq_hz });
                n_lines += 1;
            }
        }
    }
    // Bias step: the most significant change point.
    if let Ok(cps) = binary_segmentation(d, ctx.rate_hz, t0, &s.changepoints) {
        let min_sep = (s.changepoints.min_segment_s * ctx.rate_hz) as i64;
        if let Some(cp) = cps
            .iter()
            .filter(|c| !terms.iter().any(|t| matches!(t, Term::Step { index } if (*index as i64 - c.index as i64).abs() <= min_sep)))
            .min_by(|a, b| a.p_value.total_cmp(&b.p_value).then(b.size.abs().total_cmp(&a.size.abs())))
        {
            out.push(Term::Step { index: cp.index });
        }
    }
    // Temperature.
    if let Some(t) = ctx.exo.temperature_c
        && !terms.iter().any(|x| matches!(x, Term::Temperature { .. }))
        && let Ok(scan) = lagged_polynomial_scan(d, t, t0, ctx.rate_hz, s.max_temp_lag_s, 1.0, 2)
    {
        out.push(Term::Temperature {
            lag: scan.lag_samples,
            t0_c: scan.x0,
        });
    }
    // g-sensitivity.
    if ctx.exo.specific_force_m_s2.is_some() && !terms.contains(&Term::GSensitivity) {
        out.push(Term::GSensitivity);
    }
    out
}

/// The rate-random-walk candidate, when the Allan deviation of the train innovations shows
/// excess rising (+½) or flat (flicker) that the model cannot produce; with the kind seen, so the
/// report names a flicker finding as such (the model file has no flicker term: a random-walk
/// level is its approximation over the record's time scales). `e`: the train innovations.
fn rrw_candidate(terms: &[Term], e: &[f64], rate_hz: f64, alpha: f64) -> Option<(Term, AllanKind)> {
    if terms.contains(&Term::RateRandomWalk) {
        return None;
    }
    let a = allan_check(e, rate_hz, alpha).ok()?;
    matches!(a.kind, AllanKind::RateRandomWalk | AllanKind::Flicker)
        .then_some((Term::RateRandomWalk, a.kind))
}

/// Run the loop on one channel.
pub fn diagnose_channel(
    input: &ChannelInput,
    s: &DiagnoseSettings,
) -> Result<ChannelDiagnosis, AnalysisError> {
    s.validate()?;
    let y = input.values;
    check_series(y, 1)?;
    if !crate::analysis::is_pos(input.rate_hz) {
        return Err(AnalysisError::bad("rate_hz must be > 0"));
    }
    let n = y.len();
    if let Some(t) = input.exogenous.temperature_c {
        check_series(t, n)?;
    }
    if let Some(f) = input.exogenous.specific_force_m_s2 {
        for c in f {
            check_series(c, n)?;
        }
    }
    let sp = split(n, input.rate_hz, s)?;
    let ctx = Ctx {
        y,
        rate_hz: input.rate_hz,
        exo: input.exogenous,
    };
    let mut terms: Vec<Term> = Vec::new();
    let mut p = ctx.select_order(&terms, &sp, s.max_ar_order, 1)?;
    let (baseline, bf, bcols) = test_metrics(&ctx, &terms, &sp, p, s.ljung_box_lags)?;
    let baseline_findings = findings(&ctx, &bf, &bcols, &sp, s);
    let mut before = baseline.clone();
    let mut prev_fit = (bf.clone(), bcols.clone());
    let mut iterations = Vec::new();
    let mut rejected = Vec::new();
    let mut overlays = Vec::new();
    let nv = sp.validation.len() as f64;
    for it in 1..=s.max_iterations {
        let (prev_terms, prev_p) = (terms.clone(), p);
        let (f, cols) = ctx.fit(&terms, sp.train.clone(), p)?;
        let sse0 = {
            let r = f.residuals_to(y, &cols, sp.validation.end);
            r.innovation[sp.validation.clone()]
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
        };
        let train_r = f.residuals_to(y, &cols, sp.train.end);
        let cands = candidates(
            &ctx,
            &terms,
            &train_r.open_loop[sp.train.clone()],
            sp.train.start,
            s,
        );
        let m = cands.len().max(1) as f64;
        let mut scores: Vec<(Term, CandidateScore)> = Vec::new();
        for c in cands {
            let mut t2 = terms.clone();
            t2.push(c.clone());
            let Ok(sse1) = ctx.sse(&t2, sp.train.clone(), p, sp.validation.clone()) else {
                continue;
            };
            let lr = nv * (sse0 / sse1).ln();
            let k = c.n_params();
            scores.push((
                c.clone(),
                CandidateScore {
                    family: c.family().into(),
                    description: c.describe(input.rate_hz),
                    n_params: k,
                    q: (sse0 - sse1) / nv,
                    lr,
                    p_value: if lr > 0.0 { chi2_sf(lr, k as f64) } else { 1.0 },
                },
            ));
        }
        let all: Vec<CandidateScore> = scores.iter().map(|x| x.1.clone()).collect();
        let best = scores
            .iter()
            .filter(|(_, sc)| sc.q > 0.0 && sc.p_value < s.alpha / m)
            .max_by(|a, b| a.1.q.total_cmp(&b.1.q))
            .cloned();
        // The random-walk level is the explanation of last resort: in the one-step metric it
        // competes with every slow effect (it tracks a temperature drift or a step as well), and
        // under it a slow regressor keeps little one-step information. So an effect with a
        // physical cause is preferred: the level is offered only when no deterministic candidate
        // passes, tested alone at alpha; the backward step then removes any slow regressor that
        // had been credited with the walk's drift.
        let best = match best {
            Some(b) => Some(b),
            None => rrw_candidate(
                &terms,
                &train_r.innovation[sp.train.clone()],
                ctx.rate_hz,
                s.alpha,
            )
            .and_then(|(c, kind)| {
                let mut t2 = terms.clone();
                t2.push(c.clone());
                let sse1 = ctx
                    .sse(&t2, sp.train.clone(), p, sp.validation.clone())
                    .ok()?;
                let lr = nv * (sse0 / sse1).ln();
                let seen = if kind == AllanKind::Flicker {
                    "Allan excess flat: flicker (bias instability), approximated by"
                } else {
                    "Allan excess rising: rate random walk, modelled as"
                };
                let sc = CandidateScore {
                    family: c.family().into(),
                    description: format!("{seen} a {}", c.describe(input.rate_hz)),
                    n_params: 1,
                    q: (sse0 - sse1) / nv,
                    lr,
                    p_value: if lr > 0.0 { chi2_sf(lr, 1.0) } else { 1.0 },
                };
                (sc.q > 0.0 && sc.p_value < s.alpha).then_some((c, sc))
            }),
        };
        let Some((term, score)) = best else {
            rejected = all;
            break;
        };
        terms.push(term);
        p = ctx.select_order(&terms, &sp, s.max_ar_order, p)?;
        // Backward step (stepwise selection, Efroymson 1960): with the new term in, re-test each
        // earlier one by the same validation LR; drop the least significant if it no longer
        // passes at alpha. A slow regressor credited with a random walk's drift before the walk
        // was modelled is removed here once the level explains the drift.
        let mut removed = Vec::new();
        while terms.len() > 1 {
            let sse_all = ctx.sse(&terms, sp.train.clone(), p, sp.validation.clone())?;
            let mut worst: Option<(usize, f64)> = None;
            for i in 0..terms.len() - 1 {
                let mut t2 = terms.clone();
                t2.remove(i);
                let Ok(sse_wo) = ctx.sse(&t2, sp.train.clone(), p, sp.validation.clone()) else {
                    continue;
                };
                let lr = nv * (sse_wo / sse_all).ln();
                let pv = if lr > 0.0 {
                    chi2_sf(lr, terms[i].n_params() as f64)
                } else {
                    1.0
                };
                if pv >= s.alpha && worst.is_none_or(|w| pv > w.1) {
                    worst = Some((i, pv));
                }
            }
            let Some((i, _)) = worst else { break };
            let t = terms.remove(i);
            removed.push(format!("{} ({})", t.family(), t.describe(input.rate_hz)));
            p = ctx.select_order(&terms, &sp, s.max_ar_order, p)?;
        }
        polish_structure(&ctx, &mut terms, sp.train.start..sp.validation.end, p, s)?;
        // No progress: the added term replaced an earlier one that polishing then moved back
        // (a step re-found next to where it was), so the model is the previous iteration's.
        // Stop instead of cycling to max_iterations.
        if terms.len() == prev_terms.len() && terms.iter().all(|t| prev_terms.contains(t)) {
            terms = prev_terms;
            p = prev_p;
            break;
        }
        let (after, af, acols) = test_metrics(&ctx, &terms, &sp, p, s.ljung_box_lags)?;
        let pos = terms.len() - 1;
        let effect = effects_of(&terms, &af, input.rate_hz)
            .pop()
            .ok_or_else(|| AnalysisError::singular("no effect"))?;
        // Overlay: the previous model's open-loop residual with the new effect's contribution.
        let prev_d = prev_fit.0.open_loop(y, &prev_fit.1);
        let contrib = match terms[pos] {
            Term::RateRandomWalk => {
                // The tracked level is the effect's contribution.
                let k = af.level_gain.unwrap_or(0.0);
                let d = af.open_loop(y, &acols);
                let mut l = 0.0;
                d.iter()
                    .map(|v| {
                        let o = l;
                        l += k * (v - l);
                        o
                    })
                    .collect()
            }
            _ => term_contribution(&ctx, &terms, &af, pos),
        };
        let (t, a, b) = if let Term::Line { freq_hz } = terms[pos] {
            // A few periods in the middle of the test set.
            let w = ((5.0 / freq_hz) * input.rate_hz).ceil() as usize;
            let st = sp.test.start + sp.test.len() / 2;
            let r = st..(st + w.max(10)).min(n);
            (
                r.clone().map(|i| i as f64 / input.rate_hz).collect(),
                prev_d[r.clone()].to_vec(),
                contrib[r].to_vec(),
            )
        } else {
            let ts: Vec<f64> = (0..n).map(|i| i as f64 / input.rate_hz).collect();
            (
                decimate(&ts, 2000),
                decimate(&prev_d, 2000),
                decimate(&contrib, 2000),
            )
        };
        overlays.push(Overlay {
            family: score.family.clone(),
            t_s: t,
            residual: a,
            effect: b,
        });
        let share = |b: f64, a: f64| if b > 0.0 { (b - a) / b } else { 0.0 };
        iterations.push(Iteration {
            index: it,
            family: score.family.clone(),
            effect,
            share_removed_one_step: share(before.mse_one_step, after.mse_one_step),
            share_removed_open_loop: share(before.mse_open_loop, after.mse_open_loop),
            score,
            removed,
            candidates: all,
            before: before.clone(),
            after: after.clone(),
        });
        before = after;
        prev_fit = (af, acols);
    }
    let (final_metrics, ff, fcols) = test_metrics(&ctx, &terms, &sp, p, s.ljung_box_lags)?;
    let final_findings = findings(&ctx, &ff, &fcols, &sp, s);
    // Deployment refit: once the structure is chosen and the test scored, the parameters that go
    // into the bias model are re-estimated on the whole log.
    let mut deploy_terms = terms.clone();
    polish_structure(&ctx, &mut deploy_terms, 0..n, p, s)?;
    let (df, _) = ctx.fit(&deploy_terms, 0..n, p)?;
    let q = quantisation(y).ok();
    let sat = saturation(y, q.as_ref().and_then(|q| q.lsb)).ok();
    // Plot data: spectra and Allan curves of the test innovations, first vs final model.
    let rb = bf.residuals(y, &bcols);
    let rf = ff.residuals(y, &fcols);
    let seg = (sp.test.len() / 8).clamp(256, 8192);
    let plots = PlotData {
        residual: ResidualPlots {
            spectrum_before: welch(&rb.innovation[sp.test.clone()], input.rate_hz, seg).ok(),
            spectrum_after: welch(&rf.innovation[sp.test.clone()], input.rate_hz, seg).ok(),
            allan_before: crate::analysis::allan::oadev_octaves(
                &rb.innovation[sp.test.clone()],
                input.rate_hz,
            ),
            allan_after: crate::analysis::allan::oadev_octaves(
                &rf.innovation[sp.test.clone()],
                input.rate_hz,
            ),
        },
        overlays,
    };
    Ok(ChannelDiagnosis {
        channel: input.name.into(),
        sample_rate_hz: input.rate_hz,
        n,
        split: sp,
        quantisation: q,
        saturation: sat,
        baseline,
        baseline_findings,
        effects: effects_of(&deploy_terms, &df, input.rate_hz),
        refit: DeploymentFit {
            intercept: df.intercept,
            ar: df.ar.coeffs.clone(),
            innovation_var: df.ar.noise_var,
        },
        iterations,
        rejected,
        final_metrics,
        final_findings,
        plots,
    })
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
