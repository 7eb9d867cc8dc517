//! The online bias stage: deterministic calibration, learned effects, and the stochastic gyro
//! bias observed while still and propagated by its fitted model through motion.
//!
//! Per sample, in order (unit = rad/s for gyro channels, m/s² for accelerometer channels):
//!
//! 1. **Calibration** (all six channels): `corrected = M^-1 (raw - bias)`, `M = diag(scale) N`
//!    per triad ([`crate::stage::bias::settings`]).
//! 2. **Deterministic effects** of the model file (issue 6), subtracted from the channel:
//!    temperature `c1 (T_l - T0) + c2 (T_l - T0)^2` with the lagged temperature `T_l`
//!    ([`crate::stage::bias::temperature`]); gyro g-sensitivity `k · f` with `f` the calibrated specific
//!    force of the same sample.
//! 3. **Vibration lines**: each line is removed by an adaptive notch whose weights track its
//!    amplitude and phase continuously ([`crate::stage::bias::line_canceller`]; unit DC gain, so bias and
//!    manoeuvres pass).
//! 4. **Stillness** ([`crate::stage::bias::stillness`]) on the result, with the current gyro bias
//!    estimate as the reference rate.
//! 5. **Stochastic gyro bias** per gyro channel: a Kalman filter on the fitted model in
//!    state-space form ([`crate::stage::bias::kf`], model from
//!    [`crate::model::bias_state_space::state_space_from_model`]). Measurement `z = y - mean`
//!    (the expected true rate at rest is 0; the Earth rate, ≤ 7.3e-5 rad/s, is below consumer
//!    MEMS noise and is absorbed into the estimate) is used **only while still**, and with a delay
//!    of `update_delay_s`: a sample becomes a measurement only when the detector still
//!    reports rest that many samples later, so the onset of a manoeuvre never reaches the
//!    estimate. The published estimate is the filter's prediction over that delay. While moving
//!    the filter only predicts: the subtracted bias is the model's propagation, never the motion.
//!    A CUSUM on the normalised innovations ([`crate::stage::bias::cusum`]), present when the model has
//!    a `step` effect, inflates the random-constant state on an alarm so the filter re-anchors.
//!    A `rate_random_walk` effect sets that state's process noise.
//! 6. **Accelerometer channels**: calibration and deterministic effects only. Decision: at rest
//!    an accelerometer measures bias plus the gravity projection `g·(attitude)`, and the attitude
//!    is unknown here; a car stopping on a 1° slope moves a horizontal axis by 0.17 m/s², 10–100×
//!    a consumer accelerometer's bias instability. Estimating accel bias at stops would turn every
//!    change of parking attitude into "bias" and hand the GPS/INS filter beside us a wrong bias
//!    that also destroys its tilt observability; that filter, which knows the attitude, is the
//!    right place for accel bias. The published `bias_sd` of an accel channel with a model is the
//!    stationary 1-σ of its bias process: the uncertainty of the bias nobody subtracted.
//!
//! **Engaging on evidence** (`apply_k`, default 3). A gyro channel running the warm-up model
//! (the default: no model file) subtracts its estimate only once it is statistically
//! distinguishable from zero: |estimate| > `apply_k`·σ (99.7 % at 3σ, Gaussian). The channel is
//! then *engaged* for the rest of the run and follows its estimate. Until then the sample keeps
//! its value; the estimate and its σ are published in the stage health (`bias`, `bias_sd`,
//! `engaged`) and the sample's `bias_sd` is √(σ² + estimate²), the error of subtracting nothing.
//! Why: a GPS/INS filter downstream learns the residual constant bias itself; a correction with
//! no evidence behind it is noise that filter must learn again, and while the estimate settles
//! each change is a step — one made during a GNSS outage becomes attitude error
//! (docs/navigation.md, "Do no harm"). Measured alternatives, both rejected: holding an engaged
//! estimate until it moved by 3σ left a staircase that raised the ADIS16405 bench's output Allan
//! deviation above the raw's at τ = 20–80 s; asking a model file's estimate for the same
//! evidence (against the model's mean) withheld corrections that work — the MPU6050 bench's gy
//! never engaged, its τ = 165 s deviation stayed the raw's 3.4e-5 against 5.5e-6 when subtracted
//! (`tests/learned_allan_real.rs`). A fitted model's σ carries its AR part's stationary spread,
//! so its estimate is subtracted from the start, as before.
//!
//! Published per channel: `bias[c] = corrected - output` (everything subtracted after the
//! calibration: effects, line estimate, the stochastic estimate once engaged), `bias_sd[c]` = 1-σ
//! of what was subtracted as an estimate of the bias: σ from the filter covariance once engaged,
//! √(σ² + estimate²) before. Flags: `STILL`, `BIAS_REMOVED` (a gyro estimate runs: subtracted
//! where engaged, published with its σ), `WARMING_UP` (a gyro channel is still being identified: only calibration and
//! effects applied to it), `EFFECT_COMPENSATED` (a temperature, g-sensitivity or vibration term
//! was subtracted, or a step re-anchored the estimate), `NON_FINITE`.
//!
//! **Warm-up.** A gyro channel without a model collects the first contiguous still stretch of
//! `warmup.still_samples`, or `warmup.still_max_s` of them if fewer (at least
//! `MIN_STILL_SAMPLES`; into a buffer allocated at construction) and measures the sensor's
//! own white-noise variance R on it (about a fitted line, so drift is not counted as noise). Its
//! filter is then a random-walk bias under that noise, the walk's variance R/(T² fs) per second
//! for the time constant T = `warmup.time_constant_s`: a first-order low-pass whose complement
//! never amplifies any frequency, so the output's Allan deviation cannot rise at any τ, and
//! whose gain follows from the sensor's measured noise, not from a rate that fits one sensor
//! class. It starts at the stretch's mean with that mean's standard error. Until then, once the
//! still stretch holds one second of samples, its running mean is subtracted as a *provisional*
//! bias (published with its standard error; flags `WARMING_UP` and `BIAS_REMOVED`).
//! A stretch that holds one value (a stuck axis, or noise below one LSB) has no noise to
//! measure: it is started again, counted per channel (`constant_stretches` in the health) and
//! said once in a `WARN` line, and the channel stays warming up until it varies at rest.
//!
//! **Guarded updates.** A still measurement whose innovation lies beyond `GUARD_K` σ of its
//! predicted spread is not used (counted `rejected_updates`): a slow rotation the stillness
//! tests could not see must not move the estimate, so across a motion onset the estimate stays
//! within its own published σ. A bias that really moved (a shock) is still taken up: when every
//! still measurement has disagreed for `REANCHOR_S` seconds, the estimate's variance is
//! inflated to the disagreement and it re-anchors (counted `reanchors`). A steady turn is not
//! rest: a quiet offset that turned gravity in the accelerometer, or one about gravity larger
//! than the bias it departs from (stillness docs, "Steady turns"). It is counted
//! (`steady_turns` / `steady_turn_samples`), the first few said in a `WARN` line, and never
//! re-anchored onto.
//!
//! **Repeats.** A stale repeat (`REPEATED`) is no new measurement: it neither feeds the
//! stillness detector nor updates a filter, and it gets the current bias.
//!
//! **Time.** Steps between samples come from the sequence counter (robust to bursty host
//! timestamps), falling back to `t_ns` and the nominal rate when the counter does not advance.
//! After a gap longer than 100 samples the delay line is flushed without updates and the detector
//! restarts.

