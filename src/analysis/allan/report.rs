//! `imuprep allan`: per channel, the overlapping Allan deviation at octave τ with Greenhall–Riley
//! confidence bands ([`crate::analysis::allan`], [`crate::stats::allan_edf`]) and the IEEE-952
//! terms fitted to it ([`super::terms`]); the report a person reads and the JSON a tool reads.
//! The exports (Kalibr `imu.yaml`, GNSS_IMU config values, bias model TOML) are in
//! [`super::export`], the plot in [`super::plot`].
//!
//! The Allan variance assumes samples equally spaced at the log's declared rate; the report
//! counts time-stamp intervals that break that (gaps) so a reader can judge, but does not
//! resample (a host-time-stamped log's jitter is not a sensor gap).

use super::terms::{FitSettings, MODEL_ERROR_MAX, Resolution, Term, TermFit, fit_terms};
use super::{AllanReadings, overlapping_adev};
use crate::analysis::AnalysisError;
use crate::sample::{CHANNEL_NAMES, Channels, Sample};
use crate::stats::NumError;
use serde::Serialize;
use std::fmt;

/// Standard gravity, m/s² per g (for µg).
pub const G0_M_S2: f64 = 9.80665;

/// One channel's result.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelAllan {
    /// `gx gy gz ax ay az`.
    pub channel: String,
    /// Gyro (rad/s) or accelerometer (m/s²).
    pub gyro: bool,
    /// Mean of the channel over the log, channel unit.
    pub mean: f64,
    /// Curve, bands and terms.
    pub fit: TermFit,
    /// The older slope-line readings of the same curve (cross-check; see
    /// [`crate::analysis::allan`]).
    pub slope_line: Option<AllanReadings>,
}

/// How evenly the samples are spaced.
#[derive(Clone, Debug, Serialize)]
pub struct Timing {
    /// Median time-stamp interval, s.
    pub median_dt_s: f64,
    /// Largest interval, s.
    pub max_dt_s: f64,
    /// Intervals longer than 1.5 / rate.
    pub long_intervals: usize,
    /// Intervals ≤ 0 (time going backwards or repeated).
    pub non_increasing: usize,
    /// Last minus first time stamp, s.
    pub span_s: f64,
}

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct AllanReport {
    /// Where the samples came from.
    pub source: String,
    /// Declared sample rate, Hz (the τ grid uses it: τ = m / rate).
    pub rate_hz: f64,
    /// Samples used.
    pub n_samples: usize,
    /// `n_samples / rate_hz`, s.
    pub duration_s: f64,
    pub timing: Timing,
    /// Fit settings used.
    pub settings: FitSettings,
    /// Channels analysed.
    pub channels: Vec<ChannelAllan>,
    /// Channels asked for but not analysed, with the reason.
    pub skipped: Vec<(String, String)>,
    /// What makes the figures doubtful (a record not at rest), one line each.
    pub warnings: Vec<String>,
}

fn timing(n: usize, t_ns: impl Fn(usize) -> u64, rate_hz: f64) -> Timing {
    let mut dts: Vec<f64> = (1..n)
        .map(|i| (t_ns(i) as f64 - t_ns(i - 1) as f64) * 1e-9)
        .collect();
    let long_intervals = dts.iter().filter(|d| **d > 1.5 / rate_hz).count();
    let non_increasing = dts.iter().filter(|d| **d <= 0.0).count();
    let max_dt_s = dts.iter().copied().fold(0.0, f64::max);
    let median_dt_s = if dts.is_empty() {
        0.0
    } else {
        crate::stats::robust::upper_median(&mut dts)
    };
    let span_s = match n {
        0 => 0.0,
        _ => (t_ns(n - 1) as f64 - t_ns(0) as f64) * 1e-9,
    };
    Timing {
        median_dt_s,
        max_dt_s,
        long_intervals,
        non_increasing,
        span_s,
    }
}

/// Allan analysis of `channels` (indices into `gx gy gz ax ay az`) of `samples` at `rate_hz`.
/// A channel with a non-finite value or too short a record is listed in `skipped` with the
/// reason; the others are analysed.
pub fn allan_report(
    source: &str,
    samples: &[Sample],
    rate_hz: f64,
    channels: &[usize],
    settings: &FitSettings,
) -> Result<AllanReport, AnalysisError> {
    let series = Series {
        n: samples.len(),
        t_ns: &|i| samples[i].t_ns,
        fill: &|c, y| {
            for (v, s) in y.iter_mut().zip(samples) {
                *v = s.channel(c);
            }
        },
    };
    report_of(source, &series, rate_hz, channels, settings)
}

