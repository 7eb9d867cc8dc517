//! Decoders against streams made by encoders nobody here wrote (pyubx2, pymavlink) and the real
//! PX4 logs read by pyulog; inline re-encoding preserves every message and every byte. The
//! fixtures and the scripts that made them are in tests/reference/.
mod common;
use common::{csv_rows as rows, inline_identity};

use bytes::BytesMut;
use imuprep::frame::inline::InlineEncoder;
use imuprep::frame::mavlink::{MavlinkDecoder, MavlinkOptions};
use imuprep::frame::ubx::UbxDecoder;
use imuprep::frame::ulog::{UlogDecoder, UlogOptions};
use imuprep::frame::{Decoded, DecoderStats, Protocol, ProtocolDecoder};
use imuprep::sample::{Sample, flags};

const UBX: &[u8] = include_bytes!("reference/ubx_stream.bin");
const UBX_EXPECTED: &str = include_str!("reference/ubx_expected.csv");
const MAV: &[u8] = include_bytes!("reference/mavlink_stream.bin");
const MAV_EXPECTED: &str = include_str!("reference/mavlink_expected.csv");
const ULOG_EXPECTED: &str = include_str!("reference/ulog_expected.csv");
const MAV_TLOG: &[u8] = include_bytes!("reference/mavlink_stream.tlog");

fn run(d: &mut dyn ProtocolDecoder, bytes: &[u8], chunk: usize) -> (Vec<Decoded>, DecoderStats) {
    imuprep::frame::protocol::decode_chunked(d, bytes, chunk)
}

fn samples(items: &[Decoded]) -> Vec<Sample> {
    imuprep::frame::protocol::samples_of(items)
}

#[test]
fn ubx_values_equal_pyubx2() {
    let want = rows(UBX_EXPECTED);
    for chunk in [1, 7, 64, 100_000] {
        let (items, st) = run(&mut UbxDecoder::default(), UBX, chunk);
        let got = samples(&items);
        assert_eq!(got.len(), want.len(), "chunk {chunk}");
        // pyubx2 read 16 NMEA sentences and 13 other UBX messages.
        assert_eq!(st.other_messages, 29);
        assert_eq!(
            (st.crc_errors, st.garbage_bytes, st.partial_samples),
            (0, 0, 0)
        );
        for (s, w) in got.iter().zip(&want) {
            let v: Vec<f64> = w[2..9].iter().map(|x| x.parse().unwrap()).collect();
            // Same integer fields on both sides; the only difference is float rounding of the
            // scale factors (2^-12 deg → rad), far below the 2^-12 deg/s resolution.
            for (c, want) in v.iter().take(6).enumerate() {
                assert!((s.channel(c) - want).abs() < 1e-12, "channel {c}");
            }
            assert!((s.temp_c.unwrap() - v[6]).abs() < 1e-9);
        }
    }
}

#[test]
fn ubx_time_tags_unwrap_and_sequence_from_time() {
    let (items, st) = run(&mut UbxDecoder::default(), UBX, 4096);
    let got = samples(&items);
    // ESF-RAW: 48 sets 256 counts (10 ms) apart through the 2^24 wrap; no gaps, no backwards.
    for w in got[..48].windows(2) {
        assert_eq!(w[1].t_ns - w[0].t_ns, 10_000_000);
        assert_eq!(w[1].seq, w[0].seq + 1);
    }
    // One step back: from the ESF-RAW time base (24-bit tags, ~655 s) to the ESF-MEAS one (ms
    // since start, ~131 s); a receiver sends one or the other, the fixture both.
    assert_eq!(st.time_backwards, 1);
    assert!(
        got[..48]
            .iter()
            .all(|s| s.flags & (flags::GAP | flags::DUPLICATE) == 0)
    );
}

#[test]
fn ubx_inline_identity_reproduces_every_byte() {
    let (items, _) = run(&mut UbxDecoder::default(), UBX, 333);
    let out = inline_identity(Protocol::Ubx, &items, 0.0, 0.0);
    assert_eq!(out.len(), UBX.len());
    assert!(out == UBX, "inline identity differs from the input");
}

