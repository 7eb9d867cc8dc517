//! u-blox UBX: IMU samples from UBX-ESF-RAW (class 0x10, id 0x03) and UBX-ESF-MEAS (0x10 0x02),
//! as dead-reckoning receivers (NEO-M8U, ZED-F9R, …) send them; NMEA sentences, RTCM 3 frames
//! and every other UBX message on the same port are counted and passed through whole.
//!
//! ```text
//! UBX frame: B5 62 | class | id | len u16 LE | payload (len) | CK_A CK_B
//!            checksum: 8-bit Fletcher over class..payload
//! ESF-RAW payload : reserved U4, then N blocks of { data X4, sTtag U4 }
//! ESF-MEAS payload: timeTag U4, flags X2 (numMeas = bits 11..15, calibTtagValid = bit 3), id U2,
//!                   numMeas × data X4, [calibTtag U4]
//! data X4         : bits 0..23 value (24-bit two's complement), bits 24..29 (MEAS) / 24..31 (RAW)
//!                   data type
//! ```
//!
//! Data types and scale factors (u-blox interface description, "sensor data types"): gyro
//! x/y/z = 14/13/5 in 2⁻¹² deg/s, accel x/y/z = 16/17/18 in 2⁻¹⁰ m/s², gyro temperature = 12 in
//! 10⁻² °C. One sample is the set of blocks with the same time tag: ESF-RAW packs several sets
//! per message (each block carries its own 24-bit sensor time tag), ESF-MEAS sends one time tag
//! per message, or gyro and accel of one time tag in two messages (ZED-F9R) which are joined
//! here. A set missing an axis still becomes a sample, with that channel NaN (flagged
//! non-finite, counted as partial).
//!
//! Time: the time tags are counters of `tag_bits` bits and `tick_us` per count (configurable;
//! the defaults are an assumption to check against the receiver's manual: ESF-RAW 24 bits of
//! 39.0625 µs, ESF-MEAS 32 bits of 1 ms); they are unwrapped into a continuous ns time. Sequence
//! numbers and gap/duplicate flags come from that time ([`TimeTracker`]).
//!
//! Written by hand rather than with the `ublox` crate: the framing is a few lines, the crate's
//! ESF-MEAS value conversion drops the sign of the 24-bit field, and inline output needs the
//! exact bytes of every message, which a typed parser does not keep.

use super::protocol::{Carrier, Decoded, Protocol, ProtocolDecoder, TimeTracker, flag_values};
use super::{DecoderStats, Descriptor};
use crate::sample::Sample;
use bytes::{Buf, Bytes, BytesMut};
use crc::{CRC_24_LTE_A, Crc};
use std::collections::VecDeque;

/// The two UBX sync bytes.
pub const SYNC: [u8; 2] = [0xB5, 0x62];
/// UBX class of the external-sensor-fusion messages.
pub const CLASS_ESF: u8 = 0x10;
pub const ID_ESF_MEAS: u8 = 0x02;
pub const ID_ESF_RAW: u8 = 0x03;
/// Largest UBX payload accepted; longer lengths are taken as corrupt (the receivers' largest
/// messages are a few kB).
pub const MAX_PAYLOAD: usize = 8192;
/// Longest NMEA sentence accepted (the standard says 82 characters; some talkers exceed it).
const MAX_NMEA: usize = 160;

/// Data types (bits 24.. of a data word).
pub const TYPE_GYRO_X: u8 = 14;
pub const TYPE_GYRO_Y: u8 = 13;
pub const TYPE_GYRO_Z: u8 = 5;
pub const TYPE_GYRO_TEMP: u8 = 12;
pub const TYPE_ACCEL_X: u8 = 16;
pub const TYPE_ACCEL_Y: u8 = 17;
pub const TYPE_ACCEL_Z: u8 = 18;
/// Data type of channel `c` (gx gy gz ax ay az).
pub const CHANNEL_TYPES: [u8; 6] = [
    TYPE_GYRO_X,
    TYPE_GYRO_Y,
    TYPE_GYRO_Z,
    TYPE_ACCEL_X,
    TYPE_ACCEL_Y,
    TYPE_ACCEL_Z,
];

