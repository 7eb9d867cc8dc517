//! ROS 2 bags (MCAP, sensor_msgs/msg/Imu in CDR) against a bag made by `rosbags` and the values
//! rosbags reads from it (tests/reference/gen_mcap_reference.py); inline re-encoding keeps every
//! message; the MCAP sink's bag is read back by the `mcap` crate here and by rosbags
//! (tests/reference/check_mcap_sink.py, its result committed). Needs `--features ros2`.
mod common;

use bytes::BytesMut;
use common::bag_opts;
use imuprep::frame::detect::{ProtocolChoice, ProtocolConfig, decode_bytes};
use imuprep::frame::inline::InlineEncoder;
use imuprep::frame::mcap::{McapDecoder, McapOptions};
use imuprep::frame::mcap_out::ChunkCompression;
use imuprep::frame::ros2;
use imuprep::frame::{
    AxisConvention, Decoded, DecoderStats, Descriptor, Protocol, ProtocolDecoder,
};
use imuprep::io::mcap_sink::{McapSinkOptions, encode_bag};
use imuprep::sample::{Sample, flags};

const BAG: &[u8] = include_bytes!("reference/mcap_bag.mcap");
const EXPECTED: &str = include_str!("reference/mcap_expected.csv");
const SINK_BAG: &str = "tests/reference/mcap_sink_bag.mcap";
const SINK_ROSBAGS: &str = include_str!("reference/mcap_sink_rosbags.csv");
const SINK_LZ4_BAG: &str = "tests/reference/mcap_sink_lz4_bag.mcap";
const SINK_LZ4_ROSBAGS: &str = include_str!("reference/mcap_sink_lz4_rosbags.csv");
const SINK_ZSTD_BAG: &str = "tests/reference/mcap_sink_zstd_bag.mcap";
const SINK_ZSTD_ROSBAGS: &str = include_str!("reference/mcap_sink_zstd_rosbags.csv");

fn run(d: &mut dyn ProtocolDecoder, bytes: &[u8], chunk: usize) -> (Vec<Decoded>, DecoderStats) {
    imuprep::frame::protocol::decode_chunked(d, bytes, chunk)
}

fn samples(items: &[Decoded]) -> Vec<Sample> {
    imuprep::frame::protocol::samples_of(items)
}

struct Row {
    topic: String,
    stamp: u64,
    log_time: u64,
    v: Vec<f64>,
}

fn expected(topic: &str) -> Vec<Row> {
    EXPECTED
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Row {
                topic: f[0].into(),
                stamp: f[1].parse().unwrap(),
                log_time: f[2].parse().unwrap(),
                v: f[3..].iter().map(|x| x.parse().unwrap()).collect(),
            }
        })
        .filter(|r| r.topic == topic)
        .collect()
}

/// Every record of an MCAP file, through the `mcap` crate (a second opinion on our output).
fn crate_messages(bytes: &[u8]) -> Vec<(String, String, u64, Vec<u8>)> {
    mcap::MessageStream::new(bytes)
        .expect("mcap crate opens it")
        .map(|m| {
            let m = m.expect("mcap crate reads every message");
            let schema = m
                .channel
                .schema
                .as_ref()
                .map_or(String::new(), |s| s.name.clone());
            (
                m.channel.topic.clone(),
                schema,
                m.log_time,
                m.data.into_owned(),
            )
        })
        .collect()
}

#[test]
fn values_equal_rosbags_at_every_chunking() {
    let want = expected("/imu/data");
    assert_eq!(want.len(), 60);
    for chunk in [1, 7, 512, 4096, BAG.len()] {
        let mut d = McapDecoder::new(bag_opts(None, "header"));
        let (items, st) = run(&mut d, BAG, chunk);
        let got = samples(&items);
        assert_eq!(got.len(), 60, "chunk {chunk}: {}", d.found());
        for (s, r) in got.iter().zip(&want) {
            assert_eq!(s.t_ns, r.stamp);
            // The same IEEE doubles on both sides: exact.
            assert_eq!(s.channels().to_vec(), r.v[..6].to_vec());
            assert_eq!(s.temp_c, None);
        }
        // Message 30 comes 10 ms after 29 at 200 Hz: one missing period, flagged.
        let gaps: Vec<usize> = (0..60).filter(|&i| got[i].has(flags::GAP)).collect();
        assert_eq!(gaps, vec![30]);
        assert_eq!(
            (st.missing_frames, st.garbage_bytes, st.crc_errors),
            (1, 0, 0)
        );
        // Everything else passes through: /imu/second, /chatter, schemas, channels, indexes.
        let others = items
            .iter()
            .filter(|d| matches!(d, Decoded::Other(_)))
            .count();
        assert!(others >= 20 + 12 + 3 + 3, "chunk {chunk}: {others}");
        assert!(d.found().contains("reading /imu/data"), "{}", d.found());
    }
}

