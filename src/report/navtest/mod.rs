//! `imuprep navtest`: imuprep's own GNSS/INS filter ([`crate::nav::eskf`]) on the real
//! rtklibexplorer drive and walk, with simulated GNSS outages, fed (a) the raw IMU, (b) imuprep's
//! default-cleaned IMU (the embedded config's pipeline, run in-process), (c) imuprep's output
//! with the models `imuprep fit` made on another stretch or the other recording ([`fitted`];
//! scored on the outages outside that stretch, beside (a) and (b) on the same outages), and
//! (d) the raw IMU
//! with the filter's bias process augmented by a first-order Gauss–Markov part per axis whose σ
//! and correlation time come from imuprep's Allan terms ([`crate::analysis::allan::export::bias_model`])
//! of the recording's longest still stretch (the random-walk part keeps the reference's density;
//! an implausible part falls back to it, [`augment`]); the do-no-harm check (b) ≤ (a) per cell
//! with the outages behind every miss ([`harm`]); the error budget of the 30-s outages
//! ([`budget`]); (e) and (e') the raw IMU with the filter's process noise from the same Allan
//! terms ([`noise_variants`]); plus, on the static benches, the drift of a free-inertial
//! solution, raw against cleaned ([`static_drift`]).
//!
//! Files: [`setup`] (records, the reference's settings, body-frame IMU), [`outages`] (schedule,
//! filter runs, statistics), [`attref`], [`comma`], [`augment`], [`fitted`], [`harm`],
//! [`budget`], [`static_drift`], and the text report (`display`).
//!
//! **What is copied from the reference filter's setup** (rtklibexplorer's GNSS_IMU, its
//! `drive_config.py` / `walk_config.py`; values, not code): the IMU-to-body rotation, the lever
//! arm, the drive's IMU time offset (−0.125 s), the noise densities with the tool's
//! per-state factors and its per-step discretisation (`(v·√rate·factor)²` per second, i.e.
//! √100·factor times the datasheet density, see [`reference_noise`]), ZUPT/ZARU thresholds
//! (50 still epochs, 0.25 m/s², 0.25 °/s, σ 0.01 m/s and 0.01 °/s), the initial uncertainties,
//! the yaw alignment to the GNSS course above 1 m/s, GNSS σ from the `.pos` file (×2 float,
//! ×5 single), accelerations read in g and scaled by the local gravity. What differs: the initial
//! roll and pitch come from levelling the first second of IMU data (the tool starts level with
//! 10° σ); the still test runs on 10-epoch moving averages (the tool's input is low-passed at
//! 10 Hz by its converter, the IMU here is used as recorded); mechanisation in a local-level
//! NED frame (the tool: ECEF).
//!
//! **Outages** as the Python harness (`tests/reference/navtest/`, scheme (ii)): 10, 30 and 60 s,
//! start times `start_coast + i·3L/K` s after the first GNSS epoch for the smallest K that gives
//! ≥ 20 scorable outages up to 1 s before the GNSS ends; scored at the last RTK epoch the filter
//! did not get, which must be fixed. Each outage is a copy of the no-outage filter at its start
//! that runs without GNSS (ZUPT still active) to its end — one outage per run. Errors: the
//! antenna position against the RTK position (horizontal, vertical), and heading and tilt
//! against the raw no-outage run at the same epoch; where a record has an independent attitude
//! reference (comma2k19's pose, the drive's RTK course over ground) also against that
//! ([`attref`]).

pub mod attref;
pub mod augment;
pub mod budget;
pub mod comma;
mod display;
pub mod fitted;
pub mod harm;
pub mod outages;
pub mod setup;
pub mod static_drift;

use std::path::Path;

use serde::Serialize;

