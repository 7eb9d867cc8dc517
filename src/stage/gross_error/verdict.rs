//! The verdict on one pending event (`resolve`): gather its context, trim it to the part that
//! breaks the signal, confirm it two-sidedly (`confirm.rs`), rule out a shock seen on other
//! axes, a break inside a manoeuvre the gate itself called motion, and a short break at a level
//! the channel itself held within the last `level_window_s` (the level test), and write the
//! verdict — replaced or suspect — into the held samples.

use super::gate::{Mode, RAW_KEEP};
use super::{GrossErrorStage, MAX_EVENT, RING, Replacement, SHOCK_MEMORY, at_ring};
use super::{MAX_CONTEXT, MAX_POST};
use super::{confirm, rest};
use crate::sample::flags;
use crate::stats::robust::{median, sigma_from_abs_dev, upper_median};

/// One event's verdict, as recorded by [`GrossErrorStage::record_verdicts`]: what the
/// confirmation saw and decided, for explaining a miss or a false replacement offline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventVerdict {
    /// Channel index (`CHANNEL_NAMES`).
    pub channel: usize,
    /// Index of the event's first sample among the stage's measurements (stale repeats share
    /// their original's index; see `flags::REPEATED`).
    pub start: u64,
    /// The event's samples.
    pub len: usize,
    /// The judged part, `lead..keep` (`confirm::trim`); the rest was handed back to the signal.
    pub lead: usize,
    pub keep: usize,
    /// The two-sided evidence on the judged part (`None`: not judged — too long, too little
    /// context after it, or no roughness to measure).
    pub evidence: Option<confirm::Evidence>,
    /// The several-axes test called it a shock.
    pub shock: bool,
    /// The gate called it motion and the break covers under a third of it.
    pub motion_break: bool,
    /// The level test's distance of the judged part from the recent level, in robust σ of the
    /// level (`None`: not applied — a judged part of `confirm::SMOOTH_MIN` samples or more, not
    /// judged, the test off, or too little history).
    pub level: Option<f64>,
    /// The level test vetoed it (`level` < `level_k`).
    pub level_veto: bool,
    /// Confirmed by the test against the resting level (`rest_k`; the shape tests let it pass).
    pub rest: bool,
    /// Confirmed gross (the judged part replaced).
    pub gross: bool,
}

/// At rest (`rest_k`), the break is the span of the event from its first to its last sample
/// beyond this many spreads of the level: a sample of Gaussian rest noise lies there with
/// probability 7e-6 (at 3 it was 2.7e-3, and an ordinary 3.2 σ sample next to a spike was
/// replaced with it in `tests/gross_error_stage.rs`).
const REST_SPAN_K: f64 = 4.5;
/// At rest (`rest_k`), every other channel's samples during the event each lie fewer than
/// this many of its MAD σ (`rest::Rest::z_robust`) off its own level: a sample of ordinary rest noise does, and a
/// touch, a tap or the start of a motion that moves another axis does not.
const OTHERS_REST_K: f64 = 4.0;
/// A partner channel of the several-axes test is sharp beyond this many times its roughness.
const SHOCK_K: f64 = 4.0;
/// Time constant of a channel's rate of confirmed gross errors (samples).
pub(super) const RATE_WINDOW: f64 = 5000.0;
/// A partner whose own confirmed gross errors are so frequent that one falls within the
/// 3-sample window by chance with at least this probability is no evidence of a common cause.
const CHANCE: f64 = 3e-3;
/// Most measurements the level test reads (half the ring; the rest holds the event and the
/// samples after it: at most `MAX_LOOKAHEAD` = 1000).
const LEVEL_MAX: usize = 1024;
/// Fewest measurements the level test reads: fewer, and it makes no veto (the guard's own
/// minimum history is 16 increments, `guard::GUARD_N`).
const LEVEL_MIN: usize = 16;

