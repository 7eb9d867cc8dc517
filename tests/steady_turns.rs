//! Steady turns about gravity through the embedded default pipeline (docs/real-data.md, "Steady
//! turns"): a turntable, a robot turning in place, a slow pan, a log that starts spinning, a
//! bias that moves across gravity, and sways (a ship's roll, a yawing mount). A constant rate has no variance and, about gravity, no trace
//! in the accelerometer: only its onset and its size tell it from a bias that moved.
//!
//! The benches: 100 Hz, gyro white noise 0.005 rad/s (0.29 °/s) per sample, turn-on bias
//! (0.01, −0.02, 0.005) rad/s, accelerometer offsets 0.1 and −0.2 m/s² on x and y (gravity seen
//! 1.3° off the z axis, as an uncalibrated MEMS triad sees it), white 0.03 m/s². The turn is
//! about the z axis (gravity) or the x axis (a tilt: gravity turns in the accelerometer) with
//! raised-cosine ramps. Seeded: every number is reproducible.

use imuprep::config::Config;
use imuprep::rng::Rng;
use imuprep::sample::{Sample, flags};
use imuprep::stage::bias::health::BiasHealth;
use imuprep::stage::run_through;

const FS: f64 = 100.0;
const G: f64 = 9.80665;
const BIAS: [f64; 3] = [0.01, -0.02, 0.005];

/// A turn about z: `rest0_s` at rest, a `ramp_s` ramp up to `rate_dps`, held for `hold_s`, a
/// ramp down, `rest1_s` at rest (`rest0_s` = 0 starts spinning). Extra gx bias `gx_step` rad/s
/// from `gx_step_at_s` on. Returns the samples and the true gz (rad/s).
struct Bench {
    rate_dps: f64,
    rest0_s: f64,
    ramp_s: f64,
    hold_s: f64,
    rest1_s: f64,
    gx_step: f64,
    gx_step_at_s: f64,
    /// The turn's axis: 2 (z, about gravity) or 0 (x, a tilt).
    axis: usize,
    /// A sway instead of a held turn: the rate is `rate_dps` · sin(2π (t − `rest0_s`) / this)
    /// for `hold_s`, with no ramps (0: a held turn).
    sway_period_s: f64,
}

impl Bench {
    fn turn(rate_dps: f64, rest0_s: f64, ramp_s: f64, hold_s: f64, rest1_s: f64) -> Self {
        Bench {
            rate_dps,
            rest0_s,
            ramp_s,
            hold_s,
            rest1_s,
            gx_step: 0.0,
            gx_step_at_s: f64::INFINITY,
            axis: 2,
            sway_period_s: 0.0,
        }
    }

    /// 90 s at rest, a sway of `amplitude_dps` and `period_s` about `axis` for 300 s, 90 s at
    /// rest.
    fn sway(amplitude_dps: f64, period_s: f64, axis: usize) -> Self {
        Bench {
            axis,
            sway_period_s: period_s,
            ..Bench::turn(amplitude_dps, 90.0, 0.0, 300.0, 90.0)
        }
    }

    fn tilt(rate_dps: f64, hold_s: f64) -> Self {
        Bench {
            axis: 0,
            ..Bench::turn(rate_dps, 90.0, 2.0, hold_s, 90.0)
        }
    }

    fn duration_s(&self) -> f64 {
        self.rest0_s + 2.0 * self.ramp_s + self.hold_s + self.rest1_s
    }

    /// The turn's envelope at `t` (0 at rest, 1 while held; a sway's sine).
    fn envelope(&self, t: f64) -> f64 {
        if self.sway_period_s > 0.0 {
            let x = t - self.rest0_s;
            return if (0.0..self.hold_s).contains(&x) {
                (std::f64::consts::TAU * x / self.sway_period_s).sin()
            } else {
                0.0
            };
        }
        let ramp = |x: f64| 0.5 - 0.5 * (std::f64::consts::PI * x.clamp(0.0, 1.0)).cos();
        let up = if self.rest0_s == 0.0 {
            1.0
        } else {
            ramp((t - self.rest0_s) / self.ramp_s)
        };
        let down_at = self.rest0_s + self.ramp_s + self.hold_s;
        up * (1.0 - ramp((t - down_at) / self.ramp_s))
    }

