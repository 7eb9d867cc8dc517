//! Unit tests of the filter on synthetic IMU data whose truth is known.

use super::earth::{self, euler_to_ctm};
use super::eskf::*;
use crate::rng::Rng;
use nalgebra::{Matrix3, Vector3};

const DT: f64 = 0.01;
const LAT: f64 = 0.7; // rad, about 40° N
const H: f64 = 1600.0;

fn cfg(zupt: bool) -> EskfConfig {
    EskfConfig {
        noise: ImuNoise {
            gyro_psd: 0.038f64.to_radians(),
            accel_psd: 0.0137,
            gyro_bias_rw: 7.6e-4f64.to_radians(),
            accel_bias_rw: 2.7e-3,
        },
        init: InitSd {
            att: [2f64.to_radians(), 2f64.to_radians(), 5f64.to_radians()],
            vel: [0.05, 0.05, 0.1],
            pos: [0.05, 0.05, 0.1],
            accel_bias: 0.2,
            gyro_bias: 0.2f64.to_radians(),
        },
        lever_arm_b: [0.0, 0.05, 0.0],
        zupt: zupt.then_some(ZuptConfig::REFERENCE),
        yaw_align_speed: None,
        yaw_align_sd: 5f64.to_radians(),
        augmentation: None,
    }
}

fn at_rest(yaw: f64) -> NavState {
    NavState {
        lat: LAT,
        lon: -1.8,
        h: H,
        v: Vector3::zeros(),
        c_bn: euler_to_ctm(0.0, 0.0, yaw).transpose(),
    }
}

/// The error-free IMU output of a body at rest with attitude `c_bn`: Earth rate and the
/// reaction to gravity (Coriolis vanishes at rest).
fn rest_imu(c_bn: &Matrix3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let w = c_bn.transpose() * earth::earth_rate_ned(LAT);
    let f = c_bn.transpose() * Vector3::new(0.0, 0.0, -earth::gravity(LAT, H));
    (w, f)
}

fn horiz_m(a: &NavState, b: &NavState) -> f64 {
    let (rn, re) = earth::radii(a.lat);
    ((a.lat - b.lat) * (rn + a.h)).hypot((a.lon - b.lon) * (re + a.h) * a.lat.cos())
}

#[test]
fn error_free_rest_stays_put() {
    // Mechanisation alone on the exact output of a resting IMU: the Earth rate, gravity and
    // frame rotation must cancel. Bound 1 mm after 300 s: the trapezoidal position update and
    // first-order frame rotation leave errors many orders below that.
    let mut nav = at_rest(0.4);
    let (w, f) = rest_imu(&nav.c_bn);
    let start = nav;
    for _ in 0..30_000 {
        nav.mechanise(DT, &w, &f, true);
    }
    assert!(horiz_m(&nav, &start) < 1e-3, "{}", horiz_m(&nav, &start));
    assert!((nav.h - start.h).abs() < 1e-3, "{}", nav.h - start.h);
    assert!(nav.v.norm() < 1e-5, "{}", nav.v);
}

