//! The gross-error stage's look-ahead (`lookahead_samples`): the output lags by L samples, every
//! sample comes out once and in order, and an event that proves to be motion within the lag has
//! its replaced samples restored to the raw input (flag `REVISED`) — a level change, a smooth
//! event, a shock on three axes — while spikes, runs of independent amplitudes, a corrupted
//! whole frame and events holding a NaN stay replaced. The gate's decisions do not depend on L:
//! the output differs from the causal stage's only on the restored samples.
//!
//! Every stream is seeded white noise of σ = 0.01 on all six channels, with a white-noise model
//! of that σ given (no warm-up); events are placed 300 samples apart so the trackers settle.

mod common;

use imuprep::model::arima::ArimaModelFile;
use imuprep::rng::Rng;
use imuprep::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use imuprep::stage::gross_error::{GrossErrorSettings, GrossErrorStage};
use imuprep::stage::{Pipeline, Stage, run_through};

const SIGMA: f64 = 0.01;
const GX: usize = 0;
const GY: usize = 1;
const GZ: usize = 2;
const AZ: usize = 5;

fn models() -> ArimaModelFile {
    ArimaModelFile {
        channels: CHANNEL_NAMES
            .iter()
            .map(|c| common::white_arima(c, SIGMA))
            .collect(),
    }
}

fn stage(lookahead: usize) -> GrossErrorStage {
    let s = GrossErrorSettings {
        lookahead_samples: lookahead,
        ..GrossErrorSettings::default()
    };
    GrossErrorStage::new(s, Some(&models())).unwrap()
}

/// Where each kind of event sits in the stream, and its length.
struct Layout {
    spike: usize,
    run: (usize, usize),
    smooth: (usize, usize),
    shock: usize,
    frame: usize,
    with_nan: (usize, usize),
    step: usize,
}

/// Noise with one event of each kind (values in σ, added to channel `c`).
fn stream() -> (Vec<Sample>, Layout) {
    let n = 3000;
    let mut rng = Rng::new(4242);
    let mut x: Vec<Sample> = (0..n)
        .map(|i| {
            let mut s = Sample {
                seq: i as u32,
                t_ns: i as u64 * 5_000_000,
                ..Sample::default()
            };
            for c in 0..N_CHANNELS {
                s.set_channel(c, SIGMA * rng.normal());
            }
            s
        })
        .collect();
    let mut put = |at: usize, c: usize, v: &[f64]| {
        for (j, a) in v.iter().enumerate() {
            x[at + j].set_channel(c, a * SIGMA);
        }
    };
    // A spike, and a run of independent amplitudes (as the simulator's runs): gross errors.
    put(300, GZ, &[20.0]);
    put(600, GZ, &[12.0, 25.0, 8.0, 19.0, 30.0]);
    // Sharp onset, then a smooth decay (steps ≤ 1.5σ, far below jump_k σ_Δ): a knock the
    // vehicle really felt. Its first sample is 9σ off the forecast, above release_k = 7, so
    // the causal release rule does not apply: only the smoothness test can revise it.
    let smooth = [9.0, 9.5, 9.8, 9.5, 8.5, 7.0, 5.5, 4.0, 3.0];
    put(900, GZ, &smooth);
    // A shock on three axes: gx and az at 1200, gy from 1201 for two samples.
    put(1200, GX, &[15.0]);
    put(1200, AZ, &[10.0]);
    put(1201, GY, &[-12.0, -14.0]);
    // A corrupted whole frame: every channel off at one sample.
    for c in 0..N_CHANNELS {
        put(1500, c, &[20.0]);
    }
    // The smooth event again, with a NaN inside.
    put(1800, GZ, &smooth);
    x[1803].set_channel(GZ, f64::NAN);
    // A real step that lasts: a level change.
    for s in &mut x[2100..] {
        let v = s.channel(GZ) + 50.0 * SIGMA;
        s.set_channel(GZ, v);
    }
    let layout = Layout {
        spike: 300,
        run: (600, 5),
        smooth: (900, smooth.len()),
        shock: 1200,
        frame: 1500,
        with_nan: (1800, smooth.len()),
        step: 2100,
    };
    (x, layout)
}

fn replaced(out: &[Sample], i: usize, c: usize) -> bool {
    out[i].flags & flags::replaced_ch(c) != 0
}

fn replaced_in(out: &[Sample], from: usize, len: usize, c: usize) -> usize {
    (from..from + len).filter(|&i| replaced(out, i, c)).count()
}

