use super::*;
use crate::rng::Rng;

/// ARMA(p, q) with intercept, simulated with `burn` discarded samples.
fn simulate(c: f64, ar: &[f64], ma: &[f64], sigma: f64, n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let burn = 500;
    let mut x: Vec<f64> = Vec::with_capacity(n + burn);
    let mut e: Vec<f64> = Vec::with_capacity(n + burn);
    for t in 0..n + burn {
        let et = sigma * rng.normal();
        let mut v = c + et;
        for (i, a) in ar.iter().enumerate() {
            if t > i {
                v += a * x[t - 1 - i];
            }
        }
        for (j, b) in ma.iter().enumerate() {
            if t > j {
                v += b * e[t - 1 - j];
            }
        }
        x.push(v);
        e.push(et);
    }
    x.split_off(burn)
}

#[test]
fn ma_invertibility_matches_the_closed_form_region() {
    // MA(1) 1 + θz invertible iff |θ| < 1 (the AR regions are tested in stats::ar_poly).
    assert!(ma_is_invertible(&[-0.9]));
    assert!(!ma_is_invertible(&[1.2]));
}

#[test]
fn css_ar1_equals_ols_closed_form() {
    // For q = 0, CSS is OLS of x_t on (1, x_{t−1}); compare with the textbook formulas.
    let x = simulate(0.3, &[0.6], &[], 1.0, 3000, 21);
    let f = fit_arima(&x, 1, 0, 0, &CssOptions::default()).unwrap();
    let (xs, ys) = (&x[..x.len() - 1], &x[1..]);
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(ys).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = xs.iter().map(|a| (a - mx) * (a - mx)).sum();
    let phi = sxy / sxx;
    let c = my - phi * mx;
    // LM on a quadratic objective lands on the normal-equation solution to ~1e-10.
    assert!((f.ar[0] - phi).abs() < 1e-9, "{} vs {phi}", f.ar[0]);
    assert!((f.constant - c).abs() < 1e-9);
    assert!(f.converged);
}

#[test]
fn css_recovers_arma11_parameters() {
    // N = 20 000: asymptotic sd of φ̂, θ̂ for φ = 0.5, θ = 0.3 is ~√((1−φ²)(1+φθ)²/(φ+θ)²/N)
    // ≈ 0.009; 0.04 is > 4 sd.
    let x = simulate(0.2, &[0.5], &[0.3], 0.5, 20_000, 7);
    let f = fit_arima(&x, 1, 0, 1, &CssOptions::default()).unwrap();
    assert!((f.ar[0] - 0.5).abs() < 0.04, "phi {}", f.ar[0]);
    assert!((f.ma[0] - 0.3).abs() < 0.04, "theta {}", f.ma[0]);
    assert!(
        (f.sigma2.sqrt() - 0.5).abs() < 0.01,
        "sigma {}",
        f.sigma2.sqrt()
    );
    assert!((f.mean() - 0.4).abs() < 0.05, "mean {}", f.mean());
    assert!(f.converged);
}

#[test]
fn identify_picks_d1_for_a_random_walk_with_ar_increments() {
    // ∇x is AR(1) φ = 0.6: ADF cannot reject the unit root, so d = 1, and the AIC grid finds
    // φ ≈ 0.6 (sd ≈ 0.8/√5000 ≈ 0.011; 0.05 is > 4 sd) with white residuals.
    let w = simulate(0.0, &[0.6], &[], 1.0, 5000, 9);
    let mut acc = 0.0;
    let x: Vec<f64> = w
        .iter()
        .map(|v| {
            acc += v;
            acc
        })
        .collect();
    let id = identify(&x, &IdentifySettings::default()).unwrap();
    assert_eq!(id.fit.d, 1);
    assert!(id.diagnostics.adf.p_value > 0.05);
    assert_eq!(id.diagnostics.aic_table.len(), 12);
    assert!(id.fit.p >= 1, "p = {}", id.fit.p);
    // Whatever the chosen (p, q), its one-step residual sd matches the true innovation sd.
    assert!((id.fit.sigma2.sqrt() - 1.0).abs() < 0.03);
    assert!(
        id.diagnostics.ljung_box.p_value > 0.01,
        "{:?}",
        id.diagnostics.ljung_box
    );
    assert_eq!(id.diagnostics.suggested_p, 1);
}

