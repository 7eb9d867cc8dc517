//! The simulator's `gait` motion (src/sim/gait.rs, `replay/gait.toml`): one trajectory for both
//! triads (a strapdown integration of the true rate and specific force reproduces the walk), the
//! impacts change no velocity, and the walk's main numbers are what docs/scenario.md says.
//! `cargo test --release --test sim_gait -- --nocapture` prints them.

mod sim_common;

use imuprep::sim::gait::{GaitPlan, SpanKind};
use imuprep::sim::{Effect, Scenario, SimRecord, Simulator, Trajectory};
use nalgebra::{Rotation3, Vector3};
use sim_common::run;

const GAIT: &str = include_str!("../replay/gait.toml");

fn gait(sets: &[(&str, &str)]) -> Scenario {
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    Scenario::from_toml_str_with(GAIT, &sets).unwrap()
}

/// The default walk at 1 kHz, seed 1: its plan and its records.
fn walk_at_1_khz() -> (GaitPlan, Vec<SimRecord>) {
    let scn = gait(&[("sensor.sample_rate_hz", "1000.0")]);
    let sim = Simulator::new(&scn, 1).unwrap();
    let Trajectory::Gait { plan, .. } = sim.trajectory() else {
        panic!("gait")
    };
    (plan.clone(), run(&scn, 1))
}

/// Strapdown-integrate `signal(record)` (gyro rad/s, accel m/s²) over records `from..=to`,
/// starting from attitude `c_nb`, velocity 0 and position `p`: attitude by the trapezoidal mean
/// rate, velocity and position by trapezoids of the navigation-frame specific force plus
/// gravity. The state at `to`.
fn strapdown(
    recs: &[SimRecord],
    from: usize,
    to: usize,
    mut c_nb: Rotation3<f64>,
    mut p: Vector3<f64>,
    signal: impl Fn(&SimRecord) -> [f64; 6],
) -> (Rotation3<f64>, Vector3<f64>, Vector3<f64>) {
    let dt = recs[1].truth.t_s - recs[0].truth.t_s;
    let g_n = Vector3::new(0.0, 0.0, 9.80665);
    let mut v = Vector3::zeros();
    for w in recs[from..=to].windows(2) {
        let (a, b) = (signal(&w[0]), signal(&w[1]));
        let wa = Vector3::new(a[0], a[1], a[2]);
        let wb = Vector3::new(b[0], b[1], b[2]);
        let fa = Vector3::new(a[3], a[4], a[5]);
        let fb = Vector3::new(b[3], b[4], b[5]);
        let c_next = c_nb * Rotation3::new((wa + wb) * (0.5 * dt));
        let v_next = v + (c_nb * fa + c_next * fb) * (0.5 * dt) + g_n * dt;
        p += (v + v_next) * (0.5 * dt);
        v = v_next;
        c_nb = c_next;
    }
    (c_nb, v, p)
}

#[test]
fn strapdown_integration_of_the_truth_reproduces_every_stride_and_the_turns() {
    let (plan, recs) = walk_at_1_khz();
    let at = |t: f64| ((t * 1000.0).round() as usize).min(recs.len() - 1);
    let rigid = |r: &SimRecord| r.truth.true_signal;
    // With the impacts (real motion, in `road_vibration_*`): what the sensor feels.
    let felt = |r: &SimRecord| -> [f64; 6] {
        std::array::from_fn(|c| {
            r.truth.true_signal[c] + r.truth.component(Effect::RoadVibration, c)
        })
    };
    // Every stride on its own, from its foot flat's start (the plan's pose, at rest) to the end of
    // its foot slap: back at rest where the plan puts the foot.
    let spans = plan.spans();
    let (mut worst_v, mut worst_p, mut worst_att, mut worst_v_felt) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut strides = 0;
    for w in spans.windows(2) {
        if w[0].kind != SpanKind::FootFlat || w[1].kind != SpanKind::Moving {
            continue;
        }
        strides += 1;
        let (i, j) = (at(w[0].t0_s), at(w[1].t1_s));
        let (start, end) = (plan.pose(recs[i].truth.t_s), plan.pose(recs[j].truth.t_s));
        let (c, v, p) = strapdown(&recs, i, j, start.c_nb(), start.p, rigid);
        worst_v = worst_v.max(v.norm());
        worst_p = worst_p.max((p - end.p).norm());
        worst_att = worst_att.max((c.inverse() * end.c_nb()).angle());
        let (_, v, _) = strapdown(&recs, i, j, start.c_nb(), start.p, felt);
        worst_v_felt = worst_v_felt.max(v.norm());
    }
    // The whole walk's attitude from the gyros alone: the turns the text asks for.
    let (c_end, _, _) = strapdown(
        &recs,
        0,
        recs.len() - 1,
        plan.pose(0.0).c_nb(),
        Vector3::zeros(),
        rigid,
    );
    let fwd = c_end * Vector3::x();
    let heading = fwd.y.atan2(fwd.x).to_degrees();
    eprintln!(
        "gait strapdown at 1 kHz, {strides} strides each from rest: end speed ≤ {worst_v:.1e} m/s \
         ({worst_v_felt:.1e} with the impacts), position ≤ {worst_p:.1e} m, attitude ≤ \
         {worst_att:.1e} rad; heading after the walk {heading:.4}°"
    );
    assert_eq!(strides, 60);
    // Trapezoids of smooth signals (rate, acceleration and their slopes continuous: the
    // shapes' first two derivatives vanish at every phase boundary) err by O(dt²) per stride
    // (observed ≤ 4e-5 m/s, 1e-5 m, 1e-5 rad); 1e-3 m/s, 1e-3 m and 1e-4 rad leave room for that
    // and are far below what an inconsistent term leaves: a lost centripetal or Euler-rate term
    // errs by ≥ 0.1 m/s within a stride.
    assert!(worst_v < 1e-3, "speed at the end of a stride {worst_v}");
    assert!(worst_p < 1e-3, "position {worst_p}");
    assert!(worst_att < 1e-4, "attitude {worst_att}");
    // The impacts integrate to zero velocity (src/sim/gait.rs), to the trapezoid's error on a
    // 6.5-ms pulse sampled at 1 ms; 1e-2 m/s is 2 % of the foot's speed at heel strike.
    assert!(worst_v_felt < 1e-2, "speed with the impacts {worst_v_felt}");
    // Heading 30° + 2 × 90° = 210° ≡ −150°, to the integration's 1e-4 rad.
    assert!((heading + 150.0).abs() < 1e-2, "heading {heading}");
}

