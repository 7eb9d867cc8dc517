//! What the `--paper-split` diagnose loop ([`super::paper_split::diagnose_channel`]) returns: per
//! channel the split, the first and final models' test metrics and residual findings, every
//! effect added with its score and test, and the plot data.

use super::paper_split::Split;
use crate::analysis::allan::check::AllanFinding;
use crate::analysis::changepoint::ChangePoint;
use crate::analysis::exogenous::ExogenousReport;
use crate::analysis::quantisation::{Quantisation, Saturation};
use crate::analysis::spectrum::{Psd, SpectralPeak};
use crate::model::bias_model::Effect;
use crate::stats::acf::Whiteness;
use serde::Serialize;

/// A candidate's score on validation.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateScore {
    /// Effect family.
    pub family: String,
    /// The candidate's structure (frequency, lag, time ...).
    pub description: String,
    /// Parameters it adds.
    pub n_params: usize,
    /// Q = validation one-step MSE reduction, units².
    pub q: f64,
    /// Λ = N_val ln(SSE₀/SSE₁).
    pub lr: f64,
    /// P(χ²(k) > Λ).
    pub p_value: f64,
}

/// Test-set metrics of one model (fitted on train ∪ validation).
#[derive(Clone, Debug, Serialize)]
pub struct TestMetrics {
    /// AR order.
    pub ar_order: usize,
    /// One-step innovation MSE on test, units².
    pub mse_one_step: f64,
    /// Open-loop MSE on test: mean of (y − c − Xβ)², units².
    pub mse_open_loop: f64,
    /// Ljung–Box of the test innovations.
    pub ljung_box: Option<Whiteness>,
}

/// One added effect.
#[derive(Clone, Debug, Serialize)]
pub struct Iteration {
    /// 1-based.
    pub index: usize,
    /// Family name.
    pub family: String,
    /// The effect with its parameters (from the train ∪ validation refit).
    pub effect: Effect,
    /// Its score and test.
    pub score: CandidateScore,
    /// Earlier effects dropped by the backward step of this iteration.
    pub removed: Vec<String>,
    /// All candidates scored in this iteration.
    pub candidates: Vec<CandidateScore>,
    /// Before adding it.
    pub before: TestMetrics,
    /// After adding it.
    pub after: TestMetrics,
    /// (before − after)/before of the one-step test MSE.
    pub share_removed_one_step: f64,
    /// (before − after)/before of the open-loop test MSE.
    pub share_removed_open_loop: f64,
}

/// Residual analyses of one model on the test set.
#[derive(Clone, Debug, Serialize)]
pub struct Findings {
    /// Whiteness of the innovations.
    pub ljung_box: Option<Whiteness>,
    /// Significant lines in the open-loop residual.
    pub spectral_peaks: Vec<SpectralPeak>,
    /// Steps in the open-loop residual.
    pub change_points: Vec<ChangePoint>,
    /// Exogenous correlation of the open-loop residual.
    pub exogenous: Option<ExogenousReport>,
    /// Allan deviation of the innovations vs a white residual.
    pub allan: Option<AllanFinding>,
}

/// One effect's fitted contribution over the residual before it was added.
#[derive(Clone, Debug, Default)]
pub struct Overlay {
    /// Effect family.
    pub family: String,
    /// Time, s from the start of the log.
    pub t_s: Vec<f64>,
    /// Open-loop residual of the previous model.
    pub residual: Vec<f64>,
    /// The new effect's fitted contribution.
    pub effect: Vec<f64>,
}

/// The AR part of a diagnosis's deployment refit on the whole log: what the bias model file's
/// channel carries besides the effects.
#[derive(Clone, Debug, Serialize)]
pub struct DeploymentFit {
    /// Intercept (the bias model's `mean` when effects apply on top).
    pub intercept: f64,
    /// AR coefficients.
    pub ar: Vec<f64>,
    /// One-step innovation variance.
    pub innovation_var: f64,
}

/// A channel's residual before and after its effects, as both diagnoses plot it
/// ([`super::report::residual_plots`]; not serialised).
#[derive(Clone, Debug, Default)]
pub struct ResidualPlots {
    /// Welch spectrum, before and after.
    pub spectrum_before: Option<Psd>,
    pub spectrum_after: Option<Psd>,
    /// Allan deviation, (tau s, deviation) per octave, before and after.
    pub allan_before: Vec<(f64, f64)>,
    pub allan_after: Vec<(f64, f64)>,
}

/// Plot data (not serialised).
#[derive(Clone, Debug, Default)]
pub struct PlotData {
    /// The test innovations of the first and the final model.
    pub residual: ResidualPlots,
    /// Per iteration: the effect over the residual it explains.
    pub overlays: Vec<Overlay>,
}

/// The diagnosis of one channel.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelDiagnosis {
    pub channel: String,
    pub sample_rate_hz: f64,
    pub n: usize,
    pub split: Split,
    /// Quantisation of the raw values.
    pub quantisation: Option<Quantisation>,
    /// Saturation of the raw values.
    pub saturation: Option<Saturation>,
    /// The first model on test.
    pub baseline: TestMetrics,
    /// What the first model left (test set).
    pub baseline_findings: Findings,
    /// Effects added, in order.
    pub iterations: Vec<Iteration>,
    /// Candidates of the last (rejected) round.
    pub rejected: Vec<CandidateScore>,
    /// The final model on test.
    pub final_metrics: TestMetrics,
    /// What the final model leaves (test set).
    pub final_findings: Findings,
    /// Learned effects for the bias model TOML (deployment refit on the whole log).
    pub effects: Vec<Effect>,
    /// Intercept, AR and innovation variance of the deployment refit.
    #[serde(flatten)]
    pub refit: DeploymentFit,
    #[serde(skip)]
    pub plots: PlotData,
}