impl GrossErrorStage {
    /// Judge the oldest pending event of channel `c` with the context that has arrived (samples
    /// before index `upto`), and write the verdict into the held samples.
    pub(super) fn resolve(&mut self, c: usize, upto: u64) {
        let Some(ev) = self.ch[c].pending.pop_front() else {
            return;
        };
        let end = ev.end.unwrap_or(upto).min(upto);
        let m = (end - ev.start) as usize;
        let ctx = self.s.context_samples;
        let post_n = self.s.post_samples;
        let mut pre = [0.0f64; MAX_CONTEXT];
        let mut event = [0.0f64; MAX_EVENT];
        let mut post = [0.0f64; MAX_POST];
        let ring = &self.ch[c].ring;
        let at = |i: u64| ring[(i % RING as u64) as usize];
        let cand = |i: u64| self.ch[c].preds[(i % RING as u64) as usize].is_finite();
        let n_pre = (ev.start as usize).min(ctx);
        for (j, p) in pre[..n_pre].iter_mut().enumerate() {
            *p = at(ev.start - n_pre as u64 + j as u64);
        }
        let n_post = if ev.end.is_some() {
            ((upto - end) as usize).min(post_n)
        } else {
            0
        };
        for (j, p) in post[..n_post].iter_mut().enumerate() {
            let i = end + j as u64;
            // Around a one-sample event, a later sample the gate also called a candidate, on
            // its own between two ordinary ones, is the next isolated outlier, not the signal:
            // left out, so that it neither pulls the interpolation nor inflates the roughness
            // (at 2 % contamination neighbouring outliers otherwise mask each other).
            let isolated = j > 0 && i + 1 < upto && cand(i) && !cand(i - 1) && !cand(i + 1);
            *p = if m == 1 && isolated { f64::NAN } else { at(i) };
        }
        let m_judged = m.min(event.len());
        for (j, e) in event[..m_judged].iter_mut().enumerate() {
            *e = at(ev.start + j as u64);
        }
        let mut interp = [0.0f64; MAX_EVENT];
        // A verdict needs the signal on both sides: at least three samples after the event (the
        // break out of it, and one second difference of roughness), or it stays unconfirmed.
        let eligible = m_judged == m && n_post >= 3;
        // Leading and trailing samples that continue the signal are not part of the break.
        let (mut lead, mut keep) = if eligible {
            confirm::trim(
                &pre[..n_pre],
                &event[..m],
                &post[..n_post],
                self.s.edge_k,
                self.sigma_floor(c),
            )
        } else {
            (0, m)
        };
        // The judged part's surroundings: the context before plus the leading samples, and the
        // trailing samples plus the context after.
        let mut before = [0.0f64; MAX_CONTEXT + MAX_EVENT];
        let n_before = n_pre + lead;
        before[..n_pre].copy_from_slice(&pre[..n_pre]);
        before[n_pre..n_before].copy_from_slice(&event[..lead]);
        let before = &before[n_before.saturating_sub(ctx)..n_before];
        let mut after = [0.0f64; MAX_POST];
        let n_after = (m - keep + n_post).min(post_n);
        for (j, a) in after[..n_after].iter_mut().enumerate() {
            *a = if keep + j < m {
                event[keep + j]
            } else {
                post[keep + j - m]
            };
        }
        let evidence = if eligible {
            confirm::confirm_with(
                before,
                &event[lead..keep],
                &after[..n_after],
                self.sigma_floor(c),
                self.s.run_fit_side,
                &mut interp,
            )
        } else {
            None
        };
        // A partner of a shock must be sharp on its own scale, and at least a quarter as sharp
        // as the event: a 20σ glitch during a walk's 4σ footfalls is no part of them. One
        // partner suffices when it is at least half as sharp as the event (see `shock`).
        let partner_k = evidence.map_or(SHOCK_K, |e| SHOCK_K.max(0.25 * e.z_in));
        let strong_k = evidence.map_or(SHOCK_K, |e| SHOCK_K.max(0.5 * e.z_in));
        // Tested where the event starts and, if leading samples were handed back to the signal,
        // where its judged part starts: the break the partners must share is there (a gate run
        // that opens on a fast but smooth approach, three samples before a heel strike, would
        // otherwise be tested on the quiet samples before the impact).
        let mut shock = self.shock(c, ev.start, m, upto, partner_k, strong_k);
        if !shock && lead > 0 {
            shock = self.shock(c, ev.start + lead as u64, m, upto, partner_k, strong_k);
        }
        if shock {
            self.shocks[self.shock_next] = (ev.start, end);
            self.shock_next = (self.shock_next + 1) % SHOCK_MEMORY;
        }
        // The gate called the event motion (a level change or the release rule) and the part
        // that breaks the signal is under a third of it: that break is the sharp part of the
        // manoeuvre, not a gross error riding on it.
        let motion_break = ev.motion && 3 * (keep - lead) < m;
        // Opt-in (`level_window_s` > 0): a judged part too short for the smoothness test must
        // also lie off the level the channel held over the last `level_window_s` (the level
        // test, below): its shape cannot tell a short real transient from a glitch.
        let level = if evidence.is_some() && keep - lead < confirm::SMOOTH_MIN {
            self.level_distance(c, ev.start + lead as u64, upto, &event[lead..keep])
        } else {
            None
        };
        let level_veto = level.is_some_and(|d| d < self.s.level_k);
        let vetoed = shock || motion_break || level_veto;
        let shape_gross = evidence.is_some_and(|e| e.gross(keep - lead, &self.s.thresholds()));
        let rest_break = if !vetoed && !shape_gross && eligible && self.s.rest_k > 0.0 {
            self.rest_break(
                c,
                (ev.start, end),
                &pre[..n_pre],
                &event[..m],
                &post[..n_post],
            )
        } else {
            None
        };
        if let Some((a, b, level)) = rest_break {
            (lead, keep) = (a, b);
            interp[..b - a].fill(level);
        }
        let gross = !vetoed && (shape_gross || rest_break.is_some());
        if let Some(log) = self.verdicts.as_mut() {
            log.push(EventVerdict {
                channel: c,
                start: ev.start,
                len: m,
                lead,
                keep,
                evidence,
                shock,
                motion_break,
                level,
                level_veto,
                rest: rest_break.is_some(),
                gross,
            });
        }
        let use_interp = evidence.is_some() && self.s.replacement == Replacement::Interpolation;
        // Write the verdict into the held samples.
        let bit = flags::replaced_ch(c);
        let plausible = self.plausible(c);
        let mut replaced = 0u64;
        let mut suspect = 0u64;
        for h in self.held.iter_mut() {
            if h.idx < ev.start || h.idx >= end {
                continue;
            }
            let j = (h.idx - ev.start) as usize;
            let slot = (h.idx % RING as u64) as usize;
            let v = h.out.channel(c);
            let bad = !v.is_finite() || v.abs() > plausible;
            if gross && (j < lead || j >= keep) && !bad {
                continue; // outside the break: the signal itself
            }
            if gross || bad {
                let r = if use_interp && (lead..keep).contains(&j) {
                    interp[j - lead]
                } else {
                    self.ch[c].preds[slot]
                };
                if r.is_finite() {
                    h.out.set_channel(c, self.ch[c].line.put_back(h.idx, r));
                    h.out.flags |= flags::REPLACED | bit;
                    self.ch[c].ring[slot] = r;
                    replaced += 1;
                    continue;
                }
            }
            h.out.flags |= flags::suspect_ch(c);
            suspect += 1;
        }
        if gross {
            self.ch[c].gross_rate += 1.0 / RATE_WINDOW;
        }
        let k = &mut self.ch[c].gate.counters;
        k.replaced += replaced;
        k.suspect += suspect;
        if gross {
            k.confirmed += 1;
        } else {
            k.suspect_events += 1;
        }
        if !gross && ev.end.is_none() && self.ch[c].gate.mode == Mode::Active {
            // Forced while still open and judged motion: end the gate's run on the raw values.
            let mut recent = [0.0f64; RAW_KEEP];
            let last = upto.saturating_sub(1);
            for (j, r) in recent.iter_mut().enumerate() {
                *r = at_ring(&self.ch[c].ring, last.saturating_sub(j as u64));
            }
            self.ch[c].gate.resume_from(&recent);
        }
    }

