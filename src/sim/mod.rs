//! The MEMS IMU simulator: a seeded, streaming generator of samples whose truth is known.
//!
//! A [`Scenario`] (TOML, see `docs/scenario.md`) describes the sensor, its true motion, its
//! temperature and its error effects. [`Simulator`] turns it into a stream of [`SimRecord`]s,
//! one per sample instant, in O(1) memory: the sample as the sensor would send it, the
//! [`TruthRow`] with the true signal and each error component, and what the transport did to
//! the frame ([`Emission`]). Writing frames is the frame codec's job, not this module's.
//!
//! Measurement model per channel c (gyro rad/s, accel m/s², body frame FRD):
//!   u  = true + road_vibration                                  (physical input; for a gait
//!                                                                  also its impacts)
//!   x  = u + noise + turn_on_bias + S·u + M·u + K·f + Σ GM + AR + RW + temp(T) + lines + steps
//!        + gross                                                 (S scale, M misalignment,
//!                                                                  K g-sensitivity, f = u_accel)
//!   y  = clip(x, ±range)   → saturation component y − x, flag bit set when |x| ≥ range
//!   z  = LSB · round(y/LSB) → quantisation component z − y
//! and z is the measured value. Each component is one column family of the truth sidecar, so
//! measured = true + Σ components exactly when summed in column order (x + (y − x) and
//! y + (z − y) are exact by Sterbenz's lemma, as y and x, z and y lie within a factor 2 of each
//! other or one of them is 0).
//!
//! Each effect draws from its own random stream `Rng::fork(seed, stream)`, and draws the same
//! numbers whatever the other effects do, so switching one effect off leaves the others' noise
//! unchanged.

pub mod gait;
pub mod gross;
pub mod log;
pub mod motion;
pub mod processes;
pub mod scenario;
pub mod temperature;
pub mod truth;
pub mod tumble;
mod validate;
pub mod vibration;

pub use motion::{DrivePlan, Trajectory, TrueMotion};
pub use scenario::{Issue, STANDARD_GRAVITY_M_S2, Scenario};
pub use truth::{Effect, N_EFFECTS, TruthPrecision, TruthRow, TruthWriter, truth_header};

use crate::rng::Rng;
use crate::sample::{N_CHANNELS, Sample, channel_index, flags};
use crate::stats::ar_poly::ar_is_stationary;
use gross::Gross6;
use nalgebra::{Matrix3, Vector3};
use processes::{ArBias6, GaussMarkov6, MAX_AR_ORDER, RandomWalk6};
use scenario::{Checker, TemperatureProfile, VibrationMode};
use std::path::Path;
use temperature::{TemperatureBias6, TemperatureModel};
use validate::gross_channels;
use vibration::VibrationModeState;

/// Random stream labels (fixed forever: changing one changes every committed log).
mod stream {
    pub const NOISE: u64 = 1;
    pub const TURN_ON: u64 = 2;
    pub const AR: u64 = 3;
    pub const RANDOM_WALK: u64 = 4;
    pub const GROSS: u64 = 5;
    pub const TRANSPORT: u64 = 6;
    pub const JITTER: u64 = 7;
    pub const TEMP_REPORT: u64 = 8;
    /// + index of the Gauss-Markov process.
    pub const GAUSS_MARKOV: u64 = 100;
    /// + index of the vibration mode.
    pub const ROAD_VIBRATION: u64 = 200;
}

const MG_TO_M_S2: f64 = STANDARD_GRAVITY_M_S2 * 1e-3;
const DEG_H_TO_RAD_S: f64 = std::f64::consts::PI / 180.0 / 3600.0;

/// Everything that can go wrong building or running a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The TOML text is malformed, has an unknown key or a wrong type (first error only: the
    /// parser stops there).
    #[error("scenario parse error: {0}")]
    Parse(String),
    /// The scenario parsed but some values are invalid; all problems are listed.
    #[error("invalid scenario ({} problem(s)):\n{}", .0.len(), .0.iter().map(|i| format!("  {i}")).collect::<Vec<_>>().join("\n"))]
    Invalid(Vec<Issue>),
    /// Reading or writing a file; the message names the file where it is known.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// What the log header needs to know about the simulated sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorInfo {
    pub sample_rate_hz: f64,
    pub gyro_range_rad_s: f64,
    pub accel_range_m_s2: f64,
    pub device_id: u32,
}

