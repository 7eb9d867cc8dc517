//! Two pieces kept hand-written although a well-kept crate does the job, measured against that
//! crate (docs/architecture.md, "Written by hand", quotes the medians):
//!
//! * `rng`: one million standard-normal draws from the simulator's generator
//!   (`imuprep::rng::Rng`: xoshiro256** + polar Box–Muller) against `rand_chacha`'s ChaCha8 and
//!   ChaCha20 with `rand_distr::StandardNormal` (ziggurat), and one million uniforms.
//! * `csv`: the cells of a real 10-minute MPU-6050 recording (`../shared/data/real`, 5.5 MB,
//!   8 columns) split and parsed to `f64` by the importer's tokeniser (`str::split(',')`) against
//!   the `csv` crate (`StringRecord`, as the importer reads since this bench), and the whole import
//!   (`read_csv_report`) for the share tokenising takes of it. Skipped, with a `SKIPPED:` line,
//!   when the recording is absent.
//!
//! Run: `cargo bench --bench hand_vs_crate`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::io::csv::{ImportOptions, read_csv_report};
use imuprep::rng::Rng;
use rand::SeedableRng;
use rand::distr::StandardUniform;
use rand_chacha::{ChaCha8Rng, ChaCha20Rng};
use rand_distr::{Distribution, StandardNormal};
use std::hint::black_box;
use std::path::Path;

const DRAWS: usize = 1_000_000;
const CSV: &str = "../shared/data/real/mpu6050_static_10min_temp/mpu6050_static.csv";

fn rng(c: &mut Criterion) {
    let mut g = c.benchmark_group("rng_1m_draws");
    g.sample_size(20);
    g.throughput(Throughput::Elements(DRAWS as u64));
    g.bench_function("normal/hand_xoshiro_polar", |b| {
        b.iter(|| {
            let mut r = Rng::new(1);
            (0..DRAWS).fold(0.0, |a, _| a + r.normal())
        })
    });
    g.bench_function("normal/chacha8_ziggurat", |b| {
        b.iter(|| {
            let mut r = ChaCha8Rng::seed_from_u64(1);
            (0..DRAWS).fold(0.0, |a, _| {
                a + <StandardNormal as Distribution<f64>>::sample(&StandardNormal, &mut r)
            })
        })
    });
    g.bench_function("normal/chacha20_ziggurat", |b| {
        b.iter(|| {
            let mut r = ChaCha20Rng::seed_from_u64(1);
            (0..DRAWS).fold(0.0, |a, _| {
                a + <StandardNormal as Distribution<f64>>::sample(&StandardNormal, &mut r)
            })
        })
    });
    g.bench_function("uniform/hand_xoshiro", |b| {
        b.iter(|| {
            let mut r = Rng::new(1);
            (0..DRAWS).fold(0.0, |a, _| a + r.uniform())
        })
    });
    g.bench_function("uniform/chacha8", |b| {
        b.iter(|| {
            let mut r = ChaCha8Rng::seed_from_u64(1);
            (0..DRAWS).fold(0.0, |a, _| {
                a + <StandardUniform as Distribution<f64>>::sample(&StandardUniform, &mut r)
            })
        })
    });
    g.finish();
}

/// Sum of every cell after the header, by the importer's tokeniser.
fn cells_hand(text: &str) -> f64 {
    let mut sum = 0.0;
    for line in text.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        for c in &cells {
            sum += c.trim().parse::<f64>().unwrap_or(0.0);
        }
    }
    sum
}

/// The same sum through the `csv` crate's `StringRecord`.
fn cells_csv_string(text: &str) -> f64 {
    let mut rd = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let mut rec = csv::StringRecord::new();
    let mut sum = 0.0;
    while rd.read_record(&mut rec).unwrap() {
        for c in rec.iter() {
            sum += c.trim().parse::<f64>().unwrap_or(0.0);
        }
    }
    sum
}

fn csv_tokenise(c: &mut Criterion) {
    let path = Path::new(CSV);
    let Ok(text) = std::fs::read_to_string(path) else {
        eprintln!("SKIPPED: {CSV} absent: no CSV tokeniser benchmark");
        return;
    };
    let rows = text.lines().count() - 1;
    // The two tokenisers must read the same numbers (the file has no quoted cells).
    let want = cells_hand(&text);
    assert_eq!(cells_csv_string(&text), want);
    let mut g = c.benchmark_group("csv_mpu6050_static_5.5MB");
    g.sample_size(20);
    g.throughput(Throughput::Elements(rows as u64));
    g.bench_function("tokenise_parse/hand_split", |b| {
        b.iter(|| cells_hand(black_box(&text)))
    });
    g.bench_function("tokenise_parse/csv_string_record", |b| {
        b.iter(|| cells_csv_string(black_box(&text)))
    });
    g.bench_function("whole_import/read_csv_report", |b| {
        b.iter(|| {
            read_csv_report(path, &ImportOptions::default())
                .unwrap()
                .1
                .len()
        })
    });
    g.finish();
}

criterion_group!(benches, rng, csv_tokenise);
criterion_main!(benches);
