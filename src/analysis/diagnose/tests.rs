//! Tests of the loop on seeded synthetic logs (one undeclared effect each, two at once, clean).
//!
//! "The effect's own power" is measured in the loop's own metric by the clean twin: the same log
//! with the same noise streams and without the effect. Its power is
//! P = MSE_test(first model on the log) − MSE_test(first model on the twin), and the loop must
//! lower the test MSE by at least 0.9 P. Parameter tolerances are the (frequency ±0.01 Hz,
//! temperature coefficients ±5 %, step time ±1 s and size ±10 %, g-sensitivity ±10 %); each test
//! states why its effect size makes them reachable.

use super::*;
use crate::analysis::synth_test::{SynthLog, SynthSpec, generate};
use crate::model::bias_model::{Effect, TemperatureTerm};

fn run_on(log: &SynthLog, y: &[f64]) -> ChannelDiagnosis {
    let f = &log.specific_force;
    let input = ChannelInput {
        name: "gz",
        values: y,
        rate_hz: 100.0,
        exogenous: Exogenous {
            temperature_c: Some(&log.temperature_c),
            specific_force_m_s2: Some([&f[0], &f[1], &f[2]]),
            other_axes: &[],
        },
    };
    diagnose_channel(&input, &DiagnoseSettings::default()).unwrap()
}

/// Run the loop on the log and on its clean twin; check the MSE reduction against the effect's
/// own power in the one-step metric (and, for deterministic effects, the open-loop metric).
fn run_and_check_power(log: &SynthLog, open_loop_too: bool) -> ChannelDiagnosis {
    let d = run_on(log, &log.y);
    let twin = run_on(log, &log.clean_twin());
    let text = crate::analysis::diagnose::report::channel_text(&d);
    assert!(
        twin.iterations.is_empty(),
        "clean twin got effects: {:?}",
        twin.effects
    );
    let p1 = d.baseline.mse_one_step - twin.baseline.mse_one_step;
    let got1 = d.baseline.mse_one_step - d.final_metrics.mse_one_step;
    assert!(
        p1 > 0.0 && got1 >= 0.9 * p1,
        "one-step: removed {got1:.4e} of power {p1:.4e}\n{text}"
    );
    if open_loop_too {
        let p2 = d.baseline.mse_open_loop - twin.baseline.mse_open_loop;
        let got2 = d.baseline.mse_open_loop - d.final_metrics.mse_open_loop;
        assert!(
            p2 > 0.0 && got2 >= 0.9 * p2,
            "open-loop: removed {got2:.4e} of power {p2:.4e}\n{text}"
        );
    }
    d
}

/// The one effect the loop finds on `s`, checked to be of `family` and to remove its power.
fn only_effect(s: &SynthSpec, family: &str) -> Effect {
    let d = run_and_check_power(&generate(s), true);
    assert_eq!(families(&d), [family]);
    d.effects[0].clone()
}

/// Families of the final model, in the order they were added.
fn families(d: &ChannelDiagnosis) -> Vec<&str> {
    d.effects
        .iter()
        .map(|e| match e {
            Effect::VibrationLine { .. } => "vibration_line",
            Effect::Temperature(_) => "temperature",
            Effect::Step { .. } => "bias_step",
            Effect::GSensitivity { .. } => "g_sensitivity",
            Effect::RateRandomWalk { .. } => "rate_random_walk",
        })
        .collect()
}

