//! Offline analyses of recorded sensor series: noise characterisation and model comparison.

pub mod allan;
pub mod allan_check;
pub mod allan_edf;
pub mod allan_export;
pub mod allan_plot;
pub mod allan_report;
pub mod allan_terms;
pub mod bias_compare;
pub mod changepoint;
pub mod detectors;
pub mod diagnose;
pub mod diagnose_blocks;
pub mod diagnose_lines;
pub mod diagnose_report;
pub mod diagnose_slow;
mod diagnose_terms;
pub mod diagnose_wander;
pub mod diagnose_whole;
pub mod diagnose_whole_report;
pub mod exogenous;
pub mod gauss_markov;
pub mod joint_model;
pub mod quantisation;
pub mod spectrum;
pub mod svg;
#[cfg(test)]
pub(crate) mod synth_test;
pub mod wavelet;

/// Why an analysis could not run.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// Too few samples for the analysis.
    #[error("series too short: {len} samples, need {need}")]
    TooShort { len: usize, need: usize },
    /// NaN or infinite input.
    #[error("non-finite input")]
    NonFinite,
    /// Series that must have equal length do not.
    #[error("length mismatch: {0} vs {1}")]
    LengthMismatch(usize, usize),
    /// A setting outside its domain.
    #[error("bad setting: {0}")]
    BadSetting(&'static str),
    /// A least-squares system was singular.
    #[error("singular least-squares system: {0}")]
    Singular(&'static str),
    /// The underlying model fitter failed.
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
}

/// Reject empty or non-finite input once, at the boundary of each analysis.
pub(crate) fn check_finite(x: &[f64], need: usize) -> Result<(), AnalysisError> {
    if x.len() < need {
        return Err(AnalysisError::TooShort { len: x.len(), need });
    }
    if x.iter().any(|v| !v.is_finite()) {
        return Err(AnalysisError::NonFinite);
    }
    Ok(())
}

/// `x > 0` and not NaN (settings checks that must reject NaN too).
pub(crate) fn is_pos(x: f64) -> bool {
    x > 0.0
}

/// `0 < x < 1` and not NaN.
pub(crate) fn in_open_unit(x: f64) -> bool {
    x > 0.0 && x < 1.0
}
