//! Writing a simulation as a replay log (+ truth sidecar): the glue behind `imuprep simulate`.

use crate::io::log::LogWriter;
use crate::sim::log::descriptor;
use crate::sim::truth::TruthWriter;
use crate::sim::{Emission, Scenario, SimError, Simulator};
use std::path::Path;

/// What a simulation run wrote.
#[derive(Debug, Clone, Copy, Default)]
pub struct SimLogSummary {
    pub instants: u64,
    pub frames: u64,
    pub dropped: u64,
    pub duplicated: u64,
    pub bytes: u64,
}

/// Run `scn` with `seed` and write the frames a serial port would have carried (dropped frames
/// absent, duplicated ones twice) to `log`, and the truth sidecar to `truth` if given (gzip when
/// the name ends in `.gz`).
pub fn write_sim_log(
    scn: &Scenario,
    seed: u64,
    log: &Path,
    truth: Option<&Path>,
) -> Result<SimLogSummary, SimError> {
    let mut sim = Simulator::new(scn, seed)?;
    let mut tw = match truth {
        Some(p) => Some(TruthWriter::create(p, &sim.truth_header())?),
        None => None,
    };
    let out = std::io::BufWriter::with_capacity(1 << 16, std::fs::File::create(log)?);
    let mut lw = LogWriter::new(out, &descriptor(&sim));
    let mut sum = SimLogSummary::default();
    while let Some(r) = sim.next_record() {
        sum.instants += 1;
        let copies = match r.emission {
            Emission::Normal => 1,
            Emission::Dropped => {
                sum.dropped += 1;
                0
            }
            Emission::Duplicated => {
                sum.duplicated += 1;
                2
            }
        };
        for _ in 0..copies {
            lw.sample(&r.sample)?;
            sum.frames += 1;
        }
        if let Some(w) = tw.as_mut() {
            w.write_row(&r.truth)?;
        }
    }
    sum.bytes = lw.finish()?.1;
    if let Some(w) = tw {
        w.finish()?;
    }
    Ok(sum)
}
