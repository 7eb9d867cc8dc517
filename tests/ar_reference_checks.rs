//! Cross-checks against reference implementations on a deterministic fixture.
//!
//! Fixture and reference values: `tests/reference/make_fixture_and_reference.py`
//! (statsmodels 0.15.0 `yule_walker(method="mle")` and `burg`, PyWavelets 1.8.0 db4
//! periodization, allantools 2024.06 `oadev(data_type="freq", taus="octave")`); its printed
//! output is pasted below. The 360 000-sample bench series and its statsmodels fits:
//! `tests/reference/ar_fit_timing.py`.
use imuprep::analysis::allan::overlapping_adev;
use imuprep::analysis::wavelet::{denoise, wavedec, waverec};
use imuprep::model::{ArFit, burg, burg_orders, yule_walker, yule_walker_orders};

fn fixture() -> Vec<f64> {
    include_str!("fixtures/ar_wavelet_allan.csv")
        .lines()
        .skip(1)
        .map(|l| l.trim().parse::<f64>().expect("fixture is numeric"))
        .collect()
}

/// Relative/absolute closeness with a stated tolerance.
fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

/// `f`'s coefficients and noise variance against the reference `want` and `var`, each within
/// `tol` (relative to 1 + |value|); `what` names the fit in the message.
fn assert_fit(what: &str, f: &ArFit, want: &[f64], var: f64, tol: f64) {
    for (a, b) in f.coeffs.iter().zip(want) {
        assert!(close(*a, *b, tol), "{what}: {a} vs {b}");
    }
    assert!(
        close(f.noise_var / var, 1.0, tol),
        "{what} var {}",
        f.noise_var
    );
}

// AR coefficients: statsmodels solves the same Toeplitz system by LU and runs the same Burg
// recursion with a different summation order; the AR(10) system's condition number is ~1e3,
// so agreement to 1e-10 (relative to 1 + |value|) leaves ~1e3 x rounding slack.
const AR_TOL: f64 = 1e-10;

#[test]
fn yule_walker_matches_statsmodels() {
    let x = fixture();
    let cases: [(usize, &[f64], f64); 3] = [
        (1, &[0.8173743976498894], 0.0001420390285649367),
        (
            3,
            &[1.002837064851786, -0.21558753685882598, -0.0156376785640197],
            0.0001344053912075249,
        ),
        (
            10,
            &[
                1.003093012690068,
                -0.2118614096350627,
                -0.0320012321546894,
                0.014001033312948137,
                -0.0001991140231289949,
                0.0014116990918154545,
                0.010301781851350111,
                -0.01611803972907493,
                0.014334408803155622,
                -0.0040948592837347815,
            ],
            0.00013433628099470137,
        ),
    ];
    // every order from one recursion must match statsmodels' separate fits too
    let all = yule_walker_orders(&x, 10).unwrap();
    for (p, want, var) in cases {
        for f in [yule_walker(&x, p).unwrap(), all[p - 1].clone()] {
            assert_fit(&format!("p={p}"), &f, want, var, AR_TOL);
        }
    }
}

#[test]
fn burg_matches_statsmodels() {
    let x = fixture();
    let cases: [(usize, &[f64], f64); 3] = [
        (1, &[0.8174808829743715], 0.00014199336486659167),
        (
            3,
            &[
                1.0034140734010557,
                -0.21629592116022403,
                -0.01541391653146641,
            ],
            0.00013436709351246972,
        ),
        (
            10,
            &[
                1.0036540669327085,
                -0.21269611156817975,
                -0.031110455982403307,
                0.013386380268865943,
                -0.0006537436417772585,
                0.0018743422511240302,
                0.010549902554617522,
                -0.016182536394057003,
                0.014110852563459238,
                -0.004071751344180753,
            ],
            0.00013443866042688702,
        ),
    ];
    // every order from one lattice pass must match statsmodels' separate fits too
    let all = burg_orders(&x, 10).unwrap();
    for (p, want, var) in cases {
        for f in [burg(&x, p).unwrap(), all[p - 1].clone()] {
            assert_fit(&format!("p={p}"), &f, want, var, AR_TOL);
        }
    }
}

/// The 360 000-sample series of `benches/ar_fit.rs`, generated bit-identically by
/// `tests/reference/ar_fit_timing.py` (same xoshiro256** stream, same arithmetic).
fn bench_series() -> Vec<f64> {
    let mut rng = imuprep::rng::Rng::new(20261124);
    let (mut a, mut b) = (0.0, 0.0);
    (0..360_000)
        .map(|_| {
            let v = 1.5 * a - 0.7 * b + (2.0 * rng.uniform() - 1.0);
            b = a;
            a = v;
            0.05 + v + 0.5 * (2.0 * rng.uniform() - 1.0)
        })
        .collect()
}