/// One count of a gyro value, deg/s.
pub const GYRO_LSB_DEG_S: f64 = 1.0 / 4096.0;
/// One count of an accel value, m/s².
pub const ACCEL_LSB_M_S2: f64 = 1.0 / 1024.0;
/// One count of the gyro temperature, °C.
pub const TEMP_LSB_C: f64 = 0.01;

const CRC24Q: Crc<u32> = Crc::<u32>::new(&CRC_24_LTE_A);

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

/// 8-bit Fletcher checksum over `bytes` (UBX: class, id, length and payload).
pub fn checksum(bytes: &[u8]) -> [u8; 2] {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    [a, b]
}

/// Sign-extend the 24-bit value field of a data word.
#[inline]
pub fn value24(word: u32) -> i32 {
    ((word << 8) as i32) >> 8
}

/// Physical value of a data word's field for a data type, in imuprep units (gyro rad/s, accel
/// m/s², temperature °C); `None` for types that are not IMU data.
#[inline]
pub fn physical(ty: u8, raw: i32) -> Option<f64> {
    let v = raw as f64;
    match ty {
        TYPE_GYRO_X | TYPE_GYRO_Y | TYPE_GYRO_Z => Some((v * GYRO_LSB_DEG_S).to_radians()),
        TYPE_ACCEL_X | TYPE_ACCEL_Y | TYPE_ACCEL_Z => Some(v * ACCEL_LSB_M_S2),
        TYPE_GYRO_TEMP => Some(v * TEMP_LSB_C),
        _ => None,
    }
}

/// Inverse of [`physical`]: the 24-bit field for a value, rounded to the protocol's resolution
/// and clamped to the field's range; `None` when the value is not finite.
pub fn raw_of(ty: u8, v: f64) -> Option<i32> {
    if !v.is_finite() {
        return None;
    }
    let counts = match ty {
        TYPE_GYRO_X | TYPE_GYRO_Y | TYPE_GYRO_Z => v.to_degrees() / GYRO_LSB_DEG_S,
        TYPE_ACCEL_X | TYPE_ACCEL_Y | TYPE_ACCEL_Z => v / ACCEL_LSB_M_S2,
        TYPE_GYRO_TEMP => v / TEMP_LSB_C,
        _ => return None,
    };
    Some(counts.round().clamp(-8_388_608.0, 8_388_607.0) as i32)
}

/// Which channel (0..6) a data type fills, 6 for the temperature.
#[inline]
fn slot_of(ty: u8) -> Option<usize> {
    match ty {
        TYPE_GYRO_X => Some(0),
        TYPE_GYRO_Y => Some(1),
        TYPE_GYRO_Z => Some(2),
        TYPE_ACCEL_X => Some(3),
        TYPE_ACCEL_Y => Some(4),
        TYPE_ACCEL_Z => Some(5),
        TYPE_GYRO_TEMP => Some(6),
        _ => None,
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
        (self.ticks.max(0) as f64 * self.tick_ns).round() as u64
    }
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
    stats: DecoderStats,
    tracker: TimeTracker,
    raw_clock: TagClock,
    meas_clock: TagClock,
    ready: VecDeque<Decoded>,
    meas_pending: Option<Partial>,
    descriptor: Option<Descriptor>,
    described: bool,
    counted: usize,
    in_garbage: bool,
    raw_msgs: u64,
    meas_msgs: u64,
}

impl Default for UbxDecoder {
    fn default() -> Self {
        Self::new(UbxOptions::default())
    }
}

impl UbxDecoder {
    pub fn new(opts: UbxOptions) -> Self {
        UbxDecoder {
            opts,
            stats: DecoderStats::default(),
            tracker: TimeTracker::with_rate_hz(opts.rate_hz),
            raw_clock: TagClock::new(opts.raw_tag_bits, opts.raw_tick_us),
            meas_clock: TagClock::new(opts.meas_tag_bits, opts.meas_tick_us),
            ready: VecDeque::new(),
            meas_pending: None,
            descriptor: None,
            described: false,
            counted: 0,
            in_garbage: false,
            raw_msgs: 0,
            meas_msgs: 0,
        }
    }

