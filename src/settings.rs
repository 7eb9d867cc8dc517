//! The settings toolkit under every config section: errors located by key path, collected over
//! a whole file ([`Errors`]), a TOML table laid over another ([`overlay`]) and a section read key
//! by key over its defaults ([`lenient`]). `config/` (the whole file) and `stage/build.rs` (the
//! stage sections) both use it; it uses neither.

use std::fmt;
use std::path::{Path, PathBuf};

/// One configuration mistake, located by its key path (e.g. `sinks[1].bind`).
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError {
    pub path: String,
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.message)
    }
}

/// All mistakes found in one configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigErrors(pub Vec<ConfigError>);

impl fmt::Display for ConfigErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} configuration error(s):", self.0.len())?;
        for e in &self.0 {
            writeln!(f, "  - {e}")?;
        }
        Ok(())
    }
}
impl std::error::Error for ConfigErrors {}

/// Every problem found in one stage's settings, one `key: message` per entry (keys relative to
/// the stage's settings table, e.g. `stillness.window_s`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid {section} settings:\n  {}", .errors.join("\n  "))]
pub struct SettingsErrors {
    /// The stage (`gross_error`, `bias`).
    pub section: &'static str,
    pub errors: Vec<String>,
}

impl std::ops::Deref for SettingsErrors {
    type Target = [String];
    fn deref(&self) -> &[String] {
        &self.errors
    }
}

impl SettingsErrors {
    /// `Ok(valid)` when `errors` is empty.
    pub fn check<T>(section: &'static str, errors: Vec<String>, valid: T) -> Result<T, Self> {
        if errors.is_empty() {
            Ok(valid)
        } else {
            Err(SettingsErrors { section, errors })
        }
    }

    /// Record each problem in `errs` under `prefix` (the table's key path), keyed.
    pub fn push_into(self, errs: &mut Errors, prefix: &str) {
        for m in self.errors {
            push_keyed(errs, prefix, m);
        }
    }
}

/// Raw settings and their validated form (linfa's `ParamGuard`): a stage takes anything that
/// becomes its validated settings — the raw ones are checked by their one `validate`, validated
/// ones pass as they are — and is built from the validated form only.
pub trait IntoValid {
    type Valid;
    fn into_valid(self) -> Result<Self::Valid, SettingsErrors>;
}

