//! Road / engine vibration: band-limited random motion with a resonance.
//!
//! Each mode is white noise e ~ N(0,1) through a resonant AR(2) whose poles are the
//! impulse-invariant images of a damped oscillator (ω₀ = 2π f₀, damping ζ):
//!   x[n] = a₁ x[n−1] + a₂ x[n−2] + e[n],   a₁ = 2 r cos(ω₀ Δt √(1−ζ²)),  a₂ = −r²,
//!   r = e^(−ζ ω₀ Δt),
//! followed by a first difference y[n] = g (x[n] − x[n−1]). The difference puts a zero at DC:
//! a vehicle body vibrates about its mean position, so the vibration acceleration has no mean
//! and integrates to a bounded velocity (an AR(2) alone has power at DC and would make the
//! strapdown velocity random-walk). Its variance is closed-form:
//!   var(y)/g² = 2 (γ₀ − γ₁),  γ₀ = (1 − a₂) / ((1 + a₂)((1 − a₂)² − a₁²)),  γ₁ = a₁ γ₀ / (1 − a₂)
//! (Box, Jenkins & Reinsel, *Time Series Analysis*, §3.2.4), so g = rms / √(2(γ₀ − γ₁)).
//! The state starts from its stationary distribution (no switch-on transient).

use super::scenario::VibrationMode;
use crate::rng::Rng;
use crate::sample::N_CHANNELS;

/// One vibration mode on all six channels.
#[derive(Clone, Debug)]
pub struct VibrationModeState {
    a1: f64,
    a2: f64,
    gain: [f64; N_CHANNELS],
    x1: [f64; N_CHANNELS],
    x2: [f64; N_CHANNELS],
    speed_ref_m_s: Option<f64>,
    idle_fraction: f64,
    rng: Rng,
}

/// AR(2) coefficients of the resonance and the unit-gain variance of its first difference.
pub fn resonance_coeffs(freq_hz: f64, damping_ratio: f64, dt_s: f64) -> (f64, f64, f64) {
    let w0 = 2.0 * std::f64::consts::PI * freq_hz;
    let r = (-damping_ratio * w0 * dt_s).exp();
    let a1 = 2.0 * r * (w0 * dt_s * (1.0 - damping_ratio * damping_ratio).sqrt()).cos();
    let a2 = -r * r;
    let g0 = (1.0 - a2) / ((1.0 + a2) * ((1.0 - a2).powi(2) - a1 * a1));
    let g1 = a1 * g0 / (1.0 - a2);
    (a1, a2, 2.0 * (g0 - g1))
}

impl VibrationModeState {
    /// Build a mode (validated config), with its own random stream.
    pub fn new(m: &VibrationMode, dt_s: f64, mut rng: Rng) -> Self {
        let (a1, a2, unit_var) = resonance_coeffs(m.freq_hz, m.damping_ratio, dt_s);
        let g0 = (1.0 - a2) / ((1.0 + a2) * ((1.0 - a2).powi(2) - a1 * a1));
        let rho1 = a1 / (1.0 - a2);
        let unit_sd = unit_var.sqrt();
        let mut gain = [0.0; N_CHANNELS];
        for i in 0..3 {
            gain[i] = m.gyro_rms_deg_s[i].to_radians() / unit_sd;
            gain[3 + i] = m.accel_rms_m_s2[i] / unit_sd;
        }
        let mut x1 = [0.0; N_CHANNELS];
        let mut x2 = [0.0; N_CHANNELS];
        for c in 0..N_CHANNELS {
            // (x[n−1], x[n−2]) ~ stationary bivariate normal with correlation ρ₁.
            x1[c] = g0.sqrt() * rng.normal();
            x2[c] = rho1 * x1[c] + (g0 * (1.0 - rho1 * rho1)).sqrt() * rng.normal();
        }
        VibrationModeState {
            a1,
            a2,
            gain,
            x1,
            x2,
            speed_ref_m_s: m.speed_ref_m_s,
            idle_fraction: m.idle_fraction,
            rng,
        }
    }

    /// Next vibration value per channel (rad/s, m/s²) at forward speed `speed_m_s`.
    #[inline]
    pub fn step(&mut self, speed_m_s: f64) -> [f64; N_CHANNELS] {
        let scale = match self.speed_ref_m_s {
            Some(vref) => {
                self.idle_fraction + (1.0 - self.idle_fraction) * (speed_m_s.abs() / vref).min(1.0)
            }
            None => 1.0,
        };
        let mut out = [0.0; N_CHANNELS];
        for (c, o) in out.iter_mut().enumerate() {
            let x = self.a1 * self.x1[c] + self.a2 * self.x2[c] + self.rng.normal();
            *o = scale * self.gain[c] * (x - self.x1[c]);
            self.x2[c] = self.x1[c];
            self.x1[c] = x;
        }
        out
    }
}
