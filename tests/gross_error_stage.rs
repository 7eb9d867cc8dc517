//! Behaviour of the online gross-error stage: what is replaced (confirmed breaks, bad values) and
//! what is passed flagged suspect (motion, weak evidence), runs and level changes, saturation,
//! warm-up, gaps, stale repeats, scale tracking, latency, and manoeuvres on seeded synthetic
//! drives. Everything runs through `Stage::push`/`flush`, as the pipeline runs it, unless a test
//! is about the causal `process` path.

mod common;

use imuprep::model::arima::ArimaModelFile;
use imuprep::report::gate_sweep::{SyntheticSpec, run_stage, score_run, synthetic_stream};
use imuprep::rng::Rng;
use imuprep::sample::{Sample, flags};
use imuprep::stage::gross_error::{
    GrossErrorError, GrossErrorSettings, GrossErrorStage, Replacement,
};
use imuprep::stage::{Stage, run_through};

const GZ: usize = 2;

/// A sample with gz = `v`; gx (not gated) carries a tiny per-sample value so that no two
/// samples are bit-identical (stale repeats are a test of their own).
fn sample(seq: u32, v: f64) -> Sample {
    let mut s = Sample {
        seq,
        t_ns: seq as u64 * 5_000_000,
        ..Sample::default()
    };
    s.gyro.x = f64::from(seq) * 1e-12;
    s.set_channel(GZ, v);
    s
}

/// Only gz enabled.
fn gz_only(mut s: GrossErrorSettings) -> GrossErrorSettings {
    s.enabled = [false; 6];
    s.enabled[GZ] = true;
    s
}

fn white_model(sigma: f64) -> ArimaModelFile {
    ArimaModelFile {
        channels: vec![common::white_arima("gz", sigma)],
    }
}

/// A gz stage with a given white-noise model.
fn stage(settings: GrossErrorSettings, sigma: f64) -> GrossErrorStage {
    GrossErrorStage::new(gz_only(settings), Some(&white_model(sigma))).unwrap()
}

/// `n` samples of N(0, σ²) on gz from sequence number `seq0`.
fn noise(rng: &mut Rng, seq0: u32, n: u32, sigma: f64) -> Vec<Sample> {
    (0..n)
        .map(|i| sample(seq0 + i, sigma * rng.normal()))
        .collect()
}

fn replaced(s: &Sample) -> bool {
    s.has(flags::replaced_ch(GZ))
}

fn suspect(s: &Sample) -> bool {
    s.has(flags::suspect_ch(GZ))
}

#[test]
fn a_single_spike_is_replaced_by_the_interpolation_and_flagged() {
    let mut rng = Rng::new(1);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 600, sigma);
    x[500].set_channel(GZ, 20.0 * sigma);
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let out = run_through(&mut st, &x);
    assert_eq!(out.len(), x.len(), "every sample comes out once");
    assert!(replaced(&out[500]) && out[500].has(flags::REPLACED));
    assert!(!out[500].has(flags::replaced_ch(0)), "only gz was replaced");
    // The interpolation through the neighbours of zero-mean noise: within a few σ of 0 (its sd
    // is ~0.97σ for the 3 + 3-point quadratic; 4σ bound).
    assert!(
        out[500].channel(GZ).abs() < 4.0 * sigma,
        "{}",
        out[500].channel(GZ)
    );
    let n_replaced = out.iter().filter(|s| replaced(s)).count();
    assert_eq!(n_replaced, 1, "nothing else is replaced");
    let k = st.channel_counters(GZ);
    assert_eq!((k.replaced, k.confirmed), (1, 1));
    assert_eq!(
        out[501].channel(GZ),
        x[501].channel(GZ),
        "neighbours untouched"
    );
}

#[test]
fn the_causal_stage_replaces_nothing_on_the_gate_alone() {
    // Without a look-ahead there is no evidence beyond the forecast: the spike passes, flagged
    // suspect; only a bad value is replaced (by the prediction).
    let mut rng = Rng::new(11);
    let sigma = 0.01;
    let mut st = stage(
        GrossErrorSettings {
            lookahead_samples: 0,
            ..Default::default()
        },
        sigma,
    );
    for s in noise(&mut rng, 0, 500, sigma) {
        st.process(s);
    }
    let out = st.process(sample(500, 20.0 * sigma));
    assert!(suspect(&out) && !replaced(&out));
    assert_eq!(out.channel(GZ), 20.0 * sigma);
    let out = st.process(sample(501, f64::NAN));
    assert!(replaced(&out) && out.has(flags::NON_FINITE) && out.channel(GZ).is_finite());
}

#[test]
fn a_real_step_is_never_replaced() {
    // A 50σ level change that stays: the gate first sees a run of candidates, then a level
    // change; the break has no return, so nothing is replaced. The candidates pass suspect.
    let mut rng = Rng::new(2);
    let sigma = 0.01;
    for max_run in [1u32, 4, 10] {
        let mut x = noise(&mut rng, 0, 500, sigma);
        x.extend((0..100).map(|i| sample(500 + i, 0.5 + sigma * rng.normal())));
        let mut st = stage(
            GrossErrorSettings {
                max_run,
                ..Default::default()
            },
            sigma,
        );
        let out = run_through(&mut st, &x);
        assert!(out.iter().all(|s| !replaced(s)), "max_run {max_run}");
        for (o, i) in out.iter().zip(&x) {
            assert_eq!(o.channel(GZ), i.channel(GZ));
        }
        let n_suspect = out.iter().filter(|s| suspect(s)).count();
        // The run up to the level change and the sample that shows it: a few around the step.
        assert!(
            n_suspect <= 2 * max_run as usize + 1,
            "max_run {max_run}: {n_suspect} suspect"
        );
        assert_eq!(
            st.channel_counters(GZ).level_changes,
            1,
            "max_run {max_run}"
        );
    }
}

