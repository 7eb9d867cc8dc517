//! MAVLink v1 and v2: IMU samples from HIGHRES_IMU (105), SCALED_IMU (26), SCALED_IMU2 (116),
//! SCALED_IMU3 (129) and RAW_IMU (27); every other message is counted and passed through whole.
//!
//! ```text
//! v1: FE | len | seq | sysid | compid | msgid u8  | payload | CRC-16/MCRF4XX LE
//! v2: FD | len | incompat | compat | seq | sysid | compid | msgid u24 LE | payload | CRC | [signature 13]
//! CRC over the bytes after the magic up to the payload end, then the message's CRC-extra byte.
//! v2 senders drop trailing zero bytes of the payload; they are restored before parsing.
//! ```
//!
//! Units as the common message set defines them: HIGHRES_IMU in m/s², rad/s, °C (f32);
//! SCALED_IMU* in mG, mrad/s, c°C (i16; temperature 0 = not provided); RAW_IMU in raw sensor
//! counts, scaled by `gyro_scale_rad_s` and `accel_scale_m_s2` from the configuration (the
//! temperature field in c°C). The instance is SCALED_IMU → 0, SCALED_IMU2 → 1, SCALED_IMU3 → 2,
//! and the `id` field of HIGHRES_IMU / RAW_IMU.
//!
//! HIGHRES_IMU's `fields_updated` says which fields a message carries (bits 0–2 accel x/y/z,
//! 3–5 gyro x/y/z, 12 temperature): a channel whose bit no message of the stream has set yet is
//! absent ([`Sample::absent`]; a gyro-only or accel-only sensor), never a value. Once set, a
//! clear bit means "not new since the last message" (senders update the sensors at different
//! rates) and the value is read as sent. A stream whose `fields_updated` is 0 (a sender that
//! does not fill it, or a v2 frame whose trailing zeros cut it off) has every field.
//!
//! Several systems, components, messages and instances may share a link: one IMU stream
//! (system id, component id, message, instance) is selected — by the options, or else the
//! first one seen — and the others pass through like any non-IMU message; the summary lists
//! every stream found. The checksum of every message is checked with its CRC-extra byte (table
//! of the ardupilotmega dialect, which includes common, in `mavlink_crc.rs`); a message id not in
//! that table is passed through unverified (counted) when the next byte starts a frame, and
//! taken as garbage otherwise. Signed v2 frames are accepted; the signature is not checked
//! (no key here).
//!
//! Written by hand rather than with the `mavlink` crate: five message layouts and a
//! checksum, while the crate generates every dialect message (≈ 20 s more cold build for the
//! common dialect alone) and parses into typed values, where pass-through needs the bytes.

use super::Descriptor;
use super::framing::{Fault, Framer, Stamper};
use super::mavlink_crc::CRC_EXTRA;
use super::protocol::{Carrier, Decoded, Protocol, ProtocolDecoder};
use super::settle::{self, Held, Settle};
use crate::sample::Sample;
use bytes::{Bytes, BytesMut};
use crc::{CRC_16_MCRF4XX, Crc, Table};

pub const STX_V1: u8 = 0xFE;
pub const STX_V2: u8 = 0xFD;
pub const MSG_HIGHRES_IMU: u32 = 105;
pub const MSG_SCALED_IMU: u32 = 26;
pub const MSG_SCALED_IMU2: u32 = 116;
pub const MSG_SCALED_IMU3: u32 = 129;
pub const MSG_RAW_IMU: u32 = 27;
/// Full payload lengths (with extensions) of the IMU messages.
const LEN_HIGHRES: usize = 63;
const LEN_SCALED: usize = 24;
const LEN_RAW: usize = 29;
/// v2 incompatibility flag: the frame is signed (13 bytes follow the checksum).
const IFLAG_SIGNED: u8 = 0x01;
const SIGNATURE_LEN: usize = 13;
/// A tlog's time stamp before each message, bytes.
const TLOG_STAMP: usize = 8;

