//! Realism and bookkeeping tests of the simulator (issue 3).
//!
//! Every random thing is seeded; every tolerance is derived in a comment from the estimator's
//! sampling distribution (3–4σ) or from a truncation-error bound.

use imuprep::sample::{CHANNEL_NAMES, N_CHANNELS, flags};
use imuprep::sim::{Effect, Emission, N_EFFECTS, Scenario, SimRecord, Simulator, Trajectory};
use imuprep::stats::ar_poly::ar_autocovariance;
use nalgebra::{Rotation3, Vector3};

mod sim_common;

use sim_common::{DRIVE, STATIC_BENCH, run, static_scenario, truth_bytes};

/// Test-only overlapping Allan deviation (IEEE Std 1139 / allantools `oadev`, frequency data).
mod allan {
    /// Overlapping ADEV of rate samples `y` (sample period `tau0_s`) at cluster size `m`:
    /// σ²(τ) = Σ_k (x_{k+2m} − 2x_{k+m} + x_k)² / (2 τ² (N + 1 − 2m)), x the integrated phase.
    pub fn oadev(y: &[f64], tau0_s: f64, m: usize) -> f64 {
        let mut x = Vec::with_capacity(y.len() + 1);
        x.push(0.0);
        let mut acc = 0.0;
        for v in y {
            acc += v * tau0_s;
            x.push(acc);
        }
        let n = x.len();
        assert!(n > 2 * m, "record too short for m = {m}");
        let tau = m as f64 * tau0_s;
        let terms = n - 2 * m;
        let s: f64 = (0..terms)
            .map(|k| {
                let d = x[k + 2 * m] - 2.0 * x[k + m] + x[k];
                d * d
            })
            .sum();
        (s / (2.0 * tau * tau * terms as f64)).sqrt()
    }
}

fn column(recs: &[SimRecord], e: Effect, c: usize) -> Vec<f64> {
    recs.iter().map(|r| r.truth.component(e, c)).collect()
}

#[test]
fn adev_helper_matches_allantools_oadev() {
    // Reference: tests/reference/sim_allan_oadev.py (allantools 2019.9 oadev, frequency data,
    // rate 1 Hz) on the fixture it wrote. Same formula, same data: agreement to summation
    // rounding, 1e-12 relative.
    let text = include_str!("fixtures/sim_adev_fixture.csv");
    let y: Vec<f64> = text.lines().map(|l| l.parse().unwrap()).collect();
    let reference = [
        (1, 0.9998454239913138),
        (4, 0.5191933600933251),
        (16, 0.2520388682899302),
        (64, 0.14052704973421992),
        (256, 0.21264970425866303),
    ];
    for (m, want) in reference {
        let got = allan::oadev(&y, 1.0, m);
        assert!((got / want - 1.0).abs() < 1e-12, "m={m}: {got} vs {want}");
    }
}

