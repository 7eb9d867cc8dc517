//! Tests of the bias model file: parsing, validation, the FOS and effect forms.

use super::*;
use crate::model::fos::FosSettings;
use crate::model::fos_model::FosModelSpec;
use crate::rng::{Rng, ar_series};

/// One-step prediction of the file's AR model: `mean + sum ar[i-1] (y[n-i] - mean)`, with
/// `history` newest last (at least `ar.len()` values).
fn ar_predict(m: &ChannelBiasModel, history: &[f64]) -> f64 {
    let n = history.len();
    m.mean
        + m.ar
            .iter()
            .enumerate()
            .map(|(i, a)| a * (history[n - 1 - i] - m.mean))
            .sum::<f64>()
}

fn assert_same_prediction(m: &ChannelBiasModel, fos: &FosModel, history: &[f64]) {
    let p_ar = ar_predict(m, history);
    let p_fos = fos.predict_next(history, &[]);
    assert!(
        (p_ar - p_fos).abs() <= 1e-9 * p_fos.abs().max(1e-300),
        "AR {p_ar} vs FOS {p_fos} (diff {:e})",
        p_ar - p_fos
    );
}

#[test]
fn linear_fos_converts_to_the_same_ar_predictor() {
    // Seed 20240605: y(n) = 3 + x(n), x(n) = 0.6 x(n-1) + 0.25 x(n-2) + 0.1 e(n), 20 000
    // samples; FOS CP=1, L=10 as `fit --bias-method fos` runs it.
    let y: Vec<f64> = ar_series(&mut Rng::new(20_240_605), 20_000, &[0.6, 0.25], 0.1)
        .into_iter()
        .map(|x| 3.0 + x)
        .collect();
    let l = 10;
    let (fos, _) =
        FosModel::fit(&y, &[], &FosModelSpec::paper(l, 1), &FosSettings::default()).unwrap();
    let r = fos.residuals(&y, &[], l..y.len());
    let mse = r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64;
    let m = ChannelBiasModel::from_linear_fos("gz", 100.0, &fos, mse).unwrap();
    assert_eq!(m.method, "fos");
    assert_eq!(m.ar_of, ArOf::Signal);
    assert_eq!(m.innovation_var, mse);
    let file = BiasModelFile {
        channels: vec![m.clone()],
    };
    file.validate().unwrap();
    // Exactly the FOS predictor, on the fit data and on histories far from it.
    for n in (l..y.len()).step_by(97) {
        assert_same_prediction(&m, &fos, &y[..n]);
    }
    let odd: Vec<f64> = (0..l).map(|i| -7.0 + 1.3 * i as f64).collect();
    assert_same_prediction(&m, &fos, &odd);
    // And it is the generating model, to sampling accuracy (sd of phi ~ 0.007).
    assert!(m.ar.len() >= 2 && m.ar.len() <= l, "{:?}", m.ar);
    assert!((m.ar[0] - 0.6).abs() < 0.04, "{:?}", m.ar);
    assert!((m.ar[1] - 0.25).abs() < 0.04, "{:?}", m.ar);
    assert!((m.mean - 3.0).abs() < 0.05, "{}", m.mean);
    assert!((mse / 0.01 - 1.0).abs() < 0.05, "{mse}");
}

#[test]
fn linear_fos_conversion_maps_the_constant_through_the_standardisation() {
    // u(n) = 0.3 + 0.5 u(n-1) + 0.2 u(n-3), u = (y - 10) / 2: y(n) = 10 (1 - 0.7) + 0.6
    // + 0.5 y(n-1) + 0.2 y(n-3), level 3.6 / 0.3 = 12; lag 2 unselected → 0.
    let fos = FosModel {
        terms: vec![
            TermSpec::Lag { lag: 3 },
            TermSpec::Constant,
            TermSpec::Lag { lag: 1 },
        ],
        coefficients: vec![0.2, 0.3, 0.5],
        center: 10.0,
        scale: 2.0,
        exo_center: vec![],
        exo_scale: vec![],
    };
    let m = ChannelBiasModel::from_linear_fos("ax", 200.0, &fos, 1e-4).unwrap();
    assert_eq!(m.ar, vec![0.5, 0.0, 0.2]);
    assert!((m.mean - 12.0).abs() < 1e-12, "{}", m.mean);
    for h in [[1.0, 2.0, 3.0], [12.0, 12.0, 12.0], [-40.0, 0.5, 1e3]] {
        assert_same_prediction(&m, &fos, &h);
    }
}

#[test]
fn non_linear_exogenous_and_unit_root_fos_models_are_rejected() {
    let model = |terms: Vec<TermSpec>, coefficients: Vec<f64>| FosModel {
        terms,
        coefficients,
        center: 0.0,
        scale: 1.0,
        exo_center: vec![0.0],
        exo_scale: vec![1.0],
    };
    let cp = model(
        vec![
            TermSpec::Lag { lag: 1 },
            TermSpec::CrossProduct { lag1: 1, lag2: 2 },
        ],
        vec![0.5, 0.1],
    );
    let e = ChannelBiasModel::from_linear_fos("gx", 100.0, &cp, 1e-6).unwrap_err();
    assert!(e.contains("y(n-1)*y(n-2)") && e.contains("linear"), "{e}");
    let exo = model(vec![TermSpec::ExoLag { input: 0, lag: 0 }], vec![0.5]);
    let e = ChannelBiasModel::from_linear_fos("gx", 100.0, &exo, 1e-6).unwrap_err();
    assert!(e.contains("x0(n-0)") && e.contains("exogenous"), "{e}");
    let unit_root = model(
        vec![
            TermSpec::Constant,
            TermSpec::Lag { lag: 1 },
            TermSpec::Lag { lag: 2 },
        ],
        vec![0.01, 1.2, -0.2],
    );
    let e = ChannelBiasModel::from_linear_fos("gx", 100.0, &unit_root, 1e-6).unwrap_err();
    assert!(e.contains("unit root"), "{e}");
}

