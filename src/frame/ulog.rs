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
//! Written by hand: the `px4-ulog` crate parses with callbacks and stops at the first bad
//! message (with asserts on its buffers), where this decoder must count, resynchronise and
//! keep every message's bytes for pass-through.

use super::protocol::{Carrier, Decoded, Protocol, ProtocolDecoder, TimeTracker, flag_values};
use super::{DecoderStats, Descriptor};
use crate::sample::Sample;
use bytes::{Buf, Bytes, BytesMut};
use std::collections::HashMap;

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

/// One field of a format: type name, array length (1 if scalar), field name.
#[derive(Clone, Debug)]
struct Field {
    ty: String,
    n: usize,
    name: String,
}

fn primitive_size(ty: &str) -> Option<usize> {
    Some(match ty {
        "int8_t" | "uint8_t" | "bool" | "char" => 1,
        "int16_t" | "uint16_t" => 2,
        "int32_t" | "uint32_t" | "float" => 4,
        "int64_t" | "uint64_t" | "double" => 8,
        _ => return None,
    })
}

fn parse_format(body: &[u8]) -> Option<(String, Vec<Field>)> {
    let text = std::str::from_utf8(body).ok()?;
    let (name, rest) = text.split_once(':')?;
    let mut fields = Vec::new();
    for f in rest.split(';').filter(|f| !f.is_empty()) {
        let (ty, fname) = f.trim().split_once(' ')?;
        let (ty, n) = match ty.split_once('[') {
            Some((t, k)) => (t, k.trim_end_matches(']').parse::<usize>().ok()?),
            None => (ty, 1),
        };
        fields.push(Field {
            ty: ty.to_string(),
            n,
            name: fname.to_string(),
        });
    }
    Some((name.to_string(), fields))
}

/// Where the IMU values of a subscribed topic sit in its data message (offsets from the start
/// of the fields, after msg_id).
#[derive(Clone, Copy, Debug, Default)]
struct Layout {
    time: usize,
    /// Offset of three consecutive f32: gyro (sensor_combined `gyro_rad`, sensor_gyro x y z) or
    /// accel.
    xyz: usize,
    /// sensor_combined: offset of `accelerometer_m_s2`.
    accel: Option<usize>,
    temp: Option<usize>,
    /// Bytes of fields needed.
    need: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Combined,
    Gyro,
    Accel,
}

/// Field name → (byte offset, type, array length).
type FieldOffsets = HashMap<String, (usize, String, usize)>;

/// Decoder for a ULog stream (a file read front to back).
pub struct UlogDecoder {
    opts: UlogOptions,
    stats: DecoderStats,
    tracker: TimeTracker,
    header_done: bool,
    formats: HashMap<String, Vec<Field>>,
    /// msg_id → (role, layout) for the selected subscriptions.
    subs: HashMap<u16, (Role, Layout)>,
    /// msg_id → size in bytes of every subscribed topic (for plausibility checks).
    sizes: HashMap<u16, usize>,
    /// sensor_gyro / sensor_accel pairing: the last message of each, not yet used.
    gyro: Option<Bytes>,
    accel: Option<Bytes>,
    gyro_layout: Layout,
    accel_layout: Layout,
    descriptor: Option<Descriptor>,
    pending: Option<Decoded>,
    counted: usize,
    in_garbage: bool,
    found_topics: Vec<String>,
}

impl Default for UlogDecoder {
    fn default() -> Self {
        Self::new(UlogOptions::default())
    }
}

fn f32_at(p: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
}

/// Offset of data-message fields within the whole message (size u16, type u8, msg_id u16).
const DATA_FIELDS: usize = 5;

impl UlogDecoder {
    pub fn new(opts: UlogOptions) -> Self {
        UlogDecoder {
            tracker: TimeTracker::with_rate_hz(opts.rate_hz),
            opts,
            stats: DecoderStats::default(),
            header_done: false,
            formats: HashMap::new(),
            subs: HashMap::new(),
            sizes: HashMap::new(),
            gyro: None,
            accel: None,
            gyro_layout: Layout::default(),
            accel_layout: Layout::default(),
            descriptor: None,
            pending: None,
            counted: 0,
            in_garbage: false,
            found_topics: Vec::new(),
        }
    }

    fn size_of(&self, ty: &str, depth: usize) -> Option<usize> {
        if let Some(s) = primitive_size(ty) {
            return Some(s);
        }
        if depth > 8 {
            return None;
        }
        let fields = self.formats.get(ty)?;
        fields
            .iter()
            .map(|f| self.size_of(&f.ty, depth + 1).map(|s| s * f.n))
            .sum()
    }

