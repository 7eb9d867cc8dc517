//! Measuring the gross-error gate: a seeded synthetic channel with known truth, a runner that
//! pushes it through [`GrossErrorStage`], and the k-sweep behind the stage's defaults.
//!
//! Synthetic channel (one gyro axis, rad/s; all draws from `crate::rng::Rng`, so a seed fixes it):
//!
//! ```text
//!   truth_t    = bias + m_t + n_t
//!   n_t        = φ n_{t−1} + √(1−φ²) σ_n ε_t          AR(1) noise with marginal sd σ_n
//!   m_t        = manoeuvres: raised-cosine ramps 0 → A over R samples, hold H, back to 0
//!                (A ~ ±U(0.2, 1)·peak, R ~ U(ramp_min, ramp_max), H ~ U(0.5, 3) s, idle U(1, 5) s)
//!   observed_t = truth_t + s_t,  s_t ≠ 0 only on gross errors:
//!                events at `spike_rate` per sample; each is one sample or (with probability
//!                `run_fraction`) a run of U{2..=max_run_len} samples, every sample offset by
//!                ±U(spike_min_sigma, spike_max_sigma)·σ_n with one sign per event.
//! ```
//!
//! Spike sizes are in units of the noise's marginal sd σ_n (for AR(1) noise the one-step
//! innovation sd is smaller, √(1−φ²) σ_n, so a "6σ" spike is ≥ 6 innovation σ).

use serde::{Deserialize, Serialize};

use crate::analysis::detectors::{DetectorScore, score};
use crate::rng::Rng;
use crate::sample::{N_CHANNELS, Sample, flags};
use crate::stage::gross_error::{GrossErrorError, GrossErrorSettings, GrossErrorStage};

/// Specification of a synthetic channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SyntheticSpec {
    /// Samples.
    pub n: usize,
    pub seed: u64,
    /// Constant offset (rad/s).
    pub bias: f64,
    /// Marginal sd of the noise σ_n (rad/s).
    pub noise_sd: f64,
    /// AR(1) coefficient of the noise.
    pub noise_ar: f64,
    /// Peak manoeuvre amplitude (rad/s); 0 = static.
    pub manoeuvre_peak: f64,
    /// Ramp durations, samples (R ~ U(min, max)).
    pub ramp_min_samples: usize,
    pub ramp_max_samples: usize,
    /// Sample rate, only to express hold/idle times (Hz).
    pub sample_rate_hz: f64,
    /// Gross-error events per sample.
    pub spike_rate: f64,
    /// Spike size range, in σ_n.
    pub spike_min_sigma: f64,
    pub spike_max_sigma: f64,
    /// Fraction of events that are runs.
    pub run_fraction: f64,
    /// Longest run (samples).
    pub max_run_len: usize,
    /// No manoeuvre starts before this sample (e.g. a vehicle at rest during the stage's warm-up).
    pub quiet_start_samples: usize,
}

impl SyntheticSpec {
    /// A vehicle at rest: AR(1) noise φ = 0.5, σ_n = 5 mrad/s, 200 Hz, spikes 6–30 σ every
    /// 500 samples on average, a third of them runs of up to 10.
    pub fn static_gyro(n: usize, seed: u64) -> Self {
        SyntheticSpec {
            n,
            seed,
            bias: 0.01,
            noise_sd: 0.005,
            noise_ar: 0.5,
            manoeuvre_peak: 0.0,
            ramp_min_samples: 200,
            ramp_max_samples: 200,
            sample_rate_hz: 200.0,
            spike_rate: 1.0 / 500.0,
            spike_min_sigma: 6.0,
            spike_max_sigma: 30.0,
            run_fraction: 1.0 / 3.0,
            max_run_len: 10,
            quiet_start_samples: 0,
        }
    }

    /// A drive: the static noise plus yaw-rate manoeuvres up to ±0.5 rad/s with ramps of
    /// 0.25–1 s (peak slopes up to π/2·0.5/50 ≈ 0.016 rad/s per sample ≈ 3 σ_n per sample),
    /// starting 1–5 s into the log (so a 10 s warm-up sees some of them).
    pub fn drive_gyro(n: usize, seed: u64) -> Self {
        SyntheticSpec {
            manoeuvre_peak: 0.5,
            ramp_min_samples: 50,
            ramp_max_samples: 200,
            ..Self::static_gyro(n, seed)
        }
    }

    /// At rest with white noise (φ = 0): the hardest case for catching 6σ spikes, since the
    /// one-step innovation sd is the full σ_n.
    pub fn static_white_gyro(n: usize, seed: u64) -> Self {
        SyntheticSpec {
            noise_ar: 0.0,
            ..Self::static_gyro(n, seed)
        }
    }

    /// The drive, but at rest for the first `quiet_s` seconds (a warm-up at rest).
    pub fn drive_gyro_quiet_start(n: usize, seed: u64, quiet_s: f64) -> Self {
        let d = Self::drive_gyro(n, seed);
        SyntheticSpec {
            quiet_start_samples: (quiet_s * d.sample_rate_hz) as usize,
            ..d
        }
    }
}

