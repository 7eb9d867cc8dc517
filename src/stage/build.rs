//! Stage settings from the config, and the pipeline they build.

use crate::config::Errors;
use crate::stage::Pipeline;
use serde::Deserialize;
use std::path::Path;

/// Placeholder settings of a stage that is not in this build yet (kept so configs validate).
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct Disabled {
    #[serde(default)]
    pub enabled: bool,
}

/// Settings of every numerical stage, validated.
#[derive(Debug, Clone, Default)]
pub struct StagesConfig {
    pub gross_error: Disabled,
    pub bias: Disabled,
}

impl StagesConfig {
    /// Read the stage sections of a config table; `None` if any of them had an error.
    pub fn from_table(
        table: &toml::Table,
        _base: &Path,
        errs: &mut Errors,
    ) -> Option<StagesConfig> {
        let n = errs.len();
        let gross_error = crate::config::section(table, "gross_error", errs).unwrap_or_default();
        let bias = crate::config::section(table, "bias", errs).unwrap_or_default();
        (errs.len() == n).then_some(StagesConfig { gross_error, bias })
    }

    /// The pipeline these settings describe.
    pub fn build(&self) -> Pipeline {
        Pipeline::pass_through()
    }
}
