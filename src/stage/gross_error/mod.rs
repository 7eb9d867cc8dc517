//! Gross errors: online ARIMA one-step gate per channel (Chen, Li & Zhang 2013), confirmed
//! two-sidedly before anything is replaced.
//!
//! 1. **Candidates** (`gate.rs`): a sample the channel's ARIMA forecast did not expect by more
//!    than k tracked σ (with a jump test, run hysteresis, `max_run`, level changes), or a bad
//!    value (non-finite, beyond any MEMS range, saturated). Without a model a channel identifies
//!    one from its first `warmup_samples` (fewer once they span `warmup_max_s`, never fewer than
//!    the identification needs: `gate::WarmupLimits`); meanwhile a robust jump test on the raw
//!    increments makes the candidates, so warm-up is guarded too.
//! 2. **Confirmation** (`confirm.rs`): an event (successive candidates of one channel) is held
//!    until `post_samples` samples after it have arrived; it is a gross error only if it breaks
//!    the signal around it by more than `confirm_k` times that signal's own roughness, and it is
//!    not part of a shock seen on other axes (their raw values: ≥ 2 other channels beyond 4σ
//!    within one sample of its start, or one beyond 4σ and half the event's own break, unless
//!    that channel's own gross errors are frequent enough to coincide by chance; a one-sample
//!    event whose partners were off on that sample only is a corrupted frame, not a shock —
//!    unless its one partner is on its own triad and under `confirm_k` there: one vector
//!    moving; tested at the event's start and at its judged part's; an event in a shock's
//!    after-context also counts as part of it when two partners are sharp on its first sample
//!    against their roughness before that shock — the shock still ringing), and
//!    not a break covering under a third of an event the gate itself called motion (a level
//!    change, the release rule). Around a one-sample event, a later isolated candidate is left
//!    out of the context (`verdict.rs`). Opt-in (`level_window_s` > 0, off by default): a
//!    judged part shorter than the smoothness test needs (`confirm::SMOOTH_MIN` = 4 samples)
//!    must also lie at least `level_k` robust σ from the level the channel held over the last
//!    `level_window_s` of its own time stamps (the *level test*; measured in
//!    `docs/real-data.md`). At rest (`rest.rs`, `rest_k`): an event these shape tests let pass
//!    is still a gross error when it lies `rest_k` spreads off the channel's resting level,
//!    this channel and every other one at rest around it and the others still during it.
//! 3. **Output.** A confirmed event is replaced (default: by the two-sided interpolation) and
//!    flagged `REPLACED` + per-channel bit. An unconfirmed one passes unchanged, flagged
//!    per-channel `SUSPECT`: weak evidence never changes a value. Bad values are always
//!    replaced (`NON_FINITE` or the channel's saturation bit says why), saturated ones only when
//!    confirmed (the rail is the best measurement there is).
//!
//! **Latency.** Samples are held only while an event is open on some channel: then the output
//! waits until every event that touches a sample is judged (at most `lookahead_samples`, default
//! 16; an event still open then is passed as suspect). Outside events — all but a few samples in
//! a thousand on the real recordings — a sample leaves in the same call it arrived in. With
//! `lookahead_samples = 0` the stage is strictly causal: nothing is held, and candidates pass
//! flagged suspect (bad values are replaced by the prediction).
//!
//! After an event judged motion the gate continues from the raw values, not from the
//! predictions it fed itself during the event, so one real manoeuvre does not cascade into a
//! string of events.
//!
//! **Lines.** When a channel's model holds a vibration line, every test judges the channel
//! with the tracked line taken out, and a replacement gets it back (`line.rs`).
//!
//! A sample that copies the previous one bit for bit where whole samples rarely repeat by
//! chance is a stale repeat (`repeat.rs`): flagged `REPEATED`, given the output of the sample it
//! repeats, and no measurement for any stage.

pub mod confirm;
pub mod gate;
pub mod guard;
pub mod health;
pub mod identify;
mod line;
use line::ChannelLine;
mod repeat;
pub mod rest;
mod search;
use repeat::RepeatDetector;
pub mod settings;
mod verdict;
pub use verdict::EventVerdict;

use std::collections::VecDeque;

pub use gate::ChannelCounters;
use gate::{ChannelGate, GateParams, Mode, Outcome};
use guard::JumpGuard;

pub use settings::{
    GrossErrorSettings, MAX_CONTEXT, MAX_LOOKAHEAD, MAX_MEDIAN_WINDOW, MAX_POST, Replacement,
    ValidGrossErrorSettings,
};
use verdict::RATE_WINDOW;