// On 360 000 samples the two implementations' sums differ in order (blocked, 8 lanes here;
// numpy's pairwise dot and, for Burg, statsmodels' recursive denominator
// d_{m+1} = (1 - k_m^2) d_m - f^2 - b^2 instead of a fresh sum): each k differs by ~1e-15
// relative and the AR(10) step-up amplifies that ~1e3-fold. 1e-11 (relative to 1 + |value|)
// leaves a further ~10x; a real difference in method would show at 1e-4 and above.
const BENCH_TOL: f64 = 1e-11;

#[test]
fn bench_series_fits_match_statsmodels() {
    let x = bench_series();
    // the series is the one the Python script generated (its first and last values, exactly)
    assert_eq!(x[0], 0.6238906772086934);
    assert_eq!(x[359_999], 1.684665910674486);
    let burg10 = [
        1.1594883933745685,
        -0.2009762812324845,
        -0.19237777033791426,
        -0.03967066763935776,
        0.00451507674143324,
        0.00850909758942851,
        -0.003183380849639716,
        0.0009536335376980071,
        -0.000899787567436893,
        0.000718134583430494,
    ];
    let yw10 = [
        1.159470366105245,
        -0.20095176648189347,
        -0.1923932344540113,
        -0.03965044273413977,
        0.004498386214656815,
        0.008504368578692054,
        -0.0031747347063080067,
        0.0009364207834645163,
        -0.0008710931041120729,
        0.0006980545241533472,
    ];
    let fits = [
        ("burg", burg(&x, 10).unwrap(), &burg10, 0.5731112371187341),
        (
            "yule_walker",
            yule_walker(&x, 10).unwrap(),
            &yw10,
            0.5731332190647458,
        ),
    ];
    for (name, f, want, var) in fits {
        assert_fit(name, &f, want, var, BENCH_TOL);
    }
}

#[test]
fn wavelet_denoise_matches_pywt_periodization() {
    let x = fixture();
    let xw = &x[..2999]; // odd length exercises the last-sample extension
    let d = denoise(xw, 4).unwrap();
    // Same arithmetic up to summation order (8-tap filters, 4 levels, a median): 1e-12
    // relative is ~1e4 ulp of slack.
    assert!(close(d.sigma, 0.006947294841006302, 1e-12), "{}", d.sigma);
    assert!(close(d.threshold, 0.027799657693242347, 1e-12));
    let want = [
        (0, 0.05580090763800026),
        (1, 0.05533372760860245),
        (2, 0.05466146148772945),
        (500, 0.032171221223374326),
        (1499, 0.061463032074047005),
        (2500, 0.07158029574871083),
        (2997, 0.05438984980891486),
        (2998, 0.05600864686552306),
    ];
    for (i, v) in want {
        assert!(
            close(d.signal[i], v, 1e-12),
            "y[{i}] = {} vs {v}",
            d.signal[i]
        );
    }
    let ss: f64 = d.signal.iter().map(|v| v * v).sum();
    assert!(close(ss, 7.88061667076563, 1e-12), "{ss}");
    // and the zero-threshold round trip is exact to rounding, as in pywt (9e-17 there)
    let rec = waverec(&wavedec(xw, 4).unwrap()).unwrap();
    let err = rec
        .iter()
        .zip(xw)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-15, "{err}");
}

#[test]
fn allan_deviation_matches_allantools_oadev() {
    let x = fixture();
    let r = overlapping_adev(&x, 100.0);
    let want = [
        (0.01, 0.008838917894904005, 2999),
        (0.02, 0.011491314399070906, 2997),
        (0.04, 0.013620795022065441, 2993),
        (0.08, 0.01337060565116137, 2985),
        (0.16, 0.011064176366552448, 2969),
        (0.32, 0.008773960822109792, 2937),
        (0.64, 0.006858477624500051, 2873),
        (1.28, 0.005091227136134671, 2745),
        (2.56, 0.0029632988948785546, 2489),
        (5.12, 0.0021809325185835446, 1977),
        (10.24, 0.0008288924173062577, 953),
    ];
    assert_eq!(r.tau_s.len(), want.len());
    for (i, (tau, adev, n)) in want.into_iter().enumerate() {
        assert!(close(r.tau_s[i], tau, 1e-15));
        // same formula; cumulative sums in a different order: 1e-10 relative
        assert!(
            close(r.adev[i] / adev, 1.0, 1e-10),
            "tau {tau}: {} vs {adev}",
            r.adev[i]
        );
        assert_eq!(r.n_terms[i], n);
    }
}
