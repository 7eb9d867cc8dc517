//! Shared synthetic-signal helpers for the bias-stage integration tests (seeded, with truth).
#![allow(dead_code)]

use imuprep::model::bias_model::{ArOf, BiasModelFile, ChannelBiasModel, Effect};
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use imuprep::stage::bias::BiasStage;
use imuprep::stage::bias::settings::BiasSettings;
use std::f64::consts::PI;

pub const FS: f64 = 100.0;
pub const G: f64 = 9.80665;
/// Consumer gyro white noise: 0.1 °/s per sample at 100 Hz (ARW 0.6 °/√h).
pub const GYRO_WHITE_SD: f64 = 0.1 * PI / 180.0;
pub const ACCEL_WHITE_SD: f64 = 0.04;

/// Realistic slow AR(2) gyro bias: poles 0.999 and 0.99 (time constants 10 s and 1 s at 100 Hz),
/// the driving variance follows from the wanted stationary sd via [`q_for_sd`].
pub const SLOW_PHI: [f64; 2] = [1.989, -0.98901];
/// Drive bias AR(2): poles 0.99995 and 0.999 (time constants 200 s and 10 s at 100 Hz): a bias
/// instability that wanders over minutes, as MEMS gyros do; stationary sd set by [`q_for_sd`].
pub const DRIVE_PHI: [f64; 2] = [0.99995 + 0.999, -0.99995 * 0.999];

/// Driving variance giving stationary sd `sd` for the AR(2) `phi`.
pub fn q_for_sd(phi: &[f64], sd: f64) -> f64 {
    let g = imuprep::model::bias_state_space::ar_autocovariance(phi, 1.0, 0).unwrap();
    sd * sd / g[0]
}

/// AR(p) generator started in its stationary distribution (burn-in of 20 000 samples).
pub struct ArGen {
    phi: Vec<f64>,
    q_sd: f64,
    hist: Vec<f64>,
    rng: Rng,
}

impl ArGen {
    pub fn new(phi: &[f64], q: f64, seed: u64) -> Self {
        let mut g = ArGen {
            phi: phi.to_vec(),
            q_sd: q.sqrt(),
            hist: vec![0.0; phi.len()],
            rng: Rng::new(seed),
        };
        for _ in 0..20_000 {
            g.next();
        }
        g
    }
    pub fn next(&mut self) -> f64 {
        let mut x = self.q_sd * self.rng.normal();
        for (i, p) in self.phi.iter().enumerate() {
            x += p * self.hist[i];
        }
        self.hist.rotate_right(1);
        if !self.hist.is_empty() {
            self.hist[0] = x;
        }
        x
    }
}

pub fn sample(k: usize, gyro: [f64; 3], accel: [f64; 3], temp_c: Option<f64>) -> Sample {
    let mut s = Sample {
        temp_c,
        ..Sample::nth(k, 10_000_000)
    };
    s.set_channels(&[gyro[0], gyro[1], gyro[2], accel[0], accel[1], accel[2]]);
    s
}

/// A bias-only ("truth") model entry for a gyro channel.
pub fn truth_model(
    channel: &str,
    phi: &[f64],
    q: f64,
    r: f64,
    effects: Vec<Effect>,
) -> ChannelBiasModel {
    ChannelBiasModel {
        channel: channel.into(),
        method: "truth".into(),
        sample_rate_hz: FS,
        mean: 0.0,
        ar: phi.to_vec(),
        innovation_var: q,
        white_noise_var: r,
        ar_of: ArOf::Bias,
        effects,
    }
}

/// Settings for a stage built with a test model (passed to `BiasStage::new` beside them).
pub fn settings_with() -> BiasSettings {
    BiasSettings {
        // Only the model's declared effects: the tests compare a model with an effect against
        // the same model without it.
        default_step_rad_s: 0.0,
        default_rate_random_walk_q_per_s: 0.0,
        ..Default::default()
    }
}