#[test]
fn white_noise_only_gives_configured_arw_at_1s_and_slope_minus_half() {
    // One hour at 100 Hz, white noise only. ARW 0.3 deg/√h → N = 0.3·π/180/60 rad/√s; the ADEV
    // of white rate noise is N/√τ, so at τ = 1 s it equals N. VRW 0.235 m/s/√h likewise.
    let scn = static_scenario(
        3600.0,
        "[errors.white_noise]\narw_deg_sqrt_h = [0.3, 0.3, 0.3]\nvrw_m_s_sqrt_h = [0.235, 0.235, 0.235]",
    );
    let recs = run(&scn, 11);
    let n = recs.len();
    assert_eq!(n, 360_000);
    let tau0 = 0.01;
    for (c, coeff) in [(0usize, 0.3f64.to_radians() / 60.0), (5, 0.235 / 60.0)] {
        // Measured minus the true signal (−g on az, 0 on gx): the white noise as the sensor
        // output shows it.
        let y: Vec<f64> = recs
            .iter()
            .map(|r| r.sample.channel(c) - r.truth.true_signal[c])
            .collect();
        // Relative sd of an ADEV estimate with N/m clusters ≈ 1/√(2(N/m − 1)) (non-overlapping;
        // the overlapping estimator is tighter, so this bound is conservative). At τ = 1 s,
        // N/m = 3600 → 1.18 %; 4σ → 4.7 %.
        let m = 100;
        let rel_sd = 1.0 / (2.0 * (n as f64 / m as f64 - 1.0)).sqrt();
        let a1 = allan::oadev(&y, tau0, m);
        eprintln!("{}: ADEV(1 s)/coeff = {}", CHANNEL_NAMES[c], a1 / coeff);
        assert!(
            (a1 / coeff - 1.0).abs() < 4.0 * rel_sd,
            "{}: ADEV(1 s) {a1} vs {coeff} (tol {:.3})",
            CHANNEL_NAMES[c],
            4.0 * rel_sd
        );
        // Log-log slope between τ = 0.1 s and 10 s: sd of ln ADEV ≈ the relative sd above
        // (3.7 % at 10 s, 0.37 % at 0.1 s), so sd(slope) ≈ √(0.037² + 0.0037²)/ln 100 = 0.0081;
        // 4σ → 0.033.
        let a_lo = allan::oadev(&y, tau0, 10);
        let a_hi = allan::oadev(&y, tau0, 1000);
        let slope = (a_hi / a_lo).ln() / 100f64.ln();
        let sd_hi = 1.0 / (2.0 * (n as f64 / 1000.0 - 1.0)).sqrt();
        let sd_lo = 1.0 / (2.0 * (n as f64 / 10.0 - 1.0)).sqrt();
        let tol = 4.0 * (sd_hi * sd_hi + sd_lo * sd_lo).sqrt() / 100f64.ln();
        eprintln!("{}: slope {slope} (tol {tol:.3})", CHANNEL_NAMES[c]);
        assert!((slope + 0.5).abs() < tol, "slope {slope} (tol {tol:.3})");
    }
}

