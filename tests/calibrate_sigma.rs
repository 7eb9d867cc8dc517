//! What each part of the gyro fit's noise model (`analysis::calib::gyro_noise`) does to its σ,
//! on 40 seeds of `replay/tumble.toml` (docs/calibrate.md, "The gyro's σ"): the RMS and the
//! largest |z| of z = (fitted − truth)/σ over the 9 entries × 40 seeds, with the model's parts
//! switched off one at a time; and the residuals at the true K against the model. About 12
//! minutes, so ignored by default:
//!
//! ```sh
//! cargo test --release --test calibrate_sigma -- --ignored --nocapture
//! ```

mod common;

use common::{CalibTruth, calib_truth, rms, tumble_scenario};
use imuprep::analysis::calib::fit::{CalibSettings, calibrate_accel};
use imuprep::analysis::calib::gyro::{
    GyroCalibration, GyroInterval, NoiseParts, calibrate_gyro, gyro_intervals,
};
use imuprep::analysis::calib::still::{StillSettings, still_stretches};
use imuprep::sample::Channels;
use imuprep::sim::Simulator;
use imuprep::stage::bias::settings::CalibrationSettings;
use nalgebra::{Matrix3, Rotation3, Vector3};

const SEEDS: u64 = 40;
const RATE: f64 = 100.0;

/// ΔR of a motion through K.
fn rotation(k: &Matrix3<f64>, iv: &GyroInterval) -> Rotation3<f64> {
    let mut r = Rotation3::identity();
    for (w, dt) in &iv.rates {
        r *= Rotation3::new(k * w * *dt);
    }
    r
}

/// z of the nine entries against the identifiable truth M (as tests/calibrate_sim.rs).
fn z_of(g: &GyroCalibration, m: &Matrix3<f64>) -> Vec<f64> {
    let f = g.fitted.as_ref().expect("gyro calibration kept");
    let s = &f.settings;
    (0..9)
        .map(|p| {
            let (i, j) = (p / 3, p % 3);
            let (got, want) = if i == j {
                (s.scale[i], m[(i, i)])
            } else {
                (s.misalignment[i][j], m[(i, j)] / m[(i, i)])
            };
            (got - want) / f.k_sd[p]
        })
        .collect()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0f64, |m, z| m.max(z.abs()))
}

