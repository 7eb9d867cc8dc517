//! A sensor class we do not have: a foot-mounted IMU on a walking pedestrian at 100, 400 and
//! 1000 Hz (`replay/gait.toml`, the simulator's `gait` motion: src/sim/gait.rs), through the
//! embedded default pipeline and scored with the audit's do-no-harm measures
//! (`imuprep::report::audit::score_harm`).
//!
//! The simulator injects no gross error, so every REPLACED flag is a false replacement. Per rate:
//! - replaced channel-samples ≤ 1e-4 per channel-sample, every channel;
//! - invented angle |∫(out − raw)dt + ∫bias dt| ≤ 0.5° per gyro axis;
//! - the bias estimate moves by at most its own published 3σ across every motion onset;
//! - the bias estimate against the simulator's true gyro bias at the end of every stand-still
//!   and at the end of the walk, within `BIAS_K` σ of the estimate's own σ and the simulated
//!   bias instability combined (below, with why);
//! - no foot-flat sample reaches the bias estimate: the stage uses a sample only when the
//!   detector still reports rest `update_delay_s` later, so a stance whose slow roll (0.8 °/s)
//!   were taught as bias would show as a foot-flat sample STILL that much later.
//!
//! Also, at 400 Hz: the same walk on a ±250 °/s, ±4 g sensor (the swing and the heel strikes
//! clip): every clipped channel-sample flagged saturated, none replaced; and the audit's seeded
//! spikes and runs (`inject_spikes`, target F1 ≥ 0.95 on moving recordings), reported.
//!
//! What is missed is bounded at its measured value (`KNOWN_MISSES`, as tests/sensor_classes.rs
//! does), with its cause in docs/real-data.md, "A foot-mounted walker at 400 Hz and 1 kHz
//! (simulated)". `cargo test --release --test sensor_class_gait -- --nocapture` prints the
//! table there.

mod common;

use imuprep::config::Config;
use imuprep::frame::Descriptor;
use imuprep::report::audit::{
    Class, HarmScore, classify, inject_spikes, load_recording, run_config, score_harm,
    score_injections,
};
use imuprep::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use imuprep::sim::gait::{GaitPlan, SpanKind};
use imuprep::sim::{Effect, Scenario, Simulator, Trajectory, TruthRow};

const SCENARIO: &str = include_str!("../replay/gait.toml");
/// Seed of the simulation and of the injections.
const SEED: u64 = 400;
/// The bias estimate may differ from the true bias by at most `BIAS_K`·√(σ̂² + σ_GM²): σ̂ its own
/// published σ, σ_GM the scenario's bias instability (its Gauss–Markov σ, 30 °/h = 0.0083 °/s).
/// Not σ̂ alone: the default estimator follows the bias with a 60-s time constant and learns
/// only at rest, while the simulated bias wanders with τ = 100 s, so part of that wander is
/// beyond it by design: on the same sensor standing still for 90 s (this scenario with
/// `motion.initial_still_s = 90`, `bouts = 1`, `strides_per_bout = 1`, seed 400) its error
/// reaches 9.4 σ̂ (0.015 °/s). With both, a consistent estimator stays within 4σ but for 6.3e-5
/// per check. The bound is ≈ 0.035 °/s here, 23× below the stance roll's mean rate (0.8 °/s)
/// and 11× below the 0.4 °/s of motion the walker saw learnt as bias;
/// `stance_measurements` checks the leak itself, exactly.
const BIAS_K: f64 = 4.0;

/// Targets missed, bounded at the measured value (rounded at the second significant digit,
/// away from the target): (rate, channel, target prefix, bound). A listed miss that is met now
/// fails too, so the list stays true. Cause (docs/real-data.md, "A foot-mounted walker"): at
/// 100 Hz a heel strike's or toe-off's 6.5-ms pulse falls on one sample or none and its ringing
/// on the next two or three, each a one- or two-sample break; the several-axes test cannot
/// tell them from a corrupted frame (all six channels off on one sample only) or from a
/// glitch riding on a shock (the other axes still ring, but less than a quarter as sharply
/// as the event on their own scale). Measured: gx 1, ax 3, ay 9, az 15 of 9281 samples.
const KNOWN_MISSES: &[(&str, &str, &str, f64)] = &[
    ("100", "gx", "replaced per channel-sample", 1.1e-4),
    ("100", "ax", "replaced per channel-sample", 3.3e-4),
    ("100", "ay", "replaced per channel-sample", 9.7e-4),
    ("100", "az", "replaced per channel-sample", 1.7e-3),
];

