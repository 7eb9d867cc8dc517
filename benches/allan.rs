//! Overlapping Allan deviation of 8.64 M samples (one day at 100 Hz), all octave taus
//! (issue 5 target: <= 1 s). `cargo bench --bench allan`
use criterion::{Criterion, criterion_group, criterion_main};
use imuprep::analysis::allan::overlapping_adev;
use imuprep::rng::Rng;
use std::hint::black_box;

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
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