#[test]
fn covariances_and_the_whole_message_stay_in_the_carrier() {
    let want = expected("/imu/data");
    let mut d = McapDecoder::default();
    let (items, _) = run(&mut d, BAG, 4096);
    let carriers: Vec<_> = items
        .iter()
        .filter_map(|d| match d {
            Decoded::Sample(_, c) => c.clone(),
            _ => None,
        })
        .collect();
    assert_eq!(carriers.len(), 60);
    for (c, r) in carriers.iter().zip(&want) {
        // Message record: opcode, length, channel/sequence/log/publish time, then the CDR.
        let m = ros2::decode_imu(&c.frame[9 + 22..]).unwrap();
        let g = m.angular_velocity_covariance;
        let a = m.linear_acceleration_covariance;
        assert_eq!(
            [g[0], g[4], g[8], a[0], a[4], a[8]].to_vec(),
            r.v[6..12].to_vec()
        );
        assert_eq!(m.orientation_covariance[0], r.v[12]);
        assert_eq!(m.frame_id, "imu_link");
    }
}

#[test]
fn topic_and_time_source_are_selectable() {
    let want = expected("/imu/second");
    assert_eq!(want.len(), 20);
    let mut d = McapDecoder::new(bag_opts(Some("/imu/second"), "log"));
    let (items, _) = run(&mut d, BAG, 333);
    let got = samples(&items);
    assert_eq!(got.len(), 20);
    for (s, r) in got.iter().zip(&want) {
        assert_eq!(s.t_ns, r.log_time);
        assert_eq!(s.channels().to_vec(), r.v[..6].to_vec());
    }
    // A topic that is not there: nothing read, and the summary says so.
    let mut d = McapDecoder::new(bag_opts(Some("/nope"), "header"));
    let (items, st) = run(&mut d, BAG, 4096);
    assert!(samples(&items).is_empty());
    assert_eq!(st.samples, 0);
    assert!(
        d.found()
            .contains("no sensor_msgs/msg/Imu topic named /nope"),
        "{}",
        d.found()
    );
}

#[test]
fn auto_detects_mcap_by_its_magic_and_the_flag_routes_the_topic() {
    let f = decode_bytes(BAG, &ProtocolConfig::auto());
    assert_eq!(f.protocol, Protocol::Mcap);
    assert_eq!(f.samples.len(), 60);
    assert_eq!(f.descriptor.map(|d| d.axes), Some(AxisConvention::Flu));
    assert!(
        f.found.contains("\"/imu/data\", \"/imu/second\""),
        "{}",
        f.found
    );
    let args = imuprep::frame::detect::ProtocolArgs {
        topic: Some("/imu/second".into()),
        ..Default::default()
    };
    let mut c = ProtocolConfig::auto();
    args.apply(&mut c);
    assert_eq!(c.mcap.topic.as_deref(), Some("/imu/second"));
    assert_eq!(
        c.ulog.topic, "sensor_combined",
        "a ROS topic leaves the ULog topic alone"
    );
    assert!(c.validate().is_empty());
    assert_eq!(decode_bytes(BAG, &c).samples.len(), 20);
    c.protocol = ProtocolChoice::Mcap;
    c.mcap.time = "wall".into();
    assert_eq!(c.validate().len(), 1);
}

/// Inline output: every message of the bag, the IMU ones with the cleaned values written in.
fn inline(items: &[Decoded], change: impl Fn(&Sample) -> Sample) -> Vec<u8> {
    let mut enc = InlineEncoder::new(Protocol::Mcap, 0.0, 0.0);
    let mut out = BytesMut::new();
    for it in items {
        match it {
            Decoded::Sample(s, c) => enc.sample(c.as_ref(), &change(s), &mut out),
            Decoded::Other(b) => enc.other(b, &mut out),
            Decoded::Descriptor(_) => {}
        }
    }
    enc.flush(&mut out);
    out.to_vec()
}

