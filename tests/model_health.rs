//! Issue 17, online model health: the monitor stage of the embedded default pipeline watches the
//! output at rest and says when the model lacks an effect.
//!
//! Targets: false alarms ≤ 1 per hour on clean simulated logs and on the real static benches;
//! an effect of the size `diagnose` finds flagged within 2 min. On the real benches every alarm
//! must be a real effect: a line the whole neighbourhood of the alarm shows in the output's own
//! spectrum, or an accelerometer offset on a real excursion of the output (at most 1 per hour;
//! no gyro offset alarm: those benches hold no step). Real data skipped visibly when
//! `../shared/data/real` is absent.

mod monitor_common;

use monitor_common::{
    alarms, bench_without, clean_bench, cleaned, real_static_benches, watch, white_bench,
};

use imuprep::analysis::spectrum::welch;
use imuprep::report::detector_compare::simulate_decoded;
use imuprep::rng::Rng;
use imuprep::sample::{CHANNEL_NAMES, Sample};
use imuprep::stage::Stage;
use imuprep::stage::monitor::{Alarm, Finding, MonitorSettings, MonitorStage, WanderStatistic};

/// The embedded default pipeline's cleaning stages over `samples`, then the monitor (the last
/// stage of that pipeline, kept apart here so its alarms can be read).
fn monitor_over(samples: &[Sample], rate_hz: f64, wander: bool) -> MonitorStage {
    let (out, settings) = cleaned(samples, rate_hz, wander);
    watch(&out, settings, rate_hz)
}

/// Both wander statistics, the default first.
const STATISTICS: [WanderStatistic; 2] =
    [WanderStatistic::AllanRatio, WanderStatistic::BlockVariance];

/// The monitor over the cleaned output with the wander test on, statistic `st`.
fn watch_wander(
    out: &[Sample],
    settings: &MonitorSettings,
    st: WanderStatistic,
    rate: f64,
) -> MonitorStage {
    let mut on = settings.clone();
    on.wander = true;
    on.wander_statistic = st;
    watch(out, on, rate)
}

#[test]
fn clean_simulated_benches_raise_no_alarm() {
    // Four seeds × 1 h, the wander test on (each statistic): the target allows 4 false alarms; each test runs
    // every 5 s (offset), 10 s (line) or 8 s (wander) per channel at a designed false-alarm
    // probability ≤ 1e-5 per test (≤ 0.03 per hour over six channels), so even one alarm here
    // means a design fault, not bad luck.
    let scn = clean_bench(3600.0);
    let mut total = 0;
    for seed in 1..=4u64 {
        let (samples, _) = simulate_decoded(&scn, seed).unwrap();
        let (out, settings) = cleaned(&samples, 100.0, true);
        for st in STATISTICS {
            let m = watch_wander(&out, &settings, st, 100.0);
            let a = alarms(&m);
            eprintln!("seed {seed}, {st:?}: {} — {a:?}", m.status());
            for (c, name) in CHANNEL_NAMES.iter().enumerate() {
                let w = m.wander(c).unwrap();
                eprintln!(
                    "  {name}: wander quiet max {:.2} (bar {:.2}), ρ₀ {:.3e}, {} tests, {} runs broken",
                    w.max_quiet.0,
                    w.max_quiet.1,
                    w.baseline().unwrap_or(f64::NAN),
                    w.tests,
                    w.breaks
                );
                assert!(w.armed(), "the wander test arms within the hour");
            }
            assert_eq!(
                m.armed_channels(),
                6,
                "every channel armed on a still bench"
            );
            total += a.len();
        }
    }
    assert_eq!(total, 0, "false alarms on 4 h of clean simulated benches");
}

#[test]
fn a_bias_far_above_the_noise_raises_no_line_when_the_bias_stage_engages() {
    // A quiet sensor (white noise only: 0.003 °/s and 0.3 mg per sample) with turn-on gyro
    // biases of 190, 380 and 95 times that noise. The bias stage engages each gyro within the
    // first seconds, a step of the whole bias in the output. Before the line test dropped the
    // segment across that step, its first average raised a "line" at 0.39–0.49 Hz on 7 of 12
    // such 10-min benches (seeds 1–6, 100 and 200 Hz, `imuprep replay` of CSVs written with
    // numpy). Here 6 seeds × 10 min at 100 Hz, designed false-alarm probability ≤ 1e-5 per test:
    // any alarm is that fault.
    for seed in 1..=6u64 {
        let m = monitor_over(&quiet_bench(seed, 600.0, 0.0), 100.0, false);
        assert_eq!(m.armed_channels(), 6, "seed {seed}: {}", m.status());
        let a = alarms(&m);
        assert!(a.is_empty(), "seed {seed}: {a:?}");
    }
}

