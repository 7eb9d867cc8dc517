//! ROS 2 bags in SQLite (`--features ros2-sqlite`): `imuprep import BAG_DIR` against what rosbags
//! (a reader nobody here wrote) reads from the same messages
//! (`tests/reference/gen_db3_reference.py` writes the messages of the MCAP reference bags again
//! with rosbags' SQLite storage; `mcap_expected.csv` is rosbags' reading of them); damaged
//! databases said, never a panic.

mod common;

use std::path::Path;

use common::{assert_says, bag_opts, import_ok, imuprep};

use imuprep::frame::ros2::McapOptions;
use imuprep::io::bag::TopicError;
use imuprep::io::ros2_db3::{Db3Error, is_db3, read_db3};

const EXPECTED: &str = include_str!("reference/mcap_expected.csv");
const TEMP_EXPECTED: &str = include_str!("reference/db3_temp_expected.csv");
const BAG_DIR: &str = "tests/reference/db3_bag";
const BAG_FILE: &str = "tests/reference/db3_bag/db3_bag_0.db3";
const TEMP_BAG: &str = "tests/reference/db3_temp.db3";
/// The same messages in two files, split as rosbag2 splits a recording, topic ids differing.
const SPLIT_DIR: &str = "tests/reference/db3_split";

/// Rows of mcap_expected.csv for `topic`: stamp, log time, gx … az, and the accel and
/// orientation covariance[0].
fn expected(topic: &str) -> Vec<(u64, u64, Vec<f64>)> {
    EXPECTED
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[0] == topic)
        .map(|c| {
            (
                c[1].parse().unwrap(),
                c[2].parse().unwrap(),
                c[3..9].iter().map(|x| x.parse().unwrap()).collect(),
            )
        })
        .collect()
}

#[test]
fn values_equal_rosbags_from_the_directory_or_the_file() {
    for path in [BAG_DIR, BAG_FILE, SPLIT_DIR] {
        assert!(is_db3(Path::new(path)));
        for (topic, n) in [("/imu/data", 60), ("/imu/second", 20)] {
            let want = expected(topic);
            assert_eq!(want.len(), n);
            let b = read_db3(Path::new(path), &bag_opts(Some(topic), "header")).unwrap();
            assert_eq!(b.samples.len(), n, "{path} {topic}");
            assert_eq!(b.stats.bad_payload + b.stats.truncated, 0);
            for (i, (s, w)) in b.samples.iter().zip(&want).enumerate() {
                assert_eq!(s.t_ns, w.0, "{path} {topic} #{i}");
                let got = [
                    s.gyro.x, s.gyro.y, s.gyro.z, s.accel.x, s.accel.y, s.accel.z,
                ];
                // Exactly: the same f64 bits rosbags reads.
                assert_eq!(got.to_vec(), w.2, "{path} {topic} #{i}");
                assert_eq!(s.absent, 0);
            }
            let b = read_db3(Path::new(path), &bag_opts(Some(topic), "log")).unwrap();
            let logs: Vec<u64> = b.samples.iter().map(|s| s.t_ns).collect();
            assert_eq!(logs, want.iter().map(|w| w.1).collect::<Vec<_>>());
        }
    }
    // The default topic is the first Imu topic; the others and the String topic are named.
    let b = read_db3(Path::new(BAG_DIR), &McapOptions::default()).unwrap();
    assert_says(
        &b.found,
        &["60 sensor_msgs/msg/Imu messages on /imu/data (1 file)"],
    );
    let b = read_db3(Path::new(SPLIT_DIR), &McapOptions::default()).unwrap();
    assert_says(
        &b.found,
        &[
            "60 sensor_msgs/msg/Imu messages on /imu/data (2 files)",
            "other Imu topics not read: /imu/second",
            "32 messages on other topics",
        ],
    );
}