#[test]
fn inline_output_is_an_mcap_with_every_message_and_the_cleaned_values() {
    let mut d = McapDecoder::default();
    let (items, _) = run(&mut d, BAG, 4096);
    let input = crate_messages(BAG);
    assert_eq!(input.len(), 60 + 20 + 12);
    // Identity: every message, same topic, time and payload bytes, same order.
    let same = inline(&items, |s| *s);
    assert_eq!(crate_messages(&same), input);
    // Cleaned: gx + 1 rad/s on /imu/data only; covariances and everything else untouched.
    let out = inline(&items, |s| {
        let mut x = *s;
        x.gyro[0] += 1.0;
        x
    });
    let got = crate_messages(&out);
    assert_eq!(got.len(), input.len());
    let mut changed = 0;
    for (o, i) in got.iter().zip(&input) {
        assert_eq!((&o.0, &o.1, o.2), (&i.0, &i.1, i.2));
        if o.0 == "/imu/data" {
            let (a, b) = (
                ros2::decode_imu(&o.3).unwrap(),
                ros2::decode_imu(&i.3).unwrap(),
            );
            assert_eq!(a.angular_velocity[0], b.angular_velocity[0] + 1.0);
            assert_eq!(a.angular_velocity[1..], b.angular_velocity[1..]);
            assert_eq!(a.angular_velocity_covariance, b.angular_velocity_covariance);
            assert_eq!(a.linear_acceleration, b.linear_acceleration);
            changed += 1;
        } else {
            assert_eq!(o.3, i.3);
        }
    }
    assert_eq!(changed, 60);
    // And imuprep reads its own inline output back.
    let mut d2 = McapDecoder::default();
    let (items2, st2) = run(&mut d2, &out, 1000);
    assert_eq!(samples(&items2).len(), 60);
    assert_eq!(st2.garbage_bytes, 0);
}

#[test]
fn a_chunk_with_a_bad_crc_is_dropped_whole_and_garbage_is_survived() {
    // A bag written by the mcap crate (CRCs on): the sink's own output.
    let mut d = McapDecoder::default();
    let src = samples(&run(&mut d, BAG, 4096).0);
    let bag = encode_bag(&Descriptor::default(), &src, McapSinkOptions::default()).unwrap();
    let mut dec = McapDecoder::default();
    assert_eq!(samples(&run(&mut dec, &bag, 100).0).len(), 60);
    // Flip one byte inside an Imu payload: the chunk's CRC fails, its samples are not used.
    let at = bag
        .windows(8)
        .position(|w| w == src[10].gyro[0].to_le_bytes())
        .unwrap();
    let mut bad = bag.clone();
    bad[at + 3] ^= 0x40;
    let mut dec = McapDecoder::default();
    let (items, st) = run(&mut dec, &bad, 100);
    assert_eq!(st.crc_errors, 1);
    assert!(samples(&items).is_empty(), "one chunk holds them all");
    // Garbage before, between records and a cut-off tail: every sample still comes through.
    let mut g = vec![0x55u8; 37];
    g.extend_from_slice(BAG);
    g.extend_from_slice(&BAG[..200]);
    let mut dec = McapDecoder::default();
    let (items, st) = run(&mut dec, &g, 256);
    // The repeated head ends inside its chunk's first record: nothing more to decode there.
    assert_eq!(samples(&items).len(), 60);
    assert!(st.garbage_bytes >= 37);
    // Seeded random corruption: never a panic, never more samples than there are.
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    for _ in 0..300 {
        let mut b = BAG.to_vec();
        for _ in 0..4 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let i = (x as usize) % b.len();
            b[i] = (x >> 32) as u8;
        }
        let mut dec = McapDecoder::default();
        let (items, _) = run(&mut dec, &b, 1 + (x as usize % 3000));
        assert!(samples(&items).len() <= 60);
    }
}

/// The samples the sink test writes: the bag's /imu/data, with a bias estimate and its σ as
/// the bias stage would publish them.
fn sink_input() -> Vec<Sample> {
    let mut d = McapDecoder::default();
    let mut v = samples(&run(&mut d, BAG, 4096).0);
    for (i, s) in v.iter_mut().enumerate() {
        for c in 0..6 {
            s.bias[c] = 1e-3 * (c as f32 + 1.0);
            s.bias_sd[c] = 1e-4 * (c as f32 + 1.0) * (1.0 + i as f32 / 60.0);
        }
        s.flags |= flags::BIAS_REMOVED;
    }
    v
}