    /// At rest the channel's level is known: the event's samples from the first to the last
    /// beyond `REST_SPAN_K` spreads of it are a break (`rest::Rest::is_break` at `rest_k`) when
    /// channel `c` is at rest around the event (`pre`, `post`) and every other channel is too
    /// and still during it ([`Self::others_at_rest`]). Returns the break's span in `event` and
    /// the level that replaces it.
    fn rest_break(
        &self,
        c: usize,
        (start, end): (u64, u64),
        pre: &[f64],
        event: &[f64],
        post: &[f64],
    ) -> Option<(usize, usize, f64)> {
        let rest = rest::at_rest(pre, post, self.sigma_floor(c), self.s.rest_ratio)?;
        let off = |x: &f64| rest.z(*x) > REST_SPAN_K;
        let a = event.iter().position(off)?;
        let b = event.iter().rposition(off)?;
        let before = if a > 0 {
            event[a - 1]
        } else {
            pre[pre.len() - 1]
        };
        let after = event.get(b + 1).copied().unwrap_or(post[0]);
        (rest.is_break(before, &event[a..=b], after, self.s.rest_k)
            && self.others_at_rest(c, start, end, pre.len(), post.len()))
        .then_some((a, b + 1, rest.level))
    }

    /// Every other channel with values is at rest around the event (`rest::at_rest` on its
    /// own context) and undisturbed during it (each sample within `OTHERS_REST_K` MAD σ of its
    /// level).
    fn others_at_rest(&self, c: usize, start: u64, end: u64, n_pre: usize, n_post: usize) -> bool {
        let ratio = self.s.rest_ratio;
        let mut pre = [0.0f64; MAX_CONTEXT];
        let mut event = [0.0f64; MAX_EVENT];
        let mut post = [0.0f64; MAX_POST];
        let m = ((end - start) as usize).min(MAX_EVENT);
        for o in (0..self.ch.len()).filter(|&o| o != c) {
            // Raw values, as the several-axes test reads them: a partner replaced first
            // still moved.
            let at = |i: u64| at_ring(&self.ch[o].raw, i);
            for (j, p) in pre[..n_pre].iter_mut().enumerate() {
                *p = at(start - n_pre as u64 + j as u64);
            }
            for (j, e) in event[..m].iter_mut().enumerate() {
                *e = at(start + j as u64);
            }
            for (j, p) in post[..n_post].iter_mut().enumerate() {
                *p = at(end + j as u64);
            }
            if pre[..n_pre].iter().filter(|v| v.is_finite()).count() < 16 {
                continue; // an absent channel (or one without a context) casts no vote
            }
            let floor = self.sigma_floor(o);
            match rest::at_rest(&pre[..n_pre], &post[..n_post], floor, ratio) {
                Some(rest) if event[..m].iter().all(|&x| rest.z_robust(x) < OTHERS_REST_K) => {}
                _ => return false,
            }
        }
        true
    }

