//! Writing samples as a canonical CSV.

use super::CsvError;
use crate::frame::Descriptor;
use crate::io::convert::{ExportFormat, ExportWriter};
use crate::sample::Sample;
use std::path::Path;

/// Write samples as canonical CSV plus `seq` and `flags` (`export --to csv`'s writer).
pub fn write_csv(path: &Path, samples: &[Sample]) -> Result<(), CsvError> {
    let io = |err| CsvError::Io {
        path: path.into(),
        err,
    };
    let f = std::fs::File::create(path).map_err(io)?;
    let mut w = ExportWriter::new(ExportFormat::Csv, &Descriptor::default(), f).map_err(io)?;
    for s in samples {
        w.push(s).map_err(io)?;
    }
    w.finish().map(drop).map_err(io)
}