/// The sink's bag of [`sink_input`] (FLU axes) with `compression`, checked to be the committed
/// file at `path` (the one rosbags read: tests/reference/check_mcap_sink.py); written there
/// instead with IMUPREP_BLESS set.
fn sink_bag(v: &[Sample], compression: ChunkCompression, path: &str) -> Vec<u8> {
    let flu = Descriptor {
        axes: AxisConvention::Flu,
        ..Descriptor::default()
    };
    let opts = McapSinkOptions {
        compression,
        ..McapSinkOptions::default()
    };
    let bag = encode_bag(&flu, v, opts).unwrap();
    if std::env::var_os("IMUPREP_BLESS").is_some() {
        std::fs::write(path, &bag).unwrap();
    }
    assert!(
        std::fs::read(path).unwrap() == bag,
        "the sink's bytes changed ({path}): run with IMUPREP_BLESS=1, then the check script"
    );
    bag
}

#[test]
fn the_sink_writes_a_bag_the_mcap_crate_and_rosbags_read() {
    let v = sink_input();
    let bag = sink_bag(&v, ChunkCompression::None, SINK_BAG);
    let msgs = crate_messages(&bag);
    let imu: Vec<_> = msgs.iter().filter(|m| m.0 == "/imu/clean").collect();
    let health: Vec<_> = msgs.iter().filter(|m| m.0 == "/imuprep/health").collect();
    assert_eq!(imu.len(), 60);
    assert_eq!(imu[0].1, "sensor_msgs/msg/Imu");
    // 0.3 s of data: no full second, so the one health message at the end.
    assert_eq!(health.len(), 1);
    assert_eq!(health[0].1, "std_msgs/msg/String");
    let j: serde_json::Value =
        serde_json::from_str(&ros2::decode_string(&health[0].3).unwrap()).unwrap();
    assert_eq!(j["samples"], 60);
    assert_eq!(j["gap"], 1);
    for (m, s) in imu.iter().zip(&v) {
        let x = ros2::decode_imu(&m.3).unwrap();
        assert_eq!(m.2, s.t_ns);
        assert_eq!(x.angular_velocity.to_vec(), s.channels()[..3].to_vec());
        let sd = |c: usize| (s.bias_sd[c] as f64).powi(2);
        assert_eq!(x.angular_velocity_covariance[4], sd(1));
        assert_eq!(x.linear_acceleration_covariance[8], sd(5));
        assert_eq!(x.angular_velocity_covariance[1], 0.0);
        assert_eq!(x.orientation_covariance[0], -1.0);
    }
    // rosbags' reading of the committed bag: the same values, the same σ².
    let rows: Vec<Vec<f64>> = SINK_ROSBAGS
        .lines()
        .skip(1)
        .filter(|l| l.starts_with("/imu/clean"))
        .map(|l| l.split(',').skip(1).map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 60);
    for (r, s) in rows.iter().zip(&v) {
        assert_eq!(r[0] as u64, s.t_ns / 1_000_000_000);
        assert_eq!(r[1] as u64, s.t_ns % 1_000_000_000);
        assert_eq!(r[2..8].to_vec(), s.channels().to_vec());
        let var: Vec<f64> = s.bias_sd.iter().map(|x| (*x as f64).powi(2)).collect();
        assert_eq!(r[8..14].to_vec(), var);
    }
    assert!(
        SINK_ROSBAGS.contains("/imuprep/health"),
        "rosbags read the health topic"
    );
}

#[test]
fn frd_input_is_written_in_ros_flu_axes() {
    let mut s = Sample::default();
    s.set_channels(&[0.1, 0.2, 0.3, 1.0, 2.0, 9.8]);
    let frd = Descriptor {
        axes: AxisConvention::Frd,
        ..Descriptor::default()
    };
    let bag = encode_bag(&frd, &[s], McapSinkOptions::default()).unwrap();
    let m = crate_messages(&bag);
    let x = ros2::decode_imu(&m[0].3).unwrap();
    assert_eq!(x.angular_velocity, [0.1, -0.2, -0.3]);
    assert_eq!(x.linear_acceleration, [1.0, -2.0, -9.8]);
}

