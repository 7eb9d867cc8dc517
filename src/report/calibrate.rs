//! `imuprep calibrate LOG`: the accelerometer triad's bias, scale factor and misalignment from
//! the still stretches of a moving recording (`analysis::calib::still`, `analysis::calib::fit`),
//! each kept only where held-out attitudes say so. Writes `D/report.txt`, `D/report.json` and,
//! when something was kept, `D/calibration.toml`: a `[bias.settings.accel]` section that
//! `replay`/`run --config D/calibration.toml` lays over the defaults (a user config changes only
//! what it names), or that can be copied into the daemon's config.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, ensure};
use serde::Serialize;

use super::{load_channels_to, present_channels_of};
use crate::analysis::calib::course::{CourseEpoch, CourseScale, CourseSettings, course_scale};
use crate::analysis::calib::fit::{
    AccelCalibration, CalibSettings, Candidate, NotIdentifiable, calibrate_accel,
};
use crate::analysis::calib::gyro::{GyroCalibration, calibrate_gyro, gyro_intervals};
use crate::analysis::calib::still::{StillSettings, still_stretches};
use crate::analysis::quantisation::quantisation;
use crate::sample::Channels;

/// What `calibrate` runs on.
#[derive(Clone, Debug)]
pub struct CalibrateOptions {
    /// Analyse from this time, s from the start of the log ...
    pub from_s: f64,
    /// ... to this one (None: the end).
    pub to_s: Option<f64>,
    /// Gravity magnitude, m/s² (the fitted common scale is relative to it).
    pub gravity_m_s2: f64,
    /// Output directory.
    pub out_dir: PathBuf,
    /// An RTKLIB `.pos` solution with velocities on the log's clock (GPST): also fit the gyro's
    /// scale about the vertical from the turns of a drive (`analysis::calib::course`).
    pub gnss: Option<PathBuf>,
}

/// The report of one run.
#[derive(Debug, Serialize)]
pub struct CalibrateReport {
    /// What was analysed.
    pub source: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// How the calibration was chosen and tested.
    pub method: &'static str,
    /// The accelerometer calibration.
    pub accel: AccelCalibration,
    /// The gyroscope calibration (None: the log has no gyro, see `gyro_skipped`).
    pub gyro: Option<GyroCalibration>,
    pub gyro_skipped: Option<String>,
    /// The gyro's scale error about the vertical against the GNSS course (with `--gnss`), or
    /// why there is none.
    pub course: Option<CourseScale>,
    pub course_skipped: Option<String>,
    /// The config file written (None when nothing was kept).
    pub config_file: Option<PathBuf>,
}

const METHOD: &str = "still stretches by the bias stage's stillness detector; |L^-1 (f - b)| = g fitted by Levenberg-Marquardt; the largest identifiable model (>= p + 2 attitude groups, scaled-Jacobian condition number <= 100) reduced by backward elimination, each group kept only if leave-one-attitude-group-out lowers the held-out | |f| - g | error by more than its noise (z-test at alpha = 0.001 / groups in the model) and changes the corrected specific force by at least 1 LSB";

/// Longest motion between two still stretches that the gyro fit integrates, s: the gyro bias
/// is taken from the flanking stretches, and its drift over a longer motion would be read as
/// scale or misalignment.
const MAX_INTERVAL_S: f64 = 30.0;

/// The largest LSB of the three accelerometer axes over the still samples (None: none visibly
/// quantised, or too few samples).
fn accel_lsb(ch: &Channels, ranges: &[(usize, usize)]) -> Option<f64> {
    (3..6)
        .filter_map(|c| {
            let x: Vec<f64> = ranges
                .iter()
                .flat_map(|&(s, n)| ch.values[c][s..s + n].iter().copied())
                .collect();
            quantisation(&x).ok().and_then(|q| q.lsb)
        })
        .reduce(f64::max)
}

