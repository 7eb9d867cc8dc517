//! Tests of the still-stretch calibration (`calib::still`, `calib::fit`) on generated data with
//! known truth: still stretches at chosen attitudes with seeded white noise (the simulator has
//! no multi-attitude motion profile), and a static bench for the stretch finder (a tumbling
//! record end to end: `tests/calibrate.rs`).

use nalgebra::{Matrix3, Vector3};

use super::fit::{AccelCalibration, CalibSettings, calibrate_accel, condition};
use super::still::{AccelStretch, StillSettings, still_stretches};
use crate::rng::Rng;
use crate::sample::Sample;

const G: f64 = 9.80665;

/// The 26 directions of a cube's faces, edges and corners: a hand calibration's attitudes.
fn cube_directions() -> Vec<Vector3<f64>> {
    let mut d = Vec::new();
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                if (x, y, z) != (0, 0, 0) {
                    d.push(Vector3::new(x as f64, y as f64, z as f64).normalize());
                }
            }
        }
    }
    d
}

/// Stretches whose true specific force is g·u for each direction, measured as A·true + b with
/// white noise `sd` per sample over `n` samples (the mean's noise is sd/√n per axis).
fn stretches(
    dirs: &[Vector3<f64>],
    a: &Matrix3<f64>,
    b: &Vector3<f64>,
    sd: f64,
    n: usize,
    seed: u64,
) -> Vec<AccelStretch> {
    let mut rng = Rng::new(seed);
    let sm = sd / (n as f64).sqrt();
    dirs.iter()
        .enumerate()
        .map(|(k, u)| {
            let f = a * (u * G) + b + Vector3::from_fn(|_, _| sm * rng.normal());
            AccelStretch {
                start: k * n,
                len: n,
                t0_s: k as f64 * 20.0,
                mean_m_s2: f.into(),
                sd_m_s2: [sd; 3],
                norm_mean_sd_m_s2: sm,
            }
        })
        .collect()
}

fn lower(scale: [f64; 3], yx: f64, zx: f64, zy: f64) -> Matrix3<f64> {
    Matrix3::new(scale[0], 0.0, 0.0, yx, scale[1], 0.0, zx, zy, scale[2])
}

fn kept(c: &AccelCalibration) -> Vec<String> {
    c.fitted.as_ref().map_or(vec![], |f| f.groups.clone())
}

/// Compare the fit with the identifiable truth L = chol(A Aᵀ) and b; `tol_sd` in the fit's 1-σ.
fn assert_recovers(c: &AccelCalibration, a: &Matrix3<f64>, b: &Vector3<f64>, tol_sd: f64) {
    let f = c.fitted.as_ref().expect("a calibration");
    let l = (a * a.transpose()).cholesky().unwrap().l();
    let s = &f.settings;
    let got_l = Matrix3::from_fn(|i, j| s.misalignment[i][j] * s.scale[i]);
    for i in 0..3 {
        let e = (s.bias[i] - b[i]).abs();
        assert!(
            e <= tol_sd * f.bias_sd_m_s2[i],
            "bias {i}: {e:.2e} vs sd {:.2e}",
            f.bias_sd_m_s2[i]
        );
        let e = (s.scale[i] - l[(i, i)]).abs();
        assert!(
            e <= tol_sd * f.scale_sd[i],
            "scale {i}: {e:.2e} vs sd {:.2e}",
            f.scale_sd[i]
        );
    }
    for (k, (i, j)) in [(1, 0), (2, 0), (2, 1)].into_iter().enumerate() {
        let e = (got_l[(i, j)] - l[(i, j)]).abs();
        let sd = f.misalignment_sd_rad[k];
        assert!(e <= tol_sd * sd, "L[{i}][{j}]: {e:.2e} vs sd {sd:.2e}");
    }
}