pub use attref::{AttRefReport, AttRefRow, att_ref_report, reference_attitude};
pub use augment::{
    AugmentationSource, augmentation_from_allan, augmentation_from_notes, noise_variants,
};
pub use budget::{BUDGET_LENGTH_S, BudgetRow, error_budget};
pub use fitted::{FittedModels, MIN_STILL_CHOICES_S, fit_models, held_out};
pub use harm::{HarmCell, HarmOutage, harm_check};
pub use outages::{
    LENGTHS, MIN_STARTS, Oracle, Outage, OutageError, Row, RunResult, percentile, rows, run_filter,
    run_filter_with, schedule,
};
pub use setup::{
    AttRefSource, BodyImu, GnssSource, RecordSpec, comma_record, default_records, filter_config,
    reference_noise, to_body,
};
pub use static_drift::{DriftRow, STATIC_ALIGN_S, run_bench, static_drift};

use crate::config::Config;
use crate::frame::Descriptor;
use crate::nav::earth;
use crate::nav::eskf::EskfConfig;
use crate::nav::pos::{self, PosEpoch};
use crate::report::audit::{load_recording, run_config};
use crate::sample::{Sample, flags};

/// A record read from disk.
pub struct Loaded {
    pub spec: RecordSpec,
    pub desc: Descriptor,
    pub raw: Vec<Sample>,
    pub gnss: Vec<PosEpoch>,
}

/// Read a record's IMU and RTK solution.
pub fn load(spec: &RecordSpec) -> Result<Loaded, String> {
    let (desc, raw) = load_recording(&spec.imu_csv)?;
    let gnss = match spec.gnss {
        GnssSource::RtkPos => pos::read(&spec.pos).map_err(|e| e.to_string())?,
        GnssSource::ReferencePose {
            every,
            pos_sd,
            vel_sd,
        } => comma::read_reference_pose(&spec.pos, every, pos_sd, vel_sd)?,
    };
    if gnss.is_empty() || raw.is_empty() {
        return Err("no GNSS epochs or no IMU samples".into());
    }
    Ok(Loaded {
        spec: spec.clone(),
        desc,
        raw,
        gnss,
    })
}

/// What imuprep did to a record under one variant, and how the filter took it.
#[derive(Clone, Debug, Serialize)]
pub struct VariantSummary {
    pub variant: String,
    /// Samples replaced (gross error) and bias-corrected by imuprep (`None` for the raw IMU).
    pub replaced: Option<usize>,
    pub bias_removed: Option<usize>,
    /// Mean (out − in) of the gyros over the record, body axes, °/s.
    pub mean_change_dps: [f64; 3],
    pub zupt_updates: usize,
    /// The filter's gyro-bias estimate, median over its GNSS epochs, body axes, °/s.
    pub median_gyro_bias_dps: [f64; 3],
}

/// Variant (c) with one set of fitted models: its rows beside (a) and (b) on the same
/// (held-out) outages, or why it did not run.
#[derive(Clone, Debug, Serialize)]
pub struct FittedBlock {
    pub label: String,
    pub models: FittedModels,
    /// (a), (b), (c) on the outages outside the fitted stretch.
    pub rows: Vec<Row>,
    pub not_run: Option<String>,
}

/// One record's results.
#[derive(Clone, Debug, Serialize)]
pub struct RecordResult {
    pub name: String,
    pub imu_epochs: usize,
    pub gnss_epochs: usize,
    pub fixed_epochs: usize,
    pub duration_s: f64,
    /// Per length: count, first and last start (s after the first GNSS epoch), spacing.
    pub schedule: Vec<(f64, usize, f64, f64, f64)>,
    /// (a), (b), (d) on every outage.
    pub rows: Vec<Row>,
    pub outages: Vec<(String, OutageError)>,
    pub augmentation: Option<AugmentationSource>,
    pub augmentation_error: Option<String>,
    pub variants: Vec<VariantSummary>,
    pub fitted: Vec<FittedBlock>,
    /// Models `fit` could not make, (options, error).
    pub fit_errors: Vec<(String, String)>,
    pub harm: Vec<HarmCell>,
    pub harm_outages: Vec<HarmOutage>,
    pub budget: Vec<BudgetRow>,
    /// Heading and tilt against an independent attitude reference, where the record has one.
    pub att_ref: Option<AttRefReport>,
    /// The process noise of (a)–(d) (the reference filter's, [`reference_noise`]).
    pub filter_noise: crate::nav::eskf::ImuNoise,
}

