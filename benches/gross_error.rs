//! Per-sample cost of the gross-error stage (target ≤ 50 ns per channel).
//! Run: cargo bench --bench gross_error
//!
//! Six channels, each with the largest online model ARIMA(3,0,2) (and a d = 1 variant), fed a
//! pre-generated block of 200 Hz samples (AR noise, 0.2 % spikes, some runs). Throughput is in
//! channel-samples, so criterion's time per element is the cost per channel per sample. The last
//! pair compares the default stage (two-sided confirmation, look-ahead 16) with the causal one,
//! both through `push`, as the pipeline calls them, and the default with `run_fit_side = 8`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::model::arima::{ArimaChannelModel, ArimaModelFile};
use imuprep::rng::Rng;
use imuprep::sample::{CHANNEL_NAMES, N_CHANNELS, Sample};
use imuprep::stage::Stage;
use imuprep::stage::gross_error::{GrossErrorSettings, GrossErrorStage, Replacement};
use std::hint::black_box;

fn models(d: usize) -> ArimaModelFile {
    ArimaModelFile {
        channels: CHANNEL_NAMES
            .iter()
            .map(|n| ArimaChannelModel {
                channel: n.to_string(),
                p: 3,
                d,
                q: 2,
                constant: 0.0,
                ar: vec![0.5, -0.1, 0.05],
                ma: vec![0.3, 0.1],
                sigma: 0.005,
                line_per_sample: None,
                diagnostics: None,
            })
            .collect(),
    }
}

fn samples(n: usize) -> Vec<Sample> {
    let mut rng = Rng::new(5);
    let mut v = [0.0f64; N_CHANNELS];
    (0..n)
        .map(|i| {
            let mut s = Sample::nth(i, 5_000_000);
            let ch: [f64; N_CHANNELS] = std::array::from_fn(|c| {
                v[c] = 0.5 * v[c] + 0.004 * rng.normal();
                let spike = if rng.uniform() < 0.002 { 0.1 } else { 0.0 };
                v[c] + spike + if c == 5 { 9.81 } else { 0.0 }
            });
            s.set_channels(&ch);
            s
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let block = samples(10_000);
    let tail_default = GrossErrorSettings::default().tail_window_samples;
    let mut g = c.benchmark_group("gross_error_per_channel_sample");
    g.throughput(Throughput::Elements((block.len() * N_CHANNELS) as u64));
    for (name, d, repl, tail) in [
        (
            "arima302_prediction",
            0,
            Replacement::Prediction,
            tail_default,
        ),
        // Baseline in the same run: the tail adaptation off.
        (
            "arima302_prediction_no_tail",
            0,
            Replacement::Prediction,
            0.0,
        ),
        (
            "arima312_prediction",
            1,
            Replacement::Prediction,
            tail_default,
        ),
        (
            "arima302_median",
            0,
            Replacement::MedianOfPredictions,
            tail_default,
        ),
    ] {
        let s = GrossErrorSettings {
            replacement: repl,
            tail_window_samples: tail,
            ..Default::default()
        };
        let mut st = GrossErrorStage::new(s, Some(&models(d))).unwrap();
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut acc = 0u32;
                for smp in &block {
                    acc ^= st.process(black_box(*smp)).flags;
                }
                black_box(acc)
            })
        });
    }
    // The default stage (confirmation, look-ahead 16) against the causal one in the same run:
    // both through `push` into a reused buffer, as the pipeline calls them.
    // And the default with runs interpolated on a longer baseline (`run_fit_side = 8`).
    for (name, lookahead, run_fit_side) in [
        ("arima302_push_causal", 0usize, 3usize),
        ("arima302_push_default_lookahead16", 16, 3),
        ("arima302_push_lookahead16_run_fit_side8", 16, 8),
    ] {
        let s = GrossErrorSettings {
            lookahead_samples: lookahead,
            run_fit_side,
            ..Default::default()
        };
        let mut st = GrossErrorStage::new(s, Some(&models(0))).unwrap();
        let mut out = Vec::with_capacity(64);
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut acc = 0u32;
                for smp in &block {
                    out.clear();
                    st.push(black_box(*smp), &mut out);
                    acc ^= out.first().map_or(0, |o| o.flags);
                }
                black_box(acc)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
