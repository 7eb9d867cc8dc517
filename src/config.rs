//! Configuration: TOML → raw serde structs (`deny_unknown_fields`) → validated [`Config`], in one
//! step, with every error reported together with its key path.
//!
//! serde stops at the first structural error inside one table, so each section (and each sink)
//! is deserialised on its own: mistakes in different sections are all reported in one run. Value
//! checks (`validate`) then run on every section that parsed.

use serde::{Deserialize, Serialize};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

pub use crate::settings::{
    ConfigError, ConfigErrors, Errors, clean_serde, lenient, overlay, push_keyed, resolve, section,
};

/// The embedded default configuration (`config/default.toml`).
pub const DEFAULT_TOML: &str = include_str!("../config/default.toml");

// ---------------------------------------------------------------------------------------------
// Raw sections

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
    /// A recorded log (file header + frames).
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
        /// Chunk compression: "none" (default) or "lz4" (`--out mcap+lz4:PATH`).
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

/// `[zenoh]`: the one Zenoh session a run opens when a source or sink uses Zenoh.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ZenohConfig {
    /// "peer" (meets other peers directly, and routers) or "client" (through a router only).
    #[serde(default = "default_zenoh_mode")]
    pub mode: String,
    /// Endpoints to connect to, e.g. `tcp/192.168.1.10:7447`.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Endpoints to listen on, e.g. `tcp/0.0.0.0:7447` (peer mode; empty = Zenoh's default).
    #[serde(default)]
    pub listen: Vec<String>,
    /// Find peers and routers by UDP multicast scouting.
    #[serde(default = "yes")]
    pub multicast_scouting: bool,
    /// With `connect` endpoints: how long the start waits to reach one, ms; none reached =
    /// a startup error naming them. 0 = do not wait (keep trying in the background).
    #[serde(default = "default_zenoh_connect_timeout_ms")]
    pub connect_timeout_ms: u64,
}

fn default_zenoh_mode() -> String {
    "peer".into()
}
fn yes() -> bool {
    true
}
fn default_zenoh_connect_timeout_ms() -> u64 {
    5_000
}

impl Default for ZenohConfig {
    fn default() -> Self {
        ZenohConfig {
            mode: default_zenoh_mode(),
            connect: Vec::new(),
            listen: Vec::new(),
            multicast_scouting: true,
            connect_timeout_ms: default_zenoh_connect_timeout_ms(),
        }
    }
}

/// The Zenoh link protocols this build's session can use (the crate's transport features).
pub const ZENOH_TRANSPORTS: &[&str] = &["tcp", "udp"];

crate::valid_settings!(
    /// `[zenoh]` that passed [`ZenohConfig::validate`]: the only form a session is opened from.
    ValidZenohConfig,
    ZenohConfig
);

impl ZenohConfig {
    /// Every value check, one message per mistake, each starting with its key.
    pub fn validate(self) -> Result<ValidZenohConfig, crate::settings::SettingsErrors> {
        let mut e = Vec::new();
        if !["peer", "client"].contains(&self.mode.as_str()) {
            e.push(format!(
                "mode: must be \"peer\" or \"client\", got {:?}",
                self.mode
            ));
        }
        for (key, list) in [("connect", &self.connect), ("listen", &self.listen)] {
            for (i, ep) in list.iter().enumerate() {
                if let Err(m) = check_zenoh_endpoint(ep) {
                    e.push(format!("{key}[{i}]: {m}"));
                }
            }
        }
        if self.mode == "client" && !self.listen.is_empty() {
            e.push("listen: a client does not listen (mode = \"peer\" to listen)".into());
        }
        if self.mode == "client" && self.connect.is_empty() && !self.multicast_scouting {
            e.push(
                "connect: a client needs a router: give its endpoint, or multicast_scouting = true to find one"
                    .into(),
            );
        }
        crate::settings::SettingsErrors::check("zenoh", e, ValidZenohConfig::checked(self))
    }
}

