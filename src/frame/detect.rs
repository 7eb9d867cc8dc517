//! Choosing a decoder: `[source] protocol = "native" | "ubx" | "mavlink" | "ulog" | "mcap" |
//! "auto"` and the per-protocol options (`[source.ubx]`, `[source.mavlink]`, `[source.ulog]`,
//! `[source.mcap]`), the same
//! settings as command-line flags, and detection of the protocol from the first bytes.
//!
//! Detection feeds the first bytes (up to [`DETECT_BYTES`]) to every decoder and takes the one
//! that finds the most good frames (IMU samples counting double); a file magic (native log,
//! ULog, MCAP) decides at once.

use super::mavlink::{MavlinkDecoder, MavlinkOptions};
use super::protocol::{Decoded, Protocol, ProtocolDecoder};
use super::ros2::McapOptions;
use super::ubx::{UbxDecoder, UbxOptions};
use super::ulog::{UlogDecoder, UlogOptions};
use super::{DecoderStats, Descriptor, FrameDecoder, LOG_HEADER_LEN, LOG_MAGIC};
use crate::sample::{Sample, SampleSink};
use bytes::{Buf, BytesMut};

/// Bytes looked at to detect the protocol.
pub const DETECT_BYTES: usize = 4096;

/// `protocol` as configured: one of the protocols, or detect it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ProtocolChoice {
    #[default]
    Native,
    Ubx,
    Mavlink,
    Ulog,
    /// ROS 2 bag (MCAP) with sensor_msgs/msg/Imu; needs a build with `--features ros2`.
    Mcap,
    Auto,
}

/// The source's protocol and the options of each protocol.
#[derive(Clone, Debug, PartialEq, Default, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProtocolConfig {
    pub protocol: ProtocolChoice,
    pub ubx: UbxOptions,
    pub mavlink: MavlinkOptions,
    pub ulog: UlogOptions,
    pub mcap: McapOptions,
}

/// Keys of `[source]` that belong to [`ProtocolConfig`].
pub const SOURCE_KEYS: [&str; 5] = ["protocol", "ubx", "mavlink", "ulog", "mcap"];

impl ProtocolConfig {
    /// Default options, protocol detected from the first bytes.
    pub fn auto() -> Self {
        ProtocolConfig {
            protocol: ProtocolChoice::Auto,
            ..Default::default()
        }
    }

    /// A decoder for `p` with these options.
    pub fn decoder(&self, p: Protocol) -> Box<dyn ProtocolDecoder> {
        match p {
            Protocol::Native => Box::new(FrameDecoder::new()),
            Protocol::Ubx => Box::new(UbxDecoder::new(self.ubx)),
            Protocol::Mavlink => Box::new(MavlinkDecoder::new(self.mavlink.clone())),
            Protocol::Ulog => Box::new(UlogDecoder::new(self.ulog.clone())),
            #[cfg(feature = "ros2")]
            Protocol::Mcap => Box::new(super::mcap::McapDecoder::new(self.mcap.clone())),
            #[cfg(not(feature = "ros2"))]
            Protocol::Mcap => Box::new(super::ros2::NoRos2Decoder::default()),
        }
    }

    /// The configured protocol, or the one detected from `head` when `auto`.
    pub fn resolve(&self, head: &[u8]) -> Protocol {
        match self.protocol {
            ProtocolChoice::Native => Protocol::Native,
            ProtocolChoice::Ubx => Protocol::Ubx,
            ProtocolChoice::Mavlink => Protocol::Mavlink,
            ProtocolChoice::Ulog => Protocol::Ulog,
            ProtocolChoice::Mcap => Protocol::Mcap,
            ProtocolChoice::Auto => detect(head, self),
        }
    }

