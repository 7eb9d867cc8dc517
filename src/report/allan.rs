//! `imuprep allan`: the Allan report of a static recording
//! ([`crate::analysis::allan::report`]) and its exports in a folder.

use std::fmt::{self, Write};
use std::path::Path;

use anyhow::{Context, Result};

use super::{load_channels_to, parse_channels, present_channels_of};
use crate::analysis::allan::plot::allan_svg;
use crate::analysis::allan::report::{AllanReport, allan_report_of};
use crate::analysis::allan::{export, terms::FitSettings};

/// The report and the names of the files written beside it.
pub struct AllanRun {
    pub report: AllanReport,
    /// File names written in the output folder.
    pub written: Vec<String>,
    pub out_dir: std::path::PathBuf,
}

/// Allan deviation and terms of `log` (after `skip_s`) on `channels`; exports into `out_dir`.
pub fn allan(
    log: &super::Recording,
    channels: &[String],
    skip_s: f64,
    out_dir: &Path,
) -> Result<AllanRun> {
    // Held by channel (64 bytes per sample, where the samples take 136): see `Channels`.
    let (rate, samples) = load_channels_to(log, skip_s, None)?;
    let chans = parse_channels(channels)?;
    // A partial sensor's absent channels are said in the report, never analysed as NaN.
    let (chans, absent) = present_channels_of(log, &samples, &chans)?;
    let source = log.display().to_string();
    let mut report = allan_report_of(&source, &samples, rate, &chans, &FitSettings::default())
        .with_context(|| {
            format!(
                "{source}: {} ({:.2} s at {} Hz) after --skip-s {skip_s}",
                crate::text::count(samples.len() as u64, "sample", "samples"),
                samples.len() as f64 / rate,
                crate::text::trim_decimals(rate, 3)
            )
        })?;
    report.skipped.extend(absent);
    if let Some(w) = super::not_at_rest_of(&samples, rate) {
        report.warnings.push(format!(
            "{w}: the Allan deviation and its terms measure the motion as well as the sensor's noise, and so do imu.yaml, gnss_imu_config.txt and bias.toml; analyse a recording at rest, or skip to a still part (--skip-s)"
        ));
    }
    let written = write_outputs(&report, out_dir).map_err(anyhow::Error::msg)?;
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

/// Write the report (text and JSON), the plot and the three exports into `dir` (created if
/// needed). Without both gyro and accelerometer channels the two per-sensor exports are left
/// out. Returns the paths written.
fn write_outputs(
    report: &AllanReport,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, String> {
    let io = |p: &std::path::Path, e: std::io::Error| format!("writing {}: {e}", p.display());
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let (model, notes) = export::bias_model(report);
    let mut text = report.to_string();
    text.push_str(
        "
bias model (ar_of = bias: Gauss-Markov from B, white noise from N and Q, RRW from K):
",
    );
    for n in &notes {
        let _ = writeln!(
            text,
            "  {}: T_c {:.1} s, sigma_GM {:.3e}{}{}{}{}",
            n.channel,
            n.tc_s,
            n.sigma_gm,
            if n.b_is_bound {
                " (from the upper bound of B)"
            } else {
                ""
            },
            if n.n_is_bound {
                ", N from its upper bound"
            } else {
                ""
            },
            n.rrw_q_per_s.map_or(String::new(), |q| format!(
                ", rate_random_walk q_per_s {q:.3e}"
            )),
            if n.ramp_dropped {
                "; the rate ramp has no place in the format"
            } else {
                ""
            },
        );
    }
    let mut files: Vec<(&str, String)> = vec![
        ("report.txt", text),
        (
            "report.json",
            serde_json::to_string_pretty(report).map_err(|e| e.to_string())?,
        ),
        ("allan.svg", allan_svg(report)?),
        (
            "bias.toml",
            report
                .warnings
                .iter()
                .map(|w| format!("# WARNING: {w}\n"))
                .collect::<String>()
                + &model.to_toml_string().map_err(|e| e.to_string())?,
        ),
    ];
    if let Some(y) = export::kalibr_yaml(report) {
        files.push(("imu.yaml", y));
    }
    if let Some(c) = export::gnss_imu_config(report) {
        files.push(("gnss_imu_config.txt", c));
    }
    let mut written = Vec::new();
    for (name, body) in files {
        let p = dir.join(name);
        std::fs::write(&p, body).map_err(|e| io(&p, e))?;
        written.push(p);
    }
    Ok(written)
}
