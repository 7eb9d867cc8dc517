//! Partial sensors through the protocols (issue 13 item 10, export side): a gyro-only,
//! accel-only or single-axis log exported to UBX, MAVLink and ULog says its absent channels the
//! way each protocol can, and the decoders read them back as absent — the same mask on every
//! sample and in the descriptor, never a non-finite or partial count — with the present values
//! unchanged to the protocol's resolution. ULog `sensor_combined` can only say "no
//! accelerometer": any other absence is refused with the channels named. The decoders' other
//! readings of the same fields (a sender that leaves `fields_updated` 0, a field not new in this
//! message, an axis missing after the stream carried it) are pinned here too.

mod common;

use bytes::BytesMut;
use imuprep::frame::detect::{DecodedFile, ProtocolConfig, decode_bytes};
use imuprep::frame::mavlink::MavlinkDecoder;
use imuprep::frame::{Decoded, Descriptor, ProtocolDecoder, mavlink, ubx, ulog};
use imuprep::io::convert::{ExportFormat, encode_stream};
use imuprep::sample::{Sample, flags};
use std::process::Command;

/// 400 samples at 200 Hz (common::samples), with the channels of `absent` absent (NaN).
fn partial(absent: u8) -> (Descriptor, Vec<Sample>) {
    let mut s = common::samples(400, 1313);
    for x in &mut s {
        x.absent = absent;
        for c in 0..6 {
            if x.is_absent(c) {
                x.set_channel(c, f64::NAN);
            }
        }
    }
    let d = Descriptor {
        sample_rate_hz: 200.0,
        absent,
        ..Descriptor::default()
    };
    (d, s)
}

fn round_trip(to: ExportFormat, absent: u8) -> (Vec<Sample>, DecodedFile) {
    let (d, s) = partial(absent);
    let b = encode_stream(to, &d, &s).unwrap();
    (s, decode_bytes(&b, &ProtocolConfig::auto()))
}

/// Largest difference a present value may show after the trip: UBX quantizes gyro to 2⁻¹² °/s
/// and accel to 2⁻¹⁰ m/s² (half a count either way); MAVLink and ULog carry f32, which must
/// come back bit for bit.
fn tolerance(to: ExportFormat, c: usize) -> f64 {
    match (to, c < 3) {
        (ExportFormat::Ubx, true) => 0.5 * (1.0f64 / 4096.0).to_radians() + 1e-15,
        (ExportFormat::Ubx, false) => 0.5 / 1024.0 + 1e-15,
        _ => 0.0,
    }
}

fn check(to: ExportFormat, absent: u8) {
    let label = format!("{to:?} absent {absent:#08b}");
    let (sent, got) = round_trip(to, absent);
    assert_eq!(got.samples.len(), sent.len(), "{label}");
    assert_eq!(
        got.descriptor.map(|d| d.absent),
        Some(absent),
        "{label}: descriptor"
    );
    assert_eq!(
        got.stats.non_finite, 0,
        "{label}: absent counted non-finite"
    );
    assert_eq!(
        got.stats.partial_samples, 0,
        "{label}: absent counted partial"
    );
    for (i, (a, b)) in sent.iter().zip(&got.samples).enumerate() {
        assert_eq!(b.absent, absent, "{label} #{i}");
        assert!(!b.has(flags::NON_FINITE), "{label} #{i}");
        for c in 0..6 {
            if a.is_absent(c) {
                assert!(b.channel(c).is_nan(), "{label} #{i} ch {c}");
            } else if tolerance(to, c) == 0.0 {
                assert_eq!(
                    b.channel(c),
                    a.channel(c) as f32 as f64,
                    "{label} #{i} ch {c}"
                );
            } else {
                let e = (b.channel(c) - a.channel(c)).abs();
                assert!(e <= tolerance(to, c), "{label} #{i} ch {c}: {e}");
            }
        }
    }
}