#[test]
fn the_look_ahead_restores_motion_and_keeps_gross_errors_replaced() {
    let (x, at) = stream();
    let causal = run_through(&mut stage(0), &x);
    let mut st = stage(11);
    let ahead = run_through(&mut st, &x);
    assert_eq!(ahead.len(), x.len());

    // Without a look-ahead every event is replaced, the smooth one included (the causal gate
    // cannot know how it continues); the step for max_run = 10 samples.
    assert!(replaced(&causal, at.spike, GZ));
    assert_eq!(replaced_in(&causal, at.run.0, at.run.1, GZ), at.run.1);
    let smooth_causal = replaced_in(&causal, at.smooth.0, at.smooth.1, GZ);
    assert!(smooth_causal >= 5, "{smooth_causal}");
    for c in [GX, AZ] {
        assert!(replaced(&causal, at.shock, c));
    }
    assert!(replaced(&causal, at.shock + 1, GY));
    assert_eq!(replaced_in(&causal, at.step, 10, GZ), 10);

    // With it: gross errors stay replaced...
    assert!(replaced(&ahead, at.spike, GZ));
    assert_eq!(replaced_in(&ahead, at.run.0, at.run.1, GZ), at.run.1);
    for c in 0..N_CHANNELS {
        assert!(replaced(&ahead, at.frame, c), "frame glitch, channel {c}");
    }
    let nan_event = replaced_in(&ahead, at.with_nan.0, at.with_nan.1, GZ);
    assert_eq!(
        nan_event,
        replaced_in(&causal, at.with_nan.0, at.with_nan.1, GZ),
        "an event holding a NaN is not revised"
    );
    assert!(ahead[at.with_nan.0 + 3].channel(GZ).is_finite());
    // ...and motion is restored.
    assert_eq!(replaced_in(&ahead, at.smooth.0, at.smooth.1, GZ), 0);
    for c in [GX, AZ] {
        assert!(!replaced(&ahead, at.shock, c), "shock, channel {c}");
    }
    assert_eq!(replaced_in(&ahead, at.shock + 1, 2, GY), 0);
    assert_eq!(replaced_in(&ahead, at.step, 11, GZ), 0);
    assert!(ahead[at.step + 10].has(flags::LEVEL_CHANGE));

    // The gate decided the same either way: the outputs differ only where the look-ahead
    // restored a channel, and there the output is the raw input, flagged REVISED.
    let (mut restored, mut elsewhere) = (0u64, 0usize);
    let at_event = |i: usize| {
        (at.smooth.0..at.smooth.0 + at.smooth.1).contains(&i)
            || (at.shock..at.shock + 3).contains(&i)
            || (at.step..at.step + 10).contains(&i)
    };
    for i in 0..x.len() {
        assert_eq!(ahead[i].seq, x[i].seq, "order");
        for c in 0..N_CHANNELS {
            let (a, b) = (ahead[i].channel(c), causal[i].channel(c));
            if replaced(&causal, i, c) && !replaced(&ahead, i, c) {
                assert!(ahead[i].has(flags::REVISED));
                assert_eq!(a.to_bits(), x[i].channel(c).to_bits(), "sample {i} ch {c}");
                restored += 1;
                elsewhere += usize::from(!at_event(i));
            } else {
                assert_eq!(a.to_bits(), b.to_bits(), "sample {i} ch {c}");
                assert_eq!(replaced(&ahead, i, c), replaced(&causal, i, c));
            }
        }
        let any = (0..N_CHANNELS).any(|c| replaced(&ahead, i, c));
        assert_eq!(ahead[i].has(flags::REPLACED), any, "sample {i}");
    }
    let revised: u64 = (0..N_CHANNELS)
        .map(|c| st.channel_counters(c).revised)
        .sum();
    assert_eq!(revised, restored);
    // At the events: the smooth one, gx and az, gy's two, the step's ten. Elsewhere the
    // noise's own false alarms (P(|Z| > 4.5) ≈ 7e-6 per channel-sample) may be revised too
    // when they are smooth; with this seed there is one (ay at 1957).
    assert_eq!(
        restored as usize - elsewhere,
        smooth_causal + 2 + 2 + 10,
        "{elsewhere} elsewhere"
    );
    assert!(elsewhere <= 2, "{elsewhere}");
}

#[test]
fn a_look_ahead_shorter_than_the_event_restores_only_what_it_still_holds() {
    // L = 3: when the step is accepted as a level change (at the 11th sample), the samples
    // replaced before the last three are already out.
    let (x, at) = stream();
    let ahead = run_through(&mut stage(3), &x);
    assert_eq!(replaced_in(&ahead, at.step, 7, GZ), 7);
    assert_eq!(replaced_in(&ahead, at.step + 7, 3, GZ), 0);
}

#[test]
fn a_pipeline_with_a_look_ahead_emits_every_sample_once_in_order() {
    let (x, _) = stream();
    let mut p = Pipeline::new(vec![Box::new(stage(11))]);
    assert_eq!(p.lookahead(), 11);
    let mut out = Vec::new();
    for (i, s) in x.iter().enumerate() {
        let before = out.len();
        p.push(*s, &mut out);
        // Nothing for the first 11 samples, then one per sample.
        assert_eq!(out.len() - before, usize::from(i >= 11), "at {i}");
    }
    p.flush(&mut out);
    assert_eq!(out.len(), x.len());
    assert!(out.iter().zip(&x).all(|(o, s)| o.seq == s.seq));
    // The same as the stage on its own.
    let alone = run_through(&mut stage(11), &x);
    assert!(
        out.iter()
            .zip(&alone)
            .all(|(a, b)| a.flags == b.flags && a.channels() == b.channels())
    );
    // `process` is the causal stage whatever the setting.
    let mut st = stage(11);
    let causal = run_through(&mut stage(0), &x);
    assert!(
        x.iter()
            .zip(&causal)
            .all(|(s, c)| st.process(*s).flags == c.flags)
    );
}