fn summary(
    variant: &str,
    raw: &BodyImu,
    input: &BodyImu,
    out: Option<&[Sample]>,
    run: &RunResult,
) -> VariantSummary {
    let n = raw.w.len().min(input.w.len()).max(1);
    let mut chg = [0.0; 3];
    for i in 0..n.min(raw.w.len()).min(input.w.len()) {
        for (a, c) in chg.iter_mut().enumerate() {
            *c += (input.w[i][a] - raw.w[i][a]).to_degrees() / n as f64;
        }
    }
    let count = |m: u32| out.map(|s| s.iter().filter(|x| x.flags & m != 0).count());
    VariantSummary {
        variant: variant.into(),
        replaced: count(flags::REPLACED | flags::REPLACED_ANY),
        bias_removed: out.map(|s| s.iter().filter(|x| x.bias_subtracted()).count()),
        mean_change_dps: chg,
        zupt_updates: run.stats.zupt_updates,
        median_gyro_bias_dps: run.median_gyro_bias_dps,
    }
}

const A: &str = "(a) raw";
const B: &str = "(b) imuprep default";
const D: &str = "(d) raw, Allan GM bias model";

/// Run every variant on one record; `models` are the fitted models to try as (c) (this
/// record's own and the other record's).
pub fn run_record(
    l: &Loaded,
    cfg: &Config,
    models: &[FittedModels],
) -> Result<RecordResult, String> {
    let (spec, desc, raw, gnss) = (&l.spec, &l.desc, &l.raw, &l.gnss);
    let g_local = earth::gravity(gnss[0].lat, gnss[0].h);
    let cleaned = clean(cfg, desc, raw)?;
    let outages: Vec<Outage> = LENGTHS
        .iter()
        .flat_map(|&l| schedule(gnss, spec, l))
        .collect();
    let schedule_summary = LENGTHS
        .iter()
        .map(|&l| {
            let s: Vec<f64> = outages
                .iter()
                .filter(|o| o.length_s == l)
                .map(|o| o.start_rel_s)
                .collect();
            let step = if s.len() > 1 { s[1] - s[0] } else { f64::NAN };
            (
                l,
                s.len(),
                s.first().copied().unwrap_or(f64::NAN),
                s.last().copied().unwrap_or(f64::NAN),
                step,
            )
        })
        .collect();
    let raw_b = to_body(spec, raw, g_local);
    let clean_b = to_body(spec, &cleaned, g_local);
    let base = filter_config(spec, None);
    let a = run_filter(&base, &raw_b, gnss, &outages, None)?;
    let att_ref = a.attitude_at_epoch.clone();
    let b = run_filter(&base, &clean_b, gnss, &outages, Some(&att_ref))?;
    let (aug, aug_err) = match augmentation_from_allan(spec, raw, desc.sample_rate_hz, gnss) {
        Ok(a) => (Some(a), None),
        Err(e) => (None, Some(e)),
    };
    let d = match &aug {
        Some(src) => Some(run_filter(
            &filter_config(spec, src.augmentation),
            &raw_b,
            gnss,
            &outages,
            Some(&att_ref),
        )?),
        None => None,
    };
    let mut e_runs = vec![];
    for (label, noise) in aug
        .as_ref()
        .map(|s| noise_variants(s, &base.noise))
        .unwrap_or_default()
    {
        let cfg_e = EskfConfig {
            noise,
            ..base.clone()
        };
        e_runs.push((
            label,
            run_filter(&cfg_e, &raw_b, gnss, &outages, Some(&att_ref))?,
        ));
    }
    let mut rows_all = rows(&spec.name, A, &a.errors);
    rows_all.extend(rows(&spec.name, B, &b.errors));
    let mut all = vec![];
    let mut variants = vec![
        summary(A, &raw_b, &raw_b, None, &a),
        summary(B, &raw_b, &clean_b, Some(&cleaned), &b),
    ];
    for (v, r) in [(A, &a), (B, &b)] {
        all.extend(r.errors.iter().map(|e| (v.to_string(), *e)));
    }
    if let Some(d) = &d {
        rows_all.extend(rows(&spec.name, D, &d.errors));
        all.extend(d.errors.iter().map(|e| (D.to_string(), *e)));
        variants.push(summary(D, &raw_b, &raw_b, None, d));
    }
    for (label, e) in &e_runs {
        rows_all.extend(rows(&spec.name, label, &e.errors));
        all.extend(e.errors.iter().map(|x| (label.to_string(), *x)));
        variants.push(summary(label, &raw_b, &raw_b, None, e));
    }
    let mut fitted = vec![];
    for m in models {
        let label = m.label(&spec.name);
        let ho: Vec<Outage> = outages
            .iter()
            .filter(|o| held_out(m, o.start, o.end))
            .copied()
            .collect();
        let keep = |e: &[OutageError]| -> Vec<OutageError> {
            e.iter()
                .filter(|x| held_out(m, x.outage.start, x.outage.end))
                .copied()
                .collect()
        };
        let mut block = FittedBlock {
            label: label.clone(),
            models: m.clone(),
            rows: vec![],
            not_run: None,
        };
        match clean(&m.config(cfg), desc, raw) {
            Err(e) => block.not_run = Some(format!("the pipeline refused the models: {e}")),
            Ok(cl) => {
                let cb = to_body(spec, &cl, g_local);
                let c = run_filter(&base, &cb, gnss, &ho, Some(&att_ref))?;
                block.rows = rows(&spec.name, "(a) raw, same outages", &keep(&a.errors));
                block.rows.extend(rows(
                    &spec.name,
                    "(b) imuprep default, same outages",
                    &keep(&b.errors),
                ));
                block.rows.extend(rows(&spec.name, &label, &c.errors));
                all.extend(c.errors.iter().map(|e| (label.clone(), *e)));
                variants.push(summary(&label, &raw_b, &cb, Some(&cl), &c));
            }
        }
        fitted.push(block);
    }
    let (harm, harm_outages) =
        harm_check(&a.errors, &b.errors, &raw_b, &clean_b, &cleaned, spec.t_off);
    let budget = error_budget(&base, &raw_b, gnss, &outages, &att_ref)?;
    let t_first = outages
        .iter()
        .map(|o| o.start)
        .fold(f64::INFINITY, f64::min);
    let indep = reference_attitude(spec, gnss)?
        .map(|r| att_ref_report(spec.att_ref, &r, gnss, &att_ref, t_first, &all));
    Ok(RecordResult {
        name: spec.name.clone(),
        imu_epochs: raw.len(),
        gnss_epochs: gnss.len(),
        fixed_epochs: gnss.iter().filter(|e| e.q == 1).count(),
        duration_s: gnss[gnss.len() - 1].t - gnss[0].t,
        schedule: schedule_summary,
        rows: rows_all,
        outages: all,
        augmentation: aug,
        augmentation_error: aug_err,
        variants,
        fitted,
        fit_errors: vec![],
        harm,
        harm_outages,
        budget,
        att_ref: indep,
        filter_noise: base.noise,
    })
}

