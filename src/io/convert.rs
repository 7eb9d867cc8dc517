//! `import` / `export` between the IMU protocols, the native log and CSV.
//!
//! Any input the decoders read (native log, UBX, MAVLink, ULog; `auto` detects it) becomes
//! samples; samples become a native log, canonical CSV, or a fresh stream in a protocol: UBX
//! ESF-RAW (one message per sample), MAVLink v2 HIGHRES_IMU (system 1, component 1, instance 0)
//! or a ULog with `sensor_combined`.
//!
//! Absent channels (a gyro-only or accel-only log) are said the way each protocol can, and its
//! decoder reads them back as absent: UBX leaves their data words out, HIGHRES_IMU clears their
//! `fields_updated` bits (NaN in the field), the ROS 2 bag sets the vector's covariance[0] to −1.
//! ULog `sensor_combined` can say only "no accelerometer" (PX4's invalid relative time stamp):
//! a gyro-only log is written that way, any other absence is refused with the channels named
//! ([`ulog::sensor_combined_cannot_carry`]) rather than written as numbers a PX4 tool would
//! take for measurements.

use crate::frame::detect::{DecodedFile, ProtocolConfig, decode_bytes};
use crate::frame::{Descriptor, Protocol, mavlink, ubx, ulog};
use crate::io::timing::{TimeFaults, rederive_sequence};
use crate::sample::Sample;
use bytes::BytesMut;
use std::path::{Path, PathBuf};

/// What `export --to` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    /// Canonical CSV plus seq and flags.
    Csv,
    /// imuprep's native log.
    Native,
    /// u-blox UBX ESF-RAW.
    Ubx,
    /// MAVLink v2 HIGHRES_IMU.
    Mavlink,
    /// PX4 ULog with sensor_combined.
    Ulog,
    /// ROS 2 bag (MCAP) with sensor_msgs/msg/Imu on /imu/clean (needs `--features ros2`).
    Mcap,
}

/// Read a recording in any protocol the decoders know.
pub fn read_any(path: &Path, c: &ProtocolConfig) -> std::io::Result<DecodedFile> {
    let bytes = std::fs::read(path)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    Ok(decode_bytes(&bytes, c))
}

/// Read a whole recording to import it: [`read_any`], then, for a protocol whose decoder derives
/// the sequence from time stamps (all but the native one, which has a frame counter), sequence
/// numbers, time-fault flags and the nominal rate derived over the whole file by the rule a CSV
/// import uses ([`rederive_sequence`]), so a ULog and the CSV of the same stream import to the
/// same gaps and rate. The decoder's time counters (gaps, missing, duplicates, samples behind,
/// restarts) are replaced by what that found; its frame counters are kept. The time faults are
/// returned when they were derived so.
pub fn read_any_whole(
    path: &Path,
    c: &ProtocolConfig,
) -> std::io::Result<(DecodedFile, Option<TimeFaults>)> {
    whole(read_any(path, c)?)
}

/// [`read_any_whole`] for a recording split in files (rosbag2's `bag_0.mcap`, `bag_1.mcap`, …,
/// in the order of [`split_files`]): one decoder through them all
/// ([`crate::frame::detect::decode_files`]), time faults and rate over the whole.
pub fn read_files_whole(
    paths: &[PathBuf],
    c: &ProtocolConfig,
) -> std::io::Result<(DecodedFile, Option<TimeFaults>)> {
    whole(crate::frame::detect::decode_files(paths, c)?)
}

/// The files of `dir` named `*.ext` in the order of their split index (the number that ends the
/// name before `.ext`: `bag_2` before `bag_10`; names without one after, by name).
pub fn split_files(dir: &Path, ext: &str) -> std::io::Result<Vec<PathBuf>> {
    let mut f: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == ext) && p.is_file())
        .collect();
    let index = |p: &PathBuf| {
        let stem = p.file_stem().unwrap_or_default().to_string_lossy();
        let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let n = stem[stem.len() - digits..]
            .parse::<u64>()
            .unwrap_or(u64::MAX);
        (n, p.clone())
    };
    f.sort_by_key(index);
    Ok(f)
}

