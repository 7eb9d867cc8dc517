//! The model-health monitor's cost per still sample (issue 17: it runs in the 1 kHz loop):
//! 100 000 still samples of six white channels at 100 Hz through `MonitorStage`, with the default
//! settings (offset and line tests) and with the whiteness test on, side by side.
//!
//! `cargo bench --bench monitor` — criterion prints the median time per 100 000 samples.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::rng::Rng;
use imuprep::sample::{Sample, flags};
use imuprep::stage::Stage;
use imuprep::stage::monitor::{MonitorSettings, MonitorStage};
use std::hint::black_box;

const N: usize = 100_000;

fn input() -> Vec<Sample> {
    let mut r = Rng::new(1);
    (0..N)
        .map(|i| {
            let mut s = Sample::nth(i, 10_000_000);
            s.set_channels(&[
                0.01 * r.normal(),
                0.01 * r.normal(),
                0.01 * r.normal(),
                0.04 * r.normal(),
                0.04 * r.normal(),
                0.04 * r.normal(),
            ]);
            s.flags |= flags::STILL;
            s
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let samples = input();
    let mut g = c.benchmark_group("monitor");
    g.throughput(Throughput::Elements(N as u64));
    let on = MonitorSettings {
        whiteness: true,
        ..Default::default()
    };
    for (name, settings) in [
        ("default_100k", MonitorSettings::default()),
        ("whiteness_on_100k", on),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut m = MonitorStage::new(settings.clone(), Some(100.0)).unwrap();
                let mut out = Vec::with_capacity(1);
                for s in &samples {
                    out.clear();
                    m.push(*s, &mut out);
                }
                black_box(m.status())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
