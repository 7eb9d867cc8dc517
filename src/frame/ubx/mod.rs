//! u-blox UBX: IMU samples from UBX-ESF-RAW (class 0x10, id 0x03) and UBX-ESF-MEAS (0x10 0x02),
//! as dead-reckoning receivers (NEO-M8U, ZED-F9R, …) send them; NMEA sentences, RTCM 3 frames
//! and every other UBX message on the same port are counted and passed through whole.
//!
//! Message layouts, data types and scale factors: [`esf`]; the port's framing rules: [`port`].
//!
//! One sample is the set of blocks with the same time tag: ESF-RAW packs several sets
//! per message (each block carries its own 24-bit sensor time tag), ESF-MEAS sends one time tag
//! per message, or gyro and accel of one time tag in two messages (ZED-F9R) which are joined
//! here. A channel no set of the stream has carried yet is absent ([`Sample::absent`]: a
//! gyro-only or accel-only sensor, or an export of one, sends no data words for it). A set
//! missing an axis the stream has carried before still becomes a sample, with that channel NaN
//! (flagged non-finite, counted as partial).
//!
//! Time: the time tags are counters of `tag_bits` bits and `tick_us` per count (configurable;
//! the defaults are an assumption to check against the receiver's manual: ESF-RAW 24 bits of
//! 39.0625 µs, ESF-MEAS 32 bits of 1 ms); they are unwrapped into a continuous ns time. Sequence
//! numbers and gap/duplicate flags come from that time ([`crate::frame::TimeTracker`]).
//!
//! Written by hand rather than with the `ublox` crate: the framing is a few lines, the crate's
//! ESF-MEAS value conversion drops the sign of the 24-bit field, and inline output needs the
//! exact bytes of every message, which a typed parser does not keep.

pub mod esf;
pub mod port;

pub use esf::*;
pub use port::{MAX_PAYLOAD, SYNC};

use super::Descriptor;
use super::framing::{Framer, Front, Stamper};
use super::protocol::{Carrier, Decoded, Protocol, ProtocolDecoder, mark_absent};
use crate::sample::Sample;
use bytes::{Bytes, BytesMut};
use std::collections::VecDeque;

/// Time-tag settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct UbxOptions {
    /// ESF-RAW sensor time tag: one count, µs.
    pub raw_tick_us: f64,
    /// ESF-RAW sensor time tag width, bits (it wraps at 2^bits).
    pub raw_tag_bits: u8,
    /// ESF-MEAS time tag: one count, µs.
    pub meas_tick_us: f64,
    /// ESF-MEAS time tag width, bits.
    pub meas_tag_bits: u8,
    /// Nominal IMU rate, Hz (0 = learn it from the first time tags).
    pub rate_hz: f64,
}

impl Default for UbxOptions {
    fn default() -> Self {
        UbxOptions {
            raw_tick_us: 39.0625,
            raw_tag_bits: 24,
            meas_tick_us: 1000.0,
            meas_tag_bits: 32,
            rate_hz: 0.0,
        }
    }
}

/// A wrapping counter of `bits` bits unwrapped into continuous ns. A step of more than half the
/// counter's range is taken as a step backwards.
#[derive(Clone, Debug)]
struct TagClock {
    mask: u64,
    tick_ns: f64,
    last: Option<u64>,
    ticks: i64,
}

impl TagClock {
    fn new(bits: u8, tick_us: f64) -> Self {
        let bits = bits.clamp(1, 32);
        TagClock {
            mask: (1u64 << bits) - 1,
            tick_ns: tick_us * 1e3,
            last: None,
            ticks: 0,
        }
    }
    fn t_ns(&mut self, tag: u32) -> u64 {
        let tag = tag as u64 & self.mask;
        if let Some(last) = self.last {
            let d = tag.wrapping_sub(last) & self.mask;
            if d <= self.mask / 2 {
                self.ticks += d as i64;
            } else {
                self.ticks -= (self.mask + 1 - d) as i64;
            }
        } else {
            // Start at the tag itself so a file's first time reads like the receiver's.
            self.ticks = tag as i64;
        }
        self.last = Some(tag);
        round_ns(self.ticks.max(0) as f64 * self.tick_ns)
    }
}