fn mav_opts(r: &[String]) -> MavlinkOptions {
    let msg = match r[2].as_str() {
        "105" => "highres_imu",
        "26" => "scaled_imu",
        "116" => "scaled_imu2",
        _ => "raw_imu",
    };
    MavlinkOptions {
        sysid: Some(r[0].parse().unwrap()),
        compid: Some(r[1].parse().unwrap()),
        message: Some(msg.into()),
        instance: Some(r[3].parse().unwrap()),
        // The RAW_IMU scales the generating script applied.
        gyro_scale_rad_s: 1e-3,
        accel_scale_m_s2: 1e-2,
        rate_hz: 0.0,
    }
}

#[test]
fn mavlink_every_stream_equals_pymavlink() {
    let want = rows(MAV_EXPECTED);
    let mut keys: Vec<&[String]> = want.iter().map(|r| &r[..4]).collect();
    keys.dedup();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), 5, "streams in the fixture");
    for k in keys {
        let expect: Vec<&Vec<String>> = want.iter().filter(|r| &r[..4] == k).collect();
        for chunk in [1, 50, 100_000] {
            let mut d = MavlinkDecoder::new(mav_opts(k));
            let (items, st) = run(&mut d, MAV, chunk);
            let got = samples(&items);
            assert_eq!(got.len(), expect.len(), "stream {k:?} chunk {chunk}");
            // 185 messages in all, every one verified by its CRC-extra.
            assert_eq!(st.frames_ok, 185);
            assert_eq!((st.crc_errors, st.garbage_bytes, st.unverified), (0, 0, 0));
            for (s, w) in got.iter().zip(&expect) {
                let t: u64 = w[4].parse().unwrap();
                assert_eq!(s.t_ns, t);
                for c in 0..6 {
                    let v: f64 = w[5 + c].parse().unwrap();
                    // HIGHRES f32 values are compared exactly (both sides widen the same f32);
                    // scaled integers agree to float rounding of the scale.
                    assert!((s.channel(c) - v).abs() < 1e-12, "{k:?} ch {c}");
                }
                match w[11].as_str() {
                    "" => assert_eq!(s.temp_c, None),
                    t => assert!((s.temp_c.unwrap() - t.parse::<f64>().unwrap()).abs() < 1e-9),
                }
            }
        }
    }
}

/// The same messages as a telemetry log (an 8-byte stamp before each, read back by pymavlink's
/// tlog reader: gen_tlog_reference.py): the same samples as the plain stream, every stamp read
/// as one, not a byte of garbage.
#[test]
fn mavlink_tlog_reads_as_the_plain_stream() {
    for chunk in [1, 50, 100_000] {
        let mut plain = MavlinkDecoder::default();
        let (a, _) = run(&mut plain, MAV, chunk);
        let mut tlog = MavlinkDecoder::default();
        let (b, st) = run(&mut tlog, MAV_TLOG, chunk);
        assert_eq!(samples(&b), samples(&a), "chunk {chunk}");
        assert_eq!(st.frames_ok, 185);
        assert_eq!(
            (st.crc_errors, st.garbage_bytes, st.resyncs, st.unverified),
            (0, 0, 0, 0),
            "chunk {chunk}"
        );
        assert!(
            tlog.found()
                .ends_with("a tlog: 185 time stamps read before the messages"),
            "{}",
            tlog.found()
        );
    }
}

#[test]
fn mavlink_inline_keeps_every_message_and_unsigned_bytes() {
    let mut d = MavlinkDecoder::default();
    let (items, _) = run(&mut d, MAV, 97);
    // Every message comes out, in order: unsigned frames byte for byte; the signed IMU frames
    // of the selected stream lose their 13-byte signature (values re-encoded, so it would no
    // longer verify) and nothing else.
    let out = inline_identity(Protocol::Mavlink, &items, 0.0, 0.0);
    let signed_imu: usize = items
        .iter()
        .filter(|i| matches!(i, Decoded::Sample(_, Some(c)) if c.frame[0] == 0xFD && c.frame[2] & 1 == 1))
        .count();
    assert!(signed_imu > 0, "the fixture signs some frames");
    assert_eq!(out.len(), MAV.len() - 13 * signed_imu);
    let (again, st) = run(&mut MavlinkDecoder::default(), &out, 4096);
    assert_eq!(st.frames_ok, 185);
    assert_eq!(samples(&again), samples(&items));
}

