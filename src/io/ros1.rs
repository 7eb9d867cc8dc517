//! ROS 1 bags (format 2.0) for `imuprep import`: the `sensor_msgs/Imu` messages of one topic,
//! with a `sensor_msgs/Temperature` topic joined when the bag has one.
//!
//! The container — the bag header, chunk records (uncompressed, bzip2 or LZ4), connection and
//! message-data records, the index section — is read by the `rosbag` crate (behind the `ros1`
//! feature: its bzip2 and LZ4 libraries are C builds). The messages themselves are read here,
//! as `frame::ros2` reads their ROS 2 form: the layout is small and fixed (ROS 1 serialisation is
//! little endian with no padding), and no crate decodes a message without generating its types:
//!
//! ```text
//! header: seq u32, stamp.secs u32, stamp.nsecs u32, frame_id (u32 length, bytes)
//! orientation x y z w, orientation_covariance[9],
//! angular_velocity x y z, angular_velocity_covariance[9],
//! linear_acceleration x y z, linear_acceleration_covariance[9]          (all f64)
//! ```
//!
//! A whole file is read (the crate maps it): this is an import, not a stream source. The bag's
//! own index is used to choose the topic before any message is read (`--topic`, else the first
//! `sensor_msgs/Imu` connection); a bag whose index was never written (a recording that did
//! not end cleanly: `index_pos` 0) is refused with the way out (`rosbag reindex`), because the
//! crate would read past its chunk section. Time is `header.stamp` (the record's time when the
//! stamp is zero, or always with `time = "log"`), as for ROS 2 bags; a vector whose covariance
//! has −1 in element 0 ("not available") gives absent channels. Messages are kept in file order;
//! the import derives gaps, duplicates and backward steps from their stamps as for any input.

use std::collections::BTreeMap;
use std::path::Path;

use super::bag::{
    BagRead, Found, TopicError, Topics, imu_sample, join_temperature, ros_descriptor, stamp_or_log,
};
use crate::frame::DecoderStats;
use crate::frame::ros2::{COVARIANCE_NOT_AVAILABLE, McapOptions};
use crate::text::count;
use rosbag::{ChunkRecord, IndexRecord, MessageRecord, RosBag};

/// The first bytes of every ROS 1 bag (format 2.0).
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The ROS 1 message types read.
const IMU_TYPE: &str = "sensor_msgs/Imu";
const TEMPERATURE_TYPE: &str = "sensor_msgs/Temperature";

/// Why a bag could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum Ros1Error {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("not a ROS 1 bag (format 2.0): it does not start with \"#ROSBAG V2.0\"")]
    NotABag,
    #[error(
        "the bag header is damaged ({0}): it cannot say where the bag's chunks end; if the file is whole, `rosbag reindex` cannot help either"
    )]
    BadHeader(&'static str),
    #[error(
        "the bag has no index (its recording did not end cleanly: index_pos {index_pos} of {len} bytes); rebuild it with `rosbag reindex IN.bag` (ROS 1), then import the reindexed bag"
    )]
    Unindexed { index_pos: u64, len: u64 },
    #[error(transparent)]
    Topic(#[from] TopicError),
}

/// `index_pos` from the bag header record (the crate's own parse would take a 0 or a position
/// past the end, then slice the file with it).
fn index_pos(head: &[u8]) -> Result<u64, Ros1Error> {
    let rest = head.strip_prefix(MAGIC).ok_or(Ros1Error::NotABag)?;
    let len = rest
        .get(..4)
        .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
        .ok_or(Ros1Error::BadHeader("too short"))?;
    let mut fields = rest
        .get(4..4 + len)
        .ok_or(Ros1Error::BadHeader("its length runs past the file"))?;
    while fields.len() >= 4 {
        let n = u32::from_le_bytes(fields[..4].try_into().expect("4 bytes")) as usize;
        let field = fields
            .get(4..4 + n)
            .ok_or(Ros1Error::BadHeader("a field runs past the header"))?;
        if let Some(v) = field.strip_prefix(b"index_pos=") {
            let v: [u8; 8] = v
                .try_into()
                .map_err(|_| Ros1Error::BadHeader("index_pos is not 8 bytes"))?;
            return Ok(u64::from_le_bytes(v));
        }
        fields = &fields[4 + n..];
    }
    Err(Ros1Error::BadHeader("no index_pos"))
}

