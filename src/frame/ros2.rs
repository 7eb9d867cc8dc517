//! ROS 2 `sensor_msgs/msg/Imu` in CDR (XCDR1, the encoding rosbag2 records): decoding and
//! encoding by hand, plus the message definitions an MCAP file declares for its schemas.
//!
//! Written by hand because the layout is small and fixed — no crate is needed to walk it, and
//! the decoder must know the byte offsets of the fields to re-encode a cleaned sample in place:
//!
//! ```text
//! 0   encapsulation: 00 01 = little endian (00 00 = big endian), 2 option bytes
//! 4   header.stamp.sec i32, header.stamp.nanosec u32
//! 12  header.frame_id: u32 length (with the NUL), bytes, NUL
//!     (padding to 8, counted from byte 4)
//!     orientation x y z w, orientation_covariance[9]
//!     angular_velocity x y z, angular_velocity_covariance[9]
//!     linear_acceleration x y z, linear_acceleration_covariance[9]      (all f64)
//! ```
//!
//! Compiled in every build (it needs no dependency); the MCAP container around it is in
//! `frame::mcap` behind the `ros2` feature.

use crate::sample::{N_CHANNELS, Sample};

/// The 8 bytes that open (and close) an MCAP file.
pub const MAGIC: [u8; 8] = [0x89, b'M', b'C', b'A', b'P', b'0', b'\r', b'\n'];
/// Largest record accepted (a chunk; rosbag2 and the `mcap` crate write chunks of about
/// 1 MiB). A record claiming more is taken as a corrupt length.
pub const MAX_RECORD: u64 = 64 << 20;

/// Which topic to read and which time to use.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct McapOptions {
    /// Topic of the `sensor_msgs/msg/Imu` messages (absent = the first Imu topic declared).
    pub topic: Option<String>,
    /// `"header"` (header.stamp; the log time when the stamp is zero) or `"log"` (the log time
    /// the recorder gave each message).
    pub time: String,
    /// Nominal rate, Hz (0 = learn it from the time stamps).
    pub rate_hz: f64,
    /// Topic of the `sensor_msgs/msg/Temperature` messages joined to the samples (absent = the
    /// first Temperature topic declared; `""` = none).
    pub temperature_topic: Option<String>,
    /// A temperature reading older than this (s, by the time stamps) is not used (0 = no limit).
    pub temperature_max_age_s: f64,
}

impl Default for McapOptions {
    fn default() -> Self {
        McapOptions {
            topic: None,
            time: "header".into(),
            rate_hz: 0.0,
            temperature_topic: None,
            temperature_max_age_s: 5.0,
        }
    }
}

/// The fields of one `sensor_msgs/msg/Imu`, with where the IMU vectors sit in the CDR bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuMsg {
    pub sec: i32,
    pub nanosec: u32,
    pub frame_id: String,
    /// x y z w.
    pub orientation: [f64; 4],
    pub orientation_covariance: [f64; 9],
    pub angular_velocity: [f64; 3],
    pub angular_velocity_covariance: [f64; 9],
    pub linear_acceleration: [f64; 3],
    pub linear_acceleration_covariance: [f64; 9],
    /// Byte offset of `angular_velocity.x` in the CDR bytes (linear acceleration is 96 bytes on).
    pub angular_velocity_at: usize,
    pub little_endian: bool,
}

/// Why a CDR payload is not a `sensor_msgs/msg/Imu`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CdrError {
    #[error("CDR payload too short ({0} bytes)")]
    Short(usize),
    #[error(
        "unsupported CDR encapsulation {0:02x} {1:02x} (plain CDR, big or little endian, only)"
    )]
    Encapsulation(u8, u8),
    #[error("frame_id length {0} runs past the payload")]
    FrameId(usize),
}

/// Bytes of the f64 block after the frame_id: quaternion, 3 covariances, 2 vectors.
const F64_BLOCK: usize = (4 + 9 + 3 + 9 + 3 + 9) * 8;
/// From `orientation.x` to `angular_velocity.x`.
const ANGVEL_FROM_BLOCK: usize = (4 + 9) * 8;
/// From `angular_velocity.x` to `linear_acceleration.x`.
pub const LINACC_FROM_ANGVEL: usize = (3 + 9) * 8;