    /// Byte offset of each named field of `topic`.
    fn offsets(&self, topic: &str) -> Option<(FieldOffsets, usize)> {
        let fields = self.formats.get(topic)?;
        let mut o = 0;
        let mut m = HashMap::new();
        for f in fields {
            let s = self.size_of(&f.ty, 0)?;
            m.insert(f.name.clone(), (o, f.ty.clone(), f.n));
            o += s * f.n;
        }
        Some((m, o))
    }

    fn layout(&self, topic: &str, role: Role) -> Option<Layout> {
        let (m, _) = self.offsets(topic)?;
        let at = |name: &str, ty: &str, n: usize| {
            m.get(name)
                .filter(|(_, t, k)| t == ty && *k >= n)
                .map(|(o, _, _)| *o)
        };
        let time =
            at("timestamp_sample", "uint64_t", 1).or_else(|| at("timestamp", "uint64_t", 1))?;
        let (xyz, accel) = match role {
            Role::Combined => (
                at("gyro_rad", "float", 3)?,
                Some(at("accelerometer_m_s2", "float", 3)?),
            ),
            _ => {
                let x = at("x", "float", 1)?;
                if at("y", "float", 1)? != x + 4 || at("z", "float", 1)? != x + 8 {
                    return None;
                }
                (x, None)
            }
        };
        let temp = at("temperature", "float", 1);
        let need = [
            time + 8,
            xyz + 12,
            accel.map_or(0, |a| a + 12),
            temp.map_or(0, |t| t + 4),
        ]
        .into_iter()
        .max()
        .unwrap_or(0);
        Some(Layout {
            time,
            xyz,
            accel,
            temp,
            need,
        })
    }

    fn other(&mut self, b: Bytes) -> Decoded {
        self.stats.frames_ok += 1;
        self.stats.other_messages += 1;
        self.stats.other_bytes += b.len() as u64;
        Decoded::Other(b)
    }

