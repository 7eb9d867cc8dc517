//! The IEEE-952 term fit on series whose terms are known in closed form: white noise (slope −½,
//! N = σ/√fs), a rate random walk (+½, K = q√fs), quantisation (−1, Q = q/√12), a rate ramp
//! (+1, R), and a seeded mixture of N, B (flicker) and K; then what is exported from them and how
//! bad input is reported.
//!
//! Tolerances come from the seed-to-seed spread of each estimate (run
//! `cargo test --release --test allan_terms -- --ignored --nocapture` to print it over 20 seeds):
//! each bound is about 3× the spread's standard deviation plus any mean offset (and at least
//! 3 %), so a correct fit fails it with a seed only rarely and a wrong constant (a factor √2,
//! √3, 0.664, ...) fails it always.

use imuprep::analysis::allan::export::{
    FLICKER_FLOOR, bias_model, gm_allan_var, gnss_imu_config, kalibr_yaml, sensor_noise,
};
use imuprep::analysis::allan::overlapping_adev;
use imuprep::analysis::allan::report::allan_report;
use imuprep::analysis::allan::terms::{FitSettings, Resolution, Term, TermFit, fit_terms};
use imuprep::model::bias_model::{ArOf, BiasModelFile, Effect};
use imuprep::model::bias_state_space::state_space_from_model;
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

const FS: f64 = 100.0;

fn fit(y: &[f64]) -> TermFit {
    fit_terms(
        &overlapping_adev(y, FS),
        FS,
        y.len(),
        &FitSettings::default(),
    )
    .unwrap()
}

fn white(n: usize, sd: f64, rng: &mut Rng) -> Vec<f64> {
    (0..n).map(|_| sd * rng.normal()).collect()
}

/// Random walk with per-sample increments of sd `q`.
fn random_walk(n: usize, q: f64, rng: &mut Rng) -> Vec<f64> {
    let mut b = 0.0;
    (0..n)
        .map(|_| {
            b += q * rng.normal();
            b
        })
        .collect()
}

/// Flicker (1/f) rate noise by Kasdin & Walter's (1992) fractional-difference filter
/// `(1 − z⁻¹)^(−1/2)`: `h₀ = 1`, `h_k = h_{k−1} (k − ½)/k`, convolved with white noise of sd `b`
/// by FFT. Its one-sided PSD is `b²/(π f)` at f ≪ fs, so its Allan floor is
/// `2 ln2 · b²/π = (2 ln2/π) B²` with B = b.
fn flicker(n: usize, b: f64, rng: &mut Rng) -> Vec<f64> {
    let len = (2 * n).next_power_of_two();
    let mut h = vec![Complex::new(0.0, 0.0); len];
    let mut w = vec![Complex::new(0.0, 0.0); len];
    let mut hk = 1.0;
    for k in 0..n {
        if k > 0 {
            hk *= (k as f64 - 0.5) / k as f64;
        }
        h[k].re = hk;
        w[k].re = b * rng.normal();
    }
    let mut planner = FftPlanner::new();
    let fwd = planner.plan_fft_forward(len);
    let inv = planner.plan_fft_inverse(len);
    fwd.process(&mut h);
    fwd.process(&mut w);
    for (a, c) in w.iter_mut().zip(&h) {
        *a *= c;
    }
    inv.process(&mut w);
    w[..n].iter().map(|c| c.re / len as f64).collect()
}

/// Rate of white angle noise: `y_k = (e_k − e_{k−1}) fs`, `e` independent uniform on
/// `±lsb/2` — the IEEE model of angle quantisation (independent rounding errors of the
/// integrated output), Allan variance `3 (lsb²/12)/τ²`.
fn angle_quantisation(n: usize, lsb: f64, rng: &mut Rng) -> Vec<f64> {
    let mut prev = (rng.uniform() - 0.5) * lsb;
    (0..n)
        .map(|_| {
            let e = (rng.uniform() - 0.5) * lsb;
            let y = (e - prev) * FS;
            prev = e;
            y
        })
        .collect()
}

fn add(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

fn resolved(f: &TermFit, t: Term) -> f64 {
    f.term(t)
        .value()
        .unwrap_or_else(|| panic!("{} not resolved: {:?}", t.letter(), f.term(t)))
}

fn assert_rel(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got / want - 1.0).abs() < tol,
        "{what}: {got:.4e} vs {want:.4e} (tolerance {tol})"
    );
}

// --- the cases, each returning (estimates, truths) so the seed-spread run can reuse them ---