#[test]
fn no_true_signal_is_replaced_for_longer_than_max_run() {
    // Random steps, ramps and spikes: whatever happens, a run of consecutive replacements never
    // exceeds max_run, and the spikes are caught.
    let mut rng = Rng::new(3);
    let sigma = 0.01;
    let (mut level, mut slope) = (0.0, 0.0);
    let mut x = noise(&mut rng, 0, 300, sigma);
    let mut spikes = 0;
    for i in 0..50_000u32 {
        if rng.uniform() < 0.002 {
            level += (rng.uniform() - 0.5) * 2.0; // steps up to ±100σ
        }
        if rng.uniform() < 0.002 {
            slope = (rng.uniform() - 0.5) * 0.05;
        }
        if level.abs() > 10.0 {
            // Stay within a gyro's range (beyond 60 rad/s a value is implausible, and replaced).
            slope = -level.signum() * slope.abs();
        }
        level += slope;
        let spike = if rng.uniform() < 0.002 {
            spikes += 1;
            30.0 * sigma
        } else {
            0.0
        };
        x.push(sample(300 + i, level + spike + sigma * rng.normal()));
    }
    let mut st = stage(
        GrossErrorSettings {
            max_run: 6,
            ..Default::default()
        },
        sigma,
    );
    let out = run_through(&mut st, &x);
    let (mut run, mut longest, mut n) = (0, 0, 0);
    for o in &out {
        if replaced(o) {
            run += 1;
            n += 1;
            longest = longest.max(run);
        } else {
            run = 0;
        }
    }
    assert!(longest <= 6, "longest run of replacements {longest}");
    // Most of the ~100 spikes are isolated and confirmed (some fall on a step or a ramp's
    // corner, where the two-sided evidence is weaker): at least half.
    assert!(
        n >= spikes / 2,
        "{n} replaced of {spikes} spikes, longest run {longest}"
    );
}

#[test]
fn non_finite_and_implausible_values_are_replaced_and_counted() {
    let mut rng = Rng::new(4);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 400, sigma);
    for (i, bad) in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e30]
        .into_iter()
        .enumerate()
    {
        x[300 + 10 * i].set_channel(GZ, bad);
    }
    // A long outage, then good data at a new level: the first good values are not lost.
    for s in x[340..365].iter_mut() {
        s.set_channel(GZ, f64::NAN);
    }
    for s in x[365..].iter_mut() {
        s.set_channel(GZ, 0.2 + sigma * rng.normal());
    }
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let out = run_through(&mut st, &x);
    for i in [300, 310, 320, 330] {
        assert!(
            out[i].channel(GZ).is_finite() && out[i].channel(GZ).abs() < 1.0,
            "{i}"
        );
        assert!(replaced(&out[i]), "{i}");
    }
    assert!(out[300].has(flags::NON_FINITE));
    assert!(out[330].has(flags::sat_ch(GZ)), "1e30 is beyond any range");
    let k = st.channel_counters(GZ);
    assert_eq!((k.non_finite, k.implausible), (3 + 25, 1));
    for o in &out[340..365] {
        assert!(o.channel(GZ).is_finite() && replaced(o));
    }
    assert!(
        out[375..].iter().all(|o| !replaced(o)),
        "good data after the outage replaced"
    );
}

#[test]
fn saturated_stretches_pass_flagged_and_never_become_the_forecast() {
    // A turn beyond the gyro's range (saturated for 40 samples at the rail 0.3), then back to
    // noise at 0: the rail values pass (flagged saturated: the best measurement there is), and
    // the good samples after the stretch are never overwritten by a rail-valued forecast.
    let mut rng = Rng::new(5);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 600, sigma);
    for s in x[300..340].iter_mut() {
        s.set_channel(GZ, 0.3);
        s.flags |= flags::sat_ch(GZ);
    }
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let out = run_through(&mut st, &x);
    for o in &out[300..340] {
        assert!(o.has(flags::sat_ch(GZ)));
        assert_eq!(o.channel(GZ), 0.3, "the rail passes");
    }
    for (i, o) in out[340..].iter().enumerate() {
        assert!(
            !replaced(o),
            "good sample {} after the stretch replaced",
            340 + i
        );
        assert_eq!(o.channel(GZ), x[340 + i].channel(GZ));
    }
    assert_eq!(st.channel_counters(GZ).saturated, 40);
    // Saturation of another (disabled) channel is not ours to act on.
    let mut s = sample(600, 0.0);
    s.flags |= flags::sat_ch(0);
    assert!(!run_through(&mut st, &[s])[0].has(flags::REPLACED));
}

