//! Issue 4's real-drive target — flag rate ≤ 1e-4 of the channel-samples after warm-up — on the
//! two recorded drives in `../shared/data/real` (never copied into the repo; skipped with a
//! message when absent). There are no labels: every flagged event is classified and listed by
//! `cargo run --release --example flag_review -- LOG [KEY=VALUE...] --list` (see
//! `docs/flag_review_real.md`).
//!
//! Two configurations, measured on the same input:
//! - the default, causal stage: the target is missed (measured 2026-11-23: 6.4e-4 on
//!   rtklibexplorer, 4.9e-3 on comma2k19), asserted only to stay what the look-ahead improves on;
//! - with the look-ahead, `lookahead_samples = 11` (max_run + 1: every event seen to its end):
//!   measured 9.5e-5 (30 channel-samples of 317 160) and 7.8e-5 (2 of 25 536), within the
//!   target. comma2k19's 1e-4 is 2.5 channel-samples: its two left are the impulses the
//!   independent classifier calls genuine glitches.

mod common;

use imuprep::io::csv::{ImportOptions, read_csv};
use imuprep::sample::{N_CHANNELS, Sample, flags};
use imuprep::stage::gross_error::{GrossErrorSettings, GrossErrorStage};
use imuprep::stage::run_through;

/// Replaced channel-samples after the warm-up, as a share of them.
fn flag_rate(samples: &[Sample], settings: GrossErrorSettings) -> f64 {
    let from = settings.warmup_samples;
    let mut st = GrossErrorStage::new(settings, None).unwrap();
    let out = run_through(&mut st, samples);
    let n: u32 = out[from..]
        .iter()
        .map(|s| (s.flags & flags::REPLACED_ANY).count_ones())
        .sum();
    f64::from(n) / ((out.len() - from) * N_CHANNELS) as f64
}

/// (causal, look-ahead) flag rates of one recording, or None when it is absent.
fn rates(rel: &str) -> Option<(f64, f64)> {
    let path = common::real_data(rel)?;
    let (_, samples) = read_csv(&path, &ImportOptions::default()).unwrap();
    let causal = flag_rate(&samples, GrossErrorSettings::default());
    let look_ahead = GrossErrorSettings {
        lookahead_samples: 11,
        ..GrossErrorSettings::default()
    };
    let ahead = flag_rate(&samples, look_ahead);
    eprintln!("{rel}: flag rate {causal:.2e} causal (default), {ahead:.2e} with the look-ahead");
    Some((causal, ahead))
}

/// The target with the look-ahead; the causal rate for contrast.
fn assert_target(rel: &str) {
    let Some((causal, ahead)) = rates(rel) else {
        return;
    };
    assert!(ahead <= 1e-4, "look-ahead flag rate {ahead:.2e}");
    assert!(ahead < causal / 3.0, "{ahead:.2e} vs {causal:.2e}");
}

#[test]
fn rtklibexplorer_drive_meets_the_flag_rate_target_with_the_look_ahead() {
    assert_target("rtklibexplorer_drive_walk/drive_0708_imu.csv");
}

#[test]
fn comma2k19_meets_the_flag_rate_target_with_the_look_ahead() {
    assert_target("comma2k19_car_segment/imu.csv");
}
