//! The MCAP sink (`--out mcap:PATH`, `[[sinks]] kind = "mcap"`): a ROS 2 bag file (profile
//! `ros2`) with the cleaned samples as `sensor_msgs/msg/Imu` and a health topic, written with
//! the `mcap` crate (chunked, indexed, uncompressed, CRCs on), readable by `ros2 bag`, rosbags,
//! Foxglove. With `compression = "lz4"` or `"zstd"` (`--out mcap+lz4:PATH`, `mcap+zstd:PATH`)
//! the chunks are LZ4 or zstd frames: the `mcap` crate writes compressed chunks only with its
//! C-built features, so then the records are made here and written by imuprep's own indexed
//! MCAP writer ([`McapStream`], the inline output's; `lz4_flex`, `ruzstd`): same schemas, channels, messages, chunk and message indexes,
//! statistics and summary, in every `ros2` build.
//!
//! Imu messages: `header.stamp` = the sample's sensor time, `frame_id` as configured,
//! orientation unknown (`orientation_covariance[0] = -1`, the message's convention),
//! angular velocity and linear acceleration cleaned, and on the two covariance diagonals the
//! variance of the published bias estimate (σ² of `bias_sd`, per axis; all zero = unknown, as
//! ROS reads it, while the bias stage has no estimate); a triad the sensor does not have (all
//! three channels absent, a gyro-only or accel-only sensor) has `covariance[0] = -1`, the
//! message's "no data", and zero values. Axes are ROS's FLU: a sensor that
//! declared FRD has y and z negated. The log time is the sensor time too (deterministic).
//!
//! Health: `std_msgs/msg/String` with one JSON object per second of sensor time (and one at the
//! end): time, samples so far, how many carried each fault flag, and the current bias with its
//! σ. JSON in a String (not `diagnostic_msgs`) so any tool can print it and a script can parse
//! it without ROS message definitions.

use crate::frame::mcap_out::{ChunkCompression, McapStream};
use crate::frame::ros2::{self, ImuMsg};
use crate::frame::{AxisConvention, Descriptor};
use crate::sample::{Sample, flags};
use std::collections::BTreeMap;
use std::io::{Seek, Write};

/// Topics and frame of the bag.
#[derive(Clone, Debug, PartialEq)]
pub struct McapSinkOptions {
    pub topic: String,
    pub frame_id: String,
    pub health_topic: String,
    /// Chunk compression: none (the `mcap` crate's writer) or LZ4 ([`McapStream`]).
    pub compression: ChunkCompression,
}

impl Default for McapSinkOptions {
    fn default() -> Self {
        McapSinkOptions {
            topic: "/imu/clean".into(),
            frame_id: "imu_link".into(),
            health_topic: "/imuprep/health".into(),
            compression: ChunkCompression::None,
        }
    }
}

/// Health published once per this much sensor time.
const HEALTH_PERIOD_NS: u64 = 1_000_000_000;

#[derive(Default, Clone, Copy)]
struct Counts {
    samples: u64,
    gap: u64,
    duplicate: u64,
    non_finite: u64,
    saturated: u64,
    replaced: u64,
    suspect: u64,
    repeated: u64,
}

/// Where the records go: the `mcap` crate's writer (uncompressed chunks; it seeks back to
/// finish them), or imuprep's own stream writer (compressed chunks; front to back). One per
/// sink, so the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum Out<W: Write + Seek> {
    Crate(::mcap::Writer<W>),
    Stream {
        s: McapStream,
        w: W,
        buf: bytes::BytesMut,
    },
}

/// Append a length-prefixed (u32) string.
fn put_str(b: &mut Vec<u8>, v: &str) {
    b.extend_from_slice(&(v.len() as u32).to_le_bytes());
    b.extend_from_slice(v.as_bytes());
}

/// One MCAP record: opcode, u64 length, body.
fn record(op: u8, body: &[u8]) -> Vec<u8> {
    let mut r = Vec::with_capacity(9 + body.len());
    r.push(op);
    r.extend_from_slice(&(body.len() as u64).to_le_bytes());
    r.extend_from_slice(body);
    r
}

