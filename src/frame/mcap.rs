//! ROS 2 bags in MCAP: IMU samples from the `sensor_msgs/msg/Imu` (CDR) messages of one topic;
//! every other record passes through whole, in order.
//!
//! ```text
//! file  : magic 89 "MCAP0" 0D 0A | records | magic
//! record: opcode u8 | length u64 LE | body
//!   01 header  03 schema  04 channel  05 message (channel id, sequence, log time, publish time,
//!   data)  06 chunk (records, possibly compressed, with a CRC-32 of the uncompressed bytes)
//!   07..0E indexes, attachments, metadata, statistics   0F data end   02 footer
//! ```
//!
//! The records are framed here (so that a bad record is counted and the search restarts one
//! byte after it, and each record's bytes are kept for pass-through); their bodies are parsed by
//! the `mcap` crate. LZ4 and zstd chunks are inflated by pure-Rust crates ([`super::inflate`])
//! in every `ros2` build. The records inside a chunk come out one by one, as if the file had no
//! chunks. A message compressed on its own (rosbag2's `compression_mode: message`: the data is
//! one zstd frame) is inflated, and the inline output compresses its cleaned form again. A chunk
//! whose CRC fails, or that does not inflate, is dropped whole (counted): its messages cannot be
//! trusted. MCAP records outside chunks carry no checksum; as for ULog, an implausible record
//! (reserved opcode, impossible length, a message on a channel never declared) is a fault.
//!
//! The topic read is `[source.mcap] topic` (`--topic /imu/data`), else the first channel whose
//! schema is `sensor_msgs/msg/Imu` in CDR. Time is `header.stamp` (the message's log time when
//! the stamp is zero, or always with `time = "log"`); sequence and gap flags come from it.
//! The sample carries angular velocity and linear acceleration; orientation and the three
//! covariance matrices stay in the carrier (the original message), so inline output keeps them.
//! A vector whose covariance has −1 in element 0 ("data not available", the message's own
//! convention, as the MCAP sink writes a triad the sensor lacks) gives three absent channels.

use super::Descriptor;
use super::framing::{Fault, Framer, Stamper};
use super::inflate;
use super::protocol::{Carrier, Decoded, Protocol, ProtocolDecoder};
use super::ros2;
use crate::sample::Sample;
use crate::text::count;
use bytes::{Bytes, BytesMut};
use std::collections::{HashMap, VecDeque};

/// Temperature readings kept for the join (a reading logged ahead of the Imu messages it
/// belongs to must not hide the one before it).
const TEMP_HISTORY: usize = 8;
use std::ops::Range;

pub use super::ros2::{MAGIC, MAX_RECORD, McapOptions};
pub const OP_HEADER: u8 = 0x01;
pub const OP_FOOTER: u8 = 0x02;
pub const OP_SCHEMA: u8 = 0x03;
pub const OP_CHANNEL: u8 = 0x04;
pub const OP_MESSAGE: u8 = 0x05;
pub const OP_CHUNK: u8 = 0x06;
pub const OP_DATA_END: u8 = 0x0F;

/// Smallest body of each record type (fixed fields with empty strings and maps).
fn min_len(op: u8) -> Option<u64> {
    Some(match op {
        0x01 => 8,
        0x02 => 20,
        0x03 => 2 + 4 + 4 + 4,
        0x04 => 2 + 2 + 4 + 4 + 4,
        0x05 => 2 + 4 + 8 + 8,
        0x06 => 8 + 8 + 8 + 4 + 4 + 8,
        0x07 => 2 + 4,
        0x08 => 8 * 4 + 4 + 8 + 4 + 8 + 8,
        0x09 => 8 + 8 + 4 + 4 + 8 + 4,
        0x0A => 8 * 5 + 4 + 4,
        0x0B => 8 + 2 + 4 * 4 + 8 + 8 + 4,
        0x0C => 4 + 4,
        0x0D => 8 + 8 + 4,
        0x0E => 1 + 8 + 8,
        0x0F => 4,
        0x80..=0xFF => 0,
        _ => return None,
    })
}

