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
//!
//! An accelerometer's output at rest holds gravity's projection on its axis, a level no bias
//! model removes, so its mean is tested against a reference level instead of zero
//! ([`LevelDetector::against_reference`]): the median of the last window's block means minus the
//! median of the `2W` seconds of block means that end one window before that window starts. The
//! medians make it a test of a *persistent* change: the last window's median moves only once
//! half of it (`W/2`) is off, and the reference's is not moved by an excursion filling less than
//! half of it (`W`); an alarm needs `W/2` tests in a row at or above the bar, so the new level
//! has held about a window. The guard of one window keeps a step's pre-step reference in view
//! until `3W` after the step, so the step is tested at full size from `W/2` to `3W` after it.

use super::learn::{Bridge, Delayed};
use crate::stats::robust::median;
use crate::stats::special::normal_sf;
use crate::stats::student_t::student_t_quantile;
use std::collections::VecDeque;

/// One alarm of the level detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelEvent {
    /// Sensor time of the start of the window that raised the alarm, ns (the effect began
    /// within it, or before it when it grew slowly).
    pub t_ns: u64,
    /// The window's mean output, channel unit: the offset the model does not explain (against
    /// a reference level: the change of the level, [`LevelDetector::against_reference`]).
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
    // also holds the slower noise, is still uncertain); against a reference, E[(b_k − b_{k−1})²]
    // (`floor_c`).
    b2_sum: f64,
    m2_sum: f64,
    m2_n: u64,
    still_blocks: u64,
    bridge: Bridge,
    // Reference blocks when tested against a reference level ([`LevelDetector::against_reference`]),
    // 0 against zero.
    reference_blocks: usize,
    // The floor of `E[m²]`: this times the learned mean of the block statistic's square.
    floor_c: f64,
    // Scratch for the medians (no allocation per block).
    scratch: Vec<f64>,
    // Tests in a row at or above the bar that raise an alarm (1 against zero), those seen so
    // far, and the start of the window of the first of them.
    confirm: usize,
    // Learned tests arming needs.
    arm_tests: usize,
    over: usize,
    over_since_ns: u64,
    active: bool,
    pub events: u64,
}