/// White noise of 0.003 °/s per gyro sample (0.3 mg per accelerometer sample) at 100 Hz over
/// turn-on gyro biases of 190, 380 and 95 times it, `duration_s` long; from 800 s on every gyro
/// carries a further step of `step_sd` times the σ of a white 60-s mean (0.003/√6000 °/s).
fn quiet_bench(seed: u64, duration_s: f64, step_sd: f64) -> Vec<Sample> {
    let noise_gyro = 0.003_f64.to_radians();
    let bias = [0.57_f64, -1.14, 0.285].map(|b| b.to_radians());
    let step = step_sd * noise_gyro / 6000f64.sqrt();
    let mut r = Rng::new(seed);
    (0..(duration_s * 100.0) as u32)
        .map(|i| {
            let mut s = Sample {
                seq: i,
                t_ns: u64::from(i) * 10_000_000,
                ..Sample::default()
            };
            let at = if i >= 80_000 { step } else { 0.0 };
            for (c, b) in bias.iter().enumerate() {
                s.set_channel(c, b + noise_gyro * r.normal() + at);
            }
            for (c, m) in [0.02, -0.01, 9.80665].iter().enumerate() {
                s.set_channel(3 + c, m + 0.003 * r.normal());
            }
            s
        })
        .collect()
}

#[test]
fn a_quiet_gyro_with_a_large_turn_on_bias_keeps_an_honest_offset_scale() {
    // The offset test learns the RMS of a 60-s window's mean output. Before it restarted at the
    // bias stage's engagement, the first window (seconds of the raw bias) entered that scale:
    // on these benches 9–34× the white 60-s mean's σ after 20 min (in proportion to each bias),
    // and a step of 30 such σ (4.2 °/h) at 800 s was never flagged on seeds 1–6. Now, 20-min
    // benches, seeds 1–6: without a step the learned scale is that σ within 20 % (measured
    // 0.9–1.1; ~20 independent windows, one σ of the estimate ≈ 16 %) and no alarm; with the
    // step every gyro is flagged within 60 s (measured 18–28 s: the window mean under the
    // default model's 60-s tracking peaks at 0.63 of the step, 19 σ, over a bar of 8 σ: ν ≈ 16).
    let white = 0.003_f64.to_radians() / 6000f64.sqrt();
    for seed in 1..=6u64 {
        let m = monitor_over(&quiet_bench(seed, 1200.0, 0.0), 100.0, false);
        assert!(alarms(&m).is_empty(), "seed {seed}: {:?}", alarms(&m));
        let sd: Vec<f64> = (0..3)
            .map(|c| m.level(c).unwrap().window_sd().unwrap() / white)
            .collect();
        let m = monitor_over(&quiet_bench(seed, 1200.0, 30.0), 100.0, false);
        let a = alarms(&m);
        let after: Vec<Option<f64>> = (0..3)
            .map(|c| {
                a.iter()
                    .find(|a| a.channel == c && matches!(a.finding, Finding::Offset(_)))
                    .map(|a| a.t_ns as f64 * 1e-9 + 60.0 - 800.0)
            })
            .collect();
        eprintln!(
            "quiet bench, seed {seed}: learned scale / white σ {sd:.2?}; 4.2 °/h step flagged after {after:.0?} s"
        );
        for c in 0..3 {
            assert!((0.8..=1.2).contains(&sd[c]), "seed {seed} c{c}: {}", sd[c]);
            assert!(
                after[c].is_some_and(|t| (0.0..=60.0).contains(&t)),
                "seed {seed} c{c}: {:?} ({a:?})",
                after[c]
            );
        }
    }
}

