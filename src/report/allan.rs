//! `imuprep allan`: the Allan report of a static recording
//! ([`crate::analysis::allan::report`]) and its exports in a folder.

use std::fmt;
use std::path::Path;

use anyhow::Result;

use super::{load_span, parse_channels, present_channels};
use crate::analysis::allan::report::{AllanReport, allan_report};
use crate::analysis::allan::{export, terms::FitSettings};

/// The report and the names of the files written beside it.
pub struct AllanRun {
    pub report: AllanReport,
    /// File names written in the output folder.
    pub written: Vec<String>,
    pub out_dir: std::path::PathBuf,
}

/// Allan deviation and terms of `log` (after `skip_s`) on `channels`; exports into `out_dir`.
pub fn allan(log: &Path, channels: &[String], skip_s: f64, out_dir: &Path) -> Result<AllanRun> {
    let (rate, samples) = load_span(log, skip_s)?;
    let chans = parse_channels(channels)?;
    // A partial sensor's absent channels are said in the report, never analysed as NaN.
    let (chans, absent) = present_channels(log, &samples, &chans)?;
    let source = log.display().to_string();
    let mut report = allan_report(&source, &samples, rate, &chans, &FitSettings::default())?;
    report.skipped.extend(absent);
    let written = export::write_outputs(&report, out_dir).map_err(anyhow::Error::msg)?;
    let written = written
        .iter()
        .filter_map(|p| Some(p.file_name()?.to_str()?.to_string()))
        .collect();
    Ok(AllanRun {
        report,
        written,
        out_dir: out_dir.to_path_buf(),
    })
}

impl fmt::Display for AllanRun {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.report)?;
        writeln!(
            f,
            "wrote {} in {}",
            self.written.join(", "),
            self.out_dir.display()
        )?;
        if !self.written.iter().any(|n| n == "imu.yaml") {
            writeln!(
                f,
                "(imu.yaml and gnss_imu_config.txt need gyro and accelerometer channels)"
            )?;
        }
        Ok(())
    }
}
