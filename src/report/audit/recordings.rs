//! Which files under a folder are recordings, how each is read, and a config's pipeline run
//! over one.

use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::frame::Descriptor;
use crate::io::csv::{ImportOptions, Sniffed, read_csv, read_log, sniff_file};
use crate::report::convert;
use crate::sample::Sample;

/// Recordings under `dir`, sorted by path: `.log` (native), `.csv`, `.csv.gz`, `.ulg` (PX4), and
/// `.txt`, `.tsv`, `.dat` (or their `.gz`) whose content is a text table of numbers (a
/// `NOTES.txt` is none, and is no recording).
pub fn find_recordings(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d)? {
            let p = e?.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let n = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                let known =
                    [".log", ".ulg"].iter().any(|e| n.ends_with(e)) || convert::is_csv_name(&p);
                let lower = n.to_ascii_lowercase();
                let stem = lower.strip_suffix(".gz").unwrap_or(&lower);
                let text = [".txt", ".tsv", ".dat"].iter().any(|e| stem.ends_with(e))
                    && matches!(sniff_file(&p), Sniffed::Table(_));
                if known || text {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Read a recording as `imuprep import` (a text table or a ULog) or `imuprep replay` (native
/// log) would.
pub fn load_recording(path: &Path) -> Result<(Descriptor, Vec<Sample>), String> {
    let name = path.to_string_lossy();
    if name.ends_with(".log") {
        let (d, s, _) = read_log(path).map_err(|e| e.to_string())?;
        Ok((d.unwrap_or_default(), s))
    } else if name.ends_with(".ulg") {
        let pc = crate::frame::detect::ProtocolConfig::auto();
        // As `imuprep import` reads it: time faults and rate over the whole file.
        let (f, _) = crate::io::convert::read_any_whole(path, &pc).map_err(|e| e.to_string())?;
        if f.samples.is_empty() {
            return Err("no IMU samples decoded".into());
        }
        Ok((f.descriptor.unwrap_or_default(), f.samples))
    } else {
        read_csv(path, &ImportOptions::default()).map_err(|e| e.to_string())
    }
}

/// `cfg`'s pipeline over `samples` (the stages' rate from the descriptor).
pub fn run_config(
    cfg: &Config,
    desc: &Descriptor,
    samples: &[Sample],
) -> Result<Vec<Sample>, String> {
    let mut cfg = cfg.clone();
    cfg.stages
        .set_sample_rate(desc.sample_rate_hz)
        .map_err(|e| e.to_string())?;
    let mut p = cfg.stages.build()?;
    Ok(crate::stage::run_through(&mut p, samples))
}
