//! `imuprep evaluate`: the configured pipeline against a calibration-only baseline, on a
//! simulated scenario whose truth is known (issue 5's drive targets).
//!
//! Definitions (gyro channels; truth = true angular rate + road vibration, i.e. what a perfect
//! sensor would read):
//! - *1-s mean error*: the error (output − truth) averaged over consecutive 1-s blocks; its RMS.
//! - *60-s heading drift*: the error integrated over consecutive 60-s windows (rad); RMS of the
//!   window-end values — a plain single-axis strapdown of the error.
//! - *manoeuvre change*: for every stretch where |true rate| > 0.05 rad/s for ≥ 1 s, the signed
//!   change 1 − ∫output/∫truth over that stretch. Positive = *attenuated* (the output turned less
//!   than the vehicle did); negative = amplified. Everything the output still carries counts: a
//!   bias left from before the turn, and the scale-factor and g-sensitivity errors that no bias
//!   stage removes. Reported: the worst attenuation (largest positive change, 0 if none) and the
//!   worst |change|.
//! - *removed by the stage*: the part of the change the pipeline itself made. The stage's
//!   correction is c = baseline − output; if it holds the bias through the turn, c stays at its
//!   value just before. So (∫c over the turn − n·mean c in the 1 s before) / ∫truth is the share
//!   of the turn that the pipeline subtracted — the quantity that must stay small for true motion
//!   to survive.
//!
//! The baseline applies only the configured calibration (constant bias, scale, misalignment).
//!
//! *Static 60-s position drift* ([`static_position_drift`], static scenarios): a plain strapdown
//! of the output's errors over consecutive 60-s windows, each started from a perfect alignment
//! (zero attitude, velocity and position error). In the (fixed) body frame of a sensor at rest,
//! to first order in the errors (Titterton & Weston, *Strapdown Inertial Navigation Technology*,
//! 2nd ed., §12.2, with the Earth-rate and transport terms dropped — below consumer MEMS errors
//! over 60 s):
//!
//! ```text
//!   δθ' = δω                 δω = gyro output − true rate
//!   δv' = δf + f × δθ        δf = accel output − true specific force, f = true specific force
//!   δp' = δv
//! ```
//!
//! so a gyro bias tilts the computed attitude and leaks gravity into the horizontal channels
//! (`g δω t³/6`), and an accelerometer bias adds `δf t²/2`. Scored: the RMS over windows of |δp|
//! at each window's end (m).

use crate::sample::{CHANNEL_NAMES, Sample};
use crate::sim::truth::{Effect, TruthRow};
use crate::stage::Pipeline;
use serde::Serialize;

/// Scores of one output series on one gyro channel.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Scores {
    pub rms_1s_mean_error: f64,
    pub rms_60s_drift_rad: f64,
}

/// One gyro channel: pipeline vs baseline.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelEval {
    pub channel: String,
    pub pipeline: Scores,
    pub baseline: Scores,
    /// baseline / pipeline for the 1-s mean error (target ≥ 5).
    pub improvement_1s: f64,
    /// 1 − pipeline/baseline for the 60-s drift (target ≥ 0.8).
    pub drift_reduction: f64,
    /// Largest signed change (positive = attenuated; 0 if no manoeuvre was attenuated).
    /// Target: no manoeuvre attenuated by more than 1 %.
    pub worst_attenuation: f64,
    /// Largest |change| either way (amplification included).
    pub worst_abs_change: f64,
    /// Largest |share of a turn removed by the pipeline itself| (module docs).
    pub worst_stage_removed: f64,
    pub manoeuvres: usize,
    /// Every manoeuvre, in time order.
    pub manoeuvre_list: Vec<Manoeuvre>,
}

/// One manoeuvre (|true rate| > 0.05 rad/s for ≥ 1 s) on one gyro channel.
#[derive(Debug, Clone, Serialize)]
pub struct Manoeuvre {
    /// Start time from the first sample (s) and duration (s).
    pub start_s: f64,
    pub duration_s: f64,
    /// ∫truth over the manoeuvre (rad).
    pub true_angle_rad: f64,
    /// Signed 1 − ∫output/∫truth (positive = attenuated).
    pub change: f64,
    /// Share of ∫truth that the pipeline subtracted during the turn beyond the correction it
    /// applied just before it (module docs); positive = motion removed.
    pub stage_removed: f64,
    /// Mean output error (output − truth) over the manoeuvre (rad/s) — a bias left in the output.
    pub mean_error: f64,
    /// Mean output error over the 1 s before the manoeuvre (rad/s): if it matches `mean_error`, the
    /// change is a bias carried in from before the turn, not motion removed by the stage.
    pub mean_error_before: f64,
}