    fn count_input(&mut self, buf: &BytesMut) {
        if buf.len() > self.counted {
            self.stats.bytes_in += (buf.len() - self.counted) as u64;
        }
        self.counted = buf.len();
    }

    fn take(&mut self, buf: &mut BytesMut, n: usize) -> Bytes {
        self.counted = self.counted.saturating_sub(n);
        buf.split_to(n).freeze()
    }

    fn garbage(&mut self, buf: &mut BytesMut, n: usize) {
        buf.advance(n);
        self.counted = self.counted.saturating_sub(n);
        self.stats.garbage_bytes += n as u64;
        if !self.in_garbage {
            self.stats.resyncs += 1;
            self.in_garbage = true;
        }
    }

    /// After a fault at a message start: step one byte and search again.
    fn fault(&mut self, buf: &mut BytesMut) {
        buf.advance(1);
        self.counted = self.counted.saturating_sub(1);
        self.stats.garbage_bytes += 1;
        self.stats.resyncs += 1;
        self.in_garbage = true;
    }

    fn other(&mut self, frame: Bytes) {
        self.stats.frames_ok += 1;
        self.stats.other_messages += 1;
        self.stats.other_bytes += frame.len() as u64;
        match self.meas_pending.as_mut() {
            // Between the two halves of an ESF-MEAS sample: kept in the carrier, in order.
            Some(p) => p.between.extend_from_slice(&frame),
            None => self.ready.push_back(Decoded::Other(frame)),
        }
    }

