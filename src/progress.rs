//! Progress bars (`indicatif`, on stderr): one style for all, one place they draw. A bar draws
//! only when stderr is a terminal (indicatif's stderr target is hidden otherwise), so piped or
//! logged output carries none of it.
//!
//! Every bar belongs to one [`MultiProgress`], so the program's log lines can be written above
//! the bars instead of through them: the binary's log writer goes through [`suspend`].
//!
//! Work whose length is not known to be long (a file read, a replay) gets a [`Delayed`] bar: it
//! keeps count from the start but appears only once the command has run a second ([`begin`]
//! marks its start), so a short run prints nothing more than before, and a command of several
//! parts under a second each still shows one once it is past the second.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::Read;
use std::sync::LazyLock;
use std::time::{Duration, Instant};

/// The one place every bar draws (stderr; hidden when it is not a terminal).
static BARS: LazyLock<MultiProgress> = LazyLock::new(MultiProgress::new);

/// When the command started ([`begin`]; else when the first [`Delayed`] bar was made).
static START: LazyLock<Instant> = LazyLock::new(Instant::now);

/// Mark the command's start: [`Delayed`] bars count their second from here.
pub fn begin() {
    LazyLock::force(&START);
}

/// Run `f` (a write to stderr) with the bars taken off the screen, and draw them again after:
/// a log line lands above the bars instead of inside one.
pub fn suspend<R>(f: impl FnOnce() -> R) -> R {
    BARS.suspend(f)
}

/// No bar from here on: for a run whose samples go to stdout on the same terminal, where a bar
/// redrawn on stderr would tear the lines.
pub fn hide() {
    BARS.set_draw_target(ProgressDrawTarget::hidden());
}

fn style(template: &str) -> ProgressStyle {
    // The templates are constants that parse; the default style stands in if one ever did not.
    ProgressStyle::with_template(template)
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar())
}

/// The bars' templates: elapsed time, the bar, how far of how much, and the message.
const STEPS: &str = "{elapsed_precise} [{bar:30}] {pos}/{len} {msg}";
const BYTES: &str = "{elapsed_precise} [{bar:30}] {bytes}/{total_bytes} {msg}";

/// A bar of `len` steps: elapsed time, the bar, `pos/len`, and the message set on it.
pub fn bar(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(style(STEPS));
    BARS.add(bar)
}

/// Samples below which a file's second pass (`import`, `export`) shows no bar: fewer take well
/// under a second (10⁶ samples of the ADIS16405 log: 0.2–0.8 s), and a bar would only flash.
pub const SAMPLES_WORTH_A_BAR: u64 = 1_000_000;

/// A bar over `samples` samples, moved in steps of [`SAMPLE_STEP`]; hidden below
/// [`SAMPLES_WORTH_A_BAR`].
pub fn samples_bar(samples: u64, what: &str) -> ProgressBar {
    if samples < SAMPLES_WORTH_A_BAR {
        return ProgressBar::hidden();
    }
    let b = bar(samples);
    b.set_message(what.to_string());
    b
}

/// Samples between two moves of a [`samples_bar`] (a move costs more than a sample).
pub const SAMPLE_STEP: u64 = 1 << 16;

/// How long a command runs before its [`Delayed`] bars appear.
pub const DELAY: Duration = Duration::from_secs(1);

/// A bar over `total` steps or bytes that appears only once the command has run for [`DELAY`]
/// (kept hidden until then, its count kept all the same), and leaves the screen when dropped.
pub struct Delayed {
    bar: ProgressBar,
    delay: Duration,
    shown: bool,
}

impl Delayed {
    /// A byte count of `total` (the file's length), said as `what` ("read", "replayed").
    pub fn bytes(total: u64, what: &str) -> Delayed {
        Delayed::after(DELAY, BYTES, total, what)
    }

    /// A count of `total` steps (samples, instants), said as `what`.
    pub fn steps(total: u64, what: &str) -> Delayed {
        Delayed::after(DELAY, STEPS, total, what)
    }

    /// A bar of `template` appearing after `delay`.
    fn after(delay: Duration, template: &str, total: u64, what: &str) -> Delayed {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
        bar.set_style(style(template));
        bar.set_message(what.to_string());
        LazyLock::force(&START);
        Delayed {
            bar,
            delay,
            shown: false,
        }
    }

    /// `n` more steps (bytes) done; the bar appears if the command has now run for [`DELAY`].
    pub fn inc(&mut self, n: u64) {
        self.bar.inc(n);
        if !self.shown && START.elapsed() >= self.delay {
            self.shown = true;
            BARS.add(self.bar.clone());
        }
    }

    /// The `done`-th sample (counted from 1) done: the bar moves once every [`SAMPLE_STEP`].
    pub fn sample_done(&mut self, done: u64) {
        if done.is_multiple_of(SAMPLE_STEP) {
            self.inc(SAMPLE_STEP);
        }
    }

    /// Steps (bytes) done so far.
    pub fn position(&self) -> u64 {
        self.bar.position()
    }

    /// Whether the bar has appeared (the command ran past [`DELAY`]).
    pub fn shown(&self) -> bool {
        self.shown
    }
}

impl Drop for Delayed {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
        if self.shown {
            BARS.remove(&self.bar);
        }
    }
}

/// A reader that moves a [`Delayed`] bar by the bytes read through it.
pub struct ReadBar<R> {
    inner: R,
    bar: Delayed,
}

impl<R> ReadBar<R> {
    /// `inner` read from its start, `total` bytes long.
    pub fn new(inner: R, total: u64, what: &str) -> ReadBar<R> {
        ReadBar {
            inner,
            bar: Delayed::bytes(total, what),
        }
    }

    /// The bar (how far the read has come).
    pub fn bar(&self) -> &Delayed {
        &self.bar
    }
}

impl<R: Read> Read for ReadBar<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bar.inc(n as u64);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_read_bar_counts_every_byte_and_passes_them_unchanged() {
        let data: Vec<u8> = (0..200_000u32).map(|i| (i % 251) as u8).collect();
        let mut r = ReadBar::new(&data[..], data.len() as u64, "read");
        let mut out = Vec::new();
        r.read_to_end(&mut out).unwrap();
        assert_eq!(out, data);
        assert_eq!(r.bar().position(), data.len() as u64);
    }

    #[test]
    fn a_delayed_bar_appears_only_after_its_delay() {
        // Delays of zero and of a year stand for "a command past its delay" and "one inside
        // it", so the test does not hang on the machine's speed.
        let mut late = Delayed::after(Duration::ZERO, BYTES, 10, "read");
        assert!(!late.shown(), "nothing shows before the first byte");
        late.inc(4);
        assert!(late.shown());
        let mut quick = Delayed::after(Duration::from_secs(365 * 86_400), STEPS, 10, "read");
        quick.inc(10);
        assert!(!quick.shown());
        assert_eq!((late.position(), quick.position()), (4, 10));
    }
}