use crate::model::arima::{ArimaError, ArimaModelFile};
use crate::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use crate::settings::{IntoValid, SettingsErrors};
use crate::stage::Stage;
use crate::stage::health::StageHealth;

/// The flags a repeat copies from the sample it repeats, besides its values.
const VERDICT_FLAGS: u32 = flags::REPLACED
    | flags::REPLACED_ANY
    | flags::SUSPECT_ANY
    | flags::NON_FINITE
    | flags::SAT_ANY
    | flags::WARMING_UP;

/// Raw history kept per channel (samples): context + look-ahead + post context fit in it.
const RING: usize = 2048;
/// Events per channel awaiting a verdict at once; one more forces the oldest's verdict.
const MAX_PENDING: usize = 8;
/// Longest event the confirmation judges (samples); longer ones pass as suspect.
const MAX_EVENT: usize = 64;
/// Shocks remembered (`GrossErrorStage::shocks`): more than the events of all channels whose
/// verdicts can fall within one event's after-context.
const SHOCK_MEMORY: usize = 16;

/// Why the stage could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GrossErrorError {
    #[error(transparent)]
    InvalidSettings(SettingsErrors),
    #[error(transparent)]
    Model(#[from] ArimaError),
}

/// An event of one channel awaiting its verdict.
#[derive(Debug, Clone, Copy)]
struct OpenEvent {
    /// Index of its first sample.
    start: u64,
    /// Index of the first sample after it, once it has ended.
    end: Option<u64>,
    /// The gate's own verdict: motion (a level change or the release rule).
    motion: bool,
}

/// One channel's stage state.
#[derive(Debug, Clone)]
struct Channel {
    gate: ChannelGate,
    guard: JumpGuard,
    /// Events awaiting their verdict, oldest first; only the newest may still be open (no end).
    /// An event's verdict waits for the samples after it even if another event starts there.
    pending: VecDeque<OpenEvent>,
    /// Best values so far (raw, or the replacement of a confirmed gross error), by index % RING.
    ring: Box<[f64; RING]>,
    /// The raw values by index % RING (NaN for a bad value): what the several-axes test reads,
    /// so that a partner judged first (and replaced) still counts as a partner.
    raw: Box<[f64; RING]>,
    /// The gate's prediction at each index (what a bad value falls back to).
    preds: Box<[f64; RING]>,
    /// Confirmed gross errors per sample, exponentially weighted over `RATE_WINDOW` samples.
    gross_rate: f64,
    /// The vibration line the channel's model holds, tracked (module docs, "Lines").
    line: ChannelLine,
}

/// One sample held while an event that touches it is judged.
#[derive(Debug, Clone, Copy)]
struct Held {
    idx: u64,
    out: Sample,
}

/// The gross-error stage (module docs).
#[derive(Debug, Clone)]
pub struct GrossErrorStage {
    s: ValidGrossErrorSettings,
    p: GateParams,
    ch: Vec<Channel>,
    last_seq: Option<u32>,
    gaps_bridged: u64,
    gaps_reset: u64,
    /// Index of the measurement being processed (repeats share their original's).
    n_in: u64,
    /// Tells a stale repeat of the last sample from a chance one.
    repeat: RepeatDetector,
    /// The last sample emitted and its measurement index (a repeat of it copies its verdicts).
    last_out: Option<(u64, Sample)>,
    /// Stale repeats seen.
    repeats: u64,
    held: VecDeque<Held>,
    /// Samples that waited in `held`, and the longest wait (samples).
    delayed: u64,
    max_delay: u64,
    /// Every event's verdict, oldest first, once `record_verdicts` asked for them.
    verdicts: Option<Vec<EventVerdict>>,
    /// The latest events (any channel) the several-axes test called a shock, round robin: their
    /// start and end. An event in a shock's after-context is also judged against the partners'
    /// roughness before that shock (`verdict.rs`, `shock`).
    shocks: [(u64, u64); SHOCK_MEMORY],
    shock_next: usize,
    /// Time between successive measurements: the sum of the intervals (ns) that do not end in a
    /// gap, their count, and the last measurement's time stamp.
    span_ns: u64,
    intervals: u64,
    last_t: Option<u64>,
    /// Scratch for the level test (allocated once).
    level_buf: Box<[f64; RING]>,
    /// Identification of the channels that warm up.
    identifier: identify::Identifier,
    searcher: search::Searcher,
}