const TEMP_BAG: &[u8] = include_bytes!("reference/mcap_temp_bag.mcap");
const TEMP_EXPECTED: &str = include_str!("reference/mcap_temp_expected.csv");
const INLINE_BAG: &str = "tests/reference/mcap_inline_bag.mcap";
const INLINE_ROSBAGS: &str = include_str!("reference/mcap_inline_rosbags.csv");

#[test]
fn temperature_topic_is_joined_by_the_nearest_preceding_stamp() {
    // (stamp, temperature or blank) per Imu message, by the rule computed on rosbags' values
    // (tests/reference/gen_mcap_temperature.py).
    let want: Vec<(u64, Option<f64>)> = TEMP_EXPECTED
        .lines()
        .skip(1)
        .map(|l| {
            let (st, t) = l.split_once(',').unwrap();
            (st.parse().unwrap(), t.parse().ok())
        })
        .collect();
    assert_eq!(want.len(), 40);
    assert_eq!(want.iter().filter(|w| w.1.is_some()).count(), 36);
    for chunk in [1, 77, TEMP_BAG.len()] {
        let mut d = McapDecoder::default();
        let (items, st) = run(&mut d, TEMP_BAG, chunk);
        let got: Vec<(u64, Option<f64>)> =
            samples(&items).iter().map(|s| (s.t_ns, s.temp_c)).collect();
        // Exact: the same f64 rosbags deserialised.
        assert_eq!(got, want, "chunk {chunk}");
        assert_eq!(st.garbage_bytes, 0);
        assert!(
            d.found()
                .contains("temperature from /imu/temperature (4 readings)"),
            "{}",
            d.found()
        );
    }
    // Off by option, and too old a reading is not used.
    let mut off = McapDecoder::new(McapOptions {
        temperature_topic: Some(String::new()),
        ..McapOptions::default()
    });
    let (items, _) = run(&mut off, TEMP_BAG, 4096);
    assert!(samples(&items).iter().all(|s| s.temp_c.is_none()));
    // Readings are 50 ms apart: with a 10 ms limit only the samples within 10 ms of the last
    // reading before them keep it.
    let mut short = McapDecoder::new(McapOptions {
        temperature_max_age_s: 0.010,
        ..McapOptions::default()
    });
    let (items, _) = run(&mut short, TEMP_BAG, 4096);
    let n_short = samples(&items)
        .iter()
        .filter(|s| s.temp_c.is_some())
        .count();
    assert!(n_short > 0 && n_short < 36, "{n_short}");
}

#[test]
fn inline_output_keeps_a_chunk_index_the_mcap_crate_and_rosbags_seek_with() {
    let mut d = McapDecoder::default();
    let (items, _) = run(&mut d, BAG, 4096);
    let out = inline(&items, |s| *s);
    if std::env::var_os("IMUPREP_BLESS").is_some() {
        std::fs::write(INLINE_BAG, &out).unwrap();
    }
    // The committed bag is the one rosbags read (tests/reference/check_mcap_inline.py).
    assert_eq!(
        std::fs::read(INLINE_BAG).unwrap(),
        out,
        "the inline MCAP bytes changed: run with IMUPREP_BLESS=1, then the check script"
    );
    let input = crate_messages(BAG);
    // The summary: statistics, schemas, channels and a chunk index.
    let summary = mcap::Summary::read(&out)
        .expect("summary reads (CRC checked)")
        .expect("a summary");
    let stats = summary.stats.as_ref().expect("statistics");
    assert_eq!(stats.message_count, input.len() as u64);
    assert_eq!(stats.channel_count, 3);
    assert!(!summary.chunk_indexes.is_empty());
    // Seek: every message through the chunk indexes and message indexes, in log-time order.
    let mut seeked = Vec::new();
    for ci in &summary.chunk_indexes {
        let idx = summary
            .read_message_indexes(&out, ci)
            .expect("message indexes");
        let mut entries: Vec<_> = idx.values().flatten().collect();
        entries.sort_by_key(|e| (e.log_time, e.offset));
        for e in entries {
            let m = summary.seek_message(&out, ci, e).expect("seek");
            seeked.push((m.channel.topic.clone(), m.log_time, m.data.into_owned()));
        }
    }
    let mut want: Vec<_> = input
        .iter()
        .map(|m| (m.0.clone(), m.2, m.3.clone()))
        .collect();
    want.sort_by_key(|m| m.1);
    seeked.sort_by(|a, b| (a.1, &a.0).cmp(&(b.1, &b.0)));
    want.sort_by(|a, b| (a.1, &a.0).cmp(&(b.1, &b.0)));
    assert_eq!(seeked, want);
    // rosbags (through the index) reads the same Imu values the original gave it.
    let imu_rows: Vec<&str> = EXPECTED.lines().skip(1).collect();
    let got_rows: Vec<&str> = INLINE_ROSBAGS.lines().skip(1).collect();
    assert_eq!(got_rows, imu_rows);
    // A cut input still gives a closed, indexed file.
    let cut = &items[..items.len() / 2];
    let half = inline(cut, |s| *s);
    let s2 = mcap::Summary::read(&half).unwrap().expect("summary");
    assert!(s2.stats.unwrap().message_count > 0);
}