/// Absent masks (bit `c` = channel `c` absent) of a gyro-only, accel-only and gx-only sensor.
const GYRO_ONLY: u8 = 0b111_000;
const ACCEL_ONLY: u8 = 0b000_111;
const GX_ONLY: u8 = 0b111_110;

#[test]
fn mavlink_and_ubx_carry_every_absence_and_read_it_back() {
    for to in [ExportFormat::Mavlink, ExportFormat::Ubx] {
        for absent in [0, GYRO_ONLY, ACCEL_ONLY, GX_ONLY, 0b010_101] {
            check(to, absent);
        }
    }
}

#[test]
fn ulog_carries_a_gyro_only_log_and_refuses_what_sensor_combined_cannot_say() {
    check(ExportFormat::Ulog, 0);
    check(ExportFormat::Ulog, GYRO_ONLY);
    for (absent, names) in [
        (ACCEL_ONLY, "gx, gy, gz"),
        (GX_ONLY, "gy, gz, ax, ay, az"),
        (0b100_000, "az"),
    ] {
        let (d, s) = partial(absent);
        let e = encode_stream(ExportFormat::Ulog, &d, &s).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(names), "{msg}");
        assert!(msg.contains("mavlink") && msg.contains("ubx"), "{msg}");
    }
}

/// The wire says absence the protocol's way (not just a NaN the decoder happens to read).
#[test]
fn the_wire_fields_say_absence() {
    let (d, s) = partial(GYRO_ONLY);
    // MAVLink: fields_updated = gyro bits 3..5 plus the temperature bit when there is one.
    let p = mavlink::highres_payload(&s[1], 0);
    assert_eq!(u16::from_le_bytes([p[60], p[61]]), 0x0038 | 0x1000);
    let p = mavlink::highres_payload(&s[0], 0); // common::samples: no temperature at i % 7 == 0
    assert_eq!(u16::from_le_bytes([p[60], p[61]]), 0x0038);
    assert!(f32::from_le_bytes(p[56..60].try_into().unwrap()).is_nan());
    // UBX ESF-RAW: only the three gyro data words (x y z = types 14 13 5) and the temperature.
    let mut b = BytesMut::new();
    ubx::encode_esf_raw(&[(0, s[1])], &mut b);
    let types: Vec<u8> = b[6 + 4..b.len() - 2].chunks(8).map(|w| w[3]).collect();
    assert_eq!(types, vec![14, 13, 5, 12]);
    // ULog: accelerometer_timestamp_relative = RELATIVE_TIMESTAMP_INVALID (0x7fffffff).
    let b = encode_stream(ExportFormat::Ulog, &d, &s[..1]).unwrap();
    // The data message: size u16, 'D', then 50 bytes of fields: msg_id u16, timestamp u64,
    // gyro 3×f32, gyro_integral_dt u32, accelerometer_timestamp_relative i32 at 29, ….
    let last = &b[b.len() - 53..];
    assert_eq!(&last[..3], &[50, 0, b'D']);
    assert_eq!(
        i32::from_le_bytes(last[29..33].try_into().unwrap()),
        i32::MAX
    );
}

fn mavlink_stream(fields: &[u16]) -> Vec<u8> {
    let mut b = BytesMut::new();
    for (i, f) in fields.iter().enumerate() {
        let s = &common::samples(fields.len(), 7)[i];
        let mut p = mavlink::highres_payload(s, 0);
        p[60..62].copy_from_slice(&f.to_le_bytes());
        mavlink::encode_v2(i as u8, 1, 1, mavlink::MSG_HIGHRES_IMU, &p, &mut b);
    }
    b.to_vec()
}

