//! ROS 1 bags (`--features ros1`): `imuprep import IN.bag` against what rosbags (a reader nobody
//! here wrote) reads from the same bags, with chunks uncompressed, bzip2 and LZ4
//! (`tests/reference/gen_ros1_reference.py` writes the bags and `ros1_expected.csv`); and
//! damaged bags said, never a panic.

mod common;

use std::path::{Path, PathBuf};

use common::{assert_says, bag_opts, import_ok, imuprep};

use imuprep::frame::ros2::McapOptions;
use imuprep::io::bag::TopicError;
use imuprep::io::ros1::{Ros1Error, read_bag};

const EXPECTED: &str = include_str!("reference/ros1_expected.csv");
const BAGS: [&str; 3] = ["none", "bz2", "lz4"];

fn bag(name: &str) -> PathBuf {
    PathBuf::from(format!("tests/reference/ros1_bag_{name}.bag"))
}

/// Rows of ros1_expected.csv for `topic`: stamp, record time, six channels, accel
/// covariance[0], joined temperature.
#[allow(clippy::type_complexity)]
fn expected(topic: &str) -> Vec<(u64, u64, [f64; 6], f64, Option<f64>)> {
    EXPECTED
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[0] == topic)
        .map(|c| {
            let f = |i: usize| c[i].parse::<f64>().unwrap();
            (
                c[1].parse().unwrap(),
                c[2].parse().unwrap(),
                [f(3), f(4), f(5), f(6), f(7), f(8)],
                f(9),
                (!c[10].is_empty()).then(|| f(10)),
            )
        })
        .collect()
}

#[test]
fn values_equal_rosbags_for_every_chunk_compression() {
    let want = expected("/imu/data");
    assert_eq!(want.len(), 80);
    for name in BAGS {
        let b = read_bag(&bag(name), &McapOptions::default()).unwrap();
        assert_eq!(b.samples.len(), want.len(), "{name}");
        assert_eq!(b.stats.bad_payload + b.stats.truncated, 0, "{name}");
        for (i, (s, w)) in b.samples.iter().zip(&want).enumerate() {
            assert_eq!(s.t_ns, w.0, "{name} #{i}: the header stamp");
            assert_eq!(s.temp_c, w.4, "{name} #{i}: the joined temperature");
            let got = [
                s.gyro.x, s.gyro.y, s.gyro.z, s.accel.x, s.accel.y, s.accel.z,
            ];
            if w.3 == -1.0 {
                // Message 50's accel is "not available": absent, the gyro kept.
                assert_eq!(s.absent, 0b111_000, "{name} #{i}");
                assert_eq!(got[..3], w.2[..3]);
                assert!(got[3..].iter().all(|v| v.is_nan()));
            } else {
                // Exactly: the same f64 bits rosbags reads.
                assert_eq!(s.absent, 0, "{name} #{i}");
                assert_eq!(got, w.2, "{name} #{i}");
            }
        }
        assert_says(
            &b.found,
            &[
                "80 sensor_msgs/Imu messages on /imu/data",
                "other Imu topics not read: /imu/second",
                "/imu/temperature, joined to 74 of 80",
            ],
        );
    }
}

#[test]
fn topic_and_time_source_are_selectable() {
    let want = expected("/imu/second");
    let b = read_bag(&bag("lz4"), &bag_opts(Some("/imu/second"), "log")).unwrap();
    assert_eq!(b.samples.len(), 10);
    for (s, w) in b.samples.iter().zip(&want) {
        assert_eq!(s.t_ns, w.1, "the record's time");
        assert_eq!(s.gyro.x, w.2[0]);
    }
    match read_bag(&bag("lz4"), &bag_opts(Some("/imu/nope"), "header")) {
        Err(e @ Ros1Error::Topic(TopicError::NoSuchTopic { .. })) => {
            let m = e.to_string();
            assert!(m.contains("/imu/data, /imu/second"), "{m}");
        }
        other => panic!("{other:?}"),
    }
    // A temperature topic asked for and not there is an error, not a silent no-op.
    let mut o = McapOptions {
        temperature_topic: Some("/nope".into()),
        ..McapOptions::default()
    };
    assert!(matches!(
        read_bag(&bag("none"), &o),
        Err(Ros1Error::Topic(TopicError::NoSuchTopic { .. }))
    ));
    o.temperature_topic = Some(String::new());
    let b = read_bag(&bag("none"), &o).unwrap();
    assert!(b.samples.iter().all(|s| s.temp_c.is_none()));
}

