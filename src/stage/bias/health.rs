//! Typed health of the bias stage ([`BiasStage::health`]).

use serde::Serialize;

use super::BiasStage;
use crate::sample::N_CHANNELS;

crate::stage::health::counters! {
    /// Counted by the bias stage since the run started.
    #[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
    pub struct BiasCounters {
        /// Samples processed.
        samples,
        /// Samples the stillness detector called still (flag `STILL`).
        still_samples,
        /// Still measurements taken by a gyro filter (summed over channels).
        bias_updates,
        /// CUSUM step alarms (each inflated a random-constant state; summed over channels).
        step_alarms,
        /// Warm-up models fitted (one per gyro channel without a model, once).
        warmup_fits,
        /// Warm-up stretches that could not be fitted (constant values) and were started again.
        warmup_fit_failures,
        /// Samples with a non-finite channel after calibration (flag `NON_FINITE`).
        non_finite_samples,
        /// Gaps over 100 samples: delay line flushed without updates, stillness restarted.
        long_gaps,
        /// Channels of the model file whose white-noise variance was clamped (at build).
        white_noise_clamped_channels,
        /// Effects of the model file the stage cannot apply (too many lines; steps or random walks
        /// on accel channels), at build.
        ignored_effects,
        /// Still measurements the consistency guard rejected (beyond 4 σ of the prediction).
        rejected_updates,
        /// Times a gyro estimate re-anchored after 2 s of disagreeing still measurements.
        reanchors,
        /// Quiet stretches not taken for rest because the gyro stayed off its bias about gravity
        /// past `mean_veto_s` by more than that bias: steady turns (stillness docs, "Steady
        /// turns"), and their samples.
        steady_turns,
        steady_turn_samples,
        /// Stale repeats (`REPEATED`): given the current bias, no measurement.
        repeats,
        /// Gyro channels that started subtracting their estimate (a model file's at once, the
        /// warm-up model's once distinguishable from zero, `apply_k`; at most once per channel).
        engagements,
    }
}

/// Where a channel's bias model came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BiasModelOrigin {
    /// No model (yet): an accel channel without one, or a gyro channel still warming up.
    None,
    /// `[bias] model` (a file from `imuprep fit` / `diagnose`, or inline).
    File,
    /// Fitted by the stage on its first still stretch (module docs, warm-up).
    WarmUp,
}

/// What the stage does to a channel now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BiasChannelState {
    /// Calibration and the model's effects only (accel channels: module docs, point 6).
    CalibrationOnly,
    /// A gyro channel collecting its warm-up stretch; nothing estimated is subtracted yet.
    WarmingUp,
    /// Warming up, with the running mean of the still stretch subtracted (flag `BIAS_REMOVED`).
    Provisional,
    /// A bias filter runs and its estimate is subtracted (flag `BIAS_REMOVED`).
    Estimating,
}

impl BiasChannelState {
    /// A gyro channel still collecting its warm-up stretch (provisional bias or none yet).
    pub fn warming_up(self) -> bool {
        matches!(
            self,
            BiasChannelState::WarmingUp | BiasChannelState::Provisional
        )
    }
}

/// Health of one channel of the bias stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BiasChannelHealth {
    pub state: BiasChannelState,
    pub model: BiasModelOrigin,
    /// Deterministic effects applied (temperature, g-sensitivity, vibration lines).
    pub effects: u32,
    /// Stochastic bias estimate published with the last sample, rad/s (gyro) or m/s² (accel);
    /// the published `bias` of the sample is this plus the effects.
    pub bias: f64,
    /// Its 1-σ, same unit (accel with a model: the stationary σ of the bias nobody subtracted).
    pub bias_sd: f64,
    /// The estimate (`bias`) is subtracted: a model file's from the start, the warm-up model's
    /// once distinguishable from zero (`apply_k`). Before, nothing is subtracted and `bias` is
    /// published only here.
    pub engaged: bool,
    /// Step alarms of this channel.
    pub step_alarms: u64,
    /// Warm-up stretches of this channel that held one value and were started again: a stuck
    /// axis, or noise below one LSB (said once as a `WARN` line; the channel stays warming up).
    pub constant_stretches: u64,
}

/// Health of the bias stage: counters since the run started, the detector and each channel now.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BiasHealth {
    #[serde(flatten)]
    pub counters: BiasCounters,
    /// The stillness detector reports rest now.
    pub still: bool,
    /// Per channel, `gx` … `az` (a map keyed by channel name in JSON).
    #[serde(serialize_with = "crate::stage::health::by_channel")]
    pub channels: [BiasChannelHealth; N_CHANNELS],
}

impl BiasHealth {
    /// Every counter, named as the summary prints it.
    pub fn counters(&self, f: &mut dyn FnMut(&str, u64)) {
        for (k, v) in self.counters.named() {
            f(k, v);
        }
    }
}

impl BiasStage {
    /// Health now (module [`crate::stage::health`]).
    pub fn health(&self) -> BiasHealth {
        BiasHealth {
            counters: self.counters,
            still: self.detector.is_still(),
            channels: std::array::from_fn(|c| {
                let st = &self.ch[c];
                let state = if st.est.is_some() {
                    BiasChannelState::Estimating
                } else if st.warm.is_some() && st.provisional.is_some() {
                    BiasChannelState::Provisional
                } else if st.warm.is_some() {
                    BiasChannelState::WarmingUp
                } else {
                    BiasChannelState::CalibrationOnly
                };
                BiasChannelHealth {
                    state,
                    model: st.origin,
                    effects: u32::from(st.temp.is_some())
                        + u32::from(st.gsens.is_some())
                        + st.lines.iter().flatten().count() as u32,
                    bias: st.bias,
                    bias_sd: st.bias_sd,
                    engaged: st.engaged,
                    step_alarms: st.diag.step_alarms,
                    constant_stretches: st.constant_stretches,
                }
            }),
        }
    }
}
