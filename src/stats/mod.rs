//! The ground floor: statistics that every floor above uses, each written once.
//!
//! * [`special`]: special functions and distributions (on `statrs`; Student's t by hand in
//!   [`student_t`], with the measurement that says why).
//! * [`acf`]: sample ACF and PACF with their white-noise bounds, the Ljung–Box test.
//! * [`adf`]: the augmented Dickey–Fuller unit-root test with MacKinnon's p-values.
//! * [`grid`]: the LSB a quantised channel's values lie on, and the rails a clipped one held.
//! * [`line`]: the strongest vibration line of a series (a stationary sinusoid), found and fitted.
//! * [`robust`]: median, MAD-based σ, the Hampel filter.
//! * [`ar_poly`]: the AR polynomial — stability (Schur–Cohn step-down), Durbin–Levinson and its
//!   inverse, exact AR autocovariances. It sits here rather than in `model/` because the PACF
//!   above is a Durbin–Levinson recursion, and every model and the simulator use it.
//!
//! [`NumError`] is the one error vocabulary of the numerical code (stats, models, analyses): a
//! series too short, a non-finite value, a constant series, a singular system, lengths that do
//! not match, a setting outside its domain.

pub mod acf;
pub mod adf;
pub mod allan_edf;
pub mod ar_poly;
pub mod grid;
pub mod line;
pub mod robust;
pub mod special;
pub mod student_t;

/// Why a numerical routine could not compute its result. Numerical code never panics on user
/// data; it returns one of these.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NumError {
    /// Fewer samples than the computation needs.
    #[error("series too short: need at least {needed} samples, got {got}")]
    TooShort { needed: usize, got: usize },
    /// NaN or ±Inf in the input.
    #[error("non-finite value at index {index}")]
    NonFinite { index: usize },
    /// Zero variance where a variance or correlation must be estimated.
    #[error("series is constant")]
    Constant,
    /// Normal equations or a Gram matrix that are singular or not positive definite.
    #[error("singular system: {0}")]
    Singular(String),
    /// Series that must have equal lengths do not.
    #[error("length mismatch: expected {expected}, got {got}")]
    LengthMismatch { expected: usize, got: usize },
    /// A setting (order, lag count, window, threshold, …) outside its domain.
    #[error("invalid setting: {0}")]
    BadSetting(String),
}

impl NumError {
    /// [`NumError::BadSetting`] with a message.
    pub fn bad(msg: impl Into<String>) -> Self {
        NumError::BadSetting(msg.into())
    }
    /// [`NumError::Singular`] naming the system.
    pub fn singular(what: impl Into<String>) -> Self {
        NumError::Singular(what.into())
    }
}

/// The index of the first non-finite value, as an error.
pub fn check_finite(x: &[f64]) -> Result<(), NumError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(NumError::NonFinite { index }),
        None => Ok(()),
    }
}

/// At least `needed` samples, all finite: the check at the boundary of each analysis.
pub fn check_series(x: &[f64], needed: usize) -> Result<(), NumError> {
    if x.len() < needed {
        return Err(NumError::TooShort {
            needed,
            got: x.len(),
        });
    }
    check_finite(x)
}

/// `a.len() == b.len()`, as an error.
pub fn check_same_len(expected: usize, got: usize) -> Result<(), NumError> {
    if expected == got {
        Ok(())
    } else {
        Err(NumError::LengthMismatch { expected, got })
    }
}

/// Arithmetic mean (0 for an empty slice).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    x.iter().sum::<f64>() / x.len() as f64
}