/// Run `calibrate` on `log` and write its outputs.
pub fn calibrate(log: &super::Recording, o: &CalibrateOptions) -> Result<CalibrateReport> {
    ensure!(
        o.gravity_m_s2 > 9.7 && o.gravity_m_s2 < 9.9,
        "--gravity must be in (9.7, 9.9) m/s² (got {})",
        o.gravity_m_s2
    );
    let span = o.to_s.map(|t| t - o.from_s);
    ensure!(
        span.is_none_or(|s| s > 0.0),
        "--to-s must be after --from-s"
    );
    // A --gnss file that cannot be opened is a mistake in the command, said before any work
    // (it was once a line in a report that exited 0: a script never knew).
    if let Some(p) = &o.gnss {
        std::fs::File::open(p).with_context(|| format!("--gnss {}", p.display()))?;
    }
    // Held by channel (64 bytes a sample, not a `Sample`'s 136): a long log fits.
    let (rate, ch) = load_channels_to(log, o.from_s, span)?;
    let (present, left_out) = present_channels_of(log, &ch, &[3, 4, 5])?;
    ensure!(
        present.len() == 3,
        "{}: calibration needs all three accelerometer axes ({})",
        log.display(),
        left_out
            .iter()
            .map(|(n, why)| format!("{n}: {why}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    let still = StillSettings::default();
    let stretches = still_stretches(&ch, rate, &still);
    let ranges: Vec<(usize, usize)> = stretches.iter().map(|s| (s.start, s.len)).collect();
    let lsb = accel_lsb(&ch, &ranges);
    let settings = CalibSettings {
        gravity_m_s2: o.gravity_m_s2,
        group_deg: still.group_deg,
        ..CalibSettings::default()
    };
    let accel = calibrate_accel(stretches, lsb, &settings)
        .with_context(|| format!("{}: calibration fit", log.display()))?;
    let (gyro, gyro_skipped) = if ch.absent_in[..3].iter().any(|&n| n > 0) {
        (
            None,
            Some("the log has no (or not every) gyro channel".to_string()),
        )
    } else {
        let ivs = gyro_intervals(
            &ch,
            &accel.stretches,
            accel.fitted.as_ref(),
            rate,
            MAX_INTERVAL_S,
            still.group_deg,
        );
        let g = calibrate_gyro(ivs, settings.alpha, settings.max_condition)
            .with_context(|| format!("{}: gyro calibration fit", log.display()))?;
        (Some(g), None)
    };
    let (course, course_skipped) = match &o.gnss {
        None => (None, None),
        Some(p) => match course_from(&ch, p) {
            Ok(c) => (Some(c), None),
            Err(why) => (None, Some(why)),
        },
    };
    let source = format!(
        "{} [{} s .. +{:.1} s at {rate} Hz]",
        log.display(),
        o.from_s,
        ch.len() as f64 / rate
    );
    let mut report = CalibrateReport {
        source,
        rate_hz: rate,
        method: METHOD,
        accel,
        gyro,
        gyro_skipped,
        course,
        course_skipped,
        config_file: None,
    };
    std::fs::create_dir_all(&o.out_dir)
        .with_context(|| format!("creating {}", o.out_dir.display()))?;
    if let Some(toml) = config_toml(&report) {
        let p = o.out_dir.join("calibration.toml");
        std::fs::write(&p, toml).with_context(|| format!("writing {}", p.display()))?;
        report.config_file = Some(p);
    }
    let txt = o.out_dir.join("report.txt");
    std::fs::write(&txt, report.to_text()).with_context(|| format!("writing {}", txt.display()))?;
    let json = o.out_dir.join("report.json");
    std::fs::write(&json, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("writing {}", json.display()))?;
    Ok(report)
}

/// The course fit of the samples of `ch` against the `.pos` file at `path` (Err: why there is
/// none).
fn course_from(ch: &Channels, path: &Path) -> std::result::Result<CourseScale, String> {
    let epochs = crate::nav::pos::read(path).map_err(|e| e.to_string())?;
    let gnss: Vec<CourseEpoch> = epochs
        .iter()
        .map(|e| CourseEpoch {
            t: e.t,
            v_ne: e.sdv.map(|_| [e.v_neu[0], e.v_neu[1]]),
        })
        .collect();
    let t: Vec<f64> = (0..ch.len()).map(|i| ch.t_s(i)).collect();
    let gyro: Vec<[f64; 3]> = (0..ch.len()).map(|i| ch.gyro(i).into()).collect();
    let accel: Vec<[f64; 3]> = (0..ch.len()).map(|i| ch.accel(i).into()).collect();
    course_scale(&t, &gyro, &accel, &gnss, &CourseSettings::default())
        .map_err(|e| format!("{}: {e}", path.display()))
}

fn vec3(v: &[f64; 3]) -> String {
    format!("[{:.9}, {:.9}, {:.9}]", v[0], v[1], v[2])
}

/// The `[bias.settings.accel]` and `[bias.settings.gyro]` sections of what was kept (None:
/// nothing kept).
pub fn config_toml(r: &CalibrateReport) -> Option<String> {
    let a = &r.accel;
    let gyro = r
        .gyro
        .as_ref()
        .and_then(|g| g.fitted.as_ref().map(|f| (g, f)));
    if a.fitted.is_none() && gyro.is_none() {
        return None;
    }
    let mut o = format!(
        "# imuprep calibrate {}\n# Use as `--config` (it changes only these keys) or copy the sections into your config.\n",
        r.source
    );
    let matrix = |m: &[[f64; 3]; 3]| format!("[{}, {}, {}]", vec3(&m[0]), vec3(&m[1]), vec3(&m[2]));
    if let Some(f) = &a.fitted {
        let s = &f.settings;
        let _ = write!(
            o,
            "\n# accelerometer, kept: {}; held-out RMS of |f| - g {:.4e} -> {:.4e} m/s² over {} attitude groups (g = {} m/s²)\n\
             [bias.settings.accel]\nbias = {}\nscale = {}\nmisalignment = {}\n",
            f.groups.join(" + "),
            a.held_out_rms_before_m_s2,
            a.held_out_rms_after_m_s2,
            a.spread.groups,
            a.gravity_m_s2,
            vec3(&s.bias),
            vec3(&s.scale),
            matrix(&s.misalignment),
        );
    }
    if let Some((g, f)) = gyro {
        let _ = write!(
            o,
            "\n# gyroscope, kept: {}; held-out RMS direction error {:.4e} -> {:.4e} rad over {} motions\n\
             # (no bias: the bias stage estimates it online)\n[bias.settings.gyro]\nscale = {}\nmisalignment = {}\n",
            f.groups.join(" + "),
            g.held_out_rms_before_rad,
            g.held_out_rms_after_rad,
            g.intervals.len(),
            vec3(&f.settings.scale),
            matrix(&f.settings.misalignment),
        );
    }
    Some(o)
}

impl CalibrateReport {
    /// The text report.
    pub fn to_text(&self) -> String {
        let a = &self.accel;
        let sp = &a.spread;
        let mut o = format!("calibrate: {}\nmethod: {}\n\n", self.source, self.method);
        let total_s = a
            .stretches
            .iter()
            .fold(0.0, |t, s| t + s.duration_s(self.rate_hz));
        let _ = writeln!(
            o,
            "still stretches: {} ({total_s:.1} s), attitude groups: {}, direction scatter eigenvalues {:.3} / {:.3} / {:.3} (1/3 each = all directions), largest angle from the mean direction {:.1}°",
            sp.stretches,
            sp.groups,
            sp.scatter_eigenvalues[0],
            sp.scatter_eigenvalues[1],
            sp.scatter_eigenvalues[2],
            sp.max_angle_from_mean_deg
        );
        let _ = writeln!(
            o,
            "accelerometer LSB: {}",
            a.lsb_m_s2
                .map_or("not quantised (or not visibly)".into(), |q| format!(
                    "{q:.3e} m/s²"
                ))
        );
        if !a.stretches.is_empty() {
            let _ = writeln!(
                o,
                "\n  #   t0 s   dur s  group  mean f x, y, z (m/s²)          |f|-g before   after"
            );
        }
        for (k, s) in a.stretches.iter().enumerate() {
            let m = s.mean_m_s2;
            let _ = writeln!(
                o,
                "{k:>3} {:>7.1} {:>7.1} {:>6}  {:>8.4} {:>8.4} {:>8.4}   {:>+12.4e} {:>+10.3e}",
                s.t0_s,
                s.duration_s(self.rate_hz),
                a.groups[k],
                m[0],
                m[1],
                m[2],
                a.residual_before_m_s2[k],
                a.residual_after_m_s2[k]
            );
        }
        tests_text(&mut o, &a.not_identifiable, &a.candidates);
        let _ = writeln!(o, "\nresult: {}", a.verdict);
        if a.held_out_rms_before_m_s2.is_finite() && a.fit_rms_before_m_s2.is_finite() {
            let _ = writeln!(
                o,
                "held-out RMS of |f| - g (per attitude group, leave-one-group-out): {:.4e} -> {:.4e} m/s²; in-sample over the stretches: {:.4e} -> {:.4e} m/s²",
                a.held_out_rms_before_m_s2,
                a.held_out_rms_after_m_s2,
                a.fit_rms_before_m_s2,
                a.fit_rms_after_m_s2
            );
        } else {
            // No still stretch: there is no |f| - g to take an RMS of (it once printed NaN).
            let _ = writeln!(
                o,
                "held-out RMS of |f| - g: not computed (no still stretch)"
            );
        }
        if let Some(f) = &a.fitted {
            let s = &f.settings;
            let has = |g: &str| f.groups.iter().any(|k| k == g);
            for (i, ax) in ["x", "y", "z"].iter().enumerate() {
                let mut line = format!("  {ax}:");
                if has("bias") {
                    let _ = write!(
                        line,
                        " bias {:+.4e} ± {:.1e} m/s²",
                        s.bias[i], f.bias_sd_m_s2[i]
                    );
                }
                if has("scale") {
                    let _ = write!(
                        line,
                        " scale {:.6} ± {:.1e} ({:+.0} ppm)",
                        s.scale[i],
                        f.scale_sd[i],
                        (s.scale[i] - 1.0) * 1e6
                    );
                }
                let _ = writeln!(o, "{line}");
            }
            if has("misalignment") {
                let m = f.misalignment_mrad;
                let sd = f.misalignment_sd_rad.map(|v| v * 1e3);
                let _ = writeln!(
                    o,
                    "  misalignment (N, body frame = the accelerometer's x axis and x-y plane): yx {:+.3} ± {:.2}, zx {:+.3} ± {:.2}, zy {:+.3} ± {:.2} mrad",
                    m[0], sd[0], m[1], sd[1], m[2], sd[2]
                );
            }
        }
        match (&self.gyro, &self.gyro_skipped) {
            (Some(g), _) => gyro_text(&mut o, g),
            (None, Some(why)) => {
                let _ = writeln!(o, "\ngyroscope: skipped ({why})");
            }
            _ => {}
        }
        course_text(&mut o, self.course.as_ref(), self.course_skipped.as_deref());
        match &self.config_file {
            Some(p) => {
                let _ = writeln!(o, "config: {}", p.display());
            }
            None => {
                let _ = writeln!(o, "config: none written (nothing kept)");
            }
        }
        o
    }
}

/// The `--gnss` section: the gyro's scale about the vertical from the turns.
fn course_text(o: &mut String, c: Option<&CourseScale>, skipped: Option<&str>) {
    if let Some(why) = skipped {
        let _ = writeln!(o, "\ngyro scale about the vertical from GNSS course: {why}");
    }
    let Some(c) = c else { return };
    let u = c.up_body;
    let _ = writeln!(
        o,
        "\ngyro scale about the vertical from GNSS course: {} segments between straight moments ({} turning > 20°, largest {:.0}°), vertical in body axes [{:.4}, {:.4}, {:.4}]\n  scale error {:+.4} % ± {:.4} % (z = {:.2}, p = {:.2e}): {}\n  bias about the vertical {:+.4} ± {:.4} °/s; residual sd of a segment's course change {:.3}°\n  (a finding, not written: a scale about the vertical mixes the axes' scale and misalignment)",
        c.segments,
        c.turns,
        c.largest_turn_deg,
        u[0],
        u[1],
        u[2],
        100.0 * c.scale_error,
        100.0 * c.scale_error_sd,
        c.z,
        c.p_value,
        if c.significant {
            format!("significant at α = {}", c.alpha)
        } else {
            format!("not significant at α = {} — no scale error seen", c.alpha)
        },
        c.bias_rad_s.to_degrees(),
        c.bias_sd_rad_s.to_degrees(),
        c.residual_sd_rad.to_degrees()
    );
}

/// The models refused as not identifiable and the elimination's tests.
fn tests_text(o: &mut String, not_identifiable: &[NotIdentifiable], candidates: &[Candidate]) {
    for n in not_identifiable {
        let _ = writeln!(
            o,
            "not identifiable: [{}] ({} parameters): {}",
            n.model, n.parameters, n.reason
        );
    }
    for c in candidates {
        let t = &c.test;
        let effect = if c.effect_m_s2.is_finite() {
            format!(", effect {:.3e} m/s²", c.effect_m_s2)
        } else {
            String::new()
        };
        let _ = writeln!(
            o,
            "round {}: {:<12} held-out MSE {:.3e} -> {:.3e} (without -> with), z = {:.2}, p = {:.2e} (level {:.2e}){effect}: {}{}",
            c.round,
            c.group,
            t.mse_before,
            t.mse_after,
            t.z,
            t.p_value,
            t.level,
            if c.passed { "passes" } else { "fails" },
            if c.removed {
                format!(" — removed ({})", c.reason)
            } else if c.passed {
                String::new()
            } else {
                format!(" ({})", c.reason)
            }
        );
    }
}

/// The gyroscope section of the text report.
fn gyro_text(o: &mut String, g: &GyroCalibration) {
    let mut tilts: Vec<f64> = g.intervals.iter().map(|i| i.tilt_change_deg).collect();
    tilts.sort_by(f64::total_cmp);
    let _ = writeln!(
        o,
        "\ngyroscope: {} motion(s) between consecutive still stretches at different attitudes (at most {MAX_INTERVAL_S} s, no gap){}",
        g.intervals.len(),
        if tilts.is_empty() {
            String::new()
        } else {
            format!(
                ", gravity direction change {:.1}° .. {:.1}° (median {:.1}°)",
                tilts[0],
                tilts[tilts.len() - 1],
                tilts[tilts.len() / 2]
            )
        }
    );
    if !g.candidates.is_empty() {
        let _ = writeln!(
            o,
            "(held-out test on each left-out motion's two in-plane residual components, whitened by the fit's noise model: MSE in units of the modelled variance)"
        );
    }
    tests_text(o, &g.not_identifiable, &g.candidates);
    let _ = writeln!(o, "result (gyro): {}", g.verdict);
    if g.intervals.is_empty() {
        let _ = writeln!(
            o,
            "held-out RMS direction error: not computed (no motion between attitudes)"
        );
    } else {
        let _ = writeln!(
            o,
            "held-out RMS direction error (leave-one-motion-out, per in-plane component): {:.4e} -> {:.4e} rad; whitened by their modelled covariance (noise, accelerometer frame error, refit error: what the test compares, ≈ 1 when only noise is left): {:.3} -> {:.3}",
            g.held_out_rms_before_rad,
            g.held_out_rms_after_rad,
            g.held_out_white_rms_before,
            g.held_out_white_rms_after
        );
    }
    if let Some(f) = &g.fitted {
        let s = &f.settings;
        let sd = f.k_sd;
        let _ = writeln!(
            o,
            "  scale {:.6} / {:.6} / {:.6} (± {:.1e} / {:.1e} / {:.1e})",
            s.scale[0], s.scale[1], s.scale[2], sd[0], sd[4], sd[8]
        );
        let n = s.misalignment;
        let _ = writeln!(
            o,
            "  misalignment N (mrad, relative to the accelerometer frame): xy {:+.2} xz {:+.2} yx {:+.2} yz {:+.2} zx {:+.2} zy {:+.2} (± {:.2} .. {:.2})",
            n[0][1] * 1e3,
            n[0][2] * 1e3,
            n[1][0] * 1e3,
            n[1][2] * 1e3,
            n[2][0] * 1e3,
            n[2][1] * 1e3,
            [sd[1], sd[2], sd[3], sd[5], sd[6], sd[7]]
                .iter()
                .fold(f64::INFINITY, |a, b| a.min(*b))
                * 1e3,
            [sd[1], sd[2], sd[3], sd[5], sd[6], sd[7]]
                .iter()
                .fold(0.0, |a: f64, b| a.max(*b))
                * 1e3,
        );
        let _ = writeln!(
            o,
            "  (σ by generalised least squares over the modelled noise of the motions, whose consecutive pairs share a still stretch; whitened residual variance {:.2}, ≈ 1 when that model is right; plus the accelerometer calibration's error)",
            f.noise_ratio
        );
    }
}