#[test]
fn the_walk_has_the_numbers_the_docs_give() {
    let (plan, recs) = walk_at_1_khz();
    let spans = plan.spans();
    let walking = |k: SpanKind| {
        spans
            .iter()
            .filter(|s| s.kind == k)
            .map(|s| s.t1_s - s.t0_s)
            .sum::<f64>()
    };
    let (flat, moving) = (walking(SpanKind::FootFlat), walking(SpanKind::Moving));
    let stance_share = flat / (flat + moving);
    let mut peak_rate = [0.0f64; 3];
    let (mut min_gy, mut max_gy) = (0.0f64, 0.0f64);
    let (mut peak_f_rigid, mut peak_f, mut peak_v) = (0.0f64, 0.0f64, 0.0f64);
    for r in &recs {
        let t = &r.truth;
        for (pk, v) in peak_rate.iter_mut().zip(&t.true_signal[..3]) {
            *pk = pk.max(v.abs().to_degrees());
        }
        min_gy = min_gy.min(t.true_signal[1].to_degrees());
        max_gy = max_gy.max(t.true_signal[1].to_degrees());
        let f = Vector3::new(t.true_signal[3], t.true_signal[4], t.true_signal[5]);
        let vib = Vector3::new(
            t.component(Effect::RoadVibration, 3),
            t.component(Effect::RoadVibration, 4),
            t.component(Effect::RoadVibration, 5),
        );
        peak_f_rigid = peak_f_rigid.max(f.norm() / 9.80665);
        peak_f = peak_f.max((f + vib).norm() / 9.80665);
        peak_v = peak_v.max(plan.pose(t.t_s).v.norm());
    }
    eprintln!(
        "gait: {:.1} s, 60 strides, foot flat {:.1} % of the strides' time; peak rates gx \
         {:.0} gy {:.0} ({:.0} … +{:.0}) gz {:.0} °/s; peak |f| {:.2} g rigid, {:.2} g with the \
         impacts; peak foot speed {:.2} m/s",
        plan.duration_s(),
        100.0 * stance_share,
        peak_rate[0],
        peak_rate[1],
        min_gy,
        max_gy,
        peak_rate[2],
        peak_f_rigid,
        peak_f,
        peak_v
    );
    // docs/scenario.md, replay/gait.toml: foot flat 35 % of each stride; nominal pitch-rate
    // peaks −282 (toe-off), +345 (swing) and −282 °/s (foot slap), 4.9 m/s peak foot speed, all
    // scaled by the strides' 3 % jitter (≤ 2.5 sd) and the roll and yaw wobble (measured −310 …
    // +376 °/s, 5.4 m/s); 3.6 g of rigid swing and a 4-g impact on top (5.6 g measured).
    assert!((stance_share - 0.35).abs() < 1e-9, "{stance_share}");
    assert!((300.0..400.0).contains(&max_gy), "{max_gy}");
    assert!((-330.0..-250.0).contains(&min_gy), "{min_gy}");
    assert!(
        peak_f > 4.0 && peak_f_rigid > 2.0 && peak_f_rigid < 4.0,
        "{peak_f} {peak_f_rigid}"
    );
    assert!((4.5..5.5).contains(&peak_v), "{peak_v}");
}