/// A synthetic channel with its truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticStream {
    /// Spike-free signal.
    pub truth: Vec<f64>,
    /// What the sensor reports.
    pub observed: Vec<f64>,
    /// True gross errors.
    pub mask: Vec<bool>,
    /// σ_n of the spec (spike sizes are in these units).
    pub noise_sd: f64,
}

/// Generate the channel described by `spec`.
pub fn synthetic_stream(spec: &SyntheticSpec) -> SyntheticStream {
    let n = spec.n;
    let mut noise_rng = Rng::fork(spec.seed, 1);
    let mut man_rng = Rng::fork(spec.seed, 2);
    let mut spike_rng = Rng::fork(spec.seed, 3);
    // Noise.
    let innov_sd = spec.noise_sd * (1.0 - spec.noise_ar * spec.noise_ar).sqrt();
    let mut v = spec.noise_sd * noise_rng.normal();
    let mut truth: Vec<f64> = (0..n)
        .map(|_| {
            v = spec.noise_ar * v + innov_sd * noise_rng.normal();
            spec.bias + v
        })
        .collect();
    // Manoeuvres.
    if spec.manoeuvre_peak > 0.0 {
        let fs = spec.sample_rate_hz;
        let uni = |r: &mut Rng, a: f64, b: f64| a + (b - a) * r.uniform();
        let mut t = spec.quiet_start_samples + (uni(&mut man_rng, 1.0, 5.0) * fs) as usize;
        while t < n {
            let sign = if man_rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            let amp = sign * spec.manoeuvre_peak * uni(&mut man_rng, 0.2, 1.0);
            let r = uni(
                &mut man_rng,
                spec.ramp_min_samples as f64,
                spec.ramp_max_samples as f64,
            )
            .max(1.0) as usize;
            let hold = (uni(&mut man_rng, 0.5, 3.0) * fs) as usize;
            let shape = |i: usize| 0.5 * (1.0 - (std::f64::consts::PI * i as f64 / r as f64).cos());
            for i in 0..(2 * r + hold) {
                let m = if i < r {
                    amp * shape(i)
                } else if i < r + hold {
                    amp
                } else {
                    amp * (1.0 - shape(i - r - hold))
                };
                if let Some(x) = truth.get_mut(t + i) {
                    *x += m;
                }
            }
            t += 2 * r + hold + (uni(&mut man_rng, 1.0, 5.0) * fs) as usize;
        }
    }
    // Gross errors.
    let mut observed = truth.clone();
    let mut mask = vec![false; n];
    let mut t = 0usize;
    while t < n {
        if spike_rng.uniform() >= spec.spike_rate {
            t += 1;
            continue;
        }
        let len = if spike_rng.uniform() < spec.run_fraction && spec.max_run_len >= 2 {
            2 + spike_rng.below((spec.max_run_len - 1) as u64) as usize
        } else {
            1
        };
        let sign = if spike_rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        for i in t..(t + len).min(n) {
            let a = spec.spike_min_sigma
                + (spec.spike_max_sigma - spec.spike_min_sigma) * spike_rng.uniform();
            observed[i] += sign * a * spec.noise_sd;
            mask[i] = true;
        }
        // At least two clean samples between events, so events stay distinct.
        t += len + 2;
    }
    SyntheticStream {
        truth,
        observed,
        mask,
        noise_sd: spec.noise_sd,
    }
}

/// Output of the stage on one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct StageRun {
    /// Samples the stage replaced.
    pub replaced: Vec<bool>,
    /// The stage's output.
    pub corrected: Vec<f64>,
    /// Index of the first sample after warm-up.
    pub active_from: usize,
    /// Level changes accepted.
    pub level_changes: u64,
}

/// Run a fresh [`GrossErrorStage`] with `settings` on `x` in channel `channel` (the other
/// channels are disabled), 200 Hz timestamps.
pub fn run_stage(
    x: &[f64],
    settings: &GrossErrorSettings,
    channel: usize,
) -> Result<StageRun, GrossErrorError> {
    let mut s = settings.clone();
    s.enabled = [false; N_CHANNELS];
    s.enabled[channel] = true;
    let mut stage = GrossErrorStage::new(s, None)?;
    let input: Vec<Sample> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let mut smp = Sample::nth(i, 5_000_000);
            smp.set_channel(channel, v);
            smp
        })
        .collect();
    // Through the stage as the pipeline runs it: look-ahead and all.
    let out = crate::stage::run_through(&mut stage, &input);
    let active_from = out
        .iter()
        .position(|o| !o.has(flags::WARMING_UP))
        .unwrap_or(x.len());
    let level_changes = out.iter().filter(|o| o.has(flags::LEVEL_CHANGE)).count() as u64;
    let replaced = out
        .iter()
        .map(|o| o.has(flags::replaced_ch(channel)))
        .collect();
    let corrected = out.iter().map(|o| o.channel(channel)).collect();
    Ok(StageRun {
        replaced,
        corrected,
        active_from,
        level_changes,
    })
}