/// The default gz stage's output on 900 samples of white noise (σ `sigma`, seeded) carrying a
/// 6-sample half-sine of `height` σ at 300 (a knock, a twitch) and a 6-sample square glitch of
/// the same height at 600.
fn knock_and_glitch(seed: u64, height: f64, sigma: f64) -> Vec<Sample> {
    let mut rng = Rng::new(seed);
    let mut x = noise(&mut rng, 0, 900, sigma);
    for k in 0..6 {
        let bump = height * sigma * (std::f64::consts::PI * (k as f64 + 1.0) / 7.0).sin();
        let v = x[300 + k].channel(GZ) + bump;
        x[300 + k].set_channel(GZ, v);
        let v = x[600 + k].channel(GZ) + height * sigma;
        x[600 + k].set_channel(GZ, v);
    }
    let mut st = stage(GrossErrorSettings::default(), sigma);
    run_through(&mut st, &x)
}

#[test]
fn a_smooth_knock_passes_and_a_square_glitch_of_the_same_size_is_replaced() {
    // Both 30σ high and 6 samples long. The knock is a half-sine — smooth at the sample scale,
    // as anything a rigid body does through the sensor's own filter — and passes flagged
    // suspect; the glitch breaks in and out and is replaced.
    let sigma = 0.01;
    let out = knock_and_glitch(21, 30.0, sigma);
    assert!(out[300..306].iter().all(|o| !replaced(o)), "knock replaced");
    assert!(out[600..606].iter().all(replaced), "glitch passed");
    assert!(
        out[600..606]
            .iter()
            .all(|o| o.channel(GZ).abs() < 5.0 * sigma)
    );
}

#[test]
fn the_opt_in_level_test_passes_a_short_break_at_a_level_the_channel_held() {
    // gz swings ±0.5 rad/s once per second (200 Hz stamps: a 1-s level window is 200 samples;
    // its robust σ is ≈ 0.5 × 1.05) under 0.01 rad/s noise. A one-sample break of 0.3 at a
    // zero crossing is far off the interpolation — a gross error by shape alone — but lies
    // ≈ 0.6 level σ from the median of the second before. With the level test on
    // (level_window_s = 1) it passes flagged suspect, and a 3.0 break (≈ 6 level σ) is still
    // replaced; with the default (off) both are replaced. (This is also why the test is off by
    // default: on smooth manoeuvres such a break is a glitch — docs/real-data.md.)
    let sigma = 0.01;
    let mut rng = Rng::new(33);
    let swing = |i: usize| 0.5 * (2.0 * std::f64::consts::PI * i as f64 / 200.0).sin();
    let mut x: Vec<Sample> = (0..1000)
        .map(|i| sample(i as u32, swing(i) + sigma * rng.normal()))
        .collect();
    let (held, beyond) = (400, 700); // zero crossings of the swing
    let v = x[held].channel(GZ) + 0.3;
    x[held].set_channel(GZ, v);
    let v = x[beyond].channel(GZ) + 3.0;
    x[beyond].set_channel(GZ, v);
    let on = GrossErrorSettings {
        level_window_s: 1.0,
        ..GrossErrorSettings::default()
    };
    let mut st = stage(on, sigma);
    st.record_verdicts();
    let out = run_through(&mut st, &x);
    let verdicts = st.take_verdicts();
    let at = |i: usize| {
        verdicts
            .iter()
            .find(|v| v.start == i as u64)
            .copied()
            .unwrap()
    };
    let (h, b) = (at(held), at(beyond));
    eprintln!("held: {h:?}\nbeyond: {b:?}");
    let bars = GrossErrorSettings::default().thresholds();
    assert!(!replaced(&out[held]) && suspect(&out[held]), "{h:?}");
    assert!(h.level_veto && h.level.is_some_and(|d| d < 1.0), "{h:?}");
    assert!(
        h.evidence.is_some_and(|e| e.rejection(1, &bars).is_none()),
        "{h:?}"
    );
    assert!(replaced(&out[beyond]) && b.gross, "{b:?}");
    assert!(b.level.is_some_and(|d| d > 4.0), "{b:?}");
    let mut st = stage(GrossErrorSettings::default(), sigma);
    st.record_verdicts();
    let out = run_through(&mut st, &x);
    assert!(replaced(&out[held]) && replaced(&out[beyond]));
    assert!(
        st.take_verdicts()
            .iter()
            .all(|v| v.level.is_none() && !v.level_veto)
    );
}

#[test]
fn the_level_test_is_off_by_default_because_it_spares_spikes_on_smooth_manoeuvres() {
    // The synthetic drive of `synthetic_drive_with_spikes_meets_the_issue_targets` with the
    // level test on (level_window_s = 1): a 6–30 σ_n spike on a 0.5 rad/s yaw ramp lies within
    // the level the ramp swept through in the second before, so the test vetoes it although the
    // ramp is smooth at the sample scale. Measured: recall 0.867 (F1 0.929) against 0.952 with
    // the default; the issue-4 bound there is F1 ≥ 0.97. docs/real-data.md, "Sensor classes we
    // do not have".
    let spec = SyntheticSpec {
        ramp_min_samples: 200,
        ..SyntheticSpec::drive_gyro_quiet_start(300_000, 12, 12.0)
    };
    let stream = synthetic_stream(&spec);
    let on = GrossErrorSettings {
        level_window_s: 1.0,
        ..GrossErrorSettings::default()
    };
    let sc = score_run(&run_stage(&stream.observed, &on, GZ).unwrap(), &stream);
    let base = score_run(
        &run_stage(&stream.observed, &GrossErrorSettings::default(), GZ).unwrap(),
        &stream,
    );
    eprintln!("level test on: {sc:?}\ndefault: {base:?}");
    assert!(sc.recall < 0.9 && base.recall > 0.95, "{sc:?} {base:?}");
    assert!(sc.f1 < 0.97, "{sc:?}");
}

