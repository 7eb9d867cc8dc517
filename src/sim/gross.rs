//! Gross errors: isolated spikes and runs of successive bad samples, as in Chen, Li & Zhang
//! (J. Southeast Univ. 2013), which distinguishes single from successive gross errors of an
//! in-vehicle MEMS gyro.
//!
//! Per channel, independently: when no event is in progress and the previous one did not end on the
//! sample before (so that events never merge into longer runs), an event starts with probability
//! `rate` (a Bernoulli process, so the gap between events is geometric). It is a run with
//! probability `run_fraction`, of length L ~ U{2, …, L_max}, else a spike (L = 1). The event has
//! one random sign s; each of its samples adds s · a · σ_c, a ~ U[a_min, a_max] drawn per sample,
//! σ_c the channel's white-noise σ per sample.

use crate::rng::Rng;
use crate::sample::N_CHANNELS;

/// Gross-error generator for six channels.
#[derive(Clone, Debug)]
pub struct Gross6 {
    rate: f64,
    amp_min: f64,
    amp_max: f64,
    run_fraction: f64,
    max_run: u32,
    active: [bool; N_CHANNELS],
    sigma: [f64; N_CHANNELS],
    remaining: [u32; N_CHANNELS],
    /// An event just ended: the next sample is clean, so two events never merge into a run
    /// longer than `max_run`.
    cooling: [bool; N_CHANNELS],
    sign: [f64; N_CHANNELS],
    rng: Rng,
}

impl Gross6 {
    /// `active[c]`: channel affected; `sigma[c]`: the amplitude unit (signal units).
    pub fn new(
        rate: f64,
        amplitude_sigma: [f64; 2],
        run_fraction: f64,
        max_run: u32,
        active: [bool; N_CHANNELS],
        sigma: [f64; N_CHANNELS],
        rng: Rng,
    ) -> Self {
        Gross6 {
            rate,
            amp_min: amplitude_sigma[0],
            amp_max: amplitude_sigma[1],
            run_fraction,
            max_run,
            active,
            sigma,
            remaining: [0; N_CHANNELS],
            cooling: [false; N_CHANNELS],
            sign: [1.0; N_CHANNELS],
            rng,
        }
    }

    /// Error per channel and the mask of channels hit at this sample.
    #[inline]
    pub fn step(&mut self) -> ([f64; N_CHANNELS], [bool; N_CHANNELS]) {
        let mut err = [0.0; N_CHANNELS];
        let mut mask = [false; N_CHANNELS];
        for c in 0..N_CHANNELS {
            // Draw the start decision on every channel and sample, so the stream layout does
            // not depend on which channels are active.
            let u = self.rng.uniform();
            if !self.active[c] {
                continue;
            }
            if self.cooling[c] {
                self.cooling[c] = false;
                continue;
            }
            if self.remaining[c] == 0 && u < self.rate {
                let is_run = self.max_run >= 2 && self.rng.uniform() < self.run_fraction;
                self.remaining[c] = if is_run {
                    2 + self.rng.below(u64::from(self.max_run - 1)) as u32
                } else {
                    1
                };
                self.sign[c] = if self.rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            }
            if self.remaining[c] > 0 {
                self.remaining[c] -= 1;
                self.cooling[c] = self.remaining[c] == 0;
                let a = self.amp_min + (self.amp_max - self.amp_min) * self.rng.uniform();
                err[c] = self.sign[c] * a * self.sigma[c];
                mask[c] = true;
            }
        }
        (err, mask)
    }
}
