//! ROS 2 bags compressed as rosbag2 compresses them (zstd: MCAP chunks, each message, or the
//! whole file), made by `rosbags` with the zstd library (tests/reference/gen_zstd_bags.py) from
//! the uncompressed reference bags: each must give exactly what its uncompressed twin gives
//! (whose values tests/ros2_mcap.rs and tests/ros2_db3.rs check against rosbags' reading).
//! The MCAP tests need `--features ros2`, the SQLite ones `--features ros2-sqlite`; in a build
//! with neither this file has no tests.
#![cfg(any(feature = "ros2", feature = "ros2-sqlite"))]

mod common;

use common::{assert_says, import_ok, imuprep};

const R: &str = "tests/reference";

/// `imuprep import IN` then `export`: the import's output (stdout and stderr) and the CSV.
fn import_csv(input: &str) -> (String, String) {
    let dir = tempfile::tempdir().unwrap();
    let (log, csv) = (dir.path().join("x.log"), dir.path().join("x.csv"));
    let said = import_ok(input, &log);
    let ex = imuprep(&["export", log.to_str().unwrap(), "-o", csv.to_str().unwrap()]);
    assert!(ex.status.success());
    (said, std::fs::read_to_string(csv).unwrap())
}

/// The compressed bag imports to the very CSV of its uncompressed twin; what it said.
fn imports_as(compressed: &str, plain: &str) -> String {
    let (said, got) = import_csv(&format!("{R}/{compressed}"));
    let (_, want) = import_csv(&format!("{R}/{plain}"));
    assert!(want.lines().count() > 40, "{want}");
    assert_eq!(got, want, "{compressed} against {plain}");
    said
}

