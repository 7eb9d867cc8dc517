//! PX4 ULog: IMU samples from `sensor_combined`, or from `sensor_gyro` + `sensor_accel` of one
//! instance (with their temperature); every other message (definitions, parameters, other
//! topics, log strings) is passed through whole, so an inline ULog output is the same log with
//! the IMU values cleaned.
//!
//! ```text
//! file header: "ULog" 01 12 35 | version u8 | timestamp u64 (16 bytes)
//! message    : size u16 LE | type u8 | size bytes
//!   'F' format "name:type field;type field;…"   'A' subscribe: multi_id u8, msg_id u16, name
//!   'D' data: msg_id u16, the topic's fields     'S' sync: 2F 73 13 20 25 0C BB 12
//!   'B' 'I' 'M' 'P' 'Q' 'R' 'L' 'C' 'O': flags, info, parameters, log strings, dropouts
//! ```
//!
//! Field offsets are computed from the format definitions (nested types and arrays included;
//! trailing padding may be omitted on the wire). ULog carries no checksum: a message header
//! with an unknown type, an impossible size or a data message for an unknown subscription is a
//! fault, and the decoder steps one byte and searches for the next plausible message (a sync
//! message, when the writer put them in, makes that quick). Times are the topic's `timestamp`
//! (µs since boot; `timestamp_sample` when the topic has it), sequence and gap flags come from
//! them.
//!
//! `sensor_combined` says "no accelerometer values" with PX4's own marker,
//! `accelerometer_timestamp_relative = RELATIVE_TIMESTAMP_INVALID`: while no message of the
//! stream has had valid accelerometer values the accel channels are absent ([`Sample::absent`]:
//! a gyro-only sensor, or the export of one); after that, an invalid marker makes those values
//! NaN (non-finite, a partial sample) rather than data.
//!
//! Written by hand: the `px4-ulog` crate parses with callbacks and stops at the first bad
//! message (with asserts on its buffers), where this decoder must count, resynchronise and
//! keep every message's bytes for pass-through.

mod format;

use super::Descriptor;
use super::framing::{Framer, Stamper};
use super::protocol::{Carrier, Decoded, Protocol, ProtocolDecoder, mark_absent};
use crate::sample::Sample;
use bytes::{Bytes, BytesMut};
use format::{Formats, Layout, Role};

/// The first 7 bytes of a ULog file.
pub const MAGIC: [u8; 7] = [b'U', b'L', b'o', b'g', 0x01, 0x12, 0x35];
pub const HEADER_LEN: usize = 16;
/// Payload of a sync message.
pub const SYNC_MAGIC: [u8; 8] = [0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12];
/// Largest message accepted (formats and parameters are the biggest, a few kB).
const MAX_MSG: usize = 16 * 1024;
const KNOWN_TYPES: &[u8] = b"BFIMPQARDLCSO";

/// Which IMU topic and instance to read.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct UlogOptions {
    /// `sensor_combined` or `sensor_gyro` (then `sensor_gyro` + `sensor_accel` are paired).
    pub topic: String,
    /// Multi-instance id (0 = the first IMU).
    pub instance: u8,
    /// Nominal rate, Hz (0 = learn it from the time stamps).
    pub rate_hz: f64,
}

impl Default for UlogOptions {
    fn default() -> Self {
        UlogOptions {
            topic: "sensor_combined".into(),
            instance: 0,
            rate_hz: 0.0,
        }
    }
}

/// Decoder for a ULog stream (a file read front to back).
pub struct UlogDecoder {
    opts: UlogOptions,
    f: Framer,
    stamper: Stamper,
    header_done: bool,
    formats: Formats,
    /// (msg_id, role, layout) of the selected subscriptions (one or two).
    subs: Vec<(u16, Role, Layout)>,
    /// Size in bytes of every subscribed topic, indexed by msg_id ([`NO_SIZE`] = not
    /// subscribed), for the plausibility check of each data message.
    sizes: Vec<u32>,
    /// sensor_gyro / sensor_accel pairing: the last message of each, not yet used.
    gyro: Option<Bytes>,
    accel: Option<Bytes>,
    gyro_layout: Layout,
    accel_layout: Layout,
    pending: Option<Decoded>,
    found_topics: Vec<String>,
    /// sensor_combined: some message of the stream had valid accelerometer values.
    accel_seen: bool,
}

/// `sizes` entry of a msg_id without a subscription.
const NO_SIZE: u32 = u32::MAX;

