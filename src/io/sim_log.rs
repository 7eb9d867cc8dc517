//! Writing a simulation as a replay log (+ truth sidecar): the glue behind `imuprep simulate`.

use crate::io::log::LogWriter;
use crate::sim::log::descriptor;
use crate::sim::truth::TruthWriter;
use crate::sim::{Emission, Scenario, SimError, Simulator};
use std::path::Path;

/// What a simulation run wrote.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct SimLogSummary {
    pub instants: u64,
    pub frames: u64,
    pub dropped: u64,
    pub duplicated: u64,
    pub bytes: u64,
    /// Channel-samples clipped at the sensor's range (flagged saturated), over the instants.
    pub clipped: u64,
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
    // Name the file in an I/O error (a bare "No such file or directory" names nothing).
    fn at(p: &Path) -> impl FnOnce(std::io::Error) -> std::io::Error + '_ {
        move |e| std::io::Error::new(e.kind(), format!("{}: {e}", p.display()))
    }
    let mut tw = match truth {
        Some(p) => Some(TruthWriter::create(p, &sim.truth_header()).map_err(at(p))?),
        None => None,
    };
    let out =
        std::io::BufWriter::with_capacity(1 << 16, std::fs::File::create(log).map_err(at(log))?);
    let mut lw = LogWriter::new(out, &descriptor(&sim));
    let mut sum = SimLogSummary::default();
    let mut bar = crate::progress::Delayed::steps(sim.len() as u64, "instants simulated");
    while let Some(r) = sim.next_record() {
        sum.instants += 1;
        bar.sample_done(sum.instants);
        sum.clipped += u64::from((r.sample.flags & crate::sample::flags::SAT_ANY).count_ones());
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
            lw.sample(&r.sample).map_err(at(log))?;
            sum.frames += 1;
        }
        if let Some(w) = tw.as_mut() {
            w.write_row(&r.truth).map_err(at(truth.unwrap_or(log)))?;
        }
    }
    sum.bytes = lw.finish().map_err(at(log))?.1;
    if let Some(w) = tw {
        w.finish().map_err(at(truth.unwrap_or(log)))?;
    }
    Ok(sum)
}