/// A `sensor_msgs/Imu` in ROS 1 serialisation: stamp (s, ns), gx gy gz ax ay az, and the
/// channels the message declares not available (bit `c` for channel `c`). `None` when the bytes
/// are not one.
pub fn decode_imu(d: &[u8]) -> Option<(u32, u32, [f64; 6], u8)> {
    let u32_at = |o: usize| Some(u32::from_le_bytes(d.get(o..o + 4)?.try_into().ok()?));
    let (secs, nsecs, frame_len) = (u32_at(4)?, u32_at(8)?, u32_at(12)? as usize);
    // orientation 4 + covariance 9, then angular velocity at 13 f64 from the block's start.
    let block = 16usize.checked_add(frame_len)?;
    if d.len() != block + 37 * 8 {
        return None;
    }
    let f = |i: usize| f64::from_le_bytes(d[block + 8 * i..block + 8 * i + 8].try_into().unwrap());
    let (g, a) = (13, 25);
    let channels = [f(g), f(g + 1), f(g + 2), f(a), f(a + 1), f(a + 2)];
    let mut absent = 0;
    if f(g + 3) == COVARIANCE_NOT_AVAILABLE {
        absent |= 0b000_111;
    }
    if f(a + 3) == COVARIANCE_NOT_AVAILABLE {
        absent |= 0b111_000;
    }
    Some((secs, nsecs, channels, absent))
}

/// A `sensor_msgs/Temperature`: stamp (s, ns) and °C (the variance after it is not needed).
fn decode_temperature(d: &[u8]) -> Option<(u32, u32, f64)> {
    let u32_at = |o: usize| Some(u32::from_le_bytes(d.get(o..o + 4)?.try_into().ok()?));
    let at = 16usize.checked_add(u32_at(12)? as usize)?;
    if d.len() != at + 16 {
        return None;
    }
    let c = f64::from_le_bytes(d[at..at + 8].try_into().ok()?);
    Some((u32_at(4)?, u32_at(8)?, c))
}

/// What the bag's index section says: its connections, id → (topic, type), where its chunks
/// start, and the index's own damage. Where the index is damaged (a file cut short inside it),
/// the connections are those declared inside the chunks and no chunk position is trusted.
struct Index {
    conns: BTreeMap<u32, (String, String)>,
    chunk_pos: Vec<u64>,
    damage: Option<String>,
}

fn read_index(bag: &RosBag) -> Index {
    let mut conns = BTreeMap::new();
    let mut chunk_pos = Vec::new();
    let mut damage = None;
    for r in bag.index_records() {
        match r {
            Ok(IndexRecord::Connection(x)) => {
                conns.insert(x.id, (x.topic.to_string(), x.tp.to_string()));
            }
            Ok(IndexRecord::ChunkInfo(ci)) => chunk_pos.push(ci.chunk_pos),
            Ok(IndexRecord::IndexData(_)) => {}
            Err(e) => {
                damage = Some(e.to_string());
                break;
            }
        }
    }
    if damage.is_some() {
        chunk_pos.clear();
        walk_chunks(bag, &[], |m| {
            if let MessageRecord::Connection(x) = m {
                conns.insert(x.id, (x.topic.to_string(), x.tp.to_string()));
            }
        });
    }
    chunk_pos.sort_unstable();
    chunk_pos.dedup();
    Index {
        conns,
        chunk_pos,
        damage,
    }
}

/// What [`walk_chunks`] met.
#[derive(Default)]
struct Walk {
    chunks: u64,
    /// Records that could not be read (a chunk, or a record inside one), and the first error.
    damaged: u64,
    first_error: Option<String>,
    /// Whether a damaged chunk record ended the walk (no index to find the next chunk by).
    lost_rest: bool,
}

