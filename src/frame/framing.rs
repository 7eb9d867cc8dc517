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

#[cfg(doc)]
use super::protocol::HOLD_SAMPLES;
use super::protocol::{Decoded, HOLD_ITEMS, TimeTracker, flag_values};
use super::{DecoderStats, Descriptor};
use crate::sample::Sample;
use bytes::{Buf, Bytes, BytesMut};
use std::collections::VecDeque;

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
///
/// While the tracker learns the period, the stream's first samples are held here, with every
/// item the decoder makes between them, in order: the decoder hands each item it makes to
/// [`Self::pass`] and takes the held ones back with [`Self::release`]
/// ([`decode_through_hold`] writes that loop once). When the period is known (at the latest on
/// the [`HOLD_SAMPLES`]th sample), the held samples are judged with it and go out; at end of
/// input ([`Self::flush`]) what is held goes out too, judged with what is known.
#[derive(Clone, Debug, Default)]
pub struct Stamper {
    tracker: TimeTracker,
    descriptor: Option<Descriptor>,
    /// Items held while the period is learned, in order.
    hold: VecDeque<Decoded>,
    /// Samples among them.
    held_samples: usize,
    /// The held items are judged and going out.
    releasing: bool,
}

impl Stamper {
    /// `rate_hz` > 0: the nominal rate is known; else it is learned from the time stamps.
    pub fn new(rate_hz: f64) -> Self {
        Stamper {
            tracker: TimeTracker::with_rate_hz(rate_hz),
            ..Stamper::default()
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

    /// Nothing held or waiting to go out: the decoder's items need not pass the hold.
    #[inline]
    pub fn idle(&self) -> bool {
        self.hold.is_empty() && self.tracker.holding() == 0
    }

    /// An item the decoder made, in output order: back at once, or `None` while the first
    /// samples are held (the decoder goes on with its next item; [`Self::release`] gives the
    /// held ones back when the period is known).
    #[inline]
    pub fn pass(&mut self, d: Decoded, stats: &mut DecoderStats) -> Option<Decoded> {
        if self.idle() {
            return Some(d);
        }
        self.held_item(d, stats)
    }

    fn held_item(&mut self, d: Decoded, stats: &mut DecoderStats) -> Option<Decoded> {
        // Samples stamped while held (after the judging, the queue only drains: later
        // samples, judged when stamped, wait behind the held ones to keep the order).
        if matches!(d, Decoded::Sample(..)) && self.tracker.holding() > 0 {
            self.held_samples += 1;
        }
        self.hold.push_back(d);
        if self.hold.len() >= HOLD_ITEMS {
            self.tracker.end_hold(true);
        }
        self.judge_when_done(stats);
        self.release()
    }

    /// Judge the held samples once the tracker can and all of them are here.
    fn judge_when_done(&mut self, stats: &mut DecoderStats) {
        if self.tracker.window_done() && self.held_samples >= self.tracker.holding() {
            self.judge_held(stats);
        }
    }

    fn judge_held(&mut self, stats: &mut DecoderStats) {
        for d in self.hold.iter_mut() {
            if let Decoded::Sample(s, _) = d {
                self.tracker.judge(s, stats);
            }
        }
        self.tracker.judged();
        self.held_samples = 0;
        self.releasing = true;
    }

    /// The next held item, once judged.
    #[inline]
    pub fn release(&mut self) -> Option<Decoded> {
        if !self.releasing {
            return None;
        }
        let d = self.hold.pop_front();
        if d.is_none() {
            self.releasing = false;
        }
        d
    }

    /// End of input (the decoder has made every item): what is held is judged with what is
    /// known (a stream shorter than the learning window has no period, as without a hold)
    /// and goes out ([`Self::release`]).
    pub fn flush(&mut self, stats: &mut DecoderStats) {
        if self.hold.is_empty() || self.releasing {
            return;
        }
        self.tracker.end_hold(false);
        self.judge_held(stats);
    }
}

/// `ProtocolDecoder::decode_item` and `ProtocolDecoder::held` of a decoder that finishes its
/// samples with a [`Stamper`] at `self.stamper` and keeps its counters in a [`Framer`] at
/// `self.f`: its own `next_item(buf)` and `held_back()` (the item made from the bytes, and at
/// end of input what it held back) go through the stamper's hold of the first samples
/// ([`Stamper::pass`], [`Stamper::release`], [`Stamper::flush`]). Expands inside the
/// `impl ProtocolDecoder` block.
macro_rules! decode_through_hold {
    () => {
        fn decode_item(&mut self, buf: &mut bytes::BytesMut) -> Option<$crate::frame::Decoded> {
            if self.stamper.idle() {
                // Nothing held (every sample after the first ones): the item as made, not
                // moved through the hold (a sample with its carrier is a few hundred bytes).
                let d = self.next_item(buf);
                if self.stamper.idle() {
                    return d;
                }
                // This call's sample is the stream's first: held from here.
                if let Some(d) = self.stamper.pass(d?, &mut self.f.stats) {
                    return Some(d);
                }
            }
            loop {
                if let Some(d) = self.stamper.release() {
                    return Some(d);
                }
                let d = self.next_item(buf)?;
                if let Some(d) = self.stamper.pass(d, &mut self.f.stats) {
                    return Some(d);
                }
            }
        }
        fn held(&mut self) -> Option<$crate::frame::Decoded> {
            loop {
                if let Some(d) = self.stamper.release() {
                    return Some(d);
                }
                match self.held_back() {
                    Some(d) => {
                        if let Some(d) = self.stamper.pass(d, &mut self.f.stats) {
                            return Some(d);
                        }
                    }
                    None => {
                        self.stamper.flush(&mut self.f.stats);
                        return self.stamper.release();
                    }
                }
            }
        }
    };
}
pub(crate) use decode_through_hold;

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

    /// Stamp samples at `ms` (ms) through a stamper, with an other item after each sample of
    /// `after` (its index in `ms`, item count), then end the input: every item out, in order.
    fn stamped(ms: &[u64], after: &[(usize, usize)]) -> (Vec<Decoded>, DecoderStats) {
        let mut st = Stamper::new(0.0);
        let mut f = Framer::default();
        let mut out = Vec::new();
        let pass = |d: Decoded, st: &mut Stamper, f: &mut Framer, out: &mut Vec<Decoded>| {
            while let Some(r) = st.release() {
                out.push(r);
            }
            if let Some(d) = st.pass(d, &mut f.stats) {
                out.push(d);
            }
        };
        for (k, &m) in ms.iter().enumerate() {
            let mut s = Sample {
                t_ns: m * 1_000_000,
                ..Sample::default()
            };
            s.gyro[0] = k as f64;
            st.finish(&mut s, &mut f, Descriptor::default);
            pass(Decoded::Sample(s, None), &mut st, &mut f, &mut out);
            if let Some(d) = f.take_held() {
                pass(d, &mut st, &mut f, &mut out);
            }
            let n = after.iter().find(|(i, _)| *i == k).map_or(0, |(_, n)| *n);
            for j in 0..n {
                let b = Bytes::from(format!("{k}.{j}"));
                pass(Decoded::Other(b), &mut st, &mut f, &mut out);
            }
        }
        while let Some(r) = st.release() {
            out.push(r);
        }
        st.flush(&mut f.stats);
        while let Some(r) = st.release() {
            out.push(r);
        }
        (out, f.stats)
    }

    /// The items as text: `k:seq[G]` for a sample (k its index), `D` a descriptor, the bytes of
    /// an other item.
    fn text(items: &[Decoded]) -> Vec<String> {
        items
            .iter()
            .map(|d| match d {
                Decoded::Sample(s, _) => format!(
                    "{}:{}{}",
                    s.gyro[0],
                    s.seq,
                    if s.has(crate::sample::flags::GAP) {
                        "G"
                    } else {
                        ""
                    }
                ),
                Decoded::Descriptor(_) => "D".into(),
                Decoded::Other(b) => String::from_utf8_lossy(b).into_owned(),
            })
            .collect()
    }

    #[test]
    fn the_first_samples_are_held_judged_with_the_period_and_released_in_order() {
        // 100 Hz, 3 missing after the 2nd sample; other items after samples 0, 2 and 17.
        let ms: Vec<u64> = (0..20u64)
            .map(|i| if i >= 2 { i + 3 } else { i } * 10)
            .collect();
        let (out, st) = stamped(&ms, &[(0, 1), (2, 2), (17, 1)]);
        let mut want: Vec<String> = vec!["0:0".into(), "0.0".into(), "1:1".into()];
        want.push("2:5G".into());
        want.extend(["2.0".into(), "2.1".into()]);
        want.extend((3..16).map(|k| format!("{k}:{}", k + 3)));
        want.push("D".into());
        want.extend((16..18).map(|k| format!("{k}:{}", k + 3)));
        want.push("17.0".into());
        want.extend((18..20).map(|k| format!("{k}:{}", k + 3)));
        assert_eq!(text(&out), want);
        assert_eq!((st.gaps, st.missing_frames, st.samples), (1, 3, 20));
    }

    #[test]
    fn a_stream_shorter_than_the_window_is_released_at_the_end_unchanged() {
        // 5 samples, a 30-ms interval among them: no period (as before the hold), all out.
        let (out, st) = stamped(&[0, 10, 40, 50, 60], &[(1, 1)]);
        assert_eq!(text(&out), ["0:0", "1:1", "1.0", "2:2", "3:3", "4:4"]);
        assert_eq!((st.gaps, st.descriptors, st.samples), (0, 0, 5));
    }

    #[test]
    fn too_many_items_between_the_first_samples_stop_the_hold() {
        // A sparse stream: 2 samples, then HOLD_ITEMS other items: both samples go out
        // (judged without a period, as without a hold) before the items after them do, and
        // nothing is held after that; the period is learned as the intervals come.
        let ms: Vec<u64> = (0..20u64).map(|i| i * 10).collect();
        let (out, st) = stamped(&ms, &[(1, HOLD_ITEMS)]);
        assert_eq!(out.len(), 20 + HOLD_ITEMS + 1);
        let t = text(&out);
        assert_eq!(&t[..3], ["0:0", "1:1", "1.0"]);
        assert_eq!(t[2 + HOLD_ITEMS], "2:2");
        assert!(t.iter().filter(|x| x.as_str() == "D").count() == 1);
        assert_eq!(st.samples, 20);
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