/// RMS of `f` over the complete blocks of `n` samples; NaN (not computed: the JSON's null, the
/// text's "n/a") when the record holds no complete block — a 1-s record once scored a 60-s
/// drift of 0 and a reduction of NaN %.
fn blocks(err: &[f64], n: usize, f: impl Fn(&[f64]) -> f64) -> f64 {
    let v: Vec<f64> = err.chunks_exact(n.max(1)).map(f).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// `v` as `{:>w$.p$e}`, or right-aligned "n/a" when it was not computed.
fn or_na(v: f64, w: usize, p: usize, pct: bool) -> String {
    match (v.is_finite(), pct) {
        (false, _) => format!("{:>w$}", "n/a"),
        (true, false) => format!("{v:>w$.p$e}"),
        (true, true) => format!("{:>w$.p$}%", 100.0 * v, w = w - 1),
    }
}

fn scores(err: &[f64], rate: f64) -> Scores {
    let n1 = rate.round() as usize;
    let dt = 1.0 / rate;
    Scores {
        rms_1s_mean_error: blocks(err, n1, |b| b.iter().sum::<f64>() / b.len() as f64),
        rms_60s_drift_rad: blocks(err, 60 * n1, |b| b.iter().sum::<f64>() * dt),
    }
}

/// The pipeline's output and the calibration-only baseline's, sample for sample, on the same
/// simulated input.
pub struct Outputs {
    pub pipeline: Vec<Sample>,
    pub baseline: Vec<Sample>,
}

impl Outputs {
    /// Run `pipeline` and `baseline` over `samples`.
    pub fn of(
        samples: &[Sample],
        mut pipeline: Pipeline,
        baseline: impl FnMut(Sample) -> Sample,
    ) -> Self {
        Outputs {
            pipeline: crate::stage::run_through(&mut pipeline, samples),
            baseline: samples.iter().copied().map(baseline).collect(),
        }
    }
}

/// Evaluate the pipeline's output against the calibration-only baseline's on the simulated
/// scenario.
pub fn evaluate(outputs: &Outputs, truth: &[TruthRow], rate_hz: f64) -> Vec<ChannelEval> {
    let (out, base) = (&outputs.pipeline, &outputs.baseline);
    let mut res = Vec::new();
    for (c, ch_name) in CHANNEL_NAMES.iter().enumerate().take(3) {
        let tr: Vec<f64> = truth
            .iter()
            .map(|t| t.true_signal[c] + t.component(Effect::RoadVibration, c))
            .collect();
        let e_p: Vec<f64> = out.iter().zip(&tr).map(|(s, t)| s.channel(c) - t).collect();
        let e_b: Vec<f64> = base
            .iter()
            .zip(&tr)
            .map(|(s, t)| s.channel(c) - t)
            .collect();
        // The pipeline's own correction, c = baseline − output = e_b − e_p.
        let corr: Vec<f64> = e_b.iter().zip(&e_p).map(|(b, p)| b - p).collect();
        // Manoeuvres: stretches of |true rate| > 0.05 rad/s lasting ≥ 1 s.
        let mut worst: f64 = 0.0;
        let mut worst_abs: f64 = 0.0;
        let mut worst_removed: f64 = 0.0;
        let mut count = 0;
        let mut list = Vec::new();
        let n1 = rate_hz.round() as usize;
        let mut i = 0;
        while i < tr.len() {
            if truth[i].true_signal[c].abs() > 0.05 {
                let j0 = i;
                while i < tr.len() && truth[i].true_signal[c].abs() > 0.05 {
                    i += 1;
                }
                if (i - j0) as f64 >= rate_hz {
                    count += 1;
                    // Signed relative change of the manoeuvre's integral (its heading change):
                    // any bias the output still carries counts against the stage as well.
                    let true_int: f64 = tr[j0..i].iter().sum();
                    let out_int: f64 = out[j0..i].iter().map(|s| s.channel(c)).sum();
                    let change = 1.0 - out_int / true_int;
                    worst = worst.max(change);
                    worst_abs = worst_abs.max(change.abs());
                    let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len().max(1) as f64;
                    let before = mean(&corr[j0.saturating_sub(n1)..j0]);
                    let removed = corr[j0..i].iter().map(|c| c - before).sum::<f64>() / true_int;
                    worst_removed = worst_removed.max(removed.abs());
                    list.push(Manoeuvre {
                        start_s: j0 as f64 / rate_hz,
                        duration_s: (i - j0) as f64 / rate_hz,
                        true_angle_rad: true_int / rate_hz,
                        change,
                        stage_removed: removed,
                        mean_error: mean(&e_p[j0..i]),
                        mean_error_before: mean(&e_p[j0.saturating_sub(n1)..j0]),
                    });
                }
            } else {
                i += 1;
            }
        }
        let p = scores(&e_p, rate_hz);
        let b = scores(&e_b, rate_hz);
        res.push(ChannelEval {
            channel: ch_name.to_string(),
            improvement_1s: b.rms_1s_mean_error / p.rms_1s_mean_error,
            drift_reduction: 1.0 - p.rms_60s_drift_rad / b.rms_60s_drift_rad,
            pipeline: p,
            baseline: b,
            worst_attenuation: worst,
            worst_abs_change: worst_abs,
            worst_stage_removed: worst_removed,
            manoeuvres: count,
            manoeuvre_list: list,
        });
    }
    res
}

/// Static 60-s position drift of the pipeline and of the calibration-only baseline (module docs).
#[derive(Debug, Clone, Serialize)]
pub struct StaticDrift {
    /// Number of complete 60-s windows scored.
    pub windows: usize,
    /// RMS of |δp| at the window ends, m.
    pub pipeline_rms_m: f64,
    pub baseline_rms_m: f64,
    /// 1 − pipeline/baseline (target ≥ 0.8).
    pub reduction: f64,
}

/// Strapdown position error at the end of each `n`-sample window (see module docs).
fn window_position_errors(out: &[Sample], truth: &[TruthRow], n: usize, dt: f64) -> Vec<f64> {
    use nalgebra::Vector3;
    out.chunks_exact(n)
        .zip(truth.chunks_exact(n))
        .map(|(o, t)| {
            let (mut th, mut v, mut p) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
            for (s, tr) in o.iter().zip(t) {
                let f = Vector3::new(tr.true_signal[3], tr.true_signal[4], tr.true_signal[5]);
                let dw =
                    s.gyro - Vector3::new(tr.true_signal[0], tr.true_signal[1], tr.true_signal[2]);
                let df = s.accel - f;
                // Semi-implicit Euler: attitude, then velocity, then position.
                th += dw * dt;
                v += (df + f.cross(&th)) * dt;
                p += v * dt;
            }
            p.norm()
        })
        .collect()
}

/// The static 60-s position drift of `pipeline` vs the calibration-only `baseline`, or `None`
/// when the scenario moves (|true rate| > 1e-3 rad/s anywhere) or is shorter than 60 s.
pub fn static_position_drift(
    outputs: &Outputs,
    truth: &[TruthRow],
    rate_hz: f64,
) -> Option<StaticDrift> {
    let (out, base) = (&outputs.pipeline, &outputs.baseline);
    let still = truth
        .iter()
        .all(|t| t.true_signal[..3].iter().all(|w| w.abs() < 1e-3));
    let n = (60.0 * rate_hz).round() as usize;
    if !still || n == 0 || base.len() < n {
        return None;
    }
    let rms = |e: Vec<f64>| (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt();
    let dt = 1.0 / rate_hz;
    let pe = window_position_errors(out, truth, n, dt);
    let windows = pe.len();
    let p = rms(pe);
    let b = rms(window_position_errors(base, truth, n, dt));
    Some(StaticDrift {
        windows,
        pipeline_rms_m: p,
        baseline_rms_m: b,
        reduction: 1.0 - p / b,
    })
}

/// Convenience: simulate a scenario and decode it as replay would.
pub use crate::report::detector_compare::simulate_decoded as simulate;

/// `imuprep evaluate`: [`evaluate`] and [`static_position_drift`] on a simulated scenario.
#[derive(Debug, Clone, Serialize)]
pub struct EvaluateReport {
    pub scenario: String,
    pub seed: u64,
    pub channels: Vec<ChannelEval>,
    pub static_drift: Option<StaticDrift>,
}

/// Simulate `scenario` (with `--set` overrides) and score `cfg`'s pipeline against the
/// calibration-only baseline.
pub fn evaluate_scenario(
    scenario: &std::path::Path,
    seed: Option<u64>,
    cfg: &mut crate::config::Config,
    sets: &[String],
) -> anyhow::Result<EvaluateReport> {
    use anyhow::{Context, anyhow};
    let scn = super::read_scenario(scenario, sets)?;
    let seed = crate::sim::log::effective_seed(&scn, seed);
    let rate = scn.sample_rate_hz();
    cfg.stages.set_sample_rate(rate)?;
    let pipeline = cfg.stages.build().map_err(|e| anyhow!(e))?;
    let (samples, truth) = simulate(&scn, seed)?;
    let cal = cfg
        .stages
        .bias
        .as_ref()
        .map(|b| b.settings.clone().into_inner())
        .unwrap_or_default();
    let gyro_cal = cal
        .gyro
        .build()
        .context("gyro calibration matrix is singular")?;
    let accel_cal = cal
        .accel
        .build()
        .context("accel calibration matrix is singular")?;
    let calibrate = move |mut s: Sample| {
        s.gyro = gyro_cal.apply(&s.gyro);
        s.accel = accel_cal.apply(&s.accel);
        s
    };
    let outputs = Outputs::of(&samples, pipeline, calibrate);
    let channels = evaluate(&outputs, &truth, rate);
    let static_drift = static_position_drift(&outputs, &truth, rate);
    Ok(EvaluateReport {
        scenario: scenario.display().to_string(),
        seed,
        channels,
        static_drift,
    })
}

impl std::fmt::Display for EvaluateReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "pipeline vs calibration-only baseline on {} (seed {}), gyro channels:",
            self.scenario, self.seed
        )?;
        writeln!(
            f,
            "{:<3} {:>14} {:>14} {:>8} {:>14} {:>14} {:>9}  manoeuvres: worst attenuation, worst |change|, worst removed by the stage",
            "ch", "1s-mean RMS", "baseline", "ratio", "60s drift rad", "baseline", "reduced",
        )?;
        for r in &self.channels {
            writeln!(
                f,
                "{:<3} {} {} {} {} {} {}  {}",
                r.channel,
                or_na(r.pipeline.rms_1s_mean_error, 14, 3, false),
                or_na(r.baseline.rms_1s_mean_error, 14, 3, false),
                if r.improvement_1s.is_finite() {
                    format!("{:>8.2}", r.improvement_1s)
                } else {
                    format!("{:>8}", "n/a")
                },
                or_na(r.pipeline.rms_60s_drift_rad, 14, 3, false),
                or_na(r.baseline.rms_60s_drift_rad, 14, 3, false),
                or_na(r.drift_reduction, 9, 1, true),
                // With no manoeuvre on the axis there is no worst one: not "0.00%".
                if r.manoeuvres == 0 {
                    "none on this axis".to_string()
                } else {
                    format!(
                        "{:.2}%, {:.2}%, {:.2}% of {}",
                        100.0 * r.worst_attenuation,
                        100.0 * r.worst_abs_change,
                        100.0 * r.worst_stage_removed,
                        r.manoeuvres
                    )
                }
            )?;
        }
        if let Some(d) = &self.static_drift {
            writeln!(
                f,
                "static 60-s position drift (plain strapdown of the errors, {} windows): RMS {:.3e} m, baseline {:.3e} m, reduced {:.1}%",
                d.windows,
                d.pipeline_rms_m,
                d.baseline_rms_m,
                100.0 * d.reduction
            )?;
        }
        for r in self
            .channels
            .iter()
            .filter(|r| !r.manoeuvre_list.is_empty())
        {
            writeln!(
                f,
                "{} manoeuvres: start s, duration s, true angle rad, change (+ = attenuated), removed by the stage, mean error rad/s (in the 1 s before)",
                r.channel
            )?;
            for m in &r.manoeuvre_list {
                writeln!(
                    f,
                    "  {:>7.1} {:>6.1} {:>9.4} {:>+8.2}% {:>+8.3}% {:>+11.3e} ({:>+10.3e})",
                    m.start_s,
                    m.duration_s,
                    m.true_angle_rad,
                    100.0 * m.change,
                    100.0 * m.stage_removed,
                    m.mean_error,
                    m.mean_error_before
                )?;
            }
        }
        Ok(())
    }
}