fn is_stx(b: Option<u8>) -> bool {
    matches!(b, Some(STX_V1 | STX_V2))
}

/// A tlog record starts at the front: a big-endian µs time stamp between 2000 and 2100, then a
/// message start.
fn tlog_stamp_at(buf: &[u8]) -> bool {
    const Y2000_US: u64 = 946_684_800_000_000;
    const Y2100_US: u64 = 4_102_444_800_000_000;
    buf.len() > TLOG_STAMP
        && is_stx(Some(buf[TLOG_STAMP]))
        && (Y2000_US..Y2100_US).contains(&u64::from_be_bytes(
            buf[..TLOG_STAMP].try_into().expect("8 bytes"),
        ))
}
/// Standard gravity, m/s² per g (1 mG = 9.80665e-3 m/s²).
const MG_M_S2: f64 = 9.80665e-3;
/// HIGHRES_IMU `fields_updated` bit of channel `c` (gx gy gz ax ay az): gyro 3..6, accel 0..3.
const HIGHRES_CHANNEL_BITS: [u16; 6] = [1 << 3, 1 << 4, 1 << 5, 1 << 0, 1 << 1, 1 << 2];
/// HIGHRES_IMU `fields_updated` bit of the temperature.
const HIGHRES_TEMP_BIT: u16 = 1 << 12;
/// Bit of a seen-channels mask (above the six channels) for the temperature.
const TEMP_SEEN: u8 = 1 << 6;

/// Slice-by-16 tables (8 KiB): the byte-at-a-time table was three quarters of the decode time.
const X25: Crc<u16, Table<16>> = Crc::<u16, Table<16>>::new(&CRC_16_MCRF4XX);

/// CRC-extra byte of a message id, if the dialect table knows it.
pub fn crc_extra(msgid: u32) -> Option<u8> {
    CRC_EXTRA
        .binary_search_by_key(&msgid, |(id, _)| *id)
        .ok()
        .map(|i| CRC_EXTRA[i].1)
}

/// MAVLink frame checksum: CRC-16/MCRF4XX of `bytes` (after the magic, up to the payload end)
/// followed by the CRC-extra byte.
pub fn checksum(bytes: &[u8], extra: u8) -> u16 {
    let mut d = X25.digest();
    d.update(bytes);
    d.update(&[extra]);
    d.finalize()
}

/// Message names accepted in the options.
pub fn message_id(name: &str) -> Option<u32> {
    match name.to_ascii_lowercase().as_str() {
        "highres_imu" => Some(MSG_HIGHRES_IMU),
        "scaled_imu" => Some(MSG_SCALED_IMU),
        "scaled_imu2" => Some(MSG_SCALED_IMU2),
        "scaled_imu3" => Some(MSG_SCALED_IMU3),
        "raw_imu" => Some(MSG_RAW_IMU),
        _ => None,
    }
}

fn message_name(id: u32) -> &'static str {
    match id {
        MSG_HIGHRES_IMU => "HIGHRES_IMU",
        MSG_SCALED_IMU => "SCALED_IMU",
        MSG_SCALED_IMU2 => "SCALED_IMU2",
        MSG_SCALED_IMU3 => "SCALED_IMU3",
        MSG_RAW_IMU => "RAW_IMU",
        _ => "?",
    }
}

fn full_len(id: u32) -> Option<usize> {
    match id {
        MSG_HIGHRES_IMU => Some(LEN_HIGHRES),
        MSG_SCALED_IMU | MSG_SCALED_IMU2 | MSG_SCALED_IMU3 => Some(LEN_SCALED),
        MSG_RAW_IMU => Some(LEN_RAW),
        _ => None,
    }
}