crate::frame::protocol::default_from_options!(UlogDecoder, UlogOptions);

fn f32_at(p: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
}

/// Offset of data-message fields within the whole message (size u16, type u8, msg_id u16).
const DATA_FIELDS: usize = 5;

impl UlogDecoder {
    pub fn new(opts: UlogOptions) -> Self {
        UlogDecoder {
            stamper: Stamper::new(opts.rate_hz),
            opts,
            f: Framer::default(),
            header_done: false,
            formats: Formats::default(),
            subs: Vec::new(),
            sizes: Vec::new(),
            gyro: None,
            accel: None,
            gyro_layout: Layout::default(),
            accel_layout: Layout::default(),
            pending: None,
            found_topics: Vec::new(),
            accel_seen: false,
        }
    }

    fn other(&mut self, b: Bytes) -> Decoded {
        self.f.count_other(&b);
        Decoded::Other(b)
    }

    /// The subscribed size of a data message's msg_id.
    fn size_of_id(&self, id: u16) -> Option<usize> {
        match self.sizes.get(id as usize) {
            Some(&s) if s != NO_SIZE => Some(s as usize),
            _ => None,
        }
    }

    fn subscribe(&mut self, body: &[u8]) {
        if body.len() < 4 {
            return;
        }
        let multi = body[0];
        let id = u16::from_le_bytes([body[1], body[2]]);
        let Ok(name) = std::str::from_utf8(&body[3..]) else {
            return;
        };
        if let Some(size) = self.formats.topic_size(name) {
            let i = id as usize;
            if self.sizes.len() <= i {
                self.sizes.resize(i + 1, NO_SIZE);
            }
            self.sizes[i] = size.min(NO_SIZE as usize - 1) as u32;
        }
        let label = format!("{name}[{multi}]");
        if !self.found_topics.contains(&label) {
            self.found_topics.push(label);
        }
        if multi != self.opts.instance {
            return;
        }
        let role = match (name, self.opts.topic.as_str()) {
            ("sensor_combined", "sensor_combined") => Role::Combined,
            ("sensor_gyro", "sensor_gyro") => Role::Gyro,
            ("sensor_accel", "sensor_gyro") => Role::Accel,
            _ => return,
        };
        if let Some(l) = self.formats.layout(name, role) {
            match role {
                Role::Gyro => self.gyro_layout = l,
                Role::Accel => self.accel_layout = l,
                Role::Combined => {}
            }
            self.subs.retain(|(i, _, _)| *i != id);
            self.subs.push((id, role, l));
        }
    }

    fn sample_from(
        &mut self,
        t_us: u64,
        ch: [f64; 6],
        temp: Option<f64>,
        absent: u8,
        carrier: Carrier,
    ) -> Decoded {
        let mut s = Sample {
            t_ns: t_us.saturating_mul(1000),
            temp_c: temp,
            ..Sample::default()
        };
        s.set_channels(&ch);
        mark_absent(&mut s, absent);
        let learned = self
            .stamper
            .stamp(&mut s, &mut self.f.stats, || Descriptor {
                axes: super::AxisConvention::Frd,
                ..Descriptor::default()
            });
        if let Some(d) = learned {
            self.pending = Some(Decoded::Descriptor(d));
        }
        self.f.stats.frames_ok += 1;
        Decoded::Sample(s, Some(carrier))
    }