#[test]
fn noisy_biased_rest_with_zupt_stays_within_bound() {
    // A resting IMU with seeded white noise at the drive's sensor specification (0.0038 °/s/√Hz,
    // 70 µg/√Hz) and constant biases (up to 0.12 °/s gyro — below the still test's 0.25 °/s, as
    // the detector runs on bias-corrected rates and the estimate starts at zero — and 0.05 m/s²
    // accel), no GNSS: the ZUPT/ZARU updates every 0.5 s must hold it. Bound 0.1 m after 120 s:
    // between two updates (0.5 s) the velocity σ of 0.01 m/s lets the position walk a few mm
    // per update; 0.1 m is far below a free-inertial drift (a 0.12 °/s gyro bias alone gives
    // g·b·t³/6 ≈ 6 km after 120 s).
    let mut rng = Rng::new(15);
    let c = cfg(true);
    let mut kf = Eskf::new(c.clone(), at_rest(0.0));
    let start = kf.nav;
    let (w0, f0) = rest_imu(&kf.nav.c_bn);
    let bg = Vector3::new(0.1, -0.08, 0.12).map(f64::to_radians);
    let ba = Vector3::new(0.05, -0.03, 0.02);
    let (sg, sa) = (0.0038f64.to_radians() / DT.sqrt(), 70e-6 * 9.81 / DT.sqrt());
    for _ in 0..12_000 {
        let n = |rng: &mut Rng, s: f64| Vector3::new(rng.normal(), rng.normal(), rng.normal()) * s;
        let w = w0 + bg + n(&mut rng, sg);
        let f = f0 + ba + n(&mut rng, sa);
        kf.propagate(DT, &w, &f);
    }
    assert!(kf.stats.zupt_updates > 200, "{:?}", kf.stats);
    assert!(
        horiz_m(&kf.nav, &start) < 0.1,
        "{}",
        horiz_m(&kf.nav, &start)
    );
    assert!((kf.nav.h - start.h).abs() < 0.1, "{}", kf.nav.h - start.h);
    // ZARU observes the gyro bias directly: within 0.02 °/s (twice its σ of 0.01 °/s).
    let e = (kf.gyro_bias() - bg).map(f64::to_degrees);
    assert!(e.norm() < 0.02, "gyro bias error {e} °/s");
}

/// A trajectory: `yaw_rate(t)` (rad/s) and forward acceleration `acc(t)` (m/s²) of a level
/// vehicle; returns the truth at each step and the error-free IMU output. The truth is
/// integrated by the same mechanisation from the exact inputs, so it is consistent with them.
fn trajectory(
    n: usize,
    v0: f64,
    yaw_rate: impl Fn(f64) -> f64,
    acc: impl Fn(f64) -> f64,
) -> Vec<(NavState, Vector3<f64>, Vector3<f64>)> {
    let mut nav = at_rest(0.0);
    nav.v = Vector3::new(v0, 0.0, 0.0);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 * DT;
        let w_ie = earth::earth_rate_ned(nav.lat);
        let w_en = earth::transport_rate_ned(nav.lat, nav.h, &nav.v);
        let c_nb = nav.c_bn.transpose();
        let w = Vector3::new(0.0, 0.0, yaw_rate(t)) + c_nb * (w_ie + w_en);
        let fwd = nav.c_bn * Vector3::x();
        let a_n = fwd * acc(t) + Vector3::new(0.0, 0.0, 0.0);
        let g = Vector3::new(0.0, 0.0, earth::gravity(nav.lat, nav.h));
        // Specific force that keeps the velocity along the body x axis as it turns: the
        // centripetal part ω_z × v plus the Coriolis and gravity terms of the mechanisation.
        let turn = Vector3::new(0.0, 0.0, yaw_rate(t)).cross(&(c_nb * nav.v));
        let f = c_nb * (a_n - g + (2.0 * w_ie + w_en).cross(&nav.v)) + turn;
        out.push((nav, w, f));
        nav.mechanise(DT, &w, &f, true);
    }
    out
}