fn case_white(seed: u64) -> (TermFit, f64) {
    let sd = 0.02;
    let y = white(1 << 20, sd, &mut Rng::new(seed));
    (fit(&y), sd / FS.sqrt())
}

fn case_rrw(seed: u64) -> (TermFit, f64, f64) {
    let (q, sd) = (1e-4, 0.01);
    let mut rng = Rng::new(seed);
    let y = add(
        &random_walk(1 << 20, q, &mut rng),
        &white(1 << 20, sd, &mut rng),
    );
    (fit(&y), q * FS.sqrt(), sd / FS.sqrt())
}

fn case_quant(seed: u64) -> (TermFit, f64, f64) {
    // Q = 1e-4/√12 = 2.9e-5 rad; N = 1e-5 rad/√s: the −1 and −½ lines cross at
    // τ = 3Q²/N² = 25 s, so Q is the largest term over the first 11 octaves.
    let (lsb, sd) = (1e-4, 1e-4);
    let mut rng = Rng::new(seed);
    let y = add(
        &angle_quantisation(1 << 20, lsb, &mut rng),
        &white(1 << 20, sd, &mut rng),
    );
    (fit(&y), lsb / 12f64.sqrt(), sd / FS.sqrt())
}

fn case_ramp(seed: u64) -> (TermFit, f64) {
    // R = 1e-6 unit/s over 2.9 h plus white noise N = 1e-3: the lines cross at
    // τ = (2N²/R²)^(1/3) ≈ 126 s.
    let (r, sd) = (1e-6, 0.01);
    let mut rng = Rng::new(seed);
    let y: Vec<f64> = (0..1 << 20)
        .map(|i| r * i as f64 / FS + sd * rng.normal())
        .collect();
    (fit(&y), r)
}

fn case_mixture(seed: u64) -> (TermFit, [f64; 3]) {
    // N = 1e-3, B = 1.5e-3, K = 3e-4 at 100 Hz over 5.8 h: white up to ≈ 1 s, the flicker
    // floor from ≈ 1 s to ≈ 33 s, the random walk beyond (7 octaves).
    let n = 1 << 21;
    let (nn, b, k) = (1e-3, 1.5e-3, 3e-4);
    let mut rng = Rng::new(seed);
    let w = white(n, nn * FS.sqrt(), &mut rng);
    let f = flicker(n, b, &mut rng);
    let rw = random_walk(n, k / FS.sqrt(), &mut rng);
    let y: Vec<f64> = (0..n).map(|i| w[i] + f[i] + rw[i]).collect();
    (fit(&y), [nn, b, k])
}

#[test]
fn white_noise_gives_n_equal_to_sd_over_sqrt_rate_and_nothing_else() {
    let (f, n_true) = case_white(1);
    // 20 seeds: sd 0.12 %, worst 0.27 % (ν ≈ 10⁶ at the short τ)
    assert_rel(resolved(&f, Term::RandomWalk), n_true, 0.03, "N");
    // the measured curve itself has slope −½ over the octaves the fit uses
    let p = &f.points;
    let slope = (p[12].adev / p[0].adev).ln() / (p[12].tau_s / p[0].tau_s).ln();
    assert!((slope + 0.5).abs() < 0.02, "slope {slope}");
    for t in [
        Term::Quantisation,
        Term::BiasInstability,
        Term::RateRandomWalk,
        Term::RateRamp,
    ] {
        assert_ne!(f.term(t).resolution, Resolution::Resolved, "{}", t.letter());
    }
}

#[test]
fn random_walk_gives_slope_plus_half_and_its_k() {
    let (f, k_true, n_true) = case_rrw(2);
    // 20 seeds: K sd 1.5 %, worst 3.5 %; N sd 0.08 %
    assert_rel(resolved(&f, Term::RateRandomWalk), k_true, 0.05, "K");
    assert_rel(resolved(&f, Term::RandomWalk), n_true, 0.03, "N");
    // the long-τ end of the measured curve rises as +½ (3 octaves, few EDF: ±0.15)
    let p = &f.points;
    let (a, b) = (&p[p.len() - 5], &p[p.len() - 2]);
    let slope = (b.adev / a.adev).ln() / (b.tau_s / a.tau_s).ln();
    assert!((slope - 0.5).abs() < 0.15, "slope {slope}");
    assert_ne!(
        f.term(Term::BiasInstability).resolution,
        Resolution::Resolved
    );
}

