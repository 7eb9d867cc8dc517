//! The output at rest losing its whiteness at short lags: a coloured component the model lacks
//! (a sensor filter or output rate changed, broadband vibration through a damped mount, a noise
//! source with a correlation time of a few samples), told by the Ljung–Box statistic of the
//! window's autocorrelations at lags `1..=h` against the channel's own.
//!
//! **Statistic.** Contiguous still samples at the full rate (averaging would wash out a
//! correlation of a few samples) in windows of `W` seconds made of blocks of `B` (tested every
//! block: 90 s of 15-s blocks by default), each cut into segments of 1 s whose own mean is
//! removed: the window's autocorrelations are `r_k = Σ_seg c_k / Σ_seg c₀` over the segments'
//! centred lagged sums (pairs within a segment only). Anything slower than the segment — a bias
//! still settling, a wander, the ADIS16405 accelerometers' slow excursions — is the wander and
//! offset tests' business and is removed here; without that, a turn-on transient learned in the
//! first minutes inflated the learned scatter 17–31× on the simulated gyros. Per sample, per lag
//! `k ≤ h`, the lagged product and the pair's sum are accumulated (O(h) per sample; O(h) per
//! segment and O(h·W/B) per test, no burst), the same numbers as
//! [`crate::stats::acf::acf`] per segment. A skipped sample (stillness dropping out for a few
//! samples) breaks only the pairs across it; more than a second of them breaks the run.
//!
//! **Against the channel's own.** A real sensor is not white even when the model is complete
//! (its own DSP filter, quantisation, the bias estimate's small lag), so the no-effect
//! autocorrelations `ρ̂_k` are learned from the channel's quiet windows (two windows late,
//! dropped if an alarm follows: [`super::learn::Delayed`]), and the change is tested:
//! `Q_Δ = ljung_box_statistic(r − ρ̂)` ([`crate::stats::acf::ljung_box_statistic`]). For a
//! window of `N` samples whose correlation structure has not changed, `r_k − ρ̂_k` is
//! approximately normal with variance `v·(1 + 1/n₀)/N` (`v = 1` for weak correlations,
//! Bartlett; `n₀` the independent windows in `ρ̂`), so `Q_Δ/(1 + 1/n₀) ≈ v·χ²(h)`. The scale `v`
//! is learned too, as the mean of the quiet windows' `Q_Δ/((1 + 1/n₀)·h)`, floored at 1 (the
//! value for any weakly correlated noise); the score `S = Q_Δ/((1 + 1/n₀)·h·v̂)` is then
//! `F(ν, ν·n_v)` with `n_v` the independent windows in `v̂` and ν = h, lowered where the
//! channel's own values scatter wider than `χ²_h/h` ([`WhitenessDetector::edf`], the rule the
//! wander test uses), and the alarm is raised at `S ≥ F⁻¹(1 − p)`, held until `S` falls below
//! that `F`'s median.
//!
//! **What an unmodelled AR(1) does.** A component of variance ratio `a` to the white noise
//! and pole `φ` per sample adds `ρ_k = φ^k·a/(1 + a)` to every lag, and the noncentrality of
//! `Q_Δ` is `N·Σ_{k≤h} ρ_k²`. The size `diagnose` finds from a 20-min log (AR(1), φ = 0.8, sd
//! 0.2× the white σ: `a = 0.04`, docs/model-health.md) gives `N·Σρ_k² = 0.0026·N` — 23 in a
//! 90-s window at 100 Hz against a χ²(10) bar of 41.3 at `p = 1e-5`: one window flags it with
//! probability 0.22, and even the Neyman–Pearson test of that exact alternative only with 0.73
//! (`tests/reference/whiteness_power.py`); 1.5× that sd (N·Σρ_k² = 108) is flagged by one
//! window with probability ≈ 1, within 2 min.

use super::learn::{Bridge, Delayed, LogScatter, f_quantile};
use crate::stats::acf::ljung_box_statistic;
use std::collections::VecDeque;

