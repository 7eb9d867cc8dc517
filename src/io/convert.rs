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

use crate::frame::detect::{DecodedFile, ProtocolConfig, decode_file_into};
use crate::frame::{DecoderStats, Descriptor, Protocol, mavlink, ubx, ulog};
use crate::io::format::{CSV_HEADER, write_csv_row};
use crate::io::timing::{TimeFaults, rederive_sequence};
use crate::sample::Sample;
use bytes::BytesMut;
use std::io::{Seek, Write};
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

/// Read a recording in any protocol the decoders know: its samples as
/// [`decode_bytes`](crate::frame::detect::decode_bytes) gives
/// them, the file read in pieces ([`decode_file_into`]), never held whole beside them.
pub fn read_any(path: &Path, c: &ProtocolConfig) -> std::io::Result<DecodedFile> {
    let mut samples = Vec::new();
    Ok(decode_file_into(path, c, &mut samples)?.with(samples))
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
    time_counters_from(&mut f.stats, &tf);
    Ok((f, Some(tf)))
}

/// A decoder's time counters (gaps, missing, duplicates, samples behind, restarts) replaced by
/// the time faults derived over the whole file; its frame counters kept.
pub fn time_counters_from(stats: &mut DecoderStats, tf: &TimeFaults) {
    stats.gaps = tf.gaps;
    stats.missing_frames = tf.missing;
    stats.duplicates = tf.duplicates;
    stats.time_backwards = tf.backwards;
    stats.seq_restarts = tf.restarts;
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

/// Whether `to` can carry a recording whose absent channels are `absent` (the descriptor's and
/// every sample's together): ULog `sensor_combined` cannot mark every absence
/// ([`ulog::sensor_combined_cannot_carry`]), and MCAP needs a build with ROS 2 support. Asked
/// before anything is written, so a refused export leaves no file behind.
pub fn exportable(to: ExportFormat, absent: u8) -> std::io::Result<()> {
    if to == ExportFormat::Ulog
        && let Some(why) = ulog::sensor_combined_cannot_carry(absent)
    {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("export --to ulog: {why}"),
        ));
    }
    if to == ExportFormat::Mcap && !cfg!(feature = "ros2") {
        return Err(std::io::Error::other(
            "export --to mcap: this build has no ROS 2 support (cargo build --release --features ros2)",
        ));
    }
    Ok(())
}

/// Samples written in an [`ExportFormat`] one at a time as they come, so a recording is
/// exported without being held: the format's head at creation (the native log's header and
/// descriptor, ULog's definitions, CSV's header line), each sample as its message or row, the
/// bytes handed to `W` in blocks of about 64 KiB (MCAP through its own writer, which seeks back
/// to finish its chunks). UBX ESF-RAW carries the sensor time tag in 39.0625-µs ticks (24 bits,
/// the decoder's default); MAVLink v2 HIGHRES_IMU is sent as system 1, component 1, its
/// sequence counting the samples. Ask [`exportable`] first.
pub struct ExportWriter<W: Write + Seek> {
    to: ExportFormat,
    out: ExportOut<W>,
    buf: BytesMut,
    line: String,
    samples: u64,
}

enum ExportOut<W: Write + Seek> {
    Bytes(W),
    #[cfg(feature = "ros2")]
    Bag(Box<crate::io::mcap_sink::ImuBagWriter<W>>),
}

/// Bytes gathered before they are handed to the writer.
const EXPORT_BLOCK: usize = 64 * 1024;

#[cfg(feature = "ros2")]
fn mcap_error(e: ::mcap::McapError) -> std::io::Error {
    std::io::Error::other(format!("mcap: {e}"))
}

