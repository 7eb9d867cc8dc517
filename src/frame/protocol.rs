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
/// Samples held at most while the period is learned: the learning window (15 intervals).
pub const HOLD_SAMPLES: usize = LEARN_INTERVALS + 1;
/// Items (held samples and the messages between them) held at most, so a sparse IMU stream
/// among many other messages cannot hold memory without bound: beyond it the samples go out
/// judged as they come, as with nothing held.
pub const HOLD_ITEMS: usize = 4096;

/// Sequence from time, for protocols whose IMU messages carry a time stamp but no sample
/// counter: each sample gets the next sequence number, a gap of k missing periods advances it by
/// k more and flags `GAP`, a repeated or slightly older time stamp is flagged `DUPLICATE` (and
/// keeps the last number), a large backward jump is a restart (`GAP`). The nominal period is the
/// median of the first intervals unless the stream states its rate.
///
/// Learning the period, the tracker holds the stream's first samples ([`Self::track`] leaves
/// them unjudged, [`Self::holding`]) until it is known: the median of the positive intervals
/// among the first [`HOLD_SAMPLES`] samples (15 intervals when none repeats or steps back).
/// Then the caller judges the held samples in order ([`Self::judge`]) with that period, so a
/// gap among the first intervals is flagged and counted like any other; from then on each
/// sample is judged as it comes, nothing held. If those samples have no positive interval (one
/// time stamp repeated), they are judged without a period, and the period is learned from the
/// next 15 intervals as they are judged (as without a hold).
#[derive(Clone, Debug)]
pub struct TimeTracker {
    last_t_ns: Option<u64>,
    seq: u32,
    period_ns: f64,
    learn: Vec<u64>,
    /// Samples are held while the period is learned (false: learned as they are judged).
    hold: bool,
    /// The time stamp of the last sample held (the learning intervals are between them).
    hold_last: Option<u64>,
    /// Samples tracked while holding and not judged yet.
    held: usize,
    /// The held samples can be judged now (the window is complete, or the input ended).
    window_done: bool,
}

impl Default for TimeTracker {
    fn default() -> Self {
        TimeTracker {
            last_t_ns: None,
            seq: 0,
            period_ns: 0.0,
            learn: Vec::new(),
            hold: true,
            hold_last: None,
            held: 0,
            window_done: false,
        }
    }
}

impl TimeTracker {
    /// Period learned from the time stamps, the first samples held meanwhile.
    pub fn new() -> Self {
        Self::default()
    }

    /// Period learned from the time stamps, each sample judged as it comes (nothing held: a
    /// gap among the first intervals is not flagged).
    pub fn without_hold() -> Self {
        TimeTracker {
            hold: false,
            ..Self::default()
        }
    }

    /// Nominal period known in advance (from the stream's declared rate): nothing held.
    pub fn with_rate_hz(rate_hz: f64) -> Self {
        let mut t = Self::default();
        if rate_hz > 0.0 && rate_hz.is_finite() {
            t.period_ns = 1e9 / rate_hz;
            t.hold = false;
        }
        t
    }

    /// The nominal rate, Hz, once known.
    pub fn rate_hz(&self) -> Option<f64> {
        (self.period_ns > 0.0).then(|| 1e9 / self.period_ns)
    }

    /// Samples tracked while holding, not judged yet: the caller holds them.
    #[inline]
    pub fn holding(&self) -> usize {
        self.held
    }

    /// The held samples are to be judged now ([`Self::judge`] on each, in order, then
    /// [`Self::judged`]).
    #[inline]
    pub fn window_done(&self) -> bool {
        self.window_done
    }

    /// The held samples have been judged.
    pub fn judged(&mut self) {
        self.held = 0;
        self.window_done = false;
    }

    /// No more samples will come for the held ones (end of input), or too much is held
    /// ([`HOLD_ITEMS`], then `stop`: nothing is held after): judge them with what is known,
    /// the rule of a stream too short to learn from (no period unless learned).
    pub fn end_hold(&mut self, stop: bool) {
        if self.held > 0 {
            self.window_done = true;
        }
        if stop && self.hold {
            // Learned from as they are judged, as if nothing had been held.
            self.hold = false;
            self.learn.clear();
        }
    }

    /// Set `s.seq` and the time-fault flags; count them. While the period is being learned
    /// (and samples are held), the sample's interval is only learned from: its sequence
    /// number and flags are set by [`Self::judge`] once the period is known.
    #[inline]
    pub fn track(&mut self, s: &mut Sample, stats: &mut DecoderStats) {
        if !self.hold || self.period_ns > 0.0 {
            self.judge(s, stats);
            return;
        }
        let t = s.t_ns;
        if let Some(prev) = self.hold_last
            && t > prev
        {
            self.learn.push(t - prev);
        }
        self.hold_last = Some(t);
        self.held += 1;
        if self.learn.len() >= LEARN_INTERVALS || self.held >= HOLD_SAMPLES {
            let mut v = std::mem::take(&mut self.learn);
            if !v.is_empty() {
                v.sort_unstable();
                self.period_ns = v[v.len() / 2] as f64;
            }
            // Held once: without a positive interval (one time stamp repeated) the period is
            // learned from the next intervals as they are judged.
            self.hold = false;
            self.window_done = true;
        }
    }