#[test]
fn clean_twenty_minute_benches_raise_no_offset_alarm_once_armed() {
    // The offset test arms after 300 s still, its scale then learned from a few windows. With a
    // plain 5-σ bar on that scale (restarted at the bias stage's engagement), seeds 7 and 11 of
    // 24 raised a false offset alarm within a minute of arming (gx 5.87 σ, gy 5.04 σ). The bar
    // that follows the scale's degrees of freedom (14.3 σ at ν = 8, 7.2 at ν = 20) raised
    // none on seeds 1–24; here seeds 1–12 (4 h).
    for seed in 1..=12u64 {
        let (samples, _) = simulate_decoded(&clean_bench(1200.0), seed).unwrap();
        let m = monitor_over(&samples, 100.0, false);
        let a: Vec<Alarm> = alarms(&m)
            .into_iter()
            .filter(|a| matches!(a.finding, Finding::Offset(_)))
            .collect();
        assert!(a.is_empty(), "seed {seed}: {a:?}");
    }
}

#[test]
fn a_step_at_two_thirds_of_a_bench_is_flagged_within_two_minutes() {
    // 150 °/h (0.0417 °/s) on gz at t = 800 s of a 20-min bench (issue 17's case).
    let scn = clean_bench(1200.0);
    let (mut samples, _) = simulate_decoded(&scn, 11).unwrap();
    let step = (150.0_f64 / 3600.0).to_radians();
    for s in samples.iter_mut().filter(|s| s.t_s() >= 800.0) {
        s.gyro.z += step;
    }
    let m = monitor_over(&samples, 100.0, false);
    let a = alarms(&m);
    eprintln!("{a:?}");
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!(a[0].channel, 2);
    let Finding::Offset(v) = a[0].finding else {
        panic!("{a:?}")
    };
    // The window's mean output holds 0.5–1 of the step under the default model's 60-s tracking.
    assert!(v > 0.4 * step && v < 1.1 * step, "{v} vs {step}");
    // Raised when the window ending then crossed the threshold: window start + 60 s.
    let raised = a[0].t_ns as f64 * 1e-9 + 60.0;
    assert!(
        raised > 800.0 && raised <= 920.0,
        "raised at {raised} s, step at 800 s"
    );
}

#[test]
fn the_full_bench_at_200_hz_arms_every_offset_test() {
    // The whole static bench (its gross errors, steps, lines and temperature kept) at 200 Hz,
    // 20 min, seed 7: the gross-error stage replaces 19–30 samples per channel and the bias
    // stage's stillness drops out 462 times (median 10 ms; 131 times at 100 Hz). The offset
    // test bridges such skips (up to 1 s in a row); it used to restart its 60-s window at
    // each, and on this bench never armed ("learning (1183 s still seen of 300 s needed)").
    let scn = bench_without(1200.0, &[], &[("sensor.sample_rate_hz", "200")]);
    let (samples, _) = simulate_decoded(&scn, 7).unwrap();
    let m = monitor_over(&samples, 200.0, false);
    eprintln!("{}", m.status());
    assert_eq!(m.armed_channels(), 6, "{}", m.status());
}

#[test]
fn a_line_appearing_half_way_is_flagged_within_two_minutes() {
    // A 7.37-Hz line of 0.02 °/s on gx (the scenario documentation's own example amplitude;
    // the white noise is 0.05 °/s per sample) from t = 600 s of a 20-min bench.
    let scn = clean_bench(1200.0);
    let (mut samples, _) = simulate_decoded(&scn, 12).unwrap();
    let amp = 0.02_f64.to_radians();
    for s in samples.iter_mut().filter(|s| s.t_s() >= 600.0) {
        let t = s.t_s();
        s.gyro.x += amp * (2.0 * std::f64::consts::PI * 7.37 * t).sin();
    }
    let m = monitor_over(&samples, 100.0, false);
    let a = alarms(&m);
    eprintln!("{a:?}");
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!(a[0].channel, 0);
    let Finding::Line(hz, _) = a[0].finding else {
        panic!("{a:?}")
    };
    assert!((hz - 7.37).abs() < 0.1, "{hz}");
    let raised = a[0].t_ns as f64 * 1e-9;
    assert!(raised > 600.0 && raised <= 720.0, "raised at {raised} s");
}