/// A compressed file that inflates to something that is no recording: what the import of the
/// inflated copy says, naming the file given (not the temporary copy).
#[test]
fn what_the_inflated_file_holds_is_said_of_the_file_given() {
    let dir = tempfile::tempdir().unwrap();
    let z = dir.path().join("notes.txt.zstd");
    let text = b"a line of prose, not a table\nand another one here\n";
    std::fs::write(&z, imuprep::frame::inflate::zstd_compress(text)).unwrap();
    let log = dir.path().join("x.log");
    let out = imuprep(&["import", z.to_str().unwrap(), "-o", log.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_says(
        &err,
        &[
            &format!("{}: text, but not a table", z.display()),
            "(inflated from zstd)",
        ],
    );
    // Not the temporary copy's name (the file without `.zstd`).
    assert!(!err.contains("notes.txt:"), "{err}");
}

#[cfg(feature = "ros2")]
mod mcap {
    use super::*;
    use bytes::BytesMut;
    use imuprep::frame::inflate;
    use imuprep::frame::inline::InlineEncoder;
    use imuprep::frame::mcap::McapDecoder;
    use imuprep::frame::protocol::{decode_chunked, samples_of};
    use imuprep::frame::{Decoded, DecoderStats, Protocol, ProtocolDecoder, ros2};
    use std::path::Path;

    const PLAIN: &[u8] = include_bytes!("reference/mcap_bag.mcap");
    const CHUNKS: &[u8] = include_bytes!("reference/zstd_chunks.mcap");
    const TEMP_PLAIN: &[u8] = include_bytes!("reference/mcap_temp_bag.mcap");
    const MESSAGES: &[u8] = include_bytes!("reference/zstd_message.mcap");

    fn run(bytes: &[u8], chunk: usize) -> (Vec<Decoded>, DecoderStats, String) {
        let mut d = McapDecoder::default();
        let (items, st) = decode_chunked(&mut d, bytes, chunk);
        (items, st, d.found())
    }

    /// The Other records that are messages (not the Imu ones), without opcode and length.
    fn other_messages(items: &[Decoded]) -> Vec<Vec<u8>> {
        items
            .iter()
            .filter_map(|x| match x {
                Decoded::Other(b) if b.first() == Some(&0x05) => Some(b[9..].to_vec()),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn zstd_chunks_decode_to_the_samples_and_records_of_the_uncompressed_bag() {
        let (want, _, _) = run(PLAIN, 4096);
        assert_eq!(samples_of(&want).len(), 60);
        // Any split of the bytes into reads (1 byte at a time included) gives the same.
        for chunk in [1, 333, 4096, 1 << 20] {
            let (got, st, found) = run(CHUNKS, chunk);
            assert_eq!(samples_of(&got), samples_of(&want), "chunk {chunk}");
            assert_eq!(other_messages(&got), other_messages(&want), "chunk {chunk}");
            assert_eq!(common::faults(&st), [0; 4]);
            assert_says(&found, &["1 chunks (1 compressed)", "reading /imu/data"]);
        }
    }

    #[test]
    fn messages_compressed_one_by_one_decode_as_the_uncompressed_ones_temperature_too() {
        let (want, _, _) = run(TEMP_PLAIN, 4096);
        let (got, st, found) = run(MESSAGES, 777);
        let (w, g) = (samples_of(&want), samples_of(&got));
        assert_eq!(g.len(), 40);
        assert_eq!(g, w);
        // The temperature topic is compressed too: the same readings joined (samples compared
        // whole above, temperature included; here that there are some).
        assert!(g.iter().filter(|s| s.temp_c.is_some()).count() > 30);
        assert_eq!(st.bad_payload, 0);
        assert_says(
            &found,
            &["(40 messages zstd-compressed one by one)", "(4 readings)"],
        );
    }

    /// The inline output of a bag whose messages are compressed one by one keeps them so (its
    /// metadata.yaml says `compression_mode: message`, which every reader of it will apply), with
    /// the cleaned values inside.
    #[test]
    fn inline_output_compresses_each_cleaned_message_again() {
        let (items, _, _) = run(MESSAGES, 4096);
        let mut enc = InlineEncoder::new(Protocol::Mcap, 0.0, 0.0);
        let mut out = BytesMut::new();
        for it in &items {
            match it {
                Decoded::Sample(s, c) => {
                    let mut x = *s;
                    x.gyro[0] += 1.0;
                    enc.sample(c.as_ref(), &x, &mut out)
                }
                Decoded::Other(b) => enc.other(b, &mut out),
                Decoded::Descriptor(_) => {}
            }
        }
        enc.flush(&mut out);
        // Each Imu message of the output, through our decoder: still compressed, and gx + 1.
        let (back, st, found) = run(&out, 4096);
        assert_eq!(st.bad_payload, 0);
        assert_says(&found, &["(40 messages zstd-compressed one by one)"]);
        let (a, b) = (samples_of(&back), samples_of(&items));
        assert_eq!(a.len(), 40);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.gyro[0], y.gyro[0] + 1.0);
            assert_eq!((x.gyro[1], x.gyro[2]), (y.gyro[1], y.gyro[2]));
            assert_eq!((x.accel, x.t_ns), (y.accel, y.t_ns));
        }
        // Everything but angular_velocity.x is the input's message, byte for byte, once inflated.
        let carriers = |v: &[Decoded]| -> Vec<Vec<u8>> {
            v.iter()
                .filter_map(|x| match x {
                    Decoded::Sample(_, Some(c)) => Some(c.frame[9 + 22..].to_vec()),
                    _ => None,
                })
                .collect()
        };
        for (o, i) in carriers(&back).iter().zip(carriers(&items)) {
            assert!(inflate::is_zstd(o));
            let (o, i) = (
                inflate::zstd(o, 1 << 20).unwrap(),
                inflate::zstd(&i, 1 << 20).unwrap(),
            );
            let (mo, mi) = (ros2::decode_imu(&o).unwrap(), ros2::decode_imu(&i).unwrap());
            assert_eq!(mo.angular_velocity[0], mi.angular_velocity[0] + 1.0);
            assert_eq!(o.len(), i.len());
            let at = ros2::decode_imu_fast(&i).unwrap().angular_velocity_at;
            assert_eq!((&o[..at], &o[at + 8..]), (&i[..at], &i[at + 8..]));
        }
    }

    /// Seeded changed bytes anywhere in both compressed bags: a result or a counted fault, never
    /// a panic, never more samples than the bag holds.
    #[test]
    fn changed_bytes_in_compressed_bags_never_panic() {
        let mut rng = imuprep::rng::Rng::new(33);
        for (bag, n) in [(CHUNKS, 60), (MESSAGES, 40)] {
            for _ in 0..400 {
                let mut b = bag.to_vec();
                let at = rng.below(b.len() as u64) as usize;
                b[at] ^= 1 + rng.below(255) as u8;
                let (items, _, _) = run(&b, 1 + rng.below(5000) as usize);
                assert!(samples_of(&items).len() <= n);
            }
        }
    }

    #[test]
    fn a_bag_compressed_whole_imports_from_its_directory_or_its_file() {
        for input in ["zstd_file_bag", "zstd_file_bag/zstd_file_bag.mcap.zstd"] {
            let said = imports_as(input, "mcap_bag.mcap");
            assert_says(
                &said,
                &[
                    "zstd-compressed whole (rosbag2 file compression): 1 file inflated",
                    "mcap input",
                    &format!("from {R}/{input} into"),
                ],
            );
        }
        imports_as("zstd_chunks.mcap", "mcap_bag.mcap");
        imports_as("zstd_message.mcap", "mcap_temp_bag.mcap");
        // A directory holding a plain .mcap and some other compressed file: the .mcap is read,
        // the other file left alone.
        let dir = tempfile::tempdir().unwrap();
        std::fs::copy(format!("{R}/mcap_bag.mcap"), dir.path().join("run.mcap")).unwrap();
        let notes = imuprep::frame::inflate::zstd_compress(b"field notes");
        std::fs::write(dir.path().join("notes.txt.zstd"), notes).unwrap();
        let (said, got) = import_csv(dir.path().to_str().unwrap());
        assert_eq!(got, import_csv(&format!("{R}/mcap_bag.mcap")).1);
        assert!(!said.contains("inflated"), "{said}");
    }

    /// rosbag2 splits a long recording into files whose channel ids are their own: here the
    /// second file's id 1, /imu/data in the first, is /chatter (gen_mcap_split.py). Read as
    /// one stream (the files one after the other), the topic is kept by name.
    #[test]
    fn split_files_read_as_one_keep_the_topic_by_name_not_by_id() {
        let mut both = include_bytes!("reference/mcap_split/mcap_split_0.mcap").to_vec();
        both.extend_from_slice(include_bytes!("reference/mcap_split/mcap_split_1.mcap"));
        let (want, _, _) = run(PLAIN, 4096);
        for chunk in [1, 500, 1 << 20] {
            let (got, st, found) = run(&both, chunk);
            assert_eq!(samples_of(&got), samples_of(&want), "chunk {chunk}");
            assert_eq!((st.bad_payload, st.garbage_bytes), (0, 0));
            assert_says(&found, &["reading /imu/data"]);
        }
    }

    #[test]
    fn a_split_bag_directory_imports_as_one_recording_compressed_or_not() {
        let said = imports_as("mcap_split", "mcap_bag.mcap");
        assert_says(
            &said,
            &[
                "2 files read as one (mcap_split_0.mcap, mcap_split_1.mcap); mcap input",
                "1 gap (1 sample missing)",
            ],
        );
        let said = imports_as("mcap_split_zstd", "mcap_bag.mcap");
        assert_says(
            &said,
            &[
                "zstd-compressed whole (rosbag2 file compression): 2 files inflated",
                "2 files read as one (mcap_split_zstd_0.mcap, mcap_split_zstd_1.mcap)",
            ],
        );
    }

    /// A compressed file cut short (a copy that stopped): an error naming it, nothing written.
    #[test]
    fn a_cut_compressed_file_is_an_error_that_names_it() {
        let dir = tempfile::tempdir().unwrap();
        let full = std::fs::read(format!("{R}/zstd_file_bag/zstd_file_bag.mcap.zstd")).unwrap();
        let cut = dir.path().join("cut.mcap.zstd");
        std::fs::write(&cut, &full[..full.len() / 2]).unwrap();
        let log = dir.path().join("x.log");
        let out = imuprep(&["import", cut.to_str().unwrap(), "-o", log.to_str().unwrap()]);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_says(&err, &["cut.mcap.zstd: zstd"]);
        assert!(!Path::new(&log).exists());
        // `replay` imports a compressed file (no decoder streams one): the same error, and
        // the whole file replays.
        let r = imuprep(&["replay", cut.to_str().unwrap()]);
        assert!(!r.status.success());
        assert_says(
            &String::from_utf8_lossy(&r.stderr),
            &["cut.mcap.zstd: zstd"],
        );
        let whole = format!("{R}/zstd_file_bag/zstd_file_bag.mcap.zstd");
        let r = imuprep(&["replay", &whole]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{err}");
        assert_says(&err, &["zstd-compressed whole (rosbag2 file compression)"]);
    }
}

#[cfg(feature = "ros2-sqlite")]
mod sqlite {
    use super::*;

    #[test]
    fn messages_compressed_one_by_one_import_as_the_uncompressed_bag() {
        let said = imports_as("db3_zstd_message.db3", "db3_temp.db3");
        assert_says(
            &said,
            &[
                "(1 file, 40 of its Imu messages zstd-compressed one by one)",
                "joined to 37 of 40 samples",
            ],
        );
    }

    #[test]
    fn a_db3_compressed_whole_imports_from_its_directory_or_its_file() {
        for input in [
            "db3_zstd_file_bag",
            "db3_zstd_file_bag/db3_zstd_file_bag.db3.zstd",
        ] {
            let said = imports_as(input, "db3_bag");
            assert_says(
                &said,
                &[
                    "zstd-compressed whole (rosbag2 file compression): 1 file inflated",
                    "ROS 2 bag (SQLite) input: 60 sensor_msgs/msg/Imu messages",
                ],
            );
        }
    }
}
