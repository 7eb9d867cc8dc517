//! Simulator generation speed: one hour of the drive scenario at 200 Hz (720 000 samples) with
//! every effect on (replay/drive.toml repeated 12×, rate raised to 200 Hz).
//!
//! Run: `cargo bench --bench sim` (criterion reports the median time per hour of data; the
//! throughput line gives samples/s).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::sim::scenario::MotionConfig;
use imuprep::sim::{Scenario, Simulator};
use std::hint::black_box;

fn one_hour_drive_200hz() -> Scenario {
    let mut scn = Scenario::from_toml_str(include_str!("../replay/drive.toml")).unwrap();
    scn.sensor.sample_rate_hz = 200.0;
    if let MotionConfig::Drive { segments, .. } = &mut scn.motion {
        // The drive starts and ends at rest, so it can be chained: 12 × 300 s = 1 h.
        let one = segments.clone();
        for _ in 1..12 {
            segments.extend(one.iter().cloned());
        }
    }
    scn.validate().unwrap();
    scn
}

fn bench(c: &mut Criterion) {
    let scn = one_hour_drive_200hz();
    let n = Simulator::new(&scn, 1).unwrap().len();
    assert_eq!(n, 720_000);
    let mut g = c.benchmark_group("sim_drive_all_effects_1h_200hz");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("generate", |b| {
        b.iter(|| {
            let mut sim = Simulator::new(&scn, 1).unwrap();
            let mut acc = 0.0;
            while let Some(r) = sim.next_record() {
                acc += r.sample.gyro.x;
            }
            black_box(acc)
        })
    });
    g.bench_function("generate_and_format_truth_csv", |b| {
        b.iter(|| {
            let mut sim = Simulator::new(&scn, 1).unwrap();
            let mut out = std::io::sink();
            while let Some(r) = sim.next_record() {
                r.truth.write_csv_row(&mut out).unwrap();
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