    /// Check option values; errors as (key path, message).
    pub fn validate(&self) -> Vec<(String, String)> {
        let mut e = Vec::new();
        let mut check = |ok: bool, k: &str, m: &str| {
            if !ok {
                e.push((format!("source.{k}"), m.to_string()));
            }
        };
        let u = &self.ubx;
        check(
            u.raw_tick_us.is_finite() && u.raw_tick_us > 0.0,
            "ubx.raw_tick_us",
            "must be > 0 µs",
        );
        check(
            u.meas_tick_us.is_finite() && u.meas_tick_us > 0.0,
            "ubx.meas_tick_us",
            "must be > 0 µs",
        );
        check(
            (1..=32).contains(&u.raw_tag_bits),
            "ubx.raw_tag_bits",
            "must be 1..32",
        );
        check(
            (1..=32).contains(&u.meas_tag_bits),
            "ubx.meas_tag_bits",
            "must be 1..32",
        );
        let m = &self.mavlink;
        check(
            m.message
                .as_deref()
                .is_none_or(|n| super::mavlink::message_id(n).is_some()),
            "mavlink.message",
            "must be highres_imu, scaled_imu, scaled_imu2, scaled_imu3 or raw_imu",
        );
        check(
            m.gyro_scale_rad_s >= 0.0 && m.accel_scale_m_s2 >= 0.0,
            "mavlink.gyro_scale_rad_s",
            "RAW_IMU scales must be ≥ 0",
        );
        check(
            m.message.as_deref() != Some("raw_imu")
                || (m.gyro_scale_rad_s > 0.0 && m.accel_scale_m_s2 > 0.0),
            "mavlink.message",
            "raw_imu needs gyro_scale_rad_s and accel_scale_m_s2 (raw counts have no unit)",
        );
        check(
            ["sensor_combined", "sensor_gyro"].contains(&self.ulog.topic.as_str()),
            "ulog.topic",
            "must be sensor_combined or sensor_gyro (paired with sensor_accel)",
        );
        check(
            ["header", "log"].contains(&self.mcap.time.as_str()),
            "mcap.time",
            "must be \"header\" (header.stamp) or \"log\" (the recorder's log time)",
        );
        check(
            cfg!(feature = "ros2") || self.protocol != ProtocolChoice::Mcap,
            "protocol",
            "mcap needs a build with ROS 2 support (cargo build --release --features ros2)",
        );
        for r in [u.rate_hz, m.rate_hz, self.ulog.rate_hz, self.mcap.rate_hz] {
            check(
                r.is_finite() && r >= 0.0,
                "rate_hz",
                "must be ≥ 0 Hz (0 = learn from time stamps)",
            );
        }
        e
    }
}

/// Command-line flags that set the protocol and its options (they override the config).
#[derive(Clone, Debug, Default, clap::Args)]
pub struct ProtocolArgs {
    /// Input protocol: native, ubx (u-blox ESF-RAW/ESF-MEAS), mavlink (HIGHRES_IMU, SCALED_IMU*,
    /// RAW_IMU), ulog (PX4 sensor_combined), mcap (ROS 2 bag, sensor_msgs/msg/Imu), or auto
    /// (detect from the first bytes).
    #[arg(long, value_enum)]
    pub protocol: Option<ProtocolChoice>,
    /// Topic: a ROS 2 topic (starts with `/`, e.g. /imu/data) for MCAP bags; for ULog
    /// sensor_combined, or sensor_gyro (paired with sensor_accel, with temperature).
    #[arg(long)]
    pub topic: Option<String>,
    /// IMU instance: ULog multi-instance id, MAVLink instance (SCALED_IMU2 = 1, HIGHRES_IMU id).
    #[arg(long)]
    pub instance: Option<u8>,
    /// MAVLink system id of the IMU to read (default: the first IMU stream seen).
    #[arg(long)]
    pub sysid: Option<u8>,
    /// MAVLink component id of the IMU to read.
    #[arg(long)]
    pub compid: Option<u8>,
    /// MAVLink message: highres_imu, scaled_imu, scaled_imu2, scaled_imu3, raw_imu.
    #[arg(long = "mavlink-message")]
    pub mavlink_message: Option<String>,
    /// RAW_IMU gyro scale, rad/s per count.
    #[arg(long = "raw-gyro-scale")]
    pub raw_gyro_scale: Option<f64>,
    /// RAW_IMU accel scale, m/s² per count.
    #[arg(long = "raw-accel-scale")]
    pub raw_accel_scale: Option<f64>,
    /// UBX ESF-RAW sensor time tag resolution, µs per count (default 39.0625).
    #[arg(long = "ubx-raw-tick-us")]
    pub ubx_raw_tick_us: Option<f64>,
}

