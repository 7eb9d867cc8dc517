//! The terms the close-the-loop iteration ([`super::paper_split`]) adds, how each becomes regressor
//! columns of the joint model, the effects a fitted model yields, and the re-polishing of a term's
//! structure (line frequency, temperature lag, step time) on more data.

use super::paper_split::DiagnoseSettings;
use super::paper_split::Split;
use crate::analysis::AnalysisError;
use crate::analysis::exogenous::{Exogenous, lagged_polynomial_scan};
use crate::analysis::joint_model::{JointFit, LevelSpec, fit as joint_fit, fit_orders, mse};
use crate::analysis::spectrum::refine_line;
use crate::model::bias_model::{Effect, TemperatureTerm};
use std::f64::consts::PI;
use std::ops::Range;

/// An effect family member the loop can add.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Term {
    Line { freq_hz: f64 },
    Temperature { lag: usize, t0_c: f64 },
    Step { index: usize },
    GSensitivity,
    RateRandomWalk,
}

impl Term {
    pub(super) fn family(&self) -> &'static str {
        match self {
            Term::Line { .. } => "vibration_line",
            Term::Temperature { .. } => "temperature",
            Term::Step { .. } => "bias_step",
            Term::GSensitivity => "g_sensitivity",
            Term::RateRandomWalk => "rate_random_walk",
        }
    }
    pub(super) fn n_params(&self) -> usize {
        match self {
            Term::Line { .. } | Term::Temperature { .. } => 2,
            Term::Step { .. } | Term::RateRandomWalk => 1,
            Term::GSensitivity => 3,
        }
    }
    pub(super) fn describe(&self, rate_hz: f64) -> String {
        match self {
            Term::Line { freq_hz } => format!("line at {freq_hz:.5} Hz"),
            Term::Temperature { lag, t0_c } => format!(
                "temperature lag {:.1} s about {t0_c:.2} °C",
                *lag as f64 / rate_hz
            ),
            Term::Step { index } => format!("step at {:.2} s", *index as f64 / rate_hz),
            Term::GSensitivity => "specific force x, y, z".into(),
            Term::RateRandomWalk => "random-walk level".into(),
        }
    }
}

/// Everything the fit needs besides the terms.
pub(super) struct Ctx<'a> {
    pub(super) y: &'a [f64],
    pub(super) rate_hz: f64,
    pub(super) exo: Exogenous<'a>,
}

impl Ctx<'_> {
    pub(super) fn columns(&self, t: &Term) -> Vec<Vec<f64>> {
        let n = self.y.len();
        match t {
            Term::Line { freq_hz } => {
                let w = 2.0 * PI * freq_hz / self.rate_hz;
                let (s, c) = (0..n).map(|i| (w * i as f64).sin_cos()).unzip();
                vec![s, c]
            }
            Term::Temperature { lag, t0_c } => {
                let tc = self.exo.temperature_c.unwrap_or(&[]);
                let d: Vec<f64> = (0..n)
                    .map(|i| tc.get(i.saturating_sub(*lag)).copied().unwrap_or(*t0_c) - t0_c)
                    .collect();
                let d2 = d.iter().map(|v| v * v).collect();
                vec![d, d2]
            }
            Term::Step { index } => vec![
                (0..n)
                    .map(|i| if i >= *index { 1.0 } else { 0.0 })
                    .collect(),
            ],
            Term::GSensitivity => match self.exo.specific_force_m_s2 {
                Some(f) => f.iter().map(|c| c.to_vec()).collect(),
                None => vec![],
            },
            Term::RateRandomWalk => vec![],
        }
    }

    pub(super) fn all_columns(&self, terms: &[Term]) -> Vec<Vec<f64>> {
        terms.iter().flat_map(|t| self.columns(t)).collect()
    }

    pub(super) fn level(terms: &[Term]) -> LevelSpec {
        if terms.contains(&Term::RateRandomWalk) {
            LevelSpec::Fit
        } else {
            LevelSpec::None
        }
    }

    pub(super) fn fit(
        &self,
        terms: &[Term],
        range: Range<usize>,
        p: usize,
    ) -> Result<(JointFit, Vec<Vec<f64>>), AnalysisError> {
        let cols = self.all_columns(terms);
        let f = joint_fit(self.y, &cols, range, p, Self::level(terms))?;
        Ok((f, cols))
    }

    /// One-step SSE on `eval` of the model fitted on `fit_range`.
    pub(super) fn sse(
        &self,
        terms: &[Term],
        fit_range: Range<usize>,
        p: usize,
        eval: Range<usize>,
    ) -> Result<f64, AnalysisError> {
        let (f, cols) = self.fit(terms, fit_range, p)?;
        let r = f.residuals_to(self.y, &cols, eval.end);
        Ok(r.innovation[eval].iter().map(|v| v * v).sum())
    }

    /// AR order with the least validation one-step MSE. With a random-walk level the gain is
    /// fitted once at the current order and held while the order is scanned (cost).
    pub(super) fn select_order(
        &self,
        terms: &[Term],
        split: &Split,
        max_p: usize,
        p_now: usize,
    ) -> Result<usize, AnalysisError> {
        let cols = self.all_columns(terms);
        let level = match Self::level(terms) {
            LevelSpec::Fit => joint_fit(self.y, &cols, split.train.clone(), p_now, LevelSpec::Fit)?
                .level_gain
                .map_or(LevelSpec::None, LevelSpec::Fixed),
            l => l,
        };
        let mut best = (p_now, f64::INFINITY);
        let fits = fit_orders(self.y, &cols, split.train.clone(), max_p, level);
        for (i, f) in fits.into_iter().enumerate() {
            let p = i + 1;
            let Some(f) = f else {
                continue;
            };
            let r = f.residuals_to(self.y, &cols, split.validation.end);
            let v = mse(&r.innovation, split.validation.clone());
            if v < best.1 {
                best = (p, v);
            }
        }
        Ok(best.0)
    }
}