/// A Zenoh endpoint `PROTO/HOST:PORT` with a transport this build has.
fn check_zenoh_endpoint(ep: &str) -> Result<(), String> {
    let Some((proto, addr)) = ep.split_once('/') else {
        return Err(format!(
            "{ep:?} is not an endpoint (PROTO/HOST:PORT, e.g. tcp/127.0.0.1:7447)"
        ));
    };
    if !ZENOH_TRANSPORTS.contains(&proto) {
        return Err(format!(
            "{ep:?}: transport {proto:?} is not in this build (one of {})",
            ZENOH_TRANSPORTS.join(", ")
        ));
    }
    // Zenoh's own suffixes (`?metadata`, then `#config`) are its business, but their form is
    // checked as Zenoh's parser checks it (`EndPoint::try_from`): each one present is a
    // non-empty `KEY=VALUE;…` list with no empty key, `?` before `#`. The address must have a
    // port.
    let (addr, suffix) = match addr.find(['#', '?']) {
        Some(i) => (&addr[..i], &addr[i..]),
        None => (addr, ""),
    };
    let (meta, conf) = match suffix.find('#') {
        Some(i) => (&suffix[..i], Some(&suffix[i + 1..])),
        None => (suffix, None),
    };
    let meta = meta.strip_prefix('?');
    let well_formed = |p: &str| {
        let mut items = p.split(';').filter(|i| !i.is_empty()).peekable();
        items.peek().is_some() && items.all(|i| !i.split('=').next().unwrap_or("").is_empty())
    };
    for (part, sep) in [(meta, '?'), (conf, '#')] {
        match part {
            Some(p) if (sep == '#' && p.contains('?')) || !well_formed(p) => {
                return Err(format!(
                    "{ep:?}: Zenoh's options after '{sep}' must be KEY=VALUE[;KEY=VALUE…] (an empty part, an empty key, or '?' after '#', is refused by Zenoh)"
                ));
            }
            _ => {}
        }
    }
    match addr.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => Ok(()),
        _ => Err(format!(
            "{ep:?}: the address needs HOST:PORT (port 0–65535)"
        )),
    }
}

