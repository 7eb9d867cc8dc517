//! Typed health of the stages: what each stage counted since the run started and the state it
//! is in now (warming up, engaged, which model), read at report intervals — never per sample.
//!
//! In the spirit of x-io Fusion's flags and PX4's `vehicle_imu_status`: named fields with units,
//! one struct per stage ([`GrossErrorHealth`], [`BiasHealth`]), gathered by the [`Pipeline`]
//! into a [`PipelineHealth`]. It is serialised whole into the JSON summary (`stages`), folded
//! into the flat counters of the health frame and JSON-lines health record
//! (`runtime::Health::frame`), and printed as the summary's `stages` line
//! ([`PipelineHealth::nonzero_counters`]).
//!
//! [`Pipeline`]: crate::stage::Pipeline

use serde::Serialize;

use crate::frame::health::HealthFrame;
use crate::sample::{CHANNEL_NAMES, N_CHANNELS};
pub use crate::stage::bias::health::{BiasChannelHealth, BiasChannelState, BiasHealth};
pub use crate::stage::gross_error::health::{GateChannelHealth, GateState, GrossErrorHealth};
pub use crate::stage::monitor::MonitorHealth;

/// Defines a struct of `u64` counters from one list of fields, with `named()` (every counter
/// with its field name, in declaration order: the order the summary prints them) and `add()`
/// (the element-wise sum), so neither can drift from the fields.
macro_rules! counters {
    ($(#[$attr:meta])* pub struct $name:ident { $($(#[$doc:meta])* $field:ident),+ $(,)? }) => {
        $(#[$attr])*
        pub struct $name {
            $($(#[$doc])* pub $field: u64,)+
        }

        impl $name {
            /// Every counter, named as the summary prints it, in declaration order.
            pub fn named(&self) -> [(&'static str, u64); [$(stringify!($field)),+].len()] {
                [$((stringify!($field), self.$field)),+]
            }

            /// Element-wise sum (stage totals over channels).
            pub fn add(&mut self, o: &Self) {
                $(self.$field += o.$field;)+
            }
        }
    };
}
pub(crate) use counters;

/// The health of one stage, as [`crate::stage::Stage::health`] returns it.
// Built once per health report, never per sample: its size costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum StageHealth {
    /// A stage that reports nothing.
    Silent,
    GrossError(GrossErrorHealth),
    Bias(BiasHealth),
    Monitor(MonitorHealth),
    /// A pipeline nested as a stage.
    Pipeline(PipelineHealth),
}

/// The health of every stage of a pipeline; `None`: that stage is not in the pipeline.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PipelineHealth {
    pub gross_error: Option<GrossErrorHealth>,
    pub bias: Option<BiasHealth>,
    pub monitor: Option<MonitorHealth>,
}

impl PipelineHealth {
    /// Take one stage's health into its slot (a nested pipeline's slots are taken one by one).
    pub fn add(&mut self, h: StageHealth) {
        match h {
            StageHealth::Silent => {}
            StageHealth::GrossError(g) => self.gross_error = Some(g),
            StageHealth::Bias(b) => self.bias = Some(b),
            StageHealth::Monitor(m) => self.monitor = Some(m),
            StageHealth::Pipeline(p) => {
                if p.monitor.is_some() {
                    self.monitor = p.monitor;
                }
                if p.gross_error.is_some() {
                    self.gross_error = p.gross_error;
                }
                if p.bias.is_some() {
                    self.bias = p.bias;
                }
            }
        }
    }

    /// Every counter of every stage present, keyed `stage.counter` (gross-error channel counters
    /// `gross_error.<channel>.counter`, enabled channels only), in a fixed order; the summary
    /// prints the non-zero ones.
    pub fn counters(&self) -> Vec<(String, u64)> {
        let mut out = Vec::new();
        if let Some(g) = &self.gross_error {
            g.counters(&mut |k, v| out.push((format!("gross_error.{k}"), v)));
        }
        if let Some(b) = &self.bias {
            b.counters(&mut |k, v| out.push((format!("bias.{k}"), v)));
        }
        if let Some(m) = &self.monitor {
            for (k, v) in [
                ("offset_alarms", m.offset_alarms),
                ("line_alarms", m.line_alarms),
                ("wander_alarms", m.wander_alarms),
                ("whiteness_alarms", m.whiteness_alarms),
                ("armed_channels", m.armed_channels),
                ("still_samples", m.still_samples),
            ] {
                out.push((format!("monitor.{k}"), v));
            }
        }
        out
    }

    /// The stage fields of the health frame (version 2, `docs/frame-format.md`); every other
    /// field 0.
    pub fn frame_fields(&self) -> HealthFrame {
        use crate::frame::health::stage_flags as sf;
        let mut f = HealthFrame::default();
        if let Some(g) = &self.gross_error {
            f.stage_flags |= sf::GROSS_ERROR
                | channel_mask(&g.channels, |c| c.state == GateState::Active) << sf::GATE_ACTIVE
                | channel_mask(&g.channels, |c| c.state == GateState::WarmingUp)
                    << sf::GATE_WARMING;
            f.gross_error_events = g.totals().runs;
        }
        if let Some(b) = &self.bias {
            f.stage_flags |= sf::BIAS
                | if b.still { sf::STILL } else { 0 }
                | channel_mask(&b.channels, |c| c.state == BiasChannelState::Estimating)
                    << sf::BIAS_ESTIMATING
                | channel_mask(&b.channels, |c| c.state.warming_up()) << sf::BIAS_WARMING;
            f.bias_updates = b.counters.bias_updates;
            f.bias_rejected_updates = b.counters.rejected_updates;
        }
        if let Some(m) = &self.monitor {
            f.model_alarms = m.offset_alarms + m.line_alarms + m.wander_alarms + m.whiteness_alarms;
        }
        f
    }

    /// The stages' state now, for the interval log line: `ge_active=… ge_warming=…
    /// bias_est=… bias_warming=… still=0|1`, channel lists (`-`: none); empty without stages.
    pub fn state_line(&self) -> String {
        fn list<T>(v: &[T; N_CHANNELS], pred: impl Fn(&T) -> bool) -> String {
            let names: Vec<&str> = CHANNEL_NAMES
                .iter()
                .zip(v)
                .filter(|(_, x)| pred(x))
                .map(|(n, _)| *n)
                .collect();
            if names.is_empty() {
                "-".into()
            } else {
                names.join(",")
            }
        }
        let mut parts = Vec::new();
        if let Some(g) = &self.gross_error {
            parts.push(format!(
                "ge_active={} ge_warming={}",
                list(&g.channels, |c| c.state == GateState::Active),
                list(&g.channels, |c| c.state == GateState::WarmingUp)
            ));
        }
        if let Some(b) = &self.bias {
            parts.push(format!(
                "bias_est={} bias_warming={} still={}",
                list(&b.channels, |c| c.state == BiasChannelState::Estimating),
                list(&b.channels, |c| c.state.warming_up()),
                u8::from(b.still)
            ));
        }
        parts.join(" ")
    }

    /// The summary's `stages` line: `key=value` for every non-zero counter, space-separated.
    pub fn nonzero_counters(&self) -> String {
        self.counters()
            .into_iter()
            .filter(|(_, v)| *v != 0)
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// One value per channel, serialised as a map keyed by channel name (`{"gx": …, …}`).
pub(crate) fn by_channel<T: Serialize, S: serde::Serializer>(
    v: &[T; N_CHANNELS],
    s: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut m = s.serialize_map(Some(N_CHANNELS))?;
    for (name, x) in CHANNEL_NAMES.iter().zip(v) {
        m.serialize_entry(name, x)?;
    }
    m.end()
}

/// Bit `c` set for each channel `c` (0..6, `gx` … `az`) where `pred` holds.
fn channel_mask<T>(v: &[T; N_CHANNELS], pred: impl Fn(&T) -> bool) -> u64 {
    v.iter()
        .enumerate()
        .filter(|(_, x)| pred(x))
        .fold(0, |m, (c, _)| m | 1 << c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::health::stage_flags as sf;
    use crate::rng::Rng;
    use crate::sample::Sample;
    use crate::stage::bias::BiasStage;
    use crate::stage::bias::settings::BiasSettings;
    use crate::stage::gross_error::{GrossErrorSettings, GrossErrorStage};
    use crate::stage::{Pipeline, Stage};

    /// Still noise at 100 Hz (the bias stage's default rate), gravity on z, seeded.
    fn still(rng: &mut Rng, from: u32, n: u32) -> Vec<Sample> {
        (from..from + n)
            .map(|i| {
                let mut s = Sample {
                    seq: i,
                    t_ns: u64::from(i) * 10_000_000,
                    ..Sample::default()
                };
                let g = [0.01, -0.02, 0.005, 0.1, -0.1, 9.8];
                for (c, m) in g.iter().enumerate() {
                    let sd = if c < 3 { 1e-3 } else { 2e-2 };
                    s.set_channel(c, m + sd * rng.normal());
                }
                s
            })
            .collect()
    }

    fn pipeline() -> Pipeline {
        let ge = GrossErrorStage::new(GrossErrorSettings::default(), None).unwrap();
        let b = BiasStage::new(BiasSettings::default(), None).unwrap();
        Pipeline::new(vec![Box::new(ge), Box::new(b)])
    }

    /// Gross-error warm-up samples of gx at 100 Hz: the 2000-sample window, then
    /// `identify_defer_s` = 0.5 s (50 samples) while the worker identifies the model; channel
    /// c takes its model over c samples later still (one take-over per call).
    const WARMUP: u64 = 2050;

    #[test]
    fn health_follows_the_stages_from_warm_up_to_engaged() {
        let mut rng = Rng::new(16);
        let mut p = pipeline();
        let mut out = Vec::new();
        // Before any sample: both stages present, every gate and gyro channel warming up.
        let h = p.health();
        let (g, b) = (h.gross_error.unwrap(), h.bias.unwrap());
        assert!(g.channels.iter().all(|c| c.state == GateState::WarmingUp));
        assert_eq!(b.channels[0].state, BiasChannelState::WarmingUp);
        assert_eq!(b.channels[3].state, BiasChannelState::CalibrationOnly);
        let f = h.frame_fields();
        assert_eq!(f.stage_flags & 3, sf::GROSS_ERROR | sf::BIAS);
        assert_eq!((f.stage_flags >> sf::GATE_WARMING) & 0x3f, 0x3f);
        assert_eq!((f.stage_flags >> sf::BIAS_WARMING) & 0x3f, 0x07);
        assert_eq!((f.stage_flags >> sf::BIAS_ESTIMATING) & 0x3f, 0);

        // 30 s still: past the gates' 2000-sample warm-up and the bias warm-up stretch.
        for s in still(&mut rng, 0, 3000) {
            p.push(s, &mut out);
        }
        p.flush(&mut out);
        assert_eq!(out.len(), 3000);
        let h = p.health();
        let (g, b) = (h.gross_error.unwrap(), h.bias.unwrap());
        for (i, c) in g.channels.iter().enumerate() {
            assert_eq!(c.state, GateState::Active);
            assert!(c.model_order.is_some() && !c.model_given && c.sigma.is_some());
            assert_eq!(c.counters.warmup, WARMUP + i as u64);
        }
        for c in &b.channels[..3] {
            assert_eq!(c.state, BiasChannelState::Estimating);
            assert_eq!(c.model, crate::stage::bias::health::BiasModelOrigin::WarmUp);
            // The estimate is the channel's mean (0.01, −0.02, 0.005 rad/s) within a few of
            // its own published σ (a mean of ≥ 300 samples of σ 1e-3: σ ≈ 6e-5).
            assert!(c.bias_sd > 0.0 && c.bias_sd < 1e-3);
        }
        assert!((b.channels[1].bias + 0.02).abs() < 5.0 * b.channels[1].bias_sd + 1e-4);
        assert_eq!(b.counters.warmup_fits, 3);
        assert_eq!(b.counters.samples, 3000);
        assert!(b.still && b.counters.still_samples > 2500);
        let f = h.frame_fields();
        assert_eq!((f.stage_flags >> sf::GATE_ACTIVE) & 0x3f, 0x3f);
        assert_eq!((f.stage_flags >> sf::GATE_WARMING) & 0x3f, 0);
        assert_eq!((f.stage_flags >> sf::BIAS_ESTIMATING) & 0x3f, 0x07);
        assert_ne!(f.stage_flags & sf::STILL, 0);
        assert_eq!(f.bias_updates, b.counters.bias_updates);
        assert_eq!(
            h.state_line(),
            "ge_active=gx,gy,gz,ax,ay,az ge_warming=- bias_est=gx,gy,gz bias_warming=- still=1"
        );

        // The summary line: the non-zero counters, stage by stage, channel by channel.
        let line = h.nonzero_counters();
        assert!(line.starts_with("gross_error."), "{line}");
        assert!(
            line.contains(&format!("gross_error.gx.warmup={WARMUP}")),
            "{line}"
        );
        assert!(line.contains("bias.samples=3000 "), "{line}");
        assert!(line.contains("bias.warmup_fits=3"), "{line}");
        assert!(!line.contains("=0 ") && !line.ends_with("=0"), "{line}");

        // The pipeline as a stage reports the same; a nested one fills the same slots.
        let StageHealth::Pipeline(inner) = Stage::health(&p) else {
            panic!("a pipeline reports a pipeline's health")
        };
        assert_eq!(inner, h);
        let outer = Pipeline::new(vec![Box::new(p)]);
        assert_eq!(outer.health(), h);
        // JSON: channels keyed by name, counters flattened beside the state.
        let v = serde_json::to_value(&h).unwrap();
        assert_eq!(v["gross_error"]["channels"]["az"]["state"], "active");
        assert_eq!(v["gross_error"]["channels"]["az"]["warmup"], WARMUP + 5);
        assert_eq!(v["bias"]["channels"]["gx"]["state"], "estimating");
        assert_eq!(v["bias"]["warmup_fits"], 3);
    }

    #[test]
    fn no_stage_no_health() {
        let h = Pipeline::pass_through().health();
        assert_eq!(h, PipelineHealth::default());
        assert_eq!(h.frame_fields(), HealthFrame::default());
        assert_eq!(
            (h.nonzero_counters(), h.state_line()),
            (String::new(), String::new())
        );
    }
}
