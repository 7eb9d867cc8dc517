//! The measured k-sweep behind `GrossErrorSettings`' defaults.
//!
//! Runs the gross-error stage on long seeded synthetic gyro channels (static and drive, see
//! `report::gate_sweep`) for k = 3.0..=6.0 step 0.25, with and without the jump confirmation,
//! and prints false alarms per clean sample, precision, recall, F1 and RMSE.
//!
//! Run: cargo run --release --example k_sweep [-- N_SAMPLES]   (default 2 000 000 per scenario)

use imuprep::report::gate_sweep::{SyntheticSpec, default_k_grid, sweep_k, synthetic_stream};
use imuprep::stage::gross_error::GrossErrorSettings;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(2_000_000);
    let base = GrossErrorSettings::default();
    for (name, spec) in [
        ("static, AR(1) noise", SyntheticSpec::static_gyro(n, 42)),
        (
            "static, white noise",
            SyntheticSpec::static_white_gyro(n, 41),
        ),
        (
            "drive (warm-up sees manoeuvres)",
            SyntheticSpec::drive_gyro(n, 43),
        ),
        (
            "drive (warm-up at rest)",
            SyntheticSpec::drive_gyro_quiet_start(n, 44, 12.0),
        ),
    ] {
        let stream = synthetic_stream(&spec);
        let rows = match sweep_k(&stream, &base, &default_k_grid(), &[false, true]) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("sweep failed: {e}");
                std::process::exit(1);
            }
        };
        println!(
            "\n## {name}: n = {n}, spikes {} samples",
            stream.mask.iter().filter(|m| **m).count()
        );
        println!(
            "| confirm | k | false alarms / clean | FP | FN | precision | recall | recall 6–8σ | F1 | RMSE / RMSE_raw | level changes |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|");
        for r in rows {
            let s = r.score;
            println!(
                "| {} | {:.2} | {:.2e} | {} | {} | {:.5} | {:.5} | {:.4} | {:.5} | {:.4} | {} |",
                if r.confirm_jump { "jump" } else { "none" },
                r.k,
                s.false_alarm_rate,
                s.false_positives,
                s.false_negatives,
                s.precision,
                s.recall,
                r.recall_6_8_sigma,
                s.f1,
                s.rmse / r.rmse_uncorrected,
                r.level_changes
            );
        }
    }
}