/// The output's power near `hz` over its neighbours' median, from a Welch spectrum of the
/// 600 s of channel `c` after `t_s` (a real line stands out there too; noise that crossed the
/// monitor's threshold once does not).
fn line_strength(out: &[Sample], c: usize, t_s: f64, hz: f64, rate: f64) -> f64 {
    let x: Vec<f64> = out
        .iter()
        .filter(|s| s.t_s() >= t_s && s.t_s() < t_s + 600.0)
        .map(|s| s.channel(c))
        .filter(|v| v.is_finite())
        .collect();
    let psd = welch(&x, rate, 4096).unwrap();
    let near = |lo: f64, hi: f64| {
        psd.freq_hz
            .iter()
            .zip(&psd.density)
            .filter(|(f, _)| **f >= lo && **f <= hi)
            .map(|(_, d)| *d)
            .collect::<Vec<f64>>()
    };
    let peak = near(hz - 0.15, hz + 0.15).into_iter().fold(0.0, f64::max);
    let mut around: Vec<f64> = near(hz - 2.0, hz - 0.3)
        .into_iter()
        .chain(near(hz + 0.3, hz + 2.0))
        .collect();
    around.sort_by(f64::total_cmp);
    peak / around[around.len() / 2]
}

#[test]
fn real_static_benches_alarm_only_for_real_lines_and_excursions() {
    for (rel, rate, hours, samples) in real_static_benches() {
        let (out, settings) = cleaned(&samples, rate, false);
        // The wander test (off by default), each statistic: measured, held to no alarm on the
        // gyros, and each alarm to a real excursion of the output.
        let sd10: Vec<f64> = (3..6).map(|c| white_sd_10s(&out, c, rate)).collect();
        for st in STATISTICS {
            let mw = watch_wander(&out, &settings, st, rate);
            for (c, name) in CHANNEL_NAMES.iter().enumerate() {
                let d = mw.wander(c).unwrap();
                eprintln!(
                    "  {st:?} {name}: learned no-effect value {:.3e}, EDF {:.1}, quiet max {:.2} (bar {:.2})",
                    d.baseline().unwrap_or(f64::NAN),
                    d.edf(),
                    d.max_quiet.0,
                    d.max_quiet.1
                );
            }
            let w = alarms(&mw);
            let w: Vec<&Alarm> = w
                .iter()
                .filter(|x| matches!(x.finding, Finding::Wander(_)))
                .collect();
            eprintln!("{rel}: wander test on, {st:?}: {} wander alarms", w.len());
            assert!(
                w.iter().all(|x| x.channel >= 3),
                "{rel}: a wander alarm on a gyro: {w:?}"
            );
            for x in &w {
                let t0 = x.t_ns as f64 * 1e-9;
                let e: Vec<f64> = (3..6)
                    .map(|c| excursion(&out, c, t0, rate) / sd10[c - 3])
                    .collect();
                eprintln!(
                    "  {x}; 10-s excursion in its window (× the 10-s white σ) ax {:.1} ay {:.1} az {:.1}",
                    e[0], e[1], e[2]
                );
                // Each accelerometer alarm sits on an excursion of the output that the white
                // part of its noise cannot make: of 12 ten-second means, one ≥ 4σ from their
                // median (white: P ≈ 12 × 6e-5 < 1e-3).
                assert!(e[x.channel - 3] >= 4.0, "{rel}: {x} on no excursion: {e:?}");
            }
        }
        let m = watch(&out, settings, rate);
        let a = alarms(&m);
        eprintln!("{rel}: {hours:.2} h, {} alarms", a.len());
        for x in &a {
            eprintln!("  {x}");
        }
        // Offset alarms: none on a gyro (the bias model tracks the gyros' level); on the
        // accelerometers (tested against a reference level, not zero) at most 1 per hour of
        // the bench, each on a real excursion of the output: in the 240 s its test spans (the
        // reference, the guard and the window), a 10-s mean ≥ 4 of the 10-s white σ from their
        // median (white noise: P ≈ 24 × 6e-5 < 2e-3).
        let off: Vec<&Alarm> = a
            .iter()
            .filter(|x| matches!(x.finding, Finding::Offset(_)))
            .collect();
        assert!(
            off.iter().all(|x| x.channel >= 3),
            "{rel}: an offset alarm on a gyro: {off:?}"
        );
        assert!(
            off.len() as f64 <= hours,
            "{rel}: {} offset alarms in {hours:.2} h: {off:?}",
            off.len()
        );
        for x in &off {
            let t0 = x.t_ns as f64 * 1e-9 - 180.0;
            let e: Vec<f64> = (3..6)
                .map(|c| {
                    let m = means_10s(&out, c, t0, 24, rate);
                    let mid = median(m.clone());
                    m.iter().map(|v| (v - mid).abs()).fold(0.0, f64::max) / sd10[c - 3]
                })
                .collect();
            eprintln!(
                "  {x}: 10-s excursion over its test's 240 s (× the 10-s white σ) ax {:.1} ay {:.1} az {:.1}",
                e[0], e[1], e[2]
            );
            assert!(e[x.channel - 3] >= 4.0, "{rel}: {x} on no excursion: {e:?}");
        }
        assert!(
            a.iter()
                .all(|x| matches!(x.finding, Finding::Line(..) | Finding::Offset(_))),
            "{a:?}"
        );
        for x in &a {
            let Finding::Line(hz, _) = x.finding else {
                continue;
            };
            let r = line_strength(&out, x.channel, x.t_ns as f64 * 1e-9, hz, rate);
            eprintln!(
                "  {} {hz:.3} Hz: {r:.1}× its neighbours over 600 s",
                CHANNEL_NAMES[x.channel]
            );
            // A line in 600 s of data at 4096-sample resolution: the peak bin ≥ 2× the median
            // of its ±2 Hz neighbours (noise alone: P(χ²₁₄/14 ≥ 2) ≈ 0.015 per bin; with 3
            // bins searched ≈ 5 %). A single crossing of the monitor's threshold by noise
            // would not persist over 600 s.
            assert!(
                r >= 2.0,
                "{rel}: {x} is not in the output's spectrum ({r:.2}×)"
            );
        }
    }
}

