//! A warm-up window's model, identified on the sample path or off it.
//!
//! Identification (Hampel cleaning, ADF, the AIC grid of CSS fits) takes about 10–15 ms a
//! channel on 2000 samples; six channels closing their windows on one sample made that call
//! take 57–111 ms (86 ms in `cargo bench --bench latency`): far longer than a 1-kHz sensor's sample
//! interval, and than a tokio worker should be blocked. So by default (`identify_defer_s`) the
//! stage has a worker thread: when a window closes it is copied to the worker and the warm-up
//! goes on. The worker identifies the model and runs its predictor through the window
//! ([`Seed`]); the channel takes it over at a sample fixed by the data (the deferral's span of
//! its own time stamps), waiting for the worker if it has not finished by then, and carries it
//! through the samples since, Hampel-cleaned one by one as they came. The output therefore
//! depends only on the input, never on the machine's speed.

use std::panic::AssertUnwindSafe;
use std::sync::mpsc::{Sender, channel};
use std::sync::{Arc, Condvar, Mutex, PoisonError};

use super::gate::{GateParams, Seed};
use crate::model::arima::{ArimaChannelModel, IdentifySettings, identify};
use crate::stats::grid::grid_step;
use crate::stats::line::{Sinusoid, fit_sinusoid, strongest_line_if};
use crate::stats::robust::{hampel, upper_median_and_mad_sigma};

/// Half-width and bar of the Hampel filter run over the warm-up before identification: it
/// strips spikes and runs of up to 10 samples.
pub const HAMPEL_HALF_WIDTH: usize = 10;
pub const HAMPEL_K: f64 = 4.0;

/// What identifying one warm-up window gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Identified {
    pub model: ArimaChannelModel,
    /// The predictor run through the Hampel-cleaned window (`None`: too short to seed from).
    pub seed: Option<Seed>,
    /// The window's quantisation step ([`grid_step`]).
    pub resolution: f64,
    /// Models that fell back to white noise: the identification failed, or (cannot happen with
    /// validated settings) its model would not run.
    pub fallbacks: u64,
    /// The line taken out of the window before identification ([`window_line`]), in the
    /// window's sample index (0 = its first sample).
    pub line: Option<Sinusoid>,
}

impl Identified {
    /// The white-noise fallback on `raw` (for an identification that panicked).
    pub fn white(raw: &[f64], p: &GateParams, name: &str, min_var: f64) -> Identified {
        let model = white_model(raw, name, min_var);
        Identified {
            seed: Seed::new(p, &model, raw).ok().flatten(),
            model,
            resolution: grid_step(raw),
            fallbacks: 1,
            line: None,
        }
    }
}

/// White noise about the median of `cleaned`, σ its MAD σ (at least `min_var`'s root).
pub fn white_model(cleaned: &[f64], name: &str, min_var: f64) -> ArimaChannelModel {
    let (med, sd) = upper_median_and_mad_sigma(cleaned);
    ArimaChannelModel {
        channel: name.to_string(),
        p: 0,
        d: 0,
        q: 0,
        constant: med,
        ar: vec![],
        ma: vec![],
        sigma: sd.max(min_var.sqrt()),
        line_per_sample: None,
        diagnostics: None,
    }
}

/// `x` through the Hampel filter identification runs first ([`HAMPEL_HALF_WIDTH`],
/// [`HAMPEL_K`]); `x` itself where the filter cannot run (too short).
pub fn hampel_cleaned(x: &[f64]) -> Vec<f64> {
    hampel(x, HAMPEL_HALF_WIDTH, HAMPEL_K)
        .map(|r| r.corrected)
        .unwrap_or_else(|_| x.to_vec())
}

/// The window's line test: its p-value bar ([`strongest_line`](crate::stats::line::strongest_line)'s, one test per channel).
pub const LINE_ALPHA: f64 = 1e-3;
/// A line is taken out of the window (and tracked by the channel, [`super::line`]) only when it
/// is at least this share of the window's second-difference variance: the model-free tests
/// judge the second differences, and a line below this share widens their roughness by under
/// 5 %. A slow line (the ADIS16405 accelerometers' 0.57 Hz at 100 Hz) has almost no second
/// difference, and the ARIMA model holds it as it is.
pub const LINE_ROUGHNESS_SHARE: f64 = 0.1;