impl GrossErrorStage {
    /// Build the stage. Channels with a model in `models` (matched by name) start active; the
    /// other enabled channels warm up and identify their own.
    pub fn new(
        settings: impl IntoValid<Valid = ValidGrossErrorSettings>,
        models: Option<&ArimaModelFile>,
    ) -> Result<Self, GrossErrorError> {
        let settings = settings
            .into_valid()
            .map_err(GrossErrorError::InvalidSettings)?;
        let p = GateParams::new(&settings);
        let mut ch = Vec::with_capacity(N_CHANNELS);
        for (c, name) in CHANNEL_NAMES.iter().enumerate() {
            let min_sigma = if c < 3 {
                settings.min_sigma_gyro_rad_s
            } else {
                settings.min_sigma_accel_m_s2
            };
            let mut gate = ChannelGate::new(settings.enabled[c], min_sigma);
            // Channel c takes a deferred model over c samples after the deferral's end: one
            // take-over per call (0.3–1.2 ms of CPU for six at once, `cargo bench --bench latency`).
            gate.set_stagger(c);
            if gate.mode != Mode::Disabled {
                match models.and_then(|m| m.channel(name)) {
                    // A line in the model: its amplitude and phase come from the warm-up.
                    Some(m) if m.line_per_sample.is_some() => gate.warm_up_for(&p, m.clone())?,
                    Some(m) => gate.activate(&p, m.clone())?,
                    None => gate.reserve_warmup(&p.warmup),
                }
            }
            ch.push(Channel {
                gate,
                guard: JumpGuard::new(min_sigma),
                pending: VecDeque::with_capacity(MAX_PENDING),
                ring: Box::new([f64::NAN; RING]),
                raw: Box::new([f64::NAN; RING]),
                preds: Box::new([f64::NAN; RING]),
                gross_rate: 0.0,
                line: ChannelLine::new(),
            });
        }
        // A worker identifies the models of channels that warm up, and another searches the
        // channels for lines (`line.rs`), unless told to do it inline.
        let warms = ch.iter().any(|c: &Channel| c.gate.mode == Mode::WarmingUp);
        let identifier =
            identify::Identifier::new(settings.identify, warms && p.warmup.defer_max > 0);
        let searcher = search::Searcher::new(p.warmup.defer_max > 0, line::search_window);
        Ok(GrossErrorStage {
            held: VecDeque::with_capacity(4 * settings.lookahead_samples + 8),
            s: settings,
            p,
            ch,
            last_seq: None,
            gaps_bridged: 0,
            gaps_reset: 0,
            n_in: 0,
            repeat: RepeatDetector::default(),
            last_out: None,
            repeats: 0,
            delayed: 0,
            max_delay: 0,
            verdicts: None,
            shocks: [(u64::MAX, 0); SHOCK_MEMORY],
            shock_next: 0,
            span_ns: 0,
            intervals: 0,
            last_t: None,
            level_buf: Box::new([0.0; RING]),
            identifier,
            searcher,
        })
    }

    /// The settings in use.
    pub fn settings(&self) -> &GrossErrorSettings {
        &self.s
    }

    /// Models in use (given or identified so far), for writing a model file.
    pub fn models(&self) -> ArimaModelFile {
        ArimaModelFile {
            channels: self
                .ch
                .iter()
                .filter_map(|c| c.gate.model.clone())
                .collect(),
        }
    }

    /// Counters of channel `c`.
    pub fn channel_counters(&self, c: usize) -> ChannelCounters {
        self.ch[c].gate.counters
    }

    /// Tracked innovation σ of channel `c` (None unless active).
    pub fn sigma(&self, c: usize) -> Option<f64> {
        self.ch[c].gate.sigma()
    }

    /// Tracked jump σ_Δ of channel `c` (None unless active).
    pub fn jump_sigma(&self, c: usize) -> Option<f64> {
        self.ch[c].gate.jump_sigma()
    }

    /// Keep every event's verdict from now on (off by default: a diagnostic, it allocates as
    /// events are judged); [`GrossErrorStage::take_verdicts`] hands them over.
    pub fn record_verdicts(&mut self) {
        self.verdicts.get_or_insert_with(Vec::new);
    }