#[test]
fn mavlink_fields_updated_zero_is_every_field_and_a_stale_field_stays_a_value() {
    // A sender that never fills fields_updated: every channel is a measurement.
    let f = decode_bytes(&mavlink_stream(&[0; 40]), &ProtocolConfig::auto());
    assert_eq!(f.samples.len(), 40);
    assert!(
        f.samples
            .iter()
            .all(|s| s.absent == 0 && s.gyro[0].is_finite())
    );
    // PX4 updates gyro and accel at different rates: once a channel has been updated, a clear
    // bit is "not new", and the value (the last one) is read as sent.
    let mut fields = vec![0x003F | 0x1000];
    fields.extend((0..39).map(|i| if i % 2 == 0 { 0x0038 } else { 0x0007 | 0x1000 }));
    let f = decode_bytes(&mavlink_stream(&fields), &ProtocolConfig::auto());
    assert_eq!(f.samples.len(), 40);
    assert!(f.samples.iter().all(|s| s.absent == 0));
    assert!(f.samples.iter().all(|s| !s.has(flags::NON_FINITE)));
    assert_eq!(f.stats.non_finite, 0);
}

#[test]
fn ubx_axis_missing_after_the_stream_carried_it_is_partial_not_absent() {
    let s = common::samples(40, 9);
    let mut b = BytesMut::new();
    for (i, x) in s.iter().enumerate() {
        let mut x = *x;
        if i == 20 {
            x.accel[1] = f64::NAN; // no data word for ay in this one set
        }
        ubx::encode_esf_raw(&[((i as u32) * 128, x)], &mut b);
    }
    let f = decode_bytes(&b, &ProtocolConfig::auto());
    assert_eq!(f.samples.len(), 40);
    assert_eq!(f.descriptor.unwrap().absent, 0);
    assert!(f.samples.iter().all(|s| s.absent == 0));
    assert_eq!((f.stats.partial_samples, f.stats.non_finite), (1, 1));
    assert!(f.samples[20].has(flags::NON_FINITE) && f.samples[20].accel[1].is_nan());
}

#[test]
fn ulog_invalid_accel_after_valid_ones_is_no_measurement() {
    // PX4 writes sensor_combined with the accel marked invalid when no new accel sample came:
    // the values there (stale, or zero) are not data.
    let mut s = common::samples(40, 11);
    let mut b = BytesMut::new();
    // Encode sample 25 as accel-absent (the marker), the others whole.
    s[25].absent = GYRO_ONLY;
    ulog::encode_sensor_combined_log(&s, &mut b);
    let f = decode_bytes(&b, &ProtocolConfig::auto());
    assert_eq!(f.samples.len(), 40);
    assert!(f.samples.iter().all(|s| s.absent == 0));
    assert_eq!((f.stats.partial_samples, f.stats.non_finite), (1, 1));
    let g = &f.samples[25];
    assert!(g.has(flags::NON_FINITE) && g.accel.iter().all(|v| v.is_nan()));
    assert!(g.gyro.iter().all(|v| v.is_finite()));
}