/// The `N` bytes at `o` in big-endian order (reversed when the data are little-endian).
fn be_bytes<const N: usize>(d: &[u8], o: usize, le: bool) -> [u8; N] {
    let mut b: [u8; N] = d[o..o + N].try_into().expect("N bytes");
    if le {
        b.reverse();
    }
    b
}

fn f64_at(d: &[u8], o: usize, le: bool) -> f64 {
    f64::from_be_bytes(be_bytes(d, o, le))
}

fn u32_at(d: &[u8], o: usize, le: bool) -> u32 {
    u32::from_be_bytes(be_bytes(d, o, le))
}

/// Where the f64 block starts, and the byte order; checks every length.
fn layout(d: &[u8]) -> Result<(usize, bool, usize), CdrError> {
    header_layout(d, F64_BLOCK)
}

/// After a `std_msgs/Header` (stamp, frame id): where the 8-aligned data starts, the byte
/// order and the frame id's length; checks that `need` bytes follow.
fn header_layout(d: &[u8], need: usize) -> Result<(usize, bool, usize), CdrError> {
    if d.len() < 16 {
        return Err(CdrError::Short(d.len()));
    }
    let le = match (d[0], d[1]) {
        (0, 1) => true,
        (0, 0) => false,
        (a, b) => return Err(CdrError::Encapsulation(a, b)),
    };
    let n = u32_at(d, 12, le) as usize;
    let end = 16usize.checked_add(n).ok_or(CdrError::FrameId(n))?;
    if end > d.len() {
        return Err(CdrError::FrameId(n));
    }
    // Align to 8 counted from the end of the encapsulation header.
    let block = 4 + (end - 4).div_ceil(8) * 8;
    if block + need > d.len() {
        return Err(CdrError::Short(d.len()));
    }
    Ok((block, le, n))
}

/// What [`decode_imu_fast`] reads of a `sensor_msgs/msg/Imu`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuFast {
    pub sec: i32,
    pub nanosec: u32,
    /// gx gy gz ax ay az.
    pub channels: [f64; N_CHANNELS],
    /// Channels the message says it has no data for (bit `c` for channel `c`): a vector whose
    /// covariance's element 0 is −1, the message's own "not available" convention.
    pub absent: u8,
    /// Byte offset of `angular_velocity.x`.
    pub angular_velocity_at: usize,
    pub little_endian: bool,
}

/// Covariance element 0 that says "this vector's data is not available" (`sensor_msgs/Imu`).
pub const COVARIANCE_NOT_AVAILABLE: f64 = -1.0;

/// The IMU vectors only (the hot path): time, angular velocity, linear acceleration, which of
/// them the message declares not available, and the offset of `angular_velocity.x`.
#[inline]
pub fn decode_imu_fast(d: &[u8]) -> Result<ImuFast, CdrError> {
    let (block, le, _) = layout(d)?;
    let sec = u32_at(d, 4, le) as i32;
    let nanosec = u32_at(d, 8, le);
    let g = block + ANGVEL_FROM_BLOCK;
    let a = g + LINACC_FROM_ANGVEL;
    let channels = [
        f64_at(d, g, le),
        f64_at(d, g + 8, le),
        f64_at(d, g + 16, le),
        f64_at(d, a, le),
        f64_at(d, a + 8, le),
        f64_at(d, a + 16, le),
    ];
    // Each vector is followed by its covariance.
    let not_available = |v: usize| f64_at(d, v + 24, le) == COVARIANCE_NOT_AVAILABLE;
    let mut absent = 0;
    if not_available(g) {
        absent |= 0b000_111;
    }
    if not_available(a) {
        absent |= 0b111_000;
    }
    Ok(ImuFast {
        sec,
        nanosec,
        channels,
        absent,
        angular_velocity_at: g,
        little_endian: le,
    })
}

/// A CDR `sensor_msgs/msg/Temperature`: header stamp (sec, nanosec) and `temperature` (°C);
/// the `variance` after it is not needed.
pub fn decode_temperature(d: &[u8]) -> Result<(i32, u32, f64), CdrError> {
    let (at, le, _) = header_layout(d, 16)?;
    Ok((u32_at(d, 4, le) as i32, u32_at(d, 8, le), f64_at(d, at, le)))
}