    /// The level window in measurements: `level_window_s` of the stream's own time (its mean
    /// interval between measurements, intervals that end in a gap left out), at most
    /// [`LEVEL_MAX`]; `None` when the test is off or no interval has been seen.
    fn level_window(&self) -> Option<usize> {
        if self.s.level_window_s <= 0.0 || self.intervals == 0 || self.span_ns == 0 {
            return None;
        }
        let dt = self.span_ns as f64 * 1e-9 / self.intervals as f64;
        Some(((self.s.level_window_s / dt).round() as usize).clamp(1, LEVEL_MAX))
    }

    /// The level test's distance (module docs of `settings.rs`, `level_window_s`): how far the
    /// judged samples `judged` (the first at index `a`) lie from the level channel `c` held
    /// over the level window before them — the median over the samples of |x − m| / σ_L, m the
    /// median and σ_L the robust σ of the window's best values so far (replacements in, bad
    /// values out), σ_L no lower than the confirmation's floor. `None` (no veto) with fewer than
    /// [`LEVEL_MIN`] values: at the start of a stream the shape tests decide alone.
    fn level_distance(&mut self, c: usize, a: u64, upto: u64, judged: &[f64]) -> Option<f64> {
        let w = self.level_window()?;
        // The ring holds the last RING measurements up to `upto`.
        let room = (RING as u64).saturating_sub(upto.saturating_sub(a) + 1);
        let w = (w as u64).min(room).min(a) as usize;
        if w < LEVEL_MIN {
            return None;
        }
        let floor = self.sigma_floor(c);
        let buf = &mut self.level_buf[..];
        let mut n = 0;
        for i in a - w as u64..a {
            let v = at_ring(&self.ch[c].ring, i);
            if v.is_finite() {
                buf[n] = v;
                n += 1;
            }
        }
        if n < LEVEL_MIN {
            return None;
        }
        let med = upper_median(&mut buf[..n]);
        for v in buf[..n].iter_mut() {
            *v = (*v - med).abs();
        }
        let sd = sigma_from_abs_dev(&mut buf[..n]).max(floor);
        let mut d = [0.0f64; MAX_EVENT];
        let m = judged.len().min(MAX_EVENT);
        for (o, x) in d.iter_mut().zip(judged) {
            // A non-finite value is as far off as it gets.
            *o = if x.is_finite() {
                (x - med).abs() / sd
            } else {
                f64::INFINITY
            };
        }
        Some(median(&mut d[..m]))
    }

