//! The one decoder contract every wire format keeps (native frames, UBX, MAVLink, ULog).
//!
//! A decoder takes bytes from the front of a buffer and yields [`Decoded`] items in input order:
//! a sensor [`Descriptor`], an IMU [`Sample`] with the [`Carrier`] that can re-encode it, or the
//! bytes of a message that is not IMU data ([`Decoded::Other`], passed through unchanged by the
//! inline sinks). Bad input never ends the stream: a bad frame is counted in [`DecoderStats`] and
//! skipped, the search for the next frame starts one byte after the suspect start, so no good
//! frame is lost to resynchronisation. Sequence and time faults are flagged on the samples
//! (`GAP`, `DUPLICATE`) the way the native decoder flags them, non-finite and saturated values
//! too.
//!
//! The [`Sample`] stays `Copy` and small: what a protocol needs to re-encode a cleaned sample
//! (the original message bytes, its slot in that message) travels beside it in the [`Carrier`],
//! which the pipeline never sees.

use super::{DecoderStats, Descriptor, Message};
use crate::sample::{Sample, flags};
use bytes::{Bytes, BytesMut};

/// `impl Default for $decoder`: `$decoder::new` with `$options::default()` (every protocol
/// decoder is built from its options).
macro_rules! default_from_options {
    ($decoder:ty, $options:ty) => {
        impl Default for $decoder {
            fn default() -> Self {
                Self::new(<$options>::default())
            }
        }
    };
}
pub(crate) use default_from_options;

/// `ProtocolDecoder::stats` and `ProtocolDecoder::descriptor` of a decoder that keeps its
/// counters in a `Framer` at `self.f` and its time base in a `Stamper` at `self.stamper` (UBX,
/// MAVLink, ULog, MCAP); expands inside the `impl ProtocolDecoder` block.
macro_rules! framer_stats_and_descriptor {
    () => {
        fn stats(&self) -> $crate::frame::DecoderStats {
            self.f.stats
        }
        fn descriptor(&self) -> Option<$crate::frame::Descriptor> {
            self.stamper.descriptor()
        }
    };
}
pub(crate) use framer_stats_and_descriptor;

/// The wire formats imuprep reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// imuprep's own frames (docs/frame-format.md).
    #[default]
    Native,
    /// u-blox UBX: ESF-RAW / ESF-MEAS; NMEA and other UBX messages passed through.
    Ubx,
    /// MAVLink v1/v2: HIGHRES_IMU, SCALED_IMU/2/3, RAW_IMU; other messages passed through.
    Mavlink,
    /// PX4 ULog: sensor_combined, or sensor_gyro + sensor_accel of one instance.
    Ulog,
    /// ROS 2 bag in MCAP: sensor_msgs/msg/Imu (CDR) of one topic; other records passed through.
    Mcap,
}

impl Protocol {
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Native => "native",
            Protocol::Ubx => "ubx",
            Protocol::Mavlink => "mavlink",
            Protocol::Ulog => "ulog",
            Protocol::Mcap => "mcap",
        }
    }
}

impl std::fmt::Display for Protocol {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a protocol needs to re-encode a cleaned sample in its own format: the original
/// message(s) that carried it and where in them it sits. Cheap to clone (reference-counted
/// bytes), never on the pipeline's path.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Carrier {
    /// The original message bytes (whole frame: sync to checksum).
    pub frame: Bytes,
    /// A second message that carried part of the same sample (UBX ESF-MEAS sends gyro and
    /// accel of one time tag in two messages), written right after `frame`.
    pub frame2: Option<Bytes>,
    /// Messages that came between `frame` and `frame2` (written between them, so the
    /// inline output keeps the input's order byte for byte).
    pub between: Option<Bytes>,
    /// This sample's index among the samples `frame` carries (ESF-RAW packs several).
    pub slot: u16,
    /// Samples `frame` carries in all; the re-encoded frame is written after the last one.
    pub slots: u16,
    /// Protocol-specific byte offsets of the values in the frame(s) (ULog: gyro, accel,
    /// temperature (u16::MAX = none), pair flag; MCAP: angular velocity, -, big endian, not
    /// patchable); unused by UBX and MAVLink.
    pub offsets: [u16; 4],
    /// MAVLink RAW_IMU: the configured scales (gyro rad/s, accel m/s² per count) the counts
    /// were read with, so the inline output writes cleaned values back in counts.
    pub raw_scale: Option<[f64; 2]>,
}

