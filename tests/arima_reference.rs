//! Cross-check of the hypothesis tests and the CSS ARIMA fit against statsmodels/scipy on the
//! deterministic fixture `tests/fixtures/arma11.csv` (ARMA(1,1), c = 0.05, φ = 0.6, θ = 0.3,
//! σ = 0.02, N = 2000). Values printed by `tests/reference/arima_statsmodels.py`
//! (numpy 2.4.6, scipy 1.17.1, statsmodels 0.15.0).

use imuprep::model::arima::{CssOptions, difference, fit_arima, fit_css};
use imuprep::stats::acf::{acf, ljung_box, pacf};
use imuprep::stats::adf::{AdfLag, adf, mackinnon_crit, mackinnon_p};

fn fixture() -> Vec<f64> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/arma11.csv");
    let text = std::fs::read_to_string(path).expect("fixture present in the crate");
    text.lines()
        .skip(1)
        .map(|l| l.trim().parse::<f64>().expect("fixture is numeric"))
        .collect()
}

fn cumsum(x: &[f64]) -> Vec<f64> {
    let mut acc = 0.0;
    x.iter()
        .map(|v| {
            acc += v;
            acc
        })
        .collect()
}

fn close(got: f64, want: f64, rel_tol: f64) -> bool {
    (got - want).abs() <= rel_tol * want.abs().max(1e-300)
}

#[test]
fn adf_matches_statsmodels_on_stationary_fixture() {
    // Same regression, same AIC lag search; only the linear algebra differs (scaled Cholesky on
    // centred normal equations vs statsmodels' pinv on X): 1e-9 relative on τ covers cond(X)² ε.
    let x = fixture();
    let r = adf(&x, AdfLag::default()).unwrap();
    assert_eq!(r.used_lag, 2);
    assert_eq!(r.n_obs, 1997);
    assert!(close(r.stat, -17.60628604695137, 1e-9), "τ = {}", r.stat);
    assert!(
        close(r.p_value, 3.899260421349437e-30, 1e-7),
        "p = {}",
        r.p_value
    );
    let crit = [-3.4336287809345873, -2.862988387691722, -2.5675410598947996];
    for (g, w) in r.crit.iter().zip(crit) {
        assert!(close(*g, w, 1e-12), "crit {g} vs {w}");
    }
    assert!(close(r.ic_best.unwrap(), -9750.014669259039, 1e-10));
}

#[test]
fn adf_matches_statsmodels_on_integrated_fixture() {
    let y = cumsum(&fixture());
    let r = adf(&y, AdfLag::default()).unwrap();
    assert_eq!(r.used_lag, 3);
    assert_eq!(r.n_obs, 1996);
    // The level column of an I(1) series is far larger than the differences; scaling keeps the
    // normal equations at cond ≈ 1e4–1e5, hence 1e-8 relative.
    assert!(close(r.stat, 1.7431658217116228, 1e-8), "τ = {}", r.stat);
    // Above τ_max = 2.74 p is 1; here the large-p polynomial applies.
    assert!(
        close(r.p_value, 0.9982293761707051, 1e-9),
        "p = {}",
        r.p_value
    );
    let crit = [-3.433630425730241, -2.862989113874071, -2.5675414465504156];
    for (g, w) in r.crit.iter().zip(crit) {
        assert!(close(*g, w, 1e-12));
    }
}

#[test]
fn adf_fixed_lag_matches_statsmodels() {
    let r = adf(&fixture(), AdfLag::Fixed { lags: 4 }).unwrap();
    assert_eq!(r.n_obs, 1995);
    assert!(close(r.stat, -15.906104668897406, 1e-9), "τ = {}", r.stat);
}

#[test]
fn mackinnon_tables_match_statsmodels() {
    // Same polynomial and the same Φ: differences are Φ's ~1e-15; 1e-12 relative.
    let stats = [-5.0, -3.0, -2.0, -1.0, 0.5];
    let want = [
        2.2193154713956276e-05,
        0.034894400275345266,
        0.28657309916843154,
        0.7532643012005655,
        0.9848730963065522,
    ];
    for (s, w) in stats.iter().zip(want) {
        assert!(
            close(mackinnon_p(*s), w, 1e-12),
            "p({s}) = {}",
            mackinnon_p(*s)
        );
    }
    let c = mackinnon_crit(100);
    for (g, w) in c.iter().zip([-3.497501033, -2.89090644, -2.5824349]) {
        assert!(close(*g, w, 1e-12));
    }
}

