//! Stale repeats: a sample that copies the previous one bit for bit, told from one that repeats it
//! by chance ([`RepeatDetector::is_repeat`]).

use crate::sample::{N_CHANNELS, Sample};

/// Present channels a sample needs before a bit-identical copy of the previous one counts as a
/// stale repeat: one triad (three quantised values all unchanged is rare in real data; one
/// channel unchanged is common at rest).
const MIN_REPEAT_CHANNELS: usize = 3;
/// Samples over which the shares of unchanged values are averaged.
const CHANCE_WINDOW: u64 = 1000;
/// Pairs of samples before the shares are trusted: until then every bit-identical copy is
/// stale (the rule before there were shares).
const CHANCE_MIN_PAIRS: u64 = 100;
/// Whole-sample repeats beyond this many times the product of the channels' shares of unchanged
/// values are stale copies (chance repeats come at about that product).
const STALE_EXCESS: f64 = 4.0;

/// The previous sample and the running shares of unchanged values a stale repeat is judged on.
#[derive(Debug, Clone, Default)]
pub(super) struct RepeatDetector {
    /// Raw channels of the last sample that was no repeat.
    last_raw: Option<[f64; N_CHANNELS]>,
    /// Each channel's share of samples that kept the previous one's value bit for bit, the share
    /// of whole samples that did (running means over the last [`CHANCE_WINDOW`]), and the pairs
    /// counted.
    unchanged: [f64; N_CHANNELS],
    whole: f64,
    pairs: u64,
}

impl RepeatDetector {
    /// `s` repeats the previous sample bit for bit (every present channel finite): a stale
    /// sample. Remembers `s` as the previous sample otherwise. Absent channels take no part;
    /// with fewer than [`MIN_REPEAT_CHANNELS`] present a bit-identical sample is ordinary for a
    /// quantised sensor at rest, so nothing is called a repeat.
    ///
    /// Nor is it one where whole samples repeat by chance: a sensor whose noise is below its LSB on
    /// every channel does that (σ = 0.2 LSB: 31 % of its samples), and those are measurements. A
    /// logger writing faster than its sensor repeats whole samples far more often than its
    /// channels' own shares of unchanged values predict; chance repeats come as often as their
    /// product. So a copy is stale while the share of whole-sample repeats (over the last
    /// [`CHANCE_WINDOW`] samples) exceeds [`STALE_EXCESS`] times the product of the channels'
    /// shares: on the rtklibexplorer walk (34 % stale copies) it is 100 times that and more.
    pub(super) fn is_repeat(&mut self, s: &Sample) -> bool {
        let v = s.channels();
        let present = N_CHANNELS - s.absent.count_ones() as usize;
        let Some(l) = self.last_raw else {
            self.last_raw = Some(v);
            return false;
        };
        let same = |c: usize| l[c].to_bits() == v[c].to_bits() && l[c].is_finite();
        let identical = (0..N_CHANNELS).all(|c| s.is_absent(c) || same(c));
        // The shares count every pair of successive samples, stale or not, this one included.
        self.pairs = self.pairs.saturating_add(1);
        let w = 1.0 / (self.pairs.min(CHANCE_WINDOW) as f64);
        for c in (0..N_CHANNELS).filter(|&c| !s.is_absent(c)) {
            self.unchanged[c] += w * (f64::from(u8::from(same(c))) - self.unchanged[c]);
        }
        self.whole += w * (f64::from(u8::from(identical)) - self.whole);
        let chance: f64 = (0..N_CHANNELS)
            .filter(|&c| !s.is_absent(c))
            .map(|c| self.unchanged[c])
            .product();
        let learned = self.pairs >= CHANCE_MIN_PAIRS;
        let repeat = present >= MIN_REPEAT_CHANNELS
            && identical
            && (!learned || self.whole > STALE_EXCESS * chance);
        if !repeat {
            self.last_raw = Some(v);
        }
        repeat
    }
}
