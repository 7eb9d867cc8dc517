//! What an import found besides the samples ([`ImportReport`]), and how it is said.

use super::TableFormat;
use super::units;
use crate::io::timing::TimeFaults;

/// The empty cells of one present channel (a column with values in other rows): each imported
/// as a missing value (NaN), which the decoders and the pipeline flag `NON_FINITE`.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct EmptyCells {
    pub channel: String,
    pub cells: u64,
    /// Line in the file (1 = the header) of the first.
    pub first_line: usize,
    /// The file that line is in, where the import read two (`--accel-file`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
}

/// Which column an import read for one of t, gx..az, temp.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ColumnUse {
    pub key: &'static str,
    pub column: String,
}

/// What an import found besides the samples.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ImportReport {
    /// How the text table was read when it is not a comma-separated file with its header on
    /// line 1: the delimiter, decimal commas, comment lines skipped, no header.
    pub table: Option<TableFormat>,
    /// Samples: the rows read (with two streams merged, the merged samples).
    pub rows: u64,
    /// The columns read (absent channels and, with `--rate`, the time column left out).
    pub columns: Vec<ColumnUse>,
    /// How the time, gyro and accel units were decided (stated, convention or inferred from the
    /// data, with the evidence).
    pub units: Vec<units::UnitFinding>,
    /// The data contradicting a stated unit (never overridden: the flag to pass is named).
    pub warnings: Vec<String>,
    /// Sequence and time faults derived from the time stamps (all zero with `--rate`).
    pub time: TimeFaults,
    /// `--rate`: the time stamps are the row index over this rate, Hz (no time column read).
    pub index_rate_hz: Option<f64>,
    /// Channels the file does not have (no column, or a column empty in every row): written as
    /// absent (the descriptor's absent mask, NaN values), never as zeros.
    pub absent: Vec<String>,
    /// Present channels with some empty cells, in channel order (rows kept, values NaN).
    pub empty_cells: Vec<EmptyCells>,
    /// Rows whose every present channel is empty (counted in `empty_cells` too): kept as
    /// samples with no value, their time stamp holding the time base.
    pub empty_rows: u64,
    /// Line of the first such row.
    pub first_empty_row: Option<usize>,
    /// The table held two streams (gyro rows and accelerometer rows) and was merged onto one's
    /// time stamps; `rows` counts the merged samples.
    pub streams: Option<super::streams::StreamMerge>,
    /// What the import did to the time stamps besides the unit (a counter's wraps unwrapped).
    pub notes: Vec<String>,
    /// `--where COL=VALUE`: the rows read and those left out.
    pub selected: Option<String>,
}

impl std::fmt::Display for ImportReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(t) = &self.table {
            writeln!(f, "table: {t}")?;
        }
        let rows = crate::text::count(self.rows, "row", "rows");
        match self.index_rate_hz {
            Some(hz) => write!(
                f,
                "{rows}; time: row index / {hz} Hz (--rate: no time column read, so no gap or time fault can be seen)"
            )?,
            None => write!(f, "{rows}; {}", self.time)?,
        }
        if !self.absent.is_empty() {
            write!(
                f,
                "; channels absent (no column, or every cell empty): {} — written as absent, not as zeros",
                self.absent.join(", ")
            )?;
        }
        if let Some(s) = &self.selected {
            write!(f, "\n{s}")?;
        }
        if let Some(m) = &self.streams {
            write!(f, "\n{m}")?;
        }
        // Missing values on a line of their own: a user must see them, not find them at the
        // end of the time summary.
        if !self.empty_cells.is_empty() {
            let each: Vec<String> = self
                .empty_cells
                .iter()
                .map(|e| {
                    format!(
                        "{}: {} (first at line {}{})",
                        e.channel,
                        crate::text::count(e.cells, "empty cell", "empty cells"),
                        e.first_line,
                        e.file
                            .as_ref()
                            .map_or(String::new(), |f| format!(" of {f}"))
                    )
                })
                .collect();
            write!(
                f,
                "\n{} — imported as missing values (NaN), rows kept, flagged non-finite by the pipeline",
                each.join(", ")
            )?;
        }
        if let Some(line) = self.first_empty_row {
            write!(
                f,
                "\n{} with every channel empty (first at line {}) — kept, with no value (the time stamp holds the time base), flagged non-finite by the pipeline",
                crate::text::count(self.empty_rows, "row", "rows"),
                line
            )?;
        }
        if !self.columns.is_empty() {
            let each: Vec<String> = self
                .columns
                .iter()
                .map(|c| format!("{}={}", c.key, c.column))
                .collect();
            write!(f, "\ncolumns: {}", each.join(", "))?;
        }
        for u in &self.units {
            write!(f, "\n{u}")?;
        }
        for n in &self.notes {
            write!(f, "\n{n}")?;
        }
        for w in &self.warnings {
            write!(f, "\nWARNING: {w}")?;
        }
        Ok(())
    }
}
