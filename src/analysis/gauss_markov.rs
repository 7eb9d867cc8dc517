//! First-order Gauss-Markov fit from the autocorrelation (Sensors 2012 Nu-SVR paper, sec 2.2.3
//! and 4.1.2; Tamazin et al. 2013, sec 2).
//!
//! A first-order GM process has `R(tau) = sigma^2 exp(-|tau| / T_c)` (T_c the correlation time,
//! `beta = 1/T_c`); sampled at `dt` it is the AR(1) `x_k = exp(-dt/T_c) x_{k-1} + w_k`. We
//! estimate `R(k)` by the biased sample autocovariance of the demeaned series and offer two
//! readings:
//!
//! * [`GmMethod::OneOverE`] — the papers' method: `T_c` is where the normalised ACF
//!   `R(k)/R(0)` first falls below `1/e` (linear interpolation between lags), `sigma^2 = R(0)`.
//!   White measurement noise inflates R(0) and pulls the crossing early.
//! * [`GmMethod::LogLeastSquares`] (default) — least squares of `ln R(k) = ln sigma^2 - k dt / T_c`
//!   over lags k = 1..k_stop, where k_stop is the last lag before R(k) drops below
//!   `R(1) e^-2` (about two correlation times: beyond that the relative error of the sample
//!   ACF grows quickly). Lag 0 is excluded, so additive white noise does not bias sigma or T_c.

use crate::model::ar::autocovariance_biased;
use crate::stats::{NumError, check_series};
use serde::{Deserialize, Serialize};

/// How to read the GM parameters off the autocorrelation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GmMethod {
    /// 1/e crossing of the normalised ACF; sigma from R(0).
    OneOverE,
    /// Least squares on ln R(k), lags 1..k_stop.
    LogLeastSquares,
}

/// Fitted first-order Gauss-Markov parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaussMarkovFit {
    /// Standard deviation of the GM process, units of x.
    pub sigma: f64,
    /// Correlation time T_c, s.
    pub tau_c_s: f64,
    /// Method used.
    pub method: GmMethod,
    /// Number of ACF lags used (LS) or the crossing lag (1/e).
    pub lags_used: usize,
}

/// Why a GM fit failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GmError {
    /// Too short, non-finite or constant (the shared numerical vocabulary, [`NumError`]).
    #[error(transparent)]
    Numeric(#[from] NumError),
    #[error("sample rate must be positive and finite")]
    BadRate,
    #[error(
        "autocorrelation does not decay within {0} lags (correlation time too long for the record or max_lag)"
    )]
    NoDecay(usize),
    #[error("autocorrelation not positive at lag 1, or gone within one lag: no decay to fit")]
    NotCorrelated,
}

