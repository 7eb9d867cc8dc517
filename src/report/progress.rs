//! The commands' progress bars (`indicatif`, on stderr): one style for all. A bar draws only
//! when stderr is a terminal (indicatif's stderr target is hidden otherwise), so piped or
//! logged output carries none of it.

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `len` steps: elapsed time, the bar, `pos/len`, and the message set on it.
pub fn bar(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len);
    // The template is a constant that parses; the default style stands in if it ever did not.
    let style = ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar
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
