//! `[source]`: where samples come from (serial, replay, stdin, Zenoh), its defaults and its value
//! checks.

use super::{Errors, ZENOH_NOT_BUILT, check_zenoh_key};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Where samples come from.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "lowercase")]
pub enum SourceConfig {
    /// A serial port carrying native frames.
    Serial {
        /// Device path, e.g. `/dev/ttyUSB0`.
        port: String,
        /// Line rate, baud.
        #[serde(default = "default_baud")]
        baud: u32,
        /// First reconnect delay after the port vanishes, ms; doubles per failure.
        #[serde(default = "default_retry_initial_ms")]
        retry_initial_ms: u64,
        /// Longest reconnect delay, ms.
        #[serde(default = "default_retry_max_ms")]
        retry_max_ms: u64,
        /// A port open but silent this long is reported (a stall) and reopened, ms (0 = never).
        #[serde(default = "default_stall_ms")]
        stall_ms: u64,
    },
    /// A recorded file: a native log (file header + frames), a sensor protocol's recording or
    /// any file `import` reads (`report::daemon::replay_source`).
    Replay {
        path: PathBuf,
        /// 0 = as fast as possible; otherwise paced by sensor time at this speed factor.
        #[serde(default)]
        speed: f64,
    },
    /// Frames (or a whole log) on standard input.
    Stdin,
    /// Native frames published by another process over Zenoh (a build with `--features
    /// zenoh`; the session is `[zenoh]`): each payload of `key` is fed to the frame decoder.
    Zenoh {
        /// Key expression to subscribe, e.g. `imuprep/imu0/raw`; its payloads are native frames.
        key: String,
        /// Silent this long = a stall: reported, counted in health, ms (0 = never).
        #[serde(default = "default_stall_ms")]
        stall_ms: u64,
    },
}

fn default_baud() -> u32 {
    921_600
}
fn default_retry_initial_ms() -> u64 {
    100
}
fn default_stall_ms() -> u64 {
    2_000
}
fn default_retry_max_ms() -> u64 {
    5_000
}

pub(super) fn validate_source(s: &SourceConfig, _base: &Path, errs: &mut Errors) {
    match s {
        SourceConfig::Serial {
            port,
            baud,
            retry_initial_ms,
            retry_max_ms,
            ..
        } => {
            errs.check(!port.is_empty(), "source.port", "must name a device");
            errs.check(*baud > 0, "source.baud", "must be > 0");
            errs.check(
                *retry_initial_ms > 0 && retry_initial_ms <= retry_max_ms,
                "source.retry_initial_ms",
                "must be > 0 and ≤ retry_max_ms",
            );
        }
        SourceConfig::Replay { speed, .. } => {
            errs.check(
                speed.is_finite() && *speed >= 0.0,
                "source.speed",
                format!("must be ≥ 0 (0 = as fast as possible), got {speed}"),
            );
        }
        SourceConfig::Stdin => {}
        SourceConfig::Zenoh { key, .. } => {
            errs.check(cfg!(feature = "zenoh"), "source.kind", ZENOH_NOT_BUILT);
            if let Err(m) = check_zenoh_key(key, true) {
                errs.push("source.key", m);
            }
        }
    }
}