/// Every record inside the bag's chunks, in file order, to `f`: chunk by chunk from the index's
/// positions `chunk_pos` (a damaged chunk loses only itself), or, without them, front to back
/// (a damaged chunk record ends the walk: the chunk section has no sync word to find the next
/// one by). A damaged record inside a chunk loses the rest of that chunk.
fn walk_chunks(bag: &RosBag, chunk_pos: &[u64], mut f: impl FnMut(MessageRecord<'_>)) -> Walk {
    let mut w = Walk::default();
    let fail = |w: &mut Walk, e: String| {
        w.damaged += 1;
        w.first_error.get_or_insert(e);
    };
    let mut visit = |w: &mut Walk, c: &rosbag::record_types::Chunk<'_>| {
        w.chunks += 1;
        for m in c.messages() {
            match m {
                Ok(m) => f(m),
                Err(e) => {
                    fail(w, e.to_string());
                    return;
                }
            }
        }
    };
    let mut it = bag.chunk_records();
    if chunk_pos.is_empty() {
        for r in it {
            match r {
                Ok(ChunkRecord::Chunk(c)) => visit(&mut w, &c),
                Ok(ChunkRecord::IndexData(_)) => {}
                Err(e) => {
                    fail(&mut w, e.to_string());
                    w.lost_rest = true;
                    break;
                }
            }
        }
        return w;
    }
    for &pos in chunk_pos {
        let r = it.seek(pos).map_err(|e| e.to_string()).and_then(|_| {
            it.next()
                .unwrap_or(Err(rosbag::Error::OutOfBounds))
                .map_err(|e| e.to_string())
        });
        match r {
            Ok(ChunkRecord::Chunk(c)) => visit(&mut w, &c),
            Ok(ChunkRecord::IndexData(_)) => fail(
                &mut w,
                format!("no chunk at byte {pos}, where the index puts one"),
            ),
            Err(e) => fail(&mut w, e),
        }
    }
    w
}

/// The connection ids of `topic` with type `ty`.
fn ids(conns: &BTreeMap<u32, (String, String)>, ty: &str, topic: &str) -> Vec<u32> {
    conns
        .iter()
        .filter(|(_, (n, t))| n == topic && t == ty)
        .map(|(id, _)| *id)
        .collect()
}

/// The `sensor_msgs/Imu` messages of `opts.topic` (else the first Imu topic) in the bag at
/// `path`, as samples, with the temperature of `opts.temperature_topic` (else the first
/// Temperature topic; `""` none) joined: the latest reading at or before each sample, unless
/// older than `temperature_max_age_s`.
pub fn read_bag(path: &Path, opts: &McapOptions) -> Result<BagRead, Ros1Error> {
    let len = std::fs::metadata(path)?.len();
    let mut head = Vec::with_capacity(4096);
    std::io::Read::read_to_end(
        &mut std::io::Read::take(std::fs::File::open(path)?, 4096),
        &mut head,
    )?;
    let index_pos = index_pos(&head)?;
    if index_pos == 0 || index_pos >= len {
        return Err(Ros1Error::Unindexed { index_pos, len });
    }
    let bag = RosBag::new(path)?;
    let index = read_index(&bag);
    let conns = &index.conns;
    let mut topics = Topics::default();
    for (n, t) in conns.values() {
        topics.add(n, t);
    }
    let (topic, temp) = topics.choose(IMU_TYPE, TEMPERATURE_TYPE, opts)?;
    let imu_ids = ids(conns, IMU_TYPE, &topic);
    let temp = temp.map(|t| {
        let i = ids(conns, TEMPERATURE_TYPE, &t);
        (t, i)
    });
    let header_time = opts.time != "log";
    let time_of = |secs: u32, nsecs: u32, record: u64| {
        stamp_or_log(header_time, secs.into(), nsecs.into(), record)
    };

    let mut stats = DecoderStats {
        bytes_in: len,
        ..DecoderStats::default()
    };
    let mut samples = Vec::new();
    let mut temps: Vec<(u64, f64)> = Vec::new();
    let (mut bad_temp, mut other) = (0u64, 0u64);
    let walk = walk_chunks(&bag, &index.chunk_pos, |m| {
        let MessageRecord::MessageData(m) = m else {
            return;
        };
        if imu_ids.contains(&m.conn_id) {
            match decode_imu(m.data) {
                Some((secs, nsecs, channels, absent)) => {
                    samples.push(imu_sample(time_of(secs, nsecs, m.time), &channels, absent));
                    stats.frames_ok += 1;
                    stats.samples += 1;
                }
                None => stats.bad_payload += 1,
            }
        } else if temp
            .as_ref()
            .is_some_and(|(_, ids)| ids.contains(&m.conn_id))
        {
            match decode_temperature(m.data) {
                Some((secs, nsecs, c)) if c.is_finite() => {
                    temps.push((time_of(secs, nsecs, m.time), c))
                }
                _ => bad_temp += 1,
            }
        } else {
            other += 1;
        }
    });
    stats.truncated = walk.damaged;

    let joined = join_temperature(&mut samples, temps, opts.temperature_max_age_s);
    let mut warnings = Vec::new();
    if let Some(e) = &index.damage {
        warnings.push(format!(
            "the bag's index is damaged ({e}): its topics were taken from the chunks"
        ));
    }
    if let Some(e) = walk.first_error {
        warnings.push(format!(
            "{} damaged ({e}): {} lost",
            count(walk.damaged, "record", "records"),
            if walk.lost_rest {
                "the messages after the damage (the rest of the bag: no index to find the next chunk by) are"
            } else {
                "the messages of a damaged chunk, or after the damage in it, are"
            }
        ));
    }
    let found = Found {
        imu_type: IMU_TYPE,
        other_imu: topics.others(IMU_TYPE, &topic),
        topic,
        containers: count(walk.chunks, "chunk", "chunks"),
        temperature: temp.map(|(t, _)| (t, bad_temp)),
        joined,
        other,
        warnings,
    };
    Ok(BagRead {
        descriptor: ros_descriptor(),
        samples,
        found: found.line(&stats),
        stats,
    })
}