/// A gyro-only sensor's bag: the accel triad is "no data" by the message's own convention
/// (covariance[0] = -1), never a measured zero acceleration (issue 13 item 10).
#[test]
fn an_absent_triad_is_no_data_in_the_imu_message() {
    let w = imuprep::io::mcap_sink::ImuBagWriter::new(
        std::io::Cursor::new(Vec::new()),
        McapSinkOptions::default(),
    )
    .unwrap();
    let mut s = imuprep::sample::Sample {
        absent: 0b111_000,
        ..Default::default()
    };
    s.set_channels(&[0.1, 0.2, 0.3, f64::NAN, f64::NAN, f64::NAN]);
    let m = w.imu_msg(&s);
    assert_eq!(m.linear_acceleration_covariance[0], -1.0);
    assert_eq!(m.linear_acceleration, [0.0; 3]);
    assert!(m.angular_velocity_covariance[0] >= 0.0);
    assert_eq!(m.angular_velocity, [0.1, 0.2, 0.3]);
}

/// The decoder reads the convention back (issue 13 item 10): a gyro-only and an accel-only
/// bag from the sink decode with the other triad absent — NaN, `absent` set on every sample and
/// in the descriptor, not counted non-finite — and the present triad as written.
#[test]
fn a_triad_with_covariance_minus_one_decodes_as_absent_channels() {
    let flu = Descriptor {
        axes: AxisConvention::Flu,
        ..Descriptor::default()
    };
    let src = sink_input();
    for absent in [0b111_000u8, 0b000_111] {
        let v: Vec<Sample> = src
            .iter()
            .map(|s| {
                let mut s = *s;
                s.absent = absent;
                for c in 0..6 {
                    if s.is_absent(c) {
                        s.set_channel(c, f64::NAN);
                    }
                }
                s
            })
            .collect();
        let bag = encode_bag(&flu, &v, McapSinkOptions::default()).unwrap();
        let f = decode_bytes(&bag, &ProtocolConfig::auto());
        assert_eq!(f.protocol, Protocol::Mcap);
        assert_eq!(f.samples.len(), v.len(), "{absent:#b}");
        assert_eq!(f.descriptor.unwrap().absent, absent);
        assert_eq!(
            f.stats.non_finite, 0,
            "{absent:#b}: absent counted non-finite"
        );
        for (a, b) in v.iter().zip(&f.samples) {
            assert_eq!(b.absent, absent);
            assert!(!b.has(flags::NON_FINITE));
            for c in 0..6 {
                if b.is_absent(c) {
                    assert!(b.channel(c).is_nan(), "{absent:#b} ch {c}");
                } else {
                    assert_eq!(b.channel(c), a.channel(c), "{absent:#b} ch {c}");
                }
            }
        }
    }
    // One message says it, whatever numbers the vector holds: those are not data.
    let mut m = imuprep::io::mcap_sink::ImuBagWriter::new(
        std::io::Cursor::new(Vec::new()),
        McapSinkOptions::default(),
    )
    .unwrap()
    .imu_msg(&src[0]);
    m.linear_acceleration_covariance[0] = -1.0;
    m.linear_acceleration = [1.0, 2.0, 3.0];
    let mut cdr = Vec::new();
    ros2::encode_imu(&m, &mut cdr);
    let fast = ros2::decode_imu_fast(&cdr).unwrap();
    assert_eq!(fast.absent, 0b111_000);
    assert_eq!(fast.channels[3..], [1.0, 2.0, 3.0]);
    m.linear_acceleration_covariance[0] = 0.0;
    m.angular_velocity_covariance[0] = -1.0;
    cdr.clear();
    ros2::encode_imu(&m, &mut cdr);
    assert_eq!(ros2::decode_imu_fast(&cdr).unwrap().absent, 0b000_111);
}