/// Fit a first-order GM model to `x` sampled at `rate_hz`, using ACF lags up to `max_lag`.
pub fn fit_gauss_markov(
    x: &[f64],
    rate_hz: f64,
    max_lag: usize,
    method: GmMethod,
) -> Result<GaussMarkovFit, GmError> {
    if !(rate_hz > 0.0 && rate_hz.is_finite()) {
        return Err(GmError::BadRate);
    }
    let needed = (max_lag + 1).max(8) * 2;
    check_series(x, needed)?;
    let dt = 1.0 / rate_hz;
    let (r, _) = autocovariance_biased(x, max_lag.max(2));
    if r[0].is_nan() || r[0] <= 0.0 {
        return Err(NumError::Constant.into());
    }
    match method {
        GmMethod::OneOverE => {
            let thr = r[0] / std::f64::consts::E;
            let k = (1..r.len())
                .find(|&k| r[k] < thr)
                .ok_or(GmError::NoDecay(max_lag))?;
            // linear interpolation of the crossing between k-1 and k
            let frac = (r[k - 1] - thr) / (r[k - 1] - r[k]);
            Ok(GaussMarkovFit {
                sigma: r[0].sqrt(),
                tau_c_s: ((k - 1) as f64 + frac) * dt,
                method,
                lags_used: k,
            })
        }
        GmMethod::LogLeastSquares => {
            if r[1].is_nan() || r[1] <= 0.0 {
                return Err(GmError::NotCorrelated);
            }
            let stop = r[1] * (-2.0f64).exp();
            let k_stop = (2..r.len())
                .find(|&k| r[k].is_nan() || r[k] <= stop)
                .map(|k| k - 1)
                .ok_or(GmError::NoDecay(max_lag))?;
            // need two points for a line: an ACF that falls by e^2 within one lag has no
            // correlation time resolvable at this sample rate
            if k_stop < 2 {
                return Err(GmError::NotCorrelated);
            }
            let (mut st, mut sy, mut stt, mut sty) = (0.0, 0.0, 0.0, 0.0);
            let cnt = k_stop as f64;
            for (k, rk) in r.iter().enumerate().take(k_stop + 1).skip(1) {
                let t = k as f64 * dt;
                let ly = rk.ln();
                st += t;
                sy += ly;
                stt += t * t;
                sty += t * ly;
            }
            let slope = (cnt * sty - st * sy) / (cnt * stt - st * st);
            let intercept = (sy - slope * st) / cnt;
            if slope.is_nan() || slope >= 0.0 {
                return Err(GmError::NotCorrelated);
            }
            Ok(GaussMarkovFit {
                sigma: (0.5 * intercept).exp(),
                tau_c_s: -1.0 / slope,
                method,
                lags_used: k_stop,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// GM with sigma and T_c at rate f, plus white noise of sd `white`.
    fn gm(sigma: f64, tc: f64, f: f64, n: usize, white: f64, seed: u64) -> Vec<f64> {
        let a = (-1.0 / (tc * f)).exp();
        let q = sigma * (1.0 - a * a).sqrt();
        let mut rng = Rng::new(seed);
        let mut v = sigma * rng.normal();
        (0..n)
            .map(|_| {
                v = a * v + q * rng.normal();
                v + white * rng.normal()
            })
            .collect()
    }

    /// The fit of the series of `gm(0.3, 0.5, 100.0, 400_000, …)` is the truth: T_c = 0.5 s at
    /// 100 Hz (50 samples), 400k samples = 8000 T_c. The ACF at lag k has relative sd
    /// ~ sqrt(2 T_c / T_record) ~ 1.6 %; T_c within 8 %, sigma within 5 %.
    fn assert_recovered(f: &GaussMarkovFit) {
        assert!((f.tau_c_s / 0.5 - 1.0).abs() < 0.08, "{f:?}");
        assert!((f.sigma / 0.3 - 1.0).abs() < 0.05, "{f:?}");
    }

    #[test]
    fn log_ls_recovers_sigma_and_correlation_time() {
        let x = gm(0.3, 0.5, 100.0, 400_000, 0.0, 1);
        assert_recovered(&fit_gauss_markov(&x, 100.0, 300, GmMethod::LogLeastSquares).unwrap());
    }

    #[test]
    fn one_over_e_recovers_correlation_time_without_white_noise() {
        let x = gm(0.3, 0.5, 100.0, 400_000, 0.0, 2);
        assert_recovered(&fit_gauss_markov(&x, 100.0, 300, GmMethod::OneOverE).unwrap());
    }

    #[test]
    fn log_ls_ignores_white_noise_that_biases_one_over_e() {
        // White noise as large as the GM sd doubles R(0): the 1/e reading of sigma is inflated
        // by sqrt(2) and T_c shortened; LS on lags >= 1 is not.
        let x = gm(0.3, 0.5, 100.0, 400_000, 0.3, 3);
        let ls = fit_gauss_markov(&x, 100.0, 300, GmMethod::LogLeastSquares).unwrap();
        let oe = fit_gauss_markov(&x, 100.0, 300, GmMethod::OneOverE).unwrap();
        assert_recovered(&ls);
        assert!(oe.sigma > 0.3 * 1.3, "{oe:?}");
        assert!(oe.tau_c_s < 0.5 * 0.9, "{oe:?}");
    }
}