mod construct;
pub mod cusum;
pub mod health;
pub mod kf;
pub mod line_canceller;
pub mod settings;
pub mod stillness;
pub mod temperature;
mod warmup;

use nalgebra::Vector3;

use crate::model::bias_model::{BiasModelFile, Effect};
use crate::model::bias_state_space::{BiasStateSpace, StateSpaceError, state_space_from_model};
use crate::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use crate::settings::IntoValid;
use crate::stage::Stage;
use crate::stage::bias::cusum::Cusum;
use crate::stage::bias::health::{BiasCounters, BiasModelOrigin};
use crate::stage::bias::kf::{BiasKf, ConstantState, Lead};
use crate::stage::bias::line_canceller::LineCanceller;
use crate::stage::bias::settings::{
    Calibration, MAX_UPDATE_DELAY, SettingsErrors, ValidBiasSettings, WarmupSettings,
};
use crate::stage::bias::stillness::StillnessDetector;
use crate::stage::bias::temperature::TemperatureComp;
use crate::stage::health::StageHealth;

/// Most vibration lines cancelled per channel.
pub const MAX_LINES: usize = 4;
/// Gaps longer than this (samples) flush the delay line and restart the stillness detector.
const BIG_GAP_STEPS: u32 = 100;
/// Consistency guard: a still measurement beyond this many σ of its prediction is not used.
const GUARD_K: f64 = 4.0;
/// Still time during which every measurement disagreed before the estimate re-anchors, s.
const REANCHOR_S: f64 = 2.0;
/// Steady turns said in a `WARN` line; later ones are counted only.
const STEADY_TURNS_SAID: u64 = 3;
/// Cap of one still measurement's ν²/S in the running mean (one wild sample moves it by at
/// most `NIS_CAP` × its weight).
const NIS_CAP: f64 = 100.0;
/// Time constant of that running mean, s.
const NIS_WINDOW_S: f64 = 10.0;
/// Still time before still measurements enter that mean, s: a sway may be called still for a
/// moment at each zero crossing of its rate (its window as quiet as rest, its mean within the
/// mean test), and those measurements, taken on a ramp, misfit any model of rest.
const NIS_SETTLED_S: f64 = 3.0;
/// An estimate whose still measurements' mean ν²/S exceeds this is no measured rest (χ²₁ has
/// mean 1 and variance 2; its running mean over 10 s of independent samples has sd ≈ 0.03 at
/// 100 Hz, 0.1 at 10 Hz).
const NIS_TRUSTED: f64 = 2.0;

