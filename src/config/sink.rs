//! `[[sinks]]`: where cleaned samples go — the raw TOML form ([`SinkConfig`]) with its defaults,
//! the validated form ([`Sink`]), and the check that turns one into the other.

use super::{Errors, ZENOH_NOT_BUILT, check_zenoh_key, resolve};
use serde::Deserialize;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

/// Text/binary encodings a sink can write.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Native frames (a file sink adds the log header).
    #[default]
    Native,
    /// Canonical CSV (see `export`).
    Csv,
    /// One JSON object per line.
    Jsonl,
}

/// Where cleaned samples go. Several at once.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "lowercase")]
pub enum SinkConfig {
    Stdout {
        #[serde(default = "csv")]
        format: Format,
    },
    File {
        path: PathBuf,
        #[serde(default)]
        format: Format,
    },
    /// A TCP server; each client gets its own bounded queue.
    Tcp {
        /// Listen address, e.g. `127.0.0.1:7700`.
        bind: String,
        #[serde(default)]
        format: Format,
        /// Per-client queue length, in batches of samples; a client further behind loses batches
        /// (counted) and never stalls the stream.
        #[serde(default = "default_queue")]
        queue: usize,
    },
    /// UDP datagrams to fixed addresses (one sample per datagram).
    Udp {
        targets: Vec<String>,
        #[serde(default)]
        format: Format,
    },
    /// Cleaned samples re-encoded in the input's own protocol, other messages passed through
    /// unchanged and in order: to a serial device or file at `path`, or (no path) to a new
    /// pseudo-terminal whose path is printed.
    Inline {
        #[serde(default)]
        path: Option<PathBuf>,
    },
    /// A ROS 2 bag (MCAP) with sensor_msgs/msg/Imu (bias σ² on the covariance diagonals) and a
    /// health topic (std_msgs/msg/String, JSON); needs a build with `--features ros2`.
    Mcap {
        path: PathBuf,
        #[serde(default = "default_mcap_topic")]
        topic: String,
        #[serde(default = "default_mcap_frame")]
        frame_id: String,
        #[serde(default = "default_mcap_health")]
        health_topic: String,
        /// Chunk compression: "none" (default), "lz4" (`--out mcap+lz4:PATH`) or "zstd"
        /// (`--out mcap+zstd:PATH`).
        #[serde(default)]
        compression: McapCompression,
    },
    /// Zenoh publisher on `key` (a build with `--features zenoh`; the session is `[zenoh]`):
    /// every sample on `key`, health on `key/health` (published and queryable), the descriptor
    /// on `key/descriptor` (queryable) — docs/zenoh.md.
    Zenoh {
        /// Key, e.g. `imuprep/imu0/imu` (no wildcards).
        key: String,
        /// "native" (one frame per sample, as `file:`/`tcp:` write) or "jsonl" (one JSON line).
        #[serde(default)]
        format: Format,
        /// The sink's own queue, in batches of samples; beyond it batches are dropped, counted.
        #[serde(default = "default_zenoh_queue")]
        queue: usize,
        /// Wait up to this long at start for a subscriber of `key` before data flows, s (0 = no wait).
        #[serde(default)]
        wait_s: f64,
        /// What a subscriber or router that falls behind costs: "drop" (its messages are
        /// dropped, counted; never waits) or "block" (Zenoh waits for it; the sink is then
        /// waited for like a local sink: back-pressure in an offline replay, the stall rule live).
        #[serde(default)]
        congestion: ZenohCongestion,
    },
}

/// Zenoh's congestion control for a Zenoh sink's samples.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum ZenohCongestion {
    /// `CongestionControl::Drop`: never waits; what a slow consumer cannot take is dropped.
    #[default]
    Drop,
    /// `CongestionControl::Block`: every sample, at the pace of the slowest consumer.
    Block,
}

fn default_zenoh_queue() -> usize {
    64
}

/// How the MCAP sink compresses its chunks.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum McapCompression {
    /// Uncompressed chunks (every MCAP reader reads them).
    #[default]
    None,
    /// LZ4-frame chunks (`lz4_flex`, no C build; rosbags, Foxglove and `ros2 bag` read them).
    Lz4,
    /// zstd chunks (`ruzstd`, no C build; MCAP's usual compression, read by the same readers).
    Zstd,
}

fn default_mcap_topic() -> String {
    "/imu/clean".into()
}
fn default_mcap_frame() -> String {
    "imu_link".into()
}
fn default_mcap_health() -> String {
    "/imuprep/health".into()
}