#[test]
fn identify_picks_d0_and_white_noise_for_white_noise() {
    let mut rng = Rng::new(4);
    let x: Vec<f64> = (0..4000).map(|_| 2.0 + 0.1 * rng.normal()).collect();
    let id = identify(&x, &IdentifySettings::default()).unwrap();
    assert_eq!(id.fit.d, 0);
    // AIC's penalty makes (0,0) the usual winner; any chosen model must predict no better
    // than white noise can: σ within 3 % of 0.1 (sd of σ̂ ≈ 0.1/√8000 ≈ 0.0011).
    assert!((id.fit.sigma2.sqrt() - 0.1).abs() < 0.003);
    assert!((id.fit.mean() - 2.0).abs() < 0.01);
}

#[test]
fn identify_rejects_bad_input_with_errors() {
    assert!(matches!(
        identify(&[1.0; 10], &IdentifySettings::default()),
        Err(ArimaError::Numeric(NumError::TooShort { .. }))
    ));
    let mut x: Vec<f64> = (0..500).map(|i| (i as f64 * 0.1).sin()).collect();
    x[17] = f64::NAN;
    assert!(matches!(
        identify(&x, &IdentifySettings::default()),
        Err(ArimaError::Numeric(NumError::NonFinite { index: 17 }))
    ));
    let bad = IdentifySettings {
        d_max: 2,
        adf_alpha: 1.5,
        ..Default::default()
    };
    match identify(&x, &bad) {
        Err(ArimaError::InvalidSettings(v)) => assert_eq!(v.len(), 2, "{v:?}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn predictor_reproduces_css_residuals() {
    // With level_alpha = 0 the fixed-size predictor is the model: its innovations on the fit
    // data equal the CSS residuals once the same start (history = data, e = 0) is used.
    let x = simulate(0.1, &[0.5, -0.2], &[0.4], 1.0, 2000, 13);
    let f = fit_arima(&x, 2, 0, 1, &CssOptions::default()).unwrap();
    let model = ArimaChannelModel {
        channel: "gz".into(),
        p: 2,
        d: 0,
        q: 1,
        constant: f.constant,
        ar: f.ar.clone(),
        ma: f.ma.clone(),
        sigma: f.sigma2.sqrt(),
        line_per_sample: None,
        diagnostics: None,
    };
    let resid = css_residuals(&x, f.constant, &f.ar, &f.ma, 2);
    let mut pr = ArimaPredictor::new(&model, 0.0, 0.0).unwrap();
    pr.reseed(&[x[1], x[0]]);
    for t in 2..x.len() {
        let e = x[t] - pr.predict();
        // Same recursion, different summation order: 1e-12 absolute on O(1) values.
        assert!(
            (e - resid[t - 2]).abs() < 1e-12,
            "t = {t}: {e} vs {}",
            resid[t - 2]
        );
        pr.update(x[t], e);
    }
}

#[test]
fn predictor_d1_predicts_last_value_plus_drift_for_random_walk() {
    let model = ArimaChannelModel {
        channel: "gx".into(),
        p: 0,
        d: 1,
        q: 0,
        constant: 0.01,
        ar: vec![],
        ma: vec![],
        sigma: 1.0,
        line_per_sample: None,
        diagnostics: None,
    };
    let mut pr = ArimaPredictor::new(&model, 0.5, 0.0).unwrap();
    pr.reseed(&[3.0]);
    assert_eq!(pr.predict(), 3.01);
    pr.update(4.0, 0.99);
    assert_eq!(pr.predict(), 4.01);
}

#[test]
fn psi_weights_are_closed_form_for_arma11_and_random_walk() {
    // ARMA(1,1): ψ_0 = 1, ψ_j = (φ+θ) φ^{j−1}. Random walk (0,1,0): ψ_j = 1. ARIMA(1,1,0):
    // ψ_j = (1 − φ^{j+1})/(1 − φ).
    let mut m = ArimaChannelModel {
        channel: "gz".into(),
        p: 1,
        d: 0,
        q: 1,
        constant: 0.0,
        ar: vec![0.5],
        ma: vec![0.3],
        sigma: 1.0,
        line_per_sample: None,
        diagnostics: None,
    };
    let mut psi = [0.0; 6];
    psi_weights(&m, &mut psi);
    for (j, v) in psi.iter().enumerate() {
        let want = if j == 0 {
            1.0
        } else {
            0.8 * 0.5f64.powi(j as i32 - 1)
        };
        assert!((v - want).abs() < 1e-15, "ψ_{j} = {v}");
    }
    m.d = 1;
    m.q = 0;
    m.ma = vec![];
    psi_weights(&m, &mut psi);
    for (j, v) in psi.iter().enumerate() {
        let want = (1.0 - 0.5f64.powi(j as i32 + 1)) / 0.5;
        assert!((v - want).abs() < 1e-15, "ψ_{j} = {v}");
    }
    m.p = 0;
    m.ar = vec![];
    psi_weights(&m, &mut psi);
    assert!(psi.iter().all(|v| *v == 1.0));
}

#[test]
fn model_file_round_trips_toml_and_rejects_unknown_fields() {
    let x = simulate(0.0, &[0.4], &[0.2], 1.0, 1500, 2);
    let id = identify(&x, &IdentifySettings::default()).unwrap();
    let file = ArimaModelFile {
        channels: vec![id.to_channel_model("gz")],
    };
    let s = file.to_toml_string().unwrap();
    let back = ArimaModelFile::from_toml_str(&s).unwrap();
    assert_eq!(back, file);
    let bad = s.replacen("sigma =", "sigmaa = 1.0\nsigma =", 1);
    assert!(matches!(
        ArimaModelFile::from_toml_str(&bad),
        Err(ArimaError::Toml(_))
    ));
    // A hand-written model without diagnostics loads.
    let hand = "[[channels]]\nchannel = \"gx\"\np = 1\nd = 0\nq = 0\nconstant = 0.0\nar = [0.5]\nma = []\nsigma = 0.01\n";
    let f = ArimaModelFile::from_toml_str(hand).unwrap();
    assert_eq!(f.channel("gx").unwrap().ar, vec![0.5]);
    // An inconsistent one does not.
    let wrong = hand.replace("ar = [0.5]", "ar = [1.5]");
    assert!(ArimaModelFile::from_toml_str(&wrong).is_err());
    // A line taken out before identification: its frequency, cycles per sample, round-trips;
    // one that is no frequency below Nyquist is refused with the field named.
    let lined = format!("{hand}line_per_sample = 0.22\n");
    let f = ArimaModelFile::from_toml_str(&lined).unwrap();
    assert_eq!(f.channel("gx").unwrap().line_per_sample, Some(0.22));
    let back = ArimaModelFile::from_toml_str(&f.to_toml_string().unwrap()).unwrap();
    assert_eq!(back, f);
    for bad in ["0.5", "0.0", "-0.1", "nan"] {
        let e = ArimaModelFile::from_toml_str(&format!("{hand}line_per_sample = {bad}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line_per_sample"), "{bad}: {e}");
    }
}

/// One-step innovations of `model` on `x[from..]` (predictor started on `x[..from]`), with the
/// centre fixed (`level_alpha` 0: exactly the model) or tracked as the gross-error stage does.
fn one_step_mse(model: &ArimaChannelModel, x: &[f64], from: usize, level_alpha: f64) -> f64 {
    let mut pr = ArimaPredictor::new(model, level_alpha, 0.0).unwrap();
    let mut seed: Vec<f64> = x[from - 5..from].to_vec();
    seed.reverse();
    pr.reseed(&seed);
    let mut s = 0.0;
    for &v in &x[from..] {
        let e = v - pr.predict();
        s += e * e;
        pr.update(v, e);
    }
    s / (x.len() - from) as f64
}

/// A channel carrying a vibration line (a 22-Hz sine at 100 Hz, amplitude 10× the noise, on
/// AR(1) noise): the ARMA that models the line has its AR part on the stationarity boundary
/// (a complex root pair on the unit circle). It used to be refused like an MA-boundary fit, and
/// identification fell back to a worse model (on the series of `tests/reference/arima_line.py`
/// with 46–87 % higher held-out one-step MSE, where statsmodels' AIC choice is within 4–11 % of
/// the innovation variance).
#[test]
fn a_vibration_line_is_modelled_not_refused() {
    let n = 20_000;
    let noise = simulate(0.0, &[0.3], &[], 0.01, n, 2);
    let w = 2.0 * std::f64::consts::PI * 22.0 / 100.0;
    let x: Vec<f64> = noise
        .iter()
        .enumerate()
        .map(|(i, v)| v + 0.1 * (w * i as f64 + 0.3).sin())
        .collect();
    let train = 2_000;
    let id = identify(&x[..train], &IdentifySettings::default()).unwrap();
    let model = id.to_channel_model("gz");
    // The rule before: the best candidate whose fit was not on either boundary, refitted.
    let old = id
        .diagnostics
        .aic_table
        .iter()
        .filter(|e| !e.at_boundary)
        .min_by(|a, b| a.aic.total_cmp(&b.aic))
        .unwrap();
    let old_fit = fit_arima(&x[..train], old.p, id.fit.d, old.q, &CssOptions::default()).unwrap();
    let old_model = ArimaChannelModel {
        channel: "gz".into(),
        p: old_fit.p,
        d: old_fit.d,
        q: old_fit.q,
        constant: old_fit.constant,
        ar: old_fit.ar.clone(),
        ma: old_fit.ma.clone(),
        sigma: old_fit.sigma2.sqrt(),
        line_per_sample: None,
        diagnostics: None,
    };
    // Innovation variance 1e-4; 18 000 held-out samples give the MSE a 1.1 % sd.
    let var = 0.01f64.powi(2);
    let new = one_step_mse(&model, &x, train, 0.0) / var;
    let before = one_step_mse(&old_model, &x, train, 0.0) / var;
    let new_stage = one_step_mse(&model, &x, train, 0.2) / var;
    let before_stage = one_step_mse(&old_model, &x, train, 0.2) / var;
    eprintln!(
        "chosen ({},{},{}) at_boundary {}: held-out one-step MSE / σ² {new:.3} (stage's level_alpha 0.2: {new_stage:.3}); \
         the old rule's ({},{},{}): {before:.3} ({before_stage:.3})",
        id.fit.p,
        id.fit.d,
        id.fit.q,
        id.fit.at_boundary(),
        old.p,
        id.fit.d,
        old.q
    );
    assert!(!id.fit.ma_at_boundary());
    // The line the gross-error stage takes out before its model-free tests.
    let omega = model.line().expect("a line");
    assert!((omega - w).abs() < 1e-3, "{omega} vs {w}");
    // Within 10 % of the innovation variance: the line is predicted, not left in the errors
    // (measured 1.008; the old rule's choice 1.098).
    assert!(new < 1.1, "{new}");
    assert!(new < before, "{new} vs {before}");
    // The stage's tracked centre (level_alpha 0.2) costs both some of that (measured 1.244 vs
    // 1.448: it follows part of the line, which the AR part then sees twice), but the line
    // model stays the better one there too.
    assert!(new_stage < before_stage, "{new_stage} vs {before_stage}");
}

/// `line()`: the angle of an AR root pair on the unit circle, and nothing for a stationary AR
/// part or a real unit root.
#[test]
fn the_line_of_a_model_is_its_unit_circle_root_pair() {
    let model = |ar: Vec<f64>| ArimaChannelModel {
        channel: "gx".into(),
        p: ar.len(),
        d: 0,
        q: 0,
        constant: 0.0,
        ar,
        ma: vec![],
        sigma: 1.0,
        line_per_sample: None,
        diagnostics: None,
    };
    let w: f64 = 1.2;
    // (1 − 2cos w B + B²): exactly on the circle; with a third, stationary factor (1 − 0.3B).
    let got = model(vec![2.0 * w.cos(), -1.0]).line().unwrap();
    assert!((got - w).abs() < 1e-12, "{got}");
    let (a, b) = (2.0 * w.cos(), -1.0);
    let got = model(vec![a + 0.3, b - 0.3 * a, -0.3 * b]).line().unwrap();
    assert!((got - w).abs() < 1e-9, "{got}");
    // Stationary: no line.
    assert_eq!(model(vec![0.5, -0.2]).line(), None);
    assert_eq!(model(vec![2.0 * w.cos() * 0.99, -0.98]).line(), None);
    // (1 − B)(1 − 0.5B): a real unit root is a level, not a line.
    assert_eq!(model(vec![1.5, -0.5]).line(), None);
    // One AR coefficient cannot hold a line.
    assert_eq!(model(vec![1.0]).line(), None);
}
