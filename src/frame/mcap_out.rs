//! The inline MCAP output as a stream: the input's records, in order, re-chunked and indexed so
//! that readers can seek (chunk index, message indexes, statistics, summary with its offsets),
//! written front to back without seeking (a file, a pipe or a pseudo-terminal alike).
//!
//! The decoder hands over the records of the input's data section one by one (each chunk's
//! records in place of the chunk). Schema, channel and message records are gathered into
//! uncompressed chunks of about [`CHUNK_BYTES`], each followed by its message indexes; any other
//! data-section record (attachment, metadata) closes the chunk being filled and is written as it
//! came. The input's own indexes, statistics and summary point at its own offsets: they are
//! dropped, and at the input's data-end record (or at the end of the output when the input was
//! cut short) this writer closes the file itself: data end, a summary (schemas, channels,
//! statistics, chunk indexes, attachment and metadata indexes pointing at where this writer put
//! those records), the summary offsets, the footer and the closing magic. Chunk and
//! summary CRC-32s are written; the data-section CRC is 0 ("not computed"), as the format allows.
//!
//! Chunks are uncompressed by default; [`McapStream::with_compression`] writes LZ4-frame chunks
//! instead (`lz4`, as the MCAP format names it; `lz4_flex`, pure Rust, in `ros2` builds). The
//! chunk CRC is over the uncompressed records either way, as the format defines it.
//!
//! Written by hand rather than with the `mcap` crate's writer: that one needs a seekable output
//! and assigns its own schema and channel ids, where the inline output keeps the input's records
//! byte for byte (compiled in every build; no dependency).

use super::ros2::MAGIC;
use crc::{CRC_32_ISO_HDLC, Crc, Table};
use std::collections::BTreeMap;

/// Records gathered into one chunk before it is written (as the `mcap:` sink and rosbag2 do).
pub const CHUNK_BYTES: usize = 1 << 20;

const CRC32: Crc<u32, Table<16>> = Crc::<u32, Table<16>>::new(&CRC_32_ISO_HDLC);

const OP_FOOTER: u8 = 0x02;
const OP_SCHEMA: u8 = 0x03;
const OP_CHANNEL: u8 = 0x04;
const OP_MESSAGE: u8 = 0x05;
const OP_CHUNK: u8 = 0x06;
const OP_MESSAGE_INDEX: u8 = 0x07;
const OP_CHUNK_INDEX: u8 = 0x08;
const OP_ATTACHMENT: u8 = 0x09;
const OP_ATTACHMENT_INDEX: u8 = 0x0A;
const OP_METADATA: u8 = 0x0C;
const OP_METADATA_INDEX: u8 = 0x0D;
const OP_STATISTICS: u8 = 0x0B;
const OP_SUMMARY_OFFSET: u8 = 0x0E;
const OP_DATA_END: u8 = 0x0F;

/// How the inline output compresses its chunks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ChunkCompression {
    /// Records as they are (the format's empty compression name).
    #[default]
    None,
    /// LZ4 frame format (`lz4`).
    #[cfg(feature = "ros2")]
    Lz4,
    /// One zstd frame (`zstd`; ruzstd's fastest level, about zstd's level 1).
    #[cfg(feature = "ros2")]
    Zstd,
}

impl ChunkCompression {
    /// The chunk's records as stored, and the format's name for the compression.
    fn apply(self, records: &[u8]) -> (std::borrow::Cow<'_, [u8]>, &'static str) {
        match self {
            ChunkCompression::None => (records.into(), ""),
            #[cfg(feature = "ros2")]
            ChunkCompression::Lz4 => {
                use std::io::Write;
                let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
                // Writing into a Vec cannot fail.
                e.write_all(records).expect("lz4 into memory");
                (e.finish().expect("lz4 into memory").into(), "lz4")
            }
            #[cfg(feature = "ros2")]
            ChunkCompression::Zstd => (super::inflate::zstd_compress(records).into(), "zstd"),
        }
    }
}

/// Append a string field: u32 length, bytes.
fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Before the opening magic.
    Start,
    /// In the data section.
    Data,
    /// The file is closed: whatever the input still sends (its summary) is dropped.
    Done,
}

