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
    /// Offset alarm threshold, in the channel's own learned RMS of a window mean: on a gyro the
    /// bar is the Student-t quantile at the normal's tail beyond this many σ, with the degrees of
    /// freedom that RMS is learned from (11.2 σ at 10, 5.3 at 100 for 5); on an accelerometer,
    /// this many σ of the change of its median level from a reference level before it, which
    /// must hold for half a window of tests (docs/model-health.md).
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
    /// Whether the wander test runs. Off by default: on the real ADIS16405 bench's
    /// accelerometers it raises 4.3 (`allan_ratio`) or 5.8 (`block_variance`) alarms per hour,
    /// each on a real 3-axis excursion of the sensor that `diagnose`'s model does not remove,
    /// above the 1 per hour the issue allows; none on clean simulated benches, the MPU6050 or
    /// the gyros (docs/model-health.md).
    pub wander: bool,
    /// Block over which still output is averaged for the wander test, s (its short Allan τ).
    pub wander_block_s: f64,
    /// Window of block means whose Allan slope is tested, s.
    pub wander_window_s: f64,
    /// The long Allan τ compared with the short one, s (a multiple of `wander_block_s`, at most
    /// half the window; also how often the test runs).
    pub wander_tau_s: f64,
    /// False-alarm probability of one wander test (sets the F-quantile bar).
    pub wander_p: f64,
    /// The wander test's statistic (see [`WanderStatistic`]).
    pub wander_statistic: WanderStatistic,
    /// Whether the whiteness (Ljung–Box) test runs. Off by default: on the real ADIS16405
    /// bench its accelerometers raise 1.44 alarms per hour (half at their intermittent ≈ 0.5 Hz
    /// line's strongest, an effect the line test already reported), above the 1 per hour the
    /// issue allows; none on clean simulated benches (docs/model-health.md).
    pub whiteness: bool,
    /// Segment about whose own mean the whiteness test's output is taken, s (slower content is
    /// the wander and offset tests' business).
    pub whiteness_segment_s: f64,
    /// Block of the whiteness test's window, s (the test runs once per block).
    pub whiteness_block_s: f64,
    /// Window of full-rate still output whose autocorrelations are tested, s (a multiple of
    /// `whiteness_block_s`).
    pub whiteness_window_s: f64,
    /// Lags 1..=this many samples summed in the Ljung–Box statistic.
    pub whiteness_lags: usize,
    /// False-alarm probability of one whiteness test (sets the F-quantile bar).
    pub whiteness_p: f64,
}

/// What the wander test compares with the channel's own no-effect value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WanderStatistic {
    /// `m·A(m·b)/A(b)`: the Allan variance's slope between the block and `wander_tau_s` (scale
    /// free: the window's own `A(b)` is the reference).
    AllanRatio,
    /// The variance of the window's `wander_tau_s` means about their mean, against the
    /// channel's learned value (the reference is the channel's own level: ~7× more power on a
    /// Gauss–Markov wander of the size `diagnose` finds, docs/model-health.md).
    BlockVariance,
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
            wander: false,
            wander_block_s: 1.0,
            wander_window_s: 120.0,
            wander_tau_s: 8.0,
            wander_p: 1e-5,
            wander_statistic: WanderStatistic::AllanRatio,
            whiteness: false,
            whiteness_segment_s: 1.0,
            whiteness_block_s: 15.0,
            whiteness_window_s: 90.0,
            whiteness_lags: 10,
            whiteness_p: 1e-5,
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
            ("wander_block_s", self.wander_block_s, 0.01, 60.0),
            ("wander_window_s", self.wander_window_s, 0.05, 3600.0),
            ("wander_tau_s", self.wander_tau_s, 0.02, 1800.0),
            ("wander_p", self.wander_p, 1e-12, 0.01),
            ("whiteness_segment_s", self.whiteness_segment_s, 0.01, 60.0),
            ("whiteness_block_s", self.whiteness_block_s, 0.1, 600.0),
            ("whiteness_window_s", self.whiteness_window_s, 0.1, 3600.0),
            ("whiteness_p", self.whiteness_p, 1e-12, 0.01),
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
        if self.wander_tau_s < 2.0 * self.wander_block_s
            || 2.0 * self.wander_tau_s >= self.wander_window_s
        {
            e.push(format!(
                "wander_tau_s = {} must be at least 2 × wander_block_s = {} and under half of \
                 wander_window_s = {}",
                self.wander_tau_s, self.wander_block_s, self.wander_window_s
            ));
        }
        if self.whiteness_window_s < self.whiteness_block_s {
            e.push(format!(
                "whiteness_window_s = {} must be at least whiteness_block_s = {}",
                self.whiteness_window_s, self.whiteness_block_s
            ));
        }
        if !(1..=200).contains(&self.whiteness_lags) {
            e.push(format!(
                "whiteness_lags = {} must be in [1, 200]",
                self.whiteness_lags
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