/// `x.round() as u64` (half away from zero, saturating, NaN → 0) without `f64::round`, which
/// is a libm call on x86-64 without SSE4.1 (a few % of the decode time, once per sample). For
/// x ≥ 0 the fraction `x - trunc(x)` is exact; below 0 both give 0.
#[inline]
fn round_ns(x: f64) -> u64 {
    let t = x as u64;
    if x - t as f64 >= 0.5 {
        t.saturating_add(1)
    } else {
        t
    }
}

/// The ESF-RAW message whose samples are being handed out, one per decode call, straight to
/// the caller (not through the queue: a sample with its carrier is a few hundred bytes, and
/// each move through the queue was a copy).
#[derive(Clone, Debug)]
struct RawMsg {
    frame: Bytes,
    /// Next block to read.
    block: usize,
    /// Index of the next sample among the message's `slots`.
    slot: u16,
    slots: u16,
}

/// Values of one time tag being assembled: channels and temperature; `None` = not yet seen.
#[derive(Clone, Debug)]
struct Partial {
    tag: u32,
    vals: [Option<f64>; 7],
    carrier: Carrier,
    between: Vec<u8>,
}

impl Partial {
    fn complete(&self) -> bool {
        self.vals[..6].iter().all(Option::is_some)
    }
}

/// Decoder for a UBX port (UBX + NMEA + RTCM 3 interleaved).
pub struct UbxDecoder {
    #[allow(dead_code)] // kept for the summary and for re-creating the decoder
    opts: UbxOptions,
    f: Framer,
    stamper: Stamper,
    raw_clock: TagClock,
    meas_clock: TagClock,
    ready: VecDeque<Decoded>,
    raw: Option<RawMsg>,
    meas_pending: Option<Partial>,
    raw_msgs: u64,
    meas_msgs: u64,
    /// Channels (bit `c`) some set of the stream has carried.
    seen: u8,
}

crate::frame::protocol::default_from_options!(UbxDecoder, UbxOptions);

impl UbxDecoder {
    pub fn new(opts: UbxOptions) -> Self {
        UbxDecoder {
            opts,
            f: Framer::default(),
            stamper: Stamper::new(opts.rate_hz),
            raw_clock: TagClock::new(opts.raw_tag_bits, opts.raw_tick_us),
            meas_clock: TagClock::new(opts.meas_tag_bits, opts.meas_tick_us),
            ready: VecDeque::new(),
            raw: None,
            meas_pending: None,
            raw_msgs: 0,
            meas_msgs: 0,
            seen: 0,
        }
    }

    fn other(&mut self, frame: Bytes) {
        self.f.count_other(&frame);
        match self.meas_pending.as_mut() {
            // Between the two halves of an ESF-MEAS sample: kept in the carrier, in order.
            Some(p) => p.between.extend_from_slice(&frame),
            None => self.ready.push_back(Decoded::Other(frame)),
        }
    }

    /// Finish a sample (its `t_ns` set) with the values of one time tag; the descriptor it
    /// made known, if any, is held for the next call ([`Stamper::finish`]).
    fn fill(&mut self, s: &mut Sample, vals: [Option<f64>; 7]) {
        let mut partial = false;
        for (c, val) in vals.iter().take(6).enumerate() {
            match val {
                Some(v) => {
                    self.seen |= 1 << c;
                    s.set_channel(c, *v);
                }
                // Missing after the stream carried it: a partial set (NaN, non-finite).
                None => {
                    partial |= self.seen & (1 << c) != 0;
                    s.set_channel(c, f64::NAN);
                }
            }
        }
        mark_absent(s, !self.seen);
        s.temp_c = vals[6];
        if partial {
            self.f.stats.partial_samples += 1;
        }
        self.stamper.finish(s, &mut self.f, Descriptor::default);
    }