/// The line of `cleaned` (a Hampel-cleaned window) that the stage's tests should not see: a
/// stationary sinusoid found by [`strongest_line`](crate::stats::line::strongest_line) that is at least [`LINE_ROUGHNESS_SHARE`] of
/// the window's second-difference variance.
pub fn window_line(cleaned: &[f64]) -> Option<Sinusoid> {
    // Var Δ²(A sin ωi) = A²/2 · (4 sin²(ω/2))².
    let line_var = |omega: f64, amplitude: f64| {
        let g = 4.0 * (0.5 * omega).sin().powi(2);
        0.5 * amplitude * amplitude * g * g
    };
    let d2: Vec<f64> = cleaned
        .windows(3)
        .map(|w| w[2] - 2.0 * w[1] + w[0])
        .collect();
    let m = d2.iter().sum::<f64>() / d2.len().max(1) as f64;
    let var = d2.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / d2.len().max(1) as f64;
    let bar = LINE_ROUGHNESS_SHARE * var;
    // A bin whose line could not reach the bar, even a bin higher up (g grows with ω), is not
    // worth a floor.
    let bin = std::f64::consts::TAU / cleaned.len().max(1) as f64;
    let l = strongest_line_if(cleaned, LINE_ALPHA, |omega, a| {
        line_var((omega + bin).min(std::f64::consts::PI), a) >= bar
    })?;
    (line_var(l.omega, l.amplitude()) >= bar).then_some(l)
}

/// Identify channel `name`'s model from its raw warm-up window and seed it (a failed
/// identification falls back to [`white_model`]). A line the tests should not see
/// ([`window_line`], found on the Hampel-cleaned window) is taken out of the raw window first:
/// the model is then identified, and seeded, on the window without it.
///
/// With a `given` model (a model file's that declares a line, `line_per_sample`) nothing is
/// identified: the line is fitted at the file's frequency, taken out, and the given model seeded
/// on what is left.
pub fn identify_window(
    raw: &[f64],
    id: &IdentifySettings,
    p: &GateParams,
    name: &str,
    min_var: f64,
    given: Option<&ArimaChannelModel>,
) -> Identified {
    let mut cleaned = hampel_cleaned(raw);
    let line = match given {
        Some(m) => m
            .line_per_sample
            .map(|f| fit_sinusoid(&cleaned, std::f64::consts::TAU * f, 0)),
        None => window_line(&cleaned),
    };
    if let Some(l) = &line {
        let mut without = raw.to_vec();
        l.subtract_from(&mut without, 0);
        cleaned = hampel_cleaned(&without);
    }
    let mut fallbacks = 0;
    let mut model = match given {
        Some(m) => m.clone(),
        None => identify(&cleaned, id)
            .map(|m| m.to_channel_model(name))
            .unwrap_or_else(|_| {
                fallbacks += 1;
                white_model(&cleaned, name, min_var)
            }),
    };
    let seed = Seed::new(p, &model, &cleaned).unwrap_or_else(|_| {
        fallbacks += 1;
        model = white_model(&cleaned, name, min_var);
        // A white-noise model with a positive σ always runs.
        Seed::new(p, &model, &cleaned).ok().flatten()
    });
    Identified {
        model,
        seed,
        resolution: grid_step(raw),
        fallbacks,
        line,
    }
}

enum State {
    Running,
    Done(Box<Identified>),
    /// Taken by a clone of the gate that shares it.
    Taken,
    /// The identification panicked.
    Failed,
}

/// Why [`Pending::wait`] has no result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Missing {
    /// Another clone of the gate took it: identify again (the same result).
    Taken,
    /// The identification panicked: do not run it again.
    Failed,
}

struct Slot {
    state: Mutex<State>,
    done: Condvar,
}

struct Job {
    raw: Vec<f64>,
    id: IdentifySettings,
    p: GateParams,
    name: String,
    min_var: f64,
    given: Option<ArimaChannelModel>,
    slot: Arc<Slot>,
}

/// A stage's identification: its settings, and its worker thread where windows are
/// identified one at a time (six at once would take every core from the pipeline's thread).
#[derive(Debug, Clone)]
pub struct Identifier {
    pub settings: IdentifySettings,
    jobs: Option<Sender<Job>>,
}