    /// Mean square of channel `o`'s centred second differences (raw values) over the
    /// `context_samples` before `end` (the last one, at `end − 1`, left out: it touches `end`);
    /// `None` when none is finite.
    fn mean_square(&self, o: usize, end: u64) -> Option<f64> {
        let x = |i: u64| at_ring(&self.ch[o].raw, i);
        let ctx = self.s.context_samples as u64;
        let (mut sum, mut n) = (0.0, 0u32);
        for i in end - ctx..end - 1 {
            let v = x(i) - 0.5 * (x(i - 1) + x(i + 1));
            if v.is_finite() {
                sum += v * v;
                n += 1;
            }
        }
        (n > 0).then(|| (sum / f64::from(n)).max(f64::MIN_POSITIVE))
    }

    /// Channel `o`'s centred second difference at `i` over its RMS before `end`
    /// ([`Self::mean_square`]); `None` when either is not finite.
    fn sharpness(&self, o: usize, i: u64, end: u64) -> Option<f64> {
        let x = |i: u64| at_ring(&self.ch[o].raw, i);
        let d = x(i) - 0.5 * (x(i - 1) + x(i + 1));
        let ms = self.mean_square(o, end)?;
        d.is_finite().then(|| d.abs() / ms.sqrt())
    }

    /// The shock an event starting at `start` follows: of the remembered shocks that started
    /// before `start` and ended at most `post_samples` before it (the event lies in that
    /// shock's own after-context), the earliest start; the partners' roughness before it is
    /// the quiet they are measured against.
    fn after_shock(&self, start: u64) -> Option<u64> {
        let post = self.s.post_samples as u64;
        self.shocks
            .iter()
            .filter(|(s0, e0)| *s0 < start && start <= e0 + post)
            .map(|(s0, _)| *s0)
            .min()
    }