    /// An ESF-MEAS sample into the queue (its pair's messages may follow it there); the
    /// descriptor learned on it goes right after it.
    fn emit(&mut self, tag_t_ns: u64, vals: [Option<f64>; 7], carrier: Carrier) {
        let mut s = Sample {
            t_ns: tag_t_ns,
            ..Sample::default()
        };
        self.fill(&mut s, vals);
        self.ready.push_back(Decoded::Sample(s, Some(carrier)));
        if let Some(d) = self.f.take_held() {
            self.ready.push_back(d);
        }
    }

    fn flush_meas(&mut self) {
        if let Some(p) = self.meas_pending.take() {
            let t = self.meas_clock.t_ns(p.tag);
            self.emit(t, p.vals, p.carrier);
            if !p.between.is_empty() {
                self.ready.push_back(Decoded::Other(Bytes::from(p.between)));
            }
        }
    }

    /// ESF-RAW: checked and counted here; its samples (blocks grouped by time tag) are handed
    /// out one per call by [`Self::next_raw`].
    fn esf_raw(&mut self, frame: Bytes) {
        let p = &frame[6..frame.len() - 2];
        if p.len() < 4 || !(p.len() - 4).is_multiple_of(8) {
            self.f.stats.bad_payload += 1;
            self.other(frame);
            return;
        }
        // Groups = blocks whose time tag differs from the block before (the first counts).
        let mut last = None;
        let slots = p[4..]
            .chunks_exact(8)
            .filter(|b| {
                let tag = Some([b[4], b[5], b[6], b[7]]);
                std::mem::replace(&mut last, tag) != tag
            })
            .count();
        if slots == 0 {
            // A raw message without blocks carries no sample: keep its bytes.
            self.other(frame);
            return;
        }
        self.raw_msgs += 1;
        self.f.stats.frames_ok += 1;
        self.raw = Some(RawMsg {
            frame,
            block: 0,
            slot: 0,
            slots: slots.min(u16::MAX as usize) as u16,
        });
    }

    /// The next sample of the ESF-RAW message being read: one group of blocks with the same
    /// time tag, each data word looked up in [`TYPES`]. The sample is made in the item that is
    /// returned (a sample with its carrier is a few hundred bytes; each move is a copy).
    fn next_raw(&mut self) -> Option<Decoded> {
        let m = self.raw.as_mut()?;
        let blocks = &m.frame[6 + 4 + 8 * m.block..m.frame.len() - 2];
        let word = |b: &[u8], o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        let tag = word(blocks, 4);
        let mut vals = [None; 7];
        let mut used = 0;
        for b in blocks.chunks_exact(8) {
            if word(b, 4) != tag {
                break;
            }
            let w = word(b, 0);
            let (k, lsb) = TYPES[(w >> 24) as usize];
            if k != NOT_IMU {
                vals[k as usize] = Some(value24(w) as f64 * lsb);
            }
            used += 1;
        }
        let (slot, slots) = (m.slot, m.slots);
        let frame = if 8 * used >= blocks.len() {
            // The message's last sample takes its bytes.
            self.raw.take().map(|m| m.frame)?
        } else {
            m.block += used;
            m.slot += 1;
            m.frame.clone()
        };
        let mut d = Decoded::Sample(
            Sample {
                t_ns: self.raw_clock.t_ns(tag),
                ..Sample::default()
            },
            Some(Carrier {
                frame,
                frame2: None,
                between: None,
                slot,
                slots,
                offsets: [0; 4],
                raw_scale: None,
            }),
        );
        if let Decoded::Sample(s, _) = &mut d {
            self.fill(s, vals);
        }
        Some(d)
    }