/// Every message record in decoded items (the Imu ones are the samples' carriers), without
/// opcode, length and channel id (the two writers number channels their own way).
fn message_bodies(items: &[Decoded]) -> Vec<Vec<u8>> {
    items
        .iter()
        .filter_map(|x| match x {
            Decoded::Sample(_, Some(c)) => Some(c.frame.clone()),
            Decoded::Other(b) if b.first() == Some(&0x05) => Some(b.clone()),
            _ => None,
        })
        .map(|b| b[11..].to_vec())
        .collect()
}

#[test]
fn the_sink_writes_lz4_chunks_that_read_back_as_the_uncompressed_bag() {
    let v = sink_input();
    let plain = sink_bag(&v, ChunkCompression::None, SINK_BAG);
    let lz4 = sink_bag(&v, ChunkCompression::Lz4, SINK_LZ4_BAG);
    assert!(
        lz4.len() < plain.len(),
        "{} vs {} bytes",
        lz4.len(),
        plain.len()
    );
    // The summary, read by the mcap crate (no decompression needed): LZ4 chunks, every
    // message and both channels counted.
    let sum = mcap::Summary::read(&lz4).unwrap().expect("a summary");
    assert!(!sum.chunk_indexes.is_empty());
    assert!(sum.chunk_indexes.iter().all(|c| c.compression == "lz4"));
    let stats = sum.stats.expect("statistics");
    assert_eq!((stats.message_count, stats.channel_count), (61, 2));
    let topics: Vec<_> = sum.channels.values().map(|c| c.topic.clone()).collect();
    assert!(topics.contains(&"/imu/clean".into()) && topics.contains(&"/imuprep/health".into()));
    // imuprep's decoder: the same samples and the same message records as from the
    // uncompressed bag, at any chunking, CRCs checked and passed.
    let (want, _) = run(&mut McapDecoder::default(), &plain, 4096);
    for chunk in [1, 333, 1 << 20] {
        let (got, st) = run(&mut McapDecoder::default(), &lz4, chunk);
        assert_eq!(
            (st.crc_errors, st.unknown_type, st.garbage_bytes),
            (0, 0, 0)
        );
        assert_eq!(samples(&got), samples(&want), "chunk {chunk}");
        assert_eq!(message_bodies(&got), message_bodies(&want), "chunk {chunk}");
    }
    // rosbags read the committed LZ4 bag (check_mcap_sink.py): the same rows as it read from
    // the uncompressed one, health included.
    assert_eq!(SINK_LZ4_ROSBAGS, SINK_ROSBAGS);
    // A flipped byte inside the compressed data: the chunk is dropped (counted), no panic.
    let mut bad = lz4.clone();
    let at = sum.chunk_indexes[0].chunk_start_offset as usize + 120;
    bad[at] ^= 0x55;
    let (got, st) = run(&mut McapDecoder::default(), &bad, 4096);
    assert!(samples(&got).len() < 60);
    // Dropped, not passed through: a CRC failure or a chunk that does not inflate.
    assert_eq!(st.unknown_type, 0, "{st:?}");
    assert!(st.crc_errors + st.bad_payload >= 1, "{st:?}");
}

#[test]
fn the_sink_writes_zstd_chunks_that_read_back_as_the_uncompressed_bag() {
    let v = sink_input();
    let plain = sink_bag(&v, ChunkCompression::None, SINK_BAG);
    let lz4 = sink_bag(&v, ChunkCompression::Lz4, SINK_LZ4_BAG);
    let zstd = sink_bag(&v, ChunkCompression::Zstd, SINK_ZSTD_BAG);
    // ruzstd has only its fastest level (about zstd's 1): on this 61-message bag about the size
    // of LZ4's (10 893 vs 10 758 bytes), both under half the uncompressed 25 337.
    assert!(
        zstd.len() < plain.len() / 2 && lz4.len() < plain.len() / 2,
        "{} and {} vs {} bytes",
        zstd.len(),
        lz4.len(),
        plain.len()
    );
    // The summary (the mcap crate, no decompression needed): zstd chunks, every message.
    let sum = mcap::Summary::read(&zstd).unwrap().expect("a summary");
    assert!(!sum.chunk_indexes.is_empty());
    assert!(sum.chunk_indexes.iter().all(|c| c.compression == "zstd"));
    let stats = sum.stats.expect("statistics");
    assert_eq!((stats.message_count, stats.channel_count), (61, 2));
    // imuprep's decoder: the same samples and message records as from the uncompressed bag.
    let (want, _) = run(&mut McapDecoder::default(), &plain, 4096);
    for chunk in [1, 333, 1 << 20] {
        let (got, st) = run(&mut McapDecoder::default(), &zstd, chunk);
        assert_eq!(common::faults(&st), [0; 4]);
        assert_eq!(samples(&got), samples(&want), "chunk {chunk}");
        assert_eq!(message_bodies(&got), message_bodies(&want), "chunk {chunk}");
    }
    // rosbags (its zstd: the zstd library) read the committed zstd bag: the same rows as from
    // the uncompressed one (check_mcap_sink.py mcap_sink_zstd_bag.mcap mcap_sink_zstd_rosbags.csv).
    assert_eq!(SINK_ZSTD_ROSBAGS, SINK_ROSBAGS);
}