#[test]
fn neighbouring_isolated_outliers_do_not_mask_each_other() {
    // Two pairs of 12σ outliers two samples apart on gz (as at a 2 % contamination): the later
    // one of a pair lies in the earlier one's context after it, where it used to inflate the
    // roughness and pull the interpolation. The earlier one of each pair is replaced; nothing
    // but the outliers is. (The later one is judged on its own context; at 12σ it clears the
    // thresholds only about as often as any lone outlier of that size does.)
    let mut rng = Rng::new(31);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 700, sigma);
    let outliers = [(500, 12.0), (502, -12.0), (600, 12.0), (602, 12.0)];
    for (i, a) in outliers {
        let v = x[i].channel(GZ) + a * sigma;
        x[i].set_channel(GZ, v);
    }
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let out = run_through(&mut st, &x);
    for i in [500, 600] {
        assert!(replaced(&out[i]), "outlier at {i} passed");
    }
    for (i, s) in out.iter().enumerate() {
        assert!(
            !replaced(s) || outliers.iter().any(|(j, _)| *j == i),
            "{i} replaced"
        );
    }
}

#[test]
fn stale_repeats_copy_the_verdict_of_the_sample_they_repeat() {
    let mut rng = Rng::new(23);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 600, sigma);
    x[500].set_channel(GZ, 20.0 * sigma);
    // Insert a bit-identical repeat after the spike and after an ordinary sample.
    let mut rep = x[500];
    rep.seq = 10_000; // its own sequence number: a logger writing faster than the sensor
    x.insert(501, rep);
    let mut rep2 = x[200];
    rep2.seq = 10_001;
    x.insert(201, rep2);
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let out = run_through(&mut st, &x);
    assert_eq!(out.len(), x.len());
    // (x shifted by one after index 201.)
    assert!(replaced(&out[501]) && replaced(&out[502]));
    assert!(out[502].has(flags::REPEATED));
    assert_eq!(out[501].channel(GZ), out[502].channel(GZ));
    assert!(out[201].has(flags::REPEATED) && !replaced(&out[201]));
    assert_eq!(st.health().repeats, 2);
}

#[test]
fn a_repeat_held_with_its_measurement_carries_the_measurements_flags() {
    // During the warm-up a spike opens an event and is held for its verdict; a stale repeat of
    // the sample right after it arrives while it is still held. The repeat must come out as the
    // sample it repeats: warming up, with the same value. (It used to lack WARMING_UP whenever
    // an event was open: the flag depended on another sample's event.)
    let mut rng = Rng::new(24);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 1200, sigma);
    x[700].set_channel(GZ, 30.0 * sigma);
    let mut rep = x[701];
    rep.seq = 10_000;
    x.insert(702, rep);
    let mut st = GrossErrorStage::new(gz_only(GrossErrorSettings::default()), None).unwrap();
    let out = run_through(&mut st, &x);
    assert!(replaced(&out[700]) && out[700].has(flags::WARMING_UP));
    assert!(out[702].has(flags::REPEATED));
    assert!(st.health().held_samples > 0, "the event held the output");
    assert!(
        out[702].has(flags::WARMING_UP),
        "flags {:#x}",
        out[702].flags
    );
    assert_eq!(out[702].channel(GZ), out[701].channel(GZ));
    assert_eq!(replaced(&out[702]), replaced(&out[701]));
}

#[test]
fn a_channel_quieter_than_its_lsb_is_not_flagged_at_every_toggle() {
    // A sensor whose noise is below one LSB (σ = 0.3 LSB here: a coarse range, a quiet part)
    // sits on one code and toggles to the next now and then. Each toggle is the sensor's
    // resolution, not a break; before the gate and the jump guard floored their scales at the
    // quantisation noise (LSB/√12), about 3 in 10 samples of such a channel came out suspect
    // (`imuprep replay` on a 0.2–0.4-LSB simulated bench: 29–40 %). A spike
    // of 12 LSB (40 σ) on it is still replaced.
    let mut rng = Rng::new(25);
    let lsb = 1e-3;
    let mut x: Vec<Sample> = (0..6000)
        .map(|i| sample(i, (-18.8 + 0.3 * rng.normal()).round() * lsb))
        .collect();
    let spikes = [3000, 4500];
    for i in spikes {
        let v = x[i].channel(GZ) + 12.0 * lsb;
        x[i].set_channel(GZ, v);
    }
    let toggles = x
        .windows(2)
        .filter(|w| w[0].channel(GZ) != w[1].channel(GZ))
        .count();
    assert!(toggles > 1000, "the test needs toggles: {toggles}");
    let mut st = GrossErrorStage::new(gz_only(GrossErrorSettings::default()), None).unwrap();
    let out = run_through(&mut st, &x);
    for i in spikes {
        assert!(replaced(&out[i]), "spike at {i} passed");
    }
    let flagged = out
        .iter()
        .enumerate()
        .filter(|(i, o)| (suspect(o) || replaced(o)) && !spikes.contains(i))
        .count();
    // Measured: 7. What is left are jumps of two codes (the level lies between two codes, so
    // the farther neighbour is 2.3 σ away) right after a quiet run, whose 16 recent increments
    // were nearly all 0: the guard judges them against the quantisation floor alone. They pass
    // unchanged, flagged suspect. 30 (0.5 %) bounds that with room; the old floors flagged 956
    // (16 %) of this channel.
    assert!(
        flagged <= 30,
        "{flagged} ordinary samples flagged of {toggles} toggles"
    );
}