/// A Zenoh key: non-empty, no empty chunk (`a//b`), no leading/trailing `/`; `wildcards` allows
/// `*` and `**` chunks (a subscription), else none (a publication).
pub fn check_zenoh_key(key: &str, wildcards: bool) -> Result<(), String> {
    if key.is_empty() {
        return Err("empty key".into());
    }
    if key.starts_with('/') || key.ends_with('/') || key.contains("//") {
        return Err(format!(
            "{key:?}: a key has no leading, trailing or doubled '/'"
        ));
    }
    for chunk in key.split('/') {
        let wild = chunk.contains('*') || chunk.contains('$');
        if wild && !wildcards {
            return Err(format!(
                "{key:?}: a published key names one resource (no '*')"
            ));
        }
        if wild && chunk != "*" && chunk != "**" && !chunk.contains("$*") {
            return Err(format!("{key:?}: bad wildcard chunk {chunk:?}"));
        }
        if chunk.contains(['#', '?']) {
            return Err(format!("{key:?}: '#' and '?' are not allowed in a key"));
        }
    }
    Ok(())
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

/// Health reporting.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HealthConfig {
    /// Interval between health log lines, s (0 = only the final summary).
    #[serde(default = "default_interval")]
    pub interval_s: f64,
}
fn default_interval() -> f64 {
    10.0
}
impl Default for HealthConfig {
    fn default() -> Self {
        HealthConfig {
            interval_s: default_interval(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Validated

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

/// A validated configuration: it can only exist if every check passed.
#[derive(Debug, Clone)]
pub struct Config {
    pub source: SourceConfig,
    pub sinks: Vec<Sink>,
    pub health: HealthConfig,
    pub stages: crate::stage::build::StagesConfig,
    /// `[source] protocol` and the per-protocol option tables (`[source.ubx]`, …).
    pub protocol: crate::frame::detect::ProtocolConfig,
    /// `[zenoh]`: the session a Zenoh source or sink opens.
    pub zenoh: ValidZenohConfig,
}

impl Config {
    /// True when the source or a sink uses Zenoh (the run opens one session for them).
    pub fn uses_zenoh(&self) -> bool {
        matches!(self.source, SourceConfig::Zenoh { .. })
            || self.sinks.iter().any(|s| matches!(s, Sink::Zenoh { .. }))
    }
}

impl Config {
    /// The embedded default configuration.
    pub fn default_embedded() -> Result<Config, ConfigErrors> {
        Config::from_toml_str(DEFAULT_TOML, Path::new("."))
    }

    /// Read and validate a config file; relative paths in it are taken from its directory.
    pub fn from_file(path: &Path) -> Result<Config, ConfigErrors> {
        Config::read(path, false)
    }

    /// As [`Config::from_file`], for the commands that replace the source with their own input
    /// (`replay LOG`, `audit`, `navtest`, …): a file without `[source]` takes the embedded
    /// default's, so a file holding only tuning keys works there (`run` still needs one).
    pub fn from_file_source_replaced(path: &Path) -> Result<Config, ConfigErrors> {
        Config::read(path, true)
    }

    fn read(path: &Path, default_source: bool) -> Result<Config, ConfigErrors> {
        let mut text = std::fs::read_to_string(path).map_err(|e| {
            ConfigErrors(vec![ConfigError {
                path: path.display().to_string(),
                message: format!("cannot read config: {e}"),
            }])
        })?;
        if default_source
            && let Ok(mut user) = text.parse::<toml::Table>()
            && !user.contains_key("source")
        {
            let defaults: toml::Table = DEFAULT_TOML
                .parse()
                .expect("the embedded config/default.toml parses (tested)");
            if let Some(src) = defaults.get("source") {
                user.insert("source".into(), src.clone());
                text = user.to_string();
            }
        }
        let base = path.parent().unwrap_or(Path::new("."));
        Config::from_toml_str(&text, base)
    }

    /// Parse and validate; `base` resolves relative paths (model files, replay logs).
    pub fn from_toml_str(text: &str, base: &Path) -> Result<Config, ConfigErrors> {
        let mut errs = Errors::default();
        let table: toml::Table = match text.parse() {
            Ok(t) => t,
            Err(e) => {
                errs.push("<toml>", e.to_string());
                return Err(ConfigErrors(errs.into_vec()));
            }
        };
        for k in table.keys() {
            if ![
                "source",
                "sinks",
                "health",
                "gross_error",
                "bias",
                "monitor",
                "zenoh",
            ]
            .contains(&k.as_str())
            {
                errs.push(
                    k.clone(),
                    "unknown section (expected source, sinks, health, gross_error, bias, monitor, zenoh)",
                );
            }
        }
        // A file changes only what it names: everything else comes from the embedded defaults
        // (`[source]` excepted — taken whole, and required here; the commands that bring their own
        // input fill it in first, see `from_file_source_replaced`).
        let table = overlay_on_defaults(table);
        // The protocol keys of [source] are read on their own (the source kinds' tables deny
        // unknown keys).
        let mut table = table;
        let mut proto_table = toml::Table::new();
        if let Some(src) = table.get_mut("source").and_then(|v| v.as_table_mut()) {
            for k in crate::frame::detect::SOURCE_KEYS {
                if let Some(v) = src.remove(k) {
                    proto_table.insert(k.to_string(), v);
                }
            }
        }
        let protocol = match toml::Value::Table(proto_table)
            .try_into::<crate::frame::detect::ProtocolConfig>()
        {
            Ok(p) => {
                for (k, m) in p.validate() {
                    errs.push(k, m);
                }
                p
            }
            Err(e) => {
                errs.push("source", clean_serde(&e.to_string()));
                Default::default()
            }
        };
        let source: Option<SourceConfig> = section(&table, "source", &mut errs);
        let source = match source {
            Some(s) => Some(s),
            None if !table.contains_key("source") => {
                errs.push("source", "missing section [source]");
                None
            }
            None => None,
        };
        if let Some(s) = &source {
            validate_source(s, base, &mut errs);
        }
        let mut sinks = Vec::new();
        if let Some(v) = table.get("sinks") {
            match v.as_array() {
                None => errs.push("sinks", "must be an array of tables ([[sinks]])"),
                Some(arr) => {
                    for (i, item) in arr.iter().enumerate() {
                        let path = format!("sinks[{i}]");
                        match item.clone().try_into::<SinkConfig>() {
                            Ok(s) => {
                                if let Some(s) = validate_sink(&s, base, &path, &mut errs) {
                                    sinks.push(s)
                                }
                            }
                            Err(e) => errs.push(path, clean_serde(&e.to_string())),
                        }
                    }
                }
            }
        }
        let health: HealthConfig = section(&table, "health", &mut errs).unwrap_or_default();
        errs.check(
            health.interval_s.is_finite() && health.interval_s >= 0.0,
            "health.interval_s",
            format!("must be ≥ 0 s, got {}", health.interval_s),
        );
        let zenoh: ZenohConfig = section(&table, "zenoh", &mut errs).unwrap_or_default();
        let zenoh = match zenoh.validate() {
            Ok(z) => Some(z),
            Err(e) => {
                e.push_into(&mut errs, "zenoh");
                None
            }
        };
        let stages = crate::stage::build::StagesConfig::from_table(&table, base, &mut errs);
        errs.dedup();
        if errs.is_empty() {
            Ok(Config {
                source: source.expect("no errors means the source parsed"),
                sinks,
                health,
                stages: stages.expect("no errors means the stages parsed"),
                protocol,
                zenoh: zenoh.expect("no errors means [zenoh] passed"),
            })
        } else {
            Err(ConfigErrors(errs.into_vec()))
        }
    }
}

/// `user` laid over the embedded defaults: tables merge key by key (recursively), any other
/// value replaces the default's; `[source]` and `[[sinks]]` are the user's alone (a source of
/// another kind shares no keys with the default's).
pub fn overlay_on_defaults(user: toml::Table) -> toml::Table {
    let mut base: toml::Table = DEFAULT_TOML
        .parse()
        .expect("the embedded config/default.toml parses (tested)");
    base.remove("source");
    base.remove("sinks");
    overlay(&mut base, user);
    base
}

fn validate_source(s: &SourceConfig, _base: &Path, errs: &mut Errors) {
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

/// What a config naming Zenoh is told by a build without it.
pub const ZENOH_NOT_BUILT: &str =
    "zenoh needs a build with Zenoh support (cargo build --release --features zenoh)";

fn validate_sink(s: &SinkConfig, base: &Path, path: &str, errs: &mut Errors) -> Option<Sink> {
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