    fn data(&mut self, msg: Bytes) -> Decoded {
        let id = u16::from_le_bytes([msg[3], msg[4]]);
        let Some(&(_, role, l)) = self.subs.iter().find(|(i, _, _)| *i == id) else {
            return self.other(msg);
        };
        let f = &msg[DATA_FIELDS..];
        if f.len() < l.need {
            self.f.stats.bad_payload += 1;
            return self.other(msg);
        }
        let t = u64::from_le_bytes(f[l.time..l.time + 8].try_into().expect("8 bytes"));
        let xyz = |o: usize| [0, 4, 8].map(|k| f32_at(f, o + k) as f64);
        let temp = l
            .temp
            .map(|o| f32_at(f, o) as f64)
            .filter(|t| t.is_finite());
        match role {
            Role::Combined => {
                let g = xyz(l.xyz);
                let mut a = xyz(l.accel.expect("combined layout has accel"));
                let invalid = l.accel_rel.is_some_and(|o| {
                    i32::from_le_bytes([f[o], f[o + 1], f[o + 2], f[o + 3]])
                        == format::RELATIVE_TIMESTAMP_INVALID
                });
                let mut absent = 0;
                if invalid {
                    if self.accel_seen {
                        // Invalid after valid ones: this message's accel is no measurement.
                        a = [f64::NAN; 3];
                        self.f.stats.partial_samples += 1;
                    } else {
                        absent = 0b111_000;
                    }
                } else {
                    self.accel_seen = true;
                }
                let off = [
                    (DATA_FIELDS + l.xyz) as u16,
                    (DATA_FIELDS + l.accel.unwrap_or(0)) as u16,
                    u16::MAX,
                    0,
                ];
                let c = Carrier {
                    frame: msg,
                    frame2: None,
                    between: None,
                    slot: 0,
                    slots: 1,
                    offsets: off,
                    raw_scale: None,
                };
                self.sample_from(t, [g[0], g[1], g[2], a[0], a[1], a[2]], temp, absent, c)
            }
            Role::Gyro | Role::Accel => {
                if role == Role::Gyro {
                    if let Some(old) = self.gyro.replace(msg) {
                        // Two gyro messages without an accel between: the first has no pair.
                        self.f.stats.partial_samples += 1;
                        return self.other(old);
                    }
                } else if let Some(old) = self.accel.replace(msg) {
                    self.f.stats.partial_samples += 1;
                    return self.other(old);
                }
                match (self.gyro.take(), self.accel.take()) {
                    (Some(g), Some(a)) => self.pair(g, a),
                    (g, a) => {
                        self.gyro = g;
                        self.accel = a;
                        Decoded::Other(Bytes::new())
                    }
                }
            }
        }
    }

    /// One sample from a sensor_gyro and a sensor_accel message (time and temperature from the
    /// gyro; the accel's temperature when the gyro has none).
    fn pair(&mut self, g: Bytes, a: Bytes) -> Decoded {
        let (gl, al) = (self.gyro_layout, self.accel_layout);
        let gf = &g[DATA_FIELDS..];
        let af = &a[DATA_FIELDS..];
        let t = u64::from_le_bytes(gf[gl.time..gl.time + 8].try_into().expect("8 bytes"));
        let v = |f: &[u8], o: usize| [0, 4, 8].map(|k| f32_at(f, o + k) as f64);
        let gv = v(gf, gl.xyz);
        let av = v(af, al.xyz);
        let temp = gl
            .temp
            .map(|o| f32_at(gf, o) as f64)
            .or(al.temp.map(|o| f32_at(af, o) as f64))
            .filter(|t| t.is_finite());
        let off = [
            (DATA_FIELDS + gl.xyz) as u16,
            (DATA_FIELDS + al.xyz) as u16,
            gl.temp.map_or(u16::MAX, |o| (DATA_FIELDS + o) as u16),
            1,
        ];
        let c = Carrier {
            frame: g,
            frame2: Some(a),
            between: None,
            slot: 0,
            slots: 1,
            offsets: off,
            raw_scale: None,
        };
        self.sample_from(t, [gv[0], gv[1], gv[2], av[0], av[1], av[2]], temp, 0, c)
    }

