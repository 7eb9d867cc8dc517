//! Inline MCAP output of a bag with attachments and metadata: the records pass through in
//! order, and the new summary indexes them where this writer put them (attachment index,
//! metadata index, statistics counts), so the `mcap` crate finds each one by its index.
//! Needs `--features ros2` (the input bag is written with the `mcap` crate).
#![cfg(feature = "ros2")]

mod common;

use bytes::BytesMut;
use imuprep::frame::mcap::McapDecoder;
use imuprep::frame::{Decoded, Protocol};
use std::borrow::Cow;
use std::collections::BTreeMap;

/// A bag: one String channel with 5 messages, a metadata record and two attachments between
/// them (written by the `mcap` crate's writer, uncompressed, so the decoder reads it in any
/// build).
fn bag() -> (
    Vec<u8>,
    Vec<mcap::Attachment<'static>>,
    mcap::records::Metadata,
) {
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .chunk_size(Some(64))
        .create(std::io::Cursor::new(Vec::new()))
        .expect("writer");
    let schema = w
        .add_schema("std_msgs/msg/String", "ros2msg", b"string data")
        .unwrap();
    let ch = w
        .add_channel(schema, "/chatter", "cdr", &BTreeMap::new())
        .unwrap();
    let atts: Vec<mcap::Attachment<'static>> = (0..2u64)
        .map(|i| mcap::Attachment {
            log_time: 1_000 + i,
            create_time: 2_000 + i,
            name: format!("calib{i}.yaml"),
            media_type: "application/yaml".into(),
            data: Cow::Owned(vec![b'a' + i as u8; 10 + i as usize]),
        })
        .collect();
    let meta = mcap::records::Metadata {
        name: "rosbag2".into(),
        metadata: BTreeMap::from([("ros_distro".to_string(), "jazzy".to_string())]),
    };
    for i in 0..5u32 {
        let header = mcap::records::MessageHeader {
            channel_id: ch,
            sequence: i,
            log_time: 10 * i as u64,
            publish_time: 10 * i as u64,
        };
        w.write_to_known_channel(&header, &[0, 1, 0, 0, 2, 0, 0, 0, b'x', 0])
            .unwrap();
        match i {
            1 => w.write_metadata(&meta).unwrap(),
            2 | 3 => w.attach(&atts[i as usize - 2]).unwrap(),
            _ => {}
        }
    }
    w.finish().unwrap();
    (w.into_inner().into_inner(), atts, meta)
}

fn inline(bytes: &[u8]) -> Vec<u8> {
    let mut d = McapDecoder::default();
    let (items, _) = imuprep::frame::protocol::decode_chunked(&mut d, bytes, 100);
    common::inline_identity(Protocol::Mcap, &items, 0.0, 0.0)
}

#[test]
fn attachments_and_metadata_are_indexed_where_the_inline_writer_put_them() {
    let (input, atts, meta) = bag();
    let out = inline(&input);
    let summary = mcap::Summary::read(&out)
        .expect("summary reads (CRC checked)")
        .expect("a summary");
    let stats = summary.stats.as_ref().expect("statistics");
    assert_eq!((stats.attachment_count, stats.metadata_count), (2, 1));
    assert_eq!(stats.message_count, 5);
    // Each attachment, fetched through its index, is the one written into the input.
    assert_eq!(summary.attachment_indexes.len(), 2);
    for (idx, want) in summary.attachment_indexes.iter().zip(&atts) {
        assert_eq!(
            (&idx.name, &idx.media_type, idx.log_time, idx.create_time),
            (
                &want.name,
                &want.media_type,
                want.log_time,
                want.create_time
            )
        );
        assert_eq!(idx.data_size, want.data.len() as u64);
        let got = mcap::read::attachment(&out, idx).expect("attachment at its index");
        assert_eq!(got.name, want.name);
        assert_eq!(got.data, want.data);
    }
    assert_eq!(summary.metadata_indexes.len(), 1);
    assert_eq!(summary.metadata_indexes[0].name, "rosbag2");
    let got = mcap::read::metadata(&out, &summary.metadata_indexes[0]).expect("metadata");
    assert_eq!(got, meta);
    // The messages are all there too, in order.
    let msgs: Vec<u64> = mcap::MessageStream::new(&out)
        .expect("stream")
        .map(|m| m.expect("message").log_time)
        .collect();
    assert_eq!(msgs, vec![0, 10, 20, 30, 40]);
}

#[test]
fn a_bag_without_attachments_gets_no_empty_index_groups() {
    // Only groups with records get a summary offset (the committed inline bag of
    // tests/ros2_mcap.rs, which has none, stays byte for byte the same).
    let (input, _, _) = bag();
    let mut plain = mcap::WriteOptions::new()
        .compression(None)
        .create(std::io::Cursor::new(Vec::new()))
        .unwrap();
    let s = plain
        .add_schema("std_msgs/msg/String", "ros2msg", b"string data")
        .unwrap();
    let c = plain
        .add_channel(s, "/chatter", "cdr", &BTreeMap::new())
        .unwrap();
    let header = mcap::records::MessageHeader {
        channel_id: c,
        sequence: 0,
        log_time: 5,
        publish_time: 5,
    };
    plain.write_to_known_channel(&header, &[0; 9]).unwrap();
    plain.finish().unwrap();
    let out = inline(&plain.into_inner().into_inner());
    let summary = mcap::Summary::read(&out).unwrap().expect("a summary");
    assert!(summary.attachment_indexes.is_empty() && summary.metadata_indexes.is_empty());
    assert!(!inline(&input).is_empty());
}