    /// The samples and the true rate about the turn's axis (rad/s).
    fn run(&self, seed: u64) -> (Vec<Sample>, Vec<f64>) {
        let mut r = Rng::new(seed);
        let n = (self.duration_s() * FS) as usize;
        let w = self.rate_dps.to_radians();
        let (mut out, mut truth) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let mut tilt = 0.0;
        for k in 0..n {
            let t = k as f64 / FS;
            let wt = w * self.envelope(t);
            let step = if t >= self.gx_step_at_s {
                self.gx_step
            } else {
                0.0
            };
            let mut rate = [0.0; 3];
            rate[self.axis] = wt;
            if self.axis == 0 {
                tilt += wt / FS;
            }
            let mut s = Sample::nth(k, 10_000_000);
            s.set_channels(&[
                rate[0] + BIAS[0] + step + 0.005 * r.normal(),
                rate[1] + BIAS[1] + 0.005 * r.normal(),
                rate[2] + BIAS[2] + 0.005 * r.normal(),
                0.1 + 0.03 * r.normal(),
                G * tilt.sin() - 0.2 + 0.03 * r.normal(),
                G * tilt.cos() + 0.03 * r.normal(),
            ]);
            out.push(s);
            truth.push(wt);
        }
        (out, truth)
    }
}

/// The embedded default pipeline over `samples`: its output and the bias stage's health.
fn cleaned(samples: &[Sample]) -> (Vec<Sample>, BiasHealth) {
    let mut cfg = Config::default_embedded().unwrap();
    cfg.stages.set_sample_rate(FS).unwrap();
    let mut p = cfg.stages.build().unwrap();
    let out = run_through(&mut p, samples);
    let bias = p.health().bias.expect("the default has a bias stage");
    (out, bias)
}

/// The mean of gyro axis `a` over the last minute of `out`, rad/s.
fn last_minute_mean(out: &[Sample], a: usize) -> f64 {
    let tail = &out[out.len() - (60.0 * FS) as usize..];
    tail.iter().map(|s| s.gyro[a]).sum::<f64>() / tail.len() as f64
}

/// The bench `bench` of `seed` reads rest on gyro axis `a` in its last minute to within
/// 0.05 °/s: the estimate re-anchored, and no steady turn was held.
fn rests_again(bench: &Bench, seed: u64, a: usize, what: &str) {
    let (samples, _) = bench.run(seed);
    let (out, h) = cleaned(&samples);
    let mean = last_minute_mean(&out, a).to_degrees();
    eprintln!(
        "{what}: {mean:.4} °/s; re-anchors {}, steady turns {}",
        h.counters.reanchors, h.counters.steady_turns
    );
    assert!(mean.abs() < 0.05, "{what}: {mean}");
    assert!(h.counters.reanchors >= 1, "{what}");
    assert_eq!(h.counters.steady_turns, 0, "{what}");
}

/// ∫ rate dt, degrees.
fn angle_deg(gz: impl Iterator<Item = f64>) -> f64 {
    gz.sum::<f64>().to_degrees() / FS
}

#[test]
fn a_turntable_keeps_its_turn_and_is_not_called_still() {
    // 90 s at rest, a 2-s ramp to 10 °/s, 120 s held, a ramp down, 90 s at rest. Before the
    // rule, 2 s of mean-test veto after the ramp, then the guard re-anchored the bias onto the
    // turn: the output's gz integrated to 1.5° of the true 1220°, and the rest after the turn
    // read −10 °/s until a second re-anchor. Now the output keeps the turn to within the
    // estimate's own error: measured 1220.4–1220.9° (seeds 1–3; before: 1.3° on seed 1); the
    // bound, 1 % of the turn, is 15× that error (the raw data's bias alone is off by 87°).
    let bench = Bench::turn(10.0, 90.0, 2.0, 120.0, 90.0);
    for seed in 1..=3 {
        let (samples, truth) = bench.run(seed);
        let (out, h) = cleaned(&samples);
        let t = angle_deg(truth.iter().copied());
        let o = angle_deg(out.iter().map(|s| s.gyro[2]));
        let r = angle_deg(samples.iter().map(|s| s.gyro[2]));
        eprintln!(
            "seed {seed}: turn {t:.1}°, output {o:.1}°, raw {r:.1}°; steady turns {}, samples {}, re-anchors {}",
            h.counters.steady_turns, h.counters.steady_turn_samples, h.counters.reanchors
        );
        assert!((o - t).abs() <= 0.01 * t, "seed {seed}: {o} vs {t}");
        // While held, the turn is never rest (the STILL flag a consumer may use as a ZARU).
        let held = ((90.0 + 2.0 + 5.0) * FS) as usize..((90.0 + 2.0 + 120.0) * FS) as usize;
        let still = out[held].iter().filter(|s| s.has(flags::STILL)).count();
        assert_eq!(still, 0, "seed {seed}: {still} held samples flagged STILL");
        assert_eq!(h.counters.steady_turns, 1, "seed {seed}");
        assert_eq!(h.counters.reanchors, 0, "seed {seed}");
        // Rest comes back after the turn: the last 60 s are still again (but for a window or
        // two of noise: 99.5 % on seeds 1–3 before the rule and after).
        let tail = out.len() - (60.0 * FS) as usize;
        let rest = out[tail..].iter().filter(|s| s.has(flags::STILL)).count();
        assert!(
            rest as f64 >= 0.95 * (out.len() - tail) as f64,
            "seed {seed}: {rest}"
        );
    }
}

