//! What a simulation announces as a log: its sensor descriptor and its seed. The log itself is
//! written by `crate::io::sim_log` (the log writer lives on the I/O floor).

use super::{Scenario, Simulator};
use crate::frame::Descriptor;

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

/// Seed to use: the command line's, else the scenario's, else 0.
pub fn effective_seed(scn: &Scenario, cli: Option<u64>) -> u64 {
    cli.or(scn.seed).unwrap_or(0)
}
