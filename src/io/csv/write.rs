//! Writing samples as a canonical CSV.

use super::CsvError;
use crate::io::format::{CSV_HEADER, write_csv_row};
use crate::sample::Sample;
use std::io::Write;
use std::path::Path;

/// Write samples as canonical CSV plus `seq` and `flags`.
pub fn write_csv(path: &Path, samples: &[Sample]) -> Result<(), CsvError> {
    let io = |err| CsvError::Io {
        path: path.into(),
        err,
    };
    let f = std::fs::File::create(path).map_err(io)?;
    let mut w = std::io::BufWriter::with_capacity(1 << 16, f);
    writeln!(w, "{CSV_HEADER}").map_err(io)?;
    let mut line = String::new();
    for s in samples {
        line.clear();
        write_csv_row(s, &mut line);
        w.write_all(line.as_bytes()).map_err(io)?;
    }
    w.flush().map_err(io)
}
