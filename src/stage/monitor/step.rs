//! An offset the bias model does not explain: the mean of the pipeline's output over a window
//! at rest, against the channel's own history of that mean.
//!
//! At rest the bias stage's output is its innovation — the measurement minus the predicted bias
//! and every modelled effect — so its mean over a window of `W` seconds is zero while the model
//! holds, with a spread that depends on the noise's colour and on how the model tracks
//! (white noise, flicker, the estimate's own lag). The detector keeps block means of `B` seconds
//! over contiguous still data, the mean `m` of the last `W/B` blocks, and learns `E[m²]` from
//! the channel's own still data (every window that raised no alarm). It raises an alarm when
//! `|m| ≥ k · √E[m²]`: a step, a drift or an effect the model lacks. For a step `s` under the
//! default model (a random-walk bias with time constant `T`), the output carries
//! `s·exp(−t/T)` and the window's mean peaks at `s·(T/W)(1 − e^{−W/T})` (0.63 s for W = T):
//! the same signal-to-noise as comparing two raw windows, without needing the raw bias. The
//! alarm holds (hysteresis: until `|m|` falls below half the threshold), so a step is one event
//! and a ramp is one event with a duration.

use super::learn::{Bridge, Delayed};
use std::collections::VecDeque;

/// One alarm of the level detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelEvent {
    /// Sensor time of the start of the window that raised the alarm, ns (the effect began
    /// within it, or before it when it grew slowly).
    pub t_ns: u64,
    /// The window's mean output, channel unit: the offset the model does not explain.
    pub offset: f64,
    /// `|m| / √E[m²]` at the alarm.
    pub z: f64,
}

/// Means of consecutive blocks of `n` values, each with the time of its first value.
#[derive(Debug, Clone)]
pub struct BlockMean {
    /// Values per block.
    pub n: usize,
    sum: f64,
    count: usize,
    start_ns: u64,
}

impl BlockMean {
    pub fn new(n: usize) -> Self {
        BlockMean {
            n: n.max(1),
            sum: 0.0,
            count: 0,
            start_ns: 0,
        }
    }

    /// Whether a block is partly filled.
    pub fn partial(&self) -> bool {
        self.count > 0
    }

    /// Drops the partly filled block.
    pub fn reset(&mut self) {
        self.sum = 0.0;
        self.count = 0;
    }

    /// One value; the block's mean and start time when it completes one.
    pub fn push(&mut self, t_ns: u64, v: f64) -> Option<(f64, u64)> {
        if self.count == 0 {
            self.start_ns = t_ns;
        }
        self.sum += v;
        self.count += 1;
        if self.count < self.n {
            return None;
        }
        let mean = self.sum / self.count as f64;
        self.reset();
        Some((mean, self.start_ns))
    }
}

/// Level-change detector of one channel.
#[derive(Debug, Clone)]
pub struct LevelDetector {
    window_blocks: usize,
    k: f64,
    learn_blocks: usize,
    // Current block.
    block: BlockMean,
    // Contiguous still blocks: (mean, start time).
    blocks: VecDeque<(f64, u64)>,
    // Window means not yet learned from: each waits two windows, and is dropped if an alarm
    // comes meanwhile (the rise of a step must not teach the detector that steps are ordinary).
    pending: Delayed<(f64, f64)>,
    // Learned E[m²], and E[b²] of single block means (12× the independent samples: with
    // E[b²]/W it gives a floor for E[m²] — exact for white noise — while E[m²] itself, which
    // also holds the slower noise, is still uncertain).
    b2_sum: f64,
    m2_sum: f64,
    m2_n: u64,
    still_blocks: u64,
    bridge: Bridge,
    active: bool,
    pub events: u64,
}