/// 10-s means of channel `c` of `out` from `t0_s` on, `k` of them.
fn means_10s(out: &[Sample], c: usize, t0_s: f64, k: usize, rate: f64) -> Vec<f64> {
    let per = (10.0 * rate).round() as usize;
    let i0 = out.partition_point(|s| s.t_s() < t0_s);
    out[i0..]
        .chunks_exact(per)
        .take(k)
        .map(|b| b.iter().map(|s| s.channel(c)).sum::<f64>() / per as f64)
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The white part of the 10-s means' σ over the whole record: 1.4826 MAD of successive
/// differences / √2 (slow wander barely moves successive differences).
fn white_sd_10s(out: &[Sample], c: usize, rate: f64) -> f64 {
    let m = means_10s(out, c, 0.0, usize::MAX, rate);
    let d: Vec<f64> = m.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    1.4826 * median(d) / 2f64.sqrt()
}

/// Largest distance of a 10-s mean of the 120-s window from `t0_s` to the window's median.
fn excursion(out: &[Sample], c: usize, t0_s: f64, rate: f64) -> f64 {
    let m = means_10s(out, c, t0_s, 12, rate);
    let mid = median(m.clone());
    m.iter().map(|v| (v - mid).abs()).fold(0.0, f64::max)
}

/// Adds a first-order Gauss–Markov wander (correlation time `tau_s`, stationary sd `sd`, exact
/// discretisation, started from its stationary distribution) to channel `c` from `t0_s` on.
fn add_wander(samples: &mut [Sample], c: usize, t0_s: f64, tau_s: f64, sd: f64, seed: u64) {
    let mut r = imuprep::rng::Rng::new(seed);
    let mut b = sd * r.normal();
    let mut last_t: Option<f64> = None;
    for s in samples.iter_mut().filter(|s| s.t_s() >= t0_s) {
        let t = s.t_s();
        if let Some(lt) = last_t {
            let phi = (-(t - lt) / tau_s).exp();
            b = phi * b + sd * (1.0 - phi * phi).sqrt() * r.normal();
        }
        last_t = Some(t);
        match c {
            0..=2 => s.gyro[c] += b,
            _ => s.accel[c - 3] += b,
        }
    }
}

/// Alarms of the default pipeline with the wander test on (statistic `st`) over `sim` with a
/// Gauss–Markov wander (τ = 20 s, sd `sd`) added to gz from 1800 s.
fn alarms_with_late_wander(sim: &[Sample], sd: f64, seed: u64, st: WanderStatistic) -> Vec<Alarm> {
    let mut samples = sim.to_vec();
    add_wander(&mut samples, 2, 1800.0, 20.0, sd, 500 + seed);
    let (out, settings) = cleaned(&samples, 100.0, true);
    alarms(&watch_wander(&out, &settings, st, 100.0))
}

/// Seconds from the wander's onset (1800 s) to its first wander alarm (a window is tested at its
/// end, 120 s after the start the alarm names).
fn wander_flagged_after_s(a: &[Alarm]) -> Option<f64> {
    a.iter()
        .find(|x| matches!(x.finding, Finding::Wander(_)))
        .map(|x| x.t_ns as f64 * 1e-9 + 120.0 - 1800.0)
}

#[test]
fn a_wander_appearing_late_is_flagged_within_two_minutes() {
    // A Gauss–Markov wander, τ = 20 s, σ = 0.02 °/s (72 °/h: 4× the 1-s mean of the gyro's
    // white noise, 0.005 °/s; 7× the bench's own τ = 20 s term), on gz from t = 1800 s of a 40-min
    // bench (30 min to learn the channel, as a running daemon has). Measured over τ = 8, 12,
    // 16 s and σ = 2, 3, 4× (docs/model-health.md): 4× is the smallest size flagged within 2 min
    // on every seed; 3× takes 83–195 s, 2× 155–315 s or is missed. Four seeds.
    let scn = clean_bench(2400.0);
    let sd = 0.02_f64.to_radians();
    for seed in 0..4u64 {
        let (sim, _) = simulate_decoded(&scn, 100 + seed).unwrap();
        let a = alarms_with_late_wander(&sim, sd, seed, WanderStatistic::AllanRatio);
        eprintln!("seed {seed}: {a:?}");
        // The first alarm is the wander's on gz; no alarm on the five clean channels.
        assert!(
            matches!(a.first().map(|x| x.finding), Some(Finding::Wander(_))),
            "{a:?}"
        );
        assert!(a.iter().all(|x| x.channel == 2), "{a:?}");
        let after = wander_flagged_after_s(&a).unwrap();
        assert!(
            after > 0.0 && after <= 120.0,
            "seed {seed}: flagged {after} s after the onset"
        );
    }
}

#[test]
fn block_variance_flags_a_wander_of_the_size_diagnose_finds_within_two_minutes() {
    // The diagnose ladder's white background (tests/wander_ladder.rs: there diagnose keeps a
    // GM wander of 1× the 1-s white σ on every 20-min log), a GM of that size (τ = 20 s,
    // 0.005 °/s) on gz from 1800 s of 40 min, the block-variance statistic: flagged 42–107 s
    // after the onset on these four seeds (docs/model-health.md; the Allan ratio: 1 of 4 within
    // 600 s), and no alarm on the other channels.
    let scn = white_bench(2400.0);
    let sd = 0.005_f64.to_radians();
    for seed in 0..4u64 {
        let (sim, _) = simulate_decoded(&scn, 100 + seed).unwrap();
        let a = alarms_with_late_wander(&sim, sd, seed, WanderStatistic::BlockVariance);
        eprintln!("seed {seed}: {a:?}");
        // Every alarm on gz (the offset test may see the wander's mean too: also a detection).
        assert!(a.iter().all(|x| x.channel == 2), "{a:?}");
        let after = wander_flagged_after_s(&a).expect("the wander is flagged");
        assert!(
            after > 0.0 && after <= 120.0,
            "seed {seed}: flagged {after} s after the onset"
        );
    }
}

/// The size / τ sweep behind docs/model-health.md's table (`--ignored`: 36 runs of 40 min).
#[test]
#[ignore]
fn sweep_wander_size_and_tau() {
    let scn = clean_bench(2400.0);
    // 1-s mean of the gyro white noise: 0.05 °/s per sample at 100 Hz → 0.005 °/s.
    let w1 = 0.005_f64.to_radians();
    let sims: Vec<Vec<Sample>> = (0..4u64)
        .map(|seed| simulate_decoded(&scn, 100 + seed).unwrap().0)
        .collect();
    for tau in [8.0, 12.0, 16.0] {
        for k in [2.0, 3.0, 4.0] {
            let mut times = Vec::new();
            for (seed, sim) in sims.iter().enumerate() {
                let mut samples = sim.clone();
                add_wander(&mut samples, 2, 1800.0, 20.0, k * w1, 500 + seed as u64);
                let (out, mut st) = cleaned(&samples, 100.0, true);
                st.wander_tau_s = tau;
                let a = alarms(&watch(&out, st, 100.0));
                // The five clean channels stay quiet at every τ.
                assert!(a.iter().all(|x| x.channel == 2), "τ {tau}: {a:?}");
                times.push(wander_flagged_after_s(&a).map(f64::round));
            }
            eprintln!("τ {tau} s, σ {k}× the 1-s white σ: flagged after {times:?} s");
        }
    }
}

/// The monitor's time to flag a wander of the size `diagnose` finds (`tests/wander_ladder.rs`:
/// kept on every 20-min log from 1× the 1-s white σ, on most from 0.5×) from 1800 s of a 40-min
/// log, on the ladder's own white background and on the clean bench (whose own Gauss–Markov
/// and AR bias the monitor learns as its no-effect value), each statistic, the sweep's seeds
/// (`--ignored`: 80 runs of 40 min).
#[test]
#[ignore]
fn wander_of_the_size_diagnose_finds() {
    let w1 = 0.005_f64.to_radians();
    for (bench, scn) in [
        ("white", white_bench(2400.0)),
        ("clean bench", clean_bench(2400.0)),
    ] {
        let sims: Vec<Vec<Sample>> = (0..4u64)
            .map(|seed| simulate_decoded(&scn, 100 + seed).unwrap().0)
            .collect();
        for k in [0.5, 1.0, 1.5, 2.0, 3.0] {
            for st in STATISTICS {
                let times: Vec<Option<f64>> = sims
                    .iter()
                    .enumerate()
                    .map(|(seed, sim)| {
                        let a = alarms_with_late_wander(sim, k * w1, seed as u64, st);
                        assert!(a.iter().all(|x| x.channel == 2), "{bench} {k}×: {a:?}");
                        wander_flagged_after_s(&a).map(f64::round)
                    })
                    .collect();
                eprintln!(
                    "{bench}, {st:?}, σ {k}× the 1-s white σ (τ 20 s): flagged after {times:?} s \
                     (None: not in 600 s)"
                );
            }
        }
    }
}

/// 1 mg, m/s².
const MG: f64 = 9.80665e-3;

/// The monitor over `out`, with the sensor time at which each alarm was raised (the alarm
/// itself names the start of the window that first showed the effect).
fn watch_timed(out: &[Sample], settings: MonitorSettings, rate_hz: f64) -> Vec<(f64, Alarm)> {
    let mut m = MonitorStage::new(settings, Some(rate_hz)).unwrap();
    let mut sink = Vec::with_capacity(1);
    let mut raised = Vec::new();
    let mut seen = 0;
    for s in out {
        m.push(*s, &mut sink);
        sink.clear();
        let n = m.alarms().count();
        if n > seen {
            raised.extend(m.alarms().skip(seen).map(|a| (s.t_s(), *a)));
            seen = n;
        }
    }
    raised
}

/// Seconds from an accelerometer bias step (`mg` on every accelerometer axis from `t0` s of a
/// clean bench of `len_s`, seed `seed`) to each axis's first offset alarm (`None`: not raised),
/// and every alarm of the run with the time it was raised.
fn accel_step_flagged_after_s(
    mg: f64,
    t0: f64,
    len_s: f64,
    seed: u64,
) -> ([Option<f64>; 3], Vec<(f64, Alarm)>) {
    let scn = clean_bench(len_s);
    let (mut samples, _) = simulate_decoded(&scn, seed).unwrap();
    for s in samples.iter_mut().filter(|s| s.t_s() >= t0) {
        for a in 0..3 {
            s.accel[a] += mg * MG;
        }
    }
    let (out, settings) = cleaned(&samples, 100.0, false);
    let a = watch_timed(&out, settings, 100.0);
    let mut after = [None; 3];
    for (t, x) in &a {
        if let Finding::Offset(_) = x.finding
            && x.channel >= 3
            && after[x.channel - 3].is_none()
        {
            after[x.channel - 3] = Some(t - t0);
        }
    }
    (after, a)
}

#[test]
fn an_accelerometer_step_is_flagged_within_two_minutes() {
    // A bias step on every accelerometer axis at 800 s of a 20-min clean bench, seeds 21–24.
    // `diagnose` keeps a step of 1 mg (ax) on 3 of 4 such logs, 0.75 mg (az) on 3 of 4, 0.5 mg
    // (ay) on 1 of 4, 1.5 and 2 mg on all (docs/model-health.md), so 1 mg is the size it finds. Against zero the
    // offset test flagged none of them (2 mg, seed 21: no axis; its learned scale held
    // gravity's projection); against
    // the reference level: 2 mg on all 12 axes in 51.6–57.6 s, 1 mg on 10 of 12 in 56.6–77.8 s
    // (az: 136.6 s on seed 23, missed on seed 22). No alarm before the step on any seed.
    let mut within_1mg = 0;
    for seed in 21..25u64 {
        for (mg, need_all) in [(2.0, true), (1.0, false)] {
            let (after, a) = accel_step_flagged_after_s(mg, 800.0, 1200.0, seed);
            eprintln!("{mg} mg, seed {seed}: flagged after {after:?} s");
            assert!(
                a.iter().all(|(t, x)| *t >= 800.0 && x.channel >= 3),
                "{mg} mg, seed {seed}: {a:?}"
            );
            let fast = after.iter().flatten().filter(|t| **t <= 120.0).count();
            if need_all {
                assert_eq!(fast, 3, "{mg} mg, seed {seed}: {after:?}");
            } else {
                within_1mg += fast;
            }
        }
    }
    // Measured 10 of 12: a regression, not noise, if fewer (the runs are seeded).
    assert!(
        within_1mg >= 10,
        "1 mg flagged within 2 min on {within_1mg} of 12 axes"
    );
}

#[test]
#[ignore]
fn sweep_accel_step_size() {
    for mg in [0.5, 0.75, 1.0, 2.0, 3.0] {
        for seed in 21..25u64 {
            let (after, a) = accel_step_flagged_after_s(mg, 800.0, 1200.0, seed);
            let other: Vec<String> = a
                .iter()
                .filter(|(t, _)| *t < 800.0)
                .map(|(t, x)| format!("{t:.0} s: {x}"))
                .collect();
            eprintln!(
                "{mg} mg, seed {seed}: ax/ay/az flagged after {after:?} s; before the step: {other:?}"
            );
        }
    }
}

/// Why a 1 mg step on az is at the edge (docs/model-health.md, "Time to flag"): the offset
/// test's statistic `D` (median of the last twelve 5-s means minus the median of the 24 that end
/// 60 s before them) recomputed on the cleaned output of the clean bench, every 5 s: its RMS
/// before the step (what the test learns its scale from) and its median from 30 to 180 s after
/// a 1 mg step on every axis (where the test sees the step at full size), in mg. The 5-s means
/// are taken over every sample (the bench is still 99.8 % of the time), so this is the test's
/// statistic without its skips.
#[test]
#[ignore]
fn accel_step_statistic_against_its_noise() {
    let d_series = |out: &[Sample], c: usize| -> Vec<(f64, f64)> {
        let per = 500; // 5 s at 100 Hz
        let b: Vec<f64> = out
            .chunks_exact(per)
            .map(|w| w.iter().map(|s| s.accel[c - 3]).sum::<f64>() / per as f64)
            .collect();
        (48..=b.len())
            .map(|k| {
                let blk = &b[k - 48..k];
                let d = median(blk[36..].to_vec()) - median(blk[..24].to_vec());
                (k as f64 * 5.0, d / MG)
            })
            .collect()
    };
    for seed in 21..25u64 {
        let scn = clean_bench(1200.0);
        let (mut samples, _) = simulate_decoded(&scn, seed).unwrap();
        for s in samples.iter_mut().filter(|s| s.t_s() >= 800.0) {
            for a in 0..3 {
                s.accel[a] += MG;
            }
        }
        let (out, _) = cleaned(&samples, 100.0, false);
        let mut line = format!("seed {seed}:");
        for (c, name) in CHANNEL_NAMES.iter().enumerate().skip(3) {
            let d = d_series(&out, c);
            let pre: Vec<f64> = d.iter().filter(|x| x.0 <= 800.0).map(|x| x.1).collect();
            let rms = (pre.iter().map(|v| v * v).sum::<f64>() / pre.len() as f64).sqrt();
            let post = median(
                d.iter()
                    .filter(|x| x.0 > 830.0 && x.0 < 980.0)
                    .map(|x| x.1)
                    .collect(),
            );
            line += &format!(
                "  {name}: pre RMS {rms:.3}, post median {post:.3} ({:.1}×)",
                post / rms
            );
        }
        eprintln!("{line}");
    }
}