impl ProtocolArgs {
    /// The flags given, by name (`--protocol`, `--topic`, …).
    pub fn given(&self) -> Vec<&'static str> {
        crate::text::flags_set([
            ("--protocol", self.protocol.is_some()),
            ("--topic", self.topic.is_some()),
            ("--instance", self.instance.is_some()),
            ("--sysid", self.sysid.is_some()),
            ("--compid", self.compid.is_some()),
            ("--mavlink-message", self.mavlink_message.is_some()),
            ("--raw-gyro-scale", self.raw_gyro_scale.is_some()),
            ("--raw-accel-scale", self.raw_accel_scale.is_some()),
            ("--ubx-raw-tick-us", self.ubx_raw_tick_us.is_some()),
        ])
    }

    /// Apply the flags given on top of `c`.
    pub fn apply(&self, c: &mut ProtocolConfig) {
        if let Some(p) = self.protocol {
            c.protocol = p;
        }
        if let Some(t) = &self.topic {
            // ROS 2 topic names are absolute (`/imu/data`); ULog topic names never start with `/`.
            if t.starts_with('/') || c.protocol == ProtocolChoice::Mcap {
                c.mcap.topic = Some(t.clone());
                // A ROS 2 topic names a bag: without --protocol, a native default means MCAP.
                if self.protocol.is_none() && c.protocol == ProtocolChoice::Native {
                    c.protocol = ProtocolChoice::Mcap;
                }
            } else {
                c.ulog.topic = t.clone();
            }
        }
        if let Some(i) = self.instance {
            c.ulog.instance = i;
            c.mavlink.instance = Some(i);
        }
        if self.sysid.is_some() {
            c.mavlink.sysid = self.sysid;
        }
        if self.compid.is_some() {
            c.mavlink.compid = self.compid;
        }
        if self.mavlink_message.is_some() {
            c.mavlink.message = self.mavlink_message.clone();
        }
        if let Some(v) = self.raw_gyro_scale {
            c.mavlink.gyro_scale_rad_s = v;
        }
        if let Some(v) = self.raw_accel_scale {
            c.mavlink.accel_scale_m_s2 = v;
        }
        if let Some(v) = self.ubx_raw_tick_us {
            c.ubx.raw_tick_us = v;
        }
    }
}

