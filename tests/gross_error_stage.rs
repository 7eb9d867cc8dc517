//! Behaviour of the online gross-error stage: replacement, runs and level changes, non-finite and
//! saturated input, warm-up identification, gaps, scale tracking, and manoeuvres on seeded
//! synthetic drives.

mod common;

use imuprep::analysis::gate_sweep::{SyntheticSpec, run_stage, score_run, synthetic_stream};
use imuprep::model::arima::{ArimaChannelModel, ArimaModelFile};
use imuprep::rng::Rng;
use imuprep::sample::{Sample, flags};
use imuprep::stage::Stage;
use imuprep::stage::gross_error::{
    GrossErrorError, GrossErrorSettings, GrossErrorStage, Replacement,
};

const GZ: usize = 2;

fn sample(seq: u32, v: f64) -> Sample {
    let mut s = Sample {
        seq,
        t_ns: seq as u64 * 5_000_000,
        ..Sample::default()
    };
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

/// A stage on gz with a given white-noise model, fed `n` samples of N(0, σ²) first.
fn primed_stage(
    settings: GrossErrorSettings,
    sigma: f64,
    n: u32,
    rng: &mut Rng,
) -> GrossErrorStage {
    let mut st = GrossErrorStage::new(gz_only(settings), Some(&white_model(sigma))).unwrap();
    for i in 0..n {
        let out = st.process(sample(i, sigma * rng.normal()));
        assert!(
            !out.has(flags::WARMING_UP),
            "a given model needs no warm-up"
        );
    }
    st
}

#[test]
fn single_spike_is_replaced_by_the_prediction_and_flagged() {
    let mut rng = Rng::new(1);
    let sigma = 0.01;
    let mut st = primed_stage(GrossErrorSettings::default(), sigma, 500, &mut rng);
    let before = st.channel_counters(GZ);
    let out = st.process(sample(500, 20.0 * sigma));
    assert!(out.has(flags::REPLACED) && out.has(flags::replaced_ch(GZ)));
    assert!(!out.has(flags::replaced_ch(0)), "only gz was replaced");
    // The prediction is the local level of zero-mean noise: within a few σ of 0 (the level
    // EWMA with α = 0.2 has sd σ·√(α/(2−α)) = 0.33σ).
    assert!(
        out.channel(GZ).abs() < 2.0 * sigma,
        "replacement {}",
        out.channel(GZ)
    );
    let after = st.channel_counters(GZ);
    assert_eq!(after.replaced, before.replaced + 1);
    assert_eq!(after.runs, before.runs + 1);
    // The next good sample passes untouched.
    let out = st.process(sample(501, 0.3 * sigma));
    assert!(!out.has(flags::REPLACED));
    assert_eq!(out.channel(GZ), 0.3 * sigma);
}

#[test]
fn a_step_is_replaced_for_at_most_max_run_samples_then_accepted_as_level_change() {
    let mut rng = Rng::new(2);
    let sigma = 0.01;
    for max_run in [1u32, 4, 10] {
        let s = GrossErrorSettings {
            max_run,
            ..Default::default()
        };
        let mut st = primed_stage(s, sigma, 500, &mut rng);
        let mut replaced = 0;
        let mut level_change_at = None;
        for i in 0..50u32 {
            let out = st.process(sample(500 + i, 0.5 + sigma * rng.normal()));
            if out.has(flags::replaced_ch(GZ)) {
                assert!(level_change_at.is_none(), "replaced after the level change");
                replaced += 1;
            }
            if out.has(flags::LEVEL_CHANGE) {
                assert!(!out.has(flags::replaced_ch(GZ)));
                assert!(
                    (out.channel(GZ) - 0.5).abs() < 5.0 * sigma,
                    "level change passes raw"
                );
                level_change_at = Some(i);
            }
        }
        assert_eq!(replaced, max_run, "max_run = {max_run}");
        assert_eq!(level_change_at, Some(max_run));
        assert_eq!(st.channel_counters(GZ).level_changes, 1);
    }
}

#[test]
fn no_true_signal_is_replaced_for_longer_than_max_run() {
    // Random steps, ramps and spikes: whatever happens, a run of consecutive replacements of
    // finite samples never exceeds max_run (the guarantee behind "never replace a true signal
    // forever").
    let mut rng = Rng::new(3);
    let sigma = 0.01;
    let s = GrossErrorSettings {
        max_run: 6,
        ..Default::default()
    };
    let mut st = primed_stage(s, sigma, 300, &mut rng);
    let (mut level, mut slope, mut run, mut longest) = (0.0, 0.0, 0u32, 0u32);
    for i in 0..50_000u32 {
        if rng.uniform() < 0.002 {
            level += (rng.uniform() - 0.5) * 2.0; // steps up to ±100σ
        }
        if rng.uniform() < 0.002 {
            slope = (rng.uniform() - 0.5) * 0.05;
        }
        level += slope;
        let spike = if rng.uniform() < 0.01 {
            30.0 * sigma
        } else {
            0.0
        };
        let out = st.process(sample(300 + i, level + spike + sigma * rng.normal()));
        if out.has(flags::replaced_ch(GZ)) {
            run += 1;
            longest = longest.max(run);
        } else {
            run = 0;
        }
    }
    assert!(longest <= 6, "longest run of replacements {longest}");
    assert!(longest >= 1, "the test must exercise replacement");
}

#[test]
fn non_finite_values_are_replaced_and_counted() {
    let mut rng = Rng::new(4);
    let sigma = 0.01;
    let mut st = primed_stage(GrossErrorSettings::default(), sigma, 300, &mut rng);
    for (i, bad) in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        let out = st.process(sample(300 + i as u32, bad));
        assert!(out.channel(GZ).is_finite(), "{bad} must be replaced");
        assert!(out.has(flags::NON_FINITE) && out.has(flags::replaced_ch(GZ)));
    }
    assert_eq!(st.channel_counters(GZ).non_finite, 3);
    // A long outage: replaced throughout (there is nothing to accept), and the first good value
    // afterwards is not lost to a stale forecast for longer than max_run.
    let mut last_replaced = 0;
    for i in 0..40u32 {
        let v = if i < 25 {
            f64::NAN
        } else {
            0.2 + sigma * rng.normal()
        };
        let out = st.process(sample(303 + i, v));
        assert!(out.channel(GZ).is_finite());
        if out.has(flags::replaced_ch(GZ)) {
            last_replaced = i;
        }
    }
    assert!(
        last_replaced < 25 + 10,
        "good data replaced until {last_replaced}"
    );
}

