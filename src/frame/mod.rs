//! The native imuprep wire format, version 1 (documented in `docs/frame-format.md`).
//!
//! ```text
//! offset size  field
//!  0     2     sync word 0xA5 0x5A
//!  2     1     format version (1)
//!  3     1     message type (1 descriptor, 2 sample, 3 clean sample, 4 health)
//!  4     2     payload length N, u16 little-endian (≤ MAX_PAYLOAD)
//!  6     4     sequence counter, u32 LE (samples; descriptors carry 0)
//! 10     2     header check: CRC-16/IBM-3740 of bytes 0..10, LE
//! 12     N     payload (little-endian)
//! 12+N   4     CRC-32C (Castagnoli) of bytes 0..12+N, LE
//! ```
//!
//! The header check lets the decoder reject a corrupt length before it waits for a bogus payload;
//! the trailer protects the whole frame. A recorded log is [`LOG_MAGIC`], a u16 log version, a u16
//! reserved field, then exactly the frames a serial port carries (starting with a descriptor).

pub mod codec;
pub mod detect;
pub mod framing;
pub mod health;
#[cfg(any(feature = "ros2", feature = "ros2-sqlite"))]
pub mod inflate;
pub mod inline;
pub mod mavlink;
mod mavlink_crc;
#[cfg(feature = "ros2")]
pub mod mcap;
pub mod mcap_out;
pub mod protocol;
pub mod ros2;
pub mod settle;
pub mod ubx;
pub mod ulog;

use crate::sample::{Sample, flags};
use bytes::{BufMut, BytesMut};
use crc::{CRC_16_IBM_3740, Crc, Table};

pub use codec::{DecoderStats, FrameDecoder};
pub use protocol::{Carrier, Codec, Decoded, Protocol, ProtocolDecoder, TimeTracker};

/// Two sync bytes that open every frame.
pub const SYNC: [u8; 2] = [0xA5, 0x5A];
/// Wire format version carried in every frame.
pub const VERSION: u8 = 1;
/// Bytes before the payload.
pub const HEADER_LEN: usize = 12;
/// CRC-32C trailer length.
pub const TRAILER_LEN: usize = 4;
/// Largest payload any version-1 message has; longer lengths are rejected as corrupt.
pub const MAX_PAYLOAD: usize = 256;

/// Message type: sensor descriptor.
pub const MSG_DESCRIPTOR: u8 = 1;
/// Message type: one raw or processed sample.
pub const MSG_SAMPLE: u8 = 2;
/// Message type: a sample with the bias estimate and its uncertainty (output of the bias stage).
pub const MSG_CLEAN_SAMPLE: u8 = 3;
/// Message type: the daemon's health counters ([`health::HealthFrame`]), at the health interval.
pub const MSG_HEALTH: u8 = 4;

/// Payload sizes per message type.
pub const DESCRIPTOR_PAYLOAD: usize = 24;
pub const SAMPLE_PAYLOAD: usize = 40;
pub const CLEAN_SAMPLE_PAYLOAD: usize = SAMPLE_PAYLOAD + 48;

/// Bytes of one raw sample frame on the wire.
pub const SAMPLE_FRAME_LEN: usize = HEADER_LEN + SAMPLE_PAYLOAD + TRAILER_LEN;

/// Magic bytes at the start of a recorded log.
pub const LOG_MAGIC: [u8; 8] = *b"IMUPLOG\0";
/// Recorded-log container version.
pub const LOG_VERSION: u16 = 1;
/// Bytes of the log file header before the first frame.
pub const LOG_HEADER_LEN: usize = 12;

pub(crate) const CRC16: Crc<u16, Table<16>> = Crc::<u16, Table<16>>::new(&CRC_16_IBM_3740);
/// CRC-32C (Castagnoli): the `crc32c` crate uses the SSE4.2 / ARMv8 CRC instruction where the
/// CPU has it and falls back to software elsewhere; same polynomial and result either way.
#[inline]
pub(crate) fn crc32c(bytes: &[u8]) -> u32 {
    crc32c::crc32c(bytes)
}

/// Axis convention of the body frame, as declared by the sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisConvention {
    #[default]
    Unknown,
    /// x forward, y right, z down.
    Frd,
    /// x forward, y left, z up.
    Flu,
}

impl AxisConvention {
    fn to_u8(self) -> u8 {
        match self {
            AxisConvention::Unknown => 0,
            AxisConvention::Frd => 1,
            AxisConvention::Flu => 2,
        }
    }
    fn from_u8(v: u8) -> Self {
        match v {
            1 => AxisConvention::Frd,
            2 => AxisConvention::Flu,
            _ => AxisConvention::Unknown,
        }
    }
}