/// A recording format imuprep does not read, told by its first bytes, and what to do instead
/// (said where such a file decodes to nothing, instead of a count of garbage bytes).
pub fn foreign_format(head: &[u8]) -> Option<&'static str> {
    if head.starts_with(b"#ROSBAG V2.0") {
        Some(if cfg!(feature = "ros1") {
            "a ROS 1 bag, which the decoders do not stream: import it first (`imuprep import \
             IN.bag -o OUT.log`, `--topic /imu/data` to choose the Imu topic) and use OUT.log"
        } else {
            "a ROS 1 bag, which this build does not read: a build with `--features ros1` imports \
             it (`imuprep import IN.bag -o OUT.log`); or convert it to a ROS 2 bag in MCAP with \
             the Python rosbags package (`rosbags-convert --src IN.bag --dst OUT --dst-storage \
             mcap`) and import OUT/OUT.mcap (a build with `--features ros2`), or export its Imu \
             topic as CSV (`rostopic echo -b IN.bag -p /imu/data > imu.csv`) and import that"
        })
    } else if !cfg!(feature = "ros2") && head.starts_with(&super::ros2::MAGIC) {
        Some(
            "a ROS 2 bag (MCAP), which this build does not read: rebuild with `cargo build \
             --release --features ros2` and run the same command",
        )
    } else if head.starts_with(b"SQLite ") {
        Some(if cfg!(feature = "ros2-sqlite") {
            "an SQLite database (a ROS 2 bag's .db3?), which the decoders do not stream: import \
             it first (`imuprep import BAG_DIR -o OUT.log`, `--topic /imu/data` to choose the Imu \
             topic) and use OUT.log"
        } else {
            "an SQLite database (a ROS 2 bag's .db3?), which this build does not read: a build \
             with `--features ros2-sqlite` imports it (`imuprep import BAG_DIR -o OUT.log`); or \
             convert it (`ros2 bag convert`, or `rosbags-convert --src BAG_DIR --dst OUT \
             --dst-storage mcap`) and import the .mcap (a build with `--features ros2`)"
        })
    } else if head.starts_with(&[0x28, 0xB5, 0x2F, 0xFD]) {
        Some(if cfg!(any(feature = "ros2", feature = "ros2-sqlite")) {
            "a zstd-compressed file (rosbag2's file compression writes .mcap.zstd and .db3.zstd), \
             which the decoders do not stream: import it (`imuprep import FILE_OR_BAG_DIR -o \
             OUT.log`: inflated, then read as what it holds) and use OUT.log"
        } else {
            "a zstd-compressed file (rosbag2's file compression writes .mcap.zstd and .db3.zstd), \
             which this build does not read: a build with `--features ros2` (MCAP) or \
             `ros2-sqlite` (.db3) imports it (`imuprep import FILE_OR_BAG_DIR -o OUT.log`); or \
             inflate it first (`zstd -d FILE`) and use what it holds"
        })
    } else if head.starts_with(&[0x1F, 0x8B]) {
        // A gzipped text table named `.gz` is read as it is (by `import` and every command
        // that imports): this is said of one that holds something else, a log for one.
        Some(
            "a gzip-compressed file that holds no text table (a compressed log?): decompress it \
             (`gunzip -k FILE`) and use what it holds",
        )
    } else if head.starts_with(b"PK\x03\x04") {
        Some(
            "a zip archive (phone sensor apps export one): unpack it and import the table inside \
             (a file per sensor: `imuprep import Gyroscope.csv --accel-file \
             TotalAcceleration.csv -o OUT.log`)",
        )
    } else if head.starts_with(b"\x89HDF\r\n\x1a\n") {
        Some(
            "an HDF5 file, which imuprep does not read: write its IMU datasets as a table (t, gx, \
             gy, gz, ax, ay, az) and import that",
        )
    } else if head.starts_with(&[0xA3, 0x95, 0x80]) {
        Some(
            "an ArduPilot DataFlash log (.bin), which imuprep does not read: export its IMU \
             messages of one sensor as a table with pymavlink (`mavlogdump.py --types IMU \
             --condition 'IMU.I==0' --format csv LOG.bin > imu.csv`) and import that (TimeUS in \
             µs, GyrX.. in rad/s, AccX.. in m/s²)",
        )
    } else {
        None
    }
}

/// A recording `import` reads in this build but no streaming decoder does (a ROS 1 bag, a
/// ROS 2 bag in SQLite, a zstd-compressed bag file), told by its first bytes (as
/// [`foreign_format`] names them).
pub fn import_only(head: &[u8]) -> bool {
    (cfg!(feature = "ros1") && head.starts_with(b"#ROSBAG V2.0"))
        || (cfg!(feature = "ros2-sqlite") && head.starts_with(b"SQLite "))
        || (cfg!(any(feature = "ros2", feature = "ros2-sqlite"))
            && head.starts_with(&[0x28, 0xB5, 0x2F, 0xFD]))
}

/// The first bytes of `path` told as a [`foreign_format`] (nothing when it cannot be read).
pub fn foreign_file(path: &std::path::Path) -> Option<&'static str> {
    foreign_format(&file_head(path, 16)?)
}

/// The first `max` bytes of the file at `path` (all of a shorter one); `None` when it cannot be
/// read.
pub fn file_head(path: &std::path::Path, max: usize) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut head = Vec::with_capacity(max);
    std::fs::File::open(path)
        .ok()?
        .take(max as u64)
        .read_to_end(&mut head)
        .ok()?;
    Some(head)
}

/// The sensor protocol the first bytes of `path` decode as ([`detect`]), if not native.
pub fn file_protocol(path: &std::path::Path) -> Option<Protocol> {
    let p = detect(&file_head(path, DETECT_BYTES)?, &ProtocolConfig::auto());
    (p != Protocol::Native).then_some(p)
}

/// The protocol whose decoder finds the most in `head`.
pub fn detect(head: &[u8], c: &ProtocolConfig) -> Protocol {
    if head.starts_with(&LOG_MAGIC) {
        return Protocol::Native;
    }
    if head.starts_with(&super::ulog::MAGIC) {
        return Protocol::Ulog;
    }
    if head.starts_with(&super::ros2::MAGIC) {
        return Protocol::Mcap;
    }
    let mut best = (Protocol::Native, 0u64);
    for p in [Protocol::Native, Protocol::Ubx, Protocol::Mavlink] {
        let mut d = c.decoder(p);
        let mut buf = BytesMut::from(head);
        while d.decode_item(&mut buf).is_some() {}
        let st = d.stats();
        let score = st.frames_ok + st.samples;
        if score > best.1 {
            best = (p, score);
        }
    }
    best.0
}

