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

/// Why a model could not be fitted. Fitting never panics on user data; it returns one of these.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// The series is too short for the requested order / lag structure.
    #[error("series too short: need at least {needed} samples, got {got}")]
    TooShort { needed: usize, got: usize },
    /// The requested model order is not usable (e.g. zero).
    #[error("bad model order {0}")]
    BadOrder(usize),
    /// An input value is NaN or infinite.
    #[error("non-finite input value at index {index}")]
    NonFinite { index: usize },
    /// The series has (numerically) zero variance, so no correlation structure exists.
    #[error("series has zero variance")]
    ZeroVariance,
    /// The normal equations / Gram matrix are singular or not positive definite.
    #[error("singular system: {0}")]
    Singular(String),
    /// Series or candidate columns of different lengths were passed together.
    #[error("length mismatch: expected {expected}, got {got}")]
    LengthMismatch { expected: usize, got: usize },
    /// A setting is out of range.
    #[error("invalid settings: {0}")]
    InvalidSettings(String),
}

/// Return the index of the first non-finite value, as an error.
pub(crate) fn check_finite(x: &[f64]) -> Result<(), ModelError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(ModelError::NonFinite { index }),
        None => Ok(()),
    }
}

/// Common input checks of the AR fitters: order >= 1, enough samples, finite values.
pub(crate) fn check_ar_input(x: &[f64], p: usize) -> Result<(), ModelError> {
    if p == 0 {
        return Err(ModelError::BadOrder(p));
    }
    // At least 2p+1 samples so that every lagged product used has a few terms and the
    // covariance method's p x p system is not trivially rank deficient.
    let needed = 2 * p + 1;
    if x.len() < needed {
        return Err(ModelError::TooShort {
            needed,
            got: x.len(),
        });
    }
    check_finite(x)
}

/// Arithmetic mean (0 for an empty slice).
pub(crate) fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    kernels::sum(x) / x.len() as f64
}