/// Effects of a fitted model, in term order.
pub(super) fn effects_of(terms: &[Term], f: &JointFit, rate_hz: f64) -> Vec<Effect> {
    let mut out = Vec::new();
    let mut j = 0;
    for t in terms {
        match t {
            Term::Line { freq_hz } => {
                let (a, b) = (f.beta[j], f.beta[j + 1]);
                out.push(Effect::VibrationLine {
                    freq_hz: *freq_hz,
                    amplitude: a.hypot(b),
                    phase_rad: b.atan2(a),
                });
            }
            Term::Temperature { lag, t0_c } => out.push(Effect::Temperature(TemperatureTerm {
                t0_c: *t0_c,
                c1_per_c: f.beta[j],
                c2_per_c2: f.beta[j + 1],
                lag_s: *lag as f64 / rate_hz,
            })),
            Term::Step { index } => out.push(Effect::Step {
                t_s: *index as f64 / rate_hz,
                size: f.beta[j],
            }),
            Term::GSensitivity => out.push(Effect::GSensitivity {
                coeffs_per_m_s2: [f.beta[j], f.beta[j + 1], f.beta[j + 2]],
            }),
            Term::RateRandomWalk => out.push(Effect::RateRandomWalk {
                q_per_s: f.level_q_per_sample.unwrap_or(0.0) * rate_hz,
            }),
        }
        j += t.n_params() * usize::from(!matches!(t, Term::RateRandomWalk));
    }
    out
}

/// The contribution Σβx of the term at `pos` in `terms`.
pub(super) fn term_contribution(ctx: &Ctx, terms: &[Term], f: &JointFit, pos: usize) -> Vec<f64> {
    let mut j = 0;
    for t in &terms[..pos] {
        j += ctx.columns(t).len();
    }
    let cols = ctx.columns(&terms[pos]);
    (0..ctx.y.len())
        .map(|n| {
            cols.iter()
                .enumerate()
                .map(|(k, c)| f.beta[j + k] * c[n])
                .sum()
        })
        .collect()
}

/// Re-polish each term's structure on a refit range (more data): line frequencies (±¼ bin),
/// the temperature lag and centre (full lag scan), step times (least-squares location within
/// ±`min_segment_s`). Each term is polished on the residual of the model without it.
pub(super) fn polish_structure(
    ctx: &Ctx,
    terms: &mut [Term],
    range: Range<usize>,
    p: usize,
    s: &DiagnoseSettings,
) -> Result<(), AnalysisError> {
    for i in 0..terms.len() {
        if matches!(terms[i], Term::GSensitivity | Term::RateRandomWalk) {
            continue;
        }
        let mut others = terms.to_vec();
        others.remove(i);
        let (f, cols) = ctx.fit(&others, range.clone(), p)?;
        let d = f.open_loop(ctx.y, &cols);
        let seg = &d[range.clone()];
        match terms[i] {
            Term::Line { freq_hz } => {
                let bin = ctx.rate_hz / range.len() as f64;
                if let Ok(l) = refine_line(seg, ctx.rate_hz, range.start, freq_hz, 0.25 * bin) {
                    terms[i] = Term::Line { freq_hz: l.freq_hz };
                }
            }
            Term::Temperature { .. } => {
                if let Some(t) = ctx.exo.temperature_c
                    && let Ok(scan) = lagged_polynomial_scan(
                        seg,
                        t,
                        range.start,
                        ctx.rate_hz,
                        s.max_temp_lag_s,
                        1.0,
                        2,
                    )
                {
                    terms[i] = Term::Temperature {
                        lag: scan.lag_samples,
                        t0_c: scan.x0,
                    };
                }
            }
            Term::Step { index } => {
                // Least-squares location of one mean shift within the window, from prefix sums.
                let w = (s.changepoints.min_segment_s * ctx.rate_hz) as usize;
                let m = seg.len();
                let mean = seg.iter().sum::<f64>() / m as f64;
                let mut cs = vec![0.0; m + 1];
                for (k, v) in seg.iter().enumerate() {
                    cs[k + 1] = cs[k] + v - mean;
                }
                let lo = index.saturating_sub(w).max(range.start + 1) - range.start;
                let hi = (index + w).min(range.end - 1) - range.start;
                let best = (lo..=hi).max_by(|&a, &b| {
                    let st = |k: usize| cs[k] * cs[k] / (k as f64 * (m - k) as f64);
                    st(a).total_cmp(&st(b))
                });
                if let Some(k) = best {
                    terms[i] = Term::Step {
                        index: range.start + k,
                    };
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Block means of at most `max_points` blocks (for plots of slow curves).
pub(super) fn decimate(x: &[f64], max_points: usize) -> Vec<f64> {
    let b = x.len().div_ceil(max_points.max(1)).max(1);
    x.chunks(b)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect()
}