/// Writes an indexed MCAP from the input's records (see the module documentation).
#[derive(Debug)]
pub struct McapStream {
    state: State,
    /// Bytes written so far (file offsets of what comes next).
    written: u64,
    /// Records of the chunk being filled.
    chunk: Vec<u8>,
    chunk_times: Option<(u64, u64)>,
    /// Per channel: (log time, offset in the chunk's records) of its messages in the chunk.
    chunk_msgs: BTreeMap<u16, Vec<(u64, u64)>>,
    /// Chunk index records, for the summary.
    chunk_index: Vec<u8>,
    /// Schema and channel records, by id, for the summary.
    schemas: BTreeMap<u16, Vec<u8>>,
    channels: BTreeMap<u16, Vec<u8>>,
    messages: u64,
    per_channel: BTreeMap<u16, u64>,
    times: Option<(u64, u64)>,
    chunks: u32,
    attachments: u32,
    metadata: u32,
    /// Attachment and metadata index records, for the summary.
    attachment_index: Vec<u8>,
    metadata_index: Vec<u8>,
    compression: ChunkCompression,
}

impl Default for McapStream {
    fn default() -> Self {
        McapStream {
            state: State::Start,
            written: 0,
            chunk: Vec::new(),
            chunk_times: None,
            chunk_msgs: BTreeMap::new(),
            chunk_index: Vec::new(),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            messages: 0,
            per_channel: BTreeMap::new(),
            times: None,
            chunks: 0,
            attachments: 0,
            metadata: 0,
            attachment_index: Vec::new(),
            metadata_index: Vec::new(),
            compression: ChunkCompression::None,
        }
    }
}

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}

fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"))
}

fn widen(t: Option<(u64, u64)>, x: u64) -> Option<(u64, u64)> {
    Some(t.map_or((x, x), |(a, b)| (a.min(x), b.max(x))))
}

/// A length-prefixed (u32) string field at `o` of `b`: its bytes with the prefix, and the
/// offset after it; `None` when it runs past the end.
fn string_at(b: &[u8], o: usize) -> Option<(&[u8], usize)> {
    let n = u32::from_le_bytes(b.get(o..o + 4)?.try_into().ok()?) as usize;
    let end = o.checked_add(4)?.checked_add(n)?;
    Some((b.get(o..end)?, end))
}

/// The attachment index body for attachment record `b` (opcode and length included) written
/// at offset `at`: offset, length, log time, create time, data size, name, media type. `None`
/// for a body too short for its fields (the record still passes through, unindexed).
fn attachment_index(b: &[u8], at: u64) -> Option<Vec<u8>> {
    let body = b.get(9..)?;
    let times = body.get(..16)?;
    let (name, o) = string_at(body, 16)?;
    let (media, o) = string_at(body, o)?;
    let data_size = body.get(o..o + 8)?;
    let mut i = Vec::with_capacity(40 + name.len() + media.len());
    i.extend_from_slice(&at.to_le_bytes());
    i.extend_from_slice(&(b.len() as u64).to_le_bytes());
    i.extend_from_slice(times);
    i.extend_from_slice(data_size);
    i.extend_from_slice(name);
    i.extend_from_slice(media);
    Some(i)
}

/// The metadata index body for metadata record `b` written at `at`: offset, length, name.
fn metadata_index(b: &[u8], at: u64) -> Option<Vec<u8>> {
    let (name, _) = string_at(b.get(9..)?, 0)?;
    let mut i = Vec::with_capacity(16 + name.len());
    i.extend_from_slice(&at.to_le_bytes());
    i.extend_from_slice(&(b.len() as u64).to_le_bytes());
    i.extend_from_slice(name);
    Some(i)
}