#[test]
fn whole_samples_repeating_by_chance_are_measurements_and_stale_copies_are_not() {
    // Six quantised channels. (a) Noise 0.2 LSB on each: a whole sample repeats its
    // predecessor by chance about 3 times in 10, and each is a new measurement. (b) Noise 3
    // LSB, every measurement written twice (a logger at twice the sensor's rate): each copy is
    // stale. Before the chance rule every chance repeat of (a) was flagged REPEATED (and
    // learned from by no stage); the copies of (b) must all still be.
    let lsb = 1e-3;
    let quantised = |rng: &mut Rng, sd: f64, i: u32| {
        let mut s = Sample {
            seq: i,
            t_ns: u64::from(i) * 5_000_000,
            ..Sample::default()
        };
        for c in 0..6 {
            let level = [9.3, -18.8, 4.6, 20.2, -10.1, 2043.7][c];
            s.set_channel(c, (level + sd * rng.normal()).round() * lsb);
        }
        s
    };
    let mut rng = Rng::new(26);
    let quiet: Vec<Sample> = (0..6000).map(|i| quantised(&mut rng, 0.2, i)).collect();
    let chance = quiet
        .windows(2)
        .filter(|w| w[0].channels() == w[1].channels())
        .count();
    assert!(chance > 1000, "the test needs chance repeats: {chance}");
    let mut st = GrossErrorStage::new(GrossErrorSettings::default(), None).unwrap();
    let out = run_through(&mut st, &quiet);
    let flagged: Vec<usize> = (0..out.len())
        .filter(|&i| out[i].has(flags::REPEATED))
        .collect();
    // The shares are trusted from the 100th pair on; before, every copy counts as stale (the
    // old rule). After that, none may be flagged.
    eprintln!("{} of {chance} chance repeats flagged", flagged.len());
    assert!(
        flagged.iter().all(|&i| i <= 100),
        "{} of {chance} chance repeats flagged, after the 100th sample: {:?}",
        flagged.len(),
        flagged
            .iter()
            .filter(|&&i| i > 100)
            .take(20)
            .collect::<Vec<_>>()
    );

    let mut rng = Rng::new(27);
    let mut doubled = Vec::new();
    for i in 0..3000 {
        let s = quantised(&mut rng, 3.0, 2 * i);
        let mut copy = s;
        copy.seq = 2 * i + 1;
        copy.t_ns += 2_500_000;
        doubled.push(s);
        doubled.push(copy);
    }
    let mut st = GrossErrorStage::new(GrossErrorSettings::default(), None).unwrap();
    let out = run_through(&mut st, &doubled);
    for (i, o) in out.iter().enumerate() {
        assert_eq!(o.has(flags::REPEATED), i % 2 == 1, "sample {i}");
    }
}

#[test]
fn warm_up_is_guarded() {
    // No model: the channel warms up for 2000 samples. Bad values in that time are replaced
    // and flagged, and an isolated 30σ spike is caught by the jump guard and confirmed.
    let mut rng = Rng::new(24);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 3000, sigma);
    x[100].set_channel(GZ, f64::NAN);
    x[200].set_channel(GZ, f64::INFINITY);
    x[300].set_channel(GZ, 1e30);
    x[700].set_channel(GZ, 30.0 * sigma);
    let mut st = GrossErrorStage::new(gz_only(GrossErrorSettings::default()), None).unwrap();
    let out = run_through(&mut st, &x);
    for i in [100, 200, 300, 700] {
        assert!(out[i].has(flags::WARMING_UP), "{i}");
        assert!(replaced(&out[i]), "{i}");
        assert!(
            out[i].channel(GZ).abs() < 5.0 * sigma,
            "{i}: {}",
            out[i].channel(GZ)
        );
    }
    assert!(out[100].has(flags::NON_FINITE) && out[300].has(flags::sat_ch(GZ)));
    let n = out[..2000].iter().filter(|o| replaced(o)).count();
    assert_eq!(n, 4, "nothing else in the warm-up replaced");
}