fn whole(mut f: DecodedFile) -> std::io::Result<(DecodedFile, Option<TimeFaults>)> {
    if f.protocol == Protocol::Native || f.samples.is_empty() {
        return Ok((f, None));
    }
    let d = f.descriptor.get_or_insert_with(Descriptor::default);
    let tf = rederive_whole(&mut f.samples, d);
    f.stats.gaps = tf.gaps;
    f.stats.missing_frames = tf.missing;
    f.stats.duplicates = tf.duplicates;
    f.stats.time_backwards = tf.backwards;
    f.stats.seq_restarts = tf.restarts;
    Ok((f, Some(tf)))
}

/// What every import of a whole file does with its samples: sequence numbers and gap flags
/// derived from the stamps over the whole file ([`rederive_sequence`]), and the nominal rate
/// they give set in `d` (kept as it was when they give none).
pub fn rederive_whole(samples: &mut [Sample], d: &mut Descriptor) -> TimeFaults {
    let tf = rederive_sequence(samples);
    if tf.nominal_rate_hz > 0.0 {
        d.sample_rate_hz = tf.nominal_rate_hz;
    }
    tf
}

/// The samples as a byte stream in `to` (not CSV). Fails for `Mcap` in a build without ROS 2
/// support (or on the bag writer's own error), and for `Ulog` when some sample lacks channels
/// `sensor_combined` cannot mark absent.
pub fn encode_stream(
    to: ExportFormat,
    d: &Descriptor,
    samples: &[Sample],
) -> std::io::Result<BytesMut> {
    let mut out = BytesMut::with_capacity(samples.len() * 64 + 1024);
    match to {
        ExportFormat::Csv | ExportFormat::Native => {
            crate::io::log::encode_log(d, samples, &mut out);
        }
        ExportFormat::Ubx => {
            // Sensor time tag: 24 bits of 39.0625 µs (the decoder's default).
            for s in samples {
                let tag = ((s.t_ns as f64 / 39_062.5).round() as u64 & 0x00FF_FFFF) as u32;
                ubx::encode_esf_raw(&[(tag, *s)], &mut out);
            }
        }
        ExportFormat::Mavlink => {
            for (i, s) in samples.iter().enumerate() {
                let p = mavlink::highres_payload(s, 0);
                mavlink::encode_v2(i as u8, 1, 1, mavlink::MSG_HIGHRES_IMU, &p, &mut out);
            }
        }
        ExportFormat::Ulog => {
            let absent = samples.iter().fold(d.absent, |m, s| m | s.absent);
            if let Some(why) = ulog::sensor_combined_cannot_carry(absent) {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("export --to ulog: {why}"),
                ));
            }
            ulog::encode_sensor_combined_log(samples, &mut out)
        }
        ExportFormat::Mcap => {
            #[cfg(feature = "ros2")]
            {
                let b = crate::io::mcap_sink::encode_bag(d, samples, Default::default())
                    .map_err(|e| std::io::Error::other(format!("mcap: {e}")))?;
                out.extend_from_slice(&b);
            }
            #[cfg(not(feature = "ros2"))]
            {
                let _ = d;
                return Err(std::io::Error::other(
                    "export --to mcap: this build has no ROS 2 support (cargo build --release --features ros2)",
                ));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_files_are_ordered_by_their_index() {
        let dir = tempfile::tempdir().unwrap();
        for n in [
            "b_10.db3",
            "b_2.db3",
            "b_0.db3",
            "metadata.yaml",
            "b_1.db3",
            "b.db3",
            "b_1.mcap",
        ] {
            std::fs::write(dir.path().join(n), b"").unwrap();
        }
        let f: Vec<String> = split_files(dir.path(), "db3")
            .unwrap()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(f, ["b_0.db3", "b_1.db3", "b_2.db3", "b_10.db3", "b.db3"]);
    }
}