/// Which IMU stream to take; `None` = the first one seen.
#[derive(Clone, Debug, PartialEq, Default, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct MavlinkOptions {
    pub sysid: Option<u8>,
    pub compid: Option<u8>,
    /// highres_imu, scaled_imu, scaled_imu2, scaled_imu3 or raw_imu.
    pub message: Option<String>,
    pub instance: Option<u8>,
    /// RAW_IMU gyro scale, rad/s per count (0 = RAW_IMU is not used).
    pub gyro_scale_rad_s: f64,
    /// RAW_IMU accel scale, m/s² per count (0 = RAW_IMU is not used).
    pub accel_scale_m_s2: f64,
    /// Nominal IMU rate, Hz (0 = learn it from the time stamps).
    pub rate_hz: f64,
}

/// One IMU stream on the link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct StreamKey {
    pub sysid: u8,
    pub compid: u8,
    pub msgid: u32,
    pub instance: u8,
}

/// A frame's header fields and payload (zero-extended to `full` bytes for IMU messages).
struct Frame<'a> {
    v2: bool,
    sysid: u8,
    compid: u8,
    msgid: u32,
    payload: &'a [u8],
}

fn parse_header(f: &[u8]) -> Option<Frame<'_>> {
    match *f.first()? {
        STX_V1 => Some(Frame {
            v2: false,
            sysid: f[3],
            compid: f[4],
            msgid: f[5] as u32,
            payload: &f[6..6 + f[1] as usize],
        }),
        STX_V2 => Some(Frame {
            v2: true,
            sysid: f[5],
            compid: f[6],
            msgid: u32::from_le_bytes([f[7], f[8], f[9], 0]),
            payload: &f[10..10 + f[1] as usize],
        }),
        _ => None,
    }
}

fn f32_at(p: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
}
fn i16_at(p: &[u8], o: usize) -> i16 {
    i16::from_le_bytes([p[o], p[o + 1]])
}

/// Decoder for a MAVLink link.
pub struct MavlinkDecoder {
    opts: MavlinkOptions,
    want_msg: Option<u32>,
    selected: Option<StreamKey>,
    streams: Vec<(StreamKey, u64)>,
    f: Framer,
    stamper: Stamper,
    eof: bool,
    v1: u64,
    v2: u64,
    /// HIGHRES_IMU `fields_updated` bits the selected stream has set so far.
    seen_fields: u16,
    /// The selected stream's first samples, held until its channel set is known.
    settle: Settle,
    /// A telemetry log (`.tlog` of QGroundControl, Mission Planner, MAVProxy): every message
    /// after an 8-byte big-endian time stamp (µs since 1970). Decided on the input's first
    /// bytes; `None` until 9 have come.
    tlog: Option<bool>,
    /// tlog time stamps read (not garbage).
    tlog_stamps: u64,
}

super::protocol::default_from_options!(MavlinkDecoder, MavlinkOptions);

impl MavlinkDecoder {
    pub fn new(opts: MavlinkOptions) -> Self {
        let want_msg = opts.message.as_deref().and_then(message_id);
        MavlinkDecoder {
            stamper: Stamper::new(opts.rate_hz),
            opts,
            want_msg,
            selected: None,
            streams: Vec::new(),
            f: Framer::default(),
            eof: false,
            v1: 0,
            v2: 0,
            seen_fields: 0,
            settle: Settle::default(),
            tlog: None,
            tlog_stamps: 0,
        }
    }

    /// Every IMU stream seen, with its message count.
    pub fn streams(&self) -> &[(StreamKey, u64)] {
        &self.streams
    }

    fn matches(&self, k: &StreamKey) -> bool {
        self.opts.sysid.is_none_or(|v| v == k.sysid)
            && self.opts.compid.is_none_or(|v| v == k.compid)
            && self.want_msg.is_none_or(|v| v == k.msgid)
            && self.opts.instance.is_none_or(|v| v == k.instance)
            && (k.msgid != MSG_RAW_IMU
                || (self.opts.gyro_scale_rad_s > 0.0 && self.opts.accel_scale_m_s2 > 0.0))
    }