#[test]
fn the_output_waits_only_while_an_event_is_open() {
    // Quiet noise: every push emits its own sample at once. A spike: the stage holds the
    // output until the spike's verdict, at most lookahead_samples, then catches up.
    let mut rng = Rng::new(25);
    let sigma = 0.01;
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let mut buf = Vec::new();
    for s in noise(&mut rng, 0, 300, sigma) {
        buf.clear();
        st.push(s, &mut buf);
        assert_eq!(buf.len(), 1);
        assert_eq!(buf[0].seq, s.seq, "no lag outside events");
    }
    let mut x = noise(&mut rng, 300, 40, sigma);
    x[0].set_channel(GZ, 20.0 * sigma);
    let mut emitted = 0;
    let mut longest_wait = 0;
    for (k, s) in x.iter().enumerate() {
        buf.clear();
        st.push(*s, &mut buf);
        emitted += buf.len();
        longest_wait = longest_wait.max(k + 1 - emitted);
    }
    assert_eq!(emitted, x.len(), "caught up");
    assert!(longest_wait >= 1 && longest_wait <= st.settings().lookahead_samples);
}

#[test]
fn median_replacement_replaces_with_the_local_level() {
    let mut rng = Rng::new(26);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 600, sigma);
    x[400].set_channel(GZ, 0.5);
    let mut st = stage(
        GrossErrorSettings {
            replacement: Replacement::MedianOfPredictions,
            ..Default::default()
        },
        sigma,
    );
    let out = run_through(&mut st, &x);
    assert!(replaced(&out[400]));
    // The median of the last three predictions of zero-mean noise (local level sd ~0.33σ).
    assert!(
        out[400].channel(GZ).abs() < 2.0 * sigma,
        "{}",
        out[400].channel(GZ)
    );
}

#[test]
fn warm_up_flags_samples_then_identifies_a_model() {
    let s = gz_only(GrossErrorSettings {
        warmup_samples: 1000,
        ..Default::default()
    });
    let mut st = GrossErrorStage::new(s, None).unwrap();
    let mut rng = Rng::new(6);
    let mut v = 0.0;
    let x: Vec<Sample> = (0..1500u32)
        .map(|i| {
            v = 0.6 * v + 0.01 * rng.normal();
            sample(i, 0.02 + v)
        })
        .collect();
    let out = run_through(&mut st, &x);
    for (i, o) in out.iter().enumerate() {
        // The 1000th sample completes the window; the warm-up goes on for `identify_defer_s`
        // = 0.5 s of the stamps (100 samples at 200 Hz) while the model is identified, and gz
        // (channel 2) takes it over 2 samples after that; the sample that ends the warm-up is
        // itself a warm-up sample.
        assert_eq!(o.has(flags::WARMING_UP), i < 1102, "sample {i}");
    }
    assert_eq!(st.channel_counters(GZ).warmup, 1102);
    let models = st.models();
    let m = models.channel("gz").expect("identified");
    // AR(1) φ = 0.6 noise: d = 0 and an innovation σ near 0.01 (10 % bound: the Hampel
    // pre-clean trims a little of the tails).
    assert_eq!(m.d, 0);
    assert!((m.sigma - 0.01).abs() < 0.001, "σ = {}", m.sigma);
    assert_eq!(st.channel_counters(GZ).fallback_models, 0);
}

#[test]
fn constant_channel_falls_back_without_panicking() {
    let s = GrossErrorSettings {
        warmup_samples: 500,
        ..Default::default()
    };
    let mut st = GrossErrorStage::new(s, None).unwrap();
    // All six channels constant (a disconnected sensor), but not bit-identical samples (the
    // sequence advances and gz alternates by one ULP so they are not stale repeats).
    let x: Vec<Sample> = (0..700u32)
        .map(|i| {
            let mut smp = sample(i, if i % 2 == 0 { 0.0 } else { 1e-300 });
            smp.accel.z = 9.81;
            smp
        })
        .collect();
    let out = run_through(&mut st, &x);
    assert!(out.iter().all(|o| !o.has(flags::REPLACED)));
    // (gx carries the helper's tiny per-sample ramp, so it is not constant.)
    for c in 1..6 {
        assert_eq!(st.channel_counters(c).fallback_models, 1, "channel {c}");
        // σ floored at min_sigma (1e-4 rad/s, 1e-3 m/s²), never zero.
        let floor = if c < 3 { 1e-4 } else { 1e-3 };
        assert!(st.sigma(c).unwrap() >= floor * (1.0 - 1e-12));
    }
}

#[test]
fn short_gaps_are_bridged_and_long_gaps_reset() {
    let mut rng = Rng::new(7);
    let sigma = 0.01;
    let mut x = noise(&mut rng, 0, 300, sigma);
    // Bridged: 2 frames missing, then a 30σ spike is still caught.
    let mut tail = noise(&mut rng, 302, 100, sigma);
    tail[0].flags |= flags::GAP;
    tail[50].set_channel(GZ, 30.0 * sigma);
    x.extend(tail);
    // Reset: 1000 frames missing, the signal moved meanwhile: the new level is accepted.
    let mut after: Vec<Sample> = (0..60u32)
        .map(|i| sample(1402 + i, 0.8 + sigma * rng.normal()))
        .collect();
    after[0].flags |= flags::GAP;
    x.extend(after);
    let mut st = stage(GrossErrorSettings::default(), sigma);
    let out = run_through(&mut st, &x);
    assert!(replaced(&out[350]), "spike after a bridged gap");
    assert!(
        out[400..].iter().all(|o| !replaced(o)),
        "new level replaced after the reset"
    );
    let h = st.health();
    assert_eq!((h.gaps_bridged, h.gaps_reset), (1, 1));
}