impl LevelDetector {
    /// `block_n` samples per block, `window_blocks` blocks per window, alarm at `k` σ, armed
    /// after `learn_blocks` still blocks (and at least `window_blocks` windows) were seen; up
    /// to `bridge_n` skipped samples in a row are bridged ([`LevelDetector::skip`]).
    pub fn new(
        block_n: usize,
        window_blocks: usize,
        k: f64,
        learn_blocks: usize,
        bridge_n: usize,
    ) -> Self {
        LevelDetector {
            window_blocks: window_blocks.max(1),
            k,
            learn_blocks,
            block: BlockMean::new(block_n),
            blocks: VecDeque::with_capacity(window_blocks + 1),
            pending: Delayed::new(2 * window_blocks.max(1)),
            b2_sum: 0.0,
            m2_sum: 0.0,
            m2_n: 0,
            still_blocks: 0,
            bridge: Bridge::new(bridge_n),
            active: false,
            events: 0,
        }
    }

    /// Whether the detector has learned enough of the channel to raise alarms.
    pub fn armed(&self) -> bool {
        self.still_blocks >= self.learn_blocks as u64 && self.m2_n >= self.window_blocks as u64
    }

    /// Whether an alarm is holding now.
    pub fn active(&self) -> bool {
        self.active
    }

    /// The learned root-mean-square of a window's mean (channel unit), once any.
    pub fn window_sd(&self) -> Option<f64> {
        (self.m2_n > 0).then(|| {
            let n = self.m2_n as f64;
            (self.m2_sum / n)
                .max(self.b2_sum / n / self.window_blocks as f64)
                .sqrt()
        })
    }

    /// Windows learned from so far, and how many arming needs.
    pub fn learned_windows(&self) -> (u64, usize) {
        (self.m2_n, self.window_blocks)
    }

    /// A sample that cannot be used (not judged still, a replaced or bad value): left out of
    /// the block, and the run goes on, unless more than the bridge is skipped in a row — then
    /// the run is broken ([`LevelDetector::interrupt`]).
    pub fn skip(&mut self) {
        if self.bridge.skip() {
            self.interrupt();
        }
    }

    /// The contiguous run of still data was broken (motion, a gap, more than the bridge
    /// skipped).
    pub fn interrupt(&mut self) {
        self.bridge.reset();
        self.block.reset();
        self.blocks.clear();
        self.active = false;
    }

