//! Stage settings from the config, and the pipeline they build.
//!
//! Each stage section has `enabled`, an optional `model` file (written by `imuprep fit`; without
//! one the stage identifies its own model from a warm-up window) and a `settings` table. Model
//! files are read and checked during validation, so a bad model stops the run before it starts.

use crate::model::arima::ArimaModelFile;
use crate::model::bias_model::BiasModelFile;
use crate::settings::{Errors, SettingsErrors, clean_serde, lenient, push_keyed, resolve};
use crate::stage::bias::BiasStage;
use crate::stage::bias::settings::{BiasSettings, ValidBiasSettings};
use crate::stage::gross_error::{GrossErrorSettings, GrossErrorStage, ValidGrossErrorSettings};
use crate::stage::monitor::{MonitorSettings, MonitorStage};
use crate::stage::{Pipeline, Stage};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// `[gross_error]` as written.
#[derive(Debug, Clone, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct GrossErrorSection {
    #[serde(default)]
    enabled: bool,
    /// ARIMA model file from `imuprep fit` (relative to the config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model: Option<PathBuf>,
    #[serde(default)]
    settings: GrossErrorSettings,
}

/// `[bias] model`: the one place a bias model is given — a file from `imuprep fit` /
/// `imuprep diagnose` (relative to the config file), or the model itself inline
/// (`[[bias.model.channels]]`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(untagged)]
pub enum BiasModelSource {
    File(PathBuf),
    Inline(BiasModelFile),
}

/// `[bias]` as written.
#[derive(Debug, Clone, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct BiasSection {
    #[serde(default)]
    enabled: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model: Option<BiasModelSource>,
    #[serde(default)]
    settings: BiasSettings,
}

/// `[monitor]` as written.
#[derive(Debug, Clone, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct MonitorSection {
    #[serde(default)]
    enabled: bool,
    #[serde(default)]
    settings: MonitorSettings,
}

/// Validated bias stage settings.
#[derive(Debug, Clone)]
pub struct BiasConfig {
    pub settings: ValidBiasSettings,
    pub model: Option<BiasModelFile>,
}

/// Validated gross-error stage settings.
#[derive(Debug, Clone)]
pub struct GrossErrorConfig {
    pub settings: ValidGrossErrorSettings,
    pub model: Option<ArimaModelFile>,
}

/// Settings of every numerical stage, validated.
#[derive(Debug, Clone, Default)]
pub struct StagesConfig {
    pub gross_error: Option<GrossErrorConfig>,
    pub bias: Option<BiasConfig>,
    /// The model-health monitor (watches, changes nothing).
    pub monitor: Option<MonitorSettings>,
    /// The sensor's declared rate (a log's descriptor), Hz; `None`: stages that need one
    /// without a setting learn it from the time stamps.
    pub declared_rate_hz: Option<f64>,
}

/// Read a TOML model file, recording any error at `path`.
pub fn load_model<T>(
    base: &Path,
    file: &Path,
    path: &str,
    parse: impl Fn(&str) -> Result<T, String>,
    errs: &mut Errors,
) -> Option<T> {
    let p = resolve(base, file);
    match std::fs::read_to_string(&p) {
        Ok(text) => match parse(&text) {
            Ok(m) => Some(m),
            Err(e) => {
                errs.push(path, format!("{}: {}", p.display(), clean_serde(&e)));
                None
            }
        },
        Err(e) => {
            errs.push(path, format!("cannot read {}: {e}", p.display()));
            None
        }
    }
}

/// One stage section of `table` read key by key over the type's defaults
/// ([`lenient`]): every structural mistake in it is reported, at its own key path.
fn stage_section<T>(table: &toml::Table, key: &str, errs: &mut Errors) -> T
where
    T: Serialize + serde::de::DeserializeOwned + Default,
{
    let base = toml::Table::try_from(T::default()).expect("stage defaults serialise to TOML");
    match table.get(key) {
        None => T::default(),
        Some(toml::Value::Table(user)) => lenient(base, user, key, errs).unwrap_or_default(),
        Some(_) => {
            errs.push(key, "must be a table");
            T::default()
        }
    }
}

/// The validated settings, or `None` with each problem recorded in `errs` under `key`.
fn validated<T>(r: Result<T, SettingsErrors>, errs: &mut Errors, key: &str) -> Option<T> {
    r.map_err(|e| e.push_into(errs, key)).ok()
}

