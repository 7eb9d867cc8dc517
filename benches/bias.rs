//! Speed of the bias stage per sample (6 channels), on a drive with stops (still and moving
//! samples mixed as in a real drive). Report: time per batch of 10 000 samples / 10 000 = per
//! sample; / 6 = per channel. Run: `cargo bench --bench bias`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::model::bias_model::{ArOf, BiasModelFile, ChannelBiasModel, Effect, TemperatureTerm};
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use imuprep::stage::bias::BiasStage;
use imuprep::stage::bias::settings::BiasSettings;
use std::hint::black_box;

const N: usize = 10_000;
const G: f64 = 9.80665;

/// 30-s cycles: 8 s still, 22 s moving with a 0.3 rad/s turn and road vibration.
fn input() -> Vec<Sample> {
    let mut r = Rng::new(1);
    (0..N)
        .map(|k| {
            let t = k as f64 / 100.0;
            let moving = t % 30.0 >= 8.0;
            let m = if moving { 1.0 } else { 0.0 };
            let mut s = Sample {
                temp_c: Some(25.0),
                ..Sample::nth(k, 10_000_000)
            };
            s.set_channels(&[
                0.002 + 0.00175 * r.normal() + m * 0.01 * r.normal(),
                -0.001 + 0.00175 * r.normal() + m * 0.01 * r.normal(),
                0.003 + 0.00175 * r.normal() + m * 0.3,
                0.04 * r.normal() + m * 0.3 * r.normal(),
                0.04 * r.normal() + m * 3.0,
                G + 0.04 * r.normal() + m * 0.3 * r.normal(),
            ]);
            s
        })
        .collect()
}

fn model(phi: &[f64], effects: bool) -> BiasModelFile {
    let eff = |gyro: bool| {
        if !effects {
            return vec![];
        }
        let mut v = vec![
            Effect::Temperature(TemperatureTerm {
                t0_c: 25.0,
                c1_per_c: 1e-4,
                c2_per_c2: 1e-6,
                lag_s: 20.0,
            }),
            Effect::VibrationLine {
                freq_hz: 17.3,
                amplitude: 0.01,
                phase_rad: 0.0,
            },
        ];
        if gyro {
            v.push(Effect::Step {
                t_s: 1.0,
                size: 0.004,
            });
            v.push(Effect::GSensitivity {
                coeffs_per_m_s2: [1e-4, 0.0, 2e-4],
            });
            v.push(Effect::RateRandomWalk { q_per_s: 1e-10 });
        }
        v
    };
    let q = 1e-12;
    BiasModelFile {
        channels: ["gx", "gy", "gz", "ax", "ay", "az"]
            .iter()
            .enumerate()
            .map(|(c, name)| ChannelBiasModel {
                channel: name.to_string(),
                method: "truth".into(),
                sample_rate_hz: 100.0,
                mean: 0.0,
                ar: phi.to_vec(),
                innovation_var: q,
                white_noise_var: 3e-6,
                ar_of: ArOf::Bias,
                effects: eff(c < 3),
            })
            .collect(),
    }
}

fn bench(c: &mut Criterion) {
    let samples = input();
    let mut group = c.benchmark_group("bias_stage");
    group.throughput(Throughput::Elements(N as u64));
    let cases: [(&str, BiasModelFile); 3] = [
        (
            "ar2_no_effects",
            model(&[0.99995 + 0.999, -0.99995 * 0.999], false),
        ),
        ("ar4_no_effects", model(&[1.2, -0.1, -0.2, 0.09], false)),
        (
            "ar2_all_effects",
            model(&[0.99995 + 0.999, -0.99995 * 0.999], true),
        ),
    ];
    for (name, m) in cases {
        let mut stage = BiasStage::new(BiasSettings::default(), Some(&m)).unwrap();
        group.bench_function(name, |b| {
            b.iter(|| {
                for s in &samples {
                    black_box(stage.process(black_box(*s)));
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
