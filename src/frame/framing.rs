//! What every protocol decoder does around its own message format, written once: the byte
//! bookkeeping of framing and resynchronisation ([`Framer`]) and the finishing of a fresh sample
//! ([`Stamper`]: sequence and time faults, the descriptor learned from the rate, value flags).
//!
//! A decoder looks at the front of the buffer, decides with its own rules whether a whole
//! message starts there, and tells the [`Framer`] what it found: garbage before a message start
//! ([`Framer::skip`], [`Framer::seek`], [`Framer::seek_magic`]), a suspect start that failed a
//! check ([`Framer::fault`]: one byte is dropped, so a message starting inside the suspect one
//! is still found), or a whole message ([`Framer::take`]). The framer keeps the counters of the
//! decoder contract (bytes in, garbage, resynchronisations) consistent across calls: bytes are
//! counted once when they arrive ([`Framer::arrived`]) however often the decoder is called on
//! the same buffer.

use super::protocol::{Decoded, TimeTracker, flag_values};
use super::{DecoderStats, Descriptor};
use crate::sample::Sample;
use bytes::{Buf, Bytes, BytesMut};

/// What a protocol's framing rule says about the bytes at the front of the buffer (which start
/// like one of its messages).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Front {
    /// Not enough bytes yet; the message's whole length when it is known.
    Need(Option<usize>),
    /// Not a message: the check that failed.
    Bad(Fault),
    /// A whole message of this many bytes, checked.
    Whole(usize),
}

/// Which check a suspect message start failed (the counter it adds to).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// Only the start byte(s) looked right.
    Sync,
    Header,
    Length,
    Crc,
    UnknownType,
    Payload,
}

/// Framing state and counters shared by the protocol decoders.
#[derive(Clone, Debug, Default)]
pub struct Framer {
    /// The decoder's counters (the framer keeps the byte counts; the decoder adds its own).
    pub stats: DecoderStats,
    /// Bytes of the buffer already counted in `bytes_in`.
    counted: usize,
    /// Inside a run of garbage (a run counts one resynchronisation).
    in_garbage: bool,
    /// An item made in the last call and held back for the next one (the descriptor learned on
    /// the sample that call handed out: [`Stamper::finish`]).
    held: Option<Decoded>,
}

impl Framer {
    /// At the start of every decode call: count the bytes appended since the last call, and
    /// hand out the item held back by the last call, if any (it goes first).
    #[inline]
    pub fn begin(&mut self, buf: &BytesMut) -> Option<Decoded> {
        self.arrived(buf);
        self.held.take()
    }

    /// The item held back for the next call ([`Stamper::finish`]), taken now.
    #[inline]
    pub fn take_held(&mut self) -> Option<Decoded> {
        self.held.take()
    }

    /// At the start of every decode call: count the bytes appended since the last call.
    #[inline]
    pub fn arrived(&mut self, buf: &BytesMut) {
        if buf.len() > self.counted {
            self.stats.bytes_in += (buf.len() - self.counted) as u64;
        }
        self.counted = buf.len();
    }

    #[inline]
    fn consumed(&mut self, n: usize) {
        self.counted = self.counted.saturating_sub(n);
    }

    /// `n` bytes at the front that start no message: dropped and counted; a run of garbage
    /// counts one resynchronisation.
    pub fn skip(&mut self, buf: &mut BytesMut, n: usize) {
        let n = n.min(buf.len());
        if n == 0 {
            return;
        }
        buf.advance(n);
        self.consumed(n);
        self.stats.garbage_bytes += n as u64;
        if !self.in_garbage {
            self.stats.resyncs += 1;
            self.in_garbage = true;
        }
    }

    /// A suspect message start failed a check: drop its first byte (counted) and search again
    /// from the next, so no message that starts inside it is lost.
    pub fn fault(&mut self, buf: &mut BytesMut) {
        if buf.is_empty() {
            return;
        }
        buf.advance(1);
        self.consumed(1);
        self.stats.garbage_bytes += 1;
        self.stats.resyncs += 1;
        self.in_garbage = true;
    }

    /// A suspect start that failed `check`: counted, then [`Self::fault`].
    pub fn bad(&mut self, buf: &mut BytesMut, check: Fault) {
        let st = &mut self.stats;
        match check {
            Fault::Sync => {}
            Fault::Header => st.header_errors += 1,
            Fault::Length => st.bad_length += 1,
            Fault::Crc => st.crc_errors += 1,
            Fault::UnknownType => st.unknown_type += 1,
            Fault::Payload => st.bad_payload += 1,
        }
        self.fault(buf);
    }

    /// Not enough bytes for a message of `total` bytes (when known): room for it is made in
    /// the buffer, so the next read can complete it (a caller whose lengths are not checked
    /// before the bytes arrive passes `None`: a corrupt length must not allocate).
    pub fn need(&mut self, buf: &mut BytesMut, total: Option<usize>) {
        if let Some(t) = total
            && t > buf.len()
        {
            buf.reserve(t - buf.len());
        }
    }

    /// A whole, checked message of `n` bytes at the front: taken off the buffer (no copy).
    #[inline]
    pub fn take(&mut self, buf: &mut BytesMut, n: usize) -> Bytes {
        self.in_garbage = false;
        self.consumed(n);
        buf.split_to(n).freeze()
    }

    /// Drop the bytes before the first one that can start a message. `false` when there is
    /// none (the buffer is then empty).
    #[inline]
    pub fn seek(&mut self, buf: &mut BytesMut, is_start: impl Fn(u8) -> bool) -> bool {
        let p = buf.iter().position(|&b| is_start(b));
        self.skip(buf, p.unwrap_or(buf.len()));
        p.is_some()
    }