    /// The verdicts recorded since the last call (empty unless `record_verdicts` was called).
    pub fn take_verdicts(&mut self) -> Vec<EventVerdict> {
        self.verdicts
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Samples that were held for an event's verdict, and the longest hold (samples).
    pub fn delays(&self) -> (u64, u64) {
        (self.delayed, self.max_delay)
    }

    /// Give repeat `s` the output values and verdict flags of the sample it repeats.
    fn copy_verdicts(&self, s: &mut Sample) {
        if let Some((_, prev)) = &self.last_out {
            s.set_channels(&prev.channels());
            s.flags |= prev.flags & VERDICT_FLAGS;
        }
    }

    /// The causal path's repeat handling: true (and `s` completed) if `s` is a repeat.
    fn take_repeat(&mut self, s: &mut Sample) -> bool {
        if !self.repeat.is_repeat(s) {
            return false;
        }
        s.flags |= flags::REPEATED;
        self.repeats += 1;
        self.copy_verdicts(s);
        true
    }

    fn min_sigma(&self, c: usize) -> f64 {
        if c < 3 {
            self.s.min_sigma_gyro_rad_s
        } else {
            self.s.min_sigma_accel_m_s2
        }
    }

    /// Floor of the confirmation's scale σ̂: `min_sigma`, and no lower than the channel's own
    /// quantisation noise, LSB/√12 (a flat quantised context has no roughness, but a one-LSB
    /// toggle in it is the sensor's resolution, not a break: 3.5 σ̂ at this floor).
    fn sigma_floor(&self, c: usize) -> f64 {
        self.min_sigma(c)
            .max(self.ch[c].gate.resolution() / 12f64.sqrt())
    }

    fn plausible(&self, c: usize) -> f64 {
        if c < 3 {
            self.s.plausible_gyro_rad_s
        } else {
            self.s.plausible_accel_m_s2
        }
    }

    /// Gate every enabled channel of `s` (index `n_in`); open, end and resolve events. With
    /// `hold`, verdicts wait for the look-ahead; without, they are applied to `s` at once.
    fn step(&mut self, s: &mut Sample, hold: bool) {
        if s.has(flags::GAP) {
            self.on_gap(s.seq);
        }
        // Samples since the previous measurement (a gap's missing ones too): what a line's
        // reference advances by.
        let steps = match self.last_seq {
            Some(last) if s.has(flags::GAP) => s.seq.wrapping_sub(last).clamp(1, 1 << 16),
            _ => 1,
        };
        self.last_seq = Some(s.seq);
        if let Some(l) = self.last_t
            && !s.has(flags::GAP)
            && s.t_ns > l
        {
            self.span_ns += s.t_ns - l;
            self.intervals += 1;
        }
        self.last_t = Some(s.t_ns);
        let idx = self.n_in;
        let slot = (idx % RING as u64) as usize;
        let mut warming = false;
        for c in 0..N_CHANNELS {
            // An absent channel is no measurement: no gate, no event, no verdict (its ring
            // stays NaN, so it is no partner of the several-axes test either).
            if self.ch[c].gate.mode == Mode::Disabled || s.is_absent(c) {
                continue;
            }
            let x = s.channel(c);
            let saturated = s.flags & flags::sat_ch(c) != 0;
            let finite = x.is_finite();
            let implausible = finite && x.abs() > self.plausible(c);
            let bad = !finite || implausible;
            // With a line, every test below judges the value less the line predicted for it.
            let line = self.line_step(c, idx, steps);
            let v = if bad { x } else { x - line };
            {
                let k = &mut self.ch[c].gate.counters;
                if !finite {
                    s.flags |= flags::NON_FINITE;
                    k.non_finite += 1;
                }
                if implausible {
                    s.flags |= flags::sat_ch(c);
                    k.implausible += 1;
                }
                if saturated {
                    k.saturated += 1;
                }
            }
            self.ch[c].ring[slot] = v;
            self.ch[c].gross_rate *= 1.0 - 1.0 / RATE_WINDOW;
            self.ch[c].raw[slot] = if bad { f64::NAN } else { v };
            let was_warm = self.ch[c].gate.mode == Mode::WarmingUp;
            let usable = !bad && !saturated;
            let jumped = usable && self.ch[c].guard.candidate(v, self.s.k, self.s.max_run);
            let outcome = if was_warm {
                warming = true;
                self.warm_step(c, s, usable, jumped)
            } else {
                self.ch[c].gate.gate(&self.p, v, bad, saturated, jumped)
            };
            let accepted = usable && !matches!(outcome, Outcome::Candidate { .. });
            self.ch[c].guard.commit(v, accepted);
            if accepted {
                self.ch[c].line.learn(x);
            }
            self.ch[c].preds[slot] = match outcome {
                Outcome::Candidate { pred } => pred,
                _ => f64::NAN,
            };
            let ended = self.ch[c].gate.ended.take();
            match outcome {
                Outcome::Candidate { pred } => {
                    if !hold {
                        // Causal: no evidence beyond the gate; bad values are replaced.
                        self.apply_causal(c, s, bad, pred);
                        continue;
                    }
                    let open = self.ch[c].pending.back().is_some_and(|e| e.end.is_none());
                    if !open {
                        if self.ch[c].pending.len() == MAX_PENDING {
                            self.resolve(c, idx);
                        }
                        self.open(c, idx);
                    }
                }
                Outcome::LevelChange => {
                    s.flags |= flags::LEVEL_CHANGE;
                    if let Some(ev) = self.ch[c].pending.back_mut()
                        && ev.end.is_none()
                    {
                        ev.end = Some(idx);
                        ev.motion = true;
                    }
                }
                Outcome::Passed | Outcome::Warming => {
                    if let (Some(e), Some(ev)) = (ended, self.ch[c].pending.back_mut())
                        && ev.end.is_none()
                    {
                        ev.end = Some(idx);
                        ev.motion |= e.motion;
                    }
                }
            }
            // The warm-up ended on this sample: an open warm-up event ends with it (the gate
            // starts afresh and knows nothing of it).
            if was_warm
                && self.ch[c].gate.mode == Mode::Active
                && let Some(ev) = self.ch[c].pending.back_mut()
                && ev.end.is_none()
            {
                ev.end = Some(idx + 1);
            }
        }
        if warming {
            s.flags |= flags::WARMING_UP;
        }
    }

    /// Warm-up of channel `c`: feed the identification buffer; the jump guard alone makes the
    /// candidates (`jumped`), and bad values are candidates too.
    fn warm_step(&mut self, c: usize, s: &Sample, usable: bool, jumped: bool) -> Outcome {
        let v = s.channel(c);
        let ch = &mut self.ch[c];
        let candidate = !usable || jumped;
        if !candidate && ch.guard.run() > 0 {
            ch.gate.ended = Some(gate::EventEnd { motion: false });
        }
        let activated = ch.gate.warm_push(
            &self.p,
            usable.then_some(v),
            s.t_ns,
            s.has(flags::GAP),
            &self.identifier,
            CHANNEL_NAMES[c],
        );
        // The guard learns the channel's LSB as the warm-up tells it, and again from the whole
        // window at activation.
        let n = ch.gate.warm_len();
        if activated
            || (usable && (gate::GRID_MIN_SAMPLES..=gate::GRID_SETTLED_SAMPLES).contains(&n))
        {
            ch.guard.set_quantum(ch.gate.resolution());
        }
        if candidate {
            Outcome::Candidate {
                pred: ch.guard.last(),
            }
        } else {
            Outcome::Warming
        }
    }

    /// Channel `c`'s line estimate for its sample at index `idx`, `steps` samples after the
    /// previous one (0 without a line); a channel that has just become active is first looked
    /// at for a line.
    fn line_step(&mut self, c: usize, idx: u64, steps: u32) -> f64 {
        let ch = &mut self.ch[c];
        if !ch.line.checked() && ch.gate.mode == Mode::Active {
            let stagger = c as u64 * line::LINE_SEARCH_SAMPLES / N_CHANNELS as u64;
            ch.line.adopt(
                ch.gate.line,
                ch.gate.model.as_ref(),
                idx,
                stagger,
                CHANNEL_NAMES[c],
            );
        }
        if ch.line.take_up(idx, c, &self.searcher, CHANNEL_NAMES[c]) {
            ch.gate.counters.lines_found += 1;
        }
        if ch.line.search_due(idx) && idx >= RING as u64 {
            ch.line.start_search(&ch.ring, idx, c, &self.searcher);
        }
        ch.line.predict(idx, steps)
    }

    fn open(&mut self, c: usize, idx: u64) {
        self.ch[c].pending.push_back(OpenEvent {
            start: idx,
            end: None,
            motion: false,
        });
    }

    /// Causal verdict on a candidate (no look-ahead): bad values are replaced by the prediction,
    /// the rest pass flagged suspect.
    fn apply_causal(&mut self, c: usize, s: &mut Sample, bad: bool, pred: f64) {
        let r = self.ch[c].line.put_back(self.n_in, pred);
        let k = &mut self.ch[c].gate.counters;
        if bad && pred.is_finite() {
            s.set_channel(c, r);
            s.flags |= flags::REPLACED | flags::replaced_ch(c);
            k.replaced += 1;
        } else {
            s.flags |= flags::suspect_ch(c);
            k.suspect += 1;
        }
    }

    /// Handle `flags::GAP`: bridge or reset; open events are judged at once (their context ends
    /// at the gap).
    fn on_gap(&mut self, seq: u32) {
        let upto = self.n_in;
        for c in 0..N_CHANNELS {
            if let Some(ev) = self.ch[c].pending.back_mut() {
                ev.end.get_or_insert(upto);
            }
            while !self.ch[c].pending.is_empty() {
                self.resolve(c, upto);
            }
        }
        let missing = self
            .last_seq
            .map(|last| seq.wrapping_sub(last).wrapping_sub(1));
        match missing {
            Some(m) if m <= self.s.bridge_max_missing => {
                self.gaps_bridged += 1;
                for ch in self.ch.iter_mut() {
                    ch.gate.bridge(m);
                }
            }
            _ => {
                self.gaps_reset += 1;
                for ch in self.ch.iter_mut() {
                    ch.gate.reset();
                    ch.guard.reset();
                }
            }
        }
    }

    /// Judge the events that have all the context they wait for (or have waited too long).
    fn resolve_ready(&mut self) {
        let now = self.n_in;
        let lookahead = self.s.lookahead_samples as u64;
        let post = self.s.post_samples as u64;
        for c in 0..N_CHANNELS {
            while let Some(ev) = self.ch[c].pending.front().copied() {
                let ready = ev.end.is_some_and(|e| now + 1 >= e + post);
                if ready || now + 1 - ev.start >= lookahead {
                    self.resolve(c, now + 1);
                } else {
                    break;
                }
            }
        }
    }

    /// Emit the held samples no open event touches, oldest first.
    fn emit(&mut self, out: &mut Vec<Sample>) {
        let oldest_open = self
            .ch
            .iter()
            .filter_map(|c| c.pending.front().map(|e| e.start))
            .min()
            .unwrap_or(u64::MAX);
        while let Some(h) = self.held.front() {
            if h.idx >= oldest_open {
                break;
            }
            let h = self.held.pop_front().expect("front exists");
            let wait = self.n_in - h.idx;
            if wait > 0 {
                self.delayed += 1;
                self.max_delay = self.max_delay.max(wait);
            }
            self.last_out = Some((h.idx, h.out));
            out.push(h.out);
        }
    }
}

fn at_ring(ring: &[f64; RING], i: u64) -> f64 {
    ring[(i % RING as u64) as usize]
}

impl GrossErrorStage {
    /// The causal stage: one sample in, the same sample out, no look-ahead (module docs); what
    /// [`Stage::push`] does when `lookahead_samples` is 0.
    pub fn process(&mut self, mut s: Sample) -> Sample {
        if self.take_repeat(&mut s) {
            return s;
        }
        self.step(&mut s, false);
        self.last_out = Some((self.n_in, s));
        self.n_in += 1;
        s
    }
}

impl Stage for GrossErrorStage {
    fn name(&self) -> &'static str {
        "gross_error"
    }