/// `pub struct $valid($raw)`: settings that passed `$raw::validate(self) -> Result<$valid,
/// SettingsErrors>` (which builds it with `$valid::checked`), read through `Deref`, with the
/// [`IntoValid`] conversions of the raw and validated forms, owned and borrowed.
#[macro_export]
macro_rules! valid_settings {
    ($(#[$doc:meta])* $valid:ident, $raw:ty) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $valid($raw);

        impl $valid {
            /// Only for the raw type's `validate`, once every check has passed.
            fn checked(raw: $raw) -> Self {
                $valid(raw)
            }
            /// The settings, to change and validate again.
            pub fn into_inner(self) -> $raw {
                self.0
            }
        }

        impl std::ops::Deref for $valid {
            type Target = $raw;
            fn deref(&self) -> &$raw {
                &self.0
            }
        }

        impl PartialEq<$raw> for $valid {
            fn eq(&self, o: &$raw) -> bool {
                self.0 == *o
            }
        }

        impl $crate::settings::IntoValid for $raw {
            type Valid = $valid;
            fn into_valid(self) -> Result<$valid, $crate::settings::SettingsErrors> {
                self.validate()
            }
        }

        impl $crate::settings::IntoValid for &$raw {
            type Valid = $valid;
            fn into_valid(self) -> Result<$valid, $crate::settings::SettingsErrors> {
                self.clone().validate()
            }
        }

        impl $crate::settings::IntoValid for $valid {
            type Valid = $valid;
            fn into_valid(self) -> Result<$valid, $crate::settings::SettingsErrors> {
                Ok(self)
            }
        }

        impl $crate::settings::IntoValid for &$valid {
            type Valid = $valid;
            fn into_valid(self) -> Result<$valid, $crate::settings::SettingsErrors> {
                Ok(self.clone())
            }
        }
    };
}

/// Collects errors while validating.
#[derive(Default)]
pub struct Errors(Vec<ConfigError>);

impl Errors {
    pub fn push(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.0.push(ConfigError {
            path: path.into(),
            message: message.into(),
        });
    }
    /// Record `message` at `path` unless `ok`.
    pub fn check(&mut self, ok: bool, path: impl Into<String>, message: impl Into<String>) {
        if !ok {
            self.push(path, message);
        }
    }
    pub fn len(&self) -> usize {
        self.0.len()
    }
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    /// Drop repeats of an error already recorded (same path, same message), keeping the order.
    pub fn dedup(&mut self) {
        let mut seen = std::collections::HashSet::new();
        self.0
            .retain(|e| seen.insert((e.path.clone(), e.message.clone())));
    }
    pub fn into_vec(self) -> Vec<ConfigError> {
        self.0
    }
}

/// Merge `top` into `base`: sub-tables merge, other values replace.
pub fn overlay(base: &mut toml::Table, top: toml::Table) {
    for (k, v) in top {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => overlay(b, t),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// `T` from `user` laid key by key over `base` (a table of `T`'s fields, usually its
/// defaults): a key that does not deserialise — unknown, or of the wrong type — is reported once,
/// at its own path (`prefix.key.sub`), and keeps the base value; every other key still applies.
/// So every structural mistake of a section is found in one run, and the value checks that follow
/// see every key that parsed.
pub fn lenient<T: serde::de::DeserializeOwned>(
    base: toml::Table,
    user: &toml::Table,
    prefix: &str,
    errs: &mut Errors,
) -> Option<T> {
    let check = |t: &toml::Table| {
        toml::Value::Table(t.clone())
            .try_into::<T>()
            .map(|_| ())
            .map_err(|e| clean_serde(&e.to_string()))
    };
    let mut acc = base;
    apply_keys(&mut acc, &mut Vec::new(), user, prefix, errs, &check);
    match toml::Value::Table(acc).try_into::<T>() {
        Ok(t) => Some(t),
        Err(e) => {
            errs.push(prefix, clean_serde(&e.to_string()));
            None
        }
    }
}

/// The value at `at` inside `root`, if any.
fn value_at<'a>(root: &'a toml::Table, at: &[String]) -> Option<&'a toml::Value> {
    let (last, parents) = at.split_last()?;
    let mut t = root;
    for k in parents {
        t = t.get(k)?.as_table()?;
    }
    t.get(last)
}

/// Set the value at `at` inside `root` (the parents exist: they were walked to get here).
fn set_at(root: &mut toml::Table, at: &[String], v: toml::Value) {
    let (last, parents) = at.split_last().expect("a key path is never empty");
    let mut t = root;
    for k in parents {
        t = t
            .get_mut(k)
            .and_then(|x| x.as_table_mut())
            .expect("parent tables exist");
    }
    t.insert(last.clone(), v);
}

fn apply_keys(
    root: &mut toml::Table,
    at: &mut Vec<String>,
    user: &toml::Table,
    prefix: &str,
    errs: &mut Errors,
    check: &dyn Fn(&toml::Table) -> Result<(), String>,
) {
    for (k, v) in user {
        at.push(k.clone());
        match (value_at(root, at), v) {
            (Some(toml::Value::Table(bt)), toml::Value::Table(ut)) => {
                // The sub-table as a whole first (a tagged enum changes variant only so), key by
                // key when that fails, to name the key at fault.
                let mut merged = bt.clone();
                overlay(&mut merged, ut.clone());
                let mut trial = root.clone();
                set_at(&mut trial, at, toml::Value::Table(merged));
                if check(&trial).is_ok() {
                    *root = trial;
                } else {
                    apply_keys(root, at, ut, prefix, errs, check)
                }
            }
            _ => {
                let mut trial = root.clone();
                set_at(&mut trial, at, v.clone());
                match check(&trial) {
                    Ok(()) => *root = trial,
                    Err(e) => errs.push(format!("{prefix}.{}", at.join(".")), e),
                }
            }
        }
        at.pop();
    }
}

/// Value-check messages that start with their key (`k = 60 must be …`, `gyro.scale[1]: …`)
/// recorded at `prefix.key`; others at `prefix`.
pub fn push_keyed(errs: &mut Errors, prefix: &str, message: String) {
    let key_len = message
        .find(|c: char| !(c.is_ascii_alphanumeric() || "_.[]".contains(c)))
        .unwrap_or(0);
    let (key, rest) = message.split_at(key_len);
    if key_len > 0 && rest.starts_with(": ") {
        errs.push(format!("{prefix}.{key}"), rest[2..].to_string());
    } else if key_len > 0 && rest.starts_with(" = ") {
        errs.push(format!("{prefix}.{key}"), message.clone());
    } else {
        errs.push(prefix, message);
    }
}

/// Deserialise one top-level section, recording every key at fault under `section.key`: the
/// first error serde reports hides the rest of the section (an unknown key stops it before a
/// bad value is checked), so each key it names is recorded and left out, and the rest is tried
/// again — the remainder, when it then parses, is returned so its values are validated in the
/// same run. An error that names no key of the section is recorded under the section's name.
pub fn section<T: serde::de::DeserializeOwned>(
    table: &toml::Table,
    key: &str,
    errs: &mut Errors,
) -> Option<T> {
    let mut v = table.get(key)?.clone();
    loop {
        let e = match v.clone().try_into::<T>() {
            Ok(t) => return Some(t),
            Err(e) => clean_serde(&e.to_string()),
        };
        let at = faulty_key(&e).filter(|k| v.as_table().is_some_and(|t| t.contains_key(k)));
        match (at, v.as_table_mut()) {
            (Some(k), Some(t)) => {
                errs.push(format!("{key}.{k}"), e);
                t.remove(&k);
            }
            _ => {
                errs.push(key, e);
                return None;
            }
        }
    }
}

/// The section key a serde message blames: "unknown field `k`", or "… in `k`" / "… in `k.sub`".
fn faulty_key(message: &str) -> Option<String> {
    let quoted = |from: &str| -> Option<String> {
        let rest = &message[message.find(from)? + from.len()..];
        let k = &rest[..rest.find('`')?];
        Some(k.split(['.', '[']).next().unwrap_or(k).to_string())
    };
    quoted("unknown field `").or_else(|| quoted(" in `"))
}

/// serde's TOML messages span lines; keep them on one.
pub fn clean_serde(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Resolve `p` against `base` unless absolute.
pub fn resolve(base: &Path, p: &Path) -> PathBuf {
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}