/// Why the stage cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum BiasStageError {
    /// The settings are invalid (all problems listed).
    #[error(transparent)]
    Settings(#[from] SettingsErrors),
    /// The model passed in is invalid (all problems listed).
    #[error("invalid bias model:\n  {}", .0.join("\n  "))]
    Model(Vec<String>),
    /// A channel's model cannot be put into state-space form.
    #[error("channel {channel}: {source}")]
    StateSpace {
        channel: String,
        #[source]
        source: StateSpaceError,
    },
}

/// Per-channel diagnostics of the last processed sample (for tests, tools and health).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChannelDiagnostics {
    /// True if the channel's filter took a measurement on the last sample.
    pub updated: bool,
    /// Innovation of that measurement (unit), `z - H x` of the delayed sample.
    pub innovation: f64,
    /// Its predicted variance S (unit²).
    pub innovation_var: f64,
    /// The channel has a running bias filter.
    pub estimating: bool,
    /// The channel is collecting its warm-up stretch.
    pub warming_up: bool,
    /// Step alarms so far.
    pub step_alarms: u64,
}

#[derive(Debug, Clone, Copy)]
struct DelayEntry {
    steps: u32,
    z: [f64; 3],
    usable: [bool; 3],
}

#[derive(Debug, Clone)]
struct ChannelKf {
    kf: BiasKf,
    ss: BiasStateSpace,
    lead_nominal: Lead,
    cusum: Option<Cusum>,
    step_size: f64,
    /// Successive still measurements the guard rejected.
    rejected_run: u32,
    /// A still measurement has updated the estimate (a warm-up's is measured from the start).
    anchored: bool,
    /// Running mean of the still measurements' ν²/S (each capped at `NIS_CAP`), ≈ 1 while the
    /// model describes the sensor at rest.
    nis: f64,
}

#[derive(Debug, Clone)]
struct ChannelState {
    temp: Option<TemperatureComp>,
    gsens: Option<[f64; 3]>,
    lines: [Option<LineCanceller>; MAX_LINES],
    est: Option<ChannelKf>,
    warm: Option<Vec<f64>>,
    /// Running sum and sum of squares of the warm-up buffer (O(1) provisional bias).
    warm_sum: f64,
    warm_sumsq: f64,
    /// Provisional bias while warming up: the mean of the current (or last) still stretch once it
    /// holds at least one second of samples, and the standard error of that mean.
    provisional: Option<(f64, f64)>,
    /// Accel channels: stationary 1-σ of the modelled bias (unit), else 0.
    stationary_sd: f64,
    /// Stochastic estimate (unit, mean included) of the last sample, and its 1-σ.
    bias: f64,
    bias_sd: f64,
    /// The estimate has been distinguishable from zero (`apply_k`) and is subtracted (module
    /// docs, "Engaging on evidence").
    engaged: bool,
    diag: ChannelDiagnostics,
    /// Where the channel's model came from.
    origin: BiasModelOrigin,
    /// Warm-up stretches that held one value (a stuck axis, or noise below one LSB).
    constant_stretches: u64,
}