    fn push(&mut self, mut s: Sample, out: &mut Vec<Sample>) {
        if self.s.lookahead_samples == 0 {
            out.push(self.process(s));
            return;
        }
        if self.repeat.is_repeat(&s) {
            s.flags |= flags::REPEATED;
            self.repeats += 1;
            match self.held.back() {
                // Its measurement is still being judged: it takes what the measurement carries
                // now (its warm-up flag, a verdict of a channel already judged) and gets the
                // verdicts still to come with it.
                Some(h) => {
                    let idx = h.idx;
                    s.set_channels(&h.out.channels());
                    s.flags |= h.out.flags & VERDICT_FLAGS;
                    self.held.push_back(Held { idx, out: s });
                }
                None => {
                    self.copy_verdicts(&mut s);
                    out.push(s);
                }
            }
            return;
        }
        self.step(&mut s, true);
        self.held.push_back(Held {
            idx: self.n_in,
            out: s,
        });
        self.resolve_ready();
        self.emit(out);
        self.n_in += 1;
    }

    fn flush(&mut self, out: &mut Vec<Sample>) {
        let upto = self.n_in;
        for c in 0..N_CHANNELS {
            while !self.ch[c].pending.is_empty() {
                self.resolve(c, upto);
            }
        }
        self.emit(out);
    }

    fn lookahead(&self) -> usize {
        self.s.lookahead_samples
    }

    fn health(&self) -> StageHealth {
        StageHealth::GrossError(GrossErrorStage::health(self))
    }
}
