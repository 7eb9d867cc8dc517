//! The UBX decoder as it was before the per-sample rework (commit e606db5: every sample through
//! the ready queue, per-word `slot_of` + `physical` dispatch, byte-at-a-time Fletcher checksum,
//! `f64::round` per time tag), kept verbatim here as the benchmark's in-run baseline. Only its
//! UBX framing rule is copied (NMEA and RTCM 3 go to the library's rule: the bench stream has
//! none).
#![allow(dead_code)]

use bytes::{Bytes, BytesMut};
use imuprep::frame::framing::{Fault, Framer, Front, Stamper};
use imuprep::frame::ubx::port::is_start;
use imuprep::frame::ubx::{
    ACCEL_LSB_M_S2, CLASS_ESF, GYRO_LSB_DEG_S, ID_ESF_MEAS, ID_ESF_RAW, MAX_PAYLOAD, SYNC,
    TEMP_LSB_C, TYPE_ACCEL_X, TYPE_ACCEL_Y, TYPE_ACCEL_Z, TYPE_GYRO_TEMP, TYPE_GYRO_X, TYPE_GYRO_Y,
    TYPE_GYRO_Z, UbxOptions, meas_words, raw_groups, value24,
};
use imuprep::frame::{Carrier, Decoded, DecoderStats, Descriptor, Protocol, ProtocolDecoder};
use imuprep::sample::Sample;
use std::collections::VecDeque;

fn checksum(bytes: &[u8]) -> [u8; 2] {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    [a, b]
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

/// Which channel (0..6) a data type fills, 6 for the temperature.
#[inline]
pub fn slot_of(ty: u8) -> Option<usize> {
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

fn front(buf: &[u8]) -> Front {
    if buf[0] != 0xB5 {
        return imuprep::frame::ubx::port::front(buf);
    }
    if buf.len() < 2 {
        return Front::Need(None);
    }
    if buf[1] != SYNC[1] {
        return Front::Bad(Fault::Sync);
    }
    if buf.len() < 6 {
        return Front::Need(None);
    }
    let len = u16::from_le_bytes([buf[4], buf[5]]) as usize;
    if len > MAX_PAYLOAD {
        return Front::Bad(Fault::Length);
    }
    let total = 6 + len + 2;
    if buf.len() < total {
        return Front::Need(Some(total));
    }
    if checksum(&buf[2..6 + len]) != [buf[6 + len], buf[7 + len]] {
        return Front::Bad(Fault::Crc);
    }
    Front::Whole(total)
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
pub struct UbxDecoderBefore {
    #[allow(dead_code)] // kept for the summary and for re-creating the decoder
    opts: UbxOptions,
    f: Framer,
    stamper: Stamper,
    raw_clock: TagClock,
    meas_clock: TagClock,
    ready: VecDeque<Decoded>,
    meas_pending: Option<Partial>,
    raw_msgs: u64,
    meas_msgs: u64,
}

impl Default for UbxDecoderBefore {
    fn default() -> Self {
        Self::new(UbxOptions::default())
    }
}

impl UbxDecoderBefore {
    pub fn new(opts: UbxOptions) -> Self {
        UbxDecoderBefore {
            opts,
            f: Framer::default(),
            stamper: Stamper::new(opts.rate_hz),
            raw_clock: TagClock::new(opts.raw_tag_bits, opts.raw_tick_us),
            meas_clock: TagClock::new(opts.meas_tag_bits, opts.meas_tick_us),
            ready: VecDeque::new(),
            meas_pending: None,
            raw_msgs: 0,
            meas_msgs: 0,
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
            self.f.stats.partial_samples += 1;
        }
        // The descriptor learned on a sample goes out just before it.
        if let Some(d) = self
            .stamper
            .stamp(&mut s, &mut self.f.stats, Descriptor::default)
        {
            self.ready.push_back(Decoded::Descriptor(d));
        }
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
            self.f.stats.bad_payload += 1;
            self.other(frame);
            return;
        }
        self.raw_msgs += 1;
        self.f.stats.frames_ok += 1;
        // The samples go into the queue as they are made; their carriers learn how many the
        // message holds once all are made (one pass over the blocks).
        let first = self.ready.len();
        let mut slots = 0u16;
        for (i, (tag, range)) in raw_groups(p).enumerate() {
            slots = i as u16 + 1;
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
                slots: 0,
                offsets: [0; 4],
                raw_scale: None,
            };
            self.emit(t, vals, carrier);
        }
        for item in self.ready.range_mut(first..) {
            if let Decoded::Sample(_, Some(c)) = item {
                c.slots = slots;
            }
        }
        if slots == 0 {
            // A raw message without blocks carries no sample: keep its bytes.
            self.f.stats.frames_ok -= 1;
            self.other(frame);
        }
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

    /// Find and handle one message at the front of `buf`; false = need more bytes.
    fn step(&mut self, buf: &mut BytesMut) -> bool {
        if !self.f.seek(buf, is_start) {
            return false;
        }
        match front(buf) {
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

impl ProtocolDecoder for UbxDecoderBefore {
    fn protocol(&self) -> Protocol {
        Protocol::Ubx
    }
    fn decode_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        self.f.arrived(buf);
        loop {
            if let Some(d) = self.ready.pop_front() {
                return Some(d);
            }
            if buf.is_empty() || !self.step(buf) {
                return self.ready.pop_front();
            }
        }
    }
    fn held(&mut self) -> Option<Decoded> {
        // An ESF-MEAS half whose partner never came: a partial sample.
        self.flush_meas();
        self.ready.pop_front()
    }
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        // The front cannot complete: count it truncated and look for a message inside it.
        let start = buf.first().is_some_and(|&b| is_start(b));
        self.f.truncated_front(buf, start);
    }
    fn stats(&self) -> DecoderStats {
        self.f.stats
    }
    fn descriptor(&self) -> Option<Descriptor> {
        self.stamper.descriptor()
    }
    fn found(&self) -> String {
        format!(
            "UBX: {} ESF-RAW and {} ESF-MEAS messages with IMU data, {} other messages (UBX, NMEA, RTCM) passed through",
            self.raw_msgs, self.meas_msgs, self.f.stats.other_messages
        )
    }
}