#[test]
fn temperature_is_joined_over_the_whole_bag() {
    let want: Vec<(u64, Option<f64>)> = TEMP_EXPECTED
        .lines()
        .skip(1)
        .map(|l| {
            let (t, c) = l.split_once(',').unwrap();
            (
                t.parse().unwrap(),
                (!c.is_empty()).then(|| c.parse().unwrap()),
            )
        })
        .collect();
    let b = read_db3(Path::new(TEMP_BAG), &McapOptions::default()).unwrap();
    let got: Vec<(u64, Option<f64>)> = b.samples.iter().map(|s| (s.t_ns, s.temp_c)).collect();
    assert_eq!(got, want);
    let joined = want.iter().filter(|w| w.1.is_some()).count();
    assert_says(&b.found, &[&format!("joined to {joined} of 40 samples")]);
    let o = McapOptions {
        temperature_topic: Some("/nope".into()),
        ..McapOptions::default()
    };
    assert!(matches!(
        read_db3(Path::new(TEMP_BAG), &o),
        Err(Db3Error::Topic(TopicError::NoSuchTopic { .. }))
    ));
}

#[test]
fn import_and_replay_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bag.log");
    let run = imuprep;
    let err = import_ok(BAG_DIR, &log);
    assert_says(
        &err,
        &[
            "ROS 2 bag (SQLite) input: 60 sensor_msgs/msg/Imu",
            "200.000 Hz nominal",
            "1 gap (1 sample missing)",
        ],
    );
    // The bag on replay, its directory or its file: imported into a temporary log and that
    // replayed, the output the replay of the log `import` wrote.
    let replayed = |input: &str, name: &str| {
        let csv = dir.path().join(name);
        let out = run(&["replay", input, "--out", &format!("csv:{}", csv.display())]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{input}: {err}");
        std::fs::read(csv).unwrap()
    };
    let of_log = replayed(log.to_str().unwrap(), "log.csv");
    assert_eq!(
        of_log.iter().filter(|b| **b == b'\n').count(),
        61,
        "a header, 60 samples"
    );
    assert!(
        replayed(BAG_DIR, "dir.csv") == of_log,
        "replay of the bag directory"
    );
    assert!(
        replayed(BAG_FILE, "file.csv") == of_log,
        "replay of the bag file"
    );
    // An SQLite file that is no bag, and a topic not in the bag: errors naming why.
    let not_bag = Path::new("tests/reference/db3_not_a_bag.db3");
    let out = run(&[
        "import",
        not_bag.to_str().unwrap(),
        "-o",
        log.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("not a rosbag2 bag"), "{err}");
    let out = run(&[
        "import",
        BAG_DIR,
        "--topic",
        "/x",
        "-o",
        log.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("its sensor_msgs/msg/Imu topics: /imu/data, /imu/second"),
        "{err}"
    );
}

#[test]
fn damaged_databases_are_said_and_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.db3");
    let good = std::fs::read(BAG_FILE).unwrap();
    let mut outcomes = [0usize; 2];
    // Cut anywhere, and a byte changed anywhere (seeded positions): a result or an error,
    // never a panic, and never more samples than the bag holds unless damage is said.
    let mut x: u64 = 0x2545_F491_4F6C_DD1D;
    for k in 0..400usize {
        let bytes = if k < 60 {
            good[..k * good.len() / 60].to_vec()
        } else {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let mut b = good.clone();
            let at = (x % good.len() as u64) as usize;
            b[at] = b[at].wrapping_add(1 + (k % 255) as u8);
            b
        };
        std::fs::write(&p, &bytes).unwrap();
        match read_db3(&p, &McapOptions::default()) {
            Ok(b) => {
                // SQLite pages carry no checksum: a changed byte can change a value or a row
                // unseen by the query; where it breaks the file's structure, SQLite's own
                // check says so and the import warns.
                assert!(
                    b.samples.len() <= 60 || b.found.contains("WARNING"),
                    "case {k}: {}",
                    b.found
                );
                outcomes[0] += 1;
            }
            Err(_) => outcomes[1] += 1,
        }
    }
    eprintln!("damaged: {} read, {} refused", outcomes[0], outcomes[1]);
}