#[test]
fn constant_velocity_and_turn_tracked_with_gnss() {
    // 10 m/s, weaving (yaw rate 10 °/s·sin(2πt/30 s): S-turns of ±48°, so the heading and the
    // z gyro bias stay observable through the centripetal acceleration), 90 s; seeded IMU noise
    // at the filter's densities, constant biases, 4-Hz GNSS (σ 2 cm position, 5 cm/s velocity,
    // seeded). The filter starts 3° off in yaw.
    let n = 9_000;
    let weave = |t: f64| 10f64.to_radians() * (2.0 * std::f64::consts::PI * t / 30.0).sin();
    let truth = trajectory(n, 10.0, weave, |_| 0.0);
    let mut rng = Rng::new(1515);
    let c = cfg(false);
    let mut start = truth[0].0;
    start.c_bn = euler_to_ctm(0.0, 0.0, 3f64.to_radians()).transpose();
    let mut kf = Eskf::new(c.clone(), start);
    let bg = Vector3::new(0.1, -0.15, 0.2).map(f64::to_radians);
    let ba = Vector3::new(0.03, -0.02, 0.04);
    let (sg, sa) = (c.noise.gyro_psd / DT.sqrt(), c.noise.accel_psd / DT.sqrt());
    let l = Vector3::from(c.lever_arm_b);
    let mut worst_after_60 = 0.0f64;
    for (k, (tr, w, f)) in truth.iter().enumerate() {
        let nz = |rng: &mut Rng, s: f64| Vector3::new(rng.normal(), rng.normal(), rng.normal()) * s;
        if k > 0 {
            kf.propagate(
                DT,
                &(w + bg + nz(&mut rng, sg)),
                &(f + ba + nz(&mut rng, sa)),
            );
        }
        if k % 25 == 0 {
            let (la, lo, h) = tr.point(&l);
            let (rn, re) = earth::radii(la);
            let p = nz(&mut rng, 0.02);
            kf.update_gnss(&GnssFix {
                lat: la + p[0] / (rn + h),
                lon: lo + p[1] / ((re + h) * la.cos()),
                h: h - p[2],
                v: tr.v + tr.c_bn * w.cross(&l) + nz(&mut rng, 0.05),
                pos_sd: Vector3::repeat(0.02),
                vel_sd: Some(Vector3::repeat(0.05)),
            });
        }
        if k as f64 * DT >= 60.0 {
            worst_after_60 = worst_after_60.max(horiz_m(&kf.nav, tr));
        }
    }
    let tr = &truth[n - 1].0;
    // Bounds: with 2-cm GNSS the position error stays at the few-cm level (0.1 m = 5 σ);
    // the heading, observable through the turn and the accelerations, within 0.5° of truth
    // (started 3° off); the z gyro bias (observable through heading) within 0.05 °/s.
    assert!(worst_after_60 < 0.1, "{worst_after_60}");
    let dyaw = (kf.nav.euler()[2] - tr.euler()[2]).to_degrees();
    assert!(dyaw.abs() < 0.5, "yaw error {dyaw}°");
    let ebg = (kf.gyro_bias()[2] - bg[2]).to_degrees();
    assert!(ebg.abs() < 0.05, "z gyro bias error {ebg} °/s");
    assert!((kf.nav.v - tr.v).norm() < 0.05, "{}", kf.nav.v - tr.v);
}

#[test]
fn outage_growth_matches_half_b_t_squared() {
    // Error-free data, 10 m/s north, GNSS for 60 s, then an outage during which the
    // accelerometer gains an unmodelled bias b = 0.05 m/s² along the body x (north) axis.
    // A constant acceleration error gives ½·b·t² along the track: 2.5 / 10 / 22.5 m after
    // 10 / 20 / 30 s. Tolerance 2 %: the filter's own state is exact before the step (no
    // noise), and the only other effects (Schuler coupling, 84-min period; gravity-gradient)
    // are below 0.1 % over 30 s.
    let n = 9_001;
    let truth = trajectory(n, 10.0, |_| 0.0, |_| 0.0);
    let c = cfg(false);
    let mut kf = Eskf::new(c.clone(), truth[0].0);
    let l = Vector3::from(c.lever_arm_b);
    let b = 0.05;
    for (k, (tr, w, f)) in truth.iter().enumerate() {
        let t = k as f64 * DT;
        if k > 0 {
            let mut f = *f;
            if t > 60.0 {
                f[0] += b;
            }
            kf.propagate(DT, w, &f);
        }
        if t <= 60.0 && k % 25 == 0 {
            let (la, lo, h) = tr.point(&l);
            kf.update_gnss(&GnssFix {
                lat: la,
                lon: lo,
                h,
                v: tr.v,
                pos_sd: Vector3::repeat(0.02),
                vel_sd: Some(Vector3::repeat(0.05)),
            });
        }
        for l_s in [10.0, 20.0, 30.0] {
            if k == ((60.0 + l_s) / DT).round() as usize {
                let want = 0.5 * b * l_s * l_s;
                let got = horiz_m(&kf.nav, tr);
                assert!(
                    (got - want).abs() < 0.02 * want,
                    "after {l_s} s: {got} m, want {want}"
                );
            }
        }
    }
}

