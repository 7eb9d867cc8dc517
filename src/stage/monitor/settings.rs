//! Settings of the model-health monitor (`[monitor]` in the daemon config).

use serde::{Deserialize, Serialize};

/// `[monitor.settings]`: every field in seconds or σ, one line each.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MonitorSettings {
    /// Block over which still output is averaged, s.
    pub block_s: f64,
    /// Window whose mean output is tested for an offset the model lacks, s (a multiple of
    /// `block_s`; about the bias model's time constant is where a step shows most).
    pub window_s: f64,
    /// Offset alarm threshold, in the channel's own learned RMS of a window mean.
    pub offset_k: f64,
    /// Still time a channel needs before its offset test is armed, s.
    pub learn_s: f64,
    /// Segment of the moving spectrum, s (rounded up to a power-of-two number of samples).
    pub line_segment_s: f64,
    /// Segments per spectrum average.
    pub line_averages: usize,
    /// Line alarm threshold: a bin's power over its neighbours' median (noise ≈ 1).
    pub line_k: f64,
    /// How long an alarm keeps the status at "effect suspected", s.
    pub hold_s: f64,
}

impl Default for MonitorSettings {
    fn default() -> Self {
        MonitorSettings {
            block_s: 5.0,
            window_s: 60.0,
            offset_k: 5.0,
            learn_s: 300.0,
            line_segment_s: 10.0,
            line_averages: 6,
            line_k: 6.0,
            hold_s: 600.0,
        }
    }
}

impl MonitorSettings {
    /// Every problem, each message starting with its key.
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut e = Vec::new();
        for (name, v, lo, hi) in [
            ("block_s", self.block_s, 0.05, 600.0),
            ("window_s", self.window_s, 0.05, 3600.0),
            ("offset_k", self.offset_k, 2.0, 50.0),
            ("learn_s", self.learn_s, 0.0, 86_400.0),
            ("line_segment_s", self.line_segment_s, 0.1, 600.0),
            ("line_k", self.line_k, 2.0, 1000.0),
            ("hold_s", self.hold_s, 0.0, 86_400.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                e.push(format!("{name} = {v} must be in [{lo}, {hi}]"));
            }
        }
        if self.window_s < self.block_s {
            e.push(format!(
                "window_s = {} must be at least block_s = {}",
                self.window_s, self.block_s
            ));
        }
        if !(1..=64).contains(&self.line_averages) {
            e.push(format!(
                "line_averages = {} must be in [1, 64]",
                self.line_averages
            ));
        }
        if e.is_empty() { Ok(()) } else { Err(e) }
    }
}
