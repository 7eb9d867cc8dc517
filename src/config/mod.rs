//! Configuration: TOML → raw serde structs (`deny_unknown_fields`) → validated [`Config`], in one
//! step, with every error reported together with its key path.
//!
//! serde stops at the first structural error inside one table, so each section (and each sink)
//! is deserialised on its own: mistakes in different sections are all reported in one run. Value
//! checks (`validate`) then run on every section that parsed.
//!
//! One file per section: `source.rs` (`[source]`), `sink.rs` (`[[sinks]]`, raw and validated),
//! `zenoh.rs` (`[zenoh]`); this file holds [`Config`] itself, `[health]`, and the loading that
//! reads every section and gathers their errors.

mod sink;
mod source;
mod zenoh;

pub use sink::{Format, McapCompression, Sink, SinkConfig, ZenohCongestion};
pub use source::SourceConfig;
pub use zenoh::{
    ValidZenohConfig, ZENOH_NOT_BUILT, ZENOH_TRANSPORTS, ZenohConfig, check_zenoh_key,
};

use serde::{Deserialize, Serialize};
use sink::validate_sink;
use source::validate_source;
use std::path::Path;

pub use crate::settings::{
    ConfigError, ConfigErrors, Errors, clean_serde, lenient, overlay, push_keyed, resolve, section,
};

/// The embedded default configuration (`config/default.toml`).
pub const DEFAULT_TOML: &str = include_str!("../../config/default.toml");

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