#[test]
fn sigma_ignores_spikes_but_follows_a_real_rise_in_noise() {
    let mut rng = Rng::new(8);
    let sigma = 0.01;
    let mut st = stage(GrossErrorSettings::default(), sigma);
    run_through(&mut st, &noise(&mut rng, 0, 2000, sigma));
    let s0 = st.sigma(GZ).unwrap();
    // 30 isolated 20σ spikes among 3000 samples: σ moves by no more than its own sampling noise
    // (relative sd ≈ 1/√(2·200) = 5 %; bound 15 %).
    let x: Vec<Sample> = (0..3000u32)
        .map(|i| {
            let spike = if i % 100 == 50 { 20.0 * sigma } else { 0.0 };
            sample(2000 + i, spike + sigma * rng.normal())
        })
        .collect();
    run_through(&mut st, &x);
    let s1 = st.sigma(GZ).unwrap();
    assert!((s1 / s0 - 1.0).abs() < 0.15, "σ {s0} → {s1} after spikes");
    // Noise triples: within 5 window lengths σ follows to within 20 %.
    let x: Vec<Sample> = (0..1000u32)
        .map(|i| sample(5000 + i, 3.0 * sigma * rng.normal()))
        .collect();
    run_through(&mut st, &x);
    let s2 = st.sigma(GZ).unwrap();
    assert!((s2 / (3.0 * s0) - 1.0).abs() < 0.2, "σ {s2} vs 3σ₀");
}

#[test]
fn smooth_manoeuvres_without_spikes_are_left_alone() {
    // Yaw-rate ramps 0 → ±0.5 rad/s over 1 s (raised cosine), holds of 0.5–3 s, AR(1) noise
    // σ_n = 5 mrad/s at 200 Hz, no spikes at all; warm-up at rest. Every replacement is a false
    // alarm. Target ≤ 1e-4 per clean sample: on 300 000 samples ≤ 30.
    let spec = SyntheticSpec {
        spike_rate: 0.0,
        ramp_min_samples: 200,
        ..SyntheticSpec::drive_gyro_quiet_start(300_000, 11, 12.0)
    };
    let stream = synthetic_stream(&spec);
    let run = run_stage(&stream.observed, &GrossErrorSettings::default(), GZ).unwrap();
    let fp = run.replaced.iter().filter(|r| **r).count();
    assert!(fp <= 30, "{fp} false replacements on manoeuvres");
}

#[test]
fn synthetic_drive_with_spikes_meets_the_issue_targets() {
    // Manoeuvres as above plus spikes of 6–30 σ_n every ~500 samples, a third of them runs of
    // 2–10. Targets: F1 ≥ 0.98, false alarms ≤ 1e-4 of clean samples, and the corrected RMSE
    // ≥ 5× below the raw one.
    let spec = SyntheticSpec {
        ramp_min_samples: 200,
        ..SyntheticSpec::drive_gyro_quiet_start(300_000, 12, 12.0)
    };
    let stream = synthetic_stream(&spec);
    let run = run_stage(&stream.observed, &GrossErrorSettings::default(), GZ).unwrap();
    let sc = score_run(&run, &stream);
    // Measured 2026-11-24: precision 1.0, recall 0.952, F1 0.976 — the issue's F1 ≥ 0.98 is
    // missed since issue 12 made every replacement need two-sided evidence (the weakest 6σ
    // spikes stay unreplaced); bounded here so it cannot get worse unnoticed.
    assert!(sc.f1 >= 0.97, "{sc:?}");
    assert!(sc.precision >= 0.999, "{sc:?}");
    assert!(sc.false_alarm_rate <= 1e-4, "{sc:?}");
    let a = run.active_from;
    let raw_rmse = (stream.observed[a..]
        .iter()
        .zip(&stream.truth[a..])
        .map(|(o, t)| (o - t) * (o - t))
        .sum::<f64>()
        / (stream.truth.len() - a) as f64)
        .sqrt();
    assert!(
        sc.rmse < raw_rmse / 5.0,
        "rmse {} vs raw {raw_rmse}",
        sc.rmse
    );
}

#[test]
fn static_stream_meets_the_false_alarm_target_and_keeps_its_measured_recall() {
    let stream = synthetic_stream(&SyntheticSpec::static_gyro(300_000, 13));
    let run = run_stage(&stream.observed, &GrossErrorSettings::default(), GZ).unwrap();
    let sc = score_run(&run, &stream);
    // Measured 2026-11-24: precision 1.0, recall 0.946, F1 0.972 (issue target 0.98 missed, as
    // above).
    assert!(sc.false_alarm_rate <= 1e-4, "{sc:?}");
    assert!(sc.precision >= 0.999, "{sc:?}");
    assert!(sc.f1 >= 0.965, "{sc:?}");
}

#[test]
fn settings_validate_reports_every_problem_and_round_trip_toml() {
    let bad = GrossErrorSettings {
        k: -1.0,
        max_run: 0,
        median_window: 4,
        level_alpha: 2.0,
        warmup_samples: 10,
        lookahead_samples: 3,
        ..Default::default()
    };
    match GrossErrorStage::new(bad, None) {
        Err(GrossErrorError::InvalidSettings(v)) => assert_eq!(v.len(), 6, "{v:?}"),
        other => panic!("{other:?}"),
    }
    let s = GrossErrorSettings::default();
    let text = toml::to_string(&s).unwrap();
    let back: GrossErrorSettings = toml::from_str(&text).unwrap();
    assert_eq!(back, s);
    assert!(toml::from_str::<GrossErrorSettings>("kk = 3.0").is_err());
    // Partial files take the documented defaults; the paper's name of the median works too.
    let partial: GrossErrorSettings = toml::from_str("k = 5.0\nreplacement = \"median\"").unwrap();
    assert_eq!(partial.max_run, 10);
    assert_eq!(partial.replacement, Replacement::MedianOfPredictions);
}