/// What a well-formed record is, once its content has been checked.
enum Rec {
    /// Passed through (schemas and channels are learned on the way).
    Other,
    /// A message of the selected Imu channel, with its log time.
    Imu(u64),
    /// A message of the selected Temperature channel, with its log time.
    Temperature(u64),
    /// An uncompressed chunk: where its records are in the chunk record.
    Chunk(Range<usize>),
    /// A compressed chunk, decompressed.
    Inflated(Vec<u8>),
    /// A compressed chunk this build cannot decompress: passed through whole.
    Undecodable,
    /// A chunk whose CRC failed: dropped whole (counted).
    Corrupt,
    /// A chunk in a compression read here that does not inflate: dropped whole (counted).
    Damaged(String),
}

#[derive(Clone, Debug)]
struct Channel {
    topic: String,
    schema_id: u16,
    encoding: String,
}

/// Decoder for an MCAP stream (a file read front to back, or stdin).
pub struct McapDecoder {
    opts: McapOptions,
    /// `time = "header"`: the stamp, else the log time.
    header_time: bool,
    f: Framer,
    stamper: Stamper,
    magic_done: bool,
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, Channel>,
    selected: Option<u16>,
    /// The topics chosen (the Imu topic read, the Temperature topic joined), once chosen.
    imu_topic: Option<String>,
    temp_topic: Option<String>,
    /// The Temperature channel joined to the samples.
    temp_channel: Option<u16>,
    /// The latest temperature readings so far, oldest first: (time, °C).
    temp: VecDeque<(u64, f64)>,
    temp_msgs: u64,
    bad_temp: u64,
    /// Records of the chunk being read (uncompressed), and the read position in them.
    chunk: Option<(Bytes, usize)>,
    chunks: u64,
    /// Chunks inflated (LZ4 or zstd), and Imu messages compressed one by one (zstd).
    inflated_chunks: u64,
    compressed_msgs: u64,
    /// Compressed chunks that did not inflate (dropped).
    damaged_chunks: u64,
    unsupported: Vec<String>,
    bad_cdr: u64,
}

super::protocol::default_from_options!(McapDecoder, McapOptions);

impl McapDecoder {
    pub fn new(opts: McapOptions) -> Self {
        McapDecoder {
            stamper: Stamper::new(opts.rate_hz),
            header_time: opts.time == "header",
            opts,
            f: Framer::default(),
            magic_done: false,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            selected: None,
            imu_topic: None,
            temp_topic: None,
            temp_channel: None,
            temp: VecDeque::new(),
            temp_msgs: 0,
            bad_temp: 0,
            chunk: None,
            chunks: 0,
            inflated_chunks: 0,
            compressed_msgs: 0,
            damaged_chunks: 0,
            unsupported: Vec::new(),
            bad_cdr: 0,
        }
    }

    fn other(&mut self, b: Bytes) -> Decoded {
        self.f.count_other(&b);
        Decoded::Other(b)
    }

    fn has_schema(&self, c: &Channel, name: &str) -> bool {
        c.encoding == "cdr" && self.schemas.get(&c.schema_id).is_some_and(|s| s == name)
    }

    fn is_imu(&self, c: &Channel) -> bool {
        self.has_schema(c, ros2::IMU_SCHEMA)
    }

    fn add_channel(&mut self, id: u16, c: Channel) {
        // The channels chosen are kept by topic: a second file appended (a split bag read as
        // one) numbers its channels its own way, and an id chosen in the first file may name
        // another topic in the next. A re-declared id leaves the choice until its topic's
        // channel comes again.
        let other_topic = self.channels.get(&id).is_some_and(|x| x.topic != c.topic);
        if other_topic && self.temp_channel == Some(id) {
            self.temp_channel = None;
        }
        if other_topic && self.selected == Some(id) {
            self.selected = None;
        }
        if self.temp_channel.is_none() && self.has_schema(&c, ros2::TEMPERATURE_SCHEMA) {
            let wanted = match (&self.temp_topic, self.opts.temperature_topic.as_deref()) {
                (Some(t), _) => *t == c.topic,
                (None, Some(t)) => t == c.topic,
                (None, None) => true,
            };
            if wanted {
                self.temp_channel = Some(id);
                self.temp_topic = Some(c.topic.clone());
            }
        }
        if self.selected.is_none() && self.is_imu(&c) {
            let wanted = match (&self.imu_topic, &self.opts.topic) {
                (Some(t), _) | (None, Some(t)) => *t == c.topic,
                (None, None) => true,
            };
            if wanted {
                self.selected = Some(id);
                self.imu_topic = Some(c.topic.clone());
            }
        }
        self.channels.insert(id, c);
    }