#[test]
fn a_robot_turning_in_place_and_a_slow_pan_keep_their_angle() {
    // A 30 °/s turn of 12 s between 1-s ramps (a robot turning in place on a smooth floor), and
    // a 1 °/s pan held 5 min (a camera head). Before, the turn integrated to 0.6° of 390°, and
    // the pan was taken up by the bias filter (60-s time constant: 0.98 of its 1 °/s gone after
    // 4 min); now 390.8° and 302.3°. The 3 % bound (9° on the pan) is a 0.02 °/s estimate
    // error over the pan bench's 8 min, 30× the measured 0.3°.
    for (rate, ramp, hold, seed) in [(30.0, 1.0, 12.0, 2), (1.0, 2.0, 300.0, 1)] {
        let bench = Bench::turn(rate, 90.0, ramp, hold, 90.0);
        let (samples, truth) = bench.run(seed);
        let (out, _) = cleaned(&samples);
        let t = angle_deg(truth.iter().copied());
        let o = angle_deg(out.iter().map(|s| s.gyro[2]));
        eprintln!("{rate} °/s for {hold} s: turn {t:.1}°, output {o:.1}°");
        assert!((o - t).abs() <= 0.03 * t, "{rate} °/s: {o} vs {t}");
    }
}

#[test]
fn a_slow_tilt_keeps_its_angle() {
    // A pan about x (horizontal) at 1 °/s and 0.3 °/s for 60 s: gravity turns in the
    // accelerometer, but too slowly to raise its window sd, so only the mean test sees the
    // turn. Before, after the veto the offset was taken for a bias that moved (across gravity)
    // and taken up: the 1 °/s pan integrated to 11.9° of 62°, the 0.3 °/s one to 3.5° of 18.6°
    // (benches written the same way in Python). Now the accelerometer decides: gravity moved
    // as the offsets predict: 63.5° and 20.0°. What is left is the bias estimate's own error,
    // 0.006 °/s over the 245-s bench, whatever the pan's rate; the bound, 2.5°, is 0.01 °/s
    // (the raw data's gx bias alone is off by 140°).
    for (rate, seed) in [(1.0, 5), (0.3, 6)] {
        let (samples, truth) = Bench::tilt(rate, 60.0).run(seed);
        let (out, h) = cleaned(&samples);
        let t = angle_deg(truth.iter().copied());
        let o = angle_deg(out.iter().map(|s| s.gyro[0]));
        eprintln!(
            "tilt {rate} °/s: turn {t:.2}°, output {o:.2}°; steady turns {}",
            h.counters.steady_turns
        );
        assert!((o - t).abs() <= 2.5, "{rate} °/s: {o} vs {t}");
        assert!(h.counters.steady_turns >= 1);
    }
}

#[test]
fn a_log_that_starts_spinning_re_anchors_at_rest() {
    // Spinning at 10 °/s from the first sample for 120 s, then 90 s at rest. The warm-up can
    // only take the spin for the bias (nothing says otherwise). At rest the offset about gravity
    // (−10 °/s) is no larger than that estimate (10.3 °/s): taken for the bias that moved, since
    // were it a turn, erasing it would leave less error than the raw data's own bias. The last
    // 60 s must read the rest to within 0.05 °/s (the raw bias is 0.29 °/s; measured 0.001, as
    // before the rule: this guards the re-anchor the rule keeps).
    rests_again(
        &Bench::turn(10.0, 0.0, 2.0, 120.0, 90.0),
        3,
        2,
        "rest after the spin",
    );
}

#[test]
fn a_bias_that_moves_across_gravity_is_still_re_anchored() {
    // gx's bias steps by +2 °/s (7 σ of one sample: beyond the guard) at 120 s of a 5-min
    // rest. A turn about x would have turned gravity in the accelerometer, which stayed put:
    // the offset is the bias's, and after the mean test's 2-s veto the guard re-anchors as
    // before. The last 60 s must read rest on gx to within 0.05 °/s (2.5 % of the step;
    // measured 0.003, as before the rule).
    let mut bench = Bench::turn(0.0, 300.0, 1.0, 0.0, 0.0);
    bench.gx_step = 2f64.to_radians();
    bench.gx_step_at_s = 120.0;
    rests_again(&bench, 4, 0, "gx at rest after the step");
}

