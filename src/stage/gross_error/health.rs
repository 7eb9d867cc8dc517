//! Typed health of the gross-error stage ([`GrossErrorStage::health`]).

use serde::Serialize;

use super::GrossErrorStage;
use super::gate::{ChannelCounters, Mode};
use crate::sample::{CHANNEL_NAMES, N_CHANNELS};

/// What a channel's gate is doing now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GateState {
    /// Switched off by `enabled`: values pass untouched.
    Disabled,
    /// Collecting `warmup_samples` (or `warmup_max_s` of them) to identify its model, then
    /// `identify_defer_s` more while a worker identifies it; a robust jump test guards meanwhile.
    WarmingUp,
    /// Gating on its ARIMA model.
    Active,
}

impl From<Mode> for GateState {
    fn from(m: Mode) -> Self {
        match m {
            Mode::Disabled => GateState::Disabled,
            Mode::WarmingUp => GateState::WarmingUp,
            Mode::Active => GateState::Active,
        }
    }
}

/// Health of one channel's gate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GateChannelHealth {
    pub state: GateState,
    /// ARIMA order `[p, d, q]` of the model in use (`None` until the channel has one).
    pub model_order: Option<[usize; 3]>,
    /// The model came from the model file (`[gross_error] model`) rather than warm-up.
    pub model_given: bool,
    /// Tracked innovation σ, rad/s (gyro) or m/s² (accel); `None` unless active.
    pub sigma: Option<f64>,
    /// Counted since the run started.
    #[serde(flatten)]
    pub counters: ChannelCounters,
}

/// Health of the gross-error stage: stage-wide counters since the run started, and each channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GrossErrorHealth {
    /// Sequence gaps the gates bridged (continued across).
    pub gaps_bridged: u64,
    /// Sequence gaps long enough to restart the gates.
    pub gaps_reset: u64,
    /// Samples held back while an event that touches them was judged.
    pub held_samples: u64,
    /// Longest such hold, samples.
    pub longest_hold: u64,
    /// Stale repeats of the previous sample (given the verdicts of the one they repeat).
    pub repeats: u64,
    /// Per channel, `gx` … `az` (a map keyed by channel name in JSON).
    #[serde(serialize_with = "crate::stage::health::by_channel")]
    pub channels: [GateChannelHealth; N_CHANNELS],
}

impl GrossErrorHealth {
    /// Every counter, named as the summary prints it: the stage's, then each enabled channel's
    /// as `<channel>.<counter>`.
    pub fn counters(&self, f: &mut dyn FnMut(&str, u64)) {
        f("gaps_bridged", self.gaps_bridged);
        f("gaps_reset", self.gaps_reset);
        f("held_samples", self.held_samples);
        f("longest_hold", self.longest_hold);
        f("repeats", self.repeats);
        for (name, ch) in CHANNEL_NAMES.iter().zip(&self.channels) {
            if ch.state == GateState::Disabled {
                continue;
            }
            for (k, v) in ch.counters.named() {
                f(&format!("{name}.{k}"), v);
            }
        }
    }

    /// The channels' counters summed.
    pub fn totals(&self) -> ChannelCounters {
        let mut t = ChannelCounters::default();
        for ch in &self.channels {
            t.add(&ch.counters);
        }
        t
    }
}

impl GrossErrorStage {
    /// Health now (module [`crate::stage::health`]).
    pub fn health(&self) -> GrossErrorHealth {
        GrossErrorHealth {
            gaps_bridged: self.gaps_bridged,
            gaps_reset: self.gaps_reset,
            held_samples: self.delayed,
            longest_hold: self.max_delay,
            repeats: self.repeats,
            channels: std::array::from_fn(|c| {
                let g = &self.ch[c].gate;
                let k = g.counters;
                GateChannelHealth {
                    state: g.mode.into(),
                    model_order: g.model.as_ref().map(|m| [m.p, m.d, m.q]),
                    // A channel that never warmed up but has a model was given it.
                    model_given: g.model.is_some() && k.warmup == 0,
                    sigma: g.sigma(),
                    counters: k,
                }
            }),
        }
    }
}