/// Every field of a CDR-encoded `sensor_msgs/msg/Imu`.
pub fn decode_imu(d: &[u8]) -> Result<ImuMsg, CdrError> {
    let (block, le, n) = layout(d)?;
    let name = &d[16..16 + n];
    let name = name.strip_suffix(&[0]).unwrap_or(name);
    let arr =
        |o: usize, k: usize| -> Vec<f64> { (0..k).map(|i| f64_at(d, o + 8 * i, le)).collect() };
    let g = block + ANGVEL_FROM_BLOCK;
    let a = g + LINACC_FROM_ANGVEL;
    Ok(ImuMsg {
        sec: u32_at(d, 4, le) as i32,
        nanosec: u32_at(d, 8, le),
        frame_id: String::from_utf8_lossy(name).into_owned(),
        orientation: arr(block, 4).try_into().expect("4"),
        orientation_covariance: arr(block + 32, 9).try_into().expect("9"),
        angular_velocity: arr(g, 3).try_into().expect("3"),
        angular_velocity_covariance: arr(g + 24, 9).try_into().expect("9"),
        linear_acceleration: arr(a, 3).try_into().expect("3"),
        linear_acceleration_covariance: arr(a + 24, 9).try_into().expect("9"),
        angular_velocity_at: g,
        little_endian: le,
    })
}

/// Append a CDR (little endian) `sensor_msgs/msg/Imu`.
pub fn encode_imu(m: &ImuMsg, out: &mut Vec<u8>) {
    let start = out.len();
    out.extend_from_slice(&[0, 1, 0, 0]);
    out.extend_from_slice(&m.sec.to_le_bytes());
    out.extend_from_slice(&m.nanosec.to_le_bytes());
    let name = m.frame_id.as_bytes();
    out.extend_from_slice(&(name.len() as u32 + 1).to_le_bytes());
    out.extend_from_slice(name);
    out.push(0);
    while !(out.len() - start - 4).is_multiple_of(8) {
        out.push(0);
    }
    let put = |out: &mut Vec<u8>, v: &[f64]| {
        for x in v {
            out.extend_from_slice(&x.to_le_bytes());
        }
    };
    put(out, &m.orientation);
    put(out, &m.orientation_covariance);
    put(out, &m.angular_velocity);
    put(out, &m.angular_velocity_covariance);
    put(out, &m.linear_acceleration);
    put(out, &m.linear_acceleration_covariance);
}

/// Write the cleaned channels of `s` over the vectors at `g` (offset of `angular_velocity.x`)
/// in a CDR Imu; a non-finite cleaned value keeps the original field.
pub fn patch_imu(d: &mut [u8], g: usize, le: bool, s: &Sample) {
    let ch = s.channels();
    for (c, v) in ch.iter().enumerate() {
        let o = if c < 3 {
            g + 8 * c
        } else {
            g + LINACC_FROM_ANGVEL + 8 * (c - 3)
        };
        if v.is_finite() && o + 8 <= d.len() {
            let b = if le { v.to_le_bytes() } else { v.to_be_bytes() };
            d[o..o + 8].copy_from_slice(&b);
        }
    }
}