#[test]
#[ignore = "about 12 minutes: the measurement behind docs/calibrate.md's table of the gyro's σ"]
fn each_part_of_the_gyro_noise_model_and_the_sigma_it_gives() {
    let scn = tumble_scenario();
    let CalibTruth { l, gyro_m: m, bias } = calib_truth(&scn);
    let k_true = m.try_inverse().unwrap();
    let true_accel = CalibrationSettings {
        bias: bias.into(),
        scale: [l[(0, 0)], l[(1, 1)], l[(2, 2)]],
        misalignment: std::array::from_fn(|i| std::array::from_fn(|j| l[(i, j)] / l[(i, i)])),
    }
    .build()
    .unwrap();
    let part = |weights, shared_stretches, accel_frame| NoiseParts {
        weights,
        shared_stretches,
        accel_frame,
    };
    let variants: [(&str, NoiseParts, bool); 6] = [
        (
            "before: unweighted, motions independent, directions exact",
            part(false, false, false),
            false,
        ),
        (
            "directions through the true accelerometer calibration, fit as before",
            part(false, false, false),
            true,
        ),
        (
            "block-tridiagonal GLS, no accelerometer term",
            part(true, true, false),
            false,
        ),
        (
            "unweighted, with the accelerometer term",
            part(false, false, true),
            false,
        ),
        (
            "GLS without the cross blocks, with the accelerometer term",
            part(true, false, true),
            false,
        ),
        (
            "now: block-tridiagonal GLS and the accelerometer term",
            part(true, true, true),
            false,
        ),
    ];
    let mut z: Vec<Vec<f64>> = vec![Vec::new(); variants.len()];
    let mut ratio = Vec::new();
    // At the true K, in the true accelerometer frame: Σ|r|², Σ of the model's 2σ², and the
    // products r_k · ΔR_{k+1} r_{k+1} of motions sharing a stretch.
    let (mut r2, mut model2, mut n) = (0.0, 0.0, 0.0);
    let (mut cross, mut c1, mut c2) = (0.0, 0.0, 0.0);
    for seed in 1..=SEEDS {
        let samples: Channels = Simulator::new(&scn, seed)
            .unwrap()
            .map(|r| r.sample)
            .collect::<Vec<_>>()
            .iter()
            .collect();
        let st = still_stretches(&samples, RATE, &StillSettings::default());
        let acc = calibrate_accel(st, None, &CalibSettings::default()).unwrap();
        let fitted = gyro_intervals(
            &samples,
            &acc.stretches,
            acc.fitted.as_ref(),
            RATE,
            30.0,
            10.0,
        );
        let mut exact = gyro_intervals(&samples, &acc.stretches, None, RATE, 30.0, 10.0);
        for iv in &mut exact {
            let dir = |s: usize| {
                true_accel
                    .apply(&acc.stretches[s].mean())
                    .normalize()
                    .into()
            };
            (iv.u0, iv.u1) = (dir(iv.stretches[0]), dir(iv.stretches[1]));
        }
        for (v, (_, keep, true_frame)) in variants.iter().enumerate() {
            let mut ivs = if *true_frame {
                exact.clone()
            } else {
                fitted.clone()
            };
            ivs.iter_mut().for_each(|iv| iv.reduce_noise_model(*keep));
            let g = calibrate_gyro(ivs, 0.001, 100.0).unwrap();
            z[v].extend(z_of(&g, &m));
            if v + 1 == variants.len() {
                ratio.push(g.fitted.unwrap().noise_ratio);
            }
        }
        let res: Vec<Vector3<f64>> = exact
            .iter()
            .map(|iv| Vector3::from(iv.u1) - rotation(&k_true, iv).inverse() * Vector3::from(iv.u0))
            .collect();
        for (k, iv) in exact.iter().enumerate() {
            r2 += res[k].norm_squared();
            model2 += 2.0 * iv.noise_sd_rad.powi(2);
            n += 1.0;
            if k + 1 < exact.len() && exact[k + 1].stretches[0] == iv.stretches[1] {
                let next = rotation(&k_true, &exact[k + 1]) * res[k + 1];
                cross += res[k].dot(&next);
                c1 += res[k].norm_squared();
                c2 += next.norm_squared();
            }
        }
    }
    eprintln!("gyro z over {SEEDS} seeds of replay/tumble.toml (9 entries each):");
    for (v, (name, _, _)) in variants.iter().enumerate() {
        eprintln!(
            "  {name}: RMS z {:.3}, largest |z| {:.2} ({} values)",
            rms(&z[v]),
            max_abs(&z[v]),
            z[v].len()
        );
    }
    eprintln!(
        "whitened residual variance (now): mean {:.3}; at the true K: mean |r|² {:.3e} rad², modelled {:.3e}; correlation of r_k and ΔR_(k+1) r_(k+1) over shared stretches {:.3}",
        ratio.iter().sum::<f64>() / ratio.len() as f64,
        r2 / n,
        model2 / n,
        cross / (c1 * c2).sqrt()
    );
    // For a correct σ the RMS of 360 independent z is 1 ± 0.04 (1 σ); the nine of one fit are
    // correlated, so ± 0.1 here. The largest of 360 normal |z| is below 4 with 98 % probability.
    let now = &z[variants.len() - 1];
    assert!((rms(now) - 1.0).abs() < 0.1, "RMS z {}", rms(now));
    assert!(max_abs(now) < 4.0, "largest |z| {}", max_abs(now));
}