/// The ROS 2 profile's (empty) QoS entry in each channel's metadata, as rosbag2 writes it.
const QOS_KEY: &str = "offered_qos_profiles";
/// Ids of the stream writer's schemas (Imu, String) and channels (Imu, health).
const STREAM_SCHEMAS: [u16; 2] = [1, 2];
const STREAM_CHANNELS: [u16; 2] = [0, 1];
/// The bag header's `library`.
const LIBRARY: &str = concat!("imuprep ", env!("CARGO_PKG_VERSION"));

impl<W: Write + Seek> Out<W> {
    /// The stream writer: magic, header, both schemas and channels.
    fn stream(w: W, c: ChunkCompression, opts: &McapSinkOptions) -> std::io::Result<Self> {
        let mut o = Out::Stream {
            s: McapStream::with_compression(c),
            w,
            buf: bytes::BytesMut::new(),
        };
        o.put(&ros2::MAGIC)?;
        let mut h = Vec::new();
        put_str(&mut h, "ros2");
        put_str(&mut h, LIBRARY);
        o.put(&record(0x01, &h))?;
        let defs = [
            (ros2::IMU_SCHEMA, ros2::IMU_DEFINITION),
            (ros2::STRING_SCHEMA, ros2::STRING_DEFINITION),
        ];
        for (id, (name, def)) in STREAM_SCHEMAS.iter().zip(defs) {
            let mut b = id.to_le_bytes().to_vec();
            put_str(&mut b, name);
            put_str(&mut b, "ros2msg");
            put_str(&mut b, def);
            o.put(&record(0x03, &b))?;
        }
        let topics = [&opts.topic, &opts.health_topic];
        for ((id, schema), topic) in STREAM_CHANNELS.iter().zip(STREAM_SCHEMAS).zip(topics) {
            let mut b = id.to_le_bytes().to_vec();
            b.extend_from_slice(&schema.to_le_bytes());
            put_str(&mut b, topic);
            put_str(&mut b, "cdr");
            let mut map = Vec::new();
            put_str(&mut map, QOS_KEY);
            put_str(&mut map, "");
            b.extend_from_slice(&(map.len() as u32).to_le_bytes());
            b.extend_from_slice(&map);
            o.put(&record(0x04, &b))?;
        }
        Ok(o)
    }

    /// One record (or the magic) into the stream writer; what it writes goes to the file.
    fn put(&mut self, rec: &[u8]) -> std::io::Result<()> {
        if let Out::Stream { s, w, buf } = self {
            s.other(rec, buf);
            if !buf.is_empty() {
                w.write_all(buf)?;
                buf.clear();
            }
        }
        Ok(())
    }

    fn message(
        &mut self,
        h: &::mcap::records::MessageHeader,
        data: &[u8],
    ) -> ::mcap::McapResult<()> {
        if let Out::Crate(w) = self {
            return w.write_to_known_channel(h, data);
        }
        let mut b = Vec::with_capacity(22 + data.len());
        b.extend_from_slice(&h.channel_id.to_le_bytes());
        b.extend_from_slice(&h.sequence.to_le_bytes());
        b.extend_from_slice(&h.log_time.to_le_bytes());
        b.extend_from_slice(&h.publish_time.to_le_bytes());
        b.extend_from_slice(data);
        Ok(self.put(&record(0x05, &b))?)
    }

    fn finish(self) -> ::mcap::McapResult<W> {
        match self {
            Out::Crate(mut w) => {
                w.finish()?;
                Ok(w.into_inner())
            }
            Out::Stream {
                mut s,
                mut w,
                mut buf,
            } => {
                s.finish(&mut buf);
                w.write_all(&buf)?;
                w.flush()?;
                Ok(w)
            }
        }
    }
}

/// Writes samples into a ROS 2 MCAP bag.
pub struct ImuBagWriter<W: Write + Seek> {
    w: Out<W>,
    opts: McapSinkOptions,
    imu: u16,
    health: u16,
    seq: u32,
    hseq: u32,
    frd: bool,
    counts: Counts,
    next_health: Option<u64>,
    last: Option<Sample>,
    buf: Vec<u8>,
}