    /// Judge `s` against the last sample judged: sequence number and time-fault flags (the
    /// period learned here, from intervals as they come, if it is not known yet).
    pub fn judge(&mut self, s: &mut Sample, stats: &mut DecoderStats) {
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
        if self.period_ns <= 0.0 && !self.hold {
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
        // Without a hold (as before): the period from the first 15 intervals, judged as they
        // come, so a gap among them (interval 3 here, 12 ms) is not flagged.
        let mut tr = TimeTracker::without_hold();
        let mut st = DecoderStats::default();
        let ts: Vec<u64> = (0..20u64).map(|i| if i >= 3 { i + 2 } else { i }).collect();
        for &i in &ts {
            let mut x = s(i * 4_000_000);
            tr.track(&mut x, &mut st);
            assert!(!x.has(flags::GAP));
        }
        assert_eq!(tr.rate_hz(), Some(250.0));
        assert_eq!(tr.holding(), 0);
        let mut x = s(21 * 4_000_000 + 12_000_000);
        tr.track(&mut x, &mut st);
        assert!(x.has(flags::GAP));
        assert_eq!(st.missing_frames, 2);
    }

    #[test]
    fn time_tracker_holds_the_first_samples_and_judges_them_with_the_learned_period() {
        // 250 Hz, 2 samples missing before the 4th (interval 3: 12 ms).
        let ts: Vec<u64> = (0..20u64).map(|i| if i >= 3 { i + 2 } else { i }).collect();
        let mut tr = TimeTracker::new();
        let mut st = DecoderStats::default();
        let mut held = Vec::new();
        for (k, &i) in ts.iter().enumerate() {
            let mut x = s(i * 4_000_000);
            tr.track(&mut x, &mut st);
            if k < HOLD_SAMPLES {
                // Held: not judged yet, nothing counted.
                assert_eq!(tr.holding(), k + 1);
                assert_eq!(tr.window_done(), k + 1 == HOLD_SAMPLES);
                assert_eq!((x.seq, x.flags, st.gaps), (0, 0, 0));
                held.push(x);
                if tr.window_done() {
                    assert_eq!(tr.rate_hz(), Some(250.0));
                    for h in held.iter_mut() {
                        tr.judge(h, &mut st);
                    }
                    tr.judged();
                }
            } else {
                // Judged as it comes.
                assert_eq!(tr.holding(), 0);
                assert_eq!(x.seq as u64, i);
                held.push(x);
            }
        }
        let seqs: Vec<u64> = held.iter().map(|x| x.seq as u64).collect();
        assert_eq!(seqs, ts, "the sequence counts the missing samples");
        let gaps: Vec<usize> = (0..held.len())
            .filter(|&k| held[k].has(flags::GAP))
            .collect();
        assert_eq!(gaps, vec![3]);
        assert_eq!((st.gaps, st.missing_frames), (1, 2));
    }

    #[test]
    fn time_tracker_learns_from_fewer_intervals_when_the_first_samples_repeat() {
        // 16 samples, 4 of them repeating the time before: 11 positive intervals of 10 ms and
        // one of 30 ms (2 missing), learned on the 16th sample (the hold is at most 16).
        let ms = [
            0, 10, 10, 20, 30, 30, 60, 70, 80, 80, 90, 100, 110, 110, 120, 130,
        ];
        let mut tr = TimeTracker::new();
        let mut st = DecoderStats::default();
        let mut v: Vec<Sample> = ms.iter().map(|m| s(m * 1_000_000)).collect();
        for x in v.iter_mut() {
            tr.track(x, &mut st);
        }
        assert!(tr.window_done());
        assert_eq!(tr.rate_hz(), Some(100.0));
        for x in v.iter_mut() {
            tr.judge(x, &mut st);
        }
        tr.judged();
        let seqs: Vec<u32> = v.iter().map(|x| x.seq).collect();
        assert_eq!(seqs, [0, 1, 1, 2, 3, 3, 6, 7, 8, 8, 9, 10, 11, 11, 12, 13]);
        assert_eq!((st.gaps, st.missing_frames, st.duplicates), (1, 2, 4));
        // One time stamp 16 times: no period, judged without one; nothing held after.
        let mut tr = TimeTracker::new();
        let mut st = DecoderStats::default();
        let mut v = vec![s(5); HOLD_SAMPLES];
        for x in v.iter_mut() {
            tr.track(x, &mut st);
        }
        assert!(tr.window_done() && tr.rate_hz().is_none());
        for x in v.iter_mut() {
            tr.judge(x, &mut st);
        }
        tr.judged();
        assert_eq!(st.duplicates, HOLD_SAMPLES as u64 - 1);
        let mut x = s(10);
        tr.track(&mut x, &mut st);
        assert_eq!((tr.holding(), x.seq), (0, 1));
    }
}
