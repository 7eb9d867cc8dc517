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
//! * `arima_css_lm`: the ARIMA CSS fit (`fit_arima`, its hand Levenberg–Marquardt loop) against
//!   the same problem solved by the `levenberg-marquardt` crate (`support/arima_lm_crate.rs`),
//!   ARIMA(2,0,1) and ARIMA(3,1,2) on seeded series of 2 000 samples (the gross-error stage's
//!   `warmup_samples`) and 20 000 samples (an `imuprep fit` span), same start, same tolerances.
//!   Before timing, each case prints one `arima_css_lm:` line comparing the two results
//!   (CSS, parameters, iterations) and checks that both reach the same CSS; `start_only` times
//!   the Hannan–Rissanen start that both include.
//!
//! Run: `cargo bench --bench hand_vs_crate` (`-- arima` for the ARIMA group alone).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::io::csv::{ImportOptions, read_csv_report};
use imuprep::rng::Rng;
use rand::SeedableRng;
use rand::distr::StandardUniform;
use rand_chacha::{ChaCha8Rng, ChaCha20Rng};
use rand_distr::{Distribution, StandardNormal};
use std::hint::black_box;
use std::path::Path;

#[path = "support/arima_lm_crate.rs"]
mod arima_lm_crate;
use arima_lm_crate::fit_arima_crate;
use imuprep::model::arima::{CssOptions, fit_arima};

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

/// A seeded ARIMA(p, d, q) series (d ∈ {0, 1}): `ar`, `ma` the true coefficients, σ = 0.005
/// (rad/s, a gyro axis), intercept 0.004.
fn arima_series(ar: &[f64], d: usize, ma: &[f64], n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let (mut w, mut e) = (vec![0.0; ar.len()], vec![0.0; ma.len()]);
    let mut acc = 0.0;
    (0..n + 500)
        .map(|_| {
            let et = 0.005 * rng.normal();
            let wt = 0.004
                + ar.iter().zip(&w).map(|(a, v)| a * v).sum::<f64>()
                + et
                + ma.iter().zip(&e).map(|(m, v)| m * v).sum::<f64>();
            push_front(&mut w, wt);
            push_front(&mut e, et);
            acc += wt;
            if d == 0 { wt } else { acc }
        })
        .skip(500) // burn-in: the recursion forgets its zero start
        .collect()
}

/// Shift the lags by one, newest first (nothing for an empty lag list).
fn push_front(lags: &mut [f64], v: f64) {
    if !lags.is_empty() {
        lags.rotate_right(1);
        lags[0] = v;
    }
}

fn arima_css_lm(c: &mut Criterion) {
    let opts = CssOptions::default();
    let cases = [
        ("arima201", (2, 0, 1), vec![0.6, -0.2], vec![0.4]),
        ("arima312", (3, 1, 2), vec![0.4, -0.2, 0.1], vec![0.3, 0.2]),
    ];
    let mut g = c.benchmark_group("arima_css_lm");
    g.sample_size(20);
    for (name, (p, d, q), ar, ma) in &cases {
        for n in [2_000, 20_000] {
            let x = arima_series(ar, *d, ma, n, 7);
            let hand = fit_arima(&x, *p, *d, *q, &opts).unwrap();
            let krate = fit_arima_crate(&x, *p, *d, *q, &opts);
            let mut hb = vec![hand.constant];
            hb.extend_from_slice(&hand.ar);
            hb.extend_from_slice(&hand.ma);
            let dbeta = hb
                .iter()
                .zip(&krate.beta)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let rel_css = (krate.ssr - hand.ssr) / hand.ssr;
            eprintln!(
                "arima_css_lm: {name} n={n}: hand S={:.9e} iter={} converged={} | crate S={:.9e} \
                 residual evals={} jacobian evals={} ({:?}) | (S_crate−S_hand)/S_hand={rel_css:.2e} \
                 max|Δβ|={dbeta:.2e} | hand β={hb:.6?} crate β={:.6?}",
                hand.ssr,
                hand.iterations,
                hand.converged,
                krate.ssr,
                krate.residual_evals,
                krate.jacobian_evals,
                krate.termination,
                krate.beta
            );
            // Both minimise the same S from the same start: a relative gap above 1e-6 would mean
            // one of them stopped early or the crate problem is not the hand one.
            assert!(
                rel_css.abs() < 1e-6,
                "{name} n={n}: CSS differ by {rel_css:e}"
            );
            // The Hannan–Rissanen start alone (both fits include it): the rest is each LM loop.
            let start_only = CssOptions {
                max_iter: 0,
                ..opts
            };
            g.bench_function(format!("{name}_n{n}/start_only"), |b| {
                b.iter(|| {
                    fit_arima(black_box(&x), *p, *d, *q, &start_only)
                        .unwrap()
                        .ssr
                })
            });
            g.bench_function(format!("{name}_n{n}/hand"), |b| {
                b.iter(|| fit_arima(black_box(&x), *p, *d, *q, &opts).unwrap().ssr)
            });
            g.bench_function(format!("{name}_n{n}/crate_levenberg_marquardt"), |b| {
                b.iter(|| fit_arima_crate(black_box(&x), *p, *d, *q, &opts).ssr)
            });
        }
    }
    g.finish();
}

criterion_group!(benches, rng, csv_tokenise, arima_css_lm);
criterion_main!(benches);