#[test]
fn replay_writes_an_lz4_or_zstd_bag_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    for kind in ["lz4", "zstd"] {
        let out = dir.path().join(format!("clean_{kind}.mcap"));
        let st = std::process::Command::new(env!("CARGO_BIN_EXE_imuprep"))
            .args([
                "replay",
                "tests/reference/mcap_bag.mcap",
                "--protocol",
                "auto",
            ])
            .arg("--out")
            .arg(format!("mcap+{kind}:{}", out.display()))
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
        let b = std::fs::read(&out).unwrap();
        let sum = mcap::Summary::read(&b).unwrap().expect("a summary");
        assert!(sum.chunk_indexes.iter().all(|c| c.compression == kind));
        let f = decode_bytes(&b, &ProtocolConfig::auto());
        assert_eq!(
            f.samples.len(),
            60,
            "the bag's 60 /imu/data samples, cleaned ({kind})"
        );
    }
}

/// The MCAP decoder learns the period from the first 15 intervals; a gap among them (3 samples
/// missing before the 4th, interval 3) is flagged and counted, the sequence counts the missing
/// samples, every sample comes out once in order with the descriptor right after the 16th,
/// at every chunking. Before the first samples were held, this gap went unflagged.
#[test]
fn a_gap_among_the_first_intervals_of_a_bag_is_flagged() {
    let idx: Vec<u64> = (0..40u64).filter(|i| !(3..6).contains(i)).collect();
    let v: Vec<Sample> = idx
        .iter()
        .map(|&i| {
            let mut s = Sample {
                t_ns: 1_000_000_000 + i * 10_000_000,
                ..Sample::default()
            };
            s.set_channels(&[i as f64 * 1e-2, 0.1, -0.1, 0.2, -0.2, -9.8]);
            s
        })
        .collect();
    let bag = encode_bag(&Descriptor::default(), &v, McapSinkOptions::default()).unwrap();
    for chunk in [1, 7, 64, 4096, bag.len()] {
        let mut d = McapDecoder::default();
        let (items, st) = run(&mut d, &bag, chunk);
        let got = samples(&items);
        let ids: Vec<u64> = got
            .iter()
            .map(|s| (s.gyro[0] * 100.0).round() as u64)
            .collect();
        assert_eq!(ids, idx, "chunk {chunk}");
        let seqs: Vec<u64> = got.iter().map(|s| s.seq as u64).collect();
        assert_eq!(
            seqs, idx,
            "chunk {chunk}: the sequence counts the missing samples"
        );
        let gaps: Vec<u64> = got
            .iter()
            .filter(|s| s.has(flags::GAP))
            .map(|s| s.seq as u64)
            .collect();
        assert_eq!(gaps, [6], "chunk {chunk}");
        assert_eq!((st.gaps, st.missing_frames, st.samples), (1, 3, 37));
        // The descriptor (100 Hz) right after the 16th sample, as before the hold.
        let at = items
            .iter()
            .position(|x| matches!(x, Decoded::Descriptor(_)))
            .unwrap();
        let before = items[..at].iter().filter(|x| x.sample().is_some()).count();
        assert_eq!(before, 16, "chunk {chunk}");
        assert!(
            matches!(items[at], Decoded::Descriptor(d) if (d.sample_rate_hz - 100.0).abs() < 1e-9)
        );
    }
}