/// The drive-with-stops pattern: 30-s cycles, still for the first 8 s, then 22 s of driving with
/// a smooth turn (raised-cosine edges of 1 s) of ±0.3 rad/s held for 10 s from 12 s to 22 s
/// (alternating sign), a smooth 1.5 m/s² speed-up at 8–10 s and braking at 27–29 s.
#[derive(Clone, Copy, Debug)]
pub struct DriveTruth {
    pub still: bool,
    pub gyro: [f64; 3],
    pub accel: [f64; 3],
    /// Index of the turn this sample belongs to (its turn window 11–23 s of the cycle), if any.
    pub turn: Option<usize>,
}

pub const CYCLE_S: f64 = 30.0;

fn smooth_box(t: f64, t0: f64, t1: f64, edge: f64) -> f64 {
    // 0 before t0, raised-cosine up to 1 over `edge`, 1 until t1, down over `edge`.
    if t < t0 || t > t1 + edge {
        0.0
    } else if t < t0 + edge {
        0.5 * (1.0 - (PI * (t - t0) / edge).cos())
    } else if t <= t1 {
        1.0
    } else {
        0.5 * (1.0 + (PI * (t - t1) / edge).cos())
    }
}

/// Truth of the drive at sample k; `road` supplies the vibration noise while moving.
pub fn drive_truth(k: usize, road: &mut Rng) -> DriveTruth {
    let t = k as f64 / FS;
    let cycle = (t / CYCLE_S).floor() as usize;
    let tc = t - cycle as f64 * CYCLE_S;
    if tc < 8.0 {
        return DriveTruth {
            still: true,
            gyro: [0.0; 3],
            accel: [0.0, 0.0, G],
            turn: None,
        };
    }
    let sign = if cycle.is_multiple_of(2) { 1.0 } else { -1.0 };
    let rate = sign * 0.3 * smooth_box(tc, 11.0, 21.0, 1.0);
    // Longitudinal: a 1.5 m/s² pulse speeding up at 8–10 s and braking at 26–28 s.
    let accel_long = 1.5 * (smooth_box(tc, 8.0, 9.0, 1.0) - smooth_box(tc, 26.0, 27.0, 1.0));
    let speed = 10.0; // m/s, for the centripetal acceleration in the turn
    let lateral = speed * rate;
    let turn = (10.5..23.0).contains(&tc).then_some(cycle);
    DriveTruth {
        still: false,
        gyro: [0.01 * road.normal(), 0.01 * road.normal(), rate],
        accel: [
            accel_long + 0.3 * road.normal(),
            lateral + 0.3 * road.normal(),
            G + 0.3 * road.normal(),
        ],
        turn,
    }
}

/// RMS over 1-s blocks of the block mean of `err` (skipping the first `skip_s` seconds).
pub fn rms_of_1s_means(err: &[f64], skip_s: f64) -> f64 {
    let n = FS as usize;
    let start = (skip_s * FS) as usize;
    let blocks: Vec<f64> = err[start..]
        .chunks_exact(n)
        .map(|c| c.iter().sum::<f64>() / n as f64)
        .collect();
    (blocks.iter().map(|m| m * m).sum::<f64>() / blocks.len() as f64).sqrt()
}

/// Output of one synthetic drive.
pub struct Run {
    pub truth: Vec<DriveTruth>,
    /// Calibrated-only gyro (here the raw gyro: identity calibration).
    pub raw: Vec<[f64; 3]>,
    pub cleaned: Vec<[f64; 3]>,
    /// True total bias per gyro axis.
    pub bias: Vec<[f64; 3]>,
    pub est: Vec<[f64; 3]>,
    pub sd: Vec<[f64; 3]>,
    pub flags: Vec<u32>,
}

