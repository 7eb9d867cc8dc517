//! The bias stage allocates nothing per sample: a counting global allocator (per thread) watches
//! `process` with every effect active, and through a warm-up, where the only allocations allowed
//! are at the sample on which the model is fitted.

#[path = "bias_common/mod.rs"]
mod common;
use common::*;
use imuprep::model::bias_model::{Effect, TemperatureTerm};
use imuprep::rng::Rng;
use imuprep::stage::bias::BiasStage;
use imuprep::stage::bias::settings::{BiasSettings, WarmupSettings};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;
thread_local! {
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}
// SAFETY: forwards to the system allocator; only counts on the calling thread.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(p, l, n) }
    }
}
#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocs() -> u64 {
    ALLOCS.with(|c| c.get())
}

fn samples(n: usize) -> Vec<imuprep::sample::Sample> {
    let mut road = Rng::new(1);
    let mut nz = Rng::new(2);
    (0..n)
        .map(|k| {
            let tr = drive_truth(k, &mut road);
            let g: [f64; 3] =
                std::array::from_fn(|a| tr.gyro[a] + 0.003 + GYRO_WHITE_SD * nz.normal());
            // A gap of 50 samples and a long gap of 500 exercise the gap paths too.
            let k2 = if k > 12_000 {
                k + 550
            } else if k > 11_000 {
                k + 50
            } else {
                k
            };
            sample(k2, g, tr.accel, Some(25.0 + k as f64 * 1e-3))
        })
        .collect()
}

#[test]
fn process_never_allocates_after_construction_except_at_the_warm_up_fit() {
    let all = |gyro: bool| {
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
            Effect::VibrationLine {
                freq_hz: 31.0,
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
    let mut model = drive_model([all(true), all(true), all(true)]);
    for name in ["ax", "ay", "az"] {
        model
            .channels
            .push(truth_model(name, &[0.9], 1e-6, 1e-3, all(false)));
    }
    let mut stage = BiasStage::new(settings_with(), Some(&model)).unwrap();
    let input = samples(20_000);
    let before = allocs();
    for s in &input {
        std::hint::black_box(stage.process(*s));
    }
    assert_eq!(allocs() - before, 0, "process allocated with a full model");

    // Warm-up: allocations only on the samples where a fit happened.
    let settings = BiasSettings {
        warmup: WarmupSettings {
            still_samples: 500,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut stage = BiasStage::new(&settings, None).unwrap();
    let fits = |st: &BiasStage| st.health().counters.warmup_fits;
    let mut allocating_samples = 0;
    for s in &input {
        // (health() is read outside the measured interval.)
        let f0 = fits(&stage);
        let a0 = allocs();
        std::hint::black_box(stage.process(*s));
        let a1 = allocs();
        let f1 = fits(&stage);
        if a1 != a0 {
            assert!(
                f1 > f0,
                "allocation on a sample without a warm-up fit (seq {})",
                s.seq
            );
            allocating_samples += 1;
        }
    }
    assert_eq!(fits(&stage), 3);
    // The warm-up model is measured in place (no fit, no buffer growth): nothing allocates, not
    // even the sample that completes the warm-up.
    assert_eq!(allocating_samples, 0);
}