/// Score a stage run against the truth over the samples after warm-up.
pub fn score_run(run: &StageRun, stream: &SyntheticStream) -> DetectorScore {
    let a = run.active_from.min(stream.truth.len());
    // Lengths are equal by construction, so scoring cannot fail.
    score(
        &run.replaced[a..],
        &stream.mask[a..],
        &run.corrected[a..],
        &stream.truth[a..],
    )
    .unwrap_or(DetectorScore {
        precision: f64::NAN,
        recall: f64::NAN,
        f1: f64::NAN,
        false_alarm_rate: f64::NAN,
        rmse: f64::NAN,
        true_positives: 0,
        false_positives: 0,
        false_negatives: 0,
        clean_samples: 0,
    })
}

/// One row of a k-sweep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepRow {
    pub k: f64,
    pub confirm_jump: bool,
    pub score: DetectorScore,
    /// RMSE of the truth-vs-truth baseline is 0; this is the RMSE of the *uncorrected* series,
    /// for scale.
    pub rmse_uncorrected: f64,
    pub level_changes: u64,
    /// Recall on the spike samples of 6–8 σ_n (the hardest ones).
    pub recall_6_8_sigma: f64,
}

/// Run the stage on `stream` for every k in `ks` and every confirmation setting in `confirm`.
pub fn sweep_k(
    stream: &SyntheticStream,
    base: &GrossErrorSettings,
    ks: &[f64],
    confirm: &[bool],
) -> Result<Vec<SweepRow>, GrossErrorError> {
    let mut rows = Vec::with_capacity(ks.len() * confirm.len());
    for &c in confirm {
        for &k in ks {
            let s = GrossErrorSettings {
                k,
                confirm_jump: c,
                ..base.clone()
            };
            let run = run_stage(&stream.observed, &s, 2)?;
            let a = run.active_from.min(stream.truth.len());
            let raw = score(
                &stream.mask[a..],
                &stream.mask[a..],
                &stream.observed[a..],
                &stream.truth[a..],
            )
            .map(|s| s.rmse)
            .unwrap_or(f64::NAN);
            let (mut small, mut caught) = (0u64, 0u64);
            for i in a..stream.truth.len() {
                let size = (stream.observed[i] - stream.truth[i]).abs() / stream.noise_sd;
                if stream.mask[i] && size < 8.0 {
                    small += 1;
                    caught += run.replaced[i] as u64;
                }
            }
            rows.push(SweepRow {
                k,
                confirm_jump: c,
                score: score_run(&run, stream),
                rmse_uncorrected: raw,
                level_changes: run.level_changes,
                recall_6_8_sigma: if small == 0 {
                    1.0
                } else {
                    caught as f64 / small as f64
                },
            });
        }
    }
    Ok(rows)
}

/// The k grid of the report: 3.0, 3.25, …, 6.0.
pub fn default_k_grid() -> Vec<f64> {
    (0..=12).map(|i| 3.0 + 0.25 * i as f64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_stream_is_seeded_and_spikes_follow_the_spec() {
        let spec = SyntheticSpec::drive_gyro(100_000, 5);
        let a = synthetic_stream(&spec);
        assert_eq!(a, synthetic_stream(&spec), "same seed, same stream");
        assert_ne!(
            a.observed,
            synthetic_stream(&SyntheticSpec { seed: 6, ..spec }).observed
        );
        let mut events = 0;
        let mut runs = 0;
        let mut i = 0;
        while i < a.mask.len() {
            if !a.mask[i] {
                // Clean samples are the truth, untouched.
                assert_eq!(a.observed[i], a.truth[i]);
                i += 1;
                continue;
            }
            let start = i;
            while i < a.mask.len() && a.mask[i] {
                let size = (a.observed[i] - a.truth[i]).abs() / spec.noise_sd;
                // 1e-9: the offset is added to and then subtracted from an O(0.5) value.
                assert!((6.0 - 1e-9..=30.0 + 1e-9).contains(&size), "size {size}");
                i += 1;
            }
            assert!(i - start <= 10, "run of {}", i - start);
            events += 1;
            runs += (i - start > 1) as usize;
        }
        // 100 000 samples at 1/500: ~200 events (Poisson sd 14; the 2-sample spacing after each
        // event barely matters); a third of them runs (Binomial sd ≈ 6.7 at n = 200).
        assert!((140..=260).contains(&events), "{events} events");
        let frac = runs as f64 / events as f64;
        assert!((frac - 1.0 / 3.0).abs() < 0.12, "run fraction {frac}");
    }

    #[test]
    fn default_k_grid_is_three_to_six_in_quarters() {
        let g = default_k_grid();
        assert_eq!(g.len(), 13);
        assert_eq!(g[0], 3.0);
        assert_eq!(g[12], 6.0);
    }
}
