use super::*;
use crate::sim::Scenario;

fn plan(extra: &str) -> GaitPlan {
    let text = format!("[sensor]\nsample_rate_hz = 400.0\n[motion]\nkind = \"gait\"\n{extra}");
    let scn = Scenario::from_toml_str(&text).unwrap();
    GaitPlan::build(&scn.motion, &mut Checker::default()).unwrap()
}

#[test]
fn shapes_have_the_derivatives_they_claim() {
    // Central differences at h = 1e-5: error O(h²) ≈ 1e-9 of the second derivative.
    let h = 1e-5;
    for k in 1..100 {
        let x = k as f64 / 100.0;
        let (s0, s1, s2) = (step(x - h), step(x), step(x + h));
        assert!(((s2[0] - s0[0]) / (2.0 * h) - s1[1]).abs() < 1e-6);
        assert!(((s2[1] - s0[1]) / (2.0 * h) - s1[2]).abs() < 1e-5);
        let (b0, b1, b2) = (bump(x - h), bump(x), bump(x + h));
        assert!(((b2[0] - b0[0]) / (2.0 * h) - b1[1]).abs() < 1e-6);
        assert!(((b2[1] - b0[1]) / (2.0 * h) - b1[2]).abs() < 1e-5);
        let (w0, w1, w2) = (wobble(x - h), wobble(x), wobble(x + h));
        assert!(((w2[0] - w0[0]) / (2.0 * h) - w1[1]).abs() < 1e-6);
    }
    // Ends: value, first and second derivative vanish (S: value 0 and 1).
    for x in [0.0, 1.0] {
        assert!(step(x)[1].abs() < 1e-12 && step(x)[2].abs() < 1e-12);
        assert!(bump(x).iter().all(|v| v.abs() < 1e-12));
        assert!(wobble(x).iter().all(|v| v.abs() < 1e-12));
    }
    // The wobble's peak is 1.
    let peak = (0..=10_000)
        .map(|k| wobble(k as f64 / 10_000.0)[0].abs())
        .fold(0.0, f64::max);
    assert!((peak - 1.0).abs() < 1e-6, "{peak}");
}

#[test]
fn pose_derivatives_match_finite_differences() {
    // Velocity and acceleration, Euler rates: central differences of the closed forms
    // at every millisecond of a bout (h = 1e-6 s: error O(h²·p''''), ≪ 1e-3 relative).
    let p = plan("bouts = 2\nstrides_per_bout = 3\ninitial_still_s = 1.0\npause_s = 1.0\n");
    let h = 1e-6;
    let mut worst: [f64; 3] = [0.0; 3];
    let n = (p.duration_s() * 1000.0) as usize;
    for k in 1..n {
        let t = k as f64 * 1e-3;
        let (a, b, c) = (p.pose(t - h), p.pose(t), p.pose(t + h));
        worst[0] = worst[0].max(((c.p - a.p) / (2.0 * h) - b.v).norm());
        worst[1] = worst[1].max(((c.v - a.v) / (2.0 * h) - b.a).norm());
        for e in 0..3 {
            worst[2] =
                worst[2].max(((c.euler[e] - a.euler[e]) / (2.0 * h) - b.euler_rate[e]).abs());
        }
    }
    // Speeds ≤ 5 m/s, accelerations ≤ 30 m/s², rates ≤ 7 rad/s: these are round-off.
    assert!(
        worst[0] < 1e-5 && worst[1] < 1e-3 && worst[2] < 1e-5,
        "{worst:?}"
    );
}

#[test]
fn an_impact_peaks_at_its_size_and_changes_no_velocity_position_or_angle() {
    let p = plan("bouts = 1\nstrides_per_bout = 1\ninitial_still_s = 0.5\n");
    let t_hs = p.heel_strikes()[0];
    // Integrate 0.2 s after the heel strike at 1 µs (midpoint rule): ∫q and ∫∫q vanish to
    // the integration error, the peak is impact_g (z) and impact_deg_s (y).
    let dt = 1e-6;
    let (mut v, mut x, mut peak_az, mut peak_gy) = (0.0, 0.0, 0.0f64, 0.0f64);
    let mut last_big = 0.0;
    for k in 0..200_000 {
        let u = (k as f64 + 0.5) * dt;
        let q = p.impact(t_hs + u);
        v += q[5] * dt;
        x += v * dt;
        peak_az = peak_az.max(q[5].abs());
        peak_gy = peak_gy.max(q[1].abs());
        if q[5].abs() > 0.05 * 4.0 * 9.80665 {
            last_big = u;
        }
    }
    assert!((peak_az / (4.0 * 9.80665) - 1.0).abs() < 1e-6, "{peak_az}");
    assert!(
        (peak_gy / 60f64.to_radians() - 1.0).abs() < 1e-6,
        "{peak_gy}"
    );
    // Peak 39 m/s²: a velocity change of 1e-6 m/s and a displacement of 1e-7 m are zero.
    assert!(v.abs() < 1e-6 && x.abs() < 1e-7, "{v} {x}");
    // It starts from 0 and is below 5 % of its peak after ~47 ms (module docs).
    assert!(p.impact(t_hs)[5].abs() < 1e-12);
    assert!((0.040..0.055).contains(&last_big), "{last_big}");
}

#[test]
fn the_default_walk_has_the_documented_timeline_and_numbers() {
    let p = plan("");
    let spans = p.spans();
    let count = |k: SpanKind| spans.iter().filter(|s| s.kind == k).count();
    // 3 bouts of 20 strides; two turns of 90° (one pivot step and its foot flat each).
    assert_eq!(count(SpanKind::FootFlat), 60);
    assert_eq!(count(SpanKind::Moving), 60);
    assert_eq!(count(SpanKind::Turning), 4);
    assert_eq!(count(SpanKind::Standing), 4);
    assert_eq!(p.heel_strikes().len(), 60);
    // Continuous in time.
    for w in spans.windows(2) {
        assert!((w[0].t1_s - w[1].t0_s).abs() < 1e-9);
    }
    assert!((spans.last().unwrap().t1_s - p.duration_s()).abs() < 1e-9);
    // Stride ≈ 120/110 s (±3 % jitter): 60 strides, 10 + 2·5 + 5 s standing, two pivots.
    let period = 120.0 / 110.0;
    let walk = p.duration_s() - 25.0 - 2.0 * period;
    assert!((walk / (60.0 * period) - 1.0).abs() < 0.03, "{walk}");
}
