use super::*;
use crate::frame::DecoderStats;

fn decode_all(opts: MavlinkOptions, bytes: &[u8], chunk: usize) -> (Vec<Decoded>, DecoderStats) {
    crate::frame::protocol::decode_chunked(&mut MavlinkDecoder::new(opts), bytes, chunk)
}

fn sample(i: u64) -> Sample {
    let mut s = Sample {
        t_ns: i * 5_000_000,
        temp_c: Some(30.5),
        ..Sample::default()
    };
    s.set_channels(&[0.01, -0.02, 0.03, 0.1, -0.2, -9.81]);
    s
}

#[test]
fn crc_extra_of_known_messages() {
    // CRC-extra values of the common message set.
    assert_eq!(crc_extra(0), Some(50));
    assert_eq!(crc_extra(MSG_HIGHRES_IMU), Some(93));
    assert_eq!(crc_extra(MSG_SCALED_IMU2), Some(76));
}

#[test]
fn two_instances_are_kept_apart() {
    let mut b = BytesMut::new();
    for i in 0..10u64 {
        encode_v2(
            i as u8,
            1,
            1,
            MSG_HIGHRES_IMU,
            &highres_payload(&sample(i), 0),
            &mut b,
        );
        encode_v2(
            i as u8,
            1,
            1,
            MSG_HIGHRES_IMU,
            &highres_payload(&sample(i), 1),
            &mut b,
        );
    }
    let opts = MavlinkOptions {
        instance: Some(1),
        ..Default::default()
    };
    let (out, st) = decode_all(opts, &b, 13);
    let n = out.iter().filter_map(Decoded::sample).count();
    assert_eq!(n, 10);
    assert_eq!(st.other_messages, 10);
    assert_eq!(
        st.duplicates, 0,
        "the other instance's same time stamps are not duplicates"
    );
}

/// A tlog (an 8-byte big-endian µs stamp before every message): the stamps are read as
/// such, not as garbage; an unknown message is trusted when a stamp and a message follow;
/// a corrupt message costs only itself.
#[test]
fn a_tlog_reads_its_stamps_and_every_message() {
    let t0_us: u64 = 1_714_564_800_000_000;
    let mut b = BytesMut::new();
    let mut unknown = 0;
    for i in 0..200u64 {
        b.extend_from_slice(&(t0_us + i * 5000).to_be_bytes());
        encode_v2(
            i as u8,
            1,
            1,
            MSG_HIGHRES_IMU,
            &highres_payload(&sample(i), 0),
            &mut b,
        );
        if i % 20 == 0 {
            b.extend_from_slice(&(t0_us + i * 5000 + 100).to_be_bytes());
            encode_v2(i as u8, 1, 1, 60_000, &[1, 2, 3, 4], &mut b);
            unknown += 1;
        }
    }
    for chunk in [1, 7, 4096] {
        let mut d = MavlinkDecoder::new(MavlinkOptions::default());
        let (out, st) = crate::frame::protocol::decode_chunked(&mut d, &b, chunk);
        let n = out.iter().filter_map(Decoded::sample).count();
        assert_eq!(n, 200, "chunk {chunk}");
        assert_eq!(
            (st.garbage_bytes, st.resyncs, st.crc_errors, st.unknown_type),
            (0, 0, 0, 0),
            "chunk {chunk}: {st:?}"
        );
        assert_eq!(st.other_messages, unknown, "chunk {chunk}");
        assert!(
            d.found()
                .ends_with("a tlog: 210 time stamps read before the messages"),
            "{}",
            d.found()
        );
    }
    // One message's checksum broken: that message is lost, counted, and the rest read.
    let mut bad = b.to_vec();
    let at = 8 + 10 + 2; // inside the first record's payload
    bad[at] ^= 0xff;
    let mut d = MavlinkDecoder::new(MavlinkOptions::default());
    let (out, st) = crate::frame::protocol::decode_chunked(&mut d, &bad, 64);
    assert_eq!(out.iter().filter_map(Decoded::sample).count(), 199);
    assert_eq!(st.crc_errors, 1, "{st:?}");
    // A plain stream is no tlog.
    let mut plain = BytesMut::new();
    encode_v2(
        0,
        1,
        1,
        MSG_HIGHRES_IMU,
        &highres_payload(&sample(0), 0),
        &mut plain,
    );
    let mut d = MavlinkDecoder::new(MavlinkOptions::default());
    crate::frame::protocol::decode_chunked(&mut d, &plain, 4096);
    assert!(!d.found().contains("tlog"), "{}", d.found());
}

#[test]
fn reencode_round_trips_and_keeps_ids() {
    let mut b = BytesMut::new();
    encode_v2(
        7,
        42,
        200,
        MSG_HIGHRES_IMU,
        &highres_payload(&sample(1), 2),
        &mut b,
    );
    let mut s = sample(1);
    s.gyro[2] = 1.25;
    let mut out = BytesMut::new();
    reencode(&b, &s, 0.0, 0.0, &mut out);
    assert_eq!(&out[4..7], &[7, 42, 200]);
    let (items, st) = decode_all(MavlinkOptions::default(), &out, out.len());
    assert_eq!(st.crc_errors, 0);
    let Decoded::Sample(got, _) = &items[0] else {
        panic!("{items:?}")
    };
    assert_eq!(got.gyro[2], 1.25);
}