    /// The sample an IMU frame carries (payload zero-extended), its stream, and the fields it
    /// has (HIGHRES_IMU `fields_updated`; every bit for the other messages and for 0).
    fn imu(&self, fr: &Frame) -> Option<(StreamKey, Sample, u16)> {
        let full = full_len(fr.msgid)?;
        let mut p = [0u8; LEN_HIGHRES];
        let n = fr.payload.len().min(full);
        p[..n].copy_from_slice(&fr.payload[..n]);
        let mut s = Sample::default();
        let instance;
        let mut fields = u16::MAX;
        match fr.msgid {
            MSG_HIGHRES_IMU => {
                s.t_ns = u64::from_le_bytes(p[0..8].try_into().ok()?).saturating_mul(1000);
                let v = |i: usize| f32_at(&p, 8 + 4 * i) as f64;
                s.set_channels(&[v(3), v(4), v(5), v(0), v(1), v(2)]);
                let t = f32_at(&p, 56);
                s.temp_c = t.is_finite().then_some(t as f64);
                fields = match u16::from_le_bytes([p[60], p[61]]) {
                    0 => u16::MAX,
                    f => f,
                };
                instance = p[62];
            }
            MSG_SCALED_IMU | MSG_SCALED_IMU2 | MSG_SCALED_IMU3 => {
                let ms = u32::from_le_bytes(p[0..4].try_into().ok()?);
                s.t_ns = ms as u64 * 1_000_000;
                let a = |o| i16_at(&p, o) as f64 * MG_M_S2;
                let g = |o| i16_at(&p, o) as f64 * 1e-3;
                s.set_channels(&[g(10), g(12), g(14), a(4), a(6), a(8)]);
                let t = i16_at(&p, 22);
                s.temp_c = (t != 0).then_some(t as f64 * 0.01);
                instance = match fr.msgid {
                    MSG_SCALED_IMU => 0,
                    MSG_SCALED_IMU2 => 1,
                    _ => 2,
                };
            }
            _ => {
                s.t_ns = u64::from_le_bytes(p[0..8].try_into().ok()?).saturating_mul(1000);
                let a = |o| i16_at(&p, o) as f64 * self.opts.accel_scale_m_s2;
                let g = |o| i16_at(&p, o) as f64 * self.opts.gyro_scale_rad_s;
                s.set_channels(&[g(14), g(16), g(18), a(8), a(10), a(12)]);
                let t = i16_at(&p, 27);
                s.temp_c = (t != 0).then_some(t as f64 * 0.01);
                instance = p[26];
            }
        }
        let key = StreamKey {
            sysid: fr.sysid,
            compid: fr.compid,
            msgid: fr.msgid,
            instance,
        };
        Some((key, s, fields))
    }

    /// Handle one good frame (checksum verified or unverifiable): its item, or `None` while
    /// the selected stream's first samples are held ([`Settle`]).
    fn frame(&mut self, frame: Bytes) -> Option<Decoded> {
        self.f.stats.frames_ok += 1;
        let Some(fr) = parse_header(&frame) else {
            return self.other(frame);
        };
        if fr.v2 {
            self.v2 += 1;
        } else {
            self.v1 += 1;
        }
        let Some((key, s, fields)) = self.imu(&fr) else {
            return self.other(frame);
        };
        match self.streams.iter_mut().find(|(k, _)| *k == key) {
            Some((_, n)) => *n += 1,
            None => self.streams.push((key, 1)),
        }
        if self.selected.is_none() && self.matches(&key) {
            self.selected = Some(key);
        }
        if self.selected != Some(key) {
            return self.other(frame);
        }
        self.seen_fields |= fields;
        let seen = self.seen_channels();
        let carrier = Carrier {
            frame,
            slots: 1,
            raw_scale: (key.msgid == MSG_RAW_IMU)
                .then_some([self.opts.gyro_scale_rad_s, self.opts.accel_scale_m_s2]),
            ..Carrier::default()
        };
        if self.settle.settled() {
            return Some(self.finish(s, seen, carrier));
        }
        self.settle.sample(s, seen, carrier);
        self.next_held()
    }