#[test]
fn vibration_line_off_the_grid_is_found_named_and_removed() {
    // 12.3456 Hz lies 0.34 of a train bin (1/180 Hz) off the FFT grid. Amplitude 0.5 in unit
    // white noise: the frequency CRLB on 6 min is ~1e-5 Hz, so ±0.01 Hz (the target) is
    // loose; amplitude sd ≈ √(2 S(f)/N) ≈ 0.008 on the whole log, so ±10 % (0.05) is 6 sd and
    // the phase sd ≈ 0.008/0.5 = 0.016 rad (±0.2 rad is 12 sd).
    let mut s = SynthSpec::clean(101);
    s.line = Some((12.3456, 0.5, 0.3));
    let Effect::VibrationLine {
        freq_hz,
        amplitude,
        phase_rad,
    } = only_effect(&s, "vibration_line")
    else {
        panic!()
    };
    assert!((freq_hz - 12.3456).abs() < 0.01, "{freq_hz}");
    assert!((amplitude - 0.5).abs() < 0.05, "{amplitude}");
    assert!((phase_rad - 0.3).abs() < 0.2, "{phase_rad}");
    eprintln!(
        "line: f error {:.2e} Hz, A {amplitude:.4}, phase {phase_rad:.3}",
        freq_hz - 12.3456
    );
}

#[test]
fn temperature_bias_on_a_warm_up_is_found_with_its_coefficients() {
    // b = 0.2 (T_lag − 30) + 0.02 (T_lag − 30)², lag 15 s, on a 15 → 37 °C warm-up with a
    // 1.5 °C thermostat cycle (the cycle makes the lag identifiable). The precision is set by
    // the part of each regressor the others do not explain, seen through the noise's low-frequency
    // density S(0) ≈ 3.5: the component of (T − T0)² orthogonal to T − T0 has sd ≈ 35 °C², so
    // sd(ĉ2) ≈ √(S(0)/N)/35 ≈ 2.2e-4 on the 60 000-sample deployment refit, 1.1 % of c2; c1 about
    // 0.7 %. (With c2 = 0.004 that sd is 5.5 % and ±5 % fails one seed in three: measured by
    // `temperature_coefficient_spread_over_seeds`.) ±5 % is > 4 sd here.
    let mut s = SynthSpec::clean(202);
    s.temperature = Some((30.0, 0.2, 0.02, 15.0));
    let Effect::Temperature(TemperatureTerm {
        t0_c,
        c1_per_c,
        c2_per_c2,
        lag_s,
    }) = only_effect(&s, "temperature")
    else {
        panic!()
    };
    // Re-centre the fitted polynomial at the truth's T0 = 30 °C.
    let c1_at_30 = c1_per_c + 2.0 * c2_per_c2 * (30.0 - t0_c);
    assert!((c1_at_30 / 0.2 - 1.0).abs() < 0.05, "c1 {c1_at_30}");
    assert!((c2_per_c2 / 0.02 - 1.0).abs() < 0.05, "c2 {c2_per_c2}");
    assert!((lag_s - 15.0).abs() <= 3.0, "lag {lag_s}");
    eprintln!("temperature: c1 {c1_at_30:.5} c2 {c2_per_c2:.6} lag {lag_s}");
}

#[test]
fn bias_step_is_found_with_time_and_size() {
    // A step of 1.0 at t = 100 s (inside train). Long-run sd of the noise √S(0) ≈ 1.9: location
    // error ~ S(0)/Δ² ≈ 4 samples (±1 s = 100 samples), GLS size sd ≈ 1.9·√(1/10⁴ + 1/2.6·10⁴)
    // ≈ 0.022, so ±10 % is 4.5 sd.
    let mut s = SynthSpec::clean(303);
    s.step = Some((100.0, 1.0));
    let Effect::Step { t_s, size } = only_effect(&s, "bias_step") else {
        panic!()
    };
    assert!((t_s - 100.0).abs() <= 1.0, "{t_s}");
    assert!((size - 1.0).abs() < 0.1, "{size}");
}