/// The audit's injected spikes and runs on the 400-Hz walk: F1 measured 0.9162 (recall 0.845,
/// precision 1.000), below the 0.95 target as on every moving real recording (0.92–0.94 there):
/// bounded here, rounded down.
const INJECTED_F1_BOUND: f64 = 0.91;

/// One simulated walk: the descriptor and samples as `imuprep replay` reads them from the log
/// (f32 frames), the truth per sample and the walk's plan.
struct Walk {
    rate: f64,
    /// The scenario's Gauss–Markov bias σ per gyro axis, rad/s (all entries combined).
    gm_sigma: [f64; 3],
    desc: Descriptor,
    raw: Vec<Sample>,
    truth: Vec<TruthRow>,
    plan: GaitPlan,
}

fn simulate(sets: &[(&str, &str)]) -> Walk {
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let scn = Scenario::from_toml_str_with(SCENARIO, &sets).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("gait.log");
    imuprep::io::sim_log::write_sim_log(&scn, SEED, &log, None).unwrap();
    let (desc, raw) = load_recording(&log).unwrap();
    let sim = Simulator::new(&scn, SEED).unwrap();
    let Trajectory::Gait { plan, .. } = sim.trajectory() else {
        panic!("gait")
    };
    let plan = plan.clone();
    let truth: Vec<TruthRow> = sim.map(|r| r.truth).collect();
    assert_eq!(
        raw.len(),
        truth.len(),
        "no transport faults: one sample per instant"
    );
    let gm_sigma = std::array::from_fn(|a| {
        let v: f64 = scn
            .errors
            .gauss_markov
            .iter()
            .filter(|g| g.enabled)
            .map(|g| (g.gyro_sigma_deg_h[a] / 3600.0).to_radians().powi(2))
            .sum();
        v.sqrt()
    });
    Walk {
        rate: scn.sensor.sample_rate_hz,
        gm_sigma,
        desc,
        raw,
        truth,
        plan,
    }
}

/// The true gyro bias of a truth row, rad/s: every sensor-error component that is a bias.
fn true_bias(t: &TruthRow, c: usize) -> f64 {
    [
        Effect::TurnOnBias,
        Effect::GaussMarkov,
        Effect::ArBias,
        Effect::RandomWalk,
        Effect::Temperature,
        Effect::Step,
    ]
    .iter()
    .map(|e| t.component(*e, c))
    .sum()
}

/// The bias estimate against the truth at one instant.
#[derive(Debug, Clone, Copy)]
struct BiasCheck {
    t_s: f64,
    /// Worst axis (largest error against its bound): |estimate − true| in °/s, in the estimate's
    /// own σ, and against the bound `BIAS_K`·√(σ̂² + σ_GM²).
    err_deg_s: f64,
    err_sigma: f64,
    err_bound: f64,
    axis: usize,
    /// A running estimate is subtracted (`BIAS_REMOVED`, non-zero bias).
    engaged: bool,
}

/// The checks: the last sample of every stand-still (before a pivot or a bout) and of the walk.
fn bias_checks(w: &Walk, out: &[Sample]) -> Vec<BiasCheck> {
    w.plan
        .spans()
        .iter()
        .filter(|s| s.kind == SpanKind::Standing)
        .map(|span| {
            // The last sample instant strictly before the end of the span.
            let i = w.truth.partition_point(|r| r.t_s < span.t1_s - 1e-9) - 1;
            let s = &out[i];
            let mut worst: Option<BiasCheck> = None;
            for c in 0..3 {
                let err = (f64::from(s.bias[c]) - true_bias(&w.truth[i], c)).abs();
                let sd = f64::from(s.bias_sd[c]);
                let check = BiasCheck {
                    t_s: w.truth[i].t_s,
                    err_deg_s: err.to_degrees(),
                    err_sigma: err / sd,
                    err_bound: err / (BIAS_K * sd.hypot(w.gm_sigma[c])),
                    axis: c,
                    engaged: s.bias_subtracted(),
                };
                if worst.is_none_or(|w| check.err_bound > w.err_bound) {
                    worst = Some(check);
                }
            }
            worst.unwrap()
        })
        .collect()
}