impl<W: Write + Seek> ImuBagWriter<W> {
    pub fn new(w: W, opts: McapSinkOptions) -> ::mcap::McapResult<Self> {
        let (w, imu, health) = if opts.compression == ChunkCompression::None {
            let mut w = ::mcap::WriteOptions::new()
                .compression(None)
                .profile("ros2")
                .library(LIBRARY)
                .create(w)?;
            let meta: BTreeMap<String, String> = [(QOS_KEY.to_string(), String::new())].into();
            let imu_def = ros2::IMU_DEFINITION.as_bytes();
            let s_imu = w.add_schema(ros2::IMU_SCHEMA, "ros2msg", imu_def)?;
            let str_def = ros2::STRING_DEFINITION.as_bytes();
            let s_str = w.add_schema(ros2::STRING_SCHEMA, "ros2msg", str_def)?;
            let imu = w.add_channel(s_imu, &opts.topic, "cdr", &meta)?;
            let health = w.add_channel(s_str, &opts.health_topic, "cdr", &meta)?;
            (Out::Crate(w), imu, health)
        } else {
            let [imu, health] = STREAM_CHANNELS;
            (Out::stream(w, opts.compression, &opts)?, imu, health)
        };
        Ok(ImuBagWriter {
            w,
            opts,
            imu,
            health,
            seq: 0,
            hseq: 0,
            frd: false,
            counts: Counts::default(),
            next_health: None,
            last: None,
            buf: Vec::with_capacity(512),
        })
    }

    /// The sensor's declaration: FRD axes are turned to ROS's FLU.
    pub fn descriptor(&mut self, d: &Descriptor) {
        self.frd = d.axes == AxisConvention::Frd;
    }

    /// The Imu message for `s` (values as written: FLU).
    pub fn imu_msg(&self, s: &Sample) -> ImuMsg {
        let sign = |c: usize| {
            if self.frd && !c.is_multiple_of(3) {
                -1.0
            } else {
                1.0
            }
        };
        let ch = s.channels();
        let v = |c: usize| ch[c] * sign(c);
        let var = |c: usize| {
            let sd = s.bias_sd[c] as f64;
            if sd.is_finite() { sd * sd } else { 0.0 }
        };
        let diag = |c0: usize| {
            let mut m = [0.0; 9];
            m[0] = var(c0);
            m[4] = var(c0 + 1);
            m[8] = var(c0 + 2);
            m
        };
        let mut oc = [0.0; 9];
        oc[0] = -1.0;
        // A triad the sensor does not have (every axis absent): "no data" by the message's own
        // convention, covariance[0] = -1 (values 0, to be ignored); a single absent axis of a
        // present triad stays NaN.
        let triad_absent = |c0: usize| (c0..c0 + 3).all(|c| s.is_absent(c));
        let (mut av, mut avc) = ([v(0), v(1), v(2)], diag(0));
        if triad_absent(0) {
            (av, avc) = ([0.0; 3], oc);
        }
        let (mut la, mut lac) = ([v(3), v(4), v(5)], diag(3));
        if triad_absent(3) {
            (la, lac) = ([0.0; 3], oc);
        }
        ImuMsg {
            sec: (s.t_ns / 1_000_000_000) as i32,
            nanosec: (s.t_ns % 1_000_000_000) as u32,
            frame_id: self.opts.frame_id.clone(),
            orientation: [0.0, 0.0, 0.0, 1.0],
            orientation_covariance: oc,
            angular_velocity: av,
            angular_velocity_covariance: avc,
            linear_acceleration: la,
            linear_acceleration_covariance: lac,
            angular_velocity_at: 0,
            little_endian: true,
        }
    }

    pub fn sample(&mut self, s: &Sample) -> ::mcap::McapResult<()> {
        self.buf.clear();
        let m = self.imu_msg(s);
        ros2::encode_imu(&m, &mut self.buf);
        let h = ::mcap::records::MessageHeader {
            channel_id: self.imu,
            sequence: self.seq,
            log_time: s.t_ns,
            publish_time: s.t_ns,
        };
        self.seq = self.seq.wrapping_add(1);
        self.w.message(&h, &self.buf)?;
        let c = &mut self.counts;
        c.samples += 1;
        let f = s.flags;
        let n = |bit: u32, k: &mut u64| *k += u64::from(f & bit != 0);
        n(flags::GAP, &mut c.gap);
        n(flags::DUPLICATE, &mut c.duplicate);
        n(flags::NON_FINITE, &mut c.non_finite);
        n(flags::SAT_ANY, &mut c.saturated);
        n(flags::REPLACED, &mut c.replaced);
        n(flags::SUSPECT_ANY, &mut c.suspect);
        n(flags::REPEATED, &mut c.repeated);
        self.last = Some(*s);
        let due = *self.next_health.get_or_insert(s.t_ns + HEALTH_PERIOD_NS);
        if s.t_ns >= due {
            self.write_health()?;
            self.next_health = Some(s.t_ns + HEALTH_PERIOD_NS);
        }
        Ok(())
    }