/// Everything decoded from a whole byte string (a file): descriptor, samples, decoder counters,
/// the protocol used and what the decoder reports it found.
pub struct DecodedFile {
    pub protocol: Protocol,
    pub descriptor: Option<Descriptor>,
    pub samples: Vec<Sample>,
    pub stats: DecoderStats,
    pub found: String,
}

/// What decoding a file found besides its samples: the protocol used, the descriptor, the
/// decoder's counters and what the decoder reports it found ([`DecodedFile`]'s other fields).
pub struct FileDecoding {
    pub protocol: Protocol,
    pub descriptor: Option<Descriptor>,
    pub stats: DecoderStats,
    pub found: String,
}

impl FileDecoding {
    /// With the samples it was decoded to.
    pub fn with(self, samples: Vec<Sample>) -> DecodedFile {
        DecodedFile {
            protocol: self.protocol,
            descriptor: self.descriptor,
            samples,
            stats: self.stats,
            found: self.found,
        }
    }
}

impl DecodedFile {
    /// What was found besides the samples, and the samples.
    pub fn split(self) -> (FileDecoding, Vec<Sample>) {
        (
            FileDecoding {
                protocol: self.protocol,
                descriptor: self.descriptor,
                stats: self.stats,
                found: self.found,
            },
            self.samples,
        )
    }
}

/// Decode a whole file's bytes (a native log's file header is skipped).
pub fn decode_bytes(bytes: &[u8], c: &ProtocolConfig) -> DecodedFile {
    let mut samples = Vec::new();
    let mut d = Decoding::new(bytes, c);
    d.feed(bytes, true, &mut samples);
    d.finish().with(samples)
}

/// Bytes read from a file at a time by [`decode_file_into`] (at least [`DETECT_BYTES`], so the
/// first read holds what detection looks at).
const FILE_CHUNK: usize = 64 * 1024;

/// Decode the file at `path` as [`decode_bytes`] decodes its bytes — the same protocol, samples,
/// descriptor and counters — reading it 64 KiB at a time and handing each sample to `out` as it
/// is decoded, so that neither the file nor its samples need be held (a decoder that needs
/// more bytes says so and gets them, as the replay source's decoders do; at the file's end what
/// it holds is given out as [`decode_bytes`] gives it out).
pub fn decode_file_into(
    path: &std::path::Path,
    c: &ProtocolConfig,
    out: &mut impl SampleSink,
) -> std::io::Result<FileDecoding> {
    use std::io::Read;
    let named =
        |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    let mut f = std::fs::File::open(path).map_err(named)?;
    let mut buf = BytesMut::new();
    let mut read_more = |buf: &mut BytesMut| -> std::io::Result<bool> {
        let len = buf.len();
        buf.resize(len + FILE_CHUNK, 0);
        let mut n = 0;
        while n < FILE_CHUNK {
            match f.read(&mut buf[len + n..]) {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(named(e)),
            }
        }
        buf.truncate(len + n);
        Ok(n > 0)
    };
    let mut eof = !read_more(&mut buf)?;
    let mut dec = Decoding::new(&buf, c);
    if dec.protocol == Protocol::Native && buf.starts_with(&LOG_MAGIC) {
        buf.advance(LOG_HEADER_LEN.min(buf.len()));
    }
    loop {
        match dec.next(&mut buf, eof) {
            Some(item) => dec.take(item, out),
            None if eof => break,
            None => eof = !read_more(&mut buf)?,
        }
    }
    Ok(dec.finish())
}