    /// ESF-MEAS: one time tag per message; gyro and accel may come in two messages.
    fn esf_meas(&mut self, frame: Bytes) {
        let p = &frame[6..frame.len() - 2];
        let Some((tag, words)) = meas_words(p) else {
            self.f.stats.bad_payload += 1;
            self.other(frame);
            return;
        };
        let mut vals = [None; 7];
        let mut any = false;
        for w in words {
            let ty = ((w >> 24) & 0x3f) as u8;
            if let (Some(k), Some(v)) = (slot_of(ty), physical(ty, value24(w))) {
                vals[k] = Some(v);
                any |= k < 6;
            }
        }
        if !any {
            // Wheel ticks, speed or other sensor data: not IMU, pass through.
            self.other(frame);
            return;
        }
        self.meas_msgs += 1;
        self.f.stats.frames_ok += 1;
        match self.meas_pending.take() {
            Some(mut prev) if prev.tag == tag && prev.carrier.frame2.is_none() => {
                for (k, v) in vals.iter().enumerate() {
                    if v.is_some() {
                        prev.vals[k] = *v;
                    }
                }
                prev.carrier.frame2 = Some(frame);
                if !prev.between.is_empty() {
                    prev.carrier.between = Some(Bytes::from(std::mem::take(&mut prev.between)));
                }
                let t = self.meas_clock.t_ns(prev.tag);
                self.emit(t, prev.vals, prev.carrier);
            }
            prev => {
                if let Some(p) = prev {
                    self.meas_pending = Some(p);
                    self.flush_meas();
                }
                let part = Partial {
                    between: Vec::new(),
                    tag,
                    vals,
                    carrier: Carrier {
                        frame,
                        frame2: None,
                        between: None,
                        slot: 0,
                        slots: 1,
                        offsets: [0; 4],
                        raw_scale: None,
                    },
                };
                if part.complete() {
                    let t = self.meas_clock.t_ns(tag);
                    self.emit(t, part.vals, part.carrier);
                } else {
                    self.meas_pending = Some(part);
                }
            }
        }
    }

    /// The next item from the bytes (before the hold of the first samples for the period).
    fn next_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        if let Some(d) = self.f.begin(buf) {
            return Some(d);
        }
        loop {
            if let Some(d) = self.ready.pop_front() {
                return Some(d);
            }
            if let Some(d) = self.next_raw() {
                return Some(d);
            }
            if buf.is_empty() || !self.step(buf) {
                return self.ready.pop_front();
            }
        }
    }

    /// At end of input: an ESF-MEAS half whose partner never came (a partial sample).
    fn held_back(&mut self) -> Option<Decoded> {
        self.flush_meas();
        self.ready.pop_front()
    }

    /// Find and handle one message at the front of `buf`; false = need more bytes.
    fn step(&mut self, buf: &mut BytesMut) -> bool {
        if !self.f.seek(buf, port::is_start) {
            return false;
        }
        match port::front(buf) {
            Front::Need(total) => {
                self.f.need(buf, total);
                false
            }
            Front::Bad(check) => {
                self.f.bad(buf, check);
                true
            }
            Front::Whole(n) => {
                let (class, id) = (buf[2], buf[3]);
                let is_ubx = buf[0] == SYNC[0];
                let frame = self.f.take(buf, n);
                match (is_ubx, class, id) {
                    (true, CLASS_ESF, ID_ESF_RAW) => self.esf_raw(frame),
                    (true, CLASS_ESF, ID_ESF_MEAS) => self.esf_meas(frame),
                    _ => self.other(frame),
                }
                true
            }
        }
    }
}