/// Drive for `seconds`; the true gyro bias at sample k is `bias_fn(k, &truth, &specific_force)`
/// (rad/s), temperatures from `temp_fn`. White noise: consumer grade.
pub fn drive(
    stage: &mut BiasStage,
    seconds: f64,
    seed: u64,
    mut bias_fn: impl FnMut(usize, &DriveTruth) -> [f64; 3],
    temp_fn: impl Fn(usize) -> Option<f64>,
) -> Run {
    let n = (seconds * FS) as usize;
    let mut road = Rng::fork(seed, 1);
    let mut noise = Rng::fork(seed, 2);
    let mut run = Run {
        truth: vec![],
        raw: vec![],
        cleaned: vec![],
        bias: vec![],
        est: vec![],
        sd: vec![],
        flags: vec![],
    };
    for k in 0..n {
        let tr = drive_truth(k, &mut road);
        let b = bias_fn(k, &tr);
        let g: [f64; 3] =
            std::array::from_fn(|a| tr.gyro[a] + b[a] + GYRO_WHITE_SD * noise.normal());
        let f: [f64; 3] = std::array::from_fn(|a| tr.accel[a] + ACCEL_WHITE_SD * noise.normal());
        let out = stage.process(sample(k, g, f, temp_fn(k)));
        run.truth.push(tr);
        run.raw.push(g);
        run.cleaned.push([out.gyro[0], out.gyro[1], out.gyro[2]]);
        run.bias.push(b);
        run.est
            .push([out.bias[0] as f64, out.bias[1] as f64, out.bias[2] as f64]);
        run.sd.push([
            out.bias_sd[0] as f64,
            out.bias_sd[1] as f64,
            out.bias_sd[2] as f64,
        ]);
        run.flags.push(out.flags);
    }
    run
}

impl Run {
    pub fn err(&self, axis: usize, use_cleaned: bool) -> Vec<f64> {
        (0..self.truth.len())
            .map(|k| if use_cleaned { self.cleaned[k][axis] } else { self.raw[k][axis] } - self.truth[k].gyro[axis])
            .collect()
    }
    /// (cleaned RMS of 1-s means, baseline RMS of 1-s means) for `axis`, from `skip_s` on.
    pub fn rms_pair(&self, axis: usize, skip_s: f64) -> (f64, f64) {
        (
            rms_of_1s_means(&self.err(axis, true), skip_s),
            rms_of_1s_means(&self.err(axis, false), skip_s),
        )
    }
    /// Relative integral error of each turn on gz: (cleaned, baseline).
    pub fn turn_errors(&self) -> Vec<(f64, f64)> {
        let n_turns = self
            .truth
            .iter()
            .filter_map(|t| t.turn)
            .max()
            .map_or(0, |m| m + 1);
        (0..n_turns)
            .map(|i| {
                let (mut t, mut c, mut r) = (0.0, 0.0, 0.0);
                for k in 0..self.truth.len() {
                    if self.truth[k].turn == Some(i) {
                        t += self.truth[k].gyro[2];
                        c += self.cleaned[k][2];
                        r += self.raw[k][2];
                    }
                }
                (c / t - 1.0, r / t - 1.0)
            })
            .collect()
    }
}

/// Driving variance of the drive bias for a stationary sd of 0.05 °/s.
pub fn slow_q() -> f64 {
    q_for_sd(&DRIVE_PHI, 0.05f64.to_radians())
}

/// Stage with the true AR(2) drive-bias model on the three gyros (turn-on bias unknown to it).
pub fn drive_stage(effects: [Vec<Effect>; 3]) -> BiasStage {
    BiasStage::new(settings_with(), Some(&drive_model(effects))).unwrap()
}

/// The true AR(2) drive-bias model on gx, gy, gz with the given effects.
pub fn drive_model(effects: [Vec<Effect>; 3]) -> BiasModelFile {
    let r = GYRO_WHITE_SD * GYRO_WHITE_SD;
    let [ex, ey, ez] = effects;
    BiasModelFile {
        channels: vec![
            truth_model("gx", &DRIVE_PHI, slow_q(), r, ex),
            truth_model("gy", &DRIVE_PHI, slow_q(), r, ey),
            truth_model("gz", &DRIVE_PHI, slow_q(), r, ez),
        ],
    }
}

/// Turn-on bias (unknown to calibration and model, ~0.2–0.5 °/s) plus the AR(2) wander.
pub fn standard_bias(seed: u64) -> impl FnMut(usize, &DriveTruth) -> [f64; 3] {
    let mut ar: Vec<ArGen> = (0..3)
        .map(|a| ArGen::new(&DRIVE_PHI, slow_q(), seed + a))
        .collect();
    let turn_on = [0.004, -0.006, 0.0087];
    move |_, _| std::array::from_fn(|a| turn_on[a] + ar[a].next())
}