/// One alarm of the whiteness detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhitenessEvent {
    /// Sensor time of the start of the window that raised the alarm, ns.
    pub t_ns: u64,
    /// The window's Ljung–Box `Q` over lags `1..=h` (against zero autocorrelation).
    pub q: f64,
    /// The channel's own `Q`: the mean over the quiet windows learned from.
    pub q0: f64,
    /// `S`: the change of the autocorrelations from the channel's own, in its own scatter.
    pub score: f64,
}

/// Raw lagged sums of one segment (pairs within it only).
#[derive(Debug, Clone)]
struct Raw {
    n: f64,
    sum: f64,
    sumsq: f64,
    /// Per lag k (index k − 1): Σ yₜ·yₜ₋ₖ, Σ (yₜ + yₜ₋ₖ) and the pair count.
    prod: Vec<f64>,
    pair: Vec<f64>,
    pairs: Vec<f64>,
}

impl Raw {
    fn new(h: usize) -> Self {
        Raw {
            n: 0.0,
            sum: 0.0,
            sumsq: 0.0,
            prod: vec![0.0; h],
            pair: vec![0.0; h],
            pairs: vec![0.0; h],
        }
    }

    fn clear(&mut self) {
        self.n = 0.0;
        self.sum = 0.0;
        self.sumsq = 0.0;
        for v in [&mut self.prod, &mut self.pair, &mut self.pairs] {
            v.fill(0.0);
        }
    }
}

/// Centred lagged sums: `c₀ = Σ (y − ȳ)²`, `c_k = Σ (yₜ − ȳ)(yₜ₋ₖ − ȳ)`, each segment about
/// its own mean.
#[derive(Debug, Clone)]
struct Centred {
    n: f64,
    c0: f64,
    c: Vec<f64>,
    start_ns: u64,
}

impl Centred {
    fn new(h: usize) -> Self {
        Centred {
            n: 0.0,
            c0: 0.0,
            c: vec![0.0; h],
            start_ns: 0,
        }
    }

    fn clear(&mut self) {
        self.n = 0.0;
        self.c0 = 0.0;
        self.c.fill(0.0);
    }

    /// A segment's raw sums, about the segment's own mean.
    fn add_raw(&mut self, r: &Raw) {
        let mean = r.sum / r.n;
        self.n += r.n;
        self.c0 += r.sumsq - r.n * mean * mean;
        for k in 0..self.c.len() {
            self.c[k] += r.prod[k] - mean * r.pair[k] + r.pairs[k] * mean * mean;
        }
    }

    fn add(&mut self, o: &Centred) {
        self.n += o.n;
        self.c0 += o.c0;
        self.c.iter_mut().zip(&o.c).for_each(|(a, b)| *a += b);
    }

    /// `r_k = c_k / c₀` (`None` for a constant window).
    fn acf(&self, out: &mut Vec<f64>) -> Option<()> {
        if !(self.c0 > 0.0 && self.c0.is_finite()) {
            return None;
        }
        out.clear();
        out.extend(self.c.iter().map(|c| c / self.c0));
        Some(())
    }
}

/// Whiteness detector of one channel.
#[derive(Debug, Clone)]
pub struct WhitenessDetector {
    h: usize,
    seg_n: usize,
    block_n: usize,
    window_blocks: usize,
    p: f64,
    learn_n: u64,
    /// The last `h` values of the run (shifted), newest last; cleared where a sample is skipped.
    ring: VecDeque<f64>,
    /// Subtracted from every value of the run (its first value): keeps the sums' cancellation
    /// small on a channel far from zero.
    shift: Option<f64>,
    /// The segment being filled, the block being filled, the window's full blocks.
    seg: Raw,
    cur: Centred,
    blocks: VecDeque<Centred>,
    /// Scratch: the window's sums and autocorrelations.
    win: Centred,
    r: Vec<f64>,
    d: Vec<f64>,
    pending: Delayed<(Vec<f64>, f64, f64)>,
    rho_sum: Vec<f64>,
    learned: u64,
    q_sum: f64,
    scale_sum: f64,
    scale_n: u64,
    /// The learned `Q_Δ/h` values' log scatter (see [`WhitenessDetector::edf`]).
    scatter: LogScatter,
    still: u64,
    bridge: Bridge,
    active: bool,
    pub events: u64,
    /// Still runs broken (more than the bridge skipped, motion, a gap).
    pub breaks: u64,
    /// Tests run.
    pub tests: u64,
    /// Largest `S` over the armed tests that raised no alarm, and the bar at that test.
    pub max_quiet: (f64, f64),
}