    /// One still value; returns an alarm when one is raised.
    pub fn push(&mut self, t_ns: u64, v: f64) -> Option<LevelEvent> {
        self.bridge.reset();
        let (mean, start) = self.block.push(t_ns, v)?;
        self.still_blocks += 1;
        let w = self.window_blocks;
        if self.blocks.len() == w {
            self.blocks.pop_front();
        }
        self.blocks.push_back((mean, start));
        if self.blocks.len() < w {
            return None;
        }
        let m = self.blocks.iter().map(|b| b.0).sum::<f64>() / w as f64;
        let armed = self.armed();
        let sd = self.window_sd().unwrap_or(0.0);
        let z = if sd > 0.0 { m.abs() / sd } else { 0.0 };
        // Learn from windows that raised no alarm, two windows late (see `pending`), and not
        // while an alarm holds.
        if !self.active
            && (!armed || z < self.k)
            && let Some((m2, b2)) = self.pending.offer((m * m, mean * mean))
        {
            self.m2_sum += m2;
            self.b2_sum += b2;
            self.m2_n += 1;
        }
        if !armed {
            return None;
        }
        if self.active {
            if z < 0.5 * self.k {
                self.active = false;
            }
            return None;
        }
        if z >= self.k {
            self.active = true;
            self.events += 1;
            self.pending.drop_pending();
            return Some(LevelEvent {
                t_ns: self.blocks[0].1,
                offset: m,
                z,
            });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::stage::monitor::test_signals::{FS, feed};

    fn run(det: &mut LevelDetector, xs: &[f64]) -> Vec<LevelEvent> {
        feed(xs, 0, |t, x| det.push(t, x))
    }

    fn noise(seed: u64, n: usize, sd: f64) -> Vec<f64> {
        let mut r = Rng::new(seed);
        (0..n).map(|_| sd * r.normal()).collect()
    }

    /// The default bias model's output after a step `s` at sample `at`: `s·exp(−t/T)`.
    fn add_transient(xs: &mut [f64], at: usize, s: f64, t_c: f64) {
        for (i, x) in xs.iter_mut().enumerate().skip(at) {
            *x += s * (-((i - at) as f64) / (t_c * FS)).exp();
        }
    }

    #[test]
    fn white_noise_raises_no_alarm_and_a_step_one() {
        // 2 h of white noise at 100 Hz, 5-s blocks, 60-s windows, alarm at 5 σ: the window
        // mean is Gaussian, tested every 5 s (1440 correlated tests), P(|Z| ≥ 5) ≈ 6e-7.
        let mut det = LevelDetector::new(500, 12, 5.0, 60, 100);
        let xs = noise(7, 720_000, 0.006);
        assert!(run(&mut det, &xs).is_empty());
        // σ of a 60-s mean = 0.006/√6000 = 7.7e-5; learned from 1429 overlapping windows
        // (≈ 120 independent): within 15 %.
        let sd = det.window_sd().unwrap();
        assert!((sd / 7.75e-5 - 1.0).abs() < 0.15, "{sd}");
        // A step of 10 σ of a window mean leaving a 60-s transient, 20 min after the start:
        // one alarm, within 60 s, its offset between 0.5 and 1 of the step.
        let mut det = LevelDetector::new(500, 12, 5.0, 60, 100);
        let mut xs = noise(8, 240_000, 0.006);
        add_transient(&mut xs, 120_000, 7.75e-4, 60.0);
        let ev = run(&mut det, &xs);
        assert_eq!(ev.len(), 1, "{ev:?}");
        let t_end = ev[0].t_ns as f64 * 1e-9 + 60.0;
        assert!((1200.0..=1260.0).contains(&t_end), "raised at {t_end} s");
        assert!(
            ev[0].offset > 0.5 * 7.75e-4 && ev[0].offset < 7.75e-4,
            "{:?}",
            ev[0]
        );
    }

    #[test]
    fn short_skips_are_bridged_and_a_long_one_restarts_the_run() {
        // Blocks of 100, windows of 4 blocks, bridge 10: two samples skipped every 150 (a
        // stillness dropout or a replaced sample) leave the run whole, so 60 still blocks arm
        // the detector as without skips; 11 in a row restart the window (no alarm on a 1.0
        // offset until four fresh blocks are in).
        let mut det = LevelDetector::new(100, 4, 5.0, 50, 10);
        let xs = noise(13, 6_000, 0.01);
        for (i, &x) in xs.iter().enumerate() {
            if i % 150 == 0 {
                det.skip();
                det.skip();
            }
            det.push(i as u64 * 10_000_000, x);
        }
        assert!(det.armed(), "{:?}", det.learned_windows());
        for _ in 0..11 {
            det.skip();
        }
        let xs: Vec<f64> = noise(14, 399, 0.01).iter().map(|x| x + 1.0).collect();
        assert!(run(&mut det, &xs).is_empty());
        assert_eq!(run(&mut det, &[1.0]).len(), 1);
    }

    #[test]
    fn not_armed_until_learned_and_interrupt_restarts_the_run() {
        let mut det = LevelDetector::new(100, 4, 5.0, 50, 100);
        let xs = noise(9, 4_000, 0.01);
        run(&mut det, &xs);
        assert!(!det.armed(), "40 blocks < 50");
        let xs = noise(10, 2_000, 0.01);
        run(&mut det, &xs);
        assert!(det.armed());
        det.interrupt();
        // After an interruption the window starts again: no alarm before it is full.
        let xs: Vec<f64> = noise(11, 399, 0.01).iter().map(|x| x + 1.0).collect();
        assert!(run(&mut det, &xs).is_empty());
        let xs: Vec<f64> = noise(12, 1, 0.01).iter().map(|x| x + 1.0).collect();
        assert_eq!(run(&mut det, &xs).len(), 1);
    }
}