/// What the transport does with this instant's frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emission {
    /// Sent once.
    Normal,
    /// Not sent; its sequence number is still used up, so the receiver sees a gap.
    Dropped,
    /// Sent twice (same bytes).
    Duplicated,
}

/// One sample instant: the sample as sent, its truth, and its fate on the wire.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimRecord {
    pub sample: Sample,
    pub truth: TruthRow,
    pub emission: Emission,
}

/// A vibration line, ready to evaluate.
#[derive(Clone, Copy, Debug)]
struct Line {
    omega_rad_s: f64,
    phase_rad: f64,
    amp: [f64; N_CHANNELS],
    start_s: f64,
    /// π × the frequency's drift, rad/s².
    half_sweep_rad_s2: f64,
}

/// Transport fault generator.
#[derive(Clone, Debug)]
struct Transport {
    drop_prob: f64,
    duplicate_prob: f64,
    jitter_sd_ns: f64,
    rng: Rng,
    jitter_rng: Rng,
}

/// The streaming simulator (see the module docs for the measurement model).
#[derive(Clone, Debug)]
pub struct Simulator {
    info: SensorInfo,
    n: usize,
    k: usize,
    first_seq: u32,
    start_t_ns: u64,
    last_t_ns: Option<u64>,
    traj: Trajectory,
    road: Vec<VibrationModeState>,
    enabled: u32,
    temp: Option<TemperatureModel>,
    noise_sd: [f64; N_CHANNELS],
    noise_rng: Rng,
    turn_on: [f64; N_CHANNELS],
    scale: [f64; N_CHANNELS],
    mis_gyro: Matrix3<f64>,
    mis_accel: Matrix3<f64>,
    /// g-sensitivity, rad/s per m/s².
    g_sens: Matrix3<f64>,
    gm: Vec<(GaussMarkov6, Rng)>,
    ar: Option<(ArBias6, Rng)>,
    rw: Option<(RandomWalk6, Rng)>,
    temp_bias: Option<TemperatureBias6>,
    lines: Vec<Line>,
    steps: Vec<(f64, [f64; N_CHANNELS])>,
    gross: Option<Gross6>,
    range: Option<[f64; N_CHANNELS]>,
    lsb: Option<[f64; N_CHANNELS]>,
    transport: Option<Transport>,
}

fn gyro_accel(g: [f64; 3], gk: f64, a: [f64; 3], ak: f64) -> [f64; N_CHANNELS] {
    [
        g[0] * gk,
        g[1] * gk,
        g[2] * gk,
        a[0] * ak,
        a[1] * ak,
        a[2] * ak,
    ]
}

fn mat(m: &[[f64; 3]; 3], k: f64) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| m[i][j] * k)
}