#[test]
fn gyro_g_sensitivity_during_a_drive_is_found() {
    // k = [0.2, −0.15, 0.3] per m/s² on surge/sway/heave of sd 1.5/1.0/0.7 m/s²: effect sd ≈ 0.4.
    // GLS sd of k_z ≈ √S(f)/(σ_fz √N) ≈ 1.3/(0.7·190) ≈ 0.01 (3 % of 0.3); ±10 % is > 3 sd.
    let mut s = SynthSpec::clean(404);
    s.gsens = Some([0.3, -0.3, 0.4]);
    let Effect::GSensitivity { coeffs_per_m_s2: k } = only_effect(&s, "g_sensitivity") else {
        panic!()
    };
    for (got, want) in k.iter().zip([0.3, -0.3, 0.4]) {
        assert!((got / want - 1.0).abs() < 0.1, "{k:?}");
    }
}

#[test]
fn rate_random_walk_is_found_and_named() {
    // q = 0.01 units²/s: the walk reaches ~2.4 units sd over 10 min and crosses the white
    // Allan deviation at τ ≈ 17 s; the loop must name it from the +½ slope and add the level.
    let mut s = SynthSpec::clean(505);
    s.rrw_q_per_s = Some(0.01);
    let log = generate(&s);
    let d = run_and_check_power(&log, false);
    assert_eq!(
        families(&d),
        ["rate_random_walk"],
        "{}",
        crate::analysis::diagnose::report::channel_text(&d)
    );
    let Effect::RateRandomWalk { q_per_s } = d.effects[0] else {
        panic!()
    };
    assert!(q_per_s > 0.0);
    eprintln!("rrw: q {q_per_s:.4e}");
}

#[test]
fn two_undeclared_effects_are_both_found_in_order_of_size() {
    // A line (A = 0.8) and a step (1.0 at 100 s) in one log. Their sizes are measured one by
    // one with single-effect twins (same noise): the line's one-step power is several times the
    // step's, so the loop must add the line first, then the step.
    let spec = |line: bool, step: bool| {
        let mut s = SynthSpec::clean(606);
        s.line = line.then_some((7.7777, 0.8, -1.0));
        s.step = step.then_some((100.0, 1.0));
        generate(&s)
    };
    let both = spec(true, true);
    let d = run_on(&both, &both.y);
    let base = |log: &SynthLog| run_on(log, &log.y).baseline.mse_one_step;
    let clean = base(&spec(false, false));
    let p_line = base(&spec(true, false)) - clean;
    let p_step = base(&spec(false, true)) - clean;
    assert!(p_line > p_step && p_step > 0.0, "{p_line} {p_step}");
    assert_eq!(
        families(&d),
        ["vibration_line", "bias_step"],
        "{}",
        crate::analysis::diagnose::report::channel_text(&d)
    );
    // Each iteration's gain is ordered the same way.
    assert!(d.iterations[0].score.q > d.iterations[1].score.q);
}

#[test]
#[ignore = "50 full loops: ~1 min in release, too slow for debug; run with --release --ignored"]
fn clean_logs_get_no_invented_effects() {
    // White noise + the declared AR(1) bias, with a temperature warm-up and drive accelerations
    // offered as exogenous series but not acting. Each iteration tests at a family-wise 0.01, and
    // the out-of-sample test is conservative, so the per-log false-discovery rate is ≤ 0.01.
    // Over 50 seeds, X ~ Binomial(50, ≤ 0.01): P(X ≥ 4) ≤ 0.0016, so more than 3 logs with an
    // invented effect would reject the claimed rate.
    let mut bad = Vec::new();
    for seed in 0..50u64 {
        let log = generate(&SynthSpec::clean(10_000 + seed));
        let d = run_on(&log, &log.y);
        if !d.iterations.is_empty() {
            bad.push((seed, families(&d).join(",")));
        }
    }
    eprintln!("false discoveries: {} of 50 logs: {bad:?}", bad.len());
    assert!(bad.len() <= 3, "{bad:?}");
}