impl WhitenessDetector {
    /// Segments of `seg_n` samples (each about its own mean), `block_n` samples per block
    /// (rounded to whole segments), `window_blocks` blocks per window (tested every block),
    /// lags `1..=lags`, false-alarm probability `p` per test, armed after `learn_n` still
    /// samples; up to `bridge_n` skipped samples in a row are bridged.
    pub fn new(
        seg_n: usize,
        block_n: usize,
        window_blocks: usize,
        lags: usize,
        p: f64,
        learn_n: u64,
        bridge_n: usize,
    ) -> Self {
        let h = lags.max(1);
        let window_blocks = window_blocks.max(1);
        let seg_n = seg_n.max(h + 2);
        WhitenessDetector {
            h,
            seg_n,
            block_n: block_n.div_ceil(seg_n).max(1) * seg_n,
            window_blocks,
            p,
            learn_n,
            ring: VecDeque::with_capacity(h + 1),
            shift: None,
            seg: Raw::new(h),
            cur: Centred::new(h),
            blocks: VecDeque::with_capacity(window_blocks + 1),
            win: Centred::new(h),
            r: Vec::with_capacity(h),
            d: Vec::with_capacity(h),
            pending: Delayed::new(2 * window_blocks),
            rho_sum: vec![0.0; h],
            learned: 0,
            q_sum: 0.0,
            scale_sum: 0.0,
            scale_n: 0,
            scatter: LogScatter::default(),
            still: 0,
            bridge: Bridge::new(bridge_n),
            active: false,
            events: 0,
            breaks: 0,
            tests: 0,
            max_quiet: (0.0, 0.0),
        }
    }

    /// Independent windows among `n` learned (overlapping by all but one block).
    fn independent(&self, n: u64) -> f64 {
        if n == 0 {
            return 0.0;
        }
        (n as f64 + self.window_blocks as f64 - 1.0) / self.window_blocks as f64
    }

    /// Whether the detector has learned enough to raise alarms: the still time, and the scale
    /// from at least two independent windows.
    pub fn armed(&self) -> bool {
        self.still >= self.learn_n && self.independent(self.scale_n) >= 2.0
    }

    /// Whether an alarm is holding now.
    pub fn active(&self) -> bool {
        self.active
    }

    /// The channel's learned no-effect autocorrelations `ρ̂_1..=ρ̂_h`, once any.
    pub fn baseline(&self) -> Option<Vec<f64>> {
        (self.learned > 0).then(|| {
            let n = self.learned as f64;
            self.rho_sum.iter().map(|s| s / n).collect()
        })
    }

    /// The learned scale `v̂` of `Q_Δ` (1 for weakly correlated noise; floored there).
    pub fn scale(&self) -> f64 {
        if self.scale_n == 0 {
            return 1.0;
        }
        (self.scale_sum / self.scale_n as f64).max(1.0)
    }

    /// The channel's own Ljung–Box `Q`, once learned.
    pub fn q0(&self) -> Option<f64> {
        (self.learned > 0).then(|| self.q_sum / self.learned as f64)
    }

    /// The autocorrelations `r_1..=r_h` of the last window tested.
    pub fn last_acf(&self) -> &[f64] {
        &self.r
    }

    /// EDF of one window's `Q_Δ/h`: `h`, or less where the channel's own values scatter more
    /// than `χ²_h/h` (from four independent windows learned on, [`LogScatter`]). On a channel
    /// carrying a line whose amplitude changes, one pattern of the autocorrelations (the line's)
    /// carries most of the change: the values scatter like a χ² of fewer degrees of freedom.
    pub fn edf(&self) -> f64 {
        let h = self.h as f64;
        if self.independent(self.scale_n) < 4.0 {
            return h;
        }
        self.scatter.edf().unwrap_or(h).min(h)
    }

