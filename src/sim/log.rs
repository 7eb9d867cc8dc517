//! Writing a simulation as a replay log (+ truth sidecar): the glue behind `imuprep simulate`.

use super::{Emission, Scenario, SimError, Simulator, truth::TruthWriter};
use crate::frame::Descriptor;
use crate::io::log::LogWriter;
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

/// The descriptor a simulated sensor announces.
pub fn descriptor(sim: &Simulator) -> Descriptor {
    let i = sim.sensor_info();
    Descriptor {
        sample_rate_hz: i.sample_rate_hz,
        gyro_range_rad_s: i.gyro_range_rad_s as f32,
        accel_range_m_s2: i.accel_range_m_s2 as f32,
        axes: crate::frame::AxisConvention::Frd,
        device_id: i.device_id,
        absent: 0,
    }
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

/// Seed to use: the command line's, else the scenario's, else 0.
pub fn effective_seed(scn: &Scenario, cli: Option<u64>) -> u64 {
    cli.or(scn.seed).unwrap_or(0)
}