    /// The next item from the bytes (before the hold of the first samples for the period).
    fn next_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        self.f.arrived(buf);
        if let Some(p) = self.pending.take() {
            return Some(p);
        }
        self.step(buf)
    }

    /// At end of input: an unpaired gyro or accel message (its bytes kept).
    fn held_back(&mut self) -> Option<Decoded> {
        let b = self.gyro.take().or_else(|| self.accel.take())?;
        self.f.stats.partial_samples += 1;
        Some(self.other(b))
    }

    /// One item from the front of `buf`; `None` = need more bytes.
    fn step(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        loop {
            if !self.header_done {
                // Find the file header (a stream may start with garbage).
                if !self.f.seek_magic(buf, &MAGIC) || buf.len() < HEADER_LEN {
                    return None;
                }
                self.header_done = true;
                let h = self.f.take(buf, HEADER_LEN);
                return Some(self.other(h));
            }
            if buf.len() < 3 {
                return None;
            }
            let size = u16::from_le_bytes([buf[0], buf[1]]) as usize;
            let ty = buf[2];
            let plausible = KNOWN_TYPES.contains(&ty)
                && size <= MAX_MSG
                && match ty {
                    b'D' => size >= 2,
                    b'S' => size == SYNC_MAGIC.len(),
                    b'A' => size >= 4,
                    b'F' => size >= 3,
                    _ => true,
                };
            if !plausible {
                self.f.stats.header_errors += 1;
                self.f.fault(buf);
                continue;
            }
            let total = 3 + size;
            if buf.len() < total {
                buf.reserve(total - buf.len());
                return None;
            }
            // Content checks that catch a misread header after corruption.
            let ok = match ty {
                b'S' => buf[3..total] == SYNC_MAGIC,
                b'D' => {
                    let id = u16::from_le_bytes([buf[3], buf[4]]);
                    match self.size_of_id(id) {
                        // Trailing padding (< 8 bytes) may be left out.
                        Some(s) => size - 2 <= s && size - 2 + 8 > s,
                        None => false,
                    }
                }
                b'F' => format::is_format(&buf[3..total]),
                b'A' => std::str::from_utf8(&buf[6..total]).is_ok(),
                _ => true,
            };
            if !ok {
                self.f.stats.bad_payload += 1;
                self.f.fault(buf);
                continue;
            }
            let msg = self.f.take(buf, total);
            match ty {
                b'F' => {
                    self.formats.add(&msg[3..]);
                    return Some(self.other(msg));
                }
                b'A' => {
                    self.subscribe(&msg[3..]);
                    return Some(self.other(msg));
                }
                b'D' => {
                    let d = self.data(msg);
                    if matches!(&d, Decoded::Other(b) if b.is_empty()) {
                        // Half of a gyro/accel pair: held until its partner comes.
                        continue;
                    }
                    return Some(d);
                }
                _ => return Some(self.other(msg)),
            }
        }
    }
}

impl ProtocolDecoder for UlogDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Ulog
    }
    crate::frame::framing::decode_through_hold!();
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        // ULog has no sync word to search for: the whole tail is one cut message.
        if !buf.is_empty() {
            self.f.stats.truncated += 1;
            let n = buf.len();
            self.f.skip(buf, n);
        }
    }
    crate::frame::protocol::framer_stats_and_descriptor!();
    fn found(&self) -> String {
        let imu: Vec<&String> = self
            .found_topics
            .iter()
            .filter(|t| t.starts_with("sensor_"))
            .collect();
        format!(
            "ULog: {} topics subscribed; sensor topics: {:?}; reading {}[{}]",
            self.found_topics.len(),
            imu,
            self.opts.topic,
            self.opts.instance
        )
    }
}

/// Write the cleaned values of `s` into a copy of the carrier message(s) (f32 fields; a
/// non-finite cleaned value keeps the original).
pub fn patch(frame: &mut [u8], frame2: Option<&mut [u8]>, off: [u16; 4], s: &Sample) {
    let ch = s.channels();
    let put = |f: &mut [u8], o: usize, v: f64| {
        if v.is_finite() && o + 4 <= f.len() {
            f[o..o + 4].copy_from_slice(&(v as f32).to_le_bytes());
        }
    };
    for (k, v) in ch.iter().take(3).enumerate() {
        put(frame, off[0] as usize + 4 * k, *v);
    }
    if off[3] == 1 {
        if let Some(f2) = frame2 {
            for k in 0..3 {
                put(f2, off[1] as usize + 4 * k, ch[3 + k]);
            }
        }
    } else {
        for k in 0..3 {
            put(frame, off[1] as usize + 4 * k, ch[3 + k]);
        }
    }
    if off[2] != u16::MAX
        && let Some(t) = s.temp_c
    {
        put(frame, off[2] as usize, t);
    }
}

/// Append one ULog message.
pub fn encode_message(ty: u8, body: &[u8], out: &mut BytesMut) {
    out.extend_from_slice(&(body.len() as u16).to_le_bytes());
    out.extend_from_slice(&[ty]);
    out.extend_from_slice(body);
}

/// Why `sensor_combined` cannot carry these absent channels (`None` = it can): it says "no
/// accelerometer values" with PX4's own marker (`accelerometer_timestamp_relative =
/// RELATIVE_TIMESTAMP_INVALID`), but has no way to say the same of the gyro (its time stamp is
/// the gyro's) nor of a single axis.
pub fn sensor_combined_cannot_carry(absent: u8) -> Option<String> {
    const ACCEL: u8 = 0b111_000;
    if absent == 0 || absent == ACCEL {
        return None;
    }
    let names = crate::sample::channel_names_of(absent).join(", ");
    Some(format!(
        "the log has no {names}: ULog sensor_combined can mark only the whole accelerometer \
         invalid (PX4's RELATIVE_TIMESTAMP_INVALID), not the gyro nor a single axis, and writing \
         NaN or zeros there would pass as measurements; export to mavlink (fields_updated), ubx \
         (data words left out), csv or native instead"
    ))
}

