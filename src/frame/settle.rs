//! A stream's first samples held until its channel set is known.
//!
//! Protocols that say per message which channels it carries (MAVLink HIGHRES_IMU's
//! `fields_updated`) cannot tell from the first message whether a channel it lacks is one the
//! sensor does not have (absent, for the whole stream) or one that has not reported yet (a
//! 6-axis IMU whose accel starts a few messages after its gyro). Read from the first message
//! alone, the stream's descriptor — which the native log, `export` and every later replay use
//! to mark channels absent — would call such an accel absent for good, and a replay of the
//! export would drop every accel reading. So the first samples are held (with the messages
//! between them, in order) until every channel has been seen, or [`HOLD_SAMPLES`] samples
//! (the rate-learning window: the descriptor is made from the last of them) or [`HOLD_ITEMS`]
//! items have come, or the input ends. Then the stream's channel set is the channels seen so
//! far: a channel none of them carried is absent; a held sample that came before the first
//! one carrying a channel of the set has that channel missing — NaN, flagged non-finite and
//! counted partial, as a UBX set or a ULog message without a channel the stream carries is.
//! A stream whose first sample has every channel is released at once.

use super::protocol::{Carrier, Decoded, mark_absent};
use crate::sample::{ALL_CHANNELS, Sample};
use std::collections::VecDeque;

/// Samples held at most: the descriptor is learned on the 16th (15 intervals), the same window
/// as the period's hold ([`super::protocol::HOLD_SAMPLES`]).
pub const HOLD_SAMPLES: usize = super::protocol::HOLD_SAMPLES;
/// Items (samples and the messages between them) held at most, so a sparse IMU stream among
/// many other messages cannot hold memory without bound (as the period's hold).
pub const HOLD_ITEMS: usize = super::protocol::HOLD_ITEMS;

/// What is held, in input order.
pub enum Held {
    /// A sample of the stream, not yet finished, with the channels (bit `c`) the stream had
    /// carried up to and including its message.
    Sample(Sample, u8, Carrier),
    /// Anything else, as it will be handed out.
    Item(Decoded),
}

/// The hold queue of one stream.
#[derive(Default)]
pub struct Settle {
    queue: VecDeque<Held>,
    samples: usize,
    settled: bool,
}

impl Settle {
    /// The channel set is known: nothing more is held.
    #[inline]
    pub fn settled(&self) -> bool {
        self.settled
    }

    /// Hold a sample; settles when `seen` has every channel or the limits are reached.
    pub fn sample(&mut self, s: Sample, seen: u8, carrier: Carrier) {
        self.queue.push_back(Held::Sample(s, seen, carrier));
        self.samples += 1;
        if seen & ALL_CHANNELS == ALL_CHANNELS || self.samples >= HOLD_SAMPLES {
            self.settled = true;
        }
        self.limit();
    }

    /// Hold an item that came between held samples.
    pub fn item(&mut self, d: Decoded) {
        self.queue.push_back(Held::Item(d));
        self.limit();
    }

    fn limit(&mut self) {
        if self.queue.len() >= HOLD_ITEMS {
            self.settled = true;
        }
    }

    /// No more input (every byte decoded): what is held goes out with the channels seen so
    /// far.
    pub fn settle(&mut self) {
        self.settled = true;
    }

    /// The next held item, once settled.
    #[inline]
    pub fn release(&mut self) -> Option<Held> {
        if self.settled {
            self.queue.pop_front()
        } else {
            None
        }
    }
}

/// Set a sample's channels for a stream whose channel set is `present` (bit `c`): absent where
/// the stream has no such channel, NaN (missing) where it has one that no message had carried
/// by this sample's (`seen`). `true` when something was missing (a partial sample).
pub fn channels(s: &mut Sample, present: u8, seen: u8) -> bool {
    let missing = present & !seen & ALL_CHANNELS;
    for c in (0..6).filter(|c| missing & (1 << c) != 0) {
        s.set_channel(c, f64::NAN);
    }
    mark_absent(s, !present);
    missing != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_until_every_channel_or_the_limit() {
        let mut h = Settle::default();
        h.sample(Sample::default(), 0b000_111, Carrier::default());
        h.item(Decoded::Other(bytes::Bytes::from_static(b"x")));
        assert!(!h.settled() && h.release().is_none());
        h.sample(Sample::default(), ALL_CHANNELS, Carrier::default());
        assert!(h.settled());
        assert!(matches!(h.release(), Some(Held::Sample(_, 0b000_111, _))));
        assert!(matches!(h.release(), Some(Held::Item(_))));
        assert!(matches!(
            h.release(),
            Some(Held::Sample(_, ALL_CHANNELS, _))
        ));
        assert!(h.release().is_none());
        let mut h = Settle::default();
        for _ in 0..HOLD_SAMPLES - 1 {
            h.sample(Sample::default(), 0b000_111, Carrier::default());
        }
        assert!(!h.settled());
        h.sample(Sample::default(), 0b000_111, Carrier::default());
        assert!(
            h.settled(),
            "a gyro-only stream is released after the learning window"
        );
    }

    #[test]
    fn missing_before_the_first_reading_absent_when_never_seen() {
        let mut s = Sample::default();
        s.set_channels(&[1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
        // The stream has gyro and accel; this message came before the first accel.
        assert!(channels(&mut s, ALL_CHANNELS, 0b000_111));
        assert_eq!(s.absent, 0);
        assert!(s.accel.iter().all(|v| v.is_nan()) && s.gyro[0] == 1.0);
        // A gyro-only stream: accel absent, nothing missing.
        let mut s = Sample::default();
        assert!(!channels(&mut s, 0b000_111, 0b000_111));
        assert_eq!(s.absent, 0b111_000);
    }
}
