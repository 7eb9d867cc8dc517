//! Round trips through decoders nobody here wrote (issue 14): the pyubx2 and pymavlink streams
//! (tests/reference/ubx_stream.bin, mavlink_stream.bin) decoded, every IMU sample of the selected
//! stream changed (gyro +0.01 rad/s, accel −0.05 m/s², as a cleaning stage changes values),
//! written back inline, and read by pyubx2 and pymavlink (tests/reference/
//! check_inline_reference.py, its readings committed). The libraries see every message of the
//! input in order, every message outside the selected stream byte for byte (checked by the
//! script, stated in its CSV's first line and asserted here), and the changed values to the
//! protocol's resolution.
mod common;
use common::csv_rows as rows;

use bytes::BytesMut;
use imuprep::frame::inline::InlineEncoder;
use imuprep::frame::mavlink::MavlinkDecoder;
use imuprep::frame::ubx::{self, UbxDecoder};
use imuprep::frame::{Decoded, Protocol, ProtocolDecoder};

const UBX: &[u8] = include_bytes!("reference/ubx_stream.bin");
const UBX_EXPECTED: &str = include_str!("reference/ubx_expected.csv");
const MAV: &[u8] = include_bytes!("reference/mavlink_stream.bin");
const MAV_EXPECTED: &str = include_str!("reference/mavlink_expected.csv");
const UBX_OUT: &str = "tests/reference/ubx_inline_shifted.bin";
const MAV_OUT: &str = "tests/reference/mavlink_inline_shifted.bin";
const UBX_BACK: &str = include_str!("reference/ubx_inline_shifted_pyubx2.csv");
const MAV_BACK: &str = include_str!("reference/mavlink_inline_shifted_pymavlink.csv");
const GYRO_SHIFT: f64 = 0.01;
const ACCEL_SHIFT: f64 = -0.05;

fn shift(c: usize) -> f64 {
    if c < 3 { GYRO_SHIFT } else { ACCEL_SHIFT }
}

/// The inline output of `bytes` with every sample's values shifted.
fn shifted(p: Protocol, d: &mut dyn ProtocolDecoder, bytes: &[u8]) -> Vec<u8> {
    let (items, _) = imuprep::frame::protocol::decode_chunked(d, bytes, 333);
    let mut enc = InlineEncoder::new(p, 0.0, 0.0);
    let mut out = BytesMut::new();
    for it in &items {
        match it {
            Decoded::Sample(s, c) => {
                let mut x = *s;
                for ch in 0..6 {
                    x.set_channel(ch, s.channel(ch) + shift(ch));
                }
                enc.sample(c.as_ref(), &x, &mut out);
            }
            Decoded::Other(b) => enc.other(b, &mut out),
            Decoded::Descriptor(_) => {}
        }
    }
    enc.flush(&mut out);
    out.to_vec()
}

/// The committed output is what the encoder writes now (the one the script read).
fn bless_or_check(path: &str, bytes: &[u8]) {
    if std::env::var_os("IMUPREP_BLESS").is_some() {
        std::fs::write(path, bytes).unwrap();
    }
    assert!(
        std::fs::read(path).unwrap() == bytes,
        "{path} changed: run with IMUPREP_BLESS=1, then tests/reference/check_inline_reference.py"
    );
}

fn num(s: &str) -> f64 {
    s.parse().unwrap()
}

#[test]
fn ubx_inline_output_read_by_pyubx2_keeps_every_message_and_the_changed_values() {
    let out = shifted(Protocol::Ubx, &mut UbxDecoder::default(), UBX);
    bless_or_check(UBX_OUT, &out);
    let head = UBX_BACK.lines().next().unwrap();
    assert_eq!(
        head,
        "# pyubx2 read 58 IMU samples; all 61 messages in the input's order, the 29 others byte for byte"
    );
    let (want, got) = (rows(UBX_EXPECTED), rows(UBX_BACK));
    assert_eq!((want.len(), got.len()), (58, 58));
    // One count: gyro 2⁻¹² °/s, accel 2⁻¹⁰ m/s². The output holds the nearest count to the
    // changed value, so pyubx2 reads it within half a count (plus 1e-12 for the float
    // rounding of the scale factors, as in protocols_reference).
    let lsb = |c: usize| {
        if c < 3 {
            ubx::GYRO_LSB_DEG_S.to_radians()
        } else {
            ubx::ACCEL_LSB_M_S2
        }
    };
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        assert_eq!(w[..2], g[..2], "#{i}: kind and time tag");
        for c in 0..6 {
            let err = num(&g[2 + c]) - (num(&w[2 + c]) + shift(c));
            assert!(err.abs() <= 0.5 * lsb(c) + 1e-12, "#{i} ch {c}: {err}");
        }
        assert_eq!(w[8], g[8], "#{i}: temperature unchanged");
    }
}

#[test]
fn mavlink_inline_output_read_by_pymavlink_keeps_every_message_and_the_changed_values() {
    let mut d = MavlinkDecoder::default();
    let out = shifted(Protocol::Mavlink, &mut d, MAV);
    bless_or_check(MAV_OUT, &out);
    let head = MAV_BACK.lines().next().unwrap();
    assert_eq!(
        head,
        "# pymavlink read all 185 messages in the input's order (type, ids, sequence), the 145 outside the selected stream byte for byte"
    );
    // The selected stream (the first IMU stream seen): HIGHRES_IMU of system 1, instance 0.
    let want: Vec<Vec<String>> = rows(MAV_EXPECTED)
        .into_iter()
        .filter(|r| r[..4] == ["1", "1", "105", "0"])
        .collect();
    let got = rows(MAV_BACK);
    assert_eq!((want.len(), got.len()), (40, 40));
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        assert_eq!(w[..5], g[..5], "#{i}: ids and time");
        for c in 0..6 {
            // HIGHRES_IMU carries f32: the output holds the changed value rounded to f32,
            // and pymavlink reads exactly that.
            let v = (num(&w[5 + c]) + shift(c)) as f32 as f64;
            assert_eq!(num(&g[5 + c]), v, "#{i} ch {c}");
        }
        assert_eq!(w[11], g[11], "#{i}: temperature unchanged");
    }
}
