//! Sensor temperature profiles and the temperature-dependent bias.
//!
//! Profiles (t in s from the first sample):
//! * constant: T = T_c;
//! * ramp: T = T_s + (T_e − T_s) · clamp((t − t_s)/D, 0, 1);
//! * warm-up (self-heating after power-on): T = T_amb + ΔT (1 − e^(−t/τ));
//! * steps: set-point S(t) piecewise constant; the sensor follows with a first-order lag,
//!   discretised exactly: T[n+1] = S + (T[n] − S) e^(−Δt/τ) (τ = 0: T = S).
//!
//! Temperature bias (a second-order polynomial in the temperature offset, as in thermal
//! calibration, e.g. the Sensors 2012 paper §2.2.2):
//!   b = c₁ (T_d − T₀) + c₂ (T_d − T₀)²,
//! with T_d the die temperature, the profile seen through an optional first-order lag
//! T_d[n+1] = T + (T_d[n] − T) e^(−Δt/τ_lag), T_d[0] = T[0].

use super::scenario::{TemperatureConfig, TemperatureProfile};
use crate::rng::Rng;

/// Evaluates a temperature profile sample by sample.
#[derive(Clone, Debug)]
pub struct TemperatureModel {
    profile: TemperatureProfile,
    resolution_c: f64,
    noise_sd_c: f64,
    dt_s: f64,
    /// Steps profile: current temperature and index of the next step.
    state_c: f64,
    next_step: usize,
    rng: Rng,
}

impl TemperatureModel {
    pub fn new(cfg: &TemperatureConfig, dt_s: f64, rng: Rng) -> Self {
        let state_c = match &cfg.profile {
            TemperatureProfile::Steps { initial_c, .. } => *initial_c,
            _ => 0.0,
        };
        TemperatureModel {
            profile: cfg.profile.clone(),
            resolution_c: cfg.resolution_c,
            noise_sd_c: cfg.noise_sd_c,
            dt_s,
            state_c,
            next_step: 0,
            rng,
        }
    }

    /// True temperature at `t_s`; must be called once per sample, in order (the steps
    /// profile carries state).
    pub fn step(&mut self, t_s: f64) -> f64 {
        match &self.profile {
            TemperatureProfile::Constant { temp_c } => *temp_c,
            TemperatureProfile::Ramp {
                start_c,
                end_c,
                start_s,
                duration_s,
            } => start_c + (end_c - start_c) * ((t_s - start_s) / duration_s).clamp(0.0, 1.0),
            TemperatureProfile::WarmUp {
                ambient_c,
                rise_c,
                tau_s,
            } => ambient_c + rise_c * (1.0 - (-t_s / tau_s).exp()),
            TemperatureProfile::Steps {
                initial_c,
                steps,
                tau_s,
            } => {
                // Set-point in force at t_s (steps are sorted by validation).
                while self.next_step < steps.len() && steps[self.next_step].t_s <= t_s {
                    self.next_step += 1;
                }
                let set = if self.next_step == 0 {
                    *initial_c
                } else {
                    steps[self.next_step - 1].to_c
                };
                let out = if *tau_s > 0.0 { self.state_c } else { set };
                if *tau_s > 0.0 {
                    self.state_c = set + (self.state_c - set) * (-self.dt_s / tau_s).exp();
                }
                out
            }
        }
    }

    /// What the sensor reports for true temperature `t_c`: plus noise, quantised.
    pub fn report(&mut self, t_c: f64) -> f64 {
        let noisy = t_c + self.noise_sd_c * self.rng.normal();
        if self.resolution_c > 0.0 {
            (noisy / self.resolution_c).round() * self.resolution_c
        } else {
            noisy
        }
    }
}

/// First-order lag of the temperature driving the bias, and the polynomial per channel.
#[derive(Clone, Debug)]
pub struct TemperatureBias6 {
    t0_c: f64,
    lag_factor: f64,
    die_c: Option<f64>,
    c1: [f64; 6],
    c2: [f64; 6],
}

impl TemperatureBias6 {
    /// `c1`, `c2` in signal units per °C and per °C²; `lag_tau_s` = 0 for no lag.
    pub fn new(t0_c: f64, lag_tau_s: f64, dt_s: f64, c1: [f64; 6], c2: [f64; 6]) -> Self {
        let lag_factor = if lag_tau_s > 0.0 {
            (-dt_s / lag_tau_s).exp()
        } else {
            0.0
        };
        TemperatureBias6 {
            t0_c,
            lag_factor,
            die_c: None,
            c1,
            c2,
        }
    }

    /// Bias per channel for the current true temperature (advances the lag).
    #[inline]
    pub fn step(&mut self, t_c: f64) -> [f64; 6] {
        let die = self.die_c.unwrap_or(t_c);
        self.die_c = Some(t_c + (die - t_c) * self.lag_factor);
        let d = die - self.t0_c;
        let mut out = [0.0; 6];
        for (c, o) in out.iter_mut().enumerate() {
            *o = self.c1[c] * d + self.c2[c] * d * d;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scenario::TemperatureStep;

    fn model(profile: TemperatureProfile) -> TemperatureModel {
        let cfg = TemperatureConfig {
            resolution_c: 0.0,
            noise_sd_c: 0.0,
            profile,
        };
        TemperatureModel::new(&cfg, 0.1, Rng::new(0))
    }

    #[test]
    fn steps_follow_a_first_order_lag_exactly() {
        // Step 25 → 35 °C at t = 1 s, τ = 2 s: the continuous response T(t) = 35 − 10 e^(−(t−1)/2)
        // for t ≥ 1 (the step lands on a sample here, so the sampled lag is exact).
        let mut m = model(TemperatureProfile::Steps {
            initial_c: 25.0,
            steps: vec![TemperatureStep {
                t_s: 1.0,
                to_c: 35.0,
            }],
            tau_s: 2.0,
        });
        for k in 0..100 {
            let t = k as f64 * 0.1;
            let got = m.step(t);
            let want = if k < 10 {
                25.0
            } else {
                35.0 - 10.0 * (-(t - 1.0) / 2.0).exp()
            };
            // Repeated multiplication by e^(−Δt/τ): rounding ~1e-15 per step.
            assert!((got - want).abs() < 1e-12, "t={t}: {got} vs {want}");
        }
    }

    #[test]
    fn ramp_is_flat_outside_its_interval() {
        let mut m = model(TemperatureProfile::Ramp {
            start_c: 20.0,
            end_c: 30.0,
            start_s: 1.0,
            duration_s: 2.0,
        });
        assert_eq!(m.step(0.0), 20.0);
        assert_eq!(m.step(2.0), 25.0);
        assert_eq!(m.step(5.0), 30.0);
    }

    #[test]
    fn temperature_bias_is_linear_plus_quadratic_in_the_offset() {
        let mut b = TemperatureBias6::new(25.0, 0.0, 0.01, [0.1; 6], [0.01; 6]);
        // ΔT = 5: 0.1·5 + 0.01·25 = 0.75.
        assert!((b.step(30.0)[0] - 0.75).abs() < 1e-15);
    }
}