/// Foot-flat samples that reached the bias estimate (used as a still measurement: STILL
/// `update_delay_s` later, as the bias stage's delay line decides), and foot-flat samples
/// flagged STILL at all (the detector's hysteresis carries a stand-still's STILL a few tens of
/// ms into the first stance of a bout; harmless while the delay line drops them).
fn stance_measurements(w: &Walk, out: &[Sample]) -> (usize, usize) {
    let cfg = Config::default_embedded().unwrap();
    let delay_s = cfg.stages.bias.as_ref().unwrap().settings.update_delay_s;
    let delay = (delay_s * w.rate).round() as usize;
    let spans = w.plan.spans();
    let (mut used, mut still) = (0, 0);
    for (i, r) in w.truth.iter().enumerate() {
        let k = spans
            .partition_point(|sp| sp.t0_s <= r.t_s)
            .saturating_sub(1);
        if spans[k].kind != SpanKind::FootFlat || !out[i].has(flags::STILL) {
            continue;
        }
        still += 1;
        used += usize::from(out.get(i + delay).is_some_and(|s| s.has(flags::STILL)));
    }
    (used, still)
}

struct Row {
    rate: f64,
    samples: usize,
    score: HarmScore,
    checks: Vec<BiasCheck>,
    /// Foot-flat samples used as still measurements, and flagged STILL.
    stance: (usize, usize),
}

fn fmt_row(r: &Row) -> String {
    let rep: Vec<String> = r
        .score
        .channels
        .iter()
        .map(|c| format!("{:.1e}", c.replaced_rate))
        .collect();
    let ang: Vec<String> = r
        .score
        .channels
        .iter()
        .filter_map(|c| c.invented_angle_deg)
        .map(|a| format!("{a:.3}"))
        .collect();
    let worst = r
        .checks
        .iter()
        .max_by(|a, b| a.err_bound.total_cmp(&b.err_bound))
        .unwrap();
    format!(
        "| {:.0} Hz | {} | {} | {} | {} | {:.2} | {:.4} °/s = {:.1} σ̂ = {:.2} of the bound ({}, {:.1} s) | {} ({} STILL) |",
        r.rate,
        r.samples,
        rep.join(" "),
        ang.join(" "),
        r.score.onsets,
        r.score.onset_worst_move_3sigma,
        worst.err_deg_s,
        worst.err_sigma,
        worst.err_bound,
        CHANNEL_NAMES[worst.axis],
        worst.t_s,
        r.stance.0,
        r.stance.1,
    )
}

fn run_default(w: &Walk) -> Vec<Sample> {
    run_config(&Config::default_embedded().unwrap(), &w.desc, &w.raw).unwrap()
}