#[test]
fn mavlink_raw_imu_inline_writes_cleaned_values_back_in_counts_with_the_configured_scales() {
    let want = rows(MAV_EXPECTED);
    let key = want
        .iter()
        .find(|r| r[2] == "27")
        .expect("a RAW_IMU stream")[..4]
        .to_vec();
    let o = mav_opts(&key);
    let (items, _) = run(&mut MavlinkDecoder::new(o.clone()), MAV, 4096);
    let raw = samples(&items);
    assert!(!raw.is_empty());
    // A "cleaned" sample: gx + 5 counts (5 × 1e-3 rad/s), az − 3 counts (3 × 1e-2 m/s²). The
    // encoder has no scales of its own (0, 0): it must use the ones the carrier brings.
    let mut enc = InlineEncoder::new(Protocol::Mavlink, 0.0, 0.0);
    let mut out = BytesMut::new();
    for it in &items {
        match it {
            Decoded::Sample(s, c) => {
                let mut x = *s;
                x.gyro[0] += 5e-3;
                x.accel[2] -= 3e-2;
                enc.sample(c.as_ref(), &x, &mut out)
            }
            Decoded::Other(b) => enc.other(b, &mut out),
            Decoded::Descriptor(_) => {}
        }
    }
    let (again, st) = run(&mut MavlinkDecoder::new(o), &out, 4096);
    assert_eq!((st.frames_ok, st.crc_errors), (185, 0));
    let back = samples(&again);
    assert_eq!(back.len(), raw.len());
    for (b, r) in back.iter().zip(&raw) {
        // Whole counts both ways: equal to float rounding of the scales.
        assert!((b.gyro[0] - (r.gyro[0] + 5e-3)).abs() < 1e-12);
        assert!((b.accel[2] - (r.accel[2] - 3e-2)).abs() < 1e-12);
        assert_eq!((b.gyro[1], b.accel[0]), (r.gyro[1], r.accel[0]));
    }
}

#[test]
fn ulog_real_files_equal_pyulog() {
    let Some(dir) = common::real_data("px4_ulog") else {
        common::skipped("ulog_real_files_equal_pyulog (../shared/data/real/px4_ulog absent)");
        return;
    };
    let want = rows(ULOG_EXPECTED);
    let mut files: Vec<&str> = want.iter().map(|r| r[0].as_str()).collect();
    files.dedup();
    assert_eq!(files.len(), 5);
    for f in files {
        let bytes = std::fs::read(dir.join(f)).unwrap();
        let mut d = UlogDecoder::new(UlogOptions::default());
        let (items, st) = run(&mut d, &bytes, 65_536);
        let got = samples(&items);
        let rs: Vec<&Vec<String>> = want.iter().filter(|r| r[0] == f).collect();
        assert_eq!(got.len(), rs[0][3].parse::<usize>().unwrap(), "{f}: {st:?}");
        for r in rs {
            let s = got[r[4].parse::<usize>().unwrap()];
            assert_eq!(s.t_ns, r[5].parse::<u64>().unwrap() * 1000, "{f}");
            for c in 0..6 {
                // Both readers widen the same f32 field: equal exactly.
                assert_eq!(s.channel(c), r[6 + c].parse::<f64>().unwrap(), "{f} ch {c}");
            }
        }
        // Inline identity: the same file again, byte for byte, where no byte was garbage.
        if st.garbage_bytes == 0 {
            let out = inline_identity(Protocol::Ulog, &items, 0.0, 0.0);
            assert!(out == bytes, "{f}: inline identity differs from the input");
        } else {
            eprintln!(
                "{f}: {} garbage bytes (appended sections), inline identity not checked",
                st.garbage_bytes
            );
        }
    }
}