/// A minimal ULog with `sensor_combined` samples (for tests, benchmarks and export): header,
/// format, subscription, one data message per sample. A sample whose accelerometer is absent
/// has `accelerometer_timestamp_relative = RELATIVE_TIMESTAMP_INVALID` and NaN there; other
/// absent channels are written NaN (check [`sensor_combined_cannot_carry`] first).
pub fn encode_sensor_combined_log(samples: &[Sample], out: &mut BytesMut) {
    encode_sensor_combined_head(out);
    for s in samples {
        encode_sensor_combined_sample(s, out);
    }
}

/// The file header, flag bits, format and subscription of [`encode_sensor_combined_log`].
pub fn encode_sensor_combined_head(out: &mut BytesMut) {
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&[1]);
    out.extend_from_slice(&0u64.to_le_bytes());
    encode_message(b'B', &[0u8; 40], out);
    encode_message(
        b'F',
        b"sensor_combined:uint64_t timestamp;float[3] gyro_rad;uint32_t gyro_integral_dt;int32_t accelerometer_timestamp_relative;float[3] accelerometer_m_s2;uint32_t accelerometer_integral_dt;uint8_t accelerometer_clipping;uint8_t gyro_clipping;uint8_t accel_calibration_count;uint8_t gyro_calibration_count;",
        out,
    );
    encode_message(b'A', b"\x00\x01\x00sensor_combined", out);
}

/// One sample as a `sensor_combined` data message of [`encode_sensor_combined_log`].
pub fn encode_sensor_combined_sample(s: &Sample, out: &mut BytesMut) {
    let mut b = Vec::with_capacity(46);
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&(s.t_ns / 1000).to_le_bytes());
    let ch = s.channels();
    let value = |c: usize| {
        if s.is_absent(c) {
            f32::NAN
        } else {
            ch[c] as f32
        }
    };
    for c in 0..3 {
        b.extend_from_slice(&value(c).to_le_bytes());
    }
    b.extend_from_slice(&4000u32.to_le_bytes());
    let accel_absent = (3..6).all(|c| s.is_absent(c));
    let rel = if accel_absent {
        format::RELATIVE_TIMESTAMP_INVALID
    } else {
        0
    };
    b.extend_from_slice(&rel.to_le_bytes());
    for c in 3..6 {
        b.extend_from_slice(&value(c).to_le_bytes());
    }
    b.extend_from_slice(&4000u32.to_le_bytes());
    b.extend_from_slice(&[0, 0, 1, 1]);
    encode_message(b'D', &b, out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::DecoderStats;

    fn decode_all(bytes: &[u8], chunk: usize) -> (Vec<Decoded>, DecoderStats) {
        crate::frame::protocol::decode_chunked(&mut UlogDecoder::default(), bytes, chunk)
    }

    #[test]
    fn sensor_combined_round_trip_at_every_chunking() {
        let samples: Vec<Sample> = (0..40)
            .map(|i| {
                let mut s = Sample {
                    t_ns: 1_000_000 + i * 4_000_000,
                    ..Sample::default()
                };
                s.set_channels(&[0.001 * i as f64, 0.2, -0.3, 0.1, 0.2, -9.8]);
                s
            })
            .collect();
        let mut b = BytesMut::new();
        encode_sensor_combined_log(&samples, &mut b);
        for chunk in [1, 3, 17, 4096] {
            let (out, st) = decode_all(&b, chunk);
            let got: Vec<&Sample> = out.iter().filter_map(Decoded::sample).collect();
            assert_eq!(got.len(), 40, "chunk {chunk}");
            assert_eq!(st.garbage_bytes, 0);
            assert_eq!(got[7].gyro[0], 0.007f32 as f64);
            assert_eq!(got[7].t_ns, samples[7].t_ns);
            // Everything that is not a sample passes through: header, B, F, A.
            let bytes: usize = out
                .iter()
                .map(|d| match d {
                    Decoded::Other(b) => b.len(),
                    Decoded::Sample(_, Some(c)) => c.frame.len(),
                    _ => 0,
                })
                .sum();
            assert_eq!(bytes, b.len());
        }
    }
}
