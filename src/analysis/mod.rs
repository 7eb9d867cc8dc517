//! Offline analyses of recorded sensor series: noise characterisation and model comparison.
//!
//! One folder per method that takes several files ([`allan`], [`calib`], [`diagnose`]); a method
//! of one file stands at this level (spectrum, change points, wavelets, ...).

pub mod allan;
pub mod bias_compare;
pub mod calib;
pub mod changepoint;
pub mod detectors;
pub mod diagnose;
pub mod exogenous;
pub mod gauss_markov;
pub mod joint_model;
pub mod line_plot;
pub mod quantisation;
pub mod spectrum;
#[cfg(test)]
pub(crate) mod synth_test;
pub mod wavelet;

use crate::stats::NumError;

/// Why an analysis could not run.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// Too few samples, non-finite input, lengths that do not match, a setting outside its
    /// domain, a singular least-squares system (the shared numerical vocabulary, [`NumError`]).
    #[error(transparent)]
    Numeric(#[from] NumError),
    /// The underlying model fitter failed.
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
}

impl AnalysisError {
    /// [`NumError::BadSetting`] with a message, as an analysis error.
    pub(crate) fn bad(msg: impl Into<String>) -> Self {
        NumError::bad(msg).into()
    }
    /// [`NumError::Singular`] naming the system, as an analysis error.
    pub(crate) fn singular(what: impl Into<String>) -> Self {
        NumError::singular(what).into()
    }
}

/// `x > 0` and not NaN (settings checks that must reject NaN too).
pub(crate) fn is_pos(x: f64) -> bool {
    x > 0.0
}

/// `0 < x < 1` and not NaN.
pub(crate) fn in_open_unit(x: f64) -> bool {
    x > 0.0 && x < 1.0
}