    /// Several-axes test on the other channels' *raw* values (a partner judged first and
    /// replaced is still a partner): a channel is *sharp* within one sample of `start` when its
    /// centred second difference there exceeds `k` times its own RMS over the
    /// `context_samples` before. A shock — a knock moves the whole body, a glitch stays in its
    /// channel — is
    ///
    /// - two partners sharp beyond `partner_k`, or
    /// - one partner sharp beyond `strong_k` (at least half as sharp as the event), unless that
    ///   channel confirms gross errors of its own so often (`gross_rate`, per sample) that one
    ///   falls within the 3-sample window by chance with probability ≥ `CHANCE` (more than one
    ///   per 1000 samples over the last ~`RATE_WINDOW`): at a 2 % contamination of every axis,
    ///   or the 2e-3 per channel-sample of issue 4's dense synthetic logs, coincidences are
    ///   expected and prove nothing, or
    /// - for an event in the after-context of a shock (it starts within `post_samples` of the
    ///   end of an event called a shock, `after_shock`), two partners sharp *on its first
    ///   sample* against their RMS over the `context_samples` before that shock, beyond
    ///   `partner_k` and at least a quarter as sharp as the event on that same scale: the body
    ///   is still ringing. A real impact rings (a foot's heel strike: a pulse, a rebound and a
    ///   few lobes within ~40 ms), and a context that holds its onset is many times rougher
    ///   than the partners were before it: at a simulated heel strike's rebound at 400 Hz every
    ///   other axis is 2.7–3.0× the RMS of the context before the rebound but 29–203× the RMS
    ///   before the impact, so the first rule found no partner and the rebound was confirmed
    ///   and replaced on its own (tests/sensor_class_gait.rs). The first two rules are
    ///   unchanged: a glitch on one channel two samples after a real knock, while the other
    ///   axes move around it but not as sharply on its own sample, is judged as before.
    ///
    /// Model-free, so it holds during warm-up too. Not for a one-sample event whose partners were
    /// sharp on that sample only: that is what a corrupted whole frame looks like — unless the
    /// only partner is on the event's own triad (gyro with gyro, accelerometer with
    /// accelerometer) and sharp there by less than `confirm_k` (less than a gross error of
    /// its own). One triad measures one vector, and a real jolt about an oblique axis
    /// shows on two of its axes on the same sample (the rtklibexplorer drive's vibration at
    /// 72.67 s: gy 6.4 σ̂, gx 4.84 times its RMS there and 3.71 on the sample before), while a
    /// corrupted frame has no reason to stay under the confirmation bar on its other channel.
    /// Needs the samples up to `start + 2` (`upto` is one past the last available).
    pub(super) fn shock(
        &self,
        c: usize,
        start: u64,
        len: usize,
        upto: u64,
        partner_k: f64,
        strong_k: f64,
    ) -> bool {
        let ctx = self.s.context_samples as u64;
        if start < ctx + 2 || start + 3 > upto {
            return false;
        }
        // After a shock: each channel's sharpness on the event's first sample against its
        // roughness before that shock; a partner must be beyond `partner_k` and at least a
        // quarter as sharp as the event on that same scale.
        let before_shock = self
            .after_shock(start)
            .filter(|s0| *s0 >= ctx + 2)
            .and_then(|s0| {
                let own = self.sharpness(c, start, s0)?;
                Some((s0, partner_k.max(0.25 * own)))
            });
        let (mut partners, mut all_same, mut vector_moved) = (0, true, false);
        let (mut strong, mut strong_same) = (0, true);
        let mut ringing = 0;
        for (o, other) in self.ch.iter().enumerate() {
            if o == c || other.gate.mode == Mode::Disabled {
                continue;
            }
            if let Some((s0, k)) = before_shock
                && self.sharpness(o, start, s0).is_some_and(|r| r > k)
            {
                ringing += 1;
            }
            let x = |i: u64| at_ring(&other.raw, i);
            let d = |i: u64| x(i) - 0.5 * (x(i - 1) + x(i + 1));
            let Some(ms) = self.mean_square(o, start) else {
                continue;
            };
            let (lim2, strong2) = (partner_k * partner_k * ms, strong_k * strong_k * ms);
            // Off on that sample by as much as a gross error of its own would be.
            let gross_itself = d(start).powi(2) > self.s.confirm_k.powi(2) * ms;
            let (mut mask, mut smask) = (0u8, 0u8);
            for (bit, i) in [start - 1, start, start + 1].into_iter().enumerate() {
                let v = d(i);
                if v.is_finite() && v * v > lim2 {
                    mask |= 1 << bit;
                }
                if v.is_finite() && v * v > strong2 {
                    smask |= 1 << bit;
                }
            }
            if mask != 0 {
                partners += 1;
                all_same &= mask == 0b010;
                vector_moved |= o / 3 == c / 3 && !gross_itself;
            }
            if smask != 0 && 3.0 * other.gross_rate < CHANCE {
                strong += 1;
                strong_same &= smask == 0b010;
            }
        }
        // A lone partner on the event's own triad, sharp on that sample but by less than a
        // gross error, is the same vector moving (a rotation about an oblique axis), not a frame.
        let frame = |same: bool| len == 1 && same && (partners >= 2 || !vector_moved);
        (partners >= 2 && !frame(all_same)) || (strong >= 1 && !frame(strong_same)) || ringing >= 2
    }
}