    /// The time of a message: its header stamp (`time = "header"`, when the stamp is positive),
    /// else its log time.
    fn time_of(&self, sec: i32, nsec: u32, log_time: u64) -> u64 {
        let stamp = (sec as i64)
            .checked_mul(1_000_000_000)
            .and_then(|s| s.checked_add(nsec as i64))
            .filter(|t| *t > 0 && nsec < 1_000_000_000);
        match stamp {
            Some(t) if self.header_time => t as u64,
            _ => log_time,
        }
    }

    /// A reading of the Temperature channel, kept in time order among the latest few.
    fn temperature(&mut self, rec: &[u8], log_time: u64) {
        match ros2::decode_temperature(&inflate::message(&rec[9 + 22..])) {
            Ok((sec, nsec, c)) if c.is_finite() => {
                let t = self.time_of(sec, nsec, log_time);
                self.temp_msgs += 1;
                let at = self.temp.partition_point(|(t0, _)| *t0 <= t);
                self.temp.insert(at, (t, c));
                if self.temp.len() > TEMP_HISTORY {
                    self.temp.pop_front();
                }
            }
            _ => self.bad_temp += 1,
        }
    }

    /// The temperature for a sample at `t_ns`: the reading with the nearest preceding (or
    /// equal) time among those read so far, unless older than `temperature_max_age_s`.
    fn temperature_at(&self, t_ns: u64) -> Option<f64> {
        let &(t, c) = self.temp.iter().rev().find(|(t, _)| *t <= t_ns)?;
        let max_age = self.opts.temperature_max_age_s;
        let fresh = max_age <= 0.0 || ((t_ns - t) as f64) <= max_age * 1e9;
        fresh.then_some(c)
    }

    /// A sample from a message record of the selected channel.
    fn message(&mut self, rec: Bytes, log_time: u64) -> Decoded {
        let cdr = inflate::message(&rec[9 + 22..]);
        let compressed = matches!(cdr, std::borrow::Cow::Owned(_));
        let m = match ros2::decode_imu_fast(&cdr) {
            Ok(x) => x,
            Err(_) => {
                self.bad_cdr += 1;
                self.f.stats.bad_payload += 1;
                return self.other(rec);
            }
        };
        let (g, le) = (m.angular_velocity_at, m.little_endian);
        let t_ns = self.time_of(m.sec, m.nanosec, log_time);
        let mut s = Sample {
            t_ns,
            temp_c: self.temperature_at(t_ns),
            ..Sample::default()
        };
        s.set_channels(&m.channels);
        // A vector the message declares not available (covariance[0] = −1): absent channels.
        super::protocol::mark_absent(&mut s, m.absent);
        self.stamper.finish(&mut s, &mut self.f, || Descriptor {
            axes: super::AxisConvention::Flu,
            ..Descriptor::default()
        });
        self.f.stats.frames_ok += 1;
        self.compressed_msgs += u64::from(compressed);
        // Compressed: the offset is in the inflated data, which the inline output re-inflates.
        let at = if compressed { g } else { 9 + 22 + g };
        let c = Carrier {
            frame: rec,
            frame2: None,
            between: None,
            slot: 0,
            slots: 1,
            // offset of angular_velocity.x in the record (in the inflated data when the data
            // is compressed); compressed; byte order; not patchable.
            offsets: [
                at.min(u16::MAX as usize) as u16,
                u16::from(compressed),
                u16::from(!le),
                u16::from(at > u16::MAX as usize - 200),
            ],
            raw_scale: None,
        };
        Decoded::Sample(s, Some(c))
    }