/// The bias stage (6 channels). See the module docs for what it does.
#[derive(Debug, Clone)]
pub struct BiasStage {
    fs: f64,
    gyro_cal: Calibration,
    accel_cal: Calibration,
    detector: StillnessDetector,
    delay: usize,
    ring: [DelayEntry; MAX_UPDATE_DELAY + 1],
    ring_head: usize,
    ring_len: usize,
    lead_steps: u32,
    ch: [ChannelState; N_CHANNELS],
    prev: Option<(u32, u64)>,
    warmup: WarmupSettings,
    constant_prior_var: f64,
    step_arl_samples: f64,
    step_inflation: f64,
    default_step: f64,
    default_rrw_q_per_s: f64,
    apply_k: f64,
    counters: BiasCounters,
    /// The last sample was held off as a steady turn (stillness docs).
    in_steady_turn: bool,
    /// Weight of one still measurement in a channel's running mean of ν²/S.
    nis_weight: f64,
    /// Consecutive samples the detector has called still, up to the last.
    still_run: u64,
}

impl BiasStage {
    /// Diagnostics of channel `c` (0..6) for the last sample.
    pub fn channel_diagnostics(&self, c: usize) -> ChannelDiagnostics {
        self.ch.get(c).map(|s| s.diag).unwrap_or_default()
    }

    /// The bias state-space model channel `c` runs (fitted at warm-up or from the config).
    pub fn state_space(&self, c: usize) -> Option<&BiasStateSpace> {
        self.ch.get(c).and_then(|s| s.est.as_ref()).map(|e| &e.ss)
    }

    /// Tracked (amplitude, phase) of vibration line `i` of channel `c`.
    pub fn line_amplitude_phase(&self, c: usize, i: usize) -> Option<(f64, f64)> {
        self.ch
            .get(c)?
            .lines
            .get(i)?
            .as_ref()
            .map(|l| l.amplitude_phase())
    }

    /// True while the stillness detector reports rest.
    pub fn is_still(&self) -> bool {
        self.detector.is_still()
    }

    fn steps_since_previous(&mut self, s: &Sample) -> u32 {
        let steps = match self.prev {
            None => 1,
            Some((seq, t_ns)) => {
                let d = s.seq.wrapping_sub(seq);
                if (1..(1 << 31)).contains(&d) {
                    d
                } else if d == 0 && s.t_ns > t_ns {
                    // Source without a sequence counter: steps from the clock.
                    let k = ((s.t_ns - t_ns) as f64 * 1e-9 * self.fs).round();
                    k.clamp(1.0, u32::MAX as f64) as u32
                } else if d == 0 {
                    0 // duplicate
                } else {
                    1 // counter went backwards (restart): treat as the next sample
                }
            }
        };
        self.prev = Some((s.seq, s.t_ns));
        steps
    }