/// What the sensor says about itself: rate, ranges (for saturation detection), axes, identity.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize)]
pub struct Descriptor {
    /// Nominal output rate, Hz (0 = unknown).
    pub sample_rate_hz: f64,
    /// Gyro full-scale range, rad/s (0 = unknown: no saturation detection).
    pub gyro_range_rad_s: f32,
    /// Accelerometer full-scale range, m/s² (0 = unknown).
    pub accel_range_m_s2: f32,
    pub axes: AxisConvention,
    pub device_id: u32,
    /// Channels the sensor does not have, bit `c` for channel `c` (gx gy gz ax ay az); 0 = all
    /// six present. Byte 17 of the payload, reserved (0) before partial sensors were supported,
    /// so every older log reads as all present. Samples of the stream carry NaN there and the
    /// decoder marks them [`Sample::absent`].
    pub absent: u8,
}

/// A decoded message.
#[derive(Clone, Debug, PartialEq)]
pub enum Message {
    Descriptor(Descriptor),
    Sample(Sample),
    /// A health report published beside the samples (see [`health`]).
    Health(health::HealthFrame),
}

fn put_header(buf: &mut BytesMut, msg_type: u8, payload_len: usize, seq: u32) {
    let start = buf.len();
    buf.put_slice(&SYNC);
    buf.put_u8(VERSION);
    buf.put_u8(msg_type);
    buf.put_u16_le(payload_len as u16);
    buf.put_u32_le(seq);
    let hc = CRC16.checksum(&buf[start..start + 10]);
    buf.put_u16_le(hc);
}

fn put_trailer(buf: &mut BytesMut, start: usize) {
    let c = crc32c(&buf[start..]);
    buf.put_u32_le(c);
}

/// Append one descriptor frame.
pub fn encode_descriptor(d: &Descriptor, buf: &mut BytesMut) {
    buf.reserve(HEADER_LEN + DESCRIPTOR_PAYLOAD + TRAILER_LEN);
    let start = buf.len();
    put_header(buf, MSG_DESCRIPTOR, DESCRIPTOR_PAYLOAD, 0);
    buf.put_f64_le(d.sample_rate_hz);
    buf.put_f32_le(d.gyro_range_rad_s);
    buf.put_f32_le(d.accel_range_m_s2);
    buf.put_u8(d.axes.to_u8());
    buf.put_u8(d.absent & crate::sample::ALL_CHANNELS);
    buf.put_bytes(0, 2);
    buf.put_u32_le(d.device_id);
    put_trailer(buf, start);
}

/// Append one sample frame: a clean-sample frame (with bias and its σ) when the bias stage
/// removed a bias, else a plain sample frame.
///
/// The frame is assembled in a stack array and appended once: one capacity check per frame
/// instead of one per field.
pub fn encode_sample(s: &Sample, buf: &mut BytesMut) {
    const MAX: usize = HEADER_LEN + CLEAN_SAMPLE_PAYLOAD + TRAILER_LEN;
    let with_bias = s.flags & flags::BIAS_REMOVED != 0;
    let (ty, len) = if with_bias {
        (MSG_CLEAN_SAMPLE, CLEAN_SAMPLE_PAYLOAD)
    } else {
        (MSG_SAMPLE, SAMPLE_PAYLOAD)
    };
    let mut f = [0u8; MAX];
    f[0..2].copy_from_slice(&SYNC);
    f[2] = VERSION;
    f[3] = ty;
    f[4..6].copy_from_slice(&(len as u16).to_le_bytes());
    f[6..10].copy_from_slice(&s.seq.to_le_bytes());
    let hc = CRC16.checksum(&f[..10]);
    f[10..12].copy_from_slice(&hc.to_le_bytes());
    let p = HEADER_LEN;
    f[p..p + 8].copy_from_slice(&s.t_ns.to_le_bytes());
    for (i, v) in s.channels().iter().enumerate() {
        // An absent channel is NaN on the wire whatever the sample holds (the descriptor's
        // absent mask says why).
        let v = if s.is_absent(i) { f32::NAN } else { *v as f32 };
        f[p + 8 + 4 * i..p + 12 + 4 * i].copy_from_slice(&v.to_le_bytes());
    }
    let t = s.temp_c.map_or(f32::NAN, |t| t as f32);
    f[p + 32..p + 36].copy_from_slice(&t.to_le_bytes());
    f[p + 36..p + 40].copy_from_slice(&s.flags.to_le_bytes());
    if with_bias {
        for i in 0..6 {
            f[p + 40 + 4 * i..p + 44 + 4 * i].copy_from_slice(&s.bias[i].to_le_bytes());
            f[p + 64 + 4 * i..p + 68 + 4 * i].copy_from_slice(&s.bias_sd[i].to_le_bytes());
        }
    }
    let end = HEADER_LEN + len;
    let c = crc32c(&f[..end]);
    f[end..end + 4].copy_from_slice(&c.to_le_bytes());
    buf.extend_from_slice(&f[..end + 4]);
}