/// One item out of a decoder, in input order. The sample is kept inline (not boxed): it is
/// the hot path, and a box would allocate per sample.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Decoded {
    Descriptor(Descriptor),
    /// An IMU sample and, for protocols that can re-encode it, its carrier.
    Sample(Sample, Option<Carrier>),
    /// A whole message that is not IMU data for the selected stream, exactly as received.
    Other(Bytes),
}

impl Decoded {
    /// The sample, if this item is one.
    pub fn sample(&self) -> Option<&Sample> {
        match self {
            Decoded::Sample(s, _) => Some(s),
            _ => None,
        }
    }
}

/// The decoder contract. `decode` takes at most one item from the front of `buf` and returns
/// `None` when it needs more bytes; `decode_eof` is called when no more bytes will come and
/// counts what is left as truncated or garbage. Neither ever panics on any input.
pub trait ProtocolDecoder: Send {
    fn protocol(&self) -> Protocol;
    fn decode_item(&mut self, buf: &mut BytesMut) -> Option<Decoded>;
    /// At end of input: what can still be decoded, then the tail that cannot complete is
    /// counted and dropped ([`Self::discard_tail`]) and decoding resumes after it, until the
    /// buffer is empty; then what the decoder held back ([`Self::held`]).
    fn decode_item_eof(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        self.end_of_input();
        if let Some(d) = self.decode_item(buf) {
            return Some(d);
        }
        while !buf.is_empty() {
            self.discard_tail(buf);
            if let Some(d) = self.decode_item(buf) {
                return Some(d);
            }
        }
        self.held()
    }
    /// Bytes that can never complete a message at end of input: count and drop them.
    fn discard_tail(&mut self, buf: &mut BytesMut);
    /// No more bytes will come (a decoder that waits for the next message's start before it
    /// trusts one stops waiting).
    fn end_of_input(&mut self) {}
    /// After the last byte: an item held back waiting for a partner that never came (half of
    /// a gyro/accel pair), one per call, `None` when nothing is held.
    fn held(&mut self) -> Option<Decoded> {
        None
    }
    fn stats(&self) -> DecoderStats;
    /// The last descriptor seen or implied by the configuration, if any.
    fn descriptor(&self) -> Option<Descriptor>;
    /// A short description of what was found in the stream (for the summary), e.g. the
    /// MAVLink system/component and message, or the MCAP topic.
    fn found(&self) -> String {
        String::new()
    }
}

/// Feed `bytes` to `d` in pieces of `chunk` bytes (as a port delivers them), then end the
/// stream: every item decoded, and the decoder's counters. For tests, tools and benches that
/// decode a whole buffer.
pub fn decode_chunked(
    d: &mut dyn ProtocolDecoder,
    bytes: &[u8],
    chunk: usize,
) -> (Vec<Decoded>, DecoderStats) {
    let mut buf = BytesMut::new();
    let mut out = Vec::new();
    for c in bytes.chunks(chunk.max(1)) {
        buf.extend_from_slice(c);
        while let Some(x) = d.decode_item(&mut buf) {
            out.push(x);
        }
    }
    while let Some(x) = d.decode_item_eof(&mut buf) {
        out.push(x);
    }
    (out, d.stats())
}

/// The samples among decoded items, in order.
pub fn samples_of(items: &[Decoded]) -> Vec<Sample> {
    items
        .iter()
        .filter_map(|d| match d {
            Decoded::Sample(s, _) => Some(*s),
            _ => None,
        })
        .collect()
}

/// Adapter: any [`ProtocolDecoder`] as a `tokio_util` codec (for `FramedRead`).
pub struct Codec(pub Box<dyn ProtocolDecoder>);