impl Simulator {
    /// Validate the scenario and set up every effect from `seed`.
    pub fn new(scn: &Scenario, seed: u64) -> Result<Simulator, SimError> {
        scn.validate()?;
        let mut ck = Checker::default();
        let traj = Trajectory::build(&scn.motion, &mut ck)
            .ok_or_else(|| SimError::Invalid(ck.issues.clone()))?;
        let rate = scn.sensor.sample_rate_hz;
        let dt = 1.0 / rate;
        let n = (traj.duration_s() * rate).round() as usize;
        let e = &scn.errors;
        let mut enabled = 0u32;
        let fork = |s: u64| Rng::fork(seed, s);

        let (vib, _) = scn.motion.vibration();
        let road: Vec<VibrationModeState> = vib
            .iter()
            .enumerate()
            .filter(|(_, m)| m.enabled)
            .map(|(i, m)| VibrationModeState::new(m, dt, fork(stream::ROAD_VIBRATION + i as u64)))
            .collect();
        if !road.is_empty() || traj.transient(0.0).is_some() {
            enabled |= Effect::RoadVibration.bit();
        }

        let noise_sd = if e.white_noise.as_ref().is_some_and(|w| w.enabled) {
            enabled |= Effect::Noise.bit();
            scn.white_sigma()
        } else {
            [0.0; N_CHANNELS]
        };

        let mut turn_on = [0.0; N_CHANNELS];
        if let Some(b) = e.turn_on_bias.as_ref().filter(|b| b.enabled) {
            enabled |= Effect::TurnOnBias.bit();
            let mut rng = fork(stream::TURN_ON);
            let fixed = gyro_accel(b.gyro_deg_s, 1f64.to_radians(), b.accel_mg, MG_TO_M_S2);
            let sd = gyro_accel(
                b.gyro_sd_deg_s,
                1f64.to_radians(),
                b.accel_sd_mg,
                MG_TO_M_S2,
            );
            for c in 0..N_CHANNELS {
                turn_on[c] = fixed[c] + sd[c] * rng.normal();
            }
        }

        let mut scale = [0.0; N_CHANNELS];
        if let Some(s) = e.scale_factor.as_ref().filter(|s| s.enabled) {
            enabled |= Effect::ScaleFactor.bit();
            scale = gyro_accel(s.gyro_ppm, 1e-6, s.accel_ppm, 1e-6);
        }
        let (mut mis_gyro, mut mis_accel) = (Matrix3::zeros(), Matrix3::zeros());
        if let Some(m) = e.misalignment.as_ref().filter(|m| m.enabled) {
            enabled |= Effect::Misalignment.bit();
            mis_gyro = mat(&m.gyro_mrad, 1e-3);
            mis_accel = mat(&m.accel_mrad, 1e-3);
        }
        let mut g_sens = Matrix3::zeros();
        if let Some(g) = e.g_sensitivity.as_ref().filter(|g| g.enabled) {
            enabled |= Effect::GSensitivity.bit();
            g_sens = mat(&g.deg_s_per_g, 1f64.to_radians() / STANDARD_GRAVITY_M_S2);
        }

        let gm: Vec<(GaussMarkov6, Rng)> = e
            .gauss_markov
            .iter()
            .enumerate()
            .filter(|(_, g)| g.enabled)
            .map(|(i, g)| {
                let mut rng = fork(stream::GAUSS_MARKOV + i as u64);
                let sigma = gyro_accel(
                    g.gyro_sigma_deg_h,
                    DEG_H_TO_RAD_S,
                    g.accel_sigma_mg,
                    MG_TO_M_S2,
                );
                (GaussMarkov6::new(sigma, g.tau_s, dt, &mut rng), rng)
            })
            .collect();
        if !gm.is_empty() {
            enabled |= Effect::GaussMarkov.bit();
        }

        let ar = e.ar_bias.as_ref().filter(|a| a.enabled).map(|a| {
            enabled |= Effect::ArBias.bit();
            let mut rng = fork(stream::AR);
            let sd = gyro_accel(
                a.gyro_innovation_sd_deg_h,
                DEG_H_TO_RAD_S,
                a.accel_innovation_sd_mg,
                MG_TO_M_S2,
            );
            (
                ArBias6::new(&a.gyro_coeffs, &a.accel_coeffs, sd, &mut rng),
                rng,
            )
        });

        let rw = e.random_walk.as_ref().filter(|r| r.enabled).map(|r| {
            enabled |= Effect::RandomWalk.bit();
            // deg/h/√h → rad/s/√s: × π/180 / 3600 / 60; m/s/h/√h → m/s²/√s: / 3600 / 60.
            let k = gyro_accel(
                r.gyro_deg_h_sqrt_h,
                DEG_H_TO_RAD_S / 60.0,
                r.accel_m_s_h_sqrt_h,
                1.0 / 3600.0 / 60.0,
            );
            (RandomWalk6::new(k, dt), fork(stream::RANDOM_WALK))
        });

        let temp = scn
            .temperature
            .as_ref()
            .map(|t| TemperatureModel::new(t, dt, fork(stream::TEMP_REPORT)));
        let temp_bias = e.temperature.as_ref().filter(|t| t.enabled).map(|t| {
            enabled |= Effect::Temperature.bit();
            TemperatureBias6::new(
                t.t0_c,
                t.lag_tau_s,
                dt,
                gyro_accel(
                    t.gyro_deg_s_per_c,
                    1f64.to_radians(),
                    t.accel_mg_per_c,
                    MG_TO_M_S2,
                ),
                gyro_accel(
                    t.gyro_deg_s_per_c2,
                    1f64.to_radians(),
                    t.accel_mg_per_c2,
                    MG_TO_M_S2,
                ),
            )
        });

        let lines: Vec<Line> = e
            .vibration_lines
            .iter()
            .filter(|l| l.enabled)
            .map(|l| Line {
                omega_rad_s: 2.0 * std::f64::consts::PI * l.freq_hz,
                phase_rad: l.phase_deg.to_radians(),
                amp: gyro_accel(
                    l.gyro_amp_deg_s,
                    1f64.to_radians(),
                    l.accel_amp_mg,
                    MG_TO_M_S2,
                ),
                start_s: l.start_s,
                half_sweep_rad_s2: std::f64::consts::PI * l.drift_hz_per_s,
            })
            .collect();
        if !lines.is_empty() {
            enabled |= Effect::Vibration.bit();
        }
        let steps: Vec<(f64, [f64; N_CHANNELS])> = e
            .steps
            .iter()
            .filter(|s| s.enabled)
            .map(|s| {
                (
                    s.t_s,
                    gyro_accel(s.gyro_deg_s, 1f64.to_radians(), s.accel_mg, MG_TO_M_S2),
                )
            })
            .collect();
        if !steps.is_empty() {
            enabled |= Effect::Step.bit();
        }

        let gross = e.gross.as_ref().filter(|g| g.enabled).map(|g| {
            enabled |= Effect::Gross.bit();
            let mut sigma = scn.white_sigma();
            if let Some(v) = g.gyro_sigma_deg_s {
                sigma[..3].fill(v.to_radians());
            }
            if let Some(v) = g.accel_sigma_mg {
                sigma[3..].fill(v * MG_TO_M_S2);
            }
            let active = gross_channels(g.channels.as_deref(), &mut Checker::default());
            Gross6::new(
                g.rate_per_sample,
                g.amplitude_sigma,
                g.run_fraction,
                g.max_run_len,
                active,
                sigma,
                fork(stream::GROSS),
            )
        });

        let gyro_range_rad_s = scn.sensor.gyro_range_deg_s.to_radians();
        let accel_range_m_s2 = scn.sensor.accel_range_g * STANDARD_GRAVITY_M_S2;
        let range = e.saturation.as_ref().filter(|s| s.enabled).map(|_| {
            enabled |= Effect::Saturation.bit();
            [
                gyro_range_rad_s,
                gyro_range_rad_s,
                gyro_range_rad_s,
                accel_range_m_s2,
                accel_range_m_s2,
                accel_range_m_s2,
            ]
        });
        let lsb = e.quantisation.as_ref().filter(|q| q.enabled).map(|q| {
            enabled |= Effect::Quantisation.bit();
            let g = q.gyro_lsb_deg_s.to_radians();
            let a = q.accel_lsb_mg * MG_TO_M_S2;
            [g, g, g, a, a, a]
        });

        let transport = scn
            .transport
            .as_ref()
            .filter(|t| t.enabled)
            .map(|t| Transport {
                drop_prob: t.drop_prob,
                duplicate_prob: t.duplicate_prob,
                jitter_sd_ns: t.jitter_sd_us * 1e3,
                rng: fork(stream::TRANSPORT),
                jitter_rng: fork(stream::JITTER),
            });

        Ok(Simulator {
            info: SensorInfo {
                sample_rate_hz: rate,
                gyro_range_rad_s,
                accel_range_m_s2,
                device_id: scn.sensor.device_id,
            },
            n,
            k: 0,
            first_seq: scn.sensor.first_seq,
            start_t_ns: scn.sensor.start_t_ns,
            last_t_ns: None,
            traj,
            road,
            enabled,
            temp,
            noise_sd,
            noise_rng: fork(stream::NOISE),
            turn_on,
            scale,
            mis_gyro,
            mis_accel,
            g_sens,
            gm,
            ar,
            rw,
            temp_bias,
            lines,
            steps,
            gross,
            range,
            lsb,
            transport,
        })
    }

