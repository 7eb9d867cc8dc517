//! FOS fit time on 36 000 samples, CP = 2, L = 10 (issue 5 target: <= 20 ms).
//!
//! Data: a seeded AR(2) coloured bias plus white noise, offset like a gyro bias.
//! `cargo bench --bench fos`
use criterion::{Criterion, criterion_group, criterion_main};
use imuprep::model::fos::{FosSettings, fos_search};
use imuprep::model::fos_candidates::CandidateSet;
use imuprep::model::fos_model::{FosModel, FosModelSpec};
use imuprep::model::{burg, covariance, yule_walker};
use imuprep::rng::Rng;
use std::hint::black_box;

fn series(n: usize) -> Vec<f64> {
    let mut rng = Rng::new(42);
    let (mut a, mut b) = (0.0, 0.0);
    (0..n)
        .map(|_| {
            let v = 1.6 * a - 0.7 * b + 0.01 * rng.normal();
            b = a;
            a = v;
            0.08 + v + 0.005 * rng.normal()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let y = series(36_000);
    let spec = FosModelSpec::paper(10, 2);
    let default = FosSettings::default();
    let (m, fit) = FosModel::fit(&y, &[], &spec, &default).unwrap();
    eprintln!(
        "default settings select {} terms: {:?}",
        m.terms.len(),
        fit.selected
    );
    c.bench_function("fos_fit_cp2_l10_36k_default", |bch| {
        bch.iter(|| FosModel::fit(black_box(&y), &[], &spec, &default).unwrap())
    });
    let all = FosSettings {
        max_terms: 66,
        min_mse_ratio: 0.0,
        noise_test: false,
    };
    c.bench_function("fos_fit_cp2_l10_36k_all66_terms", |bch| {
        bch.iter(|| FosModel::fit(black_box(&y), &[], &spec, &all).unwrap())
    });
    // The generic column path on the same problem (columns built inside the timing).
    c.bench_function("fos_columns_cp2_l10_36k_default", |bch| {
        bch.iter(|| {
            let cs = CandidateSet::build(black_box(&y), &[], &spec.families).unwrap();
            fos_search(cs.target(&y), &cs.columns, &default).unwrap()
        })
    });
    for p in [1usize, 10] {
        c.bench_function(&format!("burg_p{p}_36k"), |bch| {
            bch.iter(|| burg(black_box(&y), p).unwrap())
        });
        c.bench_function(&format!("yule_walker_p{p}_36k"), |bch| {
            bch.iter(|| yule_walker(black_box(&y), p).unwrap())
        });
        c.bench_function(&format!("covariance_p{p}_36k"), |bch| {
            bch.iter(|| covariance(black_box(&y), p).unwrap())
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = bench
}
criterion_main!(benches);