    fn emit(&mut self, tag_t_ns: u64, vals: [Option<f64>; 7], carrier: Carrier) {
        let mut s = Sample {
            t_ns: tag_t_ns,
            ..Sample::default()
        };
        let mut partial = false;
        for (c, val) in vals.iter().take(6).enumerate() {
            let v = val.unwrap_or_else(|| {
                partial = true;
                f64::NAN
            });
            s.set_channel(c, v);
        }
        s.temp_c = vals[6];
        if partial {
            self.stats.partial_samples += 1;
        }
        self.tracker.track(&mut s, &mut self.stats);
        if !self.described
            && let Some(r) = self.tracker.rate_hz()
        {
            self.described = true;
            let d = Descriptor {
                sample_rate_hz: r,
                ..Descriptor::default()
            };
            self.descriptor = Some(d);
            self.stats.descriptors += 1;
            self.ready.push_back(Decoded::Descriptor(d));
        }
        flag_values(&mut s, self.descriptor.as_ref(), &mut self.stats);
        self.stats.samples += 1;
        self.ready.push_back(Decoded::Sample(s, Some(carrier)));
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

    /// ESF-RAW: blocks grouped by time tag, one sample per group.
    fn esf_raw(&mut self, frame: Bytes) {
        let p = &frame[6..frame.len() - 2];
        if p.len() < 4 || !(p.len() - 4).is_multiple_of(8) {
            self.stats.bad_payload += 1;
            self.other(frame);
            return;
        }
        self.raw_msgs += 1;
        self.stats.frames_ok += 1;
        let groups = raw_groups(p);
        let slots = groups.len() as u16;
        for (i, (tag, range)) in groups.into_iter().enumerate() {
            let mut vals = [None; 7];
            for b in range {
                let o = 4 + 8 * b;
                let word = u32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]]);
                let ty = (word >> 24) as u8;
                if let (Some(k), Some(v)) = (slot_of(ty), physical(ty, value24(word))) {
                    vals[k] = Some(v);
                }
            }
            let t = self.raw_clock.t_ns(tag);
            let carrier = Carrier {
                frame: frame.clone(),
                frame2: None,
                between: None,
                slot: i as u16,
                slots,
                offsets: [0; 4],
                raw_scale: None,
            };
            self.emit(t, vals, carrier);
        }
        if slots == 0 {
            // A raw message without blocks carries no sample: keep its bytes.
            self.stats.frames_ok -= 1;
            self.other(frame);
        }
    }

    /// ESF-MEAS: one time tag per message; gyro and accel may come in two messages.
    fn esf_meas(&mut self, frame: Bytes) {
        let p = &frame[6..frame.len() - 2];
        let Some((tag, words)) = meas_words(p) else {
            self.stats.bad_payload += 1;
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
        self.stats.frames_ok += 1;
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

    /// Find and handle one message at the front of `buf`; false = need more bytes.
    fn step(&mut self, buf: &mut BytesMut) -> bool {
        // Skip to the next possible message start.
        let start = buf
            .iter()
            .position(|&b| b == SYNC[0] || b == b'$' || b == b'!' || b == 0xD3);
        match start {
            None => {
                let n = buf.len();
                if n > 0 {
                    self.garbage(buf, n);
                }
                return false;
            }
            Some(p) if p > 0 => self.garbage(buf, p),
            _ => {}
        }
        match buf[0] {
            0xB5 => {
                if buf.len() < 2 {
                    return false;
                }
                if buf[1] != SYNC[1] {
                    self.fault(buf);
                    return true;
                }
                if buf.len() < 6 {
                    return false;
                }
                let len = u16::from_le_bytes([buf[4], buf[5]]) as usize;
                if len > MAX_PAYLOAD {
                    self.stats.bad_length += 1;
                    self.fault(buf);
                    return true;
                }
                let total = 6 + len + 2;
                if buf.len() < total {
                    buf.reserve(total - buf.len());
                    return false;
                }
                if checksum(&buf[2..6 + len]) != [buf[6 + len], buf[7 + len]] {
                    self.stats.crc_errors += 1;
                    self.fault(buf);
                    return true;
                }
                self.in_garbage = false;
                let (class, id) = (buf[2], buf[3]);
                let frame = self.take(buf, total);
                match (class, id) {
                    (CLASS_ESF, ID_ESF_RAW) => self.esf_raw(frame),
                    (CLASS_ESF, ID_ESF_MEAS) => self.esf_meas(frame),
                    _ => self.other(frame),
                }
                true
            }
            b'$' | b'!' => {
                // NMEA: printable characters up to "*HH\r\n", XOR checksum of the characters
                // between the start and the '*'.
                let lim = buf.len().min(MAX_NMEA);
                let Some(lf) = buf[..lim].iter().position(|&b| b == b'\n') else {
                    if buf.len() >= MAX_NMEA || buf[1..].iter().any(|b| !is_nmea_char(*b)) {
                        self.stats.header_errors += 1;
                        self.fault(buf);
                        return true;
                    }
                    return false;
                };
                if nmea_ok(&buf[..=lf]) {
                    self.in_garbage = false;
                    let frame = self.take(buf, lf + 1);
                    self.other(frame);
                } else {
                    self.stats.crc_errors += 1;
                    self.fault(buf);
                }
                true
            }
            _ => {
                // RTCM 3: D3, 6 zero bits + 10-bit length, payload, CRC-24Q.
                if buf.len() < 3 {
                    return false;
                }
                if buf[1] & 0xFC != 0 {
                    self.fault(buf);
                    return true;
                }
                let len = (((buf[1] & 0x03) as usize) << 8) | buf[2] as usize;
                let total = 3 + len + 3;
                if buf.len() < total {
                    return false;
                }
                let crc = ((buf[3 + len] as u32) << 16)
                    | ((buf[4 + len] as u32) << 8)
                    | buf[5 + len] as u32;
                if CRC24Q.checksum(&buf[..3 + len]) != crc {
                    self.stats.crc_errors += 1;
                    self.fault(buf);
                    return true;
                }
                self.in_garbage = false;
                let frame = self.take(buf, total);
                self.other(frame);
                true
            }
        }
    }
}

fn is_nmea_char(b: u8) -> bool {
    (0x20..0x7f).contains(&b) || b == b'\r' || b == b'\n'
}

/// A complete NMEA line (start to '\n') with a valid "*HH" checksum.
fn nmea_ok(line: &[u8]) -> bool {
    if line.len() < 6 || line[line.len() - 2] != b'\r' {
        return false;
    }
    let body = &line[1..line.len() - 2];
    let Some(star) = body.iter().rposition(|&b| b == b'*') else {
        return false;
    };
    if star + 3 != body.len() || body.iter().any(|b| !is_nmea_char(*b)) {
        return false;
    }
    let x = body[..star].iter().fold(0u8, |a, b| a ^ b);
    let hex = std::str::from_utf8(&body[star + 1..])
        .ok()
        .and_then(|h| u8::from_str_radix(h, 16).ok());
    hex == Some(x)
}

/// ESF-RAW payload → (time tag, block index range) per group of consecutive equal tags.
fn raw_groups(p: &[u8]) -> Vec<(u32, std::ops::Range<usize>)> {
    let n = (p.len() - 4) / 8;
    let mut out: Vec<(u32, std::ops::Range<usize>)> = Vec::new();
    for b in 0..n {
        let o = 4 + 8 * b + 4;
        let tag = u32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]]);
        match out.last_mut() {
            Some((t, r)) if *t == tag => r.end = b + 1,
            _ => out.push((tag, b..b + 1)),
        }
    }
    out
}

