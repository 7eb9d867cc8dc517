//! Inline MCAP output of a bag with attachments and metadata: the records pass through in
//! order, and the new summary indexes them where this writer put them (attachment index,
//! metadata index, statistics counts), so the `mcap` crate finds each one by its index.
//! Needs `--features ros2` (the input bag is written with the `mcap` crate).
#![cfg(feature = "ros2")]

use bytes::BytesMut;
use imuprep::frame::inline::InlineEncoder;
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
    let mut enc = InlineEncoder::new(Protocol::Mcap, 0.0, 0.0);
    let mut out = BytesMut::new();
    for it in &items {
        match it {
            Decoded::Sample(s, c) => enc.sample(c.as_ref(), s, &mut out),
            Decoded::Other(b) => enc.other(b, &mut out),
            Decoded::Descriptor(_) => {}
        }
    }
    enc.flush(&mut out);
    out.to_vec()
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