#[test]
fn a_sway_is_neither_rest_nor_bias() {
    // Five minutes of sway between 90-s rests. Its rate passes through zero twice a period, and
    // a slow sway brings gravity back to where it was. Before (stop 39): the 10 °/s, 20-s yaw
    // sway was called still for a moment at its zero crossings (the window is as quiet as rest
    // and its mean passes the mean test while the rate ramps through zero at 3.1 °/s²); those
    // measurements misfit the model, their mean ν²/S freed the axis, and the guard re-anchored
    // onto the sway, after which the estimate followed it: output RMS error 5.4 °/s against
    // the noise's 0.29, 64° lost. The 3 °/s, 60-s roll (±29°) lost 94° (RMS 1.30 °/s): when
    // gravity came back to where the veto began, the accelerometer could not tell a turn from
    // rest at that instant, and the offset was taken for the bias. Now only settled rest (3 s
    // still) is evidence of misfit, and the accelerometer judges the path gravity followed
    // over the last 10 s. Measured: output RMS within 1.002–1.012 × the noise's. The bound,
    // 1.02 ×, allows a bias error of 0.06 °/s RMS; the angle bound, 6° over the 480-s bench,
    // 0.0125 °/s (the raw data's bias alone is off by 138° on z and 275° on x).
    // Small fast rolls (1.5 and 2 °/s, 5-s period, ±1.2–1.6°), stop 40: quiet all through, so
    // one veto lasted the whole sway, and the offsets' integral since its start drifted further
    // than the roll: from 150 s on the roll was rest, and 12.6–14.2° were lost; its zero
    // crossings were STILL at once besides. Now the path is judged over a 2–4 s lag, and motion
    // starts the run towards STILL again. STILL while the rate exceeds 0.5 °/s: stop 40, 12,046
    // and 14,920 of the Python benches' (tests/reference/sway) 30,000 sway samples; now 11 and
    // 19 (bound 1 %); on this file's 10 °/s yaw sway 1,090 of 29,070 before, 30 now.
    for (amplitude, period, axis, seed) in [
        (10.0, 20.0, 2, 11),
        (3.0, 10.0, 0, 12),
        (3.0, 60.0, 0, 13),
        (3.0, 20.0, 0, 14),
        (1.5, 5.0, 0, 15),
        (2.0, 5.0, 0, 16),
    ] {
        let bench = Bench::sway(amplitude, period, axis);
        let (samples, truth) = bench.run(seed);
        let (out, h) = cleaned(&samples);
        let rms = |e: &mut dyn Iterator<Item = f64>| {
            let (mut s2, mut n) = (0.0, 0.0);
            for x in e {
                s2 += x * x;
                n += 1.0;
            }
            (s2 / n).sqrt().to_degrees()
        };
        let bias = BIAS[axis];
        let noise = rms(&mut samples
            .iter()
            .zip(&truth)
            .map(|(s, t)| s.gyro[axis] - t - bias));
        let err = rms(&mut out.iter().zip(&truth).map(|(s, t)| s.gyro[axis] - t));
        let angle = angle_deg(out.iter().zip(&truth).map(|(s, t)| s.gyro[axis] - t));
        let moving = truth
            .iter()
            .filter(|t| t.abs() > 0.5f64.to_radians())
            .count();
        let still_moving = out
            .iter()
            .zip(&truth)
            .filter(|(s, t)| s.has(flags::STILL) && t.abs() > 0.5f64.to_radians())
            .count();
        eprintln!(
            "sway {amplitude} °/s, {period} s, axis {axis}: output RMS error {err:.4} °/s (noise {noise:.4}), angle error {angle:.2}°; STILL while moving {still_moving} of {moving}; re-anchors {}, steady turns {}",
            h.counters.reanchors, h.counters.steady_turns
        );
        assert!(
            still_moving as f64 <= 0.01 * moving as f64,
            "{amplitude} °/s, {period} s: {still_moving} of {moving} moving samples STILL"
        );
        assert!(
            err <= 1.02 * noise,
            "{amplitude} °/s, {period} s: {err} vs {noise}"
        );
        assert!(angle.abs() <= 6.0, "{amplitude} °/s, {period} s: {angle}°");
        assert_eq!(h.counters.reanchors, 0, "{amplitude} °/s, {period} s");
    }
}