/// [`allan_report`] of a recording held by channel.
pub fn allan_report_of(
    source: &str,
    ch: &Channels,
    rate_hz: f64,
    channels: &[usize],
    settings: &FitSettings,
) -> Result<AllanReport, AnalysisError> {
    let series = Series {
        n: ch.len(),
        t_ns: &|i| ch.t_ns[i],
        fill: &|c, y| y.copy_from_slice(&ch.values[c]),
    };
    report_of(source, &series, rate_hz, channels, settings)
}

/// What the report reads of a recording: `n` samples, sample `i`'s time stamp, and channel
/// `c`'s values filled into a slice of `n`.
struct Series<'a> {
    n: usize,
    t_ns: &'a dyn Fn(usize) -> u64,
    fill: &'a dyn Fn(usize, &mut [f64]),
}

fn report_of(
    source: &str,
    rec: &Series,
    rate_hz: f64,
    channels: &[usize],
    settings: &FitSettings,
) -> Result<AllanReport, AnalysisError> {
    if !(rate_hz > 0.0 && rate_hz.is_finite()) {
        return Err(AnalysisError::bad("allan: the sample rate must be > 0"));
    }
    if rec.n < 16 {
        return Err(NumError::TooShort {
            needed: 16,
            got: rec.n,
        }
        .into());
    }
    let mut out = AllanReport {
        source: source.to_string(),
        rate_hz,
        n_samples: rec.n,
        duration_s: rec.n as f64 / rate_hz,
        timing: timing(rec.n, rec.t_ns, rate_hz),
        settings: settings.clone(),
        channels: Vec::new(),
        skipped: Vec::new(),
        warnings: Vec::new(),
    };
    let mut y = vec![0.0; rec.n];
    // A long record's channels take a while (0.2 s each for 3.6 M samples): a bar after 1 s.
    let mut bar = crate::progress::Delayed::steps(channels.len() as u64, "channels");
    for &c in channels {
        bar.inc(1);
        let name = CHANNEL_NAMES
            .get(c)
            .ok_or(AnalysisError::bad("allan: channel index"))?;
        (rec.fill)(c, &mut y);
        let bad = y.iter().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            out.skipped.push((
                name.to_string(),
                format!("{bad} non-finite samples: the Allan deviation needs a gap-free series"),
            ));
            continue;
        }
        if y.iter().all(|v| *v == y[0]) {
            out.skipped.push((
                name.to_string(),
                "constant: every sample is the same value (a stuck or absent axis)".to_string(),
            ));
            continue;
        }
        let curve = overlapping_adev(&y, rate_hz);
        match fit_terms(&curve, rate_hz, y.len(), settings) {
            Ok(fit) => out.channels.push(ChannelAllan {
                channel: name.to_string(),
                gyro: c < 3,
                mean: y.iter().sum::<f64>() / y.len() as f64,
                fit,
                slope_line: curve.readings(),
            }),
            Err(e) => out.skipped.push((name.to_string(), e.to_string())),
        }
    }
    Ok(out)
}

/// Conventional display unit of a term: (factor from SI, unit) for gyro or accelerometer.
pub fn display_unit(term: Term, gyro: bool) -> (f64, &'static str) {
    let deg = 180.0 / std::f64::consts::PI;
    let ug = 1.0 / (G0_M_S2 * 1e-6);
    match (term, gyro) {
        (Term::Quantisation, true) => (deg * 3600.0, "arcsec"),
        (Term::RandomWalk, true) => (deg * 60.0, "deg/sqrt(h)"),
        (Term::BiasInstability, true) => (deg * 3600.0, "deg/h"),
        (Term::RateRandomWalk, true) => (deg * 3600.0 * 60.0, "deg/h/sqrt(h)"),
        (Term::RateRamp, true) => (deg * 3600.0 * 3600.0, "deg/h^2"),
        (Term::Quantisation, false) => (1e3, "mm/s"),
        (Term::RandomWalk, false) => (ug, "ug/sqrt(Hz)"),
        (Term::BiasInstability, false) => (ug, "ug"),
        (Term::RateRandomWalk, false) => (ug, "ug/sqrt(s)"),
        (Term::RateRamp, false) => (ug, "ug/s"),
    }
}

/// SI unit of a term's coefficient.
pub fn si_unit(term: Term, gyro: bool) -> &'static str {
    match (term, gyro) {
        (Term::Quantisation, true) => "rad",
        (Term::RandomWalk, true) => "rad/sqrt(s)",
        (Term::BiasInstability, true) => "rad/s",
        (Term::RateRandomWalk, true) => "rad/s/sqrt(s)",
        (Term::RateRamp, true) => "rad/s^2",
        (Term::Quantisation, false) => "m/s",
        (Term::RandomWalk, false) => "m/s/sqrt(s)",
        (Term::BiasInstability, false) => "m/s^2",
        (Term::RateRandomWalk, false) => "m/s^2/sqrt(s)",
        (Term::RateRamp, false) => "m/s^3",
    }
}