#[test]
fn recovers_bias_scale_and_misalignment_within_the_noise() {
    // A consumer accelerometer: scale errors of 0.5–2 %, 3–8 mrad cross-axis, 0.05–0.2 m/s²
    // bias; 0.02 m/s² white noise over 10 s at 100 Hz per stretch (mean noise 6.3e-4 m/s²).
    let a = lower([1.02, 0.985, 1.01], 0.005, -0.003, 0.008);
    let b = Vector3::new(0.1, -0.05, 0.2);
    let (sd, n) = (0.02, 1000);
    let sm = sd / (n as f64).sqrt();
    let mut var_ratio = 0.0;
    for seed in 0..10 {
        let c = calibrate_accel(
            stretches(&cube_directions(), &a, &b, sd, n, seed),
            None,
            &CalibSettings::default(),
        )
        .unwrap();
        assert_eq!(kept(&c).len(), 3, "{:#?}", c.candidates);
        // 4.5 σ: 90 parameter estimates, a Gaussian error beyond 4.5 σ has probability 7e-6.
        assert_recovers(&c, &a, &b, 4.5);
        assert!(c.held_out_rms_after_m_s2 < 0.05 * c.held_out_rms_before_m_s2);
        // The settings written invert the error: the bias stage's own calibration brings every
        // stretch to |f| = g within a few noise σ.
        let cal = c.fitted.as_ref().unwrap().settings.build().unwrap();
        for st in &c.stretches {
            assert!((cal.apply(&st.mean()).norm() - G).abs() < 5.0 * sm);
        }
        // Residual variance per degree of freedom (26 stretches, 9 parameters).
        var_ratio += c.fit_rms_after_m_s2.powi(2) * 26.0 / 17.0 / (sm * sm) / 10.0;
    }
    // The fitted sd is the noise's, not an inflated one: what the fit leaves is the stretch
    // means' radial noise sd/√n. Over 10 × 17 dof, the variance ratio's 99.9 % range is
    // ≈ [0.67, 1.38].
    assert!((0.67..1.38).contains(&var_ratio), "{var_ratio}");
}

#[test]
fn a_general_misalignment_is_recovered_as_its_triangular_equivalent() {
    // Cross-axis terms above the diagonal too (the simulator's M): only chol(A Aᵀ) is
    // identifiable from gravity, and that is what must come back.
    let a = Matrix3::new(
        1.01, 0.004, -0.006, 0.002, 0.99, 0.005, -0.003, 0.007, 1.015,
    );
    let b = Vector3::new(-0.08, 0.12, 0.05);
    let c = calibrate_accel(
        stretches(&cube_directions(), &a, &b, 0.02, 1000, 11),
        None,
        &CalibSettings::default(),
    )
    .unwrap();
    assert_eq!(kept(&c).len(), 3);
    assert_recovers(&c, &a, &b, 4.5);
}

#[test]
fn nothing_is_added_on_twenty_clean_sensors_and_only_the_bias_where_there_is_one() {
    // α = 0.001 per round: over 20 seeds × 3 tests the chance of a false keep is ≈ 6 %
    // if the test is exact; 0 is asserted because the seeds are fixed (and it holds).
    let dirs = cube_directions();
    let b = Vector3::new(0.15, -0.1, 0.05);
    for seed in 0..20 {
        let clean = calibrate_accel(
            stretches(
                &dirs,
                &Matrix3::identity(),
                &Vector3::zeros(),
                0.02,
                500,
                seed,
            ),
            None,
            &CalibSettings::default(),
        )
        .unwrap();
        assert!(
            kept(&clean).is_empty(),
            "seed {seed}: {:#?}",
            clean.candidates
        );
        assert!(
            clean.verdict.starts_with("nothing kept"),
            "{}",
            clean.verdict
        );
        let biased = calibrate_accel(
            stretches(&dirs, &Matrix3::identity(), &b, 0.02, 500, 100 + seed),
            None,
            &CalibSettings::default(),
        )
        .unwrap();
        assert_eq!(kept(&biased), vec!["bias".to_string()], "seed {seed}");
    }
}