/// Append a record: opcode, u64 length, body.
fn record(out: &mut Vec<u8>, op: u8, body: &[u8]) {
    out.push(op);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

impl McapStream {
    /// A stream whose chunks are compressed with `c`.
    pub fn with_compression(c: ChunkCompression) -> Self {
        McapStream {
            compression: c,
            ..Self::default()
        }
    }

    fn emit(&mut self, b: &[u8], out: &mut bytes::BytesMut) {
        out.extend_from_slice(b);
        self.written += b.len() as u64;
    }

    /// One record (or magic) of the input, in input order.
    pub fn other(&mut self, b: &[u8], out: &mut bytes::BytesMut) {
        if b == MAGIC {
            if self.state == State::Start {
                self.state = State::Data;
                self.emit(b, out);
            }
            return;
        }
        if self.state != State::Data || b.len() < 9 {
            return;
        }
        let op = b[0];
        match op {
            OP_SCHEMA | OP_CHANNEL if b.len() >= 11 => {
                let id = u16_at(b, 9);
                let map = if op == OP_SCHEMA {
                    &mut self.schemas
                } else {
                    &mut self.channels
                };
                map.insert(id, b.to_vec());
                self.add_to_chunk(b, None, out);
            }
            OP_MESSAGE if b.len() >= 9 + 22 => {
                let (channel, log_time) = (u16_at(b, 9), u64_at(b, 9 + 6));
                self.messages += 1;
                *self.per_channel.entry(channel).or_insert(0) += 1;
                self.times = widen(self.times, log_time);
                self.add_to_chunk(b, Some((channel, log_time)), out);
            }
            OP_DATA_END => self.finish(out),
            // Indexes, statistics, summary offsets and the footer refer to the input's
            // offsets: this writer makes its own.
            0x02 | 0x07 | 0x08 | 0x0A | 0x0B | 0x0D | 0x0E => {}
            _ => {
                self.close_chunk(out);
                let at = self.written;
                match op {
                    OP_ATTACHMENT => {
                        self.attachments += 1;
                        if let Some(i) = attachment_index(b, at) {
                            record(&mut self.attachment_index, OP_ATTACHMENT_INDEX, &i);
                        }
                    }
                    OP_METADATA => {
                        self.metadata += 1;
                        if let Some(i) = metadata_index(b, at) {
                            record(&mut self.metadata_index, OP_METADATA_INDEX, &i);
                        }
                    }
                    _ => {}
                }
                self.emit(b, out);
            }
        }
    }

    /// A message record whose content changed (a cleaned Imu message): same place, same index.
    pub fn message(&mut self, b: &[u8], out: &mut bytes::BytesMut) {
        self.other(b, out);
    }

    fn add_to_chunk(&mut self, b: &[u8], msg: Option<(u16, u64)>, out: &mut bytes::BytesMut) {
        if let Some((channel, t)) = msg {
            let at = self.chunk.len() as u64;
            self.chunk_msgs.entry(channel).or_default().push((t, at));
            self.chunk_times = widen(self.chunk_times, t);
        }
        self.chunk.extend_from_slice(b);
        if self.chunk.len() >= CHUNK_BYTES {
            self.close_chunk(out);
        }
    }

    /// Write the chunk being filled, its message indexes, and remember its index record.
    fn close_chunk(&mut self, out: &mut bytes::BytesMut) {
        if self.chunk.is_empty() {
            return;
        }
        let records = std::mem::take(&mut self.chunk);
        let (t0, t1) = self.chunk_times.take().unwrap_or((0, 0));
        let (stored, compression) = self.compression.apply(&records);
        let mut body = Vec::with_capacity(stored.len() + 40);
        body.extend_from_slice(&t0.to_le_bytes());
        body.extend_from_slice(&t1.to_le_bytes());
        body.extend_from_slice(&(records.len() as u64).to_le_bytes());
        body.extend_from_slice(&CRC32.checksum(&records).to_le_bytes());
        put_str(&mut body, compression);
        body.extend_from_slice(&(stored.len() as u64).to_le_bytes());
        body.extend_from_slice(&stored);
        let chunk_start = self.written;
        let mut rec = Vec::with_capacity(body.len() + 9);
        record(&mut rec, OP_CHUNK, &body);
        self.emit(&rec, out);
        // Message indexes, one per channel with messages in the chunk.
        let index_start = self.written;
        let mut offsets = Vec::new();
        for (channel, entries) in std::mem::take(&mut self.chunk_msgs) {
            offsets.extend_from_slice(&channel.to_le_bytes());
            offsets.extend_from_slice(&self.written.to_le_bytes());
            let mut b = Vec::with_capacity(6 + 16 * entries.len());
            b.extend_from_slice(&channel.to_le_bytes());
            b.extend_from_slice(&((16 * entries.len()) as u32).to_le_bytes());
            for (t, at) in entries {
                b.extend_from_slice(&t.to_le_bytes());
                b.extend_from_slice(&at.to_le_bytes());
            }
            let mut r = Vec::with_capacity(b.len() + 9);
            record(&mut r, OP_MESSAGE_INDEX, &b);
            self.emit(&r, out);
        }
        let mut ci = Vec::new();
        ci.extend_from_slice(&t0.to_le_bytes());
        ci.extend_from_slice(&t1.to_le_bytes());
        ci.extend_from_slice(&chunk_start.to_le_bytes());
        ci.extend_from_slice(&(rec.len() as u64).to_le_bytes());
        ci.extend_from_slice(&(offsets.len() as u32).to_le_bytes());
        ci.extend_from_slice(&offsets);
        ci.extend_from_slice(&(self.written - index_start).to_le_bytes());
        put_str(&mut ci, compression);
        ci.extend_from_slice(&(stored.len() as u64).to_le_bytes()); // compressed size
        ci.extend_from_slice(&(records.len() as u64).to_le_bytes()); // uncompressed size
        record(&mut self.chunk_index, OP_CHUNK_INDEX, &ci);
        self.chunks += 1;
    }

    /// Close the file: the last chunk, data end, summary, summary offsets, footer, magic.
    /// Called at the input's data end, or at the end of the output if the input never got
    /// there; later calls do nothing.
    pub fn finish(&mut self, out: &mut bytes::BytesMut) {
        if self.state != State::Data {
            return;
        }
        self.close_chunk(out);
        let mut data_end = Vec::new();
        record(&mut data_end, OP_DATA_END, &0u32.to_le_bytes());
        self.emit(&data_end, out);
        let summary_start = self.written;
        let mut summary = Vec::new();
        let mut groups: Vec<(u8, u64, u64)> = Vec::new();
        let mut group = |summary: &mut Vec<u8>, op: u8, bytes: &[u8]| {
            if !bytes.is_empty() {
                groups.push((op, summary_start + summary.len() as u64, bytes.len() as u64));
                summary.extend_from_slice(bytes);
            }
        };
        let schemas: Vec<u8> = self.schemas.values().flatten().copied().collect();
        let channels: Vec<u8> = self.channels.values().flatten().copied().collect();
        group(&mut summary, OP_SCHEMA, &schemas);
        group(&mut summary, OP_CHANNEL, &channels);
        let mut st = Vec::new();
        let (t0, t1) = self.times.unwrap_or((0, 0));
        st.extend_from_slice(&self.messages.to_le_bytes());
        st.extend_from_slice(&(self.schemas.len() as u16).to_le_bytes());
        st.extend_from_slice(&(self.channels.len() as u32).to_le_bytes());
        st.extend_from_slice(&self.attachments.to_le_bytes());
        st.extend_from_slice(&self.metadata.to_le_bytes());
        st.extend_from_slice(&self.chunks.to_le_bytes());
        st.extend_from_slice(&t0.to_le_bytes());
        st.extend_from_slice(&t1.to_le_bytes());
        st.extend_from_slice(&((10 * self.per_channel.len()) as u32).to_le_bytes());
        for (c, n) in &self.per_channel {
            st.extend_from_slice(&c.to_le_bytes());
            st.extend_from_slice(&n.to_le_bytes());
        }
        let mut stats = Vec::new();
        record(&mut stats, OP_STATISTICS, &st);
        group(&mut summary, OP_STATISTICS, &stats);
        let chunk_index = std::mem::take(&mut self.chunk_index);
        group(&mut summary, OP_CHUNK_INDEX, &chunk_index);
        let attachment_index = std::mem::take(&mut self.attachment_index);
        group(&mut summary, OP_ATTACHMENT_INDEX, &attachment_index);
        let metadata_index = std::mem::take(&mut self.metadata_index);
        group(&mut summary, OP_METADATA_INDEX, &metadata_index);
        let summary_offset_start = summary_start + summary.len() as u64;
        for (op, start, len) in groups {
            let mut b = vec![op];
            b.extend_from_slice(&start.to_le_bytes());
            b.extend_from_slice(&len.to_le_bytes());
            record(&mut summary, OP_SUMMARY_OFFSET, &b);
        }
        // Footer: summary start, summary offset start, CRC-32 of the summary section through
        // the footer's offset fields.
        summary.push(OP_FOOTER);
        summary.extend_from_slice(&20u64.to_le_bytes());
        summary.extend_from_slice(&summary_start.to_le_bytes());
        summary.extend_from_slice(&summary_offset_start.to_le_bytes());
        let crc = CRC32.checksum(&summary);
        summary.extend_from_slice(&crc.to_le_bytes());
        summary.extend_from_slice(&MAGIC);
        self.emit(&summary, out);
        self.state = State::Done;
    }
}