/// Whether `path` starts as a ROS 1 bag.
pub fn is_bag(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 13];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|_| head == MAGIC)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn imu_bytes(frame: &str, g: [f64; 3], a: [f64; 3], acov0: f64) -> Vec<u8> {
        let mut d = Vec::new();
        for v in [7u32, 12, 345] {
            d.extend_from_slice(&v.to_le_bytes());
        }
        d.extend_from_slice(&(frame.len() as u32).to_le_bytes());
        d.extend_from_slice(frame.as_bytes());
        let mut f = vec![0.0; 37];
        f[3] = 1.0;
        f[13..16].copy_from_slice(&g);
        f[25..28].copy_from_slice(&a);
        f[28] = acov0;
        for v in f {
            d.extend_from_slice(&v.to_le_bytes());
        }
        d
    }

    #[test]
    fn an_imu_message_is_read_for_every_frame_id_and_wrong_lengths_are_refused() {
        for frame in ["", "i", "imu_link", "a_much_longer_frame_name"] {
            let d = imu_bytes(frame, [0.1, -0.2, 0.3], [1.0, 2.0, 9.8], 0.0);
            assert_eq!(
                decode_imu(&d),
                Some((12, 345, [0.1, -0.2, 0.3, 1.0, 2.0, 9.8], 0)),
                "{frame:?}"
            );
            // One byte short or long: not this message (never a panic).
            assert_eq!(decode_imu(&d[..d.len() - 1]), None);
            let mut longer = d.clone();
            longer.push(0);
            assert_eq!(decode_imu(&longer), None);
            for cut in 0..20 {
                assert_eq!(decode_imu(&d[..cut]), None);
            }
        }
        // A frame_id length past the message (a corrupt length) is refused, not sliced.
        let mut d = imu_bytes("x", [0.0; 3], [0.0; 3], 0.0);
        d[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(decode_imu(&d), None);
        let d = imu_bytes("x", [0.0; 3], [0.0, 0.0, 9.8], COVARIANCE_NOT_AVAILABLE);
        assert_eq!(decode_imu(&d).unwrap().3, 0b111_000);
    }

    #[test]
    fn the_header_s_index_position_is_read_and_damage_is_said() {
        let field = |name: &str, v: &[u8]| {
            let mut f = Vec::new();
            f.extend_from_slice(&((name.len() + 1 + v.len()) as u32).to_le_bytes());
            f.extend_from_slice(name.as_bytes());
            f.push(b'=');
            f.extend_from_slice(v);
            f
        };
        let mut fields = field("op", &[3]);
        fields.extend(field("index_pos", &4242u64.to_le_bytes()));
        fields.extend(field("conn_count", &1u32.to_le_bytes()));
        let mut h = MAGIC.to_vec();
        h.extend_from_slice(&(fields.len() as u32).to_le_bytes());
        h.extend_from_slice(&fields);
        assert_eq!(index_pos(&h).unwrap(), 4242);
        for cut in 0..h.len() {
            assert!(index_pos(&h[..cut]).is_err(), "cut at {cut}");
        }
        assert!(matches!(
            index_pos(b"#ROSBAG V1.2\n"),
            Err(Ros1Error::NotABag)
        ));
    }
}