/// ESF-MEAS payload → (time tag, data words), or `None` when the length does not match numMeas.
fn meas_words(p: &[u8]) -> Option<(u32, impl Iterator<Item = u32> + '_)> {
    if p.len() < 8 {
        return None;
    }
    let tag = u32::from_le_bytes([p[0], p[1], p[2], p[3]]);
    let flags = u16::from_le_bytes([p[4], p[5]]);
    let n = (flags >> 11) as usize;
    let calib = flags & 0x08 != 0;
    if p.len() != 8 + 4 * n + if calib { 4 } else { 0 } {
        return None;
    }
    Some((
        tag,
        (0..n).map(move |i| {
            let o = 8 + 4 * i;
            u32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
        }),
    ))
}

impl ProtocolDecoder for UbxDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Ubx
    }
    fn decode_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        self.count_input(buf);
        loop {
            if let Some(d) = self.ready.pop_front() {
                return Some(d);
            }
            if buf.is_empty() || !self.step(buf) {
                return self.ready.pop_front();
            }
        }
    }
    fn decode_item_eof(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        if let Some(d) = self.decode_item(buf) {
            return Some(d);
        }
        if !buf.is_empty() {
            self.discard_tail(buf);
            if let Some(d) = self.decode_item(buf) {
                return Some(d);
            }
        }
        self.flush_meas();
        self.ready.pop_front()
    }
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        // The front cannot complete: count it truncated and look for a message inside it.
        if !buf.is_empty() {
            if matches!(buf[0], 0xB5 | b'$' | b'!' | 0xD3) {
                self.stats.truncated += 1;
            }
            self.fault(buf);
        }
    }
    fn stats(&self) -> DecoderStats {
        self.stats
    }
    fn descriptor(&self) -> Option<Descriptor> {
        self.descriptor
    }
    fn found(&self) -> String {
        format!(
            "UBX: {} ESF-RAW and {} ESF-MEAS messages with IMU data, {} other messages (UBX, NMEA, RTCM) passed through",
            self.raw_msgs, self.meas_msgs, self.stats.other_messages
        )
    }
}

/// Write the cleaned values of `s` into its slot of a copy of the carrier frame(s): gyro,
/// accel and temperature fields at the protocol's resolution; a non-finite cleaned value keeps
/// the original field. The checksum is fixed by [`finish`].
pub fn patch(frame: &mut [u8], slot: u16, s: &Sample) {
    if frame.len() < 8 || frame[2] != CLASS_ESF {
        return;
    }
    let plen = frame.len() - 8;
    let ch = s.channels();
    let value = |ty: u8| -> Option<f64> {
        match slot_of(ty)? {
            6 => s.temp_c,
            k => Some(ch[k]),
        }
    };
    let put = |frame: &mut [u8], o: usize, ty_mask: u32| {
        let word = u32::from_le_bytes([frame[o], frame[o + 1], frame[o + 2], frame[o + 3]]);
        let ty = ((word >> 24) & ty_mask) as u8;
        if let Some(raw) = value(ty).and_then(|v| raw_of(ty, v)) {
            let w = (word & 0xFF00_0000) | (raw as u32 & 0x00FF_FFFF);
            frame[o..o + 4].copy_from_slice(&w.to_le_bytes());
        }
    };
    match frame[3] {
        ID_ESF_RAW if plen >= 4 && (plen - 4).is_multiple_of(8) => {
            let groups = raw_groups(&frame[6..6 + plen]);
            if let Some((_, r)) = groups.get(slot as usize) {
                for b in r.clone() {
                    put(frame, 6 + 4 + 8 * b, 0xFF);
                }
            }
        }
        ID_ESF_MEAS if plen >= 8 => {
            let flags = u16::from_le_bytes([frame[10], frame[11]]);
            let n = (flags >> 11) as usize;
            if 8 + 4 * n <= plen {
                for i in 0..n {
                    put(frame, 6 + 8 + 4 * i, 0x3F);
                }
            }
        }
        _ => {}
    }
}

