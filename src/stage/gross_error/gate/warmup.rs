//! A channel's warm-up: the window it identifies its model from, the deferral while the
//! stage's worker identifies it ([`super::super::identify`]), and activation on a model.

use super::*;

/// The largest [`ChannelGate::set_stagger`] the buffers have room for (one per channel).
pub const MAX_STAGGER: usize = crate::sample::N_CHANNELS;

/// When a channel's warm-up ends: at `samples` kept samples, or once they span `max_span_ns`
/// of their own time (a low-rate sensor identifies within a bounded time), but never on fewer
/// than `min_samples`.
///
/// The time is the sum of the intervals between successive kept samples, except an interval
/// that ends in a gap (a sample flagged [`flags::GAP`](crate::sample::flags::GAP) since the last
/// kept one): no samples came in it, so it is no warm-up time. The gap is the source's own
/// judgement, the one the stage bridges or resets on: from a sequence jump on the wire, and on
/// imported recordings from the time stamps (`io::timing`: beyond 1.5 nominal intervals, or 10
/// mean intervals for bursty host stamps). A gap rule of a few *median* intervals, learned here,
/// would fail on bursty stamps: the MPU6050 log's median interval is 2.0 ms against a mean of
/// 10.1 ms (pauses of 150–300 ms between bursts), so nearly all its time would fall in "gaps".
/// Stale repeats never reach the gate, and their time counts in the next interval; time stamps
/// that do not advance count no time, and the count of samples decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WarmupLimits {
    pub samples: usize,
    pub max_span_ns: u64,
    /// The identification's own minimum (`IdentifySettings::min_len`: 120 with the default
    /// orders): its long AR needs n/10 ≥ 2 max(p, q) (20 (p_max + q_max + 1)), its ACF/PACF and
    /// Ljung–Box 2 × 20 lags + 2, and the Hampel filter before it (half-width 10) 21 samples;
    /// the ADF's Schwert lag at 120 samples is 13, well inside. Fewer, and `identify` refuses
    /// the series (a white-noise fallback, no model at all).
    pub min_samples: usize,
    /// After the window closes, the warm-up goes on while a worker identifies the model: for
    /// `defer_ns` of the same time (0: identify inline), at most `defer_max` samples (time
    /// stamps that do not advance); see [`super::identify`].
    pub defer_ns: u64,
    pub defer_max: usize,
}

impl WarmupLimits {
    pub fn new(s: &GrossErrorSettings) -> Self {
        WarmupLimits {
            samples: s.warmup_samples,
            max_span_ns: (s.warmup_max_s * 1e9).round() as u64,
            min_samples: s.identify.min_len().min(s.warmup_samples),
            defer_ns: (s.identify_defer_s * 1e9).round() as u64,
            defer_max: if s.identify_defer_s > 0.0 {
                s.warmup_samples
            } else {
                0
            },
        }
    }

    /// Warm-up samples kept at most: the window and the deferral's.
    pub fn capacity(&self) -> usize {
        self.samples + self.deferral_capacity()
    }

    /// Samples kept at most after the window closed (0 without a deferral).
    pub fn deferral_capacity(&self) -> usize {
        if self.defer_max > 0 {
            self.defer_max + MAX_STAGGER
        } else {
            0
        }
    }
}

/// A window handed to the worker: its result, where the window closed (kept samples, warm-up
/// time), and the samples since the deferral's end.
#[derive(Debug, Clone)]
pub(super) struct Deferred {
    pending: Pending,
    closed_n: usize,
    closed_ns: u64,
    due: usize,
}

/// A model's predictor and jump reference run through a warm-up series, with the innovations
/// and jumps they met: the state a channel activates in. Computed off the sample path for a
/// deferred identification ([`super::super::identify`]), then carried through the samples since.
#[derive(Debug, Clone, PartialEq)]
pub struct Seed {
    pred: ArimaPredictor,
    level: f64,
    slope: f64,
    innov: Vec<f64>,
    jumps: Vec<f64>,
}

impl Seed {
    /// The seed of `model` on `warm` (oldest first); `None` when `warm` is too short to seed
    /// from (the channel then starts from the model's own scales).
    pub fn new(
        p: &GateParams,
        model: &ArimaChannelModel,
        warm: &[f64],
    ) -> Result<Option<Seed>, ArimaError> {
        let mut pred = ArimaPredictor::new(model, p.level_alpha, p.trend_beta)?;
        if warm.len() <= RAW_KEEP + 1 {
            return Ok(None);
        }
        let seed: Vec<f64> = warm[..RAW_KEEP].iter().rev().copied().collect();
        pred.reseed(&seed);
        let mut sd = Seed {
            pred,
            level: warm[RAW_KEEP - 1],
            slope: 0.0,
            // Room for the samples a deferred activation carries it through.
            innov: Vec::with_capacity(warm.len() + p.warmup.deferral_capacity()),
            jumps: Vec::with_capacity(warm.len() + p.warmup.deferral_capacity()),
        };
        sd.extend(p, &warm[RAW_KEEP..]);
        Ok(Some(sd))
    }