#[test]
fn the_default_pipeline_does_no_harm_on_a_foot_mounted_walker() {
    let start = std::time::Instant::now();
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for rate in ["100", "400", "1000"] {
        let w = simulate(&[("sensor.sample_rate_hz", rate)]);
        assert_eq!(classify(&w.raw, w.rate), Class::Moving);
        let out = run_default(&w);
        let name = format!("gait at {rate} Hz");
        let score = score_harm(&name, Class::Moving, w.rate, &w.raw, &out);
        for t in &score.targets {
            let known = KNOWN_MISSES.iter().find(|(r, ch, what, _)| {
                *r == rate && t.channel == *ch && t.target.starts_with(what)
            });
            failures.extend(common::judge_target(t, &name, known.map(|k| k.3)));
        }
        if score.onsets == 0 {
            failures.push(format!("{name}: no motion onset with a running estimate"));
        }
        let checks = bias_checks(&w, &out);
        for c in &checks {
            if !c.engaged || c.err_bound > 1.0 {
                failures.push(format!(
                    "{name}: bias at {:.2} s {} off by {:.4} °/s = {:.2} of the bound (engaged {})",
                    c.t_s, CHANNEL_NAMES[c.axis], c.err_deg_s, c.err_bound, c.engaged
                ));
            }
        }
        let stance = stance_measurements(&w, &out);
        if stance.0 > 0 {
            failures.push(format!(
                "{name}: {} foot-flat samples reached the bias estimate",
                stance.0
            ));
        }
        rows.push(Row {
            rate: w.rate,
            samples: w.raw.len(),
            score,
            checks,
            stance,
        });
    }
    eprintln!(
        "| rate | samples | replaced per ch-sample gx gy gz ax ay az | invented angle ° gx gy gz | onsets | onset move / 3σ | worst bias error at a stand-still's end | foot-flat samples used by the bias (flagged STILL) |"
    );
    eprintln!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        eprintln!("{}", fmt_row(r));
    }
    for r in &rows {
        let reps: Vec<String> = r
            .score
            .channels
            .iter()
            .zip(CHANNEL_NAMES)
            .map(|(c, n)| format!("{n} {}", c.replaced))
            .collect();
        eprintln!(
            "  {:.0} Hz replaced channel-samples: {}",
            r.rate,
            reps.join(", ")
        );
        for c in &r.checks {
            eprintln!(
                "  {:.0} Hz bias at {:6.2} s: worst {} {:.4} °/s = {:.2} σ̂ = {:.2} of the bound",
                r.rate, c.t_s, CHANNEL_NAMES[c.axis], c.err_deg_s, c.err_sigma, c.err_bound
            );
        }
    }
    eprintln!("scored in {:.1} s", start.elapsed().as_secs_f64());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn saturated_samples_are_flagged_and_never_replaced() {
    let w = simulate(&[
        ("sensor.gyro_range_deg_s", "250.0"),
        ("sensor.accel_range_g", "4.0"),
    ]);
    let out = run_default(&w);
    let mut clipped = [0usize; N_CHANNELS];
    let (mut unflagged, mut replaced) = (0, 0);
    for ((r, s), x) in w.truth.iter().zip(&out).zip(&w.raw) {
        for (c, n) in clipped.iter_mut().enumerate() {
            if r.component(Effect::Saturation, c) != 0.0 || x.flags & flags::sat_ch(c) != 0 {
                *n += 1;
                unflagged += usize::from(s.flags & flags::sat_ch(c) == 0);
                replaced += usize::from(s.flags & flags::replaced_ch(c) != 0);
            }
        }
    }
    let score = score_harm("gait clipped", Class::Moving, w.rate, &w.raw, &out);
    let rep: Vec<String> = score
        .channels
        .iter()
        .map(|c| format!("{} {:.1e}", c.replaced, c.replaced_rate))
        .collect();
    eprintln!(
        "±250 °/s, ±4 g at 400 Hz: clipped channel-samples {clipped:?}, {unflagged} unflagged, \
         {replaced} replaced; replaced per channel {}",
        rep.join(", ")
    );
    // The swing clips the pitch axis and the heel strikes the vertical accelerometer.
    assert!(clipped[1] > 0 && clipped[5] > 0, "{clipped:?}");
    assert_eq!(unflagged, 0);
    assert_eq!(replaced, 0);
}

#[test]
fn injected_spikes_on_the_walk_at_400_hz() {
    let w = simulate(&[]);
    assert_eq!(w.rate, 400.0);
    let mut x = w.raw.clone();
    let labels = inject_spikes(&mut x, SEED);
    let out = run_config(&Config::default_embedded().unwrap(), &w.desc, &x).unwrap();
    let k = score_injections(&out, &labels, &[0, 1, 2, 3, 4, 5]);
    let (f1, recall, precision) = (k.f1(), k.recall(), k.precision());
    let events = labels.iter().filter(|l| l.iter().any(|v| *v)).count();
    eprintln!(
        "gait at 400 Hz, injected spikes and runs ({events} labelled samples): F1 {f1:.4}, \
         recall {recall:.4}, precision {precision:.4}"
    );
    // Bounded at its measured value; met one day, the bound must go (and the docs change).
    assert!(f1 >= INJECTED_F1_BOUND, "F1 {f1} < {INJECTED_F1_BOUND}");
    assert!(
        f1 < 0.95,
        "F1 {f1} meets the target now: drop INJECTED_F1_BOUND"
    );
}