/// The CLI path a user takes: import a gyro-only CSV, export it to each protocol, import that
/// back: the re-imported log has the same absent channels and the same present values.
#[test]
fn export_then_import_keeps_the_absent_channels() {
    let dir = tempfile::tempdir().unwrap();
    let data: Vec<[f64; 6]> = common::samples(300, 5)
        .iter()
        .map(|s| s.channels())
        .collect();
    let log = common::import_csv(
        dir.path(),
        "g",
        &common::channels_csv(&data, &[0, 1, 2], 100.0),
    );
    let (_, orig, _) = imuprep::io::log::read_log(&log).unwrap();
    for to in ["ubx", "mavlink", "ulog"] {
        let out = dir.path().join(format!("g.{to}"));
        common::run_cli(&[
            "export",
            log.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--to",
            to,
        ]);
        let back = dir.path().join(format!("g_{to}.log"));
        common::run_cli(&[
            "import",
            out.to_str().unwrap(),
            "-o",
            back.to_str().unwrap(),
        ]);
        let (d, got, st) = imuprep::io::log::read_log(&back).unwrap();
        assert_eq!(d.unwrap().absent, GYRO_ONLY, "{to}");
        assert_eq!(st.non_finite, 0, "{to}");
        assert_eq!(got.len(), orig.len(), "{to}");
        for (a, b) in orig.iter().zip(&got) {
            assert_eq!(b.absent, GYRO_ONLY, "{to}");
            for c in 0..3 {
                // UBX: half a count of 2⁻¹² °/s; the others carry the log's f32 exactly.
                let tol = if to == "ubx" {
                    0.5 * (1.0f64 / 4096.0).to_radians() + 1e-15
                } else {
                    0.0
                };
                assert!((a.channel(c) - b.channel(c)).abs() <= tol, "{to} ch {c}");
            }
        }
    }
    // An accel-only log cannot go to ULog: a clear error naming the channels, no file.
    let alog = common::import_csv(
        dir.path(),
        "a",
        &common::channels_csv(&data, &[3, 4, 5], 100.0),
    );
    let out = dir.path().join("a.ulg");
    let r = Command::new(common::bin())
        .args(["export", alog.to_str().unwrap(), "-o"])
        .arg(&out)
        .args(["--to", "ulog"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success(), "{err}");
    assert!(
        err.contains("gx, gy, gz") && err.contains("sensor_combined"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Fixtures (tests/reference/partial_*): the export of a gyro-only and an accel-only log, and
/// what pyubx2, pymavlink and pyulog read from them (check_partial_export.py): a channel the
/// reference library sees no data for is an empty cell.
const REF_CSV: &str = include_str!("reference/partial_export_reference.csv");
const REF_FILES: [(&str, ExportFormat, u8); 5] = [
    ("partial_gyro.ubx", ExportFormat::Ubx, GYRO_ONLY),
    ("partial_gyro.mavlink", ExportFormat::Mavlink, GYRO_ONLY),
    ("partial_gyro.ulg", ExportFormat::Ulog, GYRO_ONLY),
    ("partial_accel.ubx", ExportFormat::Ubx, ACCEL_ONLY),
    ("partial_accel.mavlink", ExportFormat::Mavlink, ACCEL_ONLY),
];

#[test]
fn the_reference_libraries_read_the_same_absence_and_values() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference");
    for (name, to, absent) in REF_FILES {
        let (mut d, mut s) = partial(absent);
        s.truncate(20);
        d.sample_rate_hz = 200.0;
        let bytes = encode_stream(to, &d, &s).unwrap();
        let path = dir.join(name);
        if std::env::var_os("IMUPREP_BLESS").is_some() {
            // Write every fixture; the reference CSV is the script's to make from them.
            std::fs::write(&path, &bytes).unwrap();
            continue;
        }
        assert_eq!(
            std::fs::read(&path).unwrap(),
            &bytes[..],
            "{name}: the export's bytes changed: run with IMUPREP_BLESS=1, then check_partial_export.py"
        );
        let got = decode_bytes(&bytes, &ProtocolConfig::auto()).samples;
        let rows: Vec<Vec<&str>> = REF_CSV
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|r| r[0] == name)
            .collect();
        assert_eq!(rows.len(), got.len(), "{name}: reference rows");
        for (r, g) in rows.iter().zip(&got) {
            assert_eq!(r[2].parse::<u64>().unwrap() * 1000, g.t_ns, "{name}");
            for c in 0..6 {
                let cell = r[3 + c];
                assert_eq!(cell.is_empty(), g.is_absent(c), "{name} {r:?} ch {c}");
                if !cell.is_empty() {
                    // The script converts with the same scale factors in f64; the values
                    // agree to f64 rounding of that conversion.
                    let v: f64 = cell.parse().unwrap();
                    assert!((v - g.channel(c)).abs() <= 1e-12, "{name} {r:?} ch {c}");
                }
            }
        }
    }
}

/// A HIGHRES_IMU stream of 40 samples whose first `late` messages carry only the gyro and
/// temperature bits (accel fields 0, as a sender with no accel reading yet may fill them),
/// with a HEARTBEAT after the second message.
fn late_accel_stream(late: usize) -> (Vec<Sample>, Vec<u8>) {
    let s = common::samples(40, 17);
    let mut b = BytesMut::new();
    for (i, x) in s.iter().enumerate() {
        let mut p = mavlink::highres_payload(x, 0);
        if i < late {
            p[8..20].fill(0);
            p[60..62].copy_from_slice(&(0x0038u16 | 0x1000).to_le_bytes());
        }
        mavlink::encode_v2(i as u8, 1, 1, mavlink::MSG_HIGHRES_IMU, &p, &mut b);
        if i == 1 {
            mavlink::encode_v2(0, 1, 1, 0, &[0, 0, 0, 0, 2, 3, 81, 4, 3], &mut b);
        }
    }
    (s, b.to_vec())
}

fn decode_items(b: &[u8]) -> (Vec<Decoded>, imuprep::frame::DecoderStats) {
    let mut d = MavlinkDecoder::default();
    let mut buf = BytesMut::from(b);
    let mut items = Vec::new();
    while let Some(x) = d.decode_item_eof(&mut buf) {
        items.push(x);
    }
    (items, d.stats())
}

#[test]
fn mavlink_accel_that_reports_late_is_missing_at_first_not_an_absent_channel() {
    // Users expect a 6-axis IMU whose accel starts reporting a few messages after its gyro to
    // be a 6-axis stream: accel present in the descriptor (which native logs and replays use
    // for the whole stream), the first samples' accel missing — NaN, flagged, counted — not a
    // gyro-only sensor for those samples and not zeros.
    let (sent, b) = late_accel_stream(5);
    let (items, stats) = decode_items(&b);
    let got: Vec<&Sample> = items
        .iter()
        .filter_map(|x| match x {
            Decoded::Sample(s, _) => Some(s),
            _ => None,
        })
        .collect();
    assert_eq!(got.len(), 40);
    let descriptors: Vec<_> = items
        .iter()
        .filter_map(|x| match x {
            Decoded::Descriptor(d) => Some(d.absent),
            _ => None,
        })
        .collect();
    assert_eq!(descriptors, [0], "one descriptor, every channel present");
    assert_eq!((stats.partial_samples, stats.non_finite), (5, 5));
    for (i, (a, g)) in sent.iter().zip(&got).enumerate() {
        assert_eq!(g.absent, 0, "#{i}");
        assert_eq!(
            g.gyro[0], a.gyro[0] as f32 as f64,
            "#{i}: gyro as sent (f32)"
        );
        if i < 5 {
            assert!(
                g.accel.iter().all(|v| v.is_nan()),
                "#{i}: accel {:?}",
                g.accel
            );
            assert!(g.has(flags::NON_FINITE), "#{i}");
        } else {
            assert_eq!(g.accel[2], a.accel[2] as f32 as f64, "#{i}");
            assert!(!g.has(flags::NON_FINITE), "#{i}");
        }
    }
    // The heartbeat held with the first samples keeps its place: after sample 1, before 2.
    let pos = |want: &dyn Fn(&Decoded) -> bool| items.iter().position(want).unwrap();
    let hb = pos(&|x| matches!(x, Decoded::Other(_)));
    let s1 = pos(&|x| matches!(x, Decoded::Sample(s, _) if s.seq == 1));
    let s2 = pos(&|x| matches!(x, Decoded::Sample(s, _) if s.seq == 2));
    assert!(
        s1 < hb && hb < s2,
        "order: sample 1 at {s1}, heartbeat at {hb}, sample 2 at {s2}"
    );
}

#[test]
fn mavlink_accel_after_the_hold_window_is_declared_present_again_and_survives_a_native_log() {
    // Accel first at message 25, after the 16 samples held to learn the channel set: the
    // first descriptor says gyro-only (then it was), a second one right after sample 25
    // declares accel present, and a file's descriptor (decode_bytes, import/export) keeps
    // accel, so a native log of the stream still has every accel reading after message 25.
    let (sent, b) = late_accel_stream(25);
    let (items, _) = decode_items(&b);
    let mut seen = Vec::new();
    for x in &items {
        match x {
            Decoded::Descriptor(d) => seen.push(format!("d{:#b}", d.absent)),
            Decoded::Sample(s, _) if s.seq == 25 => seen.push("s25".into()),
            _ => {}
        }
    }
    assert_eq!(seen, ["d0b111000", "s25", "d0b0"]);
    let f = decode_bytes(&b, &ProtocolConfig::auto());
    assert_eq!(f.descriptor.unwrap().absent, 0);
    let native = encode_stream(ExportFormat::Native, &f.descriptor.unwrap(), &f.samples).unwrap();
    let back = decode_bytes(&native, &ProtocolConfig::auto());
    assert_eq!(back.samples.len(), 40);
    for (i, (a, g)) in sent.iter().zip(&back.samples).enumerate().skip(25) {
        assert_eq!(g.absent, 0, "#{i}");
        assert_eq!(
            g.accel[0], a.accel[0] as f32 as f64,
            "#{i}: accel lost in the native log"
        );
    }
}

/// Both holds at the start of a MAVLink stream: the channel set's (the first 5 messages carry
/// no accel) and the period's (the first 16 samples). A gap at interval 3 (messages 3 and 4
/// dropped) is flagged on the next sample and the sequence counts the 2 missing; every other
/// sample comes out once, in order, the HEARTBEAT after the second, the descriptor (200 Hz,
/// accel present) after the 16th, at every chunking.
#[test]
fn mavlink_gap_at_interval_3_is_flagged_behind_the_channel_hold() {
    let (sent, all) = late_accel_stream(5);
    // Split the stream into its messages and drop messages 3 and 4 (v2 frame: 12 + len).
    let mut frames = Vec::new();
    let mut at = 0;
    while at < all.len() {
        let n = 12 + all[at + 1] as usize;
        frames.push(&all[at..at + n]);
        at += n;
    }
    // Frame 2 is the HEARTBEAT; messages 3 and 4 are frames 4 and 5.
    let b: Vec<u8> = frames
        .iter()
        .enumerate()
        .filter(|(k, _)| !(4..6).contains(k))
        .flat_map(|(_, f)| f.iter().copied())
        .collect();
    let kept: Vec<usize> = (0..40).filter(|i| !(3..5).contains(i)).collect();
    for chunk in [1, 13, 100, b.len()] {
        let mut d = MavlinkDecoder::default();
        let (items, st) = imuprep::frame::protocol::decode_chunked(&mut d, &b, chunk);
        let got: Vec<&Sample> = items.iter().filter_map(|x| x.sample()).collect();
        let t: Vec<u64> = got.iter().map(|s| s.t_ns).collect();
        let want_t: Vec<u64> = kept.iter().map(|&i| sent[i].t_ns).collect();
        assert_eq!(t, want_t, "chunk {chunk}");
        let seqs: Vec<usize> = got.iter().map(|s| s.seq as usize).collect();
        assert_eq!(seqs, kept, "chunk {chunk}");
        let gaps: Vec<u32> = got
            .iter()
            .filter(|s| s.has(flags::GAP))
            .map(|s| s.seq)
            .collect();
        assert_eq!(gaps, [5], "chunk {chunk}");
        assert_eq!((st.gaps, st.missing_frames), (1, 2));
        // Order: 2 samples, the HEARTBEAT, 14 samples, the descriptor.
        assert!(matches!(items[2], Decoded::Other(_)), "chunk {chunk}");
        match items[17] {
            Decoded::Descriptor(d) => {
                assert!((d.sample_rate_hz - 200.0).abs() < 1e-9);
                assert_eq!(d.absent, 0, "accel present");
            }
            ref x => panic!("chunk {chunk}: {x:?}"),
        }
        assert_eq!(items.len(), 38 + 2);
    }
}