#[test]
fn saturated_samples_are_treated_as_gross_errors() {
    let mut rng = Rng::new(5);
    let sigma = 0.01;
    let mut st = primed_stage(GrossErrorSettings::default(), sigma, 300, &mut rng);
    let mut s = sample(300, 0.001);
    s.flags |= flags::sat_ch(GZ);
    let out = st.process(s);
    assert!(
        out.has(flags::replaced_ch(GZ)),
        "saturated value replaced even if plausible"
    );
    assert_eq!(st.channel_counters(GZ).saturated, 1);
    // A good sample ends that one-sample run.
    assert!(!st.process(sample(301, 0.002)).has(flags::REPLACED));
    // A saturation that lasts (a turn beyond the gyro's range): replaced for max_run samples,
    // then accepted as a level change and passed on for as long as it lasts.
    let mut replaced = 0;
    let mut level_changes = 0;
    for i in 0..40u32 {
        let mut s = sample(400 + i, 0.3);
        s.flags |= flags::sat_ch(GZ);
        let out = st.process(s);
        replaced += out.has(flags::replaced_ch(GZ)) as u32;
        level_changes += out.has(flags::LEVEL_CHANGE) as u32;
        if i > 10 {
            assert_eq!(out.channel(GZ), 0.3, "sample {i} must pass");
        }
    }
    assert_eq!((replaced, level_changes), (10, 1));
    // Saturation of another (disabled) channel is not ours to act on.
    let mut s = sample(440, 0.301);
    s.flags |= flags::sat_ch(0);
    assert!(!st.process(s).has(flags::REPLACED));
}