#[test]
fn implausible_gauss_markov_parts_fall_back_to_the_random_walk() {
    // A bad Allan/AR fit can give T_c ≈ 0 (or σ NaN). Such a part must be refused — the axis
    // keeps the random walk only — and with every part refused the 21-state filter must give
    // exactly the 15-state filter's solution (the refused states are never created or are
    // held at zero), not a diverging one.
    let good = GaussMarkov {
        sigma: 0.01f64.to_radians(),
        tc_s: 300.0,
    };
    let tiny = GaussMarkov {
        sigma: 0.01f64.to_radians(),
        tc_s: 1e-4,
    };
    let nan = GaussMarkov {
        sigma: f64::NAN,
        tc_s: 50.0,
    };
    assert!(good.check().is_ok());
    assert!(tiny.check().is_err());
    assert!(nan.check().is_err());
    let mixed = BiasAugmentation {
        accel: [Some(nan), None, Some(good)],
        gyro: [Some(tiny), Some(good), Some(tiny)],
    };
    let (g, refused) = mixed.guarded();
    let names: Vec<&str> = refused.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(names, ["ax", "gx", "gz"]);
    assert_eq!(g.accel, [None, None, Some(good)]);
    assert_eq!(g.gyro, [None, Some(good), None]);

    // All parts implausible: the filter refuses them and runs as the plain 15-state filter.
    let all_bad = BiasAugmentation {
        accel: [Some(tiny); 3],
        gyro: [Some(tiny); 3],
    };
    let mut c_aug = cfg(true);
    c_aug.augmentation = Some(all_bad);
    let mut plain = Eskf::new(cfg(true), at_rest(0.3));
    let mut aug = Eskf::new(c_aug, at_rest(0.3));
    assert_eq!(aug.n_states(), 15);
    assert_eq!(aug.stats.gm_parts_refused, 6);
    // Some refused, some kept: 21 states, the refused axes' states stay exactly zero.
    let mut c_mixed = cfg(true);
    c_mixed.augmentation = Some(mixed);
    let mut part = Eskf::new(c_mixed, at_rest(0.3));
    assert_eq!(part.n_states(), 21);
    assert_eq!(part.stats.gm_parts_refused, 3);
    let mut rng = Rng::new(16);
    let (w0, f0) = rest_imu(&plain.nav.c_bn);
    let bg = Vector3::new(0.1, -0.08, 0.12).map(f64::to_radians);
    // White gyro noise at the drive's datasheet density (as the test above).
    let sg = 0.0038f64.to_radians() / DT.sqrt();
    for _ in 0..6_000 {
        let w = w0 + bg + Vector3::new(rng.normal(), rng.normal(), rng.normal()) * sg;
        for kf in [&mut plain, &mut aug, &mut part] {
            kf.propagate(DT, &w, &f0);
        }
    }
    assert_eq!(plain.nav, aug.nav);
    assert_eq!(plain.stats.zupt_updates, aug.stats.zupt_updates);
    // At rest with ZUPT every 0.5 s (as the test above): the velocity stays at the
    // update's σ (0.01 m/s); 0.05 m/s allows for the last 0.5 s before an update.
    for kf in [&plain, &part] {
        assert!(kf.stats.zupt_updates > 100, "{:?}", kf.stats);
        assert!(kf.nav.v.norm() < 0.05, "{}", kf.nav.v);
    }
    assert_eq!(part.mg[0], 0.0);
    assert_eq!(part.mg[2], 0.0);
    assert_eq!(part.ma[0], 0.0);
    assert_eq!(part.ma[1], 0.0);
}
