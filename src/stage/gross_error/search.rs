//! The stage's searches for a vibration line (`line.rs`), run off the sample path.
//!
//! A search reads 2048 values and takes 0.02–0.2 ms (the more when it finds a line); every
//! channel without a line asks for one every 512 samples. On the sample path that is a stall of
//! up to a fifth of a 1-kHz sensor's interval, and its buffers would be allocated there. So a stage has a thread for them: each
//! channel has a slot whose buffer is allocated when the stage is built; asking copies the
//! window into it and wakes the thread, answering waits (only if the thread has not finished)
//! and reads the result. Neither allocates. The thread's own work allocates, off the sample
//! path. The caller takes the answer up at a sample fixed by the data, so the output is the
//! same however fast the thread ran.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};

use super::RING;
use crate::sample::N_CHANNELS;
use crate::stats::line::Sinusoid;

/// Where a channel's slot is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Status {
    Idle,
    Asked,
    Running,
    Done(Option<Sinusoid>),
}

#[derive(Debug)]
struct Slot {
    window: Vec<f64>,
    first: u64,
    status: Status,
}

#[derive(Debug)]
struct State {
    slots: [Slot; N_CHANNELS],
    shutdown: bool,
}

#[derive(Debug)]
struct Shared {
    state: Mutex<State>,
    /// The thread waits here for a slot asked.
    work: Condvar,
    /// The stage waits here for its answer.
    done: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// The stage's end of the thread: dropping the last one ends the thread.
#[derive(Debug)]
struct Handle(Arc<Shared>);

impl Drop for Handle {
    fn drop(&mut self) {
        self.0.lock().shutdown = true;
        self.0.work.notify_all();
    }
}

/// The searches of one stage: on a thread of their own (module docs), or nowhere (inline: the
/// caller searches itself). A clone has a thread of its own, its slots empty: a search that was
/// under way when it was cloned is answered by the caller (the same result, on the sample path).
#[derive(Debug)]
pub struct Searcher {
    handle: Option<Handle>,
    search: fn(&[f64]) -> Option<Sinusoid>,
}

impl Clone for Searcher {
    fn clone(&self) -> Self {
        Searcher::new(self.handle.is_some(), self.search)
    }
}

impl Searcher {
    /// With `thread`, start the thread that runs `search` (where none can be started, or
    /// without `thread`, the caller searches inline).
    pub fn new(thread: bool, search: fn(&[f64]) -> Option<Sinusoid>) -> Self {
        let handle = thread.then(|| spawn(search)).flatten();
        Searcher { handle, search }
    }

    /// Ask for a search of channel `c`'s `window`, whose first value is index `first`; `false`
    /// without a thread (the caller searches itself, [`Searcher::search_here`]).
    pub fn ask(&self, c: usize, window: &[f64], first: u64) -> bool {
        let Some(h) = &self.handle else {
            return false;
        };
        let mut g = h.0.lock();
        let slot = &mut g.slots[c];
        slot.window.clear();
        // Within the capacity reserved when the stage was built: no allocation.
        slot.window
            .extend_from_slice(&window[..window.len().min(RING)]);
        slot.first = first;
        slot.status = Status::Asked;
        drop(g);
        h.0.work.notify_one();
        true
    }

    /// The answer to channel `c`'s search of the window from index `first`, waiting for the
    /// thread if it has not finished; `None` if there is none to give (no thread, or the slot
    /// holds no such search: a clone's): the caller then searches itself.
    pub fn answer(&self, c: usize, first: u64) -> Option<Option<Sinusoid>> {
        let h = self.handle.as_ref()?;
        let mut g = h.0.lock();
        while matches!(g.slots[c].status, Status::Asked | Status::Running) && !g.shutdown {
            g = h.0.done.wait(g).unwrap_or_else(PoisonError::into_inner);
        }
        let slot = &mut g.slots[c];
        match slot.status {
            Status::Done(r) if slot.first == first => {
                slot.status = Status::Idle;
                Some(r)
            }
            _ => None,
        }
    }

    /// `search` here and now (no thread, or no answer from it).
    pub fn search_here(&self, window: &[f64]) -> Option<Sinusoid> {
        (self.search)(window)
    }
}

/// The thread: takes each asked slot's window (exchanging buffers, so neither side allocates),
/// searches it without holding the lock, and leaves the result. A search that panics answers
/// "no line".
fn spawn(search: fn(&[f64]) -> Option<Sinusoid>) -> Option<Handle> {
    let slot = || Slot {
        window: Vec::with_capacity(RING),
        first: 0,
        status: Status::Idle,
    };
    let shared = Arc::new(Shared {
        state: Mutex::new(State {
            slots: std::array::from_fn(|_| slot()),
            shutdown: false,
        }),
        work: Condvar::new(),
        done: Condvar::new(),
    });
    let theirs = shared.clone();
    let spawned = std::thread::Builder::new()
        .name("imuprep-lines".into())
        .spawn(move || {
            let mut buf: Vec<f64> = Vec::with_capacity(RING);
            let mut g = theirs.lock();
            loop {
                if g.shutdown {
                    // Whoever waits for an answer gets none and searches itself.
                    theirs.done.notify_all();
                    return;
                }
                let Some(c) = g.slots.iter().position(|s| s.status == Status::Asked) else {
                    g = theirs.work.wait(g).unwrap_or_else(PoisonError::into_inner);
                    continue;
                };
                std::mem::swap(&mut g.slots[c].window, &mut buf);
                g.slots[c].status = Status::Running;
                drop(g);
                let r = std::panic::catch_unwind(|| search(&buf)).unwrap_or(None);
                g = theirs.lock();
                // Asked again meanwhile: that window is in the slot's buffer now, and is searched
                // next; this result answers nothing.
                if g.slots[c].status == Status::Running {
                    std::mem::swap(&mut g.slots[c].window, &mut buf);
                    g.slots[c].status = Status::Done(r);
                    theirs.done.notify_all();
                }
            }
        });
    match spawned {
        Ok(_) => Some(Handle(shared)),
        Err(e) => {
            tracing::warn!(error = %e, "no line-search thread: vibration lines are searched for inline");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn finds_mean(w: &[f64]) -> Option<Sinusoid> {
        let m = w.iter().sum::<f64>() / w.len() as f64;
        (m > 0.0).then_some(Sinusoid {
            omega: 1.0,
            a: m,
            b: 0.0,
        })
    }

    #[test]
    fn the_thread_answers_as_the_caller_would() {
        for thread in [true, false] {
            let s = Searcher::new(thread, finds_mean);
            for c in 0..N_CHANNELS {
                let w = vec![c as f64; 100];
                let asked = s.ask(c, &w, 7 * c as u64);
                assert_eq!(asked, thread);
                let r = s
                    .answer(c, 7 * c as u64)
                    .unwrap_or_else(|| s.search_here(&w));
                assert_eq!(r, finds_mean(&w));
                // Answered once; a search it was not asked for has no answer.
                assert_eq!(s.answer(c, 7 * c as u64), None);
            }
            // A clone has its own (empty) slots.
            let clone = s.clone();
            if thread {
                assert!(s.ask(0, &[1.0; 10], 3));
                assert_eq!(clone.answer(0, 3), None);
                assert!(s.answer(0, 3).is_some());
            }
        }
    }
}