    /// Run on through `x`.
    pub fn extend(&mut self, p: &GateParams, x: &[f64]) {
        for &v in x {
            let e = v - self.pred.predict();
            self.jumps.push(v - self.level - self.slope);
            self.innov.push(e);
            self.pred.update(v, e);
            (self.level, self.slope) =
                holt_step(self.level, self.slope, v, p.jump_level_alpha, p.slope_alpha);
        }
    }
}

impl ChannelGate {
    /// Take a deferred model over `k` samples after the deferral's end (construction time; at
    /// most [`MAX_STAGGER`]).
    pub fn set_stagger(&mut self, k: usize) {
        self.stagger = k.min(MAX_STAGGER);
    }

    /// Reserve the warm-up buffers (construction time) for `limits`.
    pub fn reserve_warmup(&mut self, limits: &WarmupLimits) {
        self.warm.reserve_exact(limits.capacity());
        self.tail.reserve_exact(limits.deferral_capacity());
        self.hampel_scratch = HampelScratch::new(HAMPEL_HALF_WIDTH);
        if limits.defer_max > 0 {
            let mut job = vec![f64::NAN; limits.samples];
            std::hint::black_box(&mut job);
            job.clear();
            self.job_buf = job;
        }
    }

    /// Switch to a given `model` (a model file's): the predictor seeds itself on the first
    /// samples, the scales start from the model's own.
    pub fn activate(&mut self, p: &GateParams, model: ArimaChannelModel) -> Result<(), ArimaError> {
        self.activate_seeded(p, model, None)
    }

    /// Take a model file's `model` that declares a line (`line_per_sample`): the channel warms
    /// up, then fits the line on its window and seeds the model on the window without it
    /// ([`identify_window`](super::super::identify::identify_window)) instead of identifying.
    pub fn warm_up_for(
        &mut self,
        p: &GateParams,
        model: ArimaChannelModel,
    ) -> Result<(), ArimaError> {
        // Validated as `activate` would (the predictor's online limits).
        ArimaPredictor::new(&model, p.level_alpha, p.trend_beta)?;
        self.given = Some(model);
        self.reserve_warmup(&p.warmup);
        Ok(())
    }

    /// Switch to `model`, with the predictor and scales from `seed` where there is one.
    fn activate_seeded(
        &mut self,
        p: &GateParams,
        model: ArimaChannelModel,
        seed: Option<Seed>,
    ) -> Result<(), ArimaError> {
        // The predictor first: it validates the model (orders within the online limits) that
        // the rest indexes by.
        let pred = match seed {
            Some(sd) => {
                // Initial scales from the most recent part of the window (conditions may have
                // changed during the warm-up).
                let recent = (p.scale_window.round() as usize)
                    .max(50)
                    .min(sd.innov.len());
                let (_, s_e) = upper_median_and_mad_sigma(&sd.innov[sd.innov.len() - recent..]);
                let (_, s_d) = upper_median_and_mad_sigma(&sd.jumps[sd.jumps.len() - recent..]);
                self.sig2 = (s_e * s_e).max(self.min_var);
                self.jump2 = (s_d * s_d).max(self.min_var);
                self.x_acc = sd.level;
                self.slope = sd.slope;
                self.needs_seed = false;
                sd.pred
            }
            None => {
                let pred = ArimaPredictor::new(&model, p.level_alpha, p.trend_beta)?;
                self.sig2 = (model.sigma * model.sigma).max(self.min_var);
                self.jump2 = model_increment_var(&model).max(self.min_var);
                self.needs_seed = true;
                pred
            }
        };
        let mut psi = [0.0; PSI_N];
        psi_weights(&model, &mut psi);
        let mut acc = 0.0;
        for (r, ps) in self.r2.iter_mut().zip(&psi) {
            acc += ps * ps;
            *r = acc;
        }
        self.pred = Some(pred);
        self.model = Some(model);
        self.mode = Mode::Active;
        self.run = 0;
        self.h = 1;
        self.warm = Vec::new();
        self.tail = Vec::new();
        Ok(())
    }

    /// The channel's quantisation step: the warm-up's [`grid_step`], and during the warm-up that
    /// of the samples so far (from `GRID_MIN_SAMPLES` on; before, 0). Called when an event is
    /// judged, and for the jump guard at each of the warm-up's first `GRID_SETTLED_SAMPLES`
    /// samples (a pass over at most that many values) and at activation.
    pub fn resolution(&self) -> f64 {
        if self.mode == Mode::WarmingUp {
            if self.warm.len() >= GRID_MIN_SAMPLES {
                grid_step(&self.warm)
            } else {
                0.0
            }
        } else {
            self.resolution
        }
    }