    /// Channels (bit `c`) whose `fields_updated` bit the selected stream has set so far, and
    /// [`TEMP_SEEN`] for the temperature's.
    fn seen_channels(&self) -> u8 {
        let temp = if self.seen_fields & HIGHRES_TEMP_BIT != 0 {
            TEMP_SEEN
        } else {
            0
        };
        HIGHRES_CHANNEL_BITS
            .iter()
            .enumerate()
            .filter(|(_, b)| self.seen_fields & **b != 0)
            .fold(temp, |m, (c, _)| m | 1 << c)
    }

    /// Finish a sample of the selected stream: its channels for the stream's channel set (the
    /// channels seen so far; `seen` = those seen by its own message), time, flags.
    fn finish(&mut self, mut s: Sample, seen: u8, carrier: Carrier) -> Decoded {
        if settle::channels(&mut s, self.seen_channels(), seen) {
            self.f.stats.partial_samples += 1;
        }
        if seen & TEMP_SEEN == 0 {
            s.temp_c = None;
        }
        let key = self.selected.unwrap_or_default();
        // A descriptor learned on a frame goes out right after that frame's sample.
        self.stamper.finish(&mut s, &mut self.f, || Descriptor {
            device_id: (key.sysid as u32) << 16 | (key.compid as u32) << 8 | key.instance as u32,
            ..Descriptor::default()
        });
        Decoded::Sample(s, Some(carrier))
    }

    /// The next held item, once the channel set is known.
    fn next_held(&mut self) -> Option<Decoded> {
        Some(match self.settle.release()? {
            Held::Item(d) => d,
            Held::Sample(s, seen, c) => self.finish(s, seen, c),
        })
    }

    fn other(&mut self, frame: Bytes) -> Option<Decoded> {
        self.f.stats.other_messages += 1;
        self.f.stats.other_bytes += frame.len() as u64;
        if self.selected.is_some() && !self.settle.settled() {
            // Between held samples: held too, so the order is kept.
            self.settle.item(Decoded::Other(frame));
            return self.next_held();
        }
        Some(Decoded::Other(frame))
    }

    /// The next item from the bytes (before the hold of the first samples for the period).
    fn next_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        self.f
            .begin(buf)
            .or_else(|| self.next_held())
            .or_else(|| self.step(buf))
    }

    /// Every byte decoded: what is still held for the channel set goes out with the channels
    /// seen so far.
    fn held_back(&mut self) -> Option<Decoded> {
        self.settle.settle();
        self.next_held()
    }

    /// In a tlog, the time stamp before the next message: read (and counted as such) when the
    /// front holds a plausible one with a message start after it. `false`: wait for more bytes.
    fn tlog_stamp(&mut self, buf: &mut BytesMut) -> bool {
        if self.tlog.is_none() {
            if buf.len() < TLOG_STAMP + 1 && !self.eof {
                return false;
            }
            self.tlog = Some(tlog_stamp_at(buf));
        }
        if self.tlog == Some(true) && !is_stx(buf.first().copied()) {
            if buf.len() < TLOG_STAMP + 1 && !self.eof {
                return false;
            }
            if tlog_stamp_at(buf) {
                self.f.take(buf, TLOG_STAMP);
                self.tlog_stamps += 1;
            }
        }
        true
    }

    /// One frame from the front of `buf`, or `None` when more bytes are needed.
    fn step(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        loop {
            if !self.tlog_stamp(buf) {
                return None;
            }
            if !self.f.seek(buf, |b| b == STX_V1 || b == STX_V2) || buf.len() < 2 {
                return None;
            }
            let v2 = buf[0] == STX_V2;
            let hdr = if v2 { 10 } else { 6 };
            if buf.len() < hdr {
                return None;
            }
            let len = buf[1] as usize;
            let signed = v2 && buf[2] & IFLAG_SIGNED != 0;
            if v2 && buf[2] & !IFLAG_SIGNED != 0 {
                // An incompatibility flag this decoder does not know: the frame cannot be read.
                self.f.bad(buf, Fault::UnknownType);
                continue;
            }
            let total = hdr + len + 2 + if signed { SIGNATURE_LEN } else { 0 };
            if buf.len() < total {
                self.f.need(buf, Some(total));
                return None;
            }
            let msgid = if v2 {
                u32::from_le_bytes([buf[7], buf[8], buf[9], 0])
            } else {
                buf[5] as u32
            };
            let crc = u16::from_le_bytes([buf[hdr + len], buf[hdr + len + 1]]);
            match crc_extra(msgid) {
                Some(extra) => {
                    if checksum(&buf[1..hdr + len], extra) != crc {
                        self.f.bad(buf, Fault::Crc);
                        continue;
                    }
                }
                None => {
                    // Unknown id: trust the frame only if another frame starts right after it
                    // (in a tlog, after its time stamp).
                    let next = total
                        + if self.tlog == Some(true) {
                            TLOG_STAMP
                        } else {
                            0
                        };
                    if buf.len() <= next && !self.eof {
                        return None;
                    }
                    if buf.len() > next && !is_stx(Some(buf[next])) {
                        self.f.bad(buf, Fault::UnknownType);
                        continue;
                    }
                    self.f.stats.unverified += 1;
                }
            }
            let frame = self.f.take(buf, total);
            if let Some(d) = self.frame(frame) {
                return Some(d);
            }
        }
    }
}

