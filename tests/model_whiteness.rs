//! Issue 17, online model health — the monitor's whiteness (Ljung–Box) test (off by default,
//! turned on here): silent on clean simulated benches, on the ADIS16405 bench only on channels
//! carrying a real line; an unmodelled AR(1) component appearing at rest
//! flagged within 2 min. Real data skipped visibly when
//! `../shared/data/real` is absent. Numbers and commands: docs/model-health.md.

mod monitor_common;

use imuprep::analysis::spectrum::welch;
use imuprep::report::detector_compare::simulate_decoded;
use imuprep::sample::{CHANNEL_NAMES, Sample};
use imuprep::stage::monitor::{Alarm, Finding, MonitorStage};
use monitor_common::{alarms, clean_bench, cleaned, real_static_benches, watch};

fn whiteness_alarms(m: &MonitorStage) -> Vec<Alarm> {
    alarms(m)
        .into_iter()
        .filter(|x| matches!(x.finding, Finding::Whiteness(..)))
        .collect()
}

/// Per channel: the learned Q, scale, largest quiet score and its bar, tests, broken runs.
fn print_detectors(m: &MonitorStage) {
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let w = m.whiteness(c).unwrap();
        eprintln!(
            "  {name}: own Q {:.1}, scale {:.2}, EDF {:.1}, bar now {:.2}, quiet max {:.2} (bar {:.2}), {} tests, {} runs broken, ρ̂₁…₃ {:.3?}",
            w.q0().unwrap_or(f64::NAN),
            w.scale(),
            w.edf(),
            w.threshold().unwrap_or(f64::NAN),
            w.max_quiet.0,
            w.max_quiet.1,
            w.tests,
            w.breaks,
            w.baseline().map(|r| r[..3].to_vec())
        );
    }
}

#[test]
fn clean_simulated_benches_raise_no_whiteness_alarm() {
    // Four seeds × 1 h (the model_health test's), the default settings: a test per channel every
    // 15 s at p = 1e-5 (≈ 0.014 expected per hour over six channels), so one alarm here is a
    // design fault, not bad luck. The clean bench's own Gauss–Markov and AR(2) bias is slow
    // (τ ≥ 0.5 s); the bias stage's output is learned as each channel's own.
    let scn = clean_bench(3600.0);
    let mut total = 0;
    for seed in 1..=4u64 {
        let (samples, _) = simulate_decoded(&scn, seed).unwrap();
        let (out, mut settings) = cleaned(&samples, 100.0, false);
        settings.whiteness = true;
        let m = watch(&out, settings, 100.0);
        let a = whiteness_alarms(&m);
        eprintln!("seed {seed}: {} — {a:?}", m.status());
        print_detectors(&m);
        for c in 0..CHANNEL_NAMES.len() {
            assert!(m.whiteness(c).unwrap().armed(), "armed within the hour");
        }
        total += a.len();
    }
    assert_eq!(
        total, 0,
        "whiteness alarms on 4 h of clean simulated benches"
    );
}

/// Adds an AR(1) component (pole `phi` per sample, stationary sd `sd`, from its stationary
/// distribution) to channel `c` from `t0_s` on.
fn add_ar(samples: &mut [Sample], c: usize, t0_s: f64, phi: f64, sd: f64, seed: u64) {
    let mut r = imuprep::rng::Rng::new(seed);
    let mut a = sd * r.normal();
    let e = sd * (1.0 - phi * phi).sqrt();
    for s in samples.iter_mut().filter(|s| s.t_s() >= t0_s) {
        a = phi * a + e * r.normal();
        match c {
            0..=2 => s.gyro[c] += a,
            _ => s.accel[c - 3] += a,
        }
    }
}

/// The clean bench's gz white noise per sample at 100 Hz: ARW 0.32 °/√h = 0.00533 °/s/√Hz.
const GZ_WHITE_SD_DEG_S: f64 = 0.32 / 60.0 * 10.0;