    fn fault(&mut self, buf: &mut BytesMut) {
        buf.advance(1);
        self.counted = self.counted.saturating_sub(1);
        self.stats.garbage_bytes += 1;
        self.stats.resyncs += 1;
        self.in_garbage = true;
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
        if let Some((_, size)) = self.offsets(name) {
            self.sizes.insert(id, size);
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
        if let Some(l) = self.layout(name, role) {
            match role {
                Role::Gyro => self.gyro_layout = l,
                Role::Accel => self.accel_layout = l,
                Role::Combined => {}
            }
            self.subs.insert(id, (role, l));
        }
    }

    fn sample_from(
        &mut self,
        t_us: u64,
        ch: [f64; 6],
        temp: Option<f64>,
        carrier: Carrier,
    ) -> Decoded {
        let mut s = Sample {
            t_ns: t_us.saturating_mul(1000),
            temp_c: temp,
            ..Sample::default()
        };
        s.set_channels(&ch);
        self.tracker.track(&mut s, &mut self.stats);
        if self.descriptor.is_none()
            && let Some(r) = self.tracker.rate_hz()
        {
            let d = Descriptor {
                sample_rate_hz: r,
                axes: super::AxisConvention::Frd,
                ..Descriptor::default()
            };
            self.descriptor = Some(d);
            self.stats.descriptors += 1;
            self.pending = Some(Decoded::Descriptor(d));
        }
        flag_values(&mut s, self.descriptor.as_ref(), &mut self.stats);
        self.stats.samples += 1;
        self.stats.frames_ok += 1;
        Decoded::Sample(s, Some(carrier))
    }

    fn data(&mut self, msg: Bytes) -> Decoded {
        let id = u16::from_le_bytes([msg[3], msg[4]]);
        let Some(&(role, l)) = self.subs.get(&id) else {
            return self.other(msg);
        };
        let f = &msg[DATA_FIELDS..];
        if f.len() < l.need {
            self.stats.bad_payload += 1;
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
                let a = xyz(l.accel.expect("combined layout has accel"));
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
                self.sample_from(t, [g[0], g[1], g[2], a[0], a[1], a[2]], temp, c)
            }
            Role::Gyro | Role::Accel => {
                if role == Role::Gyro {
                    if let Some(old) = self.gyro.replace(msg) {
                        // Two gyro messages without an accel between: the first has no pair.
                        self.stats.partial_samples += 1;
                        return self.other(old);
                    }
                } else if let Some(old) = self.accel.replace(msg) {
                    self.stats.partial_samples += 1;
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
        self.sample_from(t, [gv[0], gv[1], gv[2], av[0], av[1], av[2]], temp, c)
    }

    /// One item from the front of `buf`; `None` = need more bytes.
    fn step(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        loop {
            if !self.header_done {
                // Find the file header (a stream may start with garbage).
                match buf.windows(MAGIC.len()).position(|w| w == MAGIC) {
                    Some(0) => {}
                    Some(p) => {
                        self.garbage(buf, p);
                    }
                    None => {
                        let keep = (MAGIC.len() - 1).min(buf.len());
                        let n = buf.len() - keep;
                        if n > 0 {
                            self.garbage(buf, n);
                        }
                        return None;
                    }
                }
                if buf.len() < HEADER_LEN {
                    return None;
                }
                self.header_done = true;
                self.counted = self.counted.saturating_sub(HEADER_LEN);
                let h = buf.split_to(HEADER_LEN).freeze();
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
                self.stats.header_errors += 1;
                self.fault(buf);
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
                    match self.sizes.get(&id) {
                        // Trailing padding (< 8 bytes) may be left out.
                        Some(&s) => size - 2 <= s && size - 2 + 8 > s,
                        None => false,
                    }
                }
                b'F' => parse_format(&buf[3..total]).is_some(),
                b'A' => std::str::from_utf8(&buf[6..total]).is_ok(),
                _ => true,
            };
            if !ok {
                self.stats.bad_payload += 1;
                self.fault(buf);
                continue;
            }
            self.in_garbage = false;
            self.counted = self.counted.saturating_sub(total);
            let msg = buf.split_to(total).freeze();
            match ty {
                b'F' => {
                    if let Some((name, fields)) = parse_format(&msg[3..]) {
                        self.formats.insert(name, fields);
                    }
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

    fn garbage(&mut self, buf: &mut BytesMut, n: usize) {
        buf.advance(n);
        self.counted = self.counted.saturating_sub(n);
        self.stats.garbage_bytes += n as u64;
        if !self.in_garbage {
            self.stats.resyncs += 1;
            self.in_garbage = true;
        }
    }
}

impl ProtocolDecoder for UlogDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Ulog
    }
    fn decode_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        if buf.len() > self.counted {
            self.stats.bytes_in += (buf.len() - self.counted) as u64;
        }
        self.counted = buf.len();
        if let Some(p) = self.pending.take() {
            return Some(p);
        }
        self.step(buf)
    }
    fn decode_item_eof(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        if let Some(d) = self.decode_item(buf) {
            return Some(d);
        }
        while !buf.is_empty() {
            self.discard_tail(buf);
            if let Some(d) = self.decode_item(buf) {
                return Some(d);
            }
        }
        // An unpaired gyro or accel message at the end: keep its bytes.
        if let Some(b) = self.gyro.take().or_else(|| self.accel.take()) {
            self.stats.partial_samples += 1;
            return Some(self.other(b));
        }
        None
    }
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        if !buf.is_empty() {
            self.stats.truncated += 1;
            let n = buf.len();
            self.garbage(buf, n);
        }
    }
    fn stats(&self) -> DecoderStats {
        self.stats
    }
    fn descriptor(&self) -> Option<Descriptor> {
        self.descriptor
    }
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

/// A minimal ULog with `sensor_combined` samples (for tests and benchmarks): header, format,
/// subscription, one data message per sample.
pub fn encode_sensor_combined_log(samples: &[Sample], out: &mut BytesMut) {
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
    for s in samples {
        let mut b = Vec::with_capacity(46);
        b.extend_from_slice(&1u16.to_le_bytes());
        b.extend_from_slice(&(s.t_ns / 1000).to_le_bytes());
        let ch = s.channels();
        for v in &ch[..3] {
            b.extend_from_slice(&(*v as f32).to_le_bytes());
        }
        b.extend_from_slice(&4000u32.to_le_bytes());
        b.extend_from_slice(&0i32.to_le_bytes());
        for v in &ch[3..] {
            b.extend_from_slice(&(*v as f32).to_le_bytes());
        }
        b.extend_from_slice(&4000u32.to_le_bytes());
        b.extend_from_slice(&[0, 0, 1, 1]);
        encode_message(b'D', &b, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            let got: Vec<&Sample> = out
                .iter()
                .filter_map(|d| match d {
                    Decoded::Sample(s, _) => Some(s),
                    _ => None,
                })
                .collect();
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