impl ProtocolDecoder for MavlinkDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Mavlink
    }
    super::framing::decode_through_hold!();
    fn end_of_input(&mut self) {
        // A frame with an unknown id at the very end is trusted without a frame after it.
        self.eof = true;
    }
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        let start = matches!(buf.first(), Some(&(STX_V1 | STX_V2)));
        self.f.truncated_front(buf, start);
    }
    super::protocol::framer_stats_and_descriptor!();
    fn found(&self) -> String {
        let mut s = format!(
            "MAVLink: {} v1 and {} v2 frames; IMU streams:",
            self.v1, self.v2
        );
        for (k, n) in &self.streams {
            s.push_str(&format!(
                " [sys {} comp {} {} instance {}: {} msgs{}]",
                k.sysid,
                k.compid,
                message_name(k.msgid),
                k.instance,
                n,
                if self.selected == Some(*k) {
                    ", selected"
                } else {
                    ""
                }
            ));
        }
        if self.streams.is_empty() {
            s.push_str(" none");
        }
        if self.tlog == Some(true) {
            s.push_str(&format!(
                "; a tlog: {} read before the messages",
                crate::text::count(self.tlog_stamps, "time stamp", "time stamps")
            ));
        }
        s
    }
}

/// Re-encode a carried IMU frame with the cleaned values of `s` (same message, ids, sequence
/// number and instance; the other fields unchanged). A signed v2 frame loses its signature
/// (the values changed, so it would no longer verify); the signed flag is cleared.
pub fn reencode(frame: &[u8], s: &Sample, gyro_scale: f64, accel_scale: f64, out: &mut BytesMut) {
    let Some(fr) = parse_header(frame) else {
        out.extend_from_slice(frame);
        return;
    };
    let Some(full) = full_len(fr.msgid) else {
        out.extend_from_slice(frame);
        return;
    };
    let mut p = [0u8; LEN_HIGHRES];
    let n = fr.payload.len().min(full);
    p[..n].copy_from_slice(&fr.payload[..n]);
    let ch = s.channels();
    let i16v = |v: f64, unit: f64, old: i16| -> i16 {
        if v.is_finite() && unit > 0.0 {
            (v / unit).round().clamp(i16::MIN as f64, i16::MAX as f64) as i16
        } else {
            old
        }
    };
    match fr.msgid {
        MSG_HIGHRES_IMU => {
            let order = [3, 4, 5, 0, 1, 2];
            for (i, c) in order.iter().enumerate() {
                if ch[*c].is_finite() {
                    p[8 + 4 * i..12 + 4 * i].copy_from_slice(&(ch[*c] as f32).to_le_bytes());
                }
            }
        }
        MSG_SCALED_IMU | MSG_SCALED_IMU2 | MSG_SCALED_IMU3 | MSG_RAW_IMU => {
            let (base_a, base_g, ua, ug) = if fr.msgid == MSG_RAW_IMU {
                (8, 14, accel_scale, gyro_scale)
            } else {
                (4, 10, MG_M_S2, 1e-3)
            };
            for i in 0..3 {
                let oa = base_a + 2 * i;
                let og = base_g + 2 * i;
                let a = i16v(ch[3 + i], ua, i16_at(&p, oa));
                let g = i16v(ch[i], ug, i16_at(&p, og));
                p[oa..oa + 2].copy_from_slice(&a.to_le_bytes());
                p[og..og + 2].copy_from_slice(&g.to_le_bytes());
            }
        }
        _ => {}
    }
    let mut plen = full;
    let start = out.len();
    if fr.v2 {
        // v2 senders drop trailing zeros (at least one byte stays).
        while plen > 1 && p[plen - 1] == 0 {
            plen -= 1;
        }
        out.extend_from_slice(&[STX_V2, plen as u8, frame[2] & !IFLAG_SIGNED]);
        out.extend_from_slice(&frame[3..10]);
    } else {
        out.extend_from_slice(&[STX_V1, plen as u8]);
        out.extend_from_slice(&frame[2..6]);
    }
    out.extend_from_slice(&p[..plen]);
    let c = checksum(&out[start + 1..], crc_extra(fr.msgid).unwrap_or(0));
    out.extend_from_slice(&c.to_le_bytes());
}

