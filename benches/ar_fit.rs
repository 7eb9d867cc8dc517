//! Burg and Yule-Walker fit times on 360 000 samples (1 h at 100 Hz), side by side with the
//! implementation before the one-pass kernels (`*_before`, kept here verbatim as the in-run
//! baseline) and, run right after, with statsmodels on the bit-identical series:
//! `cargo bench --bench ar_fit && python3 tests/reference/ar_fit_timing.py`.
//!
//! Series (generated identically by the Python script from the same xoshiro256** stream):
//! `v[n] = 1.5 v[n-1] - 0.7 v[n-2] + (2 u - 1)`, `x[n] = 0.05 + v[n] + 0.5 (2 u' - 1)`, with u, u'
//! successive `Rng::new(20261124).uniform()` draws.
//!
//! Two groups: `ar_fit_360k` in wall time (criterion's default) and `ar_fit_360k_cpu` in the
//! calling thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), which a loaded shared machine inflates
//! far less; the Python script reports both clocks too.
use criterion::measurement::Measurement;
use criterion::{Criterion, criterion_group, criterion_main};
use imuprep::model::{ArFit, burg, burg_orders, yule_walker, yule_walker_orders};
use imuprep::rng::Rng;
use std::hint::black_box;
use std::time::Duration;

#[path = "support/thread_cpu.rs"]
mod thread_cpu;
use thread_cpu::ThreadCpu;

const N: usize = 360_000;

fn series(n: usize) -> Vec<f64> {
    let mut rng = Rng::new(20261124);
    let (mut a, mut b) = (0.0, 0.0);
    (0..n)
        .map(|_| {
            let v = 1.5 * a - 0.7 * b + (2.0 * rng.uniform() - 1.0);
            b = a;
            a = v;
            0.05 + v + 0.5 * (2.0 * rng.uniform() - 1.0)
        })
        .collect()
}

/// Burg as it was before the one-pass lattice: two sequential passes per order, one
/// accumulator per sum.
fn burg_before(x: &[f64], p: usize) -> ArFit {
    let mu = x.iter().sum::<f64>() / x.len() as f64;
    let mut f: Vec<f64> = x.iter().map(|v| v - mu).collect();
    let mut b = f.clone();
    let n = f.len();
    let mut phi: Vec<f64> = Vec::new();
    let mut energy = 0.0;
    for m in 1..=p {
        let (mut num, mut den) = (0.0, 0.0);
        for i in m..n {
            num += f[i] * b[i - 1];
            den += f[i] * f[i] + b[i - 1] * b[i - 1];
        }
        let k = 2.0 * num / den;
        energy = 0.0;
        for i in (m..n).rev() {
            let fi = f[i] - k * b[i - 1];
            let bi = b[i - 1] - k * f[i];
            f[i] = fi;
            b[i] = bi;
            energy += fi * fi + bi * bi;
        }
        let prev = phi.clone();
        for i in 1..m {
            phi[i - 1] = prev[i - 1] - k * prev[m - i - 1];
        }
        phi.push(k);
    }
    ArFit {
        coeffs: phi,
        noise_var: energy / (2.0 * (n - p) as f64),
        mean: mu,
    }
}

/// Yule-Walker as it was: one sequential dot product per lag, then Levinson-Durbin.
fn yule_walker_before(x: &[f64], p: usize) -> ArFit {
    let mu = x.iter().sum::<f64>() / x.len() as f64;
    let d: Vec<f64> = x.iter().map(|v| v - mu).collect();
    let n = d.len();
    let r: Vec<f64> = (0..=p)
        .map(|k| {
            d[k..]
                .iter()
                .zip(&d[..n - k])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / n as f64
        })
        .collect();
    let mut phi: Vec<f64> = Vec::new();
    let mut e = r[0];
    for m in 1..=p {
        let mut num = r[m];
        for i in 1..m {
            num -= phi[i - 1] * r[m - i];
        }
        let k = num / e;
        let prev = phi.clone();
        for i in 1..m {
            phi[i - 1] = prev[i - 1] - k * prev[m - i - 1];
        }
        phi.push(k);
        e *= 1.0 - k * k;
    }
    ArFit {
        coeffs: phi,
        noise_var: e,
        mean: mu,
    }
}

fn bench(c: &mut Criterion) {
    let x = series(N);
    eprintln!(
        "series: n = {N}, sum = {:.17e}, x[0] = {:.17e}, x[N-1] = {:.17e}",
        x.iter().sum::<f64>(),
        x[0],
        x[N - 1]
    );
    let fit = burg(&x, 10).unwrap();
    let old = burg_before(&x, 10);
    eprintln!("burg p=10: {:?} noise_var {:e}", fit.coeffs, fit.noise_var);
    eprintln!(
        "  max |phi - phi_before| = {:e}",
        fit.coeffs
            .iter()
            .zip(&old.coeffs)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    );
    let yw = yule_walker(&x, 10).unwrap();
    eprintln!(
        "yule_walker p=10: {:?} noise_var {:e}",
        yw.coeffs, yw.noise_var
    );
    group(c, "ar_fit_360k", &x);
    let mut cpu = Criterion::default()
        .with_measurement(ThreadCpu)
        .configure_from_args();
    group(&mut cpu, "ar_fit_360k_cpu", &x);
}

fn group<M: Measurement>(c: &mut Criterion<M>, name: &str, x: &[f64]) {
    let mut g = c.benchmark_group(name);
    g.sample_size(30).measurement_time(Duration::from_secs(3));
    for p in [10usize, 20] {
        g.bench_function(format!("burg_p{p}"), |b| {
            b.iter(|| burg(black_box(x), p).unwrap())
        });
        g.bench_function(format!("burg_p{p}_before"), |b| {
            b.iter(|| burg_before(black_box(x), p))
        });
        g.bench_function(format!("yule_walker_p{p}"), |b| {
            b.iter(|| yule_walker(black_box(x), p).unwrap())
        });
        g.bench_function(format!("yule_walker_p{p}_before"), |b| {
            b.iter(|| yule_walker_before(black_box(x), p))
        });
    }
    // Every order 1..=10: one pass vs one fit per order (what order selection did).
    g.bench_function("burg_orders_1_to_10", |b| {
        b.iter(|| burg_orders(black_box(x), 10).unwrap())
    });
    g.bench_function("burg_each_order_1_to_10_before", |b| {
        b.iter(|| {
            (1..=10)
                .map(|p| burg_before(black_box(x), p))
                .collect::<Vec<_>>()
        })
    });
    g.bench_function("yule_walker_orders_1_to_10", |b| {
        b.iter(|| yule_walker_orders(black_box(x), 10).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