/// Seconds from the onset (1800 s) to the first whiteness alarm of the default pipeline over
/// `sim` with an AR(1) of pole `phi` and sd `k` × the white σ on gz; the other channels' alarms
/// are returned too.
fn flagged_after(
    sim: &[Sample],
    phi: f64,
    k: f64,
    seed: u64,
    window_s: f64,
) -> (Option<f64>, Vec<Alarm>) {
    let mut samples = sim.to_vec();
    let sd = (k * GZ_WHITE_SD_DEG_S).to_radians();
    add_ar(&mut samples, 2, 1800.0, phi, sd, 700 + seed);
    let (out, mut settings) = cleaned(&samples, 100.0, false);
    settings.whiteness = true;
    settings.whiteness_window_s = window_s;
    let a = whiteness_alarms(&watch(&out, settings, 100.0));
    // An alarm names its window's start; it is raised at the window's end.
    let t = a
        .iter()
        .find(|x| x.channel == 2)
        .map(|x| x.t_ns as f64 * 1e-9 + window_s - 1800.0);
    (t, a)
}

#[test]
fn an_ar_component_appearing_late_is_flagged_within_two_minutes() {
    // An AR(1), φ = 0.8 per sample (correlation time 45 ms), sd 0.3× the white σ (a = 0.09,
    // 1.5× the size `diagnose` finds on a 20-min log: docs/model-health.md) on gz from 1800 s
    // of a 40-min clean bench (30 min to learn, as a running daemon has). In a 90-s window
    // N·Σρ_k² ≈ 108 against the χ²(10) bar 41.3 (tests/reference/whiteness_power.py: one full
    // window flags it with probability ≈ 1); four seeds.
    let scn = clean_bench(2400.0);
    for seed in 0..4u64 {
        let (sim, _) = simulate_decoded(&scn, 100 + seed).unwrap();
        let (after, a) = flagged_after(&sim, 0.8, 0.3, seed, 90.0);
        eprintln!("seed {seed}: flagged after {after:?} s; {a:?}");
        assert!(a.iter().all(|x| x.channel == 2), "{a:?}");
        let after = after.expect("the AR component is flagged");
        assert!(after > 0.0 && after <= 120.0, "seed {seed}: {after} s");
    }
}

/// The size / window sweep behind docs/model-health.md's table (`--ignored`).
#[test]
#[ignore]
fn sweep_ar_size_and_window() {
    let scn = clean_bench(2400.0);
    let sims: Vec<Vec<Sample>> = (0..4u64)
        .map(|seed| simulate_decoded(&scn, 100 + seed).unwrap().0)
        .collect();
    for window_s in [60.0, 90.0, 120.0] {
        for (phi, k) in [(0.8, 0.2), (0.8, 0.3), (0.8, 0.4), (0.5, 0.3), (0.5, 0.5)] {
            let times: Vec<Option<f64>> = sims
                .iter()
                .enumerate()
                .map(|(seed, sim)| {
                    let (t, a) = flagged_after(sim, phi, k, seed as u64, window_s);
                    assert!(a.iter().all(|x| x.channel == 2), "{a:?}");
                    t.map(f64::round)
                })
                .collect();
            eprintln!(
                "window {window_s} s, AR(1) φ {phi}, sd {k}× the white σ: flagged after {times:?} s \
                 (None: not in 600 s)"
            );
        }
    }
}