/// Recompute the checksum of a UBX frame in place.
pub fn finish(frame: &mut [u8]) {
    let n = frame.len();
    if n >= 8 {
        let c = checksum(&frame[2..n - 2]);
        frame[n - 2..].copy_from_slice(&c);
    }
}

/// Append one UBX frame.
pub fn encode_frame(class: u8, id: u8, payload: &[u8], out: &mut BytesMut) {
    let start = out.len();
    out.extend_from_slice(&SYNC);
    out.extend_from_slice(&[class, id]);
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    out.extend_from_slice(payload);
    let c = checksum(&out[start + 2..]);
    out.extend_from_slice(&c);
}

/// Append an ESF-RAW message carrying `samples` (one time tag each; gyro x/y/z, accel x/y/z and
/// the temperature when present), as a receiver would send it.
pub fn encode_esf_raw(samples: &[(u32, Sample)], out: &mut BytesMut) {
    let mut p = vec![0u8; 4];
    for (tag, s) in samples {
        let ch = s.channels();
        let mut put = |ty: u8, v: f64| {
            if let Some(raw) = raw_of(ty, v) {
                let w = ((ty as u32) << 24) | (raw as u32 & 0x00FF_FFFF);
                p.extend_from_slice(&w.to_le_bytes());
                p.extend_from_slice(&(tag & 0x00FF_FFFF).to_le_bytes());
            }
        };
        for (c, ty) in CHANNEL_TYPES.iter().enumerate() {
            put(*ty, ch[c]);
        }
        if let Some(t) = s.temp_c {
            put(TYPE_GYRO_TEMP, t);
        }
    }
    encode_frame(CLASS_ESF, ID_ESF_RAW, &p, out);
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn sign_extension_and_scales() {
        assert_eq!(value24(0x00FF_FFFF), -1);
        assert_eq!(value24(0x0E80_0000), -8_388_608);
        assert_eq!(value24(0x107F_FFFF), 8_388_607);
        // 10091 counts of accel = 9.8545 m/s² (a real ZED-F9R z-axis reading at rest).
        assert!((physical(TYPE_ACCEL_Z, 10091).unwrap() - 10091.0 / 1024.0).abs() < 1e-12);
        assert_eq!(
            raw_of(TYPE_GYRO_X, physical(TYPE_GYRO_X, -5).unwrap()),
            Some(-5)
        );
    }

    #[test]
    fn esf_raw_groups_become_samples_with_nmea_between() {
        let mut b = BytesMut::new();
        b.extend_from_slice(b"$GNGGA,,,,,,0,00,99.99,,,,,,*56\r\n");
        encode_esf_raw(&[(1000, sample(0)), (1256, sample(1))], &mut b);
        b.extend_from_slice(b"$GNGGA,,,,,,0,00,99.99,,,,,,*56\r\n");
        for chunk in [1, 5, 1000] {
            let (out, st) = decode_all(&b, chunk);
            let samples: Vec<&Sample> = out
                .iter()
                .filter_map(|d| match d {
                    Decoded::Sample(s, _) => Some(s),
                    _ => None,
                })
                .collect();
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
        let n = out
            .iter()
            .filter(|d| matches!(d, Decoded::Sample(..)))
            .count();
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
