//! Synchronous per-sample stages and the [`Pipeline`] that runs them in order.
//!
//! A stage is plain Rust: no I/O, no clock reads (time arrives in the sample), no allocation and
//! no `tracing` per sample. Health is read from it at report intervals through [`Stage::counters`].

pub mod bias;
pub mod bias_kf;
pub mod bias_settings;
pub mod build;
pub mod cusum;
pub mod gross_error;
pub mod line_canceller;
pub mod stillness;
pub mod temperature;

use crate::sample::Sample;

/// One synchronous processing step.
pub trait Stage: Send {
    /// Short name used in health reports (`gross_error`, `bias`, ...).
    fn name(&self) -> &'static str;
    /// Process one sample and return it (corrected, flagged).
    fn process(&mut self, s: Sample) -> Sample;
    /// Named counters for the health report; called at report intervals, never per sample.
    fn counters(&self) -> Vec<(String, u64)> {
        Vec::new()
    }
}

/// An ordered list of stages; `process` threads a sample through all of them.
#[derive(Default)]
pub struct Pipeline {
    stages: Vec<Box<dyn Stage>>,
}

impl Pipeline {
    pub fn new(stages: Vec<Box<dyn Stage>>) -> Self {
        Pipeline { stages }
    }

    /// A pipeline with no stages: samples pass through unchanged.
    pub fn pass_through() -> Self {
        Pipeline::default()
    }

    #[inline]
    pub fn process(&mut self, mut s: Sample) -> Sample {
        for st in self.stages.iter_mut() {
            s = st.process(s);
        }
        s
    }

    pub fn stage_names(&self) -> Vec<&'static str> {
        self.stages.iter().map(|s| s.name()).collect()
    }

    /// All stages' counters, keyed `stage.counter`.
    pub fn counters(&self) -> Vec<(String, u64)> {
        let mut out = Vec::new();
        for st in &self.stages {
            for (k, v) in st.counters() {
                out.push((format!("{}.{}", st.name(), k), v));
            }
        }
        out
    }
}