fn term_name(t: Term, gyro: bool) -> &'static str {
    match (t, gyro) {
        (Term::Quantisation, _) => "quantisation",
        (Term::RandomWalk, true) => "angle random walk",
        (Term::RandomWalk, false) => "velocity random walk",
        (Term::BiasInstability, _) => "bias instability",
        (Term::RateRandomWalk, _) => "rate random walk",
        (Term::RateRamp, _) => "rate ramp",
    }
}

/// The model-error floor ε for people: a percentage, or, at the top of the range searched
/// ([`MODEL_ERROR_MAX`]: the floor is not found below it), that the IEEE model does not describe
/// the curve — the bound is not a measured value.
fn model_error_text(eps: f64) -> String {
    if eps >= 0.999 * MODEL_ERROR_MAX {
        format!(
            "above {:.0} % (the most searched: the IEEE model does not describe this curve; a record not at rest?)",
            100.0 * MODEL_ERROR_MAX
        )
    } else {
        format!("{:.1} %", 100.0 * eps)
    }
}

impl fmt::Display for AllanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "Allan deviation of {}: {} samples, {:.1} s at {:.4} Hz",
            self.source, self.n_samples, self.duration_s, self.rate_hz
        )?;
        let t = &self.timing;
        writeln!(
            f,
            "time stamps: median interval {:.4} s, largest {:.4} s, {} longer than 1.5/rate, {} not increasing \
             (the analysis takes the samples as equally spaced at the declared rate)",
            t.median_dt_s, t.max_dt_s, t.long_intervals, t.non_increasing
        )?;
        for w in &self.warnings {
            writeln!(f, "WARNING: {w}")?;
        }
        writeln!(
            f,
            "terms: weighted non-negative least squares of sigma^2(tau) = 3Q^2/tau^2 + N^2/tau + (2ln2/pi)B^2 + K^2 tau/3 + R^2 tau^2/2,\n\
             \x20      weights from Greenhall-Riley EDFs of the dominant noise type; bands: chi-squared, {:.1} %",
            100.0 * self.settings.confidence
        )?;
        for ch in &self.channels {
            let fit = &ch.fit;
            let (t0, t1) = (
                fit.points.first().map_or(0.0, |p| p.tau_s),
                fit.points.last().map_or(0.0, |p| p.tau_s),
            );
            writeln!(
                f,
                "\n{} ({}): {} taus {:.3}..{} s; {} passes{}; model error floor {}",
                ch.channel,
                if ch.gyro { "rad/s" } else { "m/s^2" },
                fit.points.len(),
                t0,
                // Whole seconds from 10 s up; below, a short record's 0.04 s must not read "0".
                if t1 < 10.0 {
                    format!("{t1:.3}")
                } else {
                    format!("{t1:.0}")
                },
                fit.passes,
                if fit.converged {
                    ""
                } else {
                    " (not converged)"
                },
                model_error_text(fit.model_error)
            )?;
            for tr in &fit.terms {
                let (k, du) = display_unit(tr.term, ch.gyro);
                let su = si_unit(tr.term, ch.gyro);
                let head = format!("  {} {:<21}", tr.term.letter(), term_name(tr.term, ch.gyro));
                match tr.resolution {
                    Resolution::Resolved => {
                        let rel = tr.std_error.map_or(String::new(), |s| {
                            format!(" +-{:.1} %", 100.0 * s / tr.coefficient)
                        });
                        let dom = tr.dominant_tau_s.map_or(String::new(), |[a, b]| {
                            format!("  largest at tau {a:.3}..{b:.3} s")
                        });
                        writeln!(
                            f,
                            "{head} {:.4e} {su}{rel} ({:.4} {du}){dom}",
                            tr.coefficient,
                            tr.coefficient * k
                        )?;
                    }
                    r => {
                        let why = match r {
                            Resolution::FittedZero => "fitted to zero",
                            Resolution::NeverDominant => {
                                "masked: another term is larger at every tau"
                            }
                            _ => "not significant (< min_z standard errors)",
                        };
                        writeln!(
                            f,
                            "{head} not resolved: {why}; <= {:.3e} {su} ({:.4} {du})",
                            tr.upper_bound,
                            tr.upper_bound * k
                        )?;
                    }
                }
            }
        }
        for (c, why) in &self.skipped {
            writeln!(f, "\n{c}: skipped: {why}")?;
        }
        Ok(())
    }
}
