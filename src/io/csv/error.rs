//! Why an import or export failed: [`CsvError`] and the words its messages use.

use std::path::PathBuf;

/// Why an import or export failed.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    #[error("{path}: {err}")]
    Io { path: PathBuf, err: std::io::Error },
    #[error("{path}: empty file (no header line)")]
    Empty { path: PathBuf },
    #[error("{path}: {msg}; header columns are: {header}")]
    Columns {
        path: PathBuf,
        msg: String,
        header: String,
    },
    #[error(
        "{path}:{line}: no header: the first row holds values, not names ({row}); name the columns by position with --columns, e.g. --columns {example} (keys t gx gy gz ax ay az temp, `_` skips a column)"
    )]
    Headerless {
        path: PathBuf,
        line: usize,
        row: String,
        example: String,
    },
    #[error("{path}:{line}:{col}: cannot read {cell:?} as a number ({})", column_words(.name))]
    Cell {
        path: PathBuf,
        line: usize,
        col: usize,
        cell: String,
        name: String,
    },
    /// Two files that cannot be read as one recording (`import --accel-file`).
    #[error("{path}: {msg}")]
    Pair { path: PathBuf, msg: String },
    #[error("{path}:{line}: {msg}")]
    Row {
        path: PathBuf,
        line: usize,
        msg: String,
    },
}

/// `column NAME`, or the name alone when it says so already (`column 3`, a column named by
/// position).
fn column_words(name: &str) -> String {
    if name.starts_with("column ") {
        name.to_string()
    } else {
        format!("column {name}")
    }
}