#[test]
fn real_static_benches_whiteness_alarms() {
    for (rel, rate, hours, samples) in real_static_benches() {
        let (out, mut settings) = cleaned(&samples, rate, false);
        settings.whiteness = true;
        let m = watch(&out, settings, rate);
        let a = whiteness_alarms(&m);
        eprintln!(
            "{rel}: {hours:.2} h, {} whiteness alarms ({:.2} per hour)",
            a.len(),
            a.len() as f64 / hours
        );
        let line_hz: Vec<(usize, f64)> = alarms(&m)
            .iter()
            .filter_map(|x| match x.finding {
                Finding::Line(hz, _) => Some((x.channel, hz)),
                _ => None,
            })
            .collect();
        // Each alarm's window against all the record's 90-s windows (rank 0–1): its variance,
        // its 0.1–5 Hz power and its power near each line of that channel — an effect growing
        // shows near the top.
        for x in &a {
            eprintln!("  {x}");
            let t0 = x.t_ns as f64 * 1e-9;
            eprintln!(
                "    variance at rank {:.3}; 0.1–5 Hz band at rank {:.3}",
                window_rank(&out, x.channel, t0, rate),
                band_rank(&out, x.channel, t0, 2.55, 2.45, rate)
            );
            for &(c, hz) in line_hz.iter().filter(|l| l.0 == x.channel) {
                let q = band_rank(&out, c, t0, hz, 0.3, rate);
                eprintln!(
                    "    line ≈ {hz:.2} Hz: band power at rank {q:.3} of the record's windows"
                );
            }
        }
        print_detectors(&m);
        // Measured (docs/model-health.md): the ADIS16405 1.44 per hour (ax 3, az 1), above the
        // target, which is why the test is off by default; two at its accelerometers'
        // intermittent ≈ 0.5 Hz line's strongest windows, two unexplained. Each is on a channel
        // carrying a real line the line test raised in the same run, none on a line-free
        // channel nor on gz with its 22-Hz line (its own scatter lowers ν to 2.5). The MPU6050's
        // 11 min, its still run broken 7 times, never arm the test: nothing there is tested.
        for x in &a {
            assert!(x.channel >= 3, "{rel}: a whiteness alarm on a gyro: {x}");
            assert!(
                line_hz.iter().any(|l| l.0 == x.channel),
                "{rel}: {x} on a channel without a line"
            );
        }
    }
}

/// The variance of channel `c` over the 90-s window from `t0_s` as the fraction of the record's
/// 90-s windows (every 15 s) with less.
fn window_rank(out: &[Sample], c: usize, t0_s: f64, rate: f64) -> f64 {
    let n = (90.0 * rate) as usize;
    let var = |from: usize| -> Option<f64> {
        let x: Vec<f64> = out
            .get(from..from + n)?
            .iter()
            .map(|s| s.channel(c))
            .collect();
        let m = x.iter().sum::<f64>() / n as f64;
        let v = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n as f64;
        v.is_finite().then_some(v)
    };
    let at = var(out.partition_point(|s| s.t_s() < t0_s)).unwrap_or(f64::NAN);
    let all: Vec<f64> = (0..out.len())
        .step_by((15.0 * rate) as usize)
        .filter_map(var)
        .collect();
    all.iter().filter(|v| **v < at).count() as f64 / all.len() as f64
}

/// Power of channel `c` within ±`half` Hz of `hz` (Welch, 10-s segments) over the 90-s window from
/// `t0_s`, as the fraction of the record's 90-s windows (every 15 s) with less.
fn band_rank(out: &[Sample], c: usize, t0_s: f64, hz: f64, half: f64, rate: f64) -> f64 {
    let band = |from: usize| -> Option<f64> {
        let n = (90.0 * rate) as usize;
        let x: Vec<f64> = out
            .get(from..from + n)?
            .iter()
            .map(|s| s.channel(c))
            .collect();
        if x.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let psd = welch(&x, rate, 1024).ok()?;
        Some(
            psd.freq_hz
                .iter()
                .zip(&psd.density)
                .filter(|(f, _)| (**f - hz).abs() <= half)
                .map(|(_, d)| *d)
                .sum(),
        )
    };
    let at = band(out.partition_point(|s| s.t_s() < t0_s)).unwrap_or(f64::NAN);
    let step = (15.0 * rate) as usize;
    let all: Vec<f64> = (0..out.len()).step_by(step).filter_map(band).collect();
    all.iter().filter(|v| **v < at).count() as f64 / all.len() as f64
}
