//! Temperature compensation with a first-order thermal lag.
//!
//! The bias follows the temperature of the sensing element, which lags the reported temperature:
//! `dT_l/dt = (T - T_l) / tau`. With T held over a sample (zero-order hold) the exact discrete
//! form over k samples of period dt is `T_l <- T + (T_l - T) exp(-k dt / tau)`. The bias term is
//! the polynomial `c1 (T_l - T0) + c2 (T_l - T0)^2` learned by `diagnose` (issue 6).

use crate::model::bias_model::TemperatureTerm;

/// Lagged temperature polynomial of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TemperatureComp {
    t0_c: f64,
    c1_per_c: f64,
    c2_per_c2: f64,
    /// `exp(-dt / tau)` per sample (0 for no lag).
    decay_per_step: f64,
    lagged_c: Option<f64>,
}

impl TemperatureComp {
    /// The compensation of `term` at `sample_rate_hz`.
    pub fn new(term: &TemperatureTerm, sample_rate_hz: f64) -> Self {
        let decay_per_step = if term.lag_s > 0.0 {
            (-1.0 / (term.lag_s * sample_rate_hz)).exp()
        } else {
            0.0
        };
        TemperatureComp {
            t0_c: term.t0_c,
            c1_per_c: term.c1_per_c,
            c2_per_c2: term.c2_per_c2,
            decay_per_step,
            lagged_c: None,
        }
    }

    /// Advance the lag by `steps` samples with the new reading (None or non-finite: the lagged
    /// temperature is held) and return the bias term (unit), or None before any reading.
    #[inline]
    pub fn update(&mut self, temp_c: Option<f64>, steps: u32) -> Option<f64> {
        if let Some(t) = temp_c.filter(|t| t.is_finite()) {
            self.lagged_c = Some(match self.lagged_c {
                None => t,
                Some(l) => {
                    let d = if steps == 1 {
                        self.decay_per_step
                    } else {
                        self.decay_per_step.powi(steps as i32)
                    };
                    t + (l - t) * d
                }
            });
        }
        self.lagged_c.map(|l| {
            let dt = l - self.t0_c;
            self.c1_per_c * dt + self.c2_per_c2 * dt * dt
        })
    }

    /// The lagged temperature, °C.
    pub fn lagged_c(&self) -> Option<f64> {
        self.lagged_c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(t0_c: f64, c1_per_c: f64, c2_per_c2: f64, lag_s: f64) -> TemperatureTerm {
        TemperatureTerm {
            t0_c,
            c1_per_c,
            c2_per_c2,
            lag_s,
        }
    }

    #[test]
    fn lag_follows_the_first_order_step_response() {
        // Step 20 -> 30 °C at t = 0 (after one reading at 20): T_l(t) = 30 - 10 exp(-t/tau)
        // exactly at the sample instants (the discretisation is exact for a held input).
        let (fs, tau) = (100.0, 5.0);
        let mut tc = TemperatureComp::new(&term(25.0, 0.1, 0.01, tau), fs);
        tc.update(Some(20.0), 1);
        for k in 1..=2000 {
            let term = tc.update(Some(30.0), 1).unwrap();
            let tl = 30.0 - 10.0 * (-(k as f64) / fs / tau).exp();
            assert!((tc.lagged_c().unwrap() - tl).abs() < 1e-9, "k {k}");
            let want = 0.1 * (tl - 25.0) + 0.01 * (tl - 25.0).powi(2);
            assert!((term - want).abs() < 1e-9);
        }
        // A gap of 300 samples equals 300 single steps.
        let mut a = tc;
        let mut b = tc;
        a.update(Some(40.0), 300);
        for _ in 0..300 {
            b.update(Some(40.0), 1);
        }
        assert!((a.lagged_c().unwrap() - b.lagged_c().unwrap()).abs() < 1e-9);
    }

    #[test]
    fn missing_temperature_holds_the_lagged_value() {
        let mut tc = TemperatureComp::new(&term(25.0, 1.0, 0.0, 0.0), 100.0);
        assert_eq!(tc.update(None, 1), None, "no reading yet: no compensation");
        assert_eq!(tc.update(Some(27.0), 1), Some(2.0));
        assert_eq!(tc.update(None, 1), Some(2.0));
        assert_eq!(tc.update(Some(f64::NAN), 1), Some(2.0));
    }
}