fn csv() -> Format {
    Format::Csv
}
fn default_queue() -> usize {
    256
}

/// Output sink, validated.
#[derive(Debug, Clone, PartialEq)]
pub enum Sink {
    Stdout {
        format: Format,
    },
    File {
        path: PathBuf,
        format: Format,
    },
    Tcp {
        bind: SocketAddr,
        format: Format,
        queue: usize,
    },
    Udp {
        targets: Vec<SocketAddr>,
        format: Format,
    },
    /// Inline output (see [`SinkConfig::Inline`]); `None` = a new pseudo-terminal.
    Inline {
        path: Option<PathBuf>,
    },
    /// ROS 2 bag (see [`SinkConfig::Mcap`]).
    Mcap {
        path: PathBuf,
        topic: String,
        frame_id: String,
        health_topic: String,
        compression: McapCompression,
    },
    /// Zenoh publisher (see [`SinkConfig::Zenoh`]).
    Zenoh {
        key: String,
        format: Format,
        queue: usize,
        wait_s: f64,
        congestion: ZenohCongestion,
    },
}

pub(super) fn validate_sink(
    s: &SinkConfig,
    base: &Path,
    path: &str,
    errs: &mut Errors,
) -> Option<Sink> {
    match s {
        SinkConfig::Stdout { format } => Some(Sink::Stdout { format: *format }),
        SinkConfig::File { path: p, format } => Some(Sink::File {
            path: resolve(base, p),
            format: *format,
        }),
        SinkConfig::Tcp {
            bind,
            format,
            queue,
        } => {
            let addr = bind.parse::<SocketAddr>();
            if addr.is_err() {
                errs.push(format!("{path}.bind"), format!("not an address: {bind:?}"));
            }
            errs.check(*queue > 0, format!("{path}.queue"), "must be > 0");
            Some(Sink::Tcp {
                bind: addr.ok()?,
                format: *format,
                queue: *queue,
            })
        }
        SinkConfig::Inline { path: p } => Some(Sink::Inline {
            path: p.as_ref().map(|p| resolve(base, p)),
        }),
        SinkConfig::Mcap {
            path: p,
            topic,
            frame_id,
            health_topic,
            compression,
        } => {
            errs.check(
                cfg!(feature = "ros2"),
                format!("{path}.kind"),
                "mcap needs a build with ROS 2 support (cargo build --release --features ros2)",
            );
            errs.check(
                topic.starts_with('/') && health_topic.starts_with('/') && topic != health_topic,
                format!("{path}.topic"),
                "topics must be absolute (start with /) and differ",
            );
            Some(Sink::Mcap {
                path: resolve(base, p),
                topic: topic.clone(),
                frame_id: frame_id.clone(),
                health_topic: health_topic.clone(),
                compression: *compression,
            })
        }
        SinkConfig::Zenoh {
            key,
            format,
            queue,
            wait_s,
            congestion,
        } => {
            errs.check(
                cfg!(feature = "zenoh"),
                format!("{path}.kind"),
                ZENOH_NOT_BUILT,
            );
            if let Err(m) = check_zenoh_key(key, false) {
                errs.push(format!("{path}.key"), m);
            }
            errs.check(
                *format != Format::Csv,
                format!("{path}.format"),
                "a zenoh sink publishes \"native\" frames or \"jsonl\" lines, not csv",
            );
            errs.check(*queue > 0, format!("{path}.queue"), "must be > 0");
            errs.check(
                wait_s.is_finite() && *wait_s >= 0.0,
                format!("{path}.wait_s"),
                format!("must be ≥ 0 s, got {wait_s}"),
            );
            Some(Sink::Zenoh {
                key: key.clone(),
                format: *format,
                queue: *queue,
                wait_s: *wait_s,
                congestion: *congestion,
            })
        }
        SinkConfig::Udp { targets, format } => {
            let mut out = Vec::new();
            for (i, t) in targets.iter().enumerate() {
                match t.parse::<SocketAddr>() {
                    Ok(a) => out.push(a),
                    Err(_) => errs.push(
                        format!("{path}.targets[{i}]"),
                        format!("not an address: {t:?}"),
                    ),
                }
            }
            errs.check(
                !targets.is_empty(),
                format!("{path}.targets"),
                "needs at least one address",
            );
            Some(Sink::Udp {
                targets: out,
                format: *format,
            })
        }
    }
}