const BAG: &[u8] = include_bytes!("reference/mcap_bag.mcap");
const LZ4_BAG: &str = "tests/reference/mcap_inline_lz4.mcap";
const LZ4_ROSBAGS: &str = "tests/reference/mcap_inline_lz4_rosbags.csv";
const EXPECTED: &str = include_str!("reference/mcap_expected.csv");

/// The rosbags bag re-chunked by a [`McapStream`] with compression `c` (identity: every
/// record as it came).
fn restream(c: imuprep::frame::mcap_out::ChunkCompression) -> Vec<u8> {
    let mut d = McapDecoder::default();
    let (items, _) = imuprep::frame::protocol::decode_chunked(&mut d, BAG, 4096);
    let mut st = imuprep::frame::mcap_out::McapStream::with_compression(c);
    let mut out = BytesMut::new();
    for it in &items {
        match it {
            Decoded::Sample(_, Some(c)) => st.message(&c.frame, &mut out),
            Decoded::Other(b) => st.other(b, &mut out),
            _ => {}
        }
    }
    st.finish(&mut out);
    out.to_vec()
}

/// (compression, uncompressed size, uncompressed CRC, stored bytes) of every chunk record.
fn chunks(bytes: &[u8]) -> Vec<(String, u64, u32, Vec<u8>)> {
    let summary = mcap::Summary::read(bytes).unwrap().expect("a summary");
    summary
        .chunk_indexes
        .iter()
        .map(|ci| {
            let at = ci.chunk_start_offset as usize;
            let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
            match mcap::parse_record(bytes[at], &bytes[at + 9..at + 9 + len]).unwrap() {
                mcap::records::Record::Chunk { header, data } => (
                    header.compression,
                    header.uncompressed_size,
                    header.uncompressed_crc,
                    data.into_owned(),
                ),
                r => panic!("chunk index points at {r:?}"),
            }
        })
        .collect()
}

#[test]
fn lz4_chunks_hold_the_same_records_and_rosbags_reads_them() {
    use imuprep::frame::mcap_out::ChunkCompression;
    use std::io::Read;
    let plain = restream(ChunkCompression::None);
    let lz4 = restream(ChunkCompression::Lz4);
    if std::env::var_os("IMUPREP_BLESS").is_some() {
        std::fs::write(LZ4_BAG, &lz4).unwrap();
    }
    // The committed bag is the one rosbags read (check_mcap_inline.py, see its docstring).
    assert_eq!(
        std::fs::read(LZ4_BAG).unwrap(),
        lz4,
        "run with IMUPREP_BLESS=1"
    );
    let (p, z) = (chunks(&plain), chunks(&lz4));
    assert_eq!(p.len(), z.len());
    for (p, z) in p.iter().zip(&z) {
        assert_eq!((p.0.as_str(), z.0.as_str()), ("", "lz4"));
        // Same uncompressed size and CRC; the LZ4 frame (decoded by lz4_flex) gives exactly
        // the uncompressed chunk's records, in fewer bytes.
        assert_eq!((p.1, p.2), (z.1, z.2));
        let mut back = Vec::new();
        lz4_flex::frame::FrameDecoder::new(&z.3[..])
            .read_to_end(&mut back)
            .unwrap();
        assert_eq!(back, p.3);
        assert!(z.3.len() < p.3.len(), "{} vs {}", z.3.len(), p.3.len());
    }
    // rosbags (through the summary and chunk indexes, decompressing LZ4) reads the Imu rows it
    // read from the original bag.
    let rows = std::fs::read_to_string(LZ4_ROSBAGS).unwrap();
    let got_rows: Vec<&str> = rows.lines().skip(1).collect();
    let want: Vec<&str> = EXPECTED.lines().skip(1).collect();
    assert_eq!(got_rows, want);
    // imuprep's decoder reads LZ4 chunks in every `ros2` build (lz4_flex): the same samples
    // from both, no chunk dropped or passed through undecoded.
    let (a, sa) = imuprep::frame::protocol::decode_chunked(&mut McapDecoder::default(), &lz4, 999);
    let (b, _) = imuprep::frame::protocol::decode_chunked(&mut McapDecoder::default(), &plain, 999);
    assert_eq!((sa.crc_errors, sa.unknown_type), (0, 0));
    assert_eq!(
        imuprep::frame::protocol::samples_of(&a),
        imuprep::frame::protocol::samples_of(&b)
    );
    assert_eq!(imuprep::frame::protocol::samples_of(&a).len(), 60);
    // The `mcap` crate's reader needs its lz4 feature (`ros2-compression`).
    #[cfg(feature = "ros2-compression")]
    {
        let msgs = |b: &[u8]| -> Vec<(u64, Vec<u8>)> {
            mcap::MessageStream::new(b)
                .unwrap()
                .map(|m| m.map(|m| (m.log_time, m.data.into_owned())).unwrap())
                .collect()
        };
        assert_eq!(msgs(&lz4), msgs(&plain));
    }
}