/// Append a v2 frame (unsigned), trailing payload zeros dropped.
pub fn encode_v2(seq: u8, sysid: u8, compid: u8, msgid: u32, payload: &[u8], out: &mut BytesMut) {
    let mut plen = payload.len();
    while plen > 1 && payload[plen - 1] == 0 {
        plen -= 1;
    }
    let start = out.len();
    out.extend_from_slice(&[STX_V2, plen as u8, 0, 0, seq, sysid, compid]);
    out.extend_from_slice(&msgid.to_le_bytes()[..3]);
    out.extend_from_slice(&payload[..plen]);
    let c = checksum(&out[start + 1..], crc_extra(msgid).unwrap_or(0));
    out.extend_from_slice(&c.to_le_bytes());
}

/// HIGHRES_IMU payload for a sample (time in µs, values as f32, the given instance id).
/// `fields_updated` has the bits of the present channels and of the temperature when there is
/// one; an absent channel's bit is clear and its field NaN (so a reader that ignores the bits
/// sees no number either), a missing temperature likewise.
pub fn highres_payload(s: &Sample, instance: u8) -> Vec<u8> {
    let mut p = Vec::with_capacity(LEN_HIGHRES);
    p.extend_from_slice(&(s.t_ns / 1000).to_le_bytes());
    let ch = s.channels();
    for c in [3, 4, 5, 0, 1, 2] {
        let v = if s.is_absent(c) {
            f32::NAN
        } else {
            ch[c] as f32
        };
        p.extend_from_slice(&v.to_le_bytes());
    }
    p.extend_from_slice(&[0u8; 24]); // mag, pressures
    p.extend_from_slice(&(s.temp_c.map_or(f32::NAN, |t| t as f32)).to_le_bytes());
    let mut fields = HIGHRES_CHANNEL_BITS
        .iter()
        .enumerate()
        .filter(|(c, _)| !s.is_absent(*c))
        .fold(0u16, |m, (_, b)| m | b);
    if s.temp_c.is_some() {
        fields |= HIGHRES_TEMP_BIT;
    }
    p.extend_from_slice(&fields.to_le_bytes());
    p.push(instance);
    p
}

#[cfg(test)]
mod tests;