#[test]
fn an_online_model_beyond_the_fixed_size_limits_is_rejected() {
    let mut f = white_model(0.01);
    f.channels[0].p = 4;
    f.channels[0].ar = vec![0.1, 0.1, 0.1, 0.1];
    assert!(matches!(
        GrossErrorStage::new(gz_only(GrossErrorSettings::default()), Some(&f)),
        Err(GrossErrorError::Model(_))
    ));
}

/// A white gz bench of `n` samples (σ `sigma`), ax white too (σ `sigma`), with isolated gz
/// outliers of 8–12 σ at a 2 % rate (seeded) and, with `tap`, ax departing by 8 σ on the same
/// samples (another axis moving with the event: a tap, not a glitch); the outliers' indices.
fn bench_with_outliers(n: u32, sigma: f64, tap: bool) -> (Vec<Sample>, Vec<usize>) {
    let mut rng = Rng::new(77);
    let mut x: Vec<Sample> = (0..n)
        .map(|i| {
            let mut s = sample(i, sigma * rng.normal());
            s.set_channel(3, sigma * rng.normal());
            s
        })
        .collect();
    let mut at = Vec::new();
    let mut i = 2100;
    while i < n as usize - 10 {
        if rng.uniform() < 0.02 {
            let a = (8.0 + 4.0 * rng.uniform()) * sigma;
            let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            let v = x[i].channel(GZ) + sign * a;
            x[i].set_channel(GZ, v);
            if tap {
                let v = x[i].channel(3) + 8.0 * sigma;
                x[i].set_channel(3, v);
            }
            at.push(i);
            i += 2;
        } else {
            i += 1;
        }
    }
    (x, at)
}

/// Replaced gz outliers and replaced clean gz samples of the stage with `rest_k`.
fn rest_run(x: &[Sample], at: &[usize], rest_k: f64, sigma: f64) -> (usize, usize) {
    let mut s = gz_only(GrossErrorSettings {
        rest_k,
        ..GrossErrorSettings::default()
    });
    s.enabled[3] = true;
    let model = ArimaModelFile {
        channels: vec![
            common::white_arima("gz", sigma),
            common::white_arima("ax", sigma),
        ],
    };
    let mut st = GrossErrorStage::new(s, Some(&model)).unwrap();
    let out = run_through(&mut st, x);
    let hit = at.iter().filter(|&&i| replaced(&out[i])).count();
    let all = out.iter().filter(|o| replaced(o)).count();
    (hit, all - hit)
}

#[test]
fn at_rest_outliers_are_judged_against_the_level_unless_another_axis_moves_with_them() {
    // 2 % isolated outliers of 8–12 σ on white noise: the shape tests alone judge a spike of
    // A σ as A/√1.5 σ̂ against `confirm_k` = 6 and lose many (their neighbours crowd the edge
    // tests); at rest its level is known and the spike is A spreads off it. Measured (seed 77,
    // 18 000 scored samples, 353 outliers): recall 0.54 without the rest test, 0.93 with it, no
    // clean sample replaced either way. Bars: the issue's 0.9, and a gain of 0.2.
    let sigma = 0.01;
    let (x, at) = bench_with_outliers(20_000, sigma, false);
    let (off, off_false) = rest_run(&x, &at, 0.0, sigma);
    let (on, on_false) = rest_run(&x, &at, 6.0, sigma);
    let (r_off, r_on) = (off as f64 / at.len() as f64, on as f64 / at.len() as f64);
    eprintln!(
        "{} outliers: recall {r_off:.3} without the rest test, {r_on:.3} with it; false {off_false} / {on_false}",
        at.len()
    );
    assert!(r_on >= 0.9 && r_on >= r_off + 0.2, "{r_off} → {r_on}");
    assert_eq!((off_false, on_false), (0, 0));
    // The same spikes with ax moving on their samples: the rest test stands down (ax is not at
    // rest during the event) and replaces nothing the shape tests do not.
    let (x, at) = bench_with_outliers(20_000, sigma, true);
    let (off, _) = rest_run(&x, &at, 0.0, sigma);
    let (on, _) = rest_run(&x, &at, 6.0, sigma);
    assert_eq!(on, off, "with a partner moving");
}

#[test]
fn at_rest_a_smooth_twitch_is_motion_and_a_square_glitch_is_not() {
    // A 6-sample half-sine of 12 σ on gz alone (a yaw twitch moves no accelerometer) passes the
    // rest test as it passes the shape tests; a 6-sample square glitch of 12 σ is replaced.
    let out = knock_and_glitch(22, 12.0, 0.01);
    assert!(
        out[300..306].iter().all(|o| !replaced(o)),
        "twitch replaced"
    );
    assert!(out[600..606].iter().all(replaced), "glitch passed");
}