impl LevelDetector {
    /// `block_n` samples per block, `window_blocks` blocks per window, alarm at `k` σ, armed
    /// after `learn_blocks` still blocks (and at least `window_blocks` windows learned from,
    /// `4 × window_blocks` against a reference) were seen; up
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
            reference_blocks: 0,
            floor_c: 1.0 / window_blocks.max(1) as f64,
            scratch: Vec::new(),
            confirm: 1,
            arm_tests: window_blocks.max(1),
            over: 0,
            over_since_ns: 0,
            active: false,
            events: 0,
        }
    }

    /// Tests the change of the level — the median of the last window's block means minus the
    /// median of `2W` of block means ending one window (`W`) before that window starts — not the
    /// mean against zero: for an accelerometer, whose output at rest holds gravity's projection
    /// on its axis (a level that changes with every attitude and that no bias model removes).
    /// Against zero that level enters `E[m²]` and hides any offset smaller than a few times
    /// itself (on the ADIS16405 bench the RMS of az's 60-s mean is 1328× its spread). A test
    /// needs `4W` of unbroken still data. The floor of `E[m²]` is `(π/2)(1/W + 1/2W)` times
    /// the variance of one block mean, `E[(b_k − b_{k−1})²]/2` (the large-sample variance of
    /// a median of white block means; exact neither for small `W` nor for coloured noise, a
    /// floor until the learned value takes over). An alarm needs `W/2` tests in a row at or
    /// above the bar, and the detector arms after `4W` learned tests.
    pub fn against_reference(mut self) -> Self {
        let w = self.window_blocks;
        self.reference_blocks = 2 * w;
        self.floor_c = std::f64::consts::FRAC_PI_2 * (1.0 / w as f64 + 0.5 / w as f64) / 2.0;
        self.blocks = VecDeque::with_capacity(4 * w + 1);
        self.scratch = Vec::with_capacity(2 * w);
        // Confirmed over half a window of tests in a row: the last window's median moves only
        // once half its blocks are off, so a level must hold about `W/2` for `W/2` tests to
        // raise an alarm (an excursion shorter than `W/2` never moves it), longer near the bar.
        self.confirm = (w / 2).max(1);
        // Learned tests: one test's span (`4W`; successive tests are correlated over about
        // that span). With `W` (a quarter of it) a 20-min clean bench armed on a scale learned
        // from one minute of tests and alarmed at 6.1 σ (docs/model-health.md).
        self.arm_tests = 4 * w;
        self
    }

    /// The alarm bar, in learned RMS of a window mean. Against zero: the Student-t quantile at
    /// the normal's tail beyond `k`, with the degrees of freedom of the learned scale — `n`
    /// overlapping windows of `W` blocks, one a block, carry `1.5 n/W` for white noise (the
    /// overlapping estimator's equivalent degrees of freedom; fewer for a wander correlated over
    /// more than a window). A bar of `k` on a scale from a few windows is crossed by chance far
    /// more often than `k` says: restarted at the bias stage's engagement, the plain 5-σ bar
    /// raised 2 alarms in 24 clean 20-min benches, both within a minute of arming
    /// (docs/model-health.md). At `k` = 5: 31.9 at ν = 5, 11.2 at 10, 7.2 at 20, 5.7 at 50,
    /// 5.3 at 100 (about 70 min of still data). Against a reference: `k` (the medians and the
    /// confirmation over half a window of tests guard that test).
    pub fn bar(&self) -> f64 {
        if self.reference_blocks > 0 {
            return self.k;
        }
        let nu = (1.5 * self.m2_n as f64 / self.window_blocks as f64).max(1.0);
        -student_t_quantile(normal_sf(self.k), nu)
    }

    /// Blocks of unbroken still data one test needs.
    pub fn test_blocks(&self) -> usize {
        self.span()
    }

    /// Blocks one test needs: the window, and against a reference the guard and the reference.
    fn span(&self) -> usize {
        if self.reference_blocks > 0 {
            2 * self.window_blocks + self.reference_blocks
        } else {
            self.window_blocks
        }
    }

    /// The median of block means `from..from + n` (oldest first).
    fn median_of(&mut self, from: usize, n: usize) -> f64 {
        self.scratch.clear();
        self.scratch
            .extend(self.blocks.iter().skip(from).take(n).map(|b| b.0));
        if self.scratch.is_empty() {
            0.0
        } else {
            median(&mut self.scratch)
        }
    }

    /// Whether the detector has learned enough of the channel to raise alarms.
    pub fn armed(&self) -> bool {
        self.still_blocks >= self.learn_blocks as u64 && self.m2_n >= self.arm_tests as u64
    }

    /// Whether an alarm is holding now.
    pub fn active(&self) -> bool {
        self.active
    }

    /// The learned root-mean-square of a window's mean (channel unit), once any.
    pub fn window_sd(&self) -> Option<f64> {
        (self.m2_n > 0).then(|| {
            let n = self.m2_n as f64;
            (self.m2_sum / n).max(self.b2_sum / n * self.floor_c).sqrt()
        })
    }

    /// Windows learned from so far, and how many arming needs.
    pub fn learned_windows(&self) -> (u64, usize) {
        (self.m2_n, self.arm_tests)
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
        self.over = 0;
        self.active = false;
    }

    /// One still value; returns an alarm when one is raised.
    pub fn push(&mut self, t_ns: u64, v: f64) -> Option<LevelEvent> {
        self.bridge.reset();
        let (mean, start) = self.block.push(t_ns, v)?;
        self.still_blocks += 1;
        let w = self.window_blocks;
        let span = self.span();
        let before = self.blocks.back().map(|b| b.0);
        if self.blocks.len() == span {
            self.blocks.pop_front();
        }
        self.blocks.push_back((mean, start));
        if self.blocks.len() < span {
            return None;
        }
        // The statistic, and the block-level value whose mean square floors `E[m²]`.
        let (m, mean) = if self.reference_blocks > 0 {
            let recent = self.median_of(span - w, w);
            let reference = self.median_of(0, self.reference_blocks);
            (recent - reference, mean - before.unwrap_or(mean))
        } else {
            (
                self.blocks.iter().map(|b| b.0).sum::<f64>() / w as f64,
                mean,
            )
        };
        let armed = self.armed();
        let bar = self.bar();
        let sd = self.window_sd().unwrap_or(0.0);
        let z = if sd > 0.0 { m.abs() / sd } else { 0.0 };
        // Learn from windows that raised no alarm, two windows late (see `pending`), and not
        // while an alarm holds.
        if !self.active
            && (!armed || z < bar)
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
            if z < 0.5 * bar {
                self.active = false;
            }
            return None;
        }
        if z < bar {
            self.over = 0;
            return None;
        }
        if self.over == 0 {
            self.over_since_ns = self.blocks[span - w].1;
        }
        self.over += 1;
        if self.over < self.confirm {
            return None;
        }
        self.over = 0;
        self.active = true;
        self.events += 1;
        self.pending.drop_pending();
        Some(LevelEvent {
            t_ns: self.over_since_ns,
            offset: m,
            z,
        })
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
    fn the_bar_follows_the_learned_scales_degrees_of_freedom() {
        // Windows of 12 blocks: n learned tests carry ν = 1.5 n/12. The quantiles at the normal's
        // tail beyond 5 σ (2.87e-7), from statrs 0.19.1's `StudentsT::inverse_cdf` (an
        // implementation this crate did not write): 11.17 at ν = 10, 7.20 at 20, 5.34 at 100.
        let mut det = LevelDetector::new(500, 12, 5.0, 60, 100);
        for (n, want) in [(80, 11.17), (160, 7.20), (800, 5.34)] {
            det.m2_n = n;
            assert!((det.bar() - want).abs() < 0.01, "n {n}: {}", det.bar());
        }
        // Against a reference the bar is k.
        let mut det = det.against_reference();
        det.m2_n = 80;
        assert_eq!(det.bar(), 5.0);
    }

    #[test]
    fn against_a_reference_a_level_is_ignored_a_step_flagged_and_an_excursion_not() {
        // 2 h at a level of 9.81 (gravity on the axis) with white noise: against zero the
        // learned scale would be the level itself; against the reference, no alarm in 2 h
        // (1440 tests at 5 σ of a Gaussian-like statistic) and the scale is the noise's:
        // σ of a 60-s median minus a 120-s median of 5-s means, ≈ √(π/2 · (1/6000 + 1/12000))
        // · 0.006 = 1.2e-4 for white noise; learned within 25 % (≈ 30 independent spans).
        let fresh = || LevelDetector::new(500, 12, 5.0, 60, 100).against_reference();
        let mut det = fresh();
        let xs: Vec<f64> = noise(17, 720_000, 0.006).iter().map(|x| x + 9.81).collect();
        assert!(run(&mut det, &xs).is_empty());
        let sd = det.window_sd().unwrap();
        assert!((sd / 1.2e-4 - 1.0).abs() < 0.25, "{sd}");
        // A step of 10× that scale at 20 min: one alarm, raised once the last window's median
        // crossed the bar (half a window or a little less after the step: the median of 12
        // blocks is half-way moved with 6 blocks off, and the step is 4.5 σ of one block) and
        // held it for six tests (25 s more): 45–75 s after the step; its size within 30 %.
        let s = 1.2e-3;
        let mut xs: Vec<f64> = noise(18, 240_000, 0.006).iter().map(|x| x + 9.81).collect();
        for x in xs.iter_mut().skip(120_000) {
            *x += s;
        }
        let mut det = fresh();
        let mut raised = Vec::new();
        for (i, &x) in xs.iter().enumerate() {
            if let Some(e) = det.push(i as u64 * 10_000_000, x) {
                raised.push((i as f64 / FS, e));
            }
        }
        assert_eq!(raised.len(), 1, "{raised:?}");
        let (t, e) = raised[0];
        assert!((1245.0..=1275.0).contains(&t), "raised at {t} s");
        assert!((e.offset / s - 1.0).abs() < 0.3, "{e:?}");
        // The same size for 25 s (5 blocks, under half a window) and back: no alarm (with
        // 6 blocks the 12-block median is half-way moved for 7 tests in a row, and 30 s of
        // this size is flagged).
        let mut xs: Vec<f64> = noise(18, 240_000, 0.006).iter().map(|x| x + 9.81).collect();
        for x in xs.iter_mut().skip(120_000).take(2_500) {
            *x += s;
        }
        let mut det = fresh();
        assert!(run(&mut det, &xs).is_empty());
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