    /// Before a file's opening magic: drop what comes before it. `true` when the buffer starts
    /// with the whole magic; otherwise the bytes that may begin it are kept for the next call.
    pub fn seek_magic(&mut self, buf: &mut BytesMut, magic: &[u8]) -> bool {
        match buf.windows(magic.len()).position(|w| w == magic) {
            Some(p) => {
                self.skip(buf, p);
                true
            }
            None => {
                let keep = (magic.len() - 1).min(buf.len());
                self.skip(buf, buf.len() - keep);
                false
            }
        }
    }

    /// Count a whole message that is not IMU data of the selected stream (passed through).
    #[inline]
    pub fn count_other(&mut self, b: &[u8]) {
        self.stats.frames_ok += 1;
        self.stats.other_messages += 1;
        self.stats.other_bytes += b.len() as u64;
    }

    /// At end of input, bytes at the front that cannot complete a message: counted truncated
    /// when `is_message_start`, then stepped over one byte (a message may start inside them).
    pub fn truncated_front(&mut self, buf: &mut BytesMut, is_message_start: bool) {
        if buf.is_empty() {
            return;
        }
        if is_message_start {
            self.stats.truncated += 1;
        }
        self.fault(buf);
    }

    /// Inside a run of garbage (since the last whole message).
    pub fn in_garbage(&self) -> bool {
        self.in_garbage
    }
}

/// Finishes the samples of a protocol that carries time stamps but no sample counter: sequence
/// number and time faults from the time ([`TimeTracker`]), a descriptor once the nominal rate is
/// known, non-finite and saturated values flagged, the sample counted.
#[derive(Clone, Debug, Default)]
pub struct Stamper {
    tracker: TimeTracker,
    descriptor: Option<Descriptor>,
}

impl Stamper {
    /// `rate_hz` > 0: the nominal rate is known; else it is learned from the time stamps.
    pub fn new(rate_hz: f64) -> Self {
        Stamper {
            tracker: TimeTracker::with_rate_hz(rate_hz),
            descriptor: None,
        }
    }

    /// The descriptor, once the rate is known.
    pub fn descriptor(&self) -> Option<Descriptor> {
        self.descriptor
    }

    /// Finish `s` (its `t_ns`, channels, temperature and absent channels set). Returns the
    /// descriptor when this sample made the rate known (`base` fills everything but the rate
    /// and the absent mask, which is this sample's): the decoder sends it on beside the sample.
    #[inline]
    pub fn stamp(
        &mut self,
        s: &mut Sample,
        stats: &mut DecoderStats,
        base: impl FnOnce() -> Descriptor,
    ) -> Option<Descriptor> {
        self.tracker.track(s, stats);
        let mut new = None;
        if self.descriptor.is_none()
            && let Some(r) = self.tracker.rate_hz()
        {
            // The channels absent when the rate became known are the stream's absent ones.
            let d = Descriptor {
                sample_rate_hz: r,
                absent: s.absent,
                ..base()
            };
            self.descriptor = Some(d);
            stats.descriptors += 1;
            new = Some(d);
        } else if let Some(d) = self.descriptor.as_mut()
            && d.absent & !s.absent != 0
        {
            // A channel the descriptor declared absent has come: declared again, present
            // (kept present after that: a later message without it is a missing value, not
            // a sensor without the channel). Without this, a native log or replay of the
            // output would read every later value of that channel as absent.
            d.absent &= s.absent;
            stats.descriptors += 1;
            new = Some(*d);
        }
        flag_values(s, self.descriptor.as_ref(), stats);
        stats.samples += 1;
        new
    }

    /// [`Self::stamp`] for a decoder that hands the sample out now: the descriptor it learned
    /// is held in the framer and goes out at the start of the next call ([`Framer::begin`]),
    /// right after the sample.
    #[inline]
    pub fn finish(&mut self, s: &mut Sample, f: &mut Framer, base: impl FnOnce() -> Descriptor) {
        if let Some(d) = self.stamp(s, &mut f.stats, base) {
            f.held = Some(Decoded::Descriptor(d));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_bytes_once_garbage_runs_and_faults() {
        let mut f = Framer::default();
        let mut buf = BytesMut::from(&b"xxAB"[..]);
        f.arrived(&buf);
        f.arrived(&buf);
        assert_eq!(f.stats.bytes_in, 4);
        assert!(f.seek(&mut buf, |b| b == b'A'));
        assert_eq!((f.stats.garbage_bytes, f.stats.resyncs), (2, 1));
        // A fault inside a garbage run is a resynchronisation of its own.
        f.fault(&mut buf);
        assert_eq!((f.stats.garbage_bytes, f.stats.resyncs), (3, 2));
        buf.extend_from_slice(b"CD");
        f.arrived(&buf);
        assert_eq!(f.stats.bytes_in, 6);
        assert_eq!(&f.take(&mut buf, 2)[..], b"BC");
        f.arrived(&buf);
        assert_eq!(f.stats.bytes_in, 6, "taking bytes adds none");
        assert!(!f.seek(&mut buf, |b| b == b'A'));
        assert!(buf.is_empty());
        assert_eq!((f.stats.garbage_bytes, f.stats.resyncs), (4, 3));
    }

    #[test]
    fn magic_search_keeps_a_partial_magic() {
        let mut f = Framer::default();
        let mut buf = BytesMut::from(&b"junkMA"[..]);
        assert!(!f.seek_magic(&mut buf, b"MAGIC"));
        assert_eq!(&buf[..], b"nkMA");
        buf.extend_from_slice(b"GIC!");
        assert!(f.seek_magic(&mut buf, b"MAGIC"));
        assert_eq!(&buf[..], b"MAGIC!");
        assert_eq!(f.stats.garbage_bytes, 4);
    }
}
