//! Allan analysis speed. `cargo bench --bench allan`
//!
//! * `allan_oadev_8_64M_octave`: overlapping ADEV of 8.64 M samples (one day at 100 Hz), all
//!   octave taus (issue 5 target: <= 1 s) — also the baseline for the rows below.
//! * `allan_report_2_78h_6ch_synthetic`: `imuprep allan`'s analysis of 2.78 h at 100 Hz
//!   (10⁶ samples) × 6 channels — ADEV, Greenhall–Riley EDFs, chi-squared bands, the IEEE-952
//!   term fit — on a seeded N + flicker + random-walk series (issue 15 target: <= 1 s).
//! * `allan_report_adis16405_6ch` and `allan_outputs_adis16405`: the same on the real
//!   ADIS16405 bench (2.78 h, 100 Hz; skipped without ../shared), and then everything the
//!   command writes (report text and JSON, SVG plot, Kalibr / GNSS_IMU / bias-model exports)
//!   rendered to memory. Reading the replay log is not included.
use criterion::{Criterion, criterion_group, criterion_main};
use imuprep::analysis::allan::export::{bias_model, gnss_imu_config, kalibr_yaml};
use imuprep::analysis::allan::overlapping_adev;
use imuprep::analysis::allan::plot::allan_svg;
use imuprep::analysis::allan::report::allan_report;
use imuprep::analysis::allan::terms::FitSettings;
use imuprep::io::csv::{ImportOptions, read_csv};
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use std::hint::black_box;
use std::path::PathBuf;

fn synthetic_samples(n: usize) -> Vec<Sample> {
    let mut rng = Rng::new(11);
    let mut walk = [0.0f64; 6];
    let mut slow = [0.0f64; 6];
    (0..n)
        .map(|i| {
            let mut s = Sample::nth(i, 10_000_000);
            let v: [f64; 6] = std::array::from_fn(|c| {
                walk[c] += 1e-6 * rng.normal();
                // a 100-s Gauss-Markov stands in for the flicker floor
                slow[c] = 0.9999 * slow[c] + 1e-5 * rng.normal();
                walk[c] + slow[c] + 0.003 * rng.normal()
            });
            s.set_channels(&v);
            s
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut rng = Rng::new(7);
    let mut b = 0.0;
    let y: Vec<f64> = (0..8_640_000)
        .map(|_| {
            b += 1e-6 * rng.normal();
            0.01 + b + 0.003 * rng.normal()
        })
        .collect();
    c.bench_function("allan_oadev_8_64M_octave", |bch| {
        bch.iter(|| overlapping_adev(black_box(&y), 100.0))
    });
    drop(y);

    let all: Vec<usize> = (0..6).collect();
    let settings = FitSettings::default();
    let samples = synthetic_samples(1_000_000);
    c.bench_function("allan_report_2_78h_6ch_synthetic", |bch| {
        bch.iter(|| allan_report("bench", black_box(&samples), 100.0, &all, &settings).unwrap())
    });
    drop(samples);

    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/real/adis16405_static/adis_16405_imu1.csv.gz");
    if !p.exists() {
        eprintln!("SKIPPED: {} not found: no real-data rows", p.display());
        return;
    }
    let (desc, samples) = read_csv(&p, &ImportOptions::default()).unwrap();
    let rate = desc.sample_rate_hz;
    c.bench_function("allan_report_adis16405_6ch", |bch| {
        bch.iter(|| allan_report("adis", black_box(&samples), rate, &all, &settings).unwrap())
    });
    let report = allan_report("adis", &samples, rate, &all, &settings).unwrap();
    c.bench_function("allan_outputs_adis16405", |bch| {
        bch.iter(|| {
            let r = black_box(&report);
            (
                r.to_string(),
                serde_json::to_string_pretty(r).unwrap(),
                allan_svg(r).unwrap(),
                kalibr_yaml(r),
                gnss_imu_config(r),
                bias_model(r).0.to_toml_string().unwrap(),
            )
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