impl tokio_util::codec::Decoder for Codec {
    type Item = Decoded;
    type Error = std::io::Error;
    fn decode(&mut self, buf: &mut BytesMut) -> Result<Option<Decoded>, std::io::Error> {
        Ok(self.0.decode_item(buf))
    }
    fn decode_eof(&mut self, buf: &mut BytesMut) -> Result<Option<Decoded>, std::io::Error> {
        Ok(self.0.decode_item_eof(buf))
    }
}

/// The native decoder's next item (`decode`, or `decode_eof` at the end of the input).
fn native_item(dec: &mut super::FrameDecoder, buf: &mut BytesMut, eof: bool) -> Option<Decoded> {
    use tokio_util::codec::Decoder;
    // Health reports are data for consumers, not input: skip them (counted) and go on.
    loop {
        let m = if eof {
            Decoder::decode_eof(dec, buf)
        } else {
            Decoder::decode(dec, buf)
        };
        match m.ok().flatten()? {
            Message::Descriptor(d) => return Some(Decoded::Descriptor(d)),
            Message::Sample(s) => return Some(Decoded::Sample(s, None)),
            Message::Health(_) => continue,
        }
    }
}

impl ProtocolDecoder for super::FrameDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Native
    }
    fn decode_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        native_item(self, buf, false)
    }
    fn decode_item_eof(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        native_item(self, buf, true)
    }
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        use tokio_util::codec::Decoder;
        while let Ok(Some(_)) = Decoder::decode_eof(self, buf) {}
    }
    fn stats(&self) -> DecoderStats {
        super::FrameDecoder::stats(self)
    }
    fn descriptor(&self) -> Option<Descriptor> {
        super::FrameDecoder::descriptor(self)
    }
}

/// Mark the channels of `mask` absent on `s` (bit `c` for channel `c`): NaN, no saturation
/// flag, and [`Sample::absent`], so they count as no measurement rather than as a non-finite
/// or saturated value.
#[inline]
pub fn mark_absent(s: &mut Sample, mask: u8) {
    s.absent = mask & crate::sample::ALL_CHANNELS;
    if s.absent == 0 {
        return;
    }
    for c in 0..crate::sample::N_CHANNELS {
        if s.is_absent(c) {
            s.set_channel(c, f64::NAN);
            s.flags &= !flags::sat_ch(c);
        }
    }
}

/// Flag non-finite channels, and saturated ones against the descriptor's ranges (same rule as
/// the native decoder). Absent channels ([`Sample::absent`]) are neither.
pub fn flag_values(s: &mut Sample, d: Option<&Descriptor>, stats: &mut DecoderStats) {
    let ch = s.channels();
    if ch
        .iter()
        .enumerate()
        .any(|(c, v)| !v.is_finite() && !s.is_absent(c))
    {
        s.flags |= flags::NON_FINITE;
        stats.non_finite += 1;
    }
    if let Some(d) = d {
        for (c, v) in ch.iter().enumerate() {
            let range = if c < 3 {
                d.gyro_range_rad_s
            } else {
                d.accel_range_m_s2
            } as f64;
            if range > 0.0 && v.abs() >= range && !s.is_absent(c) {
                s.flags |= flags::sat_ch(c);
            }
        }
    }
    if s.flags & flags::SAT_ANY != 0 {
        stats.saturated += 1;
    }
}

/// Backward time jumps shorter than this many nominal periods are late repeats; longer ones a
/// restart of the sensor clock (as the native decoder's sequence window).
const BACKWARD_WINDOW_PERIODS: f64 = 1024.0;
/// Intervals used to learn the nominal period when the protocol does not state the rate.
const LEARN_INTERVALS: usize = 15;

/// Sequence from time, for protocols whose IMU messages carry a time stamp but no sample
/// counter: each sample gets the next sequence number, a gap of k missing periods advances it by
/// k more and flags `GAP`, a repeated or slightly older time stamp is flagged `DUPLICATE` (and
/// keeps the last number), a large backward jump is a restart (`GAP`). The nominal period is the
/// median of the first intervals unless the stream states its rate.
#[derive(Clone, Debug, Default)]
pub struct TimeTracker {
    last_t_ns: Option<u64>,
    seq: u32,
    period_ns: f64,
    learn: Vec<u64>,
}