    /// Consume the oldest delay-line entry into the gyro filters (`still` = detector state now).
    fn consume(&mut self, e: DelayEntry, still: bool, alarm_fired: &mut bool) {
        // Only a rest that lasts is evidence that the model misfits it: a sway is "still" for a
        // moment at each zero crossing of its rate.
        let settled = self.still_run as f64 >= NIS_SETTLED_S * self.fs;
        for c in 0..3 {
            let st = &mut self.ch[c];
            if let Some(est) = st.est.as_mut() {
                est.kf.predict_steps(e.steps);
                if still && e.usable[c] {
                    let z = e.z[c] - est.kf.mean();
                    let (nu0, s0) = est.kf.innovation(z);
                    // A declared step's CUSUM sees every still measurement, before the guard: a
                    // step is exactly the disagreement the guard would otherwise reject.
                    if let Some(cu) = est.cusum.as_mut()
                        && s0 > 0.0
                        && cu.update(nu0 / s0.sqrt()) != 0
                    {
                        let v = (self.step_inflation * est.step_size).powi(2);
                        est.kf.inflate_constant(v);
                        st.diag.step_alarms += 1;
                        self.counters.step_alarms += 1;
                        *alarm_fired = true;
                    }
                    let (nu0, s0) = est.kf.innovation(z);
                    if s0 > 0.0 && settled {
                        est.nis += self.nis_weight * ((nu0 * nu0 / s0).min(NIS_CAP) - est.nis);
                    }
                    let consistent = nu0 * nu0 <= GUARD_K * GUARD_K * s0;
                    if !consistent {
                        self.counters.rejected_updates += 1;
                        est.rejected_run = est.rejected_run.saturating_add(e.steps.max(1));
                        if f64::from(est.rejected_run) >= REANCHOR_S * self.fs {
                            // Still for REANCHOR_S and never consistent: the bias moved.
                            est.kf.inflate_constant(nu0 * nu0);
                            est.rejected_run = 0;
                            self.counters.reanchors += 1;
                            *alarm_fired = true;
                        }
                    }
                    if (consistent || est.rejected_run == 0)
                        && let Some((nu, s)) = est.kf.update(z)
                    {
                        if consistent {
                            est.rejected_run = 0;
                        }
                        est.anchored = true;
                        st.diag.updated = true;
                        st.diag.innovation = nu;
                        st.diag.innovation_var = s;
                        self.counters.bias_updates += 1;
                    }
                } else if !still {
                    est.rejected_run = 0;
                }
            } else if let Some(buf) = st.warm.as_mut() {
                if !still {
                    buf.clear();
                    st.warm_sum = 0.0;
                    st.warm_sumsq = 0.0;
                } else if e.usable[c] {
                    let z = e.z[c];
                    buf.push(z);
                    st.warm_sum += z;
                    st.warm_sumsq += z * z;
                    let n = buf.len() as f64;
                    if n >= self.fs.max(10.0) {
                        let m = st.warm_sum / n;
                        let var = (st.warm_sumsq / n - m * m).max(0.0);
                        st.provisional = Some((m, (var / n).sqrt()));
                    }
                    if buf.len() >= self.warmup.still_samples_at(self.fs) {
                        self.finish_warmup(c);
                    }
                }
            }
        }
    }

    /// Counts a quiet sample the detector held off as a steady turn, and says the first few
    /// turns (stillness docs, "Steady turns").
    fn count_steady_turn(&mut self, t_s: f64) {
        let f = self.detector.features();
        let was = self.in_steady_turn;
        self.in_steady_turn = f.turn_held;
        if !f.turn_held {
            return;
        }
        self.counters.steady_turn_samples += 1;
        if was {
            return;
        }
        self.counters.steady_turns += 1;
        if self.counters.steady_turns <= STEADY_TURNS_SAID {
            tracing::warn!(
                "bias: at {t_s:.2} s the gyro is quiet but {:.3} °/s off its bias ({}): taken for a steady turn (a turntable, a slow pan), not for rest, while it lasts; a bias that moved so is not learned (a model that declares a step re-anchors){}",
                f.gyro_turn_rad_s.to_degrees(),
                if f.turn_tilts {
                    "gravity turns with it in the accelerometer"
                } else {
                    "about gravity, more than the bias itself"
                },
                if self.counters.steady_turns == STEADY_TURNS_SAID {
                    " — further ones are counted in the health only (`steady_turns`)"
                } else {
                    ""
                }
            );
        }
    }

    fn push_entry(&mut self, e: DelayEntry) {
        let cap = MAX_UPDATE_DELAY + 1;
        let idx = (self.ring_head + self.ring_len) % cap;
        self.ring[idx] = e;
        self.ring_len += 1;
        self.lead_steps = self.lead_steps.saturating_add(e.steps);
    }

    fn pop_entry(&mut self) -> DelayEntry {
        let e = self.ring[self.ring_head];
        self.ring_head = (self.ring_head + 1) % (MAX_UPDATE_DELAY + 1);
        self.ring_len -= 1;
        self.lead_steps = self.lead_steps.saturating_sub(e.steps);
        e
    }
}