#[test]
fn angle_quantisation_gives_slope_minus_one_and_q_equal_to_lsb_over_sqrt_12() {
    let (f, q_true, n_true) = case_quant(3);
    // 20 seeds: Q sd 0.09 %, worst 0.26 %; N (only 6 octaves, few EDF) sd 2.0 %, worst 4.5 %
    assert_rel(resolved(&f, Term::Quantisation), q_true, 0.03, "Q");
    assert_rel(resolved(&f, Term::RandomWalk), n_true, 0.06, "N");
    let p = &f.points;
    let slope = (p[5].adev / p[0].adev).ln() / (p[5].tau_s / p[0].tau_s).ln();
    assert!((slope + 1.0).abs() < 0.05, "slope {slope}");
}

#[test]
fn rate_ramp_gives_slope_plus_one_and_its_r() {
    let (f, r_true) = case_ramp(4);
    // 20 seeds: mean ratio 0.993, sd 3.1 %, worst 5.2 %
    assert_rel(resolved(&f, Term::RateRamp), r_true, 0.10, "R");
}

#[test]
fn mixture_of_n_b_k_recovers_each() {
    let (f, [n, b, k]) = case_mixture(5);
    // 20 seeds: N sd 0.13 %, B sd 0.84 % (worst 1.7 %), K sd 5.1 % (worst 9.7 %: 7 octaves
    // of random walk, the last ones with ν ≈ 2–10)
    assert_rel(resolved(&f, Term::RandomWalk), n, 0.03, "N");
    assert_rel(resolved(&f, Term::BiasInstability), b, 0.03, "B");
    assert_rel(resolved(&f, Term::RateRandomWalk), k, 0.16, "K");
    // each is the largest term where it should be (crossings at ≈ 1 s and ≈ 33 s)
    let dom = |t: Term| f.term(t).dominant_tau_s.unwrap();
    assert!(
        dom(Term::RandomWalk)[1] < 3.0,
        "{:?}",
        dom(Term::RandomWalk)
    );
    let db = dom(Term::BiasInstability);
    assert!(db[0] > 0.3 && db[1] < 100.0, "{db:?}");
    assert!(
        dom(Term::RateRandomWalk)[0] > 10.0,
        "{:?}",
        dom(Term::RateRandomWalk)
    );
}

#[test]
#[ignore = "prints the seed-to-seed spread behind the tolerances above (slow)"]
fn seed_spread() {
    // The ratio estimate / truth of term `t` over the seeds' cases: its mean, spread and worst.
    fn spread<C>(name: &str, t: Term, cases: &[C], fit_truth: impl Fn(&C) -> (&TermFit, f64)) {
        let v: Vec<f64> = cases
            .iter()
            .map(|c| {
                let (f, truth) = fit_truth(c);
                f.term(t).value().unwrap_or(f64::NAN) / truth
            })
            .collect();
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let worst = v.iter().map(|x| (x - 1.0).abs()).fold(0.0, f64::max);
        eprintln!("{name}: mean ratio {m:.4}, sd {sd:.4}, worst |ratio-1| {worst:.4}");
    }
    let seeds = 100..120u64;
    let w: Vec<_> = seeds.clone().map(case_white).collect();
    spread("white N", Term::RandomWalk, &w, |c| (&c.0, c.1));
    let r: Vec<_> = seeds.clone().map(case_rrw).collect();
    spread("rrw K", Term::RateRandomWalk, &r, |c| (&c.0, c.1));
    spread("rrw N", Term::RandomWalk, &r, |c| (&c.0, c.2));
    let q: Vec<_> = seeds.clone().map(case_quant).collect();
    spread("quant Q", Term::Quantisation, &q, |c| (&c.0, c.1));
    spread("quant N", Term::RandomWalk, &q, |c| (&c.0, c.2));
    let rr: Vec<_> = seeds.clone().map(case_ramp).collect();
    spread("ramp R", Term::RateRamp, &rr, |c| (&c.0, c.1));
    let m: Vec<_> = seeds.map(case_mixture).collect();
    spread("mix N", Term::RandomWalk, &m, |c| (&c.0, c.1[0]));
    spread("mix B", Term::BiasInstability, &m, |c| (&c.0, c.1[1]));
    spread("mix K", Term::RateRandomWalk, &m, |c| (&c.0, c.1[2]));
}

// --- exports and input handling ---