    /// The health JSON for the state now.
    pub fn health_json(&self) -> String {
        let c = self.counts;
        let (t, bias, sd) = match &self.last {
            Some(s) => (s.t_ns, s.bias, s.bias_sd),
            None => (0, [0.0; 6], [0.0; 6]),
        };
        let j = serde_json::json!({
            "t_ns": t,
            "samples": c.samples,
            "gap": c.gap,
            "duplicate": c.duplicate,
            "non_finite": c.non_finite,
            "saturated": c.saturated,
            "replaced": c.replaced,
            "suspect": c.suspect,
            "repeated": c.repeated,
            "bias": bias.map(|v| if v.is_finite() { v as f64 } else { 0.0 }),
            "bias_sd": sd.map(|v| if v.is_finite() { v as f64 } else { 0.0 }),
        });
        j.to_string()
    }

    fn write_health(&mut self) -> ::mcap::McapResult<()> {
        let t = self.last.map_or(0, |s| s.t_ns);
        let mut b = Vec::new();
        ros2::encode_string(&self.health_json(), &mut b);
        let h = ::mcap::records::MessageHeader {
            channel_id: self.health,
            sequence: self.hseq,
            log_time: t,
            publish_time: t,
        };
        self.hseq = self.hseq.wrapping_add(1);
        self.w.message(&h, &b)
    }

    /// Last health message, summary section, closing magic.
    pub fn finish(mut self) -> ::mcap::McapResult<W> {
        if self.counts.samples > 0 {
            self.write_health()?;
        }
        self.w.finish()
    }
}

/// A whole bag in memory (for `export --to mcap`).
pub fn encode_bag(
    d: &Descriptor,
    samples: &[Sample],
    opts: McapSinkOptions,
) -> ::mcap::McapResult<Vec<u8>> {
    let mut w = ImuBagWriter::new(std::io::Cursor::new(Vec::new()), opts)?;
    w.descriptor(d);
    for s in samples {
        w.sample(s)?;
    }
    Ok(w.finish()?.into_inner())
}

/// The sink task: a blocking thread that owns the file (the `mcap` writer is synchronous and
/// seeks back to finish chunks).
pub fn start(
    path: std::path::PathBuf,
    opts: McapSinkOptions,
    mut rx: tokio::sync::mpsc::Receiver<super::sink::SinkItem>,
    stats: std::sync::Arc<super::sink::SinkStats>,
) -> std::io::Result<tokio::task::JoinHandle<()>> {
    use std::sync::atomic::Ordering::Relaxed;
    let f = std::fs::File::create(&path)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    let mut w = ImuBagWriter::new(std::io::BufWriter::with_capacity(1 << 16, f), opts)
        .map_err(|e| std::io::Error::other(format!("{}: {e}", path.display())))?;
    Ok(tokio::task::spawn_blocking(move || {
        let mut failed = false;
        while let Some(item) = rx.blocking_recv() {
            match item {
                super::sink::SinkItem::Descriptor(d) => w.descriptor(&d),
                super::sink::SinkItem::Samples(b) if !failed => {
                    for s in b.iter() {
                        if let Err(e) = w.sample(s) {
                            tracing::error!("mcap sink {}: {e}", path.display());
                            stats.errors.fetch_add(1, Relaxed);
                            failed = true;
                            break;
                        }
                    }
                    stats.samples_out.fetch_add(b.len() as u64, Relaxed);
                }
                _ => {}
            }
        }
        if let Err(e) = w.finish() {
            tracing::error!("mcap sink {}: {e}", path.display());
            stats.errors.fetch_add(1, Relaxed);
        }
    }))
}