impl StagesConfig {
    /// Adopt the sensor's declared rate (from a log's descriptor) where the stages need one;
    /// the changed settings are validated again (a rate can make other values invalid).
    pub fn set_sample_rate(&mut self, rate_hz: f64) -> Result<(), SettingsErrors> {
        if rate_hz > 0.0 && rate_hz.is_finite() {
            self.declared_rate_hz = Some(rate_hz);
        }
        if let Some(b) = self.bias.as_mut()
            && rate_hz > 0.0
        {
            let mut raw = b.settings.clone().into_inner();
            raw.sample_rate_hz = rate_hz;
            b.settings = raw.validate().map_err(|mut e| {
                // Said where the settings live, and that the rate is the stream's, not the
                // config's (a 1-Hz log once got "vibration_bandwidth_hz: must be in (0,
                // sample_rate_hz/20)" with neither).
                for m in e.errors.iter_mut() {
                    *m = format!("bias.settings.{m}");
                }
                e.errors.push(format!(
                    "bias.settings.sample_rate_hz is the stream's own rate here, {rate_hz} Hz (from its descriptor), not the config's"
                ));
                e
            })?;
        }
        Ok(())
    }

    /// Read the stage sections of a config table (already laid over the embedded defaults);
    /// `None` if any of them had an error. Every section is checked in full, each mistake
    /// reported once at its key path: structure key by key, then values, then model files.
    pub fn from_table(table: &toml::Table, base: &Path, errs: &mut Errors) -> Option<StagesConfig> {
        let n = errs.len();
        let ge: GrossErrorSection = stage_section(table, "gross_error", errs);
        // Settings written in a disabled section are still checked: a mistake must not wait
        // until the day the stage is switched on.
        let ge_settings = validated(ge.settings.validate(), errs, "gross_error.settings");
        let ge_model = ge.model.as_ref().and_then(|m| {
            load_model(
                base,
                m,
                "gross_error.model",
                |t| ArimaModelFile::from_toml_str(t).map_err(|e| e.to_string()),
                errs,
            )
        });
        let bs: BiasSection = stage_section(table, "bias", errs);
        let bias_settings = validated(bs.settings.validate(), errs, "bias.settings");
        let model = match &bs.model {
            Some(BiasModelSource::File(f)) => load_model(
                base,
                f,
                "bias.model",
                |t| BiasModelFile::from_toml_str(t).map_err(|e| e.to_string()),
                errs,
            ),
            Some(BiasModelSource::Inline(m)) => {
                if let Err(v) = m.validate() {
                    for x in v {
                        push_keyed(errs, "bias.model", x);
                    }
                }
                Some(m.clone())
            }
            None => None,
        };
        // The model's rate is checked against the stage's when the stage is built: replay
        // adopts the log's declared rate first.
        let ms: MonitorSection = stage_section(table, "monitor", errs);
        if let Err(v) = ms.settings.validate() {
            for m in v {
                push_keyed(errs, "monitor.settings", m);
            }
        }
        let (Some(ge_settings), Some(bias_settings)) = (ge_settings, bias_settings) else {
            return None;
        };
        (errs.len() == n).then_some(StagesConfig {
            gross_error: ge.enabled.then_some(GrossErrorConfig {
                settings: ge_settings,
                model: ge_model,
            }),
            bias: bs.enabled.then_some(BiasConfig {
                settings: bias_settings,
                model,
            }),
            monitor: ms.enabled.then_some(ms.settings),
            declared_rate_hz: None,
        })
    }

    /// The pipeline these settings describe: gross errors first, then bias, then the monitor.
    pub fn build(&self) -> Result<Pipeline, String> {
        let mut stages: Vec<Box<dyn Stage>> = Vec::new();
        if let Some(g) = &self.gross_error {
            let st = GrossErrorStage::new(&g.settings, g.model.as_ref())
                .map_err(|e| format!("gross_error: {e}"))?;
            stages.push(Box::new(st));
        }
        if let Some(b) = &self.bias {
            let st =
                BiasStage::new(&b.settings, b.model.as_ref()).map_err(|e| format!("bias: {e}"))?;
            stages.push(Box::new(st));
        }
        if let Some(m) = &self.monitor {
            let st = MonitorStage::new(m.clone(), self.declared_rate_hz)
                .map_err(|e| format!("monitor: {e}"))?;
            stages.push(Box::new(st));
        }
        Ok(Pipeline::new(stages))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_new_sample_rate_is_validated_again_and_a_bad_one_changes_nothing() {
        let mut c = StagesConfig {
            gross_error: None,
            bias: Some(BiasConfig {
                settings: BiasSettings::default().validate().unwrap(),
                model: None,
            }),
            monitor: None,
            declared_rate_hz: None,
        };
        c.set_sample_rate(200.0).unwrap();
        assert_eq!(c.bias.as_ref().unwrap().settings.sample_rate_hz, 200.0);
        let e = c.set_sample_rate(1e6).unwrap_err();
        assert!(
            e.iter()
                .any(|m| m.starts_with("bias.settings.sample_rate_hz:")),
            "{e}"
        );
        assert!(
            e.iter()
                .any(|m| m.contains("the stream's own rate here, 1000000 Hz")),
            "{e}"
        );
        assert!(e.to_string().starts_with("invalid bias settings:"), "{e}");
        assert_eq!(c.bias.as_ref().unwrap().settings.sample_rate_hz, 200.0);
        assert_eq!(c.build().unwrap().stage_names(), ["bias"]);
    }
}