/// Six channels: gyros with N, B, K; accelerometers white plus a random walk.
fn six_channel_samples(n: usize) -> Vec<Sample> {
    let mut rng = Rng::new(9);
    let chans: Vec<Vec<f64>> = (0..6)
        .map(|c| {
            let scale = if c < 3 { 1.0 } else { 10.0 };
            let w = white(n, scale * 1e-3 * FS.sqrt(), &mut rng);
            let f = flicker(n, scale * 1.5e-3, &mut rng);
            let rw = random_walk(n, scale * 1e-4 / FS.sqrt(), &mut rng);
            (0..n).map(|i| w[i] + f[i] + rw[i]).collect()
        })
        .collect();
    (0..n)
        .map(|i| {
            let mut s = Sample::nth(i, 10_000_000);
            let v: [f64; 6] = std::array::from_fn(|c| chans[c][i]);
            s.set_channels(&v);
            s
        })
        .collect()
}

/// The number after `sep` on the line of `text` that starts with `name`, up to a `#` comment.
fn value_after(text: &str, name: &str, sep: char) -> f64 {
    let line = text.lines().find(|l| l.starts_with(name)).unwrap();
    line.split(sep)
        .nth(1)
        .unwrap()
        .split('#')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

#[test]
fn exports_carry_the_terms_in_their_units() {
    let samples = six_channel_samples(1 << 20);
    let all: Vec<usize> = (0..6).collect();
    let r = allan_report("synthetic", &samples, FS, &all, &FitSettings::default()).unwrap();
    assert_eq!(r.channels.len(), 6);
    let g = sensor_noise(&r, true).unwrap();
    // the aggregate is the largest axis
    let max_n = r.channels[..3]
        .iter()
        .map(|c| c.fit.term(Term::RandomWalk).value().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(g.noise_density, max_n);
    let yaml = kalibr_yaml(&r).unwrap();
    let field = |name: &str| value_after(&yaml, name, ':');
    // a printed value is the aggregate to 7 digits
    assert_rel(
        field("gyroscope_noise_density"),
        g.noise_density,
        1e-6,
        "yaml N",
    );
    assert_rel(
        field("gyroscope_random_walk"),
        g.random_walk,
        1e-6,
        "yaml K",
    );
    assert_eq!(field("update_rate"), FS);
    // and near the generator's (N = 1e-3, K = 1e-4 for gyros; 10× for accelerometers): loose
    // bounds, since the units and the aggregation are under test here and the fit's accuracy is
    // the closed-form tests' (K is the largest of three axes, each with ~4 octaves of walk)
    assert_rel(field("gyroscope_noise_density"), 1e-3, 0.05, "gyro N");
    assert_rel(field("accelerometer_noise_density"), 1e-2, 0.05, "accel N");
    assert_rel(field("accelerometer_random_walk"), 1e-3, 0.40, "accel K");
    // GNSS_IMU: deg/s/√Hz and µg/√Hz
    let cfg = gnss_imu_config(&r).unwrap();
    let cfg_val = |name: &str| value_after(&cfg, name, '=');
    assert_rel(
        cfg_val("gyro_noise_PSD"),
        g.noise_density.to_degrees(),
        1e-6,
        "gyro_noise_PSD",
    );
    let a = sensor_noise(&r, false).unwrap();
    assert_rel(
        cfg_val("accel_noise_PSD"),
        a.noise_density / 9.80665e-6,
        1e-6,
        "accel_noise_PSD",
    );
    assert_rel(
        cfg_val("gyro_bias_PSD"),
        g.random_walk.to_degrees(),
        1e-6,
        "gyro_bias_PSD",
    );
    assert_rel(
        cfg_val("accel_bias_PSD"),
        a.random_walk / 9.80665e-6,
        1e-6,
        "accel_bias_PSD",
    );
}

#[test]
fn bias_model_export_loads_and_its_gauss_markov_meets_the_floor() {
    let samples = six_channel_samples(1 << 19);
    let all: Vec<usize> = (0..6).collect();
    let r = allan_report("synthetic", &samples, FS, &all, &FitSettings::default()).unwrap();
    let (file, notes) = bias_model(&r);
    // the written TOML is a valid model file the daemon's [bias] model reads
    let text = file.to_toml_string().unwrap();
    let back = BiasModelFile::from_toml_str(&text).unwrap();
    assert_eq!(back, file);
    for (ch, (m, note)) in r.channels.iter().zip(file.channels.iter().zip(&notes)) {
        // the online stage's state space builds from it, with the file's R taken literally
        let ss = state_space_from_model(m).unwrap();
        assert_eq!(ss.r, m.white_noise_var);
        assert_eq!(m.ar_of, ArOf::Bias);
        assert_eq!(m.ar.len(), 1);
        // the Gauss–Markov's Allan peak is the flicker floor 0.664 B, at τ_min
        let b = match ch.fit.term(Term::BiasInstability).value() {
            Some(b) => b,
            None => ch.fit.term(Term::BiasInstability).upper_bound,
        };
        let var = m.innovation_var / (1.0 - m.ar[0] * m.ar[0]);
        let tc = -1.0 / (FS * m.ar[0].ln());
        assert_rel(tc, note.tc_s, 1e-9, "T_c");
        let peak = gm_allan_var(var, tc, 1.892_618 * tc).sqrt();
        assert_rel(peak, FLICKER_FLOOR * b, 1e-4, "GM peak");
        // white noise: N² fs (+ 2 Q² fs², Q not resolved here)
        let n = ch.fit.term(Term::RandomWalk).value().unwrap();
        let q = ch.fit.term(Term::Quantisation).value().unwrap_or(0.0);
        assert_rel(
            m.white_noise_var,
            n * n * FS + 2.0 * q * q * FS * FS,
            1e-12,
            "R",
        );
        // rate random walk only for gyros, and only when resolved
        let k = ch.fit.term(Term::RateRandomWalk).value();
        let rrw: Vec<f64> = m
            .effects
            .iter()
            .filter_map(|e| match e {
                Effect::RateRandomWalk { q_per_s } => Some(*q_per_s),
                _ => None,
            })
            .collect();
        match (ch.gyro, k) {
            (true, Some(k)) => assert_eq!(rrw, vec![k * k]),
            _ => assert!(rrw.is_empty()),
        }
    }
}

#[test]
fn a_non_finite_channel_is_skipped_with_its_reason_and_the_rest_analysed() {
    let mut samples = six_channel_samples(1 << 14);
    samples[100].gyro[1] = f64::NAN;
    samples[200].gyro[1] = f64::INFINITY;
    let all: Vec<usize> = (0..6).collect();
    let r = allan_report("bad", &samples, FS, &all, &FitSettings::default()).unwrap();
    assert_eq!(r.channels.len(), 5);
    assert_eq!(r.skipped.len(), 1);
    assert_eq!(r.skipped[0].0, "gy");
    assert!(
        r.skipped[0].1.contains("2 non-finite"),
        "{}",
        r.skipped[0].1
    );
    assert!(r.to_string().contains("gy: skipped: 2 non-finite"));
    // too short or a bad rate: an error, not a panic
    assert!(allan_report("short", &samples[..10], FS, &all, &FitSettings::default()).is_err());
    assert!(allan_report("rate", &samples, 0.0, &all, &FitSettings::default()).is_err());
    // a constant channel has no curve to fit: skipped with the reason
    let mut flat = six_channel_samples(1 << 12);
    for s in &mut flat {
        s.accel[2] = 9.81;
    }
    let r = allan_report("flat", &flat, FS, &all, &FitSettings::default()).unwrap();
    assert_eq!(r.skipped.len(), 1, "{:?}", r.skipped);
    assert_eq!(r.skipped[0].0, "az");
}

#[test]
fn timing_irregularities_are_counted() {
    let mut samples = six_channel_samples(1 << 12);
    for s in &mut samples[2000..] {
        s.t_ns += 500_000_000; // a 0.5-s gap
    }
    let all: Vec<usize> = (0..6).collect();
    let r = allan_report("gap", &samples, FS, &all, &FitSettings::default()).unwrap();
    assert_eq!(r.timing.long_intervals, 1);
    assert!(
        (r.timing.max_dt_s - 0.51).abs() < 1e-9,
        "{}",
        r.timing.max_dt_s
    );
    assert_eq!(r.timing.non_increasing, 0);
}

/// `allan` reads a log held by channel (`allan_report_of`): the same report as from the
/// samples, field for field, time-stamp gaps included.
#[test]
fn the_report_of_channels_is_the_report_of_samples() {
    use imuprep::analysis::allan::report::allan_report_of;
    use imuprep::sample::Channels;
    let mut samples = six_channel_samples(1 << 16);
    // a gap and a repeated time stamp, so the timing counts are not all zero
    for s in &mut samples[30_000..] {
        s.t_ns += 50_000_000;
    }
    samples[40_000].t_ns = samples[39_999].t_ns;
    let all: Vec<usize> = (0..6).collect();
    let set = FitSettings::default();
    let want = allan_report("x", &samples, FS, &all, &set).unwrap();
    let ch: Channels = samples.iter().collect();
    let got = allan_report_of("x", &ch, FS, &all, &set).unwrap();
    // the gap, and the interval after the repeated stamp (two periods)
    assert_eq!(want.timing.long_intervals, 2);
    assert_eq!(want.timing.non_increasing, 1);
    assert_eq!(
        serde_json::to_string(&got).unwrap(),
        serde_json::to_string(&want).unwrap()
    );
}