#[test]
fn split_follows_the_paper_and_scales_short_logs() {
    // 10 min at 100 Hz: 3 min / 3 min / rest; 5 min: 30 % / 30 % / 40 %; too short: an error.
    let s = DiagnoseSettings::default();
    let a = split(60_000, 100.0, &s).unwrap();
    assert_eq!(
        (a.train, a.validation, a.test, a.proportional),
        (0..18_000, 18_000..36_000, 36_000..60_000, false)
    );
    let b = split(30_000, 100.0, &s).unwrap();
    assert_eq!(
        (b.train, b.validation, b.test, b.proportional),
        (0..9000, 9000..18_000, 18_000..30_000, true)
    );
    assert!(split(500, 100.0, &s).is_err());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let mut y = vec![0.0; 5000];
    y[100] = f64::NAN;
    let input = ChannelInput {
        name: "gx",
        values: &y,
        rate_hz: 100.0,
        exogenous: Exogenous::default(),
    };
    assert!(diagnose_channel(&input, &DiagnoseSettings::default()).is_err());
    let t = vec![20.0; 10];
    let y = vec![0.0; 5000];
    let input = ChannelInput {
        name: "gx",
        values: &y,
        rate_hz: 100.0,
        exogenous: Exogenous {
            temperature_c: Some(&t),
            ..Exogenous::default()
        },
    };
    assert!(diagnose_channel(&input, &DiagnoseSettings::default()).is_err());
}

#[test]
fn report_serialises_with_contract_effects_and_renders_plots() {
    // A short (5-min, proportional split) log with a strong line: the JSON carries the contract's
    // tagged Effect, the text names it, and the plots (spectrum, Allan, one overlay) render.
    let mut s = SynthSpec::clean(707);
    s.n = 30_000;
    s.line = Some((23.4567, 1.0, 0.0));
    let log = generate(&s);
    let d = run_on(&log, &log.y);
    let rep = crate::analysis::diagnose::report::DiagnoseReport {
        source: "synthetic".into(),
        channels: vec![d],
        warnings: vec![],
    };
    let json = rep.to_json().unwrap();
    assert!(json.contains("\"kind\": \"vibration_line\""), "{json}");
    assert!(rep.to_text().contains("vibration line f = 23.45"));
    let plots = crate::analysis::diagnose::report::channel_plots(&rep.channels[0]).unwrap();
    let names: Vec<&str> = plots.iter().map(|p| p.0.as_str()).collect();
    assert_eq!(
        names,
        ["gz_spectrum", "gz_allan", "gz_effect1_vibration_line"]
    );
    assert!(plots.iter().all(|p| p.1.contains("</svg>")));
}

#[test]
#[ignore = "8 full loops; run with --release --ignored --nocapture to print the spread"]
fn temperature_coefficient_spread_over_seeds() {
    // Measures (and bounds) the spread behind the ±5 % tolerance of the temperature test.
    let mut worst = (0.0f64, 0.0f64);
    for seed in 0..8u64 {
        let mut s = SynthSpec::clean(2000 + seed);
        s.temperature = Some((30.0, 0.2, 0.02, 15.0));
        let log = generate(&s);
        let d = run_on(&log, &log.y);
        let Some(Effect::Temperature(TemperatureTerm {
            t0_c,
            c1_per_c,
            c2_per_c2,
            lag_s,
        })) = d
            .effects
            .iter()
            .find(|e| matches!(e, Effect::Temperature(_)))
            .cloned()
        else {
            panic!(
                "seed {seed}: no temperature effect\n{}",
                crate::analysis::diagnose::report::channel_text(&d)
            )
        };
        let e1 = (c1_per_c + 2.0 * c2_per_c2 * (30.0 - t0_c)) / 0.2 - 1.0;
        let e2 = c2_per_c2 / 0.02 - 1.0;
        eprintln!(
            "seed {seed}: c1 err {:+.2} %, c2 err {:+.2} %, lag {lag_s} s",
            100.0 * e1,
            100.0 * e2
        );
        worst = (worst.0.max(e1.abs()), worst.1.max(e2.abs()));
    }
    assert!(worst.0 < 0.05 && worst.1 < 0.05, "{worst:?}");
}
