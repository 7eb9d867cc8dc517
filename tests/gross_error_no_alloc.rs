//! The per-sample path of the gross-error stage does not touch the heap: a counting global
//! allocator (this test binary only) sees zero allocations while the stage processes spikes,
//! runs, level changes, NaN, saturation, and short and long gaps on all six channels. The one
//! allowed allocation — identification at the end of warm-up — happens before counting starts.
//! The same holds with the look-ahead (`lookahead_samples`), whose held samples and context ring
//! are reserved at construction, and with the two-sided confirmation (fixed-size arrays).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use imuprep::rng::Rng;
use imuprep::sample::{Sample, flags};
use imuprep::stage::Stage;
use imuprep::stage::gross_error::{GrossErrorSettings, GrossErrorStage, Replacement};

struct Counting;

thread_local! {
    // Const-initialised, so touching them never allocates.
    static ON: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

fn note() {
    if ON.with(|c| c.get()) {
        COUNT.with(|c| c.set(c.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(p, l, n) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

fn run(replacement: Replacement, lookahead_samples: usize) {
    let s = GrossErrorSettings {
        warmup_samples: 600,
        replacement,
        lookahead_samples,
        ..Default::default()
    };
    let mut st = GrossErrorStage::new(s, None).unwrap();
    let mut rng = Rng::new(99);
    let mut seq = 0u32;
    let make = |rng: &mut Rng, seq: u32, scale: f64| {
        let mut smp = Sample {
            seq,
            t_ns: seq as u64 * 5_000_000,
            ..Sample::default()
        };
        let v: [f64; 6] = std::array::from_fn(|c| {
            let base = if c == 5 { 9.81 } else { 0.0 };
            base + scale * 0.01 * rng.normal()
        });
        smp.set_channels(&v);
        smp
    };
    // Warm-up (identification allocates here, once per channel): the 600-sample window, then
    // `identify_defer_s` = 0.5 s (100 samples at 200 Hz) and up to 5 samples of stagger before
    // the last channel takes its model over; 800 leaves a margin.
    for _ in 0..800 {
        st.process(make(&mut rng, seq, 1.0));
        seq += 1;
    }
    // Output buffer of the look-ahead path, allocated before counting (the pipeline reuses its
    // buffers the same way).
    let mut out_buf: Vec<Sample> = Vec::with_capacity(64);
    ON.with(|c| c.set(true));
    let mut replaced = 0u64;
    for i in 0..20_000u32 {
        let mut smp = make(&mut rng, seq, 1.0);
        match i % 997 {
            10 => smp.gyro.z += 1.0,             // spike
            20..=45 => smp.accel.x += 2.0,       // long run → level change
            60 => smp.gyro.x = f64::NAN,         // non-finite
            70 => smp.flags |= flags::sat_ch(4), // saturated
            _ => {}
        }
        if i % 4001 == 100 {
            seq += 2; // short gap: bridged
            smp.seq = seq;
            smp.flags |= flags::GAP;
        }
        if i % 7001 == 200 {
            seq += 500; // long gap: reset
            smp.seq = seq;
            smp.flags |= flags::GAP;
        }
        if lookahead_samples == 0 {
            replaced += st.process(smp).has(flags::REPLACED) as u64;
        } else {
            out_buf.clear();
            st.push(smp, &mut out_buf);
            replaced += out_buf.iter().filter(|s| s.has(flags::REPLACED)).count() as u64;
        }
        seq += 1;
    }
    ON.with(|c| c.set(false));
    let n = COUNT.with(|c| c.replace(0));
    assert!(replaced > 0, "the run must exercise replacement");
    assert_eq!(
        n, 0,
        "{n} heap allocations on the per-sample path ({replacement:?}, look-ahead {lookahead_samples})"
    );
}

#[test]
fn per_sample_processing_does_not_allocate() {
    run(Replacement::Prediction, 0);
    run(Replacement::MedianOfPredictions, 0);
    // With the look-ahead: the held samples and the context ring are reserved at construction.
    run(Replacement::Prediction, 16);
    run(Replacement::Interpolation, 16);
}