    /// Warm-up samples kept so far (0 once active).
    pub fn warm_len(&self) -> usize {
        self.warm.len()
    }

    /// Warm-up time counted so far, s (see [`WarmupLimits`]).
    pub fn warmup_span_s(&self) -> f64 {
        self.warm_span_ns as f64 * 1e-9
    }

    /// One warm-up sample at time `t_ns` (`gap`: flagged [`flags::GAP`](crate::sample::flags::GAP);
    /// finite, plausible, unsaturated values are kept); at `p.warmup.samples` kept samples, or
    /// once they span `p.warmup.max_span_ns` with at least `p.warmup.min_samples` of them, the
    /// channel identifies its model and activates. Returns true when it activated.
    pub fn warm_push(
        &mut self,
        p: &GateParams,
        v: Option<f64>,
        t_ns: u64,
        gap: bool,
        id: &Identifier,
        name: &str,
    ) -> bool {
        self.counters.warmup += 1;
        self.warm_gap |= gap;
        if let Some(v) = v {
            self.warm.push(v); // within the reserved capacity: no allocation
            if let Some(last) = self.warm_last_t
                && !self.warm_gap
            {
                self.warm_span_ns += t_ns.saturating_sub(last);
            }
            self.warm_last_t = Some(t_ns);
            self.warm_gap = false;
        }
        let w = &p.warmup;
        let n = self.warm.len();
        if let Some(mut d) = self.deferred.take() {
            let closed_n = d.closed_n;
            // Each sample since the window closed is cleaned once it has its context.
            if v.is_some() && n > closed_n + HAMPEL_HALF_WIDTH {
                self.clean_tail(n - 1 - HAMPEL_HALF_WIDTH);
            }
            if n - closed_n >= w.defer_max || self.warm_span_ns - d.closed_ns >= w.defer_ns {
                d.due += 1;
            }
            if d.due <= self.stagger {
                self.deferred = Some(d);
                return false;
            }
            for j in closed_n + self.tail.len()..n {
                self.clean_tail(j);
            }
            let window = &self.warm[..closed_n];
            let mut r = match d.pending.wait() {
                Ok(r) => r,
                Err(Missing::Taken) => {
                    id.window(window, p, name, self.min_var, self.given.as_ref())
                }
                Err(Missing::Failed) => Identified::white(window, p, name, self.min_var),
            };
            if let Some(sd) = r.seed.as_mut() {
                // The model was identified without the window's line: so are the samples since
                // (the line continued over their indices).
                if let Some(l) = &r.line {
                    l.subtract_from(&mut self.tail, closed_n);
                }
                sd.extend(p, &self.tail);
            }
            self.finish(p, r, name);
            return true;
        }
        if n < w.samples && (n < w.min_samples || self.warm_span_ns < w.max_span_ns) {
            return false;
        }
        if w.defer_max > 0 {
            // The window goes to the worker in the buffer touched at construction: a fresh
            // allocation here faulted its pages in on the sample path.
            let mut job = std::mem::take(&mut self.job_buf);
            job.extend_from_slice(&self.warm);
            if let Some(pending) = id.start(job, p, name, self.min_var, self.given.as_ref()) {
                self.deferred = Some(Deferred {
                    pending,
                    closed_n: n,
                    closed_ns: self.warm_span_ns,
                    due: 0,
                });
                return false;
            }
        }
        let r = id.window(&self.warm, p, name, self.min_var, self.given.as_ref());
        self.finish(p, r, name);
        true
    }

    /// Append warm-up sample `j` (after the window), Hampel-cleaned as the window was, to the
    /// tail.
    fn clean_tail(&mut self, j: usize) {
        let v = hampel_at(
            &self.warm,
            j,
            HAMPEL_HALF_WIDTH,
            HAMPEL_K,
            &mut self.hampel_scratch,
        );
        self.tail.push(v.unwrap_or(self.warm[j]));
    }

    /// Activate on an identified (and seeded) window.
    fn finish(&mut self, p: &GateParams, r: Identified, name: &str) {
        self.resolution = r.resolution;
        // The next sample is the warm-up's next index (every kept sample is in `warm`).
        self.line = r.line.map(|l| l.shifted(self.warm.len() as f64));
        // The tracked scales never fall below the channel's quantisation noise, LSB/√12: on a
        // channel whose noise is below one LSB most samples repeat one code, the scales shrink
        // towards `min_sigma`, and every one-LSB toggle would make a candidate.
        self.min_var = self.min_var.max(self.resolution * self.resolution / 12.0);
        self.counters.fallback_models += r.fallbacks;
        if self.activate_seeded(p, r.model, r.seed).is_err() {
            // Cannot happen: an unseeded model was seeded once already. Fall back regardless.
            self.counters.fallback_models += 1;
            let fallback = white_model(&self.warm, name, self.min_var);
            // A white-noise model with a positive σ always runs.
            let _ = self.activate_seeded(p, fallback, None);
        }
    }
}