    /// Check one whole record (`rec` = opcode, length, body) and learn what it declares.
    /// `Err(())` = implausible content (a fault).
    fn record(&mut self, rec: &[u8], in_chunk: bool) -> Result<Rec, ()> {
        let op = rec[0];
        let body = &rec[9..];
        if op == OP_MESSAGE {
            // The hot path, read here: channel id u16, sequence u32, log time u64, publish
            // time u64, data (the framing checked the 22 bytes are there).
            let channel = u16::from_le_bytes([body[0], body[1]]);
            let log_time = u64::from_le_bytes(body[6..14].try_into().expect("8 bytes"));
            if Some(channel) == self.selected {
                return Ok(Rec::Imu(log_time));
            }
            if Some(channel) == self.temp_channel {
                return Ok(Rec::Temperature(log_time));
            }
            if !in_chunk && !self.channels.contains_key(&channel) {
                return Err(());
            }
            return Ok(Rec::Other);
        }
        // Only the records this decoder uses go through the crate's parser: its parsers of the
        // others (attachments, indexes, …) can panic on a truncated body (fuzzing found
        // `mcap` 0.26 slicing an attachment body before checking its length), and their
        // content is not needed — they pass by, counted.
        if !matches!(op, OP_SCHEMA | OP_CHANNEL | OP_CHUNK) {
            return Ok(Rec::Other);
        }
        let parsed = ::mcap::parse_record(op, body).map_err(|_| ())?;
        use ::mcap::records::Record;
        match parsed {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => {
                let ch = Channel {
                    topic: c.topic,
                    schema_id: c.schema_id,
                    encoding: c.message_encoding,
                };
                self.add_channel(c.id, ch);
            }
            Record::Chunk { header, data } => {
                if in_chunk {
                    return Err(());
                }
                let start = data.as_ptr() as usize - rec.as_ptr() as usize;
                let len = data.len();
                let crc_ok = |records: &[u8]| {
                    header.uncompressed_crc == 0 || crc32(records) == header.uncompressed_crc
                };
                if header.compression.is_empty() {
                    if header.uncompressed_size != len as u64 {
                        return Err(());
                    }
                    if !crc_ok(&rec[start..start + len]) {
                        return Ok(Rec::Corrupt);
                    }
                    return Ok(Rec::Chunk(start..start + len));
                }
                let inflated = match header.compression.as_str() {
                    // A corrupt size must not allocate what it claims.
                    _ if header.uncompressed_size > MAX_RECORD => Err(format!(
                        "chunk claims {} bytes uncompressed",
                        header.uncompressed_size
                    )),
                    "lz4" => inflate::lz4(&data, header.uncompressed_size),
                    "zstd" => inflate::zstd_sized(&data, header.uncompressed_size),
                    name => {
                        // Not a compression MCAP defines: the chunk passes through whole.
                        let name = name.to_string();
                        if !self.unsupported.contains(&name) {
                            tracing::warn!(
                                "MCAP chunk compressed with {name:?}, which MCAP does not define (lz4, zstd): passed through"
                            );
                            self.unsupported.push(name);
                        }
                        return Ok(Rec::Undecodable);
                    }
                };
                return Ok(match inflated {
                    Ok(v) if crc_ok(&v) => Rec::Inflated(v),
                    Ok(_) => Rec::Corrupt,
                    Err(e) => Rec::Damaged(e),
                });
            }
            _ => {}
        }
        Ok(Rec::Other)
    }

