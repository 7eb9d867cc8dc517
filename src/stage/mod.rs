//! Synchronous per-sample stages and the [`Pipeline`] that runs them in order.
//!
//! A stage is plain Rust: no I/O, no clock reads (time arrives in the sample), no allocation and
//! no `tracing` per sample. One entry point, [`Stage::push`] (with [`Stage::flush`] at the end of
//! the input); a [`Pipeline`] is itself a stage. Health is read at report intervals through
//! [`Stage::health`] (typed, one struct per stage: [`health`]).

pub mod bias;
pub mod build;
pub mod gross_error;
pub mod health;
pub mod monitor;

use crate::sample::Sample;
use crate::stage::health::{PipelineHealth, StageHealth};

/// One synchronous processing step.
pub trait Stage: Send {
    /// Short name used in health reports (`gross_error`, `bias`, ...).
    fn name(&self) -> &'static str;
    /// One sample in: append to `out` the samples that are now final, oldest first — the one
    /// entry point. A stage with a look-ahead of `L` samples holds the last `L` and emits each
    /// once `L` newer ones have been seen, so it may revise what it did to a held sample;
    /// [`Stage::flush`] emits the held ones at the end of the input. Without a look-ahead, one
    /// sample in, the same one out.
    fn push(&mut self, s: Sample, out: &mut Vec<Sample>);
    /// End of input: append the samples still held by [`Stage::push`], oldest first.
    fn flush(&mut self, _out: &mut Vec<Sample>) {}
    /// Look-ahead of [`Stage::push`], in samples (the output's lag behind the input).
    fn lookahead(&self) -> usize {
        0
    }
    /// Typed health (counters since the start, state now); called at report intervals, never
    /// per sample.
    fn health(&self) -> StageHealth {
        StageHealth::Silent
    }
    /// Whether the stage changes samples (a monitor only watches them).
    fn cleans(&self) -> bool {
        true
    }
}

/// An ordered list of stages; `push` threads a sample through all of them.
#[derive(Default)]
pub struct Pipeline {
    stages: Vec<Box<dyn Stage>>,
    /// Sum of the stages' look-aheads: the output's lag behind the input, in samples.
    lookahead: usize,
    /// Scratch buffers of `push`/`flush` (reused: no allocation per sample once grown).
    a: Vec<Sample>,
    b: Vec<Sample>,
}

impl Pipeline {
    pub fn new(stages: Vec<Box<dyn Stage>>) -> Self {
        let lookahead = stages.iter().map(|s| s.lookahead()).sum();
        Pipeline {
            stages,
            lookahead,
            a: Vec::with_capacity(8),
            b: Vec::with_capacity(8),
        }
    }

    /// A pipeline with no stages: samples pass through unchanged.
    pub fn pass_through() -> Self {
        Pipeline::default()
    }

    /// The output's lag behind the input, in samples (0: every `push` emits its own sample).
    pub fn lookahead(&self) -> usize {
        self.lookahead
    }

    /// One sample in; append to `out` the samples that are final now, oldest first (exactly
    /// one when no stage looks ahead). Together with [`Pipeline::flush`] every sample comes out
    /// once, in order.
    #[inline]
    pub fn push(&mut self, s: Sample, out: &mut Vec<Sample>) {
        self.a.clear();
        self.a.push(s);
        self.through(0, out);
    }

    /// End of input: append every sample still held by a stage, oldest first.
    pub fn flush(&mut self, out: &mut Vec<Sample>) {
        for i in 0..self.stages.len() {
            self.a.clear();
            self.stages[i].flush(&mut self.a);
            self.through(i + 1, out);
        }
    }

    /// The samples in `self.a` through stages `from..`, then appended to `out`.
    fn through(&mut self, from: usize, out: &mut Vec<Sample>) {
        for st in self.stages[from..].iter_mut() {
            if self.a.is_empty() {
                return;
            }
            self.b.clear();
            for s in self.a.drain(..) {
                st.push(s, &mut self.b);
            }
            std::mem::swap(&mut self.a, &mut self.b);
        }
        out.append(&mut self.a);
    }

    pub fn stage_names(&self) -> Vec<&'static str> {
        self.stages.iter().map(|s| s.name()).collect()
    }

    /// The stages that change samples, in order (a monitor watches only).
    pub fn cleaning_stage_names(&self) -> Vec<&'static str> {
        self.stages
            .iter()
            .filter(|s| s.cleans())
            .map(|s| s.name())
            .collect()
    }

    /// Every stage's health.
    pub fn health(&self) -> PipelineHealth {
        let mut h = PipelineHealth::default();
        for st in &self.stages {
            h.add(st.health());
        }
        h
    }
}

/// The pipeline is itself a stage: stages compose.
impl Stage for Pipeline {
    fn name(&self) -> &'static str {
        "pipeline"
    }
    fn push(&mut self, s: Sample, out: &mut Vec<Sample>) {
        Pipeline::push(self, s, out)
    }
    fn flush(&mut self, out: &mut Vec<Sample>) {
        Pipeline::flush(self, out)
    }
    fn lookahead(&self) -> usize {
        self.lookahead
    }
    fn health(&self) -> StageHealth {
        StageHealth::Pipeline(Pipeline::health(self))
    }
}

/// A whole recording through a stage (or a [`Pipeline`]), its look-ahead included: one output
/// per input, in order.
pub fn run_through(stage: &mut dyn Stage, samples: &[Sample]) -> Vec<Sample> {
    let mut out = Vec::with_capacity(samples.len());
    for s in samples {
        stage.push(*s, &mut out);
    }
    stage.flush(&mut out);
    out
}