    /// Sensor description for the log header.
    pub fn sensor_info(&self) -> SensorInfo {
        self.info
    }

    /// Number of sample instants in the record.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True if the record has no sample instants (never for a validated scenario).
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Set of enabled effects ([`Effect::bit`]).
    pub fn enabled_effects(&self) -> u32 {
        self.enabled
    }

    /// The true trajectory (for checks and plots).
    pub fn trajectory(&self) -> &Trajectory {
        &self.traj
    }

    /// CSV header of the truth sidecar (no trailing newline): only enabled effects' columns.
    pub fn truth_header(&self) -> String {
        truth_header(self.enabled, self.temp.is_some())
    }

    /// The next sample instant, or `None` at the end of the record.
    pub fn next_record(&mut self) -> Option<SimRecord> {
        if self.k >= self.n {
            return None;
        }
        let k = self.k;
        self.k += 1;
        // k / rate rather than k·Δt: no accumulated rounding over long records.
        let t_s = k as f64 / self.info.sample_rate_hz;
        let motion = self.traj.at(t_s);
        let g = motion.gyro_rad_s;
        let a = motion.accel_m_s2;
        let true_signal = [g.x, g.y, g.z, a.x, a.y, a.z];

        let mut comps = [[0.0; N_CHANNELS]; N_EFFECTS];
        // Physical input: true motion plus vibration (real motion too).
        let mut u = true_signal;
        for mode in &mut self.road {
            let v = mode.step(motion.speed_m_s);
            for c in 0..N_CHANNELS {
                comps[Effect::RoadVibration as usize][c] += v[c];
            }
        }
        if let Some(v) = self.traj.transient(t_s) {
            for c in 0..N_CHANNELS {
                comps[Effect::RoadVibration as usize][c] += v[c];
            }
        }
        for c in 0..N_CHANNELS {
            u[c] += comps[Effect::RoadVibration as usize][c];
        }

        let temp_true = self.temp.as_mut().map(|t| t.step(t_s));
        let temp_reported = match (&mut self.temp, temp_true) {
            (Some(t), Some(tc)) => Some(t.report(tc)),
            _ => None,
        };

        if self.enabled & Effect::Noise.bit() != 0 {
            for (v, sd) in comps[Effect::Noise as usize].iter_mut().zip(&self.noise_sd) {
                *v = sd * self.noise_rng.normal();
            }
        }
        comps[Effect::TurnOnBias as usize] = self.turn_on;
        for c in 0..N_CHANNELS {
            comps[Effect::ScaleFactor as usize][c] = self.scale[c] * u[c];
        }
        let ug = Vector3::new(u[0], u[1], u[2]);
        let ua = Vector3::new(u[3], u[4], u[5]);
        let mg = self.mis_gyro * ug;
        let ma = self.mis_accel * ua;
        let gs = self.g_sens * ua;
        for i in 0..3 {
            comps[Effect::Misalignment as usize][i] = mg[i];
            comps[Effect::Misalignment as usize][3 + i] = ma[i];
            comps[Effect::GSensitivity as usize][i] = gs[i];
        }
        for (p, rng) in &mut self.gm {
            let v = p.step(rng);
            for c in 0..N_CHANNELS {
                comps[Effect::GaussMarkov as usize][c] += v[c];
            }
        }
        if let Some((p, rng)) = &mut self.ar {
            comps[Effect::ArBias as usize] = p.step(rng);
        }
        if let Some((p, rng)) = &mut self.rw {
            comps[Effect::RandomWalk as usize] = p.step(rng);
        }
        if let (Some(tb), Some(tc)) = (&mut self.temp_bias, temp_true) {
            comps[Effect::Temperature as usize] = tb.step(tc);
        }
        for l in self.lines.iter().filter(|l| t_s >= l.start_s) {
            let tau = t_s - l.start_s;
            let s = if l.half_sweep_rad_s2 == 0.0 {
                (l.omega_rad_s * t_s + l.phase_rad).sin()
            } else {
                (l.omega_rad_s * t_s + l.half_sweep_rad_s2 * tau * tau + l.phase_rad).sin()
            };
            for (v, amp) in comps[Effect::Vibration as usize].iter_mut().zip(&l.amp) {
                *v += amp * s;
            }
        }
        for (t_step, size) in &self.steps {
            if t_s >= *t_step {
                for c in 0..N_CHANNELS {
                    comps[Effect::Step as usize][c] += size[c];
                }
            }
        }
        let mut gross_mask = [false; N_CHANNELS];
        if let Some(gr) = &mut self.gross {
            let (err, mask) = gr.step();
            comps[Effect::Gross as usize] = err;
            gross_mask = mask;
        }

        // Sum in column order (see the module docs: this makes the invariant exact).
        let mut x = true_signal;
        for e in &Effect::ALL[..Effect::Saturation as usize] {
            for c in 0..N_CHANNELS {
                x[c] += comps[*e as usize][c];
            }
        }
        let mut sample_flags = 0u32;
        let mut y = x;
        if let Some(range) = &self.range {
            for c in 0..N_CHANNELS {
                if x[c].abs() >= range[c] {
                    sample_flags |= flags::sat_ch(c);
                    y[c] = x[c].clamp(-range[c], range[c]);
                    comps[Effect::Saturation as usize][c] = y[c] - x[c];
                }
            }
        }
        let mut z = y;
        if let Some(lsb) = &self.lsb {
            for c in 0..N_CHANNELS {
                z[c] = (y[c] / lsb[c]).round() * lsb[c];
                comps[Effect::Quantisation as usize][c] = z[c] - y[c];
            }
        }

        // Transport: fate of the frame and the sensor timestamp.
        let nominal_ns = self.start_t_ns + (t_s * 1e9).round() as u64;
        let (emission, mut t_ns) = match &mut self.transport {
            Some(tp) => {
                let u = tp.rng.uniform();
                let em = if u < tp.drop_prob {
                    Emission::Dropped
                } else if u < tp.drop_prob + tp.duplicate_prob {
                    Emission::Duplicated
                } else {
                    Emission::Normal
                };
                let j = (tp.jitter_sd_ns * tp.jitter_rng.normal()).round() as i64;
                (em, nominal_ns.saturating_add_signed(j))
            }
            None => (Emission::Normal, nominal_ns),
        };
        if let Some(last) = self.last_t_ns {
            t_ns = t_ns.max(last + 1);
        }
        self.last_t_ns = Some(t_ns);

        let seq = self.first_seq.wrapping_add(k as u32);
        let mut sample = Sample {
            seq,
            t_ns,
            temp_c: temp_reported,
            flags: sample_flags,
            ..Sample::default()
        };
        sample.set_channels(&z);
        Some(SimRecord {
            sample,
            truth: TruthRow {
                t_s,
                seq,
                t_ns,
                true_signal,
                temp_c: temp_true,
                components: comps,
                enabled: self.enabled,
                gross_mask,
                dropped: emission == Emission::Dropped,
                duplicated: emission == Emission::Duplicated,
            },
            emission,
        })
    }
}

impl Iterator for Simulator {
    type Item = SimRecord;
    fn next(&mut self) -> Option<SimRecord> {
        self.next_record()
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        let r = self.n - self.k;
        (r, Some(r))
    }
}

/// Generate the whole record of `scn` with `seed` and write its truth sidecar to `path`
/// (gzip when the name ends in `.gz`). Returns the number of rows written.
pub fn write_truth_file(path: &Path, scn: &Scenario, seed: u64) -> Result<u64, SimError> {
    write_truth_file_with(path, scn, seed, TruthPrecision::Exact)
}

/// [`write_truth_file`] with a chosen value precision (see [`TruthPrecision`]).
pub fn write_truth_file_with(
    path: &Path,
    scn: &Scenario,
    seed: u64,
    precision: TruthPrecision,
) -> Result<u64, SimError> {
    let mut sim = Simulator::new(scn, seed)?;
    let mut w = TruthWriter::create_with(path, &sim.truth_header(), precision)?;
    while let Some(r) = sim.next_record() {
        w.write_row(&r.truth)?;
    }
    Ok(w.finish()?)
}