    /// The `F(ν, ν·n_v)` quantile at `q` (ν = [`WhitenessDetector::edf`]).
    fn quantile(&self, q: f64) -> Option<f64> {
        f_quantile(self.edf(), self.independent(self.scale_n), q)
    }

    /// The alarm bar on `S` now, once armed.
    pub fn threshold(&self) -> Option<f64> {
        if !self.armed() {
            return None;
        }
        self.quantile(1.0 - self.p)
    }

    /// A sample that cannot be used: the pairs across it are not formed, and a run of more than
    /// `bridge_n` of them breaks the still run.
    pub fn skip(&mut self) {
        self.ring.clear();
        if self.bridge.skip() {
            self.interrupt();
        }
    }

    /// The contiguous run of still data was broken.
    pub fn interrupt(&mut self) {
        if !self.blocks.is_empty() || self.cur.n > 0.0 || self.seg.n > 0.0 {
            self.breaks += 1;
        }
        self.bridge.reset();
        self.ring.clear();
        self.shift = None;
        self.seg.clear();
        self.cur.clear();
        self.blocks.clear();
        self.active = false;
    }

    /// One still value; returns an alarm when one is raised.
    pub fn push(&mut self, t_ns: u64, v: f64) -> Option<WhitenessEvent> {
        self.bridge.reset();
        self.still += 1;
        let y = v - *self.shift.get_or_insert(v);
        if self.cur.n == 0.0 && self.seg.n == 0.0 {
            self.cur.start_ns = t_ns;
        }
        // Lag k = i + 1, pairs within the segment only (the ring is cleared at its end).
        for (i, &yl) in self.ring.iter().rev().enumerate() {
            self.seg.prod[i] += y * yl;
            self.seg.pair[i] += y + yl;
            self.seg.pairs[i] += 1.0;
        }
        if self.ring.len() == self.h {
            self.ring.pop_front();
        }
        self.ring.push_back(y);
        self.seg.n += 1.0;
        self.seg.sum += y;
        self.seg.sumsq += y * y;
        if (self.seg.n as usize) < self.seg_n {
            return None;
        }
        self.cur.add_raw(&self.seg);
        self.seg.clear();
        self.ring.clear();
        if (self.cur.n as usize) < self.block_n {
            return None;
        }
        // The oldest block's storage is reused once the window is full.
        let fresh = if self.blocks.len() == self.window_blocks {
            self.blocks.pop_front()
        } else {
            None
        };
        let fresh = fresh.unwrap_or_else(|| self.cur.clone());
        let done = std::mem::replace(&mut self.cur, fresh);
        self.cur.clear();
        self.blocks.push_back(done);
        if self.blocks.len() < self.window_blocks {
            return None;
        }
        self.test()
    }

