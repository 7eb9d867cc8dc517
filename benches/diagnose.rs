//! Whole-log diagnose speed (issue 17). `cargo bench --bench diagnose`
//!
//! * `diagnose_whole_adis16405_6ch`: the default `diagnose` analysis (lines, slow effects,
//!   wander, AR, deployment refit; no file output) of the real ADIS16405 bench, 2.78 h at 100 Hz
//!   × 6 channels (target: ≤ 5 s on one core). Reading the CSV is not included.
//! * `diagnose_paper_split_adis16405_ax`: the issue-6 loop (`--paper-split`, the default before
//!   issue 17) on one channel of the same data, as the baseline measured in the same run.
//!
//! Without ../shared both run on a seeded synthetic series of the same size (white noise, a
//! Gauss-Markov wander and a 0.57 Hz line), and say so.
use criterion::{Criterion, criterion_group, criterion_main};
use imuprep::analysis::diagnose::paper_split::{ChannelInput, DiagnoseSettings, diagnose_channel};
use imuprep::analysis::diagnose::whole::{WholeSettings, diagnose_whole};
use imuprep::io::csv::{ImportOptions, read_csv};
use imuprep::report::diagnose::exogenous;
use imuprep::rng::Rng;
use imuprep::sample::{CHANNEL_NAMES, Sample};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

fn synthetic(n: usize) -> Vec<Sample> {
    let mut rng = Rng::new(17);
    let mut gm = [0.0f64; 6];
    (0..n)
        .map(|i| {
            let mut s = Sample {
                temp_c: Some(25.0),
                ..Sample::nth(i, 10_000_000)
            };
            let line = 0.009 * (2.0 * std::f64::consts::PI * 0.5667 * i as f64 / 100.0).sin();
            let v: [f64; 6] = std::array::from_fn(|c| {
                gm[c] = 0.99995 * gm[c] + 1e-4 * rng.normal();
                gm[c] + 0.006 * rng.normal() + if c >= 3 { line } else { 0.0 }
            });
            s.set_channels(&v);
            s
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/real/adis16405_static/adis_16405_imu1.csv.gz");
    let (what, samples) = if p.exists() {
        (
            "adis16405",
            read_csv(&p, &ImportOptions::default()).unwrap().1,
        )
    } else {
        eprintln!(
            "SKIPPED: {} not found: synthetic series instead",
            p.display()
        );
        ("synthetic", synthetic(1_000_000))
    };
    let rate = 100.0;
    let series: Vec<Vec<f64>> = (0..6)
        .map(|c| samples.iter().map(|s| s.channel(c)).collect())
        .collect();
    let temp: Option<Vec<f64>> = samples.iter().map(|s| s.temp_c).collect();
    let others: Vec<Vec<(String, &[f64])>> = (0..6)
        .map(|c| {
            (0..6)
                .filter(|j| *j != c)
                .map(|j| (CHANNEL_NAMES[j].to_string(), series[j].as_slice()))
                .collect()
        })
        .collect();
    let inputs: Vec<ChannelInput> = (0..6)
        .map(|c| ChannelInput {
            name: CHANNEL_NAMES[c],
            values: &series[c],
            rate_hz: rate,
            exogenous: exogenous(&series, temp.as_deref(), &others[c], c),
        })
        .collect();
    let s = WholeSettings::default();
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function(format!("diagnose_whole_{what}_6ch"), |b| {
        b.iter(|| {
            for i in &inputs {
                black_box(diagnose_whole(i, &s, &mut |_| {}).unwrap());
            }
        })
    });
    g.bench_function(format!("diagnose_paper_split_{what}_ax"), |b| {
        b.iter(|| black_box(diagnose_channel(&inputs[3], &DiagnoseSettings::default()).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