/// Also: a table's flag on the bag is refused.
#[test]
fn import_writes_a_log_with_the_gap_flagged_and_replay_runs_it() {
    let dir = std::env::temp_dir().join(format!("imuprep_ros1_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("bag.log");
    let err = import_ok("tests/reference/ros1_bag_bz2.bag", &log);
    assert_says(
        &err,
        &[
            "ROS 1 bag input: 80 sensor_msgs/Imu messages",
            "100.000 Hz nominal",
            "1 gap (1 sample missing)",
        ],
    );
    let csv = dir.join("bag.csv");
    let out = imuprep(&["export", log.to_str().unwrap(), "-o", csv.to_str().unwrap()]);
    assert!(out.status.success());
    let text = std::fs::read_to_string(&csv).unwrap();
    let gap_flag = 1 << 8;
    let flagged: Vec<usize> = text
        .lines()
        .skip(1)
        .enumerate()
        .filter(|(_, l)| l.rsplit(',').next().unwrap().parse::<u32>().unwrap() & gap_flag != 0)
        .map(|(i, _)| i)
        .collect();
    assert_eq!(flagged, vec![40], "the sample after the 20-ms step");
    // The log on replay, and the bag itself (imported into a temporary log and that replayed):
    // the same cleaned output.
    let replayed = |input: &Path, name: &str| {
        let out_csv = dir.join(name);
        let out = imuprep(&[
            "replay",
            input.to_str().unwrap(),
            "--out",
            &format!("csv:{}", out_csv.display()),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{}: {err}", input.display());
        std::fs::read(out_csv).unwrap()
    };
    let of_log = replayed(&log, "log_out.csv");
    assert_eq!(
        of_log.iter().filter(|b| **b == b'\n').count(),
        81,
        "a header, 80 samples"
    );
    let of_bag = replayed(Path::new("tests/reference/ros1_bag_bz2.bag"), "bag_out.csv");
    assert!(
        of_bag == of_log,
        "replay of the bag differs from replay of its import"
    );
    // A text table's flag on a bag is refused, naming it: the bag's messages carry their own
    // units and stamps, and the flag would be ignored.
    let out = imuprep(&[
        "import",
        "tests/reference/ros1_bag_bz2.bag",
        "--gyro-unit",
        "deg/s",
        "-o",
        log.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_says(
        &err,
        &[
            "read as a ROS 1 bag, whose messages carry their own units",
            "--gyro-unit read only a text table",
        ],
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `bytes` written to a temporary file, read.
fn read_bytes(bytes: &[u8], tag: &str) -> Result<imuprep::io::bag::BagRead, Ros1Error> {
    let p = std::env::temp_dir().join(format!("imuprep_ros1_{}_{tag}.bag", std::process::id()));
    std::fs::write(&p, bytes).unwrap();
    let r = read_bag(&p, &McapOptions::default());
    std::fs::remove_file(&p).ok();
    r
}

#[test]
fn damaged_bags_are_said_and_never_panic() {
    for name in BAGS {
        let good = std::fs::read(bag(name)).unwrap();
        // Cut before the index: refused with the way out; cut inside the index: the topics
        // are taken from the chunks, every sample kept, the damage said.
        for cut in (0..good.len()).step_by(997) {
            match read_bytes(&good[..cut], "cut") {
                Err(Ros1Error::Unindexed { .. } | Ros1Error::NotABag | Ros1Error::BadHeader(_)) => {
                }
                Ok(b) => {
                    assert_eq!(b.samples.len(), 80, "{name} cut at {cut}");
                    assert!(b.found.contains("index is damaged"), "{}", b.found);
                }
                Err(e) => panic!("{name} cut at {cut}: {e}"),
            }
        }
        // A byte changed anywhere (seeded positions, every byte value class): a result or an
        // error, never a panic; and never more samples than the bag holds.
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for k in 0..300 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let mut bad = good.clone();
            let at = (x % good.len() as u64) as usize;
            bad[at] = bad[at].wrapping_add(1 + (k % 255) as u8);
            if let Ok(b) = read_bytes(&bad, "flip") {
                assert!(b.samples.len() <= 80, "{name} byte {at}");
            }
        }
    }
    // A recording that did not end cleanly has index_pos 0: refused, `rosbag reindex` named.
    let mut unindexed = std::fs::read(bag("none")).unwrap();
    let at = unindexed
        .windows(10)
        .position(|w| w == b"index_pos=")
        .unwrap()
        + 10;
    unindexed[at..at + 8].fill(0);
    let e = read_bytes(&unindexed, "unindexed").unwrap_err();
    assert!(e.to_string().contains("rosbag reindex"), "{e}");
    // A chunk whose size field is wrong (here 4 GiB) is lost alone: the index finds the next.
    for name in ["bz2", "lz4", "none"] {
        let mut b = std::fs::read(bag(name)).unwrap();
        let at = b.windows(5).position(|w| w == b"size=").unwrap() + 5;
        b[at..at + 4].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
        let r = read_bytes(&b, "size").unwrap();
        assert_eq!(r.stats.truncated, 1, "{name}");
        assert!(
            (60..80).contains(&r.samples.len()),
            "{name}: {}",
            r.samples.len()
        );
        assert!(r.found.contains("WARNING: 1 record damaged"), "{}", r.found);
    }
}

#[test]
fn import_without_a_ros1_bag_goes_the_old_way() {
    // Not a bag: the ROS 1 reader is not tried (a native log imports as before).
    assert!(!imuprep::io::ros1::is_bag(Path::new(
        "tests/reference/mcap_bag.mcap"
    )));
    assert!(imuprep::io::ros1::is_bag(&bag("lz4")));
}