impl ProtocolDecoder for UbxDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Ubx
    }
    crate::frame::framing::decode_through_hold!();
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        // The front cannot complete: count it truncated and look for a message inside it.
        let start = buf.first().is_some_and(|&b| port::is_start(b));
        self.f.truncated_front(buf, start);
    }
    crate::frame::protocol::framer_stats_and_descriptor!();
    fn found(&self) -> String {
        format!(
            "UBX: {} ESF-RAW and {} ESF-MEAS messages with IMU data, {} other messages (UBX, NMEA, RTCM) passed through",
            self.raw_msgs, self.meas_msgs, self.f.stats.other_messages
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::DecoderStats;

    fn decode_all(bytes: &[u8], chunk: usize) -> (Vec<Decoded>, DecoderStats) {
        crate::frame::protocol::decode_chunked(&mut UbxDecoder::default(), bytes, chunk)
    }

    fn sample(i: u32) -> Sample {
        let mut s = Sample {
            temp_c: Some(31.25),
            ..Sample::default()
        };
        s.set_channels(&[0.01 * i as f64, -0.2, 0.3, 0.5, -1.0, 9.81]);
        s
    }

    #[test]
    fn esf_raw_groups_become_samples_with_nmea_between() {
        let mut b = BytesMut::new();
        b.extend_from_slice(b"$GNGGA,,,,,,0,00,99.99,,,,,,*56\r\n");
        encode_esf_raw(&[(1000, sample(0)), (1256, sample(1))], &mut b);
        b.extend_from_slice(b"$GNGGA,,,,,,0,00,99.99,,,,,,*56\r\n");
        for chunk in [1, 5, 1000] {
            let (out, st) = decode_all(&b, chunk);
            let samples: Vec<&Sample> = out.iter().filter_map(Decoded::sample).collect();
            assert_eq!(samples.len(), 2, "chunk {chunk}");
            assert_eq!(st.other_messages, 2);
            assert_eq!(st.garbage_bytes, 0);
            // 256 counts of 39.0625 µs = 10 ms.
            assert_eq!(samples[1].t_ns - samples[0].t_ns, 10_000_000);
            // gyro resolution 2^-12 deg/s: half a count is 2.1e-6 rad/s.
            assert!((samples[1].gyro[0] - 0.01).abs() < 2.2e-6);
            assert!((samples[0].accel[2] - 9.81).abs() <= 0.5 / 1024.0);
            assert_eq!(samples[0].temp_c, Some(31.25));
        }
    }

    #[test]
    fn raw_time_tag_wraps_at_24_bits() {
        let mut b = BytesMut::new();
        encode_esf_raw(&[(0xFF_FF00, sample(0))], &mut b);
        encode_esf_raw(&[(0x00_0000, sample(1))], &mut b);
        let (out, st) = decode_all(&b, 64);
        let t: Vec<u64> = out
            .iter()
            .filter_map(|d| match d {
                Decoded::Sample(s, _) => Some(s.t_ns),
                _ => None,
            })
            .collect();
        assert_eq!(
            t[1] - t[0],
            10_000_000,
            "256 counts of 39.0625 µs after the wrap"
        );
        assert_eq!(st.time_backwards, 0);
    }

    #[test]
    fn bad_checksum_loses_only_that_message() {
        let mut b = BytesMut::new();
        for i in 0..3 {
            encode_esf_raw(&[(i * 256, sample(i))], &mut b);
        }
        let len = b.len() / 3;
        b[len + 10] ^= 0x40;
        let (out, st) = decode_all(&b, 7);
        let n = out.iter().filter_map(Decoded::sample).count();
        assert_eq!(n, 2);
        assert_eq!(st.crc_errors, 1);
    }

    #[test]
    fn patch_writes_cleaned_values_and_keeps_the_rest() {
        let mut b = BytesMut::new();
        encode_esf_raw(&[(7, sample(3))], &mut b);
        let mut frame = b.to_vec();
        let mut s = sample(3);
        s.gyro[0] = 0.5;
        s.accel[1] = f64::NAN; // keeps the original field
        patch(&mut frame, 0, &s);
        finish(&mut frame);
        let (out, st) = decode_all(&frame, frame.len());
        assert_eq!(st.crc_errors, 0);
        let Decoded::Sample(got, _) = &out[0] else {
            panic!()
        };
        assert!((got.gyro[0] - 0.5).abs() < 2.2e-6);
        assert!((got.accel[1] + 1.0).abs() < 1e-3);
    }
}
