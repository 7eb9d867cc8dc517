//! Identification speed: ADF (AIC lag search) + AIC grid p ≤ 3, q ≤ 2 + CSS estimation +
//! diagnostics on 36 000 samples (3 min at 200 Hz). Target ≤ 1 s. And the stage's warm-up
//! window (2000 samples): identification against the line search run before it
//! (`stats::line::strongest_line`), on a window without and with a line.
//! Run: cargo bench --bench arima

use criterion::{Criterion, criterion_group, criterion_main};
use imuprep::model::arima::{IdentifySettings, identify};
use imuprep::rng::Rng;
use imuprep::stage::gross_error::identify::{hampel_cleaned, window_line};
use imuprep::stats::line::strongest_line;
use std::hint::black_box;

/// ARMA(1,1) noise (φ = 0.6, θ = 0.3, σ = 0.005 rad/s) around a bias: a gyro axis at 200 Hz.
fn gyro_like(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let (mut x, mut e_prev) = (0.0, 0.0);
    (0..n)
        .map(|_| {
            let e = 0.005 * rng.normal();
            x = 0.6 * x + e + 0.3 * e_prev;
            e_prev = e;
            0.01 + x
        })
        .collect()
}

/// A random walk with AR(1) increments (d = 1 path).
fn integrated(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let (mut w, mut acc) = (0.0, 0.0);
    (0..n)
        .map(|_| {
            w = 0.5 * w + 0.001 * rng.normal();
            acc += w;
            acc
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let s = IdentifySettings::default();
    let x = gyro_like(36_000, 1);
    let y = integrated(36_000, 2);
    let mut g = c.benchmark_group("identify_36000");
    g.sample_size(20);
    g.bench_function("stationary_arma11", |b| {
        b.iter(|| identify(black_box(&x), &s).unwrap())
    });
    g.bench_function("integrated_ari11", |b| {
        b.iter(|| identify(black_box(&y), &s).unwrap())
    });
    g.finish();

    let w = gyro_like(2000, 3);
    let with_line: Vec<f64> = w
        .iter()
        .enumerate()
        .map(|(i, v)| v + 0.02 * (std::f64::consts::TAU * 0.22 * i as f64).sin())
        .collect();
    let mut g = c.benchmark_group("warmup_window_2000");
    g.bench_function("identify", |b| {
        b.iter(|| identify(black_box(&w), &s).unwrap())
    });
    g.bench_function("line_search_none", |b| {
        b.iter(|| strongest_line(black_box(&w), 1e-3))
    });
    g.bench_function("line_search_line", |b| {
        b.iter(|| strongest_line(black_box(&with_line), 1e-3).unwrap())
    });
    g.finish();

    // A channel's search for a line after the warm-up (`stage::gross_error::line`), on the
    // stage's ring of 2048 samples without a line: its parts, the Hampel cleaning and the test.
    let r = gyro_like(2048, 4);
    let cleaned = hampel_cleaned(&r);
    let mut g = c.benchmark_group("line_search_ring_2048");
    g.bench_function("hampel_cleaned", |b| {
        b.iter(|| hampel_cleaned(black_box(&r)))
    });
    g.bench_function("window_line", |b| {
        b.iter(|| window_line(black_box(&cleaned)))
    });
    // White noise (a sensor at rest is nearly white): its spectrum has peaks everywhere, and
    // at the high bins a noise peak is large enough for `window_line`'s share bar, so the test
    // runs on the whole spectrum.
    let mut rng = Rng::new(5);
    let white: Vec<f64> = (0..2048).map(|_| 0.005 * rng.normal()).collect();
    g.bench_function("window_line_white", |b| {
        b.iter(|| window_line(black_box(&white)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