    /// The item of a checked record (`None`: a chunk, now being read, or dropped).
    fn act(&mut self, rec: Bytes, what: Rec) -> Option<Decoded> {
        match what {
            Rec::Other => Some(self.other(rec)),
            Rec::Imu(log_time) => Some(self.message(rec, log_time)),
            Rec::Temperature(log_time) => {
                self.temperature(&rec, log_time);
                Some(self.other(rec))
            }
            Rec::Chunk(r) => {
                self.chunks += 1;
                self.chunk = Some((rec.slice(r), 0));
                None
            }
            Rec::Inflated(v) => {
                self.chunks += 1;
                self.inflated_chunks += 1;
                self.chunk = Some((Bytes::from(v), 0));
                None
            }
            Rec::Undecodable => {
                self.f.stats.unknown_type += 1;
                Some(self.other(rec))
            }
            Rec::Corrupt => {
                self.f.stats.crc_errors += 1;
                self.f.stats.garbage_bytes += rec.len() as u64;
                None
            }
            Rec::Damaged(why) => {
                // Its messages cannot be read, nor trusted if they could: dropped, as for a CRC.
                if self.damaged_chunks == 0 {
                    tracing::warn!("MCAP chunk does not inflate ({why}): dropped whole");
                }
                self.damaged_chunks += 1;
                self.f.stats.bad_payload += 1;
                self.f.stats.garbage_bytes += rec.len() as u64;
                None
            }
        }
    }

    /// The next item from the chunk being read.
    fn next_in_chunk(&mut self) -> Option<Decoded> {
        loop {
            let (data, pos) = self.chunk.take()?;
            let rest = data.len() - pos;
            if rest == 0 {
                return None;
            }
            if rest < 9 {
                self.f.stats.bad_payload += 1;
                self.f.stats.garbage_bytes += rest as u64;
                return None;
            }
            let op = data[pos];
            let n = u64::from_le_bytes(data[pos + 1..pos + 9].try_into().expect("8 bytes"));
            let ok = min_len(op).is_some_and(|m| n >= m) && n <= (rest - 9) as u64;
            if !ok {
                // The chunk's CRC passed (or was not written) but its records do not frame:
                // the rest of the chunk is lost, counted.
                self.f.stats.bad_payload += 1;
                self.f.stats.garbage_bytes += rest as u64;
                return None;
            }
            let end = pos + 9 + n as usize;
            let checked = self.record(&data[pos..end], true);
            let rec = data.slice(pos..end);
            self.chunk = Some((data, end));
            match checked {
                Ok(what) => {
                    if let Some(d) = self.act(rec, what) {
                        return Some(d);
                    }
                }
                Err(()) => {
                    self.f.stats.bad_payload += 1;
                    self.f.stats.garbage_bytes += (end - pos) as u64;
                }
            }
        }
    }

    /// The next item from the bytes (before the hold of the first samples for the period).
    fn next_item(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        self.f.begin(buf).or_else(|| self.step(buf))
    }

    /// Nothing is held back at end of input but the first samples ([`Stamper`]).
    fn held_back(&mut self) -> Option<Decoded> {
        None
    }

    fn step(&mut self, buf: &mut BytesMut) -> Option<Decoded> {
        loop {
            if let Some(d) = self.next_in_chunk() {
                return Some(d);
            }
            if !self.magic_done {
                if !self.f.seek_magic(buf, &MAGIC) {
                    return None;
                }
                self.magic_done = true;
                let m = self.f.take(buf, MAGIC.len());
                return Some(self.other(m));
            }
            if buf.len() >= MAGIC.len() && buf[..MAGIC.len()] == MAGIC {
                // The closing magic (or a second file appended).
                let m = self.f.take(buf, MAGIC.len());
                return Some(self.other(m));
            }
            if buf.len() < 9 {
                return None;
            }
            let op = buf[0];
            let n = u64::from_le_bytes(buf[1..9].try_into().expect("8 bytes"));
            let plausible = min_len(op).is_some_and(|m| n >= m)
                && n <= MAX_RECORD
                && match op {
                    OP_FOOTER => n == 20,
                    OP_DATA_END => n == 4,
                    0x0E => n == 17,
                    _ => true,
                };
            if !plausible {
                self.f.bad(buf, Fault::Header);
                continue;
            }
            let total = 9 + n as usize;
            if buf.len() < total {
                // Not reserved here: a corrupt length must not allocate what it claims.
                return None;
            }
            match self.record(&buf[..total], false) {
                Ok(what) => {
                    let rec = self.f.take(buf, total);
                    if let Some(d) = self.act(rec, what) {
                        return Some(d);
                    }
                }
                Err(()) => {
                    // Not a record after all: step one byte.
                    self.f.bad(buf, Fault::Payload);
                }
            }
        }
    }
}