/// Append the recorded-log file header (magic, version, reserved) and the descriptor frame.
pub fn encode_log_header(d: &Descriptor, buf: &mut BytesMut) {
    buf.put_slice(&LOG_MAGIC);
    buf.put_u16_le(LOG_VERSION);
    buf.put_u16_le(0);
    encode_descriptor(d, buf);
}

/// Why a log file header was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LogHeaderError {
    #[error("file is too short to hold a log header ({0} bytes, need {LOG_HEADER_LEN})")]
    TooShort(usize),
    /// Every command reads a log, but only `replay` and `export` take `--protocol`: the message
    /// names the way in for both (and says when the file starts with text, as a CSV does).
    #[error(
        "not an imuprep log: wrong magic {magic:02x?} (expected \"IMUPLOG\\0\"){text}; a CSV, UBX, MAVLink, ULog or MCAP recording converts into a log with `imuprep import FILE -o OUT.log`, and replay and export read a UBX, MAVLink, ULog or MCAP recording directly with --protocol auto (or its name)",
        magic = .0,
        text = starts_with_text(.0)
    )]
    BadMagic([u8; 8]),
    /// Not a native log, and the first bytes decode as another protocol (the native protocol
    /// is the default, so a sensor recording would otherwise fail with no way out named).
    #[error(
        "not an imuprep log (magic {1:02x?}): it looks like a {0} recording, pass --protocol {0} (or --protocol auto) to replay or export it, or convert it for any command with `imuprep import FILE -o OUT.log`"
    )]
    LooksLike(Protocol, [u8; 8]),
    #[error("unsupported log version {0} (this build reads version {LOG_VERSION})")]
    BadVersion(u16),
    /// A recording format imuprep does not read ([`detect::foreign_format`]): what it is and
    /// what to do instead.
    #[error("not an imuprep log: {0}")]
    Foreign(&'static str),
}

impl LogHeaderError {
    /// The file is some other recording (or no recording at all), not a damaged or newer log.
    pub fn not_a_log(&self) -> bool {
        matches!(
            self,
            LogHeaderError::BadMagic(_)
                | LogHeaderError::LooksLike(..)
                | LogHeaderError::Foreign(_)
        )
    }
}

/// ", it starts with text (a CSV?)" when the first bytes are printable ASCII, else nothing.
fn starts_with_text(m: &[u8; 8]) -> &'static str {
    if m.iter()
        .all(|b| b.is_ascii_graphic() || matches!(b, b' ' | b'\t' | b'\r' | b'\n'))
    {
        ", it starts with text (a CSV?)"
    } else {
        ""
    }
}

/// Check the 12-byte log file header.
pub fn check_log_header(h: &[u8]) -> Result<(), LogHeaderError> {
    if h.len() < LOG_HEADER_LEN {
        return Err(LogHeaderError::TooShort(h.len()));
    }
    let mut magic = [0u8; 8];
    magic.copy_from_slice(&h[..8]);
    if let Some(what) = detect::foreign_format(h) {
        return Err(LogHeaderError::Foreign(what));
    }
    if magic != LOG_MAGIC {
        return Err(LogHeaderError::BadMagic(magic));
    }
    let v = u16::from_le_bytes([h[8], h[9]]);
    if v != LOG_VERSION {
        return Err(LogHeaderError::BadVersion(v));
    }
    Ok(())
}

fn f32_at(p: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
}

/// Parse a descriptor payload (length already checked).
pub(crate) fn parse_descriptor(p: &[u8]) -> Descriptor {
    Descriptor {
        sample_rate_hz: f64::from_le_bytes(p[0..8].try_into().expect("8 bytes")),
        gyro_range_rad_s: f32_at(p, 8),
        accel_range_m_s2: f32_at(p, 12),
        axes: AxisConvention::from_u8(p[16]),
        absent: p[17] & crate::sample::ALL_CHANNELS,
        device_id: u32::from_le_bytes(p[20..24].try_into().expect("4 bytes")),
    }
}

/// Parse a sample or clean-sample payload (length already checked).
pub(crate) fn parse_sample(seq: u32, p: &[u8], with_bias: bool) -> Sample {
    let mut s = Sample {
        seq,
        t_ns: u64::from_le_bytes(p[0..8].try_into().expect("8 bytes")),
        ..Sample::default()
    };
    let mut ch = [0.0f64; 6];
    for (i, c) in ch.iter_mut().enumerate() {
        *c = f32_at(p, 8 + 4 * i) as f64;
    }
    s.set_channels(&ch);
    let t = f32_at(p, 32);
    s.temp_c = if t.is_nan() { None } else { Some(t as f64) };
    s.flags = u32::from_le_bytes(p[36..40].try_into().expect("4 bytes"));
    if with_bias {
        for i in 0..6 {
            s.bias[i] = f32_at(p, 40 + 4 * i);
            s.bias_sd[i] = f32_at(p, 64 + 4 * i);
        }
    }
    s
}
