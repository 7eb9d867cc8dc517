//! Stochastic error models fitted offline and evaluated online: AR(p) by Yule-Walker
//! ([`ar`]), Burg ([`burg`]) and the covariance method ([`covariance`]); Korenberg's fast
//! orthogonal search ([`fos`]) over candidate families ([`fos_candidates`]).

pub mod ar;
pub mod arima;
pub mod bias_model;
pub mod bias_state_space;
pub mod burg;
pub mod covariance;
pub mod fos;
pub mod fos_candidates;
pub mod fos_model;
mod kernels;

pub use ar::{ArFit, yule_walker, yule_walker_orders};
pub use burg::{burg, burg_orders};
pub use covariance::covariance;

use crate::stats::{NumError, check_series};

/// Why a model could not be fitted. Fitting never panics on user data; it returns one of these.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// The series is too short, non-finite or constant, a system is singular, lengths do not
    /// match or a setting is out of range (the shared numerical vocabulary, [`NumError`]).
    #[error(transparent)]
    Numeric(#[from] NumError),
    /// The requested model order is not usable (e.g. zero).
    #[error("bad model order {0}")]
    BadOrder(usize),
}

impl ModelError {
    /// [`NumError::BadSetting`] with a message, as a model error.
    pub(crate) fn bad(msg: impl Into<String>) -> Self {
        NumError::bad(msg).into()
    }
    /// [`NumError::Singular`] naming the system, as a model error.
    pub(crate) fn singular(what: impl Into<String>) -> Self {
        NumError::singular(what).into()
    }
}

/// Common input checks of the AR fitters: order >= 1, enough samples, finite values.
pub(crate) fn check_ar_input(x: &[f64], p: usize) -> Result<(), ModelError> {
    if p == 0 {
        return Err(ModelError::BadOrder(p));
    }
    // At least 2p+1 samples so that every lagged product used has a few terms and the
    // covariance method's p x p system is not trivially rank deficient.
    Ok(check_series(x, 2 * p + 1)?)
}

/// Arithmetic mean (0 for an empty slice).
pub(crate) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    kernels::sum(x) / x.len() as f64
}