#[test]
fn gauss_markov_only_has_autocovariance_e_inverse_sigma2_at_lag_tau() {
    // σ = 10 deg/h, τ = 1 s, one hour at 100 Hz: φ = e^(−0.01), lag τ = 100 samples.
    let sigma = 10.0 * std::f64::consts::PI / 180.0 / 3600.0;
    let scn = static_scenario(
        3600.0,
        "[[errors.gauss_markov]]\ntau_s = 1.0\ngyro_sigma_deg_h = [10.0, 0.0, 0.0]",
    );
    let recs = run(&scn, 5);
    let x = column(&recs, Effect::GaussMarkov, 0);
    let n = x.len();
    let lag = 100;
    // The process has known zero mean: no mean removal, so Bartlett's formula applies as is.
    let acov = |k: usize| {
        x[..n - k]
            .iter()
            .zip(&x[k..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / n as f64
    };
    let phi = (-0.01f64).exp();
    // Bartlett (1946): var γ̂_k ≈ (1/N) Σ_m (γ_m² + γ_{m+k} γ_{m−k}), γ_m = σ² φ^|m|.
    let gamma = |m: i64| sigma * sigma * phi.powi(m.unsigned_abs() as i32);
    let bartlett_sd = |k: i64| {
        let s: f64 = (-5000..=5000)
            .map(|m| gamma(m) * gamma(m) + gamma(m + k) * gamma(m - k))
            .sum();
        (s / n as f64).sqrt()
    };
    let want = (-1.0f64).exp() * sigma * sigma;
    let got = acov(lag);
    eprintln!(
        "GM: γ̂(τ)/(e⁻¹σ²) = {}, Bartlett sd/σ² = {}",
        got / want,
        bartlett_sd(lag as i64) / (sigma * sigma)
    );
    // Tolerance 4 Bartlett sd (sd ≈ 0.020 σ² here, 5.4 % of e⁻¹σ²).
    let tol = 4.0 * bartlett_sd(lag as i64);
    assert!(
        (got - want).abs() < tol,
        "γ̂(τ) {got:e} vs e⁻¹σ² {want:e} (tol {tol:e})"
    );
    let tol0 = 4.0 * bartlett_sd(0);
    assert!(
        (acov(0) - sigma * sigma).abs() < tol0,
        "γ̂(0) {:e} vs σ² {:e}",
        acov(0),
        sigma * sigma
    );
    // Other channels have σ = 0: exactly zero.
    assert!(
        column(&recs, Effect::GaussMarkov, 1)
            .iter()
            .all(|v| *v == 0.0)
    );
}

/// A drive used for the strapdown check: every turn given by its angle, hills included.
const STRAPDOWN_DRIVE: &str = r#"
[sensor]
sample_rate_hz = 100.0
[motion]
kind = "drive"
initial_heading_deg = 10.0
[[motion.segments]]
kind = "stop"
duration_s = 5.0
[[motion.segments]]
kind = "accelerate"
to_speed_m_s = 12.0
duration_s = 8.0
[[motion.segments]]
kind = "turn"
angle_deg = 90.0
yaw_rate_deg_s = 20.0
[[motion.segments]]
kind = "hill"
grade_percent = 8.0
duration_s = 30.0
transition_s = 5.0
[[motion.segments]]
kind = "turn"
angle_deg = -135.0
duration_s = 15.0
steer_time_s = 2.0
[[motion.segments]]
kind = "accelerate"
to_speed_m_s = 20.0
duration_s = 10.0
jerk_time_s = 2.0
[[motion.segments]]
kind = "hill"
grade_percent = -6.0
duration_s = 20.0
[[motion.segments]]
kind = "turn"
angle_deg = 60.0
yaw_rate_deg_s = 10.0
[[motion.segments]]
kind = "brake"
to_speed_m_s = 0.0
duration_s = 12.0
[[motion.segments]]
kind = "stop"
duration_s = 5.0
"#;

#[test]
fn drive_strapdown_integration_reproduces_heading_change_and_speed_profile() {
    let scn = Scenario::from_toml_str(STRAPDOWN_DRIVE).unwrap();
    let recs = run(&scn, 1);
    let dt = 0.01;
    let g_n = Vector3::new(0.0, 0.0, 9.80665);
    // Start from the known initial attitude (level, heading 10°) and rest.
    let mut c_nb = Rotation3::from_euler_angles(0.0, 0.0, 10f64.to_radians());
    let mut v_n = Vector3::zeros();
    let mut heading_unwrapped = 10f64.to_radians();
    let sim = Simulator::new(&scn, 1).unwrap();
    let Trajectory::Drive { plan, .. } = sim.trajectory() else {
        panic!("drive")
    };
    let mut max_speed_err: f64 = 0.0;
    let mut ends = plan.segment_ends().into_iter().peekable();
    let mut max_end_err: f64 = 0.0;
    for w in recs.windows(2) {
        let (a, b) = (&w[0].truth, &w[1].truth);
        let wa = Vector3::new(a.true_signal[0], a.true_signal[1], a.true_signal[2]);
        let wb = Vector3::new(b.true_signal[0], b.true_signal[1], b.true_signal[2]);
        let fa = Vector3::new(a.true_signal[3], a.true_signal[4], a.true_signal[5]);
        let fb = Vector3::new(b.true_signal[3], b.true_signal[4], b.true_signal[5]);
        // Attitude: rotation by the trapezoidal mean rate (second order; the rates are smooth).
        let c_next = c_nb * Rotation3::new((wa + wb) * (0.5 * dt));
        // Velocity: trapezoid of the navigation-frame specific force, plus gravity.
        v_n += (c_nb * fa + c_next * fb) * (0.5 * dt) + g_n * dt;
        // Heading: yaw of the forward axis, unwrapped step by step.
        let fwd_old = c_nb * Vector3::x();
        let fwd = c_next * Vector3::x();
        let d = fwd.y.atan2(fwd.x) - fwd_old.y.atan2(fwd_old.x);
        heading_unwrapped += (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
            - std::f64::consts::PI;
        c_nb = c_next;
        let speed_plan = plan.at(b.t_s).speed_m_s;
        max_speed_err = max_speed_err.max((v_n.norm() - speed_plan).abs());
        // At each segment end, the speed the scenario text asked for.
        if let Some(&(t_end, v_end)) = ends.peek()
            && (b.t_s - t_end).abs() < 0.5 * dt
        {
            max_end_err = max_end_err.max((v_n.norm() - v_end).abs());
            ends.next();
        }
    }
    // Heading change written in the scenario: 90 − 135 + 60 = 15°.
    let want = 15f64.to_radians();
    let got = heading_unwrapped - 10f64.to_radians();
    eprintln!(
        "strapdown: heading error {:e} rad, max speed error {max_speed_err:e} m/s, \
         segment-end error {max_end_err:e} m/s",
        got - want
    );
    // Trapezoidal integration of a smooth rate errs by Δt²/12 · ∫ω'' dt per segment, which
    // telescopes to Δt²/12 · [ω']_ends = 0 because every jerk-limited edge starts and ends with
    // zero slope; what remains is O(Δt⁴) plus the non-commutativity of pitch and yaw on hills,
    // both < 1e-9 rad here (observed ~3e-13). 1e-6 rad leaves margin and is 2000× below the
    // 2e-3 rad that a missing cos θ on a hill would cause.
    assert!((got - want).abs() < 1e-6, "heading change {got} vs {want}");
    // Speed: the same telescoping holds for the velocity trapezoid; the residual comes from
    // rotating f with the trapezoidal attitude (observed ~3e-5 m/s). 1e-3 m/s catches a missing
    // centripetal, slope-gravity or crest term, each ≥ 0.1 m/s after one turn or hill.
    assert!(max_speed_err < 1e-3, "speed error {max_speed_err} m/s");
    assert!(
        max_end_err < 1e-3,
        "segment-end speed error {max_end_err} m/s"
    );
    // And the final state is at rest where the text says so.
    assert!(v_n.norm() < 1e-3);
}

#[test]
fn same_seed_gives_identical_records_and_truth_bytes() {
    let scn = Scenario::from_toml_str(DRIVE).unwrap();
    let a = run(&scn, 77);
    let b = run(&scn, 77);
    assert_eq!(a, b);
    assert_eq!(truth_bytes(&scn, 77), truth_bytes(&scn, 77));
}

#[test]
fn different_seed_gives_different_noise_with_the_same_statistics() {
    let scn = Scenario::from_toml_str(DRIVE).unwrap();
    let a = run(&scn, 1);
    let b = run(&scn, 2);
    let sigma = 0.30f64.to_radians() / 60.0 * 10.0; // ARW 0.3 deg/√h at 100 Hz
    let na = column(&a, Effect::Noise, 0);
    let nb = column(&b, Effect::Noise, 0);
    assert!(na.iter().zip(&nb).filter(|(x, y)| x == y).count() == 0);
    // The true motion does not depend on the seed.
    assert!(
        a.iter()
            .zip(&b)
            .all(|(x, y)| x.truth.true_signal == y.truth.true_signal)
    );
    // Sample sd of N = 30 000 normal draws: relative sd 1/√(2N) = 0.41 %; 4σ → 1.6 %.
    let n = na.len() as f64;
    for v in [&na, &nb] {
        let sd = (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        assert!(
            (sd / sigma - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
            "sd {sd} vs {sigma}"
        );
    }
}

/// One TOML snippet per effect, each switched on alone on a tilted, Earth-rotating bench (so
/// every input-proportional effect has a non-zero input on every channel).
fn effect_snippets() -> Vec<(Option<Effect>, &'static str)> {
    vec![
        (
            Some(Effect::RoadVibration),
            "[[motion.vibration]]\nfreq_hz = 12.0\ndamping_ratio = 0.2\naccel_rms_m_s2 = [0.1, 0.1, 0.2]\ngyro_rms_deg_s = [0.2, 0.2, 0.1]",
        ),
        (
            Some(Effect::Noise),
            "[errors.white_noise]\narw_deg_sqrt_h = [0.3, 0.3, 0.3]\nvrw_m_s_sqrt_h = [0.2, 0.2, 0.2]",
        ),
        (
            Some(Effect::TurnOnBias),
            "[errors.turn_on_bias]\ngyro_deg_s = [1.0, -1.0, 0.5]\naccel_mg = [20.0, -10.0, 5.0]",
        ),
        (
            Some(Effect::ScaleFactor),
            "[errors.scale_factor]\ngyro_ppm = [1000.0, 2000.0, -500.0]\naccel_ppm = [300.0, -400.0, 500.0]",
        ),
        (
            Some(Effect::Misalignment),
            "[errors.misalignment]\ngyro_mrad = [[0.0, 1.0, 2.0], [3.0, 0.0, 4.0], [5.0, 6.0, 0.0]]\naccel_mrad = [[0.0, -1.0, 2.0], [1.0, 0.0, -2.0], [3.0, 1.0, 0.0]]",
        ),
        (
            Some(Effect::GSensitivity),
            "[errors.g_sensitivity]\ndeg_s_per_g = [[0.1, 0.0, 0.05], [0.0, 0.1, 0.02], [0.03, 0.0, 0.1]]",
        ),
        (
            Some(Effect::GaussMarkov),
            "[[errors.gauss_markov]]\ntau_s = 10.0\ngyro_sigma_deg_h = [10.0, 10.0, 10.0]\naccel_sigma_mg = [0.1, 0.1, 0.1]",
        ),
        (
            Some(Effect::ArBias),
            "[errors.ar_bias]\ngyro_coeffs = [1.5, -0.56]\ngyro_innovation_sd_deg_h = [1.0, 1.0, 1.0]\naccel_coeffs = [0.9]\naccel_innovation_sd_mg = [0.01, 0.01, 0.01]",
        ),
        (
            Some(Effect::RandomWalk),
            "[errors.random_walk]\ngyro_deg_h_sqrt_h = [20.0, 20.0, 20.0]\naccel_m_s_h_sqrt_h = [0.05, 0.05, 0.05]",
        ),
        (
            Some(Effect::Temperature),
            "[temperature.profile]\nkind = \"ramp\"\nstart_c = 20.0\nend_c = 30.0\nduration_s = 20.0\n[errors.temperature]\nt0_c = 25.0\ngyro_deg_s_per_c = [0.01, 0.01, 0.01]\naccel_mg_per_c2 = [0.01, 0.01, 0.01]",
        ),
        (
            Some(Effect::Vibration),
            "[[errors.vibration_lines]]\nfreq_hz = 3.3\ngyro_amp_deg_s = [0.1, 0.1, 0.1]\naccel_amp_mg = [1.0, 1.0, 1.0]",
        ),
        (
            Some(Effect::Step),
            "[[errors.steps]]\nt_s = 5.0\ngyro_deg_s = [0.1, 0.1, 0.1]\naccel_mg = [1.0, 1.0, 1.0]",
        ),
        (
            Some(Effect::Gross),
            "[errors.gross]\nrate_per_sample = 0.01\namplitude_sigma = [6.0, 30.0]\nrun_fraction = 0.3\ngyro_sigma_deg_s = 0.05\naccel_sigma_mg = 4.0",
        ),
        (Some(Effect::Saturation), "[errors.saturation]"),
        (
            Some(Effect::Quantisation),
            "[errors.quantisation]\ngyro_lsb_deg_s = 0.0076\naccel_lsb_mg = 0.244",
        ),
        (
            None,
            "[transport]\ndrop_prob = 0.05\nduplicate_prob = 0.05\njitter_sd_us = 100.0",
        ),
    ]
}

fn bench_with(extra: &str) -> Scenario {
    // accel range 0.6 g so that saturation has something to clip on the tilted z axis.
    let text = format!(
        r#"
[sensor]
sample_rate_hz = 100.0
accel_range_g = 0.6
[motion]
kind = "static"
duration_s = 20.0
roll_deg = 20.0
pitch_deg = -30.0
yaw_deg = 45.0
earth_rate = true
latitude_deg = 45.0
{extra}
"#
    );
    Scenario::from_toml_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

#[test]
fn each_effect_alone_shows_in_its_own_column_and_nowhere_else() {
    let baseline = run(&bench_with(""), 3);
    // No effect: measured == true exactly, no component, no flag.
    for r in &baseline {
        assert_eq!(r.sample.channels(), r.truth.true_signal);
        assert_eq!(r.truth.components, [[0.0; N_CHANNELS]; N_EFFECTS]);
        assert_eq!(r.sample.flags, 0);
    }
    for (effect, snippet) in effect_snippets() {
        let recs = run(&bench_with(snippet), 3);
        assert_eq!(recs.len(), baseline.len());
        let mut seen = [false; N_CHANNELS];
        for (r, b) in recs.iter().zip(&baseline) {
            // The true motion is untouched by any error effect.
            assert_eq!(r.truth.true_signal, b.truth.true_signal, "{snippet}");
            for e in Effect::ALL {
                for c in 0..N_CHANNELS {
                    let v = r.truth.component(e, c);
                    if Some(e) == effect {
                        seen[c] |= v != 0.0;
                    } else {
                        assert_eq!(
                            v,
                            0.0,
                            "{} leaked into {}_{}",
                            snippet,
                            e.name(),
                            CHANNEL_NAMES[c]
                        );
                    }
                }
            }
            for c in 0..N_CHANNELS {
                assert_eq!(r.sample.channel(c), r.truth.reconstructed(c));
            }
            if effect != Some(Effect::Gross) {
                assert_eq!(r.truth.gross_mask, [false; N_CHANNELS]);
            }
            if effect.is_some() {
                assert_eq!(r.emission, Emission::Normal);
                assert_eq!(r.sample.t_ns, b.sample.t_ns);
            }
        }
        match effect {
            // Saturation clips only the axes beyond ±0.6 g: the tilted z axis (0.81 g; x 0.5 g, y 0.3 g).
            Some(Effect::Saturation) => {
                assert!(seen[5] && !seen[0], "saturation on az only: {seen:?}");
                assert!(recs.iter().all(|r| r.sample.flags == flags::sat_ch(5)));
            }
            // g-sensitivity is a gyro error driven by the accelerometer input.
            Some(Effect::GSensitivity) => {
                assert_eq!(
                    seen,
                    [true, true, true, false, false, false],
                    "g-sensitivity: {seen:?}"
                );
            }
            Some(e) => assert_eq!(
                seen,
                [true; N_CHANNELS],
                "{} not on every channel",
                e.name()
            ),
            None => {
                let dropped = recs
                    .iter()
                    .filter(|r| r.emission == Emission::Dropped)
                    .count();
                let dup = recs
                    .iter()
                    .filter(|r| r.emission == Emission::Duplicated)
                    .count();
                assert!(
                    dropped > 0 && dup > 0,
                    "transport faults: {dropped} dropped, {dup} dup"
                );
                assert!(
                    recs.iter()
                        .all(|r| r.truth.dropped == (r.emission == Emission::Dropped))
                );
            }
        }
    }
}

#[test]
fn switching_one_effect_off_leaves_the_others_noise_unchanged() {
    // Each effect has its own random stream: the white noise with and without a Gauss-Markov
    // process and gross errors must be bit-identical.
    let noise = "[errors.white_noise]\narw_deg_sqrt_h = [0.3, 0.3, 0.3]\nvrw_m_s_sqrt_h = [0.2, 0.2, 0.2]\n";
    let more = "[[errors.gauss_markov]]\ntau_s = 10.0\ngyro_sigma_deg_h = [10.0, 10.0, 10.0]\n[errors.gross]\nrate_per_sample = 0.01\namplitude_sigma = [6.0, 30.0]\n";
    let a = run(&bench_with(noise), 9);
    let b = run(&bench_with(&format!("{noise}{more}")), 9);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(
            x.truth.components[Effect::Noise as usize],
            y.truth.components[Effect::Noise as usize]
        );
    }
}

#[test]
fn measured_equals_true_plus_sum_of_components_with_all_effects() {
    let scn = Scenario::from_toml_str(DRIVE).unwrap();
    let mut n_sat = 0;
    for r in Simulator::new(&scn, 4).unwrap() {
        for c in 0..N_CHANNELS {
            let m = r.sample.channel(c);
            // Summed in column order the identity is exact (Sterbenz, see src/sim/mod.rs).
            assert_eq!(m, r.truth.reconstructed(c));
            // Summed in any other order: each of the ≤ 16 additions rounds by ≤ 2⁻⁵³ of the
            // running magnitude, so |error| ≤ 16 · 1.1e-16 · Σ|terms| < 2e-15 · Σ|terms|.
            let mut terms: Vec<f64> = Effect::ALL
                .iter()
                .map(|e| r.truth.component(*e, c))
                .collect();
            terms.push(r.truth.true_signal[c]);
            let abs_sum: f64 = terms.iter().map(|t| t.abs()).sum();
            let rev: f64 = terms.iter().rev().sum();
            assert!((m - rev).abs() <= 2e-15 * abs_sum, "ch {c}: {m} vs {rev}");
        }
        n_sat += usize::from(r.sample.flags & flags::SAT_ANY != 0);
    }
    // The drive stays well inside ±250 deg/s and ±8 g: nothing is clipped.
    assert_eq!(n_sat, 0);
}

#[test]
fn gross_errors_are_spikes_and_runs_up_to_max_len_with_amplitudes_in_range() {
    let scn = static_scenario(
        600.0,
        "[errors.white_noise]\narw_deg_sqrt_h = [0.3, 0.3, 0.3]\nvrw_m_s_sqrt_h = [0.2, 0.2, 0.2]\n\
         [errors.gross]\nrate_per_sample = 0.002\namplitude_sigma = [6.0, 30.0]\nrun_fraction = 0.33\nmax_run_len = 10",
    );
    let recs = run(&scn, 21);
    let sigma = [
        0.3f64.to_radians() / 60.0 * 10.0,
        0.3f64.to_radians() / 60.0 * 10.0,
        0.3f64.to_radians() / 60.0 * 10.0,
        0.2 / 60.0 * 10.0,
        0.2 / 60.0 * 10.0,
        0.2 / 60.0 * 10.0,
    ];
    let (mut spikes, mut runs) = (0usize, 0usize);
    for (c, sigma_c) in sigma.iter().enumerate() {
        let mut len = 0usize;
        for r in &recs {
            let g = r.truth.component(Effect::Gross, c);
            assert_eq!(r.truth.gross_mask[c], g != 0.0);
            if r.truth.gross_mask[c] {
                let a = g.abs() / sigma_c;
                assert!((6.0 - 1e-9..=30.0 + 1e-9).contains(&a), "amplitude {a} σ");
                len += 1;
            } else if len > 0 {
                assert!(len <= 10, "run of {len}");
                if len == 1 {
                    spikes += 1
                } else {
                    runs += 1
                }
                len = 0;
            }
        }
    }
    // Events ≈ 0.002 · 60 000 · 6 / (1 + mean extra occupancy) ≈ 600; the run fraction is a
    // binomial proportion with sd √(0.33·0.67/600) ≈ 0.019: 4σ → ±0.077.
    let total = spikes + runs;
    assert!(total > 400, "{total} events");
    let frac = runs as f64 / total as f64;
    let sd = (0.33 * 0.67 / total as f64).sqrt();
    assert!((frac - 0.33).abs() < 4.0 * sd, "run fraction {frac}");
}

#[test]
fn transport_fault_rates_and_jitter_match_config_and_time_stays_monotonic() {
    let scn = static_scenario(
        600.0,
        "[transport]\ndrop_prob = 0.01\nduplicate_prob = 0.005\njitter_sd_us = 200.0",
    );
    let recs = run(&scn, 13);
    let n = recs.len() as f64;
    let dropped = recs
        .iter()
        .filter(|r| r.emission == Emission::Dropped)
        .count() as f64;
    let dup = recs
        .iter()
        .filter(|r| r.emission == Emission::Duplicated)
        .count() as f64;
    // Binomial counts: sd √(n p (1−p)); 4σ bounds.
    for (count, p) in [(dropped, 0.01), (dup, 0.005)] {
        let sd = (n * p * (1.0 - p)).sqrt();
        assert!((count - n * p).abs() < 4.0 * sd, "{count} vs {}", n * p);
    }
    let mut sum2 = 0.0;
    for (k, w) in recs.windows(2).enumerate() {
        assert!(w[1].sample.t_ns > w[0].sample.t_ns);
        assert_eq!(w[1].sample.seq, w[0].sample.seq.wrapping_add(1));
        let nominal = ((k + 1) as f64 * 1e7) as i64;
        let j = w[1].sample.t_ns as i64 - nominal;
        sum2 += (j * j) as f64;
    }
    // Jitter sd 200 µs = 2e5 ns, 60 000 draws (clamping never binds at 50 σ below a period):
    // relative sd of the sample sd 1/√(2n) = 0.29 %; 4σ → 1.2 %.
    let sd = (sum2 / (n - 1.0)).sqrt();
    assert!(
        (sd / 2e5 - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
        "jitter sd {sd} ns"
    );
}

#[test]
fn road_vibration_has_configured_rms_and_no_mean() {
    let scn = static_scenario(
        600.0,
        "[[motion.vibration]]\nfreq_hz = 8.0\ndamping_ratio = 0.1\naccel_rms_m_s2 = [0.3, 0.0, 0.0]",
    );
    let recs = run(&scn, 17);
    let v = column(&recs, Effect::RoadVibration, 3);
    let n = v.len() as f64;
    let rms = (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    // A resonance with ζ = 0.1 at 8 Hz decorrelates in ~1/(ζω₀) = 0.2 s = 20 samples; the
    // effective number of independent squares is ≈ N / (2·20) = 1500, so the relative sd of the
    // rms is ≈ 1/√(2·1500) = 1.8 %; 4σ → 7 %.
    assert!((rms / 0.3 - 1.0).abs() < 0.07, "rms {rms}");
    // DC zero: the mean of y = g(x[n] − x[n−1]) telescopes to g (x_N − x_0)/N, O(σ_x/N):
    // far below 1e-3 of the rms.
    let mean = v.iter().sum::<f64>() / n;
    assert!(mean.abs() < 1e-3 * 0.3, "mean {mean}");
    // It is motion: the sensor reads it, the true signal does not contain it.
    assert!(recs.iter().all(|r| r.truth.true_signal[3] == 0.0));
}

#[test]
fn ar_bias_stationary_autocovariance_matches_statsmodels() {
    // tests/reference/sim_ar_acovf.py (statsmodels arma_acovf, unit innovation variance).
    let cases: [(&[f64], [f64; 4]); 2] = [
        (
            &[1.9795, -0.97951],
            [
                2440220.902799788,
                2440208.5754010743,
                2440172.098505006,
                2440111.967299553,
            ],
        ),
        (
            &[0.5, 0.2, -0.3],
            [
                1.4930555555555556,
                0.7638888888888887,
                0.4513888888888889,
                -0.0694444444444444,
            ],
        ),
    ];
    for (phi, want) in cases {
        let got = ar_autocovariance(phi, 1.0, 3).unwrap();
        for k in 0..4 {
            // The near-unit-root AR(2) has a condition number ~1e6 in its Yule-Walker system:
            // 1e-9 relative leaves room for that, the well-conditioned AR(3) agrees to ~1e-15.
            assert!(
                (got[k] / want[k] - 1.0).abs() < 1e-9,
                "φ={phi:?} lag {k}: {} vs {}",
                got[k],
                want[k]
            );
        }
    }
}

#[test]
fn warm_up_temperature_is_written_to_temp_c_and_drives_the_bias() {
    let scn = Scenario::from_toml_str(STATIC_BENCH).unwrap();
    let mut sim = Simulator::new(&scn, 1).unwrap();
    let first = sim.next_record().unwrap();
    let last = sim.by_ref().last().unwrap();
    // Warm-up: 22.5 °C at power-on, 22.5 + 6 (1 − e^(−599.99/240)) at the end.
    let want_end = 22.5 + 6.0 * (1.0 - (-599.99f64 / 240.0).exp());
    assert_eq!(first.truth.temp_c, Some(22.5));
    assert!((last.truth.temp_c.unwrap() - want_end).abs() < 1e-9);
    // Reported: quantised to 1/340 °C with 0.01 °C noise: within 0.01·5 + 1/680 of the truth.
    let rep = last.sample.temp_c.unwrap();
    assert!((rep - want_end).abs() < 0.05 + 1.0 / 680.0);
    // The temperature bias moved with it (gyro x: 0.02 deg/s/°C around 25 °C, 30 s lag).
    let b0 = first.truth.component(Effect::Temperature, 0);
    let b1 = last.truth.component(Effect::Temperature, 0);
    assert!(b1 > b0);
}