impl TimeTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// Nominal period known in advance (from the stream's declared rate).
    pub fn with_rate_hz(rate_hz: f64) -> Self {
        let mut t = Self::default();
        if rate_hz > 0.0 && rate_hz.is_finite() {
            t.period_ns = 1e9 / rate_hz;
        }
        t
    }

    /// The nominal rate, Hz, once known.
    pub fn rate_hz(&self) -> Option<f64> {
        (self.period_ns > 0.0).then(|| 1e9 / self.period_ns)
    }

    /// Set `s.seq` and the time-fault flags; count them.
    pub fn track(&mut self, s: &mut Sample, stats: &mut DecoderStats) {
        let t = s.t_ns;
        let Some(last) = self.last_t_ns else {
            self.last_t_ns = Some(t);
            s.seq = self.seq;
            return;
        };
        if t == last {
            s.flags |= flags::DUPLICATE;
            stats.duplicates += 1;
            s.seq = self.seq;
            return;
        }
        if t < last {
            stats.time_backwards += 1;
            let back = (last - t) as f64;
            if self.period_ns > 0.0 && back < BACKWARD_WINDOW_PERIODS * self.period_ns {
                s.flags |= flags::DUPLICATE;
                stats.duplicates += 1;
                s.seq = self.seq;
            } else {
                s.flags |= flags::GAP;
                stats.seq_restarts += 1;
                self.seq = self.seq.wrapping_add(1);
                s.seq = self.seq;
                self.last_t_ns = Some(t);
            }
            return;
        }
        let dt = t - last;
        if self.period_ns <= 0.0 {
            self.learn.push(dt);
            if self.learn.len() >= LEARN_INTERVALS {
                let mut v = std::mem::take(&mut self.learn);
                v.sort_unstable();
                self.period_ns = v[v.len() / 2] as f64;
            }
        }
        let mut step = 1u32;
        if self.period_ns > 0.0 && dt as f64 > 1.5 * self.period_ns {
            let missing = ((dt as f64 / self.period_ns).round() - 1.0).max(1.0);
            let missing = missing.min(u32::MAX as f64 / 2.0) as u32;
            s.flags |= flags::GAP;
            stats.gaps += 1;
            stats.missing_frames += missing as u64;
            step = step.wrapping_add(missing);
        }
        self.seq = self.seq.wrapping_add(step);
        s.seq = self.seq;
        self.last_t_ns = Some(t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(t_ns: u64) -> Sample {
        Sample {
            t_ns,
            ..Sample::default()
        }
    }

    #[test]
    fn time_tracker_flags_gap_duplicate_and_restart() {
        let mut tr = TimeTracker::with_rate_hz(100.0);
        let mut st = DecoderStats::default();
        let ts = [0, 10, 20, 20, 50, 40, 60, 10_000_000];
        let out: Vec<Sample> = ts
            .iter()
            .map(|t| {
                let mut x = s(t * 1_000_000);
                tr.track(&mut x, &mut st);
                x
            })
            .collect();
        let seqs: Vec<u32> = out.iter().map(|x| x.seq).collect();
        // 50 ms after 20 ms: two missing 10-ms periods; 40 after 50: a late repeat; 10^7 ms
        // after 60 ms: a gap of many periods.
        assert_eq!(&seqs[..7], &[0, 1, 2, 2, 5, 5, 6]);
        assert!(out[3].has(flags::DUPLICATE));
        assert!(out[4].has(flags::GAP));
        assert!(out[5].has(flags::DUPLICATE));
        assert!(out[7].has(flags::GAP));
        assert_eq!((st.duplicates, st.time_backwards), (2, 1));
        assert_eq!(st.missing_frames, 2 + (10_000_000 - 60) / 10 - 1);
    }

    #[test]
    fn time_tracker_learns_the_period() {
        let mut tr = TimeTracker::new();
        let mut st = DecoderStats::default();
        for i in 0..20u64 {
            let mut x = s(i * 4_000_000);
            tr.track(&mut x, &mut st);
        }
        assert_eq!(tr.rate_hz(), Some(250.0));
        let mut x = s(19 * 4_000_000 + 12_000_000);
        tr.track(&mut x, &mut st);
        assert!(x.has(flags::GAP));
        assert_eq!(st.missing_frames, 2);
    }
}