/// `cfg`'s pipeline over the samples, in-process.
pub fn clean(cfg: &Config, desc: &Descriptor, raw: &[Sample]) -> Result<Vec<Sample>, String> {
    run_config(cfg, desc, raw)
}

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct NavtestReport {
    pub records: Vec<RecordResult>,
    pub record_errors: Vec<(String, String)>,
    pub drift: Vec<DriftRow>,
    pub drift_errors: Vec<(String, String)>,
}

/// Run everything found under `data` (`../shared/data/real`): the rtklibexplorer drive and
/// walk and the comma2k19 segment; a missing recording is listed in the errors, not fatal.
/// Variant (c) on each record uses the models `fit` made on its own fit stretch and on the
/// other records of the same sensor, for each of [`MIN_STILL_CHOICES_S`].
pub fn navtest(data: &Path, cfg: &Config, with_static: bool) -> NavtestReport {
    // The fits' and the stages' own messages (lines found, …) are not the test's report.
    let quiet = tracing::subscriber::NoSubscriber::default();
    tracing::subscriber::with_default(quiet, || run_navtest(data, cfg, with_static))
}

fn run_navtest(data: &Path, cfg: &Config, with_static: bool) -> NavtestReport {
    let mut rep = NavtestReport {
        records: vec![],
        record_errors: vec![],
        drift: vec![],
        drift_errors: vec![],
    };
    let mut loaded = vec![];
    let mut specs = default_records(&data.join("rtklibexplorer_drive_walk"));
    specs.push(comma_record(&data.join("comma2k19_car_segment")));
    // One step a record fitted, one a record run, one a static bench.
    let benches = if with_static { 2 } else { 0 };
    let bar = crate::progress::bar(2 * specs.len() as u64 + benches);
    for spec in specs {
        match load(&spec) {
            Ok(l) => loaded.push(l),
            Err(e) => rep.record_errors.push((spec.name.clone(), e)),
        }
    }
    let mut models = vec![];
    let mut fit_errors = vec![];
    for l in &loaded {
        bar.set_message(format!("{}: fitting", l.spec.name));
        for m in MIN_STILL_CHOICES_S {
            match fit_models(&l.spec, &l.desc, &l.raw, m) {
                Ok(f) => models.push(f),
                Err(e) => fit_errors.push((l.spec.name.clone(), m, e)),
            }
        }
        bar.inc(1);
    }
    for l in &loaded {
        // This record's own models first.
        let mut mine: Vec<FittedModels> = models
            .iter()
            .filter(|m| m.record == l.spec.name)
            .cloned()
            .collect();
        // Then those of the other records of the same sensor.
        let same_sensor = |m: &&FittedModels| {
            m.record != l.spec.name
                && loaded
                    .iter()
                    .any(|o| o.spec.name == m.record && o.spec.sensor == l.spec.sensor)
        };
        mine.extend(models.iter().filter(same_sensor).cloned());
        bar.set_message(format!("{}: the filter's runs", l.spec.name));
        let run = run_record(l, cfg, &mine);
        bar.inc(1);
        match run {
            Ok(mut r) => {
                r.fit_errors = fit_errors
                    .iter()
                    .filter(|(rec, _, _)| *rec == l.spec.name)
                    .map(|(rec, m, e)| (format!("{rec}, --min-still-s {m}"), e.clone()))
                    .collect();
                rep.records.push(r)
            }
            Err(e) => rep.record_errors.push((l.spec.name.clone(), e)),
        }
    }
    if with_static {
        for (name, p, skip) in [
            (
                "ADIS16405",
                data.join("adis16405_static/adis_16405_imu1.csv.gz"),
                10.0,
            ),
            (
                "MPU6050",
                data.join("mpu6050_static_10min_temp/mpu6050_static.csv"),
                5.0,
            ),
        ] {
            bar.set_message(format!("{name}: free-inertial drift"));
            let run = run_bench(name, &p, cfg, skip);
            bar.inc(1);
            match run {
                Ok(r) => rep.drift.extend(r),
                Err(e) => rep.drift_errors.push((name.into(), e)),
            }
        }
    }
    bar.finish_and_clear();
    rep
}