/// A message record whose data is one zstd frame, with `s` patched into the inflated CDR at
/// `at` and the data compressed again (the record's length follows). A frame that no longer
/// inflates (it did when decoded) is returned as it came.
pub fn patch_compressed(rec: &[u8], at: usize, le: bool, s: &Sample) -> Vec<u8> {
    let Ok(mut cdr) = inflate::zstd(&rec[9 + 22..], inflate::MAX_MESSAGE) else {
        return rec.to_vec();
    };
    ros2::patch_imu(&mut cdr, at, le, s);
    let z = inflate::zstd_compress(&cdr);
    let mut f = Vec::with_capacity(9 + 22 + z.len());
    f.push(rec[0]);
    f.extend_from_slice(&((22 + z.len()) as u64).to_le_bytes());
    f.extend_from_slice(&rec[9..9 + 22]);
    f.extend_from_slice(&z);
    f
}

/// CRC-32 (ISO-HDLC, as zlib) used by MCAP: `crc32fast` (carry-less multiply where the CPU
/// has it; a byte-wise table took over half the decode time of a chunked bag).
fn crc32(b: &[u8]) -> u32 {
    crc32fast::hash(b)
}

impl ProtocolDecoder for McapDecoder {
    fn protocol(&self) -> Protocol {
        Protocol::Mcap
    }
    super::framing::decode_through_hold!();
    fn discard_tail(&mut self, buf: &mut BytesMut) {
        // A record cut short: count it once, then look for records after its first byte.
        let start = !self.f.in_garbage();
        self.f.truncated_front(buf, start);
    }
    super::protocol::framer_stats_and_descriptor!();
    fn found(&self) -> String {
        let mut imu: Vec<&str> = self
            .channels
            .values()
            .filter(|c| self.is_imu(c))
            .map(|c| c.topic.as_str())
            .collect();
        imu.sort_unstable();
        imu.dedup();
        let reading = match self.selected.and_then(|i| self.channels.get(&i)) {
            Some(c) => c.topic.clone(),
            None => format!(
                "nothing (no sensor_msgs/msg/Imu topic{})",
                self.opts
                    .topic
                    .as_ref()
                    .map_or(String::new(), |t| format!(" named {t}"))
            ),
        };
        let mut s = format!(
            "MCAP: {} channels, {} chunks{}; sensor_msgs/msg/Imu topics: {:?}; reading {}{}",
            self.channels.len(),
            self.chunks,
            if self.inflated_chunks > 0 {
                format!(" ({} compressed)", self.inflated_chunks)
            } else {
                String::new()
            },
            imu,
            reading,
            if self.compressed_msgs > 0 {
                format!(
                    " ({} messages zstd-compressed one by one)",
                    self.compressed_msgs
                )
            } else {
                String::new()
            }
        );
        if let Some(c) = self.temp_channel.and_then(|i| self.channels.get(&i)) {
            s += &format!(
                "; temperature from {} ({} readings{})",
                c.topic,
                self.temp_msgs,
                if self.bad_temp > 0 {
                    format!(", {} unreadable", self.bad_temp)
                } else {
                    String::new()
                }
            );
        }
        if self.bad_cdr > 0 {
            s += &format!("; {} Imu messages with bad CDR", self.bad_cdr);
        }
        if self.damaged_chunks > 0 {
            s += &format!(
                "; {} that did not inflate, dropped",
                count(self.damaged_chunks, "compressed chunk", "compressed chunks")
            );
        }
        if !self.unsupported.is_empty() {
            s += &format!(
                "; chunks passed through undecoded (compression {:?}, not one MCAP defines)",
                self.unsupported
            );
        }
        s
    }
}