impl Identifier {
    /// With `worker`, start the worker thread (it ends when the last clone of this is dropped);
    /// where no thread can be started, or without `worker`, windows are identified inline.
    pub fn new(settings: IdentifySettings, worker: bool) -> Self {
        let jobs = worker.then(spawn_worker).flatten();
        Identifier { settings, jobs }
    }

    /// [`identify_window`] with these settings, here and now.
    pub fn window(
        &self,
        raw: &[f64],
        p: &GateParams,
        name: &str,
        min_var: f64,
        given: Option<&ArimaChannelModel>,
    ) -> Identified {
        identify_window(raw, &self.settings, p, name, min_var, given)
    }

    /// Hand `raw` (and a `given` model, [`identify_window`]) to the worker; `None` without one (the caller then identifies inline: the
    /// same result, only on the sample path).
    pub fn start(
        &self,
        raw: Vec<f64>,
        p: &GateParams,
        name: &str,
        min_var: f64,
        given: Option<&ArimaChannelModel>,
    ) -> Option<Pending> {
        let slot = Arc::new(Slot {
            state: Mutex::new(State::Running),
            done: Condvar::new(),
        });
        let job = Job {
            raw,
            id: self.settings,
            p: *p,
            name: name.to_string(),
            min_var,
            // Its diagnostics are not needed to seed it.
            given: given.map(|m| ArimaChannelModel {
                diagnostics: None,
                ..m.clone()
            }),
            slot: slot.clone(),
        };
        self.jobs.as_ref()?.send(job).ok()?;
        Some(Pending(slot))
    }
}

fn spawn_worker() -> Option<Sender<Job>> {
    let (tx, rx) = channel::<Job>();
    let spawned = std::thread::Builder::new()
        .name("imuprep-identify".into())
        .spawn(move || {
            batch();
            for job in rx {
                let r = std::panic::catch_unwind(AssertUnwindSafe(|| {
                    identify_window(
                        &job.raw,
                        &job.id,
                        &job.p,
                        &job.name,
                        job.min_var,
                        job.given.as_ref(),
                    )
                }));
                let mut g = job
                    .slot
                    .state
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner);
                *g = r.map_or(State::Failed, |r| State::Done(Box::new(r)));
                job.slot.done.notify_all();
            }
        });
    match spawned {
        Ok(_) => Some(tx),
        Err(e) => {
            tracing::warn!(error = %e, "no identification thread: models are identified inline");
            None
        }
    }
}

/// Mark the calling thread as batch work: on Linux SCHED_BATCH, a CPU-bound thread that is
/// disfavoured on waking, so it does not preempt the pipeline's thread, yet keeps its fair share
/// of a busy machine. Not SCHED_IDLE: a thread of that class cannot be raised again without
/// privilege, and while the pipeline waits for it (the deferral's end) a machine busy with other
/// work would give it almost nothing, stalling the pipeline behind it. Elsewhere: ordinary.
fn batch() {
    #[cfg(target_os = "linux")]
    {
        let param = libc::sched_param { sched_priority: 0 };
        // SAFETY: sched_setscheduler with pid 0 changes only the calling thread's policy; the
        // parameter is a valid, initialised struct that outlives the call.
        let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_BATCH, &param) };
        if rc != 0 {
            tracing::debug!("identification worker: SCHED_BATCH refused, ordinary policy");
        }
    }
}

/// A window handed to the worker. Clones share it (a cloned gate takes the same model).
#[derive(Clone)]
pub struct Pending(Arc<Slot>);

impl std::fmt::Debug for Pending {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let state = match *self.0.state.lock().unwrap_or_else(PoisonError::into_inner) {
            State::Running => "running",
            State::Done(_) => "done",
            State::Taken => "taken",
            State::Failed => "failed",
        };
        write!(f, "Pending({state})")
    }
}

impl Pending {
    /// The result, waiting for the worker if it has not finished; moved out, not copied (no
    /// allocation on the sample path).
    pub fn wait(&self) -> Result<Identified, Missing> {
        let mut g = self.0.state.lock().unwrap_or_else(PoisonError::into_inner);
        while let State::Running = *g {
            g = self.0.done.wait(g).unwrap_or_else(PoisonError::into_inner);
        }
        match std::mem::replace(&mut *g, State::Taken) {
            State::Done(r) => Ok(*r),
            State::Failed => {
                *g = State::Failed;
                Err(Missing::Failed)
            }
            _ => Err(Missing::Taken),
        }
    }
}