fn example() -> BiasModelFile {
    BiasModelFile {
        channels: vec![
            ChannelBiasModel {
                channel: "gz".into(),
                method: "burg".into(),
                sample_rate_hz: 100.0,
                mean: 1.25e-3,
                ar: vec![0.61, 0.3],
                innovation_var: 3.1e-6,
                white_noise_var: 3.0e-6,
                ar_of: ArOf::Signal,
                effects: vec![
                    Effect::Temperature(TemperatureTerm {
                        t0_c: 25.0,
                        c1_per_c: 1e-4,
                        c2_per_c2: -2e-6,
                        lag_s: 30.0,
                    }),
                    Effect::VibrationLine {
                        freq_hz: 23.37,
                        amplitude: 0.01,
                        phase_rad: 0.5,
                    },
                    Effect::Step {
                        t_s: 120.5,
                        size: 0.004,
                    },
                    Effect::GSensitivity {
                        coeffs_per_m_s2: [1e-4, 0.0, -2e-4],
                    },
                    Effect::RateRandomWalk { q_per_s: 1e-10 },
                ],
            },
            ChannelBiasModel {
                channel: "ax".into(),
                method: "fos".into(),
                sample_rate_hz: 100.0,
                mean: 0.3,
                ar: vec![],
                innovation_var: 1e-3,
                white_noise_var: 0.0,
                ar_of: ArOf::Bias,
                effects: vec![],
            },
        ],
    }
}

#[test]
fn model_toml_round_trips_exactly() {
    let m = example();
    let text = m.to_toml_string().unwrap();
    let back = BiasModelFile::from_toml_str(&text).unwrap();
    assert_eq!(m, back, "TOML:\n{text}");
}

/// One hand-written channel without effects (the tests below append keys to it).
const ONE_CHANNEL: &str = r#"
    [[channels]]
    channel = "gx"
    method = "yule_walker"
    sample_rate_hz = 100.0
    mean = 0.001
    ar = [0.9]
    innovation_var = 1e-6
    white_noise_var = 3e-6
"#;

#[test]
fn hand_written_toml_with_inline_effects_parses() {
    let effects = r#"effects = [ { kind = "vibration_line", freq_hz = 12.3, amplitude = 0.02, phase_rad = 0.0 },
                                 { kind = "rate_random_walk", q_per_s = 1e-12 },
                                 { kind = "temperature", t0_c = 25.0, c1_per_c = 1e-4, c2_per_c2 = 0.0, lag_s = 30.0 } ]"#;
    let m = BiasModelFile::from_toml_str(&format!("{ONE_CHANNEL}{effects}")).unwrap();
    assert_eq!(
        m.channels[0].ar_of,
        ArOf::Signal,
        "ar_of defaults to signal"
    );
    assert_eq!(m.channels[0].effects.len(), 3);
    // The temperature term keeps its flat keys beside `kind` (the file format of every earlier
    // model file), though it is its own type in the code.
    assert_eq!(
        m.channels[0].effects[2],
        Effect::Temperature(TemperatureTerm {
            t0_c: 25.0,
            c1_per_c: 1e-4,
            c2_per_c2: 0.0,
            lag_s: 30.0,
        })
    );
}

#[test]
fn unknown_fields_are_rejected() {
    let base = ONE_CHANNEL;
    // The base alone parses: each rejection below is the extra key's.
    assert!(BiasModelFile::from_toml_str(base).is_ok());
    for extra in [
        r#"colour = "blue""#,
        r#"effects = [ { kind = "step", t_s = 1.0, size = 0.1, extra = 2 } ]"#,
        r#"effects = [ { kind = "temperature", t0_c = 25.0, c1_per_c = 1e-4, c2_per_c2 = 0.0, lag_s = 30.0, extra = 2 } ]"#,
    ] {
        assert!(
            matches!(
                BiasModelFile::from_toml_str(&format!("{base}{extra}\n")),
                Err(BiasModelError::Parse(_))
            ),
            "{extra}"
        );
    }
}

#[test]
fn validation_lists_every_problem_with_its_key() {
    let mut m = example();
    m.channels[0].ar = vec![1.5]; // non-stationary
    m.channels[0].innovation_var = -1.0;
    m.channels[1].effects.push(Effect::GSensitivity {
        coeffs_per_m_s2: [0.0; 3],
    }); // accel
    m.channels[1].effects.push(Effect::VibrationLine {
        freq_hz: 70.0,
        amplitude: 1.0,
        phase_rad: 0.0,
    });
    m.channels.push(m.channels[1].clone()); // duplicate "ax"
    let errs = m.validate().unwrap_err();
    let joined = errs.join("\n");
    for key in [
        "channels[0].ar:",
        "channels[0].innovation_var:",
        "channels[1].effects[0]: g_sensitivity",
        "channels[1].effects[1].freq_hz:",
        "channels[2].channel: `ax` appears more than once",
    ] {
        assert!(joined.contains(key), "missing `{key}` in:\n{joined}");
    }
}
