//! Shared by the simulator's integration tests (tests/sim_realism.rs, tests/sim_files.rs): the
//! committed scenarios and short scenarios run to records or truth bytes.
#![allow(dead_code)] // each test crate uses its own part

use imuprep::sim::{Scenario, SimRecord, Simulator};

pub const STATIC_BENCH: &str = include_str!("../../replay/static_bench.toml");
pub const DRIVE: &str = include_str!("../../replay/drive.toml");

pub fn static_scenario(duration_s: f64, extra: &str) -> Scenario {
    let text = format!(
        r#"
[sensor]
sample_rate_hz = 100.0
[motion]
kind = "static"
duration_s = {duration_s}
{extra}
"#
    );
    Scenario::from_toml_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

pub fn run(scn: &Scenario, seed: u64) -> Vec<SimRecord> {
    Simulator::new(scn, seed).unwrap().collect()
}

pub fn truth_bytes(scn: &Scenario, seed: u64) -> Vec<u8> {
    let mut sim = Simulator::new(scn, seed).unwrap();
    let mut out = sim.truth_header().into_bytes();
    out.push(b'\n');
    while let Some(r) = sim.next_record() {
        r.truth.write_csv_row(&mut out).unwrap();
    }
    out
}