/// Calibrate one triad; non-finite raw components contribute nothing to the mixing (they are
/// replaced by the calibration bias) and stay non-finite in the output.
#[inline]
fn calibrate(cal: &Calibration, raw: &Vector3<f64>) -> Vector3<f64> {
    if raw.iter().all(|v| v.is_finite()) {
        return cal.apply(raw);
    }
    let mut r = *raw;
    for a in 0..3 {
        if !r[a].is_finite() {
            r[a] = cal.bias[a];
        }
    }
    let mut out = cal.apply(&r);
    for a in 0..3 {
        if !raw[a].is_finite() {
            out[a] = raw[a];
        }
    }
    out
}

impl BiasStage {
    /// One sample through the stage (it has no look-ahead: [`Stage::push`] emits it at once).
    pub fn process(&mut self, mut s: Sample) -> Sample {
        self.counters.samples += 1;
        let mut steps = self.steps_since_previous(&s);
        let t_s = s.t_s();
        let mut alarm_fired = false;

        // 1. Calibration.
        let g = calibrate(&self.gyro_cal, &s.gyro);
        let a = calibrate(&self.accel_cal, &s.accel);
        let cal = [g[0], g[1], g[2], a[0], a[1], a[2]];
        // An absent channel is NaN and not finite, so it is never a measurement below; it is
        // no bad value either (not counted, not flagged).
        let finite: [bool; N_CHANNELS] = std::array::from_fn(|c| cal[c].is_finite());
        if (0..N_CHANNELS).any(|c| !finite[c] && !s.is_absent(c)) {
            s.flags |= flags::NON_FINITE;
            self.counters.non_finite_samples += 1;
        }
        let accel_ok = finite[3] && finite[4] && finite[5];

        // Long gap: flush the delay line without updates, restart the detector.
        if steps > BIG_GAP_STEPS {
            self.counters.long_gaps += 1;
            while self.ring_len > 0 {
                let e = self.pop_entry();
                self.consume(e, false, &mut alarm_fired);
            }
            for st in self.ch.iter_mut().take(3) {
                if let Some(est) = st.est.as_mut() {
                    est.kf.predict_steps(steps - 1);
                }
            }
            self.detector.reset();
            // Line cancellers and temperature lags still see the whole gap.
        }

        // 2–3. Deterministic effects and vibration lines.
        let mut eff = [0.0; N_CHANNELS];
        let mut effect_applied = false;
        for c in 0..N_CHANNELS {
            if s.is_absent(c) {
                continue; // no effect is compensated on a channel the sensor does not have
            }
            let st = &mut self.ch[c];
            if let Some(tc) = st.temp.as_mut()
                && let Some(term) = tc.update(s.temp_c, steps)
            {
                eff[c] += term;
                effect_applied = true;
            }
            if let Some(k) = st.gsens
                && accel_ok
            {
                eff[c] += k[0] * a[0] + k[1] * a[1] + k[2] * a[2];
                effect_applied = true;
            }
            for lc in st.lines.iter_mut().flatten() {
                let line = lc.process(cal[c] - eff[c], t_s, steps);
                if finite[c] {
                    eff[c] += line;
                    effect_applied = true;
                }
            }
        }
        let y: [f64; N_CHANNELS] = std::array::from_fn(|c| cal[c] - eff[c]);

        // 4. Stillness, against the gyro bias estimate (and its σ) of each axis that has one. A
        // stale repeat is no new measurement: the detector keeps its state.
        let repeat = s.has(flags::REPEATED);
        if repeat {
            self.counters.repeats += 1;
        }
        let gyro_ref: [Option<(f64, f64)>; 3] = std::array::from_fn(|c| {
            let st = &self.ch[c];
            st.est.is_some().then_some((st.bias, st.bias_sd))
        });
        // Only an estimate that is a measured rest frees nothing: a declared step, an estimate no
        // still measurement has anchored, or one whose still measurements do not fit its model
        // (an unmodelled line, a wrong noise level) frees its axis of the steady-turn rule
        // (stillness docs).
        let free = (0..3)
            .filter(|&c| {
                self.ch[c]
                    .est
                    .as_ref()
                    .is_some_and(|e| e.cusum.is_some() || !e.anchored || e.nis > NIS_TRUSTED)
            })
            .fold(0u8, |m, c| m | 1 << c);
        self.detector.set_free_axes(free);
        let still = if repeat {
            self.detector.is_still()
        } else {
            self.detector.update_present(
                &[y[0], y[1], y[2]],
                &[y[3], y[4], y[5]],
                &gyro_ref,
                s.absent,
            )
        };
        if still {
            s.flags |= flags::STILL;
            self.counters.still_samples += 1;
            self.still_run = self.still_run.saturating_add(1);
        } else {
            self.still_run = 0;
        }
        self.count_steady_turn(t_s);

        // 5. Delayed measurement updates of the gyro filters.
        for st in self.ch.iter_mut().take(3) {
            st.diag.updated = false;
        }
        if steps > BIG_GAP_STEPS {
            steps = 1; // the filters were advanced to the previous instant above
        }
        let bad = |c: usize| {
            s.flags & (flags::sat_ch(c) | flags::replaced_ch(c) | flags::SENSOR_FAULT) != 0
        };
        let entry = DelayEntry {
            steps,
            z: [y[0], y[1], y[2]],
            usable: std::array::from_fn(|c| finite[c] && steps > 0 && !bad(c) && !repeat),
        };
        self.push_entry(entry);
        if self.ring_len > self.delay {
            let e = self.pop_entry();
            self.consume(e, still, &mut alarm_fired);
        }

        // Outputs.
        let mut any_est = false;
        let mut any_warm = false;
        let lead_steps = self.lead_steps;
        let apply_k = self.apply_k;
        let mut engagements = 0;
        let mut out = [0.0; N_CHANNELS];
        for (c, st) in self.ch.iter_mut().enumerate() {
            if s.is_absent(c) {
                // Nothing measured, nothing subtracted: NaN out, no bias, not warming up.
                out[c] = f64::NAN;
                s.bias[c] = 0.0;
                s.bias_sd[c] = 0.0;
                continue;
            }
            let mut sub = eff[c];
            let mut published_sd = st.bias_sd;
            if let Some(est) = st.est.as_ref() {
                let (b, var) = if lead_steps == est.lead_nominal.steps {
                    est.kf.predict_ahead(&est.lead_nominal)
                } else {
                    est.kf.predict_ahead(&est.kf.lead(lead_steps))
                };
                st.bias = b;
                st.bias_sd = var.sqrt();
                any_est = true;
            } else if let (Some((m, se)), true) = (st.provisional, st.warm.is_some()) {
                // Warming up with a provisional bias (module docs).
                st.bias = m;
                st.bias_sd = se;
                any_est = true;
                any_warm = true;
            } else {
                st.bias = 0.0;
                st.bias_sd = st.stationary_sd;
                any_warm |= st.warm.is_some();
                published_sd = st.bias_sd;
            }
            if st.est.is_some() || (st.provisional.is_some() && st.warm.is_some()) {
                // Engaging on evidence (module docs).
                // A model file's estimate is subtracted from the start (module docs).
                let k = if st.origin == BiasModelOrigin::File {
                    0.0
                } else {
                    apply_k
                };
                if !st.engaged && (k == 0.0 || st.bias.abs() > k * st.bias_sd) {
                    st.engaged = true;
                    engagements += 1;
                }
                published_sd = if st.engaged {
                    sub += st.bias;
                    st.bias_sd
                } else {
                    st.bias_sd.hypot(st.bias)
                };
            }
            st.diag.estimating = st.est.is_some();
            st.diag.warming_up = st.warm.is_some();
            out[c] = if finite[c] {
                cal[c] - sub
            } else {
                s.channel(c)
            };
            s.bias[c] = sub as f32;
            s.bias_sd[c] = published_sd as f32;
        }
        self.counters.engagements += engagements;
        s.set_channels(&out);
        if any_est {
            s.flags |= flags::BIAS_REMOVED;
        }
        if any_warm {
            s.flags |= flags::WARMING_UP;
        }
        if effect_applied || alarm_fired {
            s.flags |= flags::EFFECT_COMPENSATED;
        }
        s
    }
}

impl Stage for BiasStage {
    fn name(&self) -> &'static str {
        "bias"
    }

    fn push(&mut self, s: Sample, out: &mut Vec<Sample>) {
        out.push(self.process(s));
    }

    fn health(&self) -> StageHealth {
        StageHealth::Bias(BiasStage::health(self))
    }
}