/// Decode the files of one recording split in parts (rosbag2's `bag_0.mcap`, `bag_1.mcap`, …)
/// in the order given, through one decoder, as one stream: the protocol is told by the first
/// file; a file cut short ends at its own end (its tail counted and dropped) before the next
/// begins.
pub fn decode_files(
    paths: &[std::path::PathBuf],
    c: &ProtocolConfig,
) -> std::io::Result<DecodedFile> {
    let mut dec: Option<Decoding> = None;
    let mut samples = Vec::new();
    for (i, p) in paths.iter().enumerate() {
        let bytes = std::fs::read(p)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", p.display())))?;
        dec.get_or_insert_with(|| Decoding::new(&bytes, c)).feed(
            &bytes,
            i + 1 == paths.len(),
            &mut samples,
        );
    }
    let d = dec.ok_or_else(|| std::io::Error::other("no file to decode"))?;
    Ok(d.finish().with(samples))
}

/// One decoder over a file's bytes, or several files' in turn, handing on the samples it
/// decodes and gathering the descriptor.
struct Decoding {
    protocol: Protocol,
    d: Box<dyn ProtocolDecoder>,
    descriptor: Option<Descriptor>,
}

impl Decoding {
    /// The decoder for the protocol `first`'s head tells (or the configuration names).
    fn new(first: &[u8], c: &ProtocolConfig) -> Self {
        let protocol = c.resolve(&first[..first.len().min(DETECT_BYTES)]);
        Decoding {
            protocol,
            d: c.decoder(protocol),
            descriptor: None,
        }
    }

    /// The next item at the front of `buf` (`None`: more bytes are needed); `eof`: no more will
    /// come (what cannot complete is counted and dropped, what the decoder holds given out).
    fn next(&mut self, buf: &mut BytesMut, eof: bool) -> Option<Decoded> {
        if eof {
            self.d.decode_item_eof(buf)
        } else {
            self.d.decode_item(buf)
        }
    }

    /// One decoded item: a sample to `out`; the first descriptor, with the channels a later
    /// one declared present again (a channel that came late is part of the file:
    /// `Stamper::stamp`).
    fn take(&mut self, item: Decoded, out: &mut impl SampleSink) {
        match item {
            Decoded::Sample(s, _) => out.push(s),
            Decoded::Descriptor(x) => {
                self.descriptor = Some(self.descriptor.map_or(x, |d: Descriptor| Descriptor {
                    absent: d.absent & x.absent,
                    ..d
                }))
            }
            Decoded::Other(_) => {}
        }
    }

    /// Decode `bytes`, its samples to `out`; `last`: no more will come (what the decoder holds
    /// is given out).
    fn feed(&mut self, bytes: &[u8], last: bool, out: &mut impl SampleSink) {
        let body = if self.protocol == Protocol::Native && bytes.starts_with(&LOG_MAGIC) {
            &bytes[LOG_HEADER_LEN.min(bytes.len())..]
        } else {
            bytes
        };
        let mut buf = BytesMut::from(body);
        loop {
            match self.next(&mut buf, last) {
                Some(item) => self.take(item, out),
                // A part that ends inside a record: its tail is dropped (counted) here, not
                // completed with the next part's bytes.
                None if !last && !buf.is_empty() => {
                    let before = buf.len();
                    self.d.discard_tail(&mut buf);
                    // Every decoder's discard_tail takes at least a byte; a guard, not a path.
                    if buf.len() == before {
                        break;
                    }
                }
                None => break,
            }
        }
    }

    fn finish(self) -> FileDecoding {
        FileDecoding {
            protocol: self.protocol,
            descriptor: self.descriptor.or(self.d.descriptor()),
            stats: self.d.stats(),
            found: self.d.found(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ros2_topic_without_protocol_reads_a_bag() {
        let args = |p: Option<ProtocolChoice>, t: &str| ProtocolArgs {
            protocol: p,
            topic: Some(t.into()),
            ..ProtocolArgs::default()
        };
        let mut c = ProtocolConfig::default();
        args(None, "/imu/data").apply(&mut c);
        assert_eq!(c.protocol, ProtocolChoice::Mcap);
        assert_eq!(c.mcap.topic.as_deref(), Some("/imu/data"));
        // An explicit protocol, or a ULog topic, is left alone.
        let mut c = ProtocolConfig::default();
        args(Some(ProtocolChoice::Auto), "/imu/data").apply(&mut c);
        assert_eq!(c.protocol, ProtocolChoice::Auto);
        let mut c = ProtocolConfig::default();
        args(None, "sensor_gyro").apply(&mut c);
        assert_eq!(c.protocol, ProtocolChoice::Native);
        assert_eq!(c.ulog.topic, "sensor_gyro");
    }
}