#[test]
fn median_replacement_is_the_median_of_recent_predictions() {
    // AR(1) φ = 0.5, mean 0, no local level: predictions are exactly 0.5·x_{t−1}.
    let model = ArimaModelFile {
        channels: vec![ArimaChannelModel {
            channel: "gz".into(),
            p: 1,
            d: 0,
            q: 0,
            constant: 0.0,
            ar: vec![0.5],
            ma: vec![],
            sigma: 0.01,
            diagnostics: None,
        }],
    };
    let s = gz_only(GrossErrorSettings {
        replacement: Replacement::MedianOfPredictions,
        median_window: 3,
        level_alpha: 0.0,
        trend_beta: 0.0,
        ..Default::default()
    });
    let mut st = GrossErrorStage::new(s, Some(&model)).unwrap();
    // First sample seeds; the next predictions are 0.5·x.
    let xs = [0.004, 0.010, -0.006, 0.002];
    for (i, &x) in xs.iter().enumerate() {
        assert!(!st.process(sample(i as u32, x)).has(flags::REPLACED));
    }
    // Predictions for samples 2, 3, 4: 0.005, −0.003, 0.001 ⇒ median 0.001.
    let out = st.process(sample(4, 0.5));
    assert!(out.has(flags::replaced_ch(GZ)));
    assert!(
        (out.channel(GZ) - 0.001).abs() < 1e-15,
        "{}",
        out.channel(GZ)
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
    for i in 0..1500u32 {
        v = 0.6 * v + 0.01 * rng.normal();
        let out = st.process(sample(i, 0.02 + v));
        // The 1000th sample completes the window: it is itself a warm-up sample.
        assert_eq!(out.has(flags::WARMING_UP), i < 1000, "sample {i}");
    }
    assert_eq!(st.channel_counters(GZ).warmup, 1000);
    let models = st.models();
    let m = models.channel("gz").expect("identified");
    // AR(1) φ = 0.6 noise: identification finds d = 0 and an innovation σ near 0.01 (sd of σ̂
    // ≈ 0.01/√2000; the Hampel pre-clean trims a little of the tails: 10 % bound).
    assert_eq!(m.d, 0);
    assert!((m.sigma - 0.01).abs() < 0.001, "σ = {}", m.sigma);
    assert!(m.diagnostics.is_some());
    assert_eq!(st.channel_counters(GZ).fallback_models, 0);
}

#[test]
fn constant_channel_falls_back_without_panicking() {
    let s = GrossErrorSettings {
        warmup_samples: 500,
        ..Default::default()
    };
    let mut st = GrossErrorStage::new(s, None).unwrap();
    for i in 0..700u32 {
        // All six channels constant (a disconnected sensor).
        let mut smp = sample(i, 0.0);
        smp.accel.z = 9.81;
        let out = st.process(smp);
        assert!(!out.has(flags::REPLACED));
    }
    for c in 0..6 {
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
    let mut st = primed_stage(GrossErrorSettings::default(), sigma, 300, &mut rng);
    // Bridged: 2 frames missing, then a 30σ jump is still a gross error.
    let mut s = sample(302, 30.0 * sigma);
    s.flags |= flags::GAP;
    assert!(st.process(s).has(flags::replaced_ch(GZ)));
    let c: std::collections::HashMap<String, u64> = st.counters().into_iter().collect();
    assert_eq!(c["gaps_bridged"], 1);
    // Reset: 1000 frames missing, the signal moved meanwhile: the new level is accepted at once.
    let mut s = sample(1303, 0.8);
    s.flags |= flags::GAP;
    let out = st.process(s);
    assert!(!out.has(flags::REPLACED));
    assert_eq!(out.channel(GZ), 0.8);
    for i in 0..20u32 {
        let out = st.process(sample(1304 + i, 0.8 + sigma * rng.normal()));
        assert!(!out.has(flags::REPLACED), "after the reset, sample {i}");
    }
    let c: std::collections::HashMap<String, u64> = st.counters().into_iter().collect();
    assert_eq!(c["gaps_reset"], 1);
}

#[test]
fn sigma_ignores_spikes_but_follows_a_real_rise_in_noise() {
    let mut rng = Rng::new(8);
    let sigma = 0.01;
    let mut st = primed_stage(GrossErrorSettings::default(), sigma, 2000, &mut rng);
    let s0 = st.sigma(GZ).unwrap();
    // 30 isolated 20σ spikes among 3000 samples: σ must not move by more than its own sampling
    // noise (relative sd ≈ 1/√(2·200) = 5 % for a 200-sample window; bound 15 %).
    for i in 0..3000u32 {
        let spike = if i % 100 == 50 { 20.0 * sigma } else { 0.0 };
        st.process(sample(2000 + i, spike + sigma * rng.normal()));
    }
    let s1 = st.sigma(GZ).unwrap();
    assert!((s1 / s0 - 1.0).abs() < 0.15, "σ {s0} → {s1} after spikes");
    // Noise triples (a rougher road): within 5 window lengths σ follows to within 20 %.
    for i in 0..1000u32 {
        st.process(sample(5000 + i, 3.0 * sigma * rng.normal()));
    }
    let s2 = st.sigma(GZ).unwrap();
    assert!(
        (s2 / (3.0 * s0) - 1.0).abs() < 0.2,
        "σ {s2} vs 3σ₀ = {}",
        3.0 * s0
    );
}

#[test]
fn smooth_manoeuvres_without_spikes_are_left_alone() {
    // The brief's manoeuvre: yaw-rate ramps 0 → ±0.5 rad/s over 1 s (raised cosine), holds of
    // 0.5–3 s, AR(1) noise σ_n = 5 mrad/s at 200 Hz, no spikes at all; warm-up at rest. Every
    // replacement here is a false alarm. Issue target ≤ 1e-4 per clean sample; on 300 000
    // samples that is ≤ 30.
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
    // 2–10. Targets from the issue: F1 ≥ 0.98, false alarms ≤ 1e-4 of clean samples, corrected
    // RMSE ≤ 1.1× that of the spike-free signal — here the spike-free signal is the truth itself,
    // so the RMSE check is against the raw series: it must drop by ≥ 5×.
    let spec = SyntheticSpec {
        ramp_min_samples: 200,
        ..SyntheticSpec::drive_gyro_quiet_start(300_000, 12, 12.0)
    };
    let stream = synthetic_stream(&spec);
    let run = run_stage(&stream.observed, &GrossErrorSettings::default(), GZ).unwrap();
    let sc = score_run(&run, &stream);
    assert!(sc.f1 >= 0.98, "{sc:?}");
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
fn static_stream_meets_the_false_alarm_target_and_catches_six_sigma_spikes() {
    let stream = synthetic_stream(&SyntheticSpec::static_gyro(300_000, 13));
    let run = run_stage(&stream.observed, &GrossErrorSettings::default(), GZ).unwrap();
    let sc = score_run(&run, &stream);
    assert!(sc.false_alarm_rate <= 1e-4, "{sc:?}");
    assert!(sc.recall >= 0.99, "{sc:?}");
    assert!(sc.f1 >= 0.98, "{sc:?}");
}

#[test]
fn settings_validate_reports_every_problem_and_round_trip_toml() {
    let bad = GrossErrorSettings {
        k: -1.0,
        max_run: 0,
        median_window: 4,
        level_alpha: 2.0,
        warmup_samples: 10,
        ..Default::default()
    };
    match GrossErrorStage::new(bad, None) {
        Err(GrossErrorError::InvalidSettings(v)) => assert_eq!(v.len(), 5, "{v:?}"),
        other => panic!("{other:?}"),
    }
    let s = GrossErrorSettings::default();
    let text = toml::to_string(&s).unwrap();
    let back: GrossErrorSettings = toml::from_str(&text).unwrap();
    assert_eq!(back, s);
    assert!(toml::from_str::<GrossErrorSettings>("kk = 3.0").is_err());
    // Partial files take the documented defaults.
    let partial: GrossErrorSettings = toml::from_str("k = 5.0").unwrap();
    assert_eq!(partial.max_run, 10);
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