impl<W: Write + Seek> ExportWriter<W> {
    /// Start an export in `to` for a sensor described by `d` on `w`.
    pub fn new(to: ExportFormat, d: &Descriptor, w: W) -> std::io::Result<Self> {
        let mut buf = BytesMut::with_capacity(EXPORT_BLOCK + 1024);
        let out = match to {
            ExportFormat::Mcap => {
                #[cfg(feature = "ros2")]
                {
                    let mut b = crate::io::mcap_sink::ImuBagWriter::new(w, Default::default())
                        .map_err(mcap_error)?;
                    b.descriptor(d);
                    ExportOut::Bag(Box::new(b))
                }
                #[cfg(not(feature = "ros2"))]
                {
                    // Refused in this build (returns the error).
                    exportable(to, 0)?;
                    ExportOut::Bytes(w)
                }
            }
            ExportFormat::Csv => {
                buf.extend_from_slice(CSV_HEADER.as_bytes());
                buf.extend_from_slice(b"\n");
                ExportOut::Bytes(w)
            }
            ExportFormat::Native => {
                crate::frame::encode_log_header(d, &mut buf);
                ExportOut::Bytes(w)
            }
            ExportFormat::Ulog => {
                ulog::encode_sensor_combined_head(&mut buf);
                ExportOut::Bytes(w)
            }
            ExportFormat::Ubx | ExportFormat::Mavlink => ExportOut::Bytes(w),
        };
        Ok(ExportWriter {
            to,
            out,
            buf,
            line: String::new(),
            samples: 0,
        })
    }

    /// Write one sample.
    pub fn push(&mut self, s: &Sample) -> std::io::Result<()> {
        let b = &mut self.buf;
        match self.to {
            ExportFormat::Csv => {
                self.line.clear();
                write_csv_row(s, &mut self.line);
                b.extend_from_slice(self.line.as_bytes());
            }
            ExportFormat::Native => crate::frame::encode_sample(s, b),
            ExportFormat::Ubx => {
                let tag = ((s.t_ns as f64 / 39_062.5).round() as u64 & 0x00FF_FFFF) as u32;
                ubx::encode_esf_raw(&[(tag, *s)], b);
            }
            ExportFormat::Mavlink => {
                let p = mavlink::highres_payload(s, 0);
                let seq = self.samples as u8;
                mavlink::encode_v2(seq, 1, 1, mavlink::MSG_HIGHRES_IMU, &p, b);
            }
            ExportFormat::Ulog => ulog::encode_sensor_combined_sample(s, b),
            ExportFormat::Mcap => {}
        }
        self.samples += 1;
        match &mut self.out {
            ExportOut::Bytes(w) => {
                if self.buf.len() >= EXPORT_BLOCK {
                    w.write_all(&self.buf)?;
                    self.buf.clear();
                }
            }
            #[cfg(feature = "ros2")]
            ExportOut::Bag(w) => w.sample(s).map_err(mcap_error)?,
        }
        Ok(())
    }

    /// The samples written so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Write what is left and flush; the writer back.
    pub fn finish(self) -> std::io::Result<W> {
        match self.out {
            ExportOut::Bytes(mut w) => {
                w.write_all(&self.buf)?;
                w.flush()?;
                Ok(w)
            }
            #[cfg(feature = "ros2")]
            ExportOut::Bag(w) => {
                let mut w = w.finish().map_err(mcap_error)?;
                w.flush()?;
                Ok(w)
            }
        }
    }
}

/// The samples as a byte stream in `to` ([`ExportWriter`] into memory). Fails where
/// [`exportable`] refuses (the descriptor's and the samples' absent channels together), and on
/// the bag writer's own error.
pub fn encode_stream(
    to: ExportFormat,
    d: &Descriptor,
    samples: &[Sample],
) -> std::io::Result<BytesMut> {
    exportable(to, samples.iter().fold(d.absent, |m, s| m | s.absent))?;
    let mut w = ExportWriter::new(to, d, std::io::Cursor::new(Vec::new()))?;
    for s in samples {
        w.push(s)?;
    }
    Ok(BytesMut::from(&w.finish()?.into_inner()[..]))
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