/// Append a CDR `std_msgs/msg/String`.
pub fn encode_string(s: &str, out: &mut Vec<u8>) {
    out.extend_from_slice(&[0, 1, 0, 0]);
    out.extend_from_slice(&(s.len() as u32 + 1).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
    out.push(0);
}

/// Decode a CDR `std_msgs/msg/String`.
pub fn decode_string(d: &[u8]) -> Option<String> {
    if d.len() < 8 {
        return None;
    }
    let le = d[1] == 1;
    let n = u32_at(d, 4, le) as usize;
    let b = d.get(8..8usize.checked_add(n)?)?;
    let b = b.strip_suffix(&[0]).unwrap_or(b);
    String::from_utf8(b.to_vec()).ok()
}

/// Schema name and definition (`ros2msg`: the message, then each type it uses after a line of
/// `=` and `MSG: type`), as rosbag2 stores them.
pub const IMU_SCHEMA: &str = "sensor_msgs/msg/Imu";
/// Schema name of the temperature messages joined to the samples.
pub const TEMPERATURE_SCHEMA: &str = "sensor_msgs/msg/Temperature";
pub const IMU_DEFINITION: &str = "std_msgs/Header header
geometry_msgs/Quaternion orientation
float64[9] orientation_covariance
geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance
geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
";
pub const STRING_SCHEMA: &str = "std_msgs/msg/String";
pub const STRING_DEFINITION: &str = "string data\n";

/// The decoder a build without the `ros2` feature has for MCAP: it reads nothing, counts every
/// byte as garbage and says why (the summary's `found` line, and one error in the log).
#[derive(Default)]
pub struct NoRos2Decoder {
    stats: super::DecoderStats,
    warned: bool,
}

impl super::ProtocolDecoder for NoRos2Decoder {
    fn protocol(&self) -> super::Protocol {
        super::Protocol::Mcap
    }
    fn decode_item(&mut self, buf: &mut bytes::BytesMut) -> Option<super::Decoded> {
        self.discard_tail(buf);
        None
    }
    fn discard_tail(&mut self, buf: &mut bytes::BytesMut) {
        if !self.warned {
            tracing::error!("{}", Self::WHY);
            self.warned = true;
        }
        self.stats.bytes_in += buf.len() as u64;
        self.stats.garbage_bytes += buf.len() as u64;
        buf.clear();
    }
    fn stats(&self) -> super::DecoderStats {
        self.stats
    }
    fn descriptor(&self) -> Option<super::Descriptor> {
        None
    }
    fn found(&self) -> String {
        Self::WHY.into()
    }
}

impl NoRos2Decoder {
    const WHY: &str = "MCAP (ROS 2 bag) input, but this build has no ROS 2 support: rebuild with `cargo build --release --features ros2`";
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(frame: &str) -> ImuMsg {
        ImuMsg {
            sec: 12,
            nanosec: 345_678_901,
            frame_id: frame.into(),
            orientation: [0.0, 0.0, 0.0, 1.0],
            orientation_covariance: [-1.0, 0., 0., 0., 0., 0., 0., 0., 0.],
            angular_velocity: [0.1, -0.2, 0.3],
            angular_velocity_covariance: [1e-6, 0., 0., 0., 2e-6, 0., 0., 0., 3e-6],
            linear_acceleration: [0.4, -0.5, 9.8],
            linear_acceleration_covariance: [4e-4, 0., 0., 0., 5e-4, 0., 0., 0., 6e-4],
            angular_velocity_at: 0,
            little_endian: true,
        }
    }

    #[test]
    fn round_trip_for_every_frame_id_length_and_patch_in_place() {
        for k in 0..20 {
            let frame: String = "f".repeat(k);
            let m = msg(&frame);
            let mut b = Vec::new();
            encode_imu(&m, &mut b);
            let d = decode_imu(&b).unwrap();
            assert_eq!(d.frame_id, frame);
            assert_eq!(d.angular_velocity, m.angular_velocity);
            assert_eq!(
                d.linear_acceleration_covariance,
                m.linear_acceleration_covariance
            );
            assert_eq!((d.angular_velocity_at - 4) % 8, 0, "aligned from byte 4");
            let mut s = Sample::default();
            s.set_channels(&[1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0]);
            patch_imu(&mut b, d.angular_velocity_at, true, &s);
            let p = decode_imu(&b).unwrap();
            assert_eq!(
                p.angular_velocity,
                [1.0, 2.0, 0.3],
                "NaN keeps the original"
            );
            assert_eq!(p.linear_acceleration, [4.0, 5.0, 6.0]);
            assert_eq!(p.angular_velocity_covariance, m.angular_velocity_covariance);
        }
    }

    #[test]
    fn truncated_and_foreign_payloads_are_errors_not_panics() {
        let mut b = Vec::new();
        encode_imu(&msg("imu"), &mut b);
        for n in 0..b.len() {
            assert!(decode_imu(&b[..n]).is_err(), "{n}");
        }
        let mut x = b.clone();
        x[1] = 3;
        assert_eq!(decode_imu(&x), Err(CdrError::Encapsulation(0, 3)));
        let mut y = b.clone();
        y[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(decode_imu(&y), Err(CdrError::FrameId(_))));
    }
}