#[test]
fn acf_pacf_ljung_box_match_statsmodels() {
    // Direct sums (statsmodels fft=False also sums directly): agreement to rounding, 1e-12 abs.
    let x = fixture();
    let want_acf = [
        1.0,
        0.7338713563579194,
        0.43837421612112876,
        0.25261519785473835,
        0.13527276458535326,
        0.06310380836117942,
        0.03709003545674345,
        0.03081193917683316,
        0.02889158088873606,
        0.040992047418365256,
        0.04402262161650791,
    ];
    let want_pacf = [
        1.0,
        0.7338713563579194,
        -0.21713442248636494,
        0.046395994185616796,
        -0.03101813805239376,
        -0.004092194605247244,
        0.028480533136585336,
        0.003530155314593773,
        0.006155032393596959,
        0.034682538602515196,
        -0.010426927141119001,
    ];
    let a = acf(&x, 10).unwrap();
    let p = pacf(&x, 10).unwrap();
    for k in 0..=10 {
        assert!((a[k] - want_acf[k]).abs() < 1e-12, "acf[{k}]");
        assert!((p[k] - want_pacf[k]).abs() < 1e-12, "pacf[{k}]");
    }
    let lb = ljung_box(&x, 10, 2).unwrap();
    assert!(close(lb.q, 1650.1383684321222, 1e-12), "Q = {}", lb.q);
    assert_eq!(lb.dof, 8);
    assert!(lb.p_value < 1e-300, "p = {}", lb.p_value);
}

/// Compare a CSS fit `[c, φ.., θ..]` with scipy's optimum of the same objective. Both optimisers
/// stop at relative tolerances ≤ 1e-12 on a smooth objective whose minimum is well conditioned
/// (N = 2000, parameters 10+ standard errors from the admissibility boundary), so the estimates
/// agree far better than their 1e-2 standard errors; 1e-6 absolute leaves margin for the flat
/// direction of LM's stopping rule.
fn assert_css(got: &[f64], want: &[f64], s2: f64, want_s2: f64) {
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 1e-6, "{got:?} vs {want:?}");
    }
    // S is stationary at the optimum: σ² agrees to second order in the parameter error, 1e-9.
    assert!(close(s2, want_s2, 1e-9), "σ² {s2} vs {want_s2}");
}

#[test]
fn css_arma11_matches_scipy_css_optimum() {
    let f = fit_arima(&fixture(), 1, 0, 1, &CssOptions::default()).unwrap();
    let got = [f.constant, f.ar[0], f.ma[0]];
    assert_css(
        &got,
        &[0.04933469224176286, 0.604109013242381, 0.29979864644516785],
        f.sigma2,
        0.00041755855952065176,
    );
    assert!(f.converged);
}

#[test]
fn css_arma21_matches_scipy_css_optimum() {
    let f = fit_arima(&fixture(), 2, 0, 1, &CssOptions::default()).unwrap();
    let got = [f.constant, f.ar[0], f.ar[1], f.ma[0]];
    assert_css(
        &got,
        &[
            0.048054625243807075,
            0.6583382009140041,
            -0.0440389428449497,
            0.24808149082217232,
        ],
        f.sigma2,
        0.00041760314642161323,
    );
}

#[test]
fn css_arima111_matches_scipy_css_optimum() {
    // d = 1 path: ∇(cumsum x) = x[1..], conditioned on the first differenced value.
    let y = cumsum(&fixture());
    let f = fit_arima(&y, 1, 1, 1, &CssOptions::default()).unwrap();
    let got = [f.constant, f.ar[0], f.ma[0]];
    assert_css(
        &got,
        &[0.04939004279450968, 0.6035793135550369, 0.30044671631450487],
        f.sigma2,
        0.00041767544025037506,
    );
    // And the explicit-difference entry point gives the same fit.
    let g = fit_css(&difference(&y, 1), 1, 1, 1, 1, &CssOptions::default()).unwrap();
    assert_eq!(f, g);
}

#[test]
fn css_agrees_with_statsmodels_exact_mle_within_a_quarter_standard_error() {
    // statsmodels' ARIMA(1,0,1) MLE (state space, exact likelihood) maximises a different
    // objective; CSS and MLE are asymptotically equivalent and differ by O_p(1/N) while the
    // standard errors are O(1/√N), so at N = 2000 the gap is a small fraction of a standard
    // error. Bound: 0.25 se (the observed gaps are 0.10 se for φ, 0.12 se for θ).
    let f = fit_arima(&fixture(), 1, 0, 1, &CssOptions::default()).unwrap();
    let mle = [
        0.12464208422449705,
        0.6017223759668608,
        0.3030905425495725,
        0.0004172804954402156,
    ];
    let se = [
        0.001496460390415895,
        0.023790817066384116,
        0.027917813440560005,
        1.3713598948814215e-05,
    ];
    let got = [f.mean(), f.ar[0], f.ma[0], f.sigma2];
    for i in 0..4 {
        assert!(
            (got[i] - mle[i]).abs() < 0.25 * se[i],
            "param {i}: CSS {} vs MLE {} (se {})",
            got[i],
            mle[i],
            se[i]
        );
    }
}
