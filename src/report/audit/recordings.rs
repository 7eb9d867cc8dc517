//! Which files under a folder are recordings, how each is read, and a config's pipeline run
//! over one.

use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::frame::Descriptor;
use crate::frame::detect::ProtocolConfig;
use crate::io::csv::{ImportOptions, Sniffed, read_log, sniff_file};
use crate::report::convert;
use crate::sample::Sample;

/// Recordings under `dir`, sorted by path: `.log` (native), `.csv`, `.csv.gz`, `.ulg` (PX4),
/// `.txt`, `.tsv`, `.dat` (or their `.gz`) whose content is a text table of numbers (a
/// `NOTES.txt` is none, and is no recording), and any other file whose first bytes decode as a
/// sensor protocol (UBX, MAVLink, ULog, MCAP) or are a bag this build imports (ROS 1, SQLite).
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
                if known || text || protocol_file(&p) {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    Ok(out)
}

/// A file that is no text (a text table is told by its name or content above) and that the
/// decoders take for a sensor protocol, or a bag only `import` reads.
fn protocol_file(p: &Path) -> bool {
    use crate::frame::detect::{file_head, file_protocol, import_only};
    match file_head(p, 16) {
        Some(head) if !head.starts_with(&crate::frame::LOG_MAGIC) => {
            import_only(&head)
                || (matches!(sniff_file(p), Sniffed::Binary) && file_protocol(p).is_some())
        }
        _ => false,
    }
}

/// Read a recording as `imuprep replay` (native log) or `imuprep import` with no flags (any
/// other: a text table, a sensor protocol's file, a bag) would.
pub fn load_recording(path: &Path) -> Result<(Descriptor, Vec<Sample>), String> {
    if path.to_string_lossy().ends_with(".log") {
        let (d, s, _) = read_log(path).map_err(|e| e.to_string())?;
        Ok((d.unwrap_or_default(), s))
    } else {
        let loaded = convert::load(path, &ProtocolConfig::auto(), &ImportOptions::default())
            .map_err(|e| format!("{e:#}"))?;
        Ok((loaded.descriptor, loaded.samples))
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
    // The stages' own messages (lines found, model-health alarms: hundreds over an audit's
    // runs, most of them on the injected copies) are the daemon's, not the audit's report.
    let quiet = tracing::subscriber::NoSubscriber::default();
    tracing::subscriber::with_default(quiet, || {
        let mut p = cfg.stages.build()?;
        Ok(crate::stage::run_through(&mut p, samples))
    })
}