    /// The test over the full window.
    fn test(&mut self) -> Option<WhitenessEvent> {
        self.win.clear();
        for b in &self.blocks {
            self.win.add(b);
        }
        self.win.acf(&mut self.r)?;
        let n = self.win.n as usize;
        let q = ljung_box_statistic(&self.r, n);
        self.tests += 1;
        // Q_Δ / (1 + 1/n₀) / h against the learned ρ̂ (NaN until one is learned).
        let per_lag = if self.learned > 0 {
            let l = self.learned as f64;
            self.d.clear();
            self.d
                .extend(self.r.iter().zip(&self.rho_sum).map(|(r, s)| r - s / l));
            {
                let n0 = self.independent(self.learned);
                ljung_box_statistic(&self.d, n) / (1.0 + 1.0 / n0) / self.h as f64
            }
        } else {
            f64::NAN
        };
        let bar = self.threshold();
        let s = per_lag / self.scale();
        let over = matches!(bar, Some(b) if s >= b);
        if !self.active
            && !over
            && let Some((r0, pl, q0)) = self.pending.offer((self.r.clone(), per_lag, q))
        {
            self.rho_sum.iter_mut().zip(&r0).for_each(|(a, b)| *a += b);
            self.learned += 1;
            self.q_sum += q0;
            if pl.is_finite() && pl > 0.0 {
                self.scale_sum += pl;
                self.scale_n += 1;
                self.scatter.add(pl);
            }
        }
        let bar = bar?;
        if self.active {
            if s < self.quantile(0.5).unwrap_or(1.0) {
                self.active = false;
            }
            return None;
        }
        if !over {
            if s > self.max_quiet.0 {
                self.max_quiet = (s, bar);
            }
            return None;
        }
        self.active = true;
        self.events += 1;
        self.pending.drop_pending();
        Some(WhitenessEvent {
            t_ns: self.blocks[0].start_ns,
            q,
            q0: self.q0().unwrap_or(f64::NAN),
            score: s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::stage::monitor::test_signals::{coloured, feed, white};
    use crate::stats::acf::acf;

    /// The defaults at 100 Hz: 1-s segments, 15-s blocks, 90-s windows, lags 1–10, p = 1e-5,
    /// armed after 300 s, skips of up to 1 s bridged.
    fn detector() -> WhitenessDetector {
        WhitenessDetector::new(100, 1500, 6, 10, 1e-5, 30_000, 100)
    }

    fn run(det: &mut WhitenessDetector, xs: &[f64], t0: usize) -> Vec<WhitenessEvent> {
        feed(xs, t0, |t, x| det.push(t, x))
    }

    #[test]
    fn streamed_autocorrelations_are_the_batch_acf_of_the_window() {
        // Segments of 25, blocks of 50, windows of 3 blocks: after 400 samples the last window
        // is samples 250..400, six segments. Reference: the batch ACF of each segment, weighted
        // by its c₀. Far from zero (9.81 + noise) to exercise the shift. Same sums in another
        // order: agreement to 1e-9.
        let mut det = WhitenessDetector::new(25, 50, 3, 7, 1e-5, 0, 10);
        let mut r = Rng::new(3);
        let xs: Vec<f64> = coloured(&mut r, 400, 0.6, 0.5)
            .iter()
            .map(|x| 9.81 + 0.01 * x)
            .collect();
        run(&mut det, &xs, 0);
        let (mut ck, mut c0) = (vec![0.0; 7], 0.0);
        for seg in xs[250..].chunks(25) {
            let m = seg.iter().sum::<f64>() / 25.0;
            let s0: f64 = seg.iter().map(|x| (x - m).powi(2)).sum();
            let a = acf(seg, 7).unwrap();
            ck.iter_mut().zip(&a[1..]).for_each(|(c, r)| *c += r * s0);
            c0 += s0;
        }
        let got = det.last_acf();
        assert_eq!(got.len(), 7);
        for (k, (g, c)) in got.iter().zip(&ck).enumerate() {
            let w = c / c0;
            assert!((g - w).abs() < 1e-9, "lag {}: {g} vs {w}", k + 1);
        }
    }

    #[test]
    fn white_noise_raises_no_alarm_and_an_ar_component_one() {
        // 4 h of white noise: 960 tests at p = 1e-5 each, P(any alarm) ≈ 1 %; the seed is fixed
        // and the largest quiet score is checked to sit under the bar.
        let mut det = detector();
        let mut r = Rng::new(41);
        let xs = white(&mut r, 1_440_000);
        assert!(run(&mut det, &xs, 0).is_empty());
        assert!(det.armed());
        // White, each 1-s segment about its own mean: E[r_k] = −(1 − k/100)/99 ≈ −0.01 (the
        // segment mean's share), learned over ≈ 160 independent windows of 9000 samples (sd
        // 1/√1.44e6 = 8e-4 per lag): within 4e-3 (5 sd).
        let rho = det.baseline().unwrap();
        for (i, x) in rho.iter().enumerate() {
            let want = -(1.0 - (i + 1) as f64 / 100.0) / 99.0;
            assert!((x - want).abs() < 4e-3, "lag {}: {x} vs {want}", i + 1);
        }
        // The scale of Q_Δ/h for white noise is 1 (floored there; the learned mean of χ²(10)/10
        // over ~160 windows is within ±0.1 at 3 sd).
        assert!(det.scale() < 1.1, "{}", det.scale());
        let (s, bar) = det.max_quiet;
        assert!(s < bar, "{s} vs {bar}");
        // Then an AR(1) component, φ = 0.8, sd 0.4 of the white noise (a = 0.16): ρ₁ = 0.11,
        // N·Σρ_k² = 0.021·9000 = 190 in one window against a bar of ≈ 4.5·10 = 45: flagged by the
        // first window that holds a third of it, within 2 min.
        let ys = coloured(&mut r, 24_000, 0.8, 0.4);
        let ev = run(&mut det, &ys, xs.len());
        assert_eq!(ev.len(), 1, "{ev:?}");
        let raised = ev[0].t_ns as f64 * 1e-9 + 90.0 - 14_400.0;
        assert!(raised > 0.0 && raised <= 120.0, "raised {raised} s after");
        assert!(ev[0].q > ev[0].q0, "{:?}", ev[0]);
        assert!(det.active());
    }

    #[test]
    fn a_channels_own_colour_is_learned_not_flagged() {
        // A channel that is coloured from the start (the AR(1) above, always there): its own
        // ρ̂ is learned and 2 h raise no alarm; the learned Q is far above white's h = 10.
        let mut det = detector();
        let mut r = Rng::new(42);
        let xs = coloured(&mut r, 720_000, 0.8, 0.4);
        assert!(run(&mut det, &xs, 0).is_empty());
        assert!(det.q0().unwrap() > 100.0, "{:?}", det.q0());
        let rho1 = det.baseline().unwrap()[0];
        // Lag-1 covariance 0.8·0.16 and variance 1.16, each less the variance of a 1-s segment's
        // mean (0.16·(1 + φ)/(1 − φ)/100 + 1/100 = 0.0244): ρ₁ = 0.1036/1.1356 = 0.091; learned
        // over ≈ 80 windows: within 0.01.
        assert!((rho1 - 0.091).abs() < 0.01, "{rho1}");
    }

    #[test]
    fn a_skip_drops_only_the_pairs_across_it_and_a_long_one_breaks_the_run() {
        // Segments of 25, blocks of 50, windows of 3 blocks, lags 1–3; two samples skipped after
        // sample 310 (inside the segment 300..325 of the last window 250..400). Reference by
        // hand: each segment about its own mean, pairs within it, none across the skip.
        let mut det = WhitenessDetector::new(25, 50, 3, 3, 1e-5, 0, 10);
        let mut r = Rng::new(44);
        let xs = coloured(&mut r, 400, 0.5, 0.5);
        for (i, &x) in xs.iter().enumerate() {
            det.push(i as u64 * 10_000_000, x);
            if i == 310 {
                det.skip();
                det.skip();
            }
        }
        assert_eq!(det.breaks, 0, "two skips are bridged");
        let (mut ck, mut c0) = ([0.0; 3], 0.0);
        for s0 in (250..400).step_by(25) {
            let seg = &xs[s0..s0 + 25];
            let m = seg.iter().sum::<f64>() / 25.0;
            c0 += seg.iter().map(|x| (x - m).powi(2)).sum::<f64>();
            for (k, c) in ck.iter_mut().enumerate() {
                for i in s0..s0 + 25 - (k + 1) {
                    let j = i + k + 1;
                    if i <= 310 && j > 310 {
                        continue;
                    }
                    *c += (xs[i] - m) * (xs[j] - m);
                }
            }
        }
        for (k, (g, c)) in det.last_acf().iter().zip(&ck).enumerate() {
            assert!(
                (g - c / c0).abs() < 1e-9,
                "lag {}: {g} vs {}",
                k + 1,
                c / c0
            );
        }
        // More than the bridge (10) skipped in a row: the run breaks.
        for _ in 0..11 {
            det.skip();
        }
        assert_eq!(det.breaks, 1);
    }
}
