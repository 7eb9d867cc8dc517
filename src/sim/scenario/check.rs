//! What validation reports: an [`Issue`] per problem at its key path, and the [`Checker`] that
//! collects them with the common value checks.

/// One validation problem: where, and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct Issue {
    /// TOML key path, e.g. `motion.segments[2].duration_s`.
    pub path: String,
    pub message: String,
}

impl std::fmt::Display for Issue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.path, self.message)
    }
}

/// Collects validation issues with their key paths.
#[derive(Default)]
pub(crate) struct Checker {
    pub issues: Vec<Issue>,
}

impl Checker {
    pub fn push(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.issues.push(Issue {
            path: path.into(),
            message: message.into(),
        });
    }
    pub fn finite(&mut self, path: &str, v: f64) -> bool {
        if v.is_finite() {
            true
        } else {
            self.push(path, format!("must be finite, got {v}"));
            false
        }
    }
    pub fn positive(&mut self, path: &str, v: f64) {
        if !(v.is_finite() && v > 0.0) {
            self.push(path, format!("must be finite and > 0, got {v}"));
        }
    }
    pub fn non_negative(&mut self, path: &str, v: f64) {
        if !(v.is_finite() && v >= 0.0) {
            self.push(path, format!("must be finite and >= 0, got {v}"));
        }
    }
    pub fn non_negative3(&mut self, path: &str, v: &[f64; 3]) {
        for (i, x) in v.iter().enumerate() {
            if !(x.is_finite() && *x >= 0.0) {
                self.push(
                    format!("{path}[{i}]"),
                    format!("must be finite and >= 0, got {x}"),
                );
            }
        }
    }
    pub fn finite3(&mut self, path: &str, v: &[f64; 3]) {
        for (i, x) in v.iter().enumerate() {
            if !x.is_finite() {
                self.push(format!("{path}[{i}]"), format!("must be finite, got {x}"));
            }
        }
    }
    pub fn finite33(&mut self, path: &str, m: &[[f64; 3]; 3]) {
        for (i, row) in m.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                if !x.is_finite() {
                    self.push(
                        format!("{path}[{i}][{j}]"),
                        format!("must be finite, got {x}"),
                    );
                }
            }
        }
    }
    pub fn probability(&mut self, path: &str, v: f64) {
        if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
            self.push(path, format!("must be a probability in [0, 1], got {v}"));
        }
    }
}