#[test]
fn a_single_attitude_is_not_identifiable() {
    // Thirty stretches of a static bench (z down), and a car whose stops tilt it by ±5°: gravity
    // never leaves z, so scale_z and bias_z (and x, y at all) cannot be told apart.
    let flat: Vec<Vector3<f64>> = (0..30).map(|_| Vector3::new(0.0, 0.0, -1.0)).collect();
    let mut rng = Rng::new(5);
    let tilted: Vec<Vector3<f64>> = (0..30)
        .map(|_| {
            let (r, p) = (
                0.087 * (2.0 * rng.uniform() - 1.0),
                0.087 * (2.0 * rng.uniform() - 1.0),
            );
            Vector3::new(p.sin(), -r.sin() * p.cos(), -r.cos() * p.cos())
        })
        .collect();
    let a = lower([1.01, 1.0, 0.99], 0.0, 0.0, 0.0);
    for dirs in [flat, tilted] {
        let c = calibrate_accel(
            stretches(&dirs, &a, &Vector3::zeros(), 0.02, 1000, 3),
            None,
            &CalibSettings::default(),
        )
        .unwrap();
        assert!(c.fitted.is_none());
        assert!(c.verdict.starts_with("not identifiable"), "{}", c.verdict);
        assert!(
            c.candidates.is_empty() && c.not_identifiable.len() == 7,
            "{:#?}",
            c.not_identifiable
        );
    }
    let none = calibrate_accel(vec![], None, &CalibSettings::default()).unwrap();
    assert!(none.verdict.starts_with("not identifiable"));
}

#[test]
fn the_condition_number_separates_spread_attitudes_from_one() {
    // The threshold of 100 sits between a hand calibration's attitudes (the cube: ≈ 3–5) and a
    // car's ±5° stops (≫ 100).
    let all = [true; 9];
    let cube: Vec<Vector3<f64>> = cube_directions().iter().map(|u| u * G).collect();
    let k = condition(&cube, &all);
    assert!(k < 10.0, "{k}");
    let z: Vec<Vector3<f64>> = (0..20)
        .map(|i| Vector3::new(0.01 * i as f64, 0.0, -G))
        .collect();
    assert!(condition(&z, &all) > 1e3);
}

#[test]
fn a_gain_below_one_lsb_is_refused() {
    // A 60 ppm scale error on z moves |f| by 6e-4 m/s²: significant over 1000-s stretches, but
    // below a 0.01 m/s² LSB, so not kept (with no LSB given it is).
    let a = lower([1.0, 1.0, 1.00006], 0.0, 0.0, 0.0);
    let st = stretches(&cube_directions(), &a, &Vector3::zeros(), 0.002, 100_000, 9);
    let free = calibrate_accel(st.clone(), None, &CalibSettings::default()).unwrap();
    assert!(
        kept(&free).contains(&"scale".to_string()),
        "{:#?}",
        free.candidates
    );
    let q = calibrate_accel(st, Some(0.01), &CalibSettings::default()).unwrap();
    assert!(kept(&q).is_empty());
    assert!(
        q.candidates
            .iter()
            .any(|c| c.reason.starts_with("below quantisation"))
    );
}

#[test]
fn a_static_bench_record_is_one_stretch_and_not_identifiable() {
    // Five minutes at rest, z down, 100 Hz: consumer noise on both triads.
    let mut rng = Rng::new(4);
    let samples: Vec<Sample> = (0..30_000u32)
        .map(|i| Sample {
            seq: i,
            t_ns: u64::from(i) * 10_000_000,
            gyro: Vector3::from_fn(|_, _| 0.005 * rng.normal()),
            accel: Vector3::new(0.0, 0.0, -G) + Vector3::from_fn(|_, _| 0.02 * rng.normal()),
            ..Sample::default()
        })
        .collect();
    let st = still_stretches(&samples.iter().collect(), 100.0, &StillSettings::default());
    assert_eq!(st.len(), 1);
    let c = calibrate_accel(st, None, &CalibSettings::default()).unwrap();
    assert!(c.verdict.starts_with("not identifiable"), "{}", c.verdict);
}
