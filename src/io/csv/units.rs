//! Units a CSV header does not state, checked against the data, never silently assumed.
//!
//! * **Accelerometer**: the median norm of the triad (rows with all three axes) is near 1 g for
//!   any recording on Earth, static or moving (a car, a walker, a bench: the median of |f| is
//!   gravity's, the dynamics are the tails). Read as g it lies in [`ACCEL_G_BAND`] (0.5–2), read
//!   as m/s² in [`ACCEL_MS2_BAND`] (5–20), as mg in [`ACCEL_MG_BAND`] (500–2000): a factor 2.5
//!   or more apart, so one reading, never two. A median of 2 g would need a sustained 1.7 g of
//!   horizontal acceleration; one of 0.5 g a sustained fall.
//! * **Gyro** (rad/s, deg/s or mdeg/s), strongest evidence first: (1) |ω| beyond
//!   [`GYRO_MAX_RAD_S`] (35 rad/s = 2000 °/s, the top of common MEMS ranges) in at least
//!   [`GYRO_OVER_FRACTION`] of the samples (a few spikes cannot decide it) can only be deg/s, or
//!   mdeg/s where (2) says so; (2) the rotation of the measured gravity direction `u` must agree
//!   with the integrated gyro: over short windows at low dynamics `Δu ≈ −(∫ω dt) × u`, and the
//!   least-squares scale `k` of the gyro's prediction is 1 for rad/s, π/180 for deg/s, π/180 000
//!   for mdeg/s ([`TiltFit`]). It counts only with enough tilting rotation (measured by the
//!   accelerometer, so it does not depend on the gyro's unit) and a fit that explains at least
//!   half of the measured tilt (R² ≥ [`TILT_MIN_R2`]); a static bench, a file without
//!   accelerometer or a car that never tilts leave it undecided. At rest, deg/s and mdeg/s are
//!   not told apart: (1) says deg/s and a warning names the other reading.
//! * **Time**: a seconds reading whose median interval gives a rate outside [`TIME_RATE_HZ`]
//!   (2 Hz–100 kHz) is no IMU; ms, µs, ns are tried in that order and the first in the band
//!   taken.

use super::columns::NameUnit;
use super::{AccelUnit, GyroUnit};
use crate::sample::Sample;
use crate::stats::robust::median;

/// Median |f| of a triad in g.
pub const ACCEL_G_BAND: (f64, f64) = (0.5, 2.0);
/// Median |f| of a triad in m/s².
pub const ACCEL_MS2_BAND: (f64, f64) = (5.0, 20.0);
/// Median |f| of a triad in mg.
pub const ACCEL_MG_BAND: (f64, f64) = (500.0, 2000.0);
/// Beyond any common MEMS gyro range read as rad/s (2000 °/s = 34.9 rad/s).
pub const GYRO_MAX_RAD_S: f64 = 35.0;
/// Fraction of samples beyond [`GYRO_MAX_RAD_S`] that makes the rad/s reading impossible.
pub const GYRO_OVER_FRACTION: f64 = 1e-3;
/// Plausible IMU rates, Hz.
pub const TIME_RATE_HZ: (f64, f64) = (2.0, 1e5);
/// Tilt windows: length, and the blocks at each end whose mean accel gives the direction, s.
pub const TILT_WINDOW_S: f64 = 0.3;
pub const TILT_END_BLOCK_S: f64 = 0.05;
/// Low dynamics: the end blocks' |f| within 5 % of the median |f|, every sample within 15 %.
pub const TILT_END_TOL: f64 = 0.05;
pub const TILT_INSIDE_TOL: f64 = 0.15;
/// A window counts when gravity's direction turned by at least this much, degrees.
pub const TILT_MIN_DEG: f64 = 2.0;
/// Evidence counts from this many windows and this much tilt in all, rad (≈ 29°).
pub const TILT_MIN_WINDOWS: usize = 5;
pub const TILT_MIN_TOTAL_RAD: f64 = 0.5;
/// The fit must explain at least this share of the measured tilt.
pub const TILT_MIN_R2: f64 = 0.5;
/// The fitted scale must lie within this factor of 1 (rad/s) or π/180 (deg/s).
pub const TILT_SCALE_FACTOR: f64 = 2.0;
/// A gyro whose rad/s reading predicts an RMS turn of gravity's direction this many times the
/// measured one is not in rad/s (a gyro bias would have to be ~30 °/s to do it), whatever the
/// fit's R² (a car's or a walker's linear accelerations turn the measured direction too, which
/// lowers R² and the ratio, never raises them).
pub const TILT_RMS_NOT_RAD: f64 = 5.0;

const DEG: f64 = std::f64::consts::PI / 180.0;

/// The median norm of the accelerometer triad over the rows with all three axes finite.
pub fn accel_median_norm(samples: &[Sample]) -> Option<(f64, usize)> {
    let mut n: Vec<f64> = samples
        .iter()
        .map(|s| s.accel.norm())
        .filter(|x| x.is_finite())
        .collect();
    (!n.is_empty()).then(|| (median(&mut n), n.len()))
}

/// The accel unit a median norm means: `None` outside both bands.
pub fn accel_unit_of_norm(m: f64) -> Option<AccelUnit> {
    let within = |b: (f64, f64)| m >= b.0 && m <= b.1;
    if within(ACCEL_G_BAND) {
        Some(AccelUnit::G)
    } else if within(ACCEL_MS2_BAND) {
        Some(AccelUnit::MS2)
    } else if within(ACCEL_MG_BAND) {
        Some(AccelUnit::MilliG)
    } else {
        None
    }
}

/// The gravity-direction fit of the gyro's scale (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltFit {
    /// Windows at low dynamics with at least [`TILT_MIN_DEG`] of tilt.
    pub windows: usize,
    /// Their tilt in all (measured by the accelerometer), rad.
    pub tilt_rad: f64,
    /// Least-squares scale k of `Δu ≈ k·(−θ × u)`, θ the integral of the gyro as read.
    pub scale: f64,
    /// Share of Σ|Δu|² the fit explains.
    pub r2: f64,
    /// RMS of the turn the gyro predicts as read over the RMS of the turn measured, `√(Σ|b|²/Σ|Δu|²)`.
    pub rms_ratio: f64,
}

impl TiltFit {
    /// Enough tilting rotation for the fit to count.
    pub fn enough(&self) -> bool {
        self.windows >= TILT_MIN_WINDOWS && self.tilt_rad >= TILT_MIN_TOTAL_RAD
    }

    /// The unit the fit says, when it says one.
    pub fn unit(&self) -> Option<GyroUnit> {
        if !self.enough() {
            return None;
        }
        let near = |target: f64| (self.scale / target).ln().abs() <= TILT_SCALE_FACTOR.ln();
        if self.r2 >= TILT_MIN_R2 && near(1.0) {
            Some(GyroUnit::RadS)
        } else if self.r2 >= TILT_MIN_R2 && near(DEG) {
            Some(GyroUnit::DegS)
        } else if self.r2 >= TILT_MIN_R2 && near(DEG * 1e-3) {
            Some(GyroUnit::MilliDegS)
        } else if self.rms_ratio >= TILT_RMS_NOT_RAD && self.rms_ratio * DEG <= TILT_RMS_NOT_RAD {
            // Read as rad/s the gyro turns gravity's direction several times more than it
            // turned: whatever else moved the accelerometer (linear acceleration only adds to
            // the measured turn), rad/s is impossible, and deg/s gives a turn of the right size.
            Some(GyroUnit::DegS)
        } else {
            None
        }
    }
}

/// What the data say of the gyro's unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroEvidence {
    /// Samples with all three gyro axes finite.
    pub n: usize,
    /// Of them beyond [`GYRO_MAX_RAD_S`] as read.
    pub over: usize,
    /// The largest |ω| as read.
    pub max: f64,
    pub tilt: Option<TiltFit>,
}

impl GyroEvidence {
    /// The unit the data say, strongest evidence first; `None`: they cannot tell.
    pub fn unit(&self) -> Option<GyroUnit> {
        let tilt = self.tilt.and_then(|t| t.unit());
        if self.over_range() {
            // Not rad/s; mdeg/s only where gravity's turning says so (it runs past 35 at 35 mdeg/s).
            return Some(
                tilt.filter(|u| *u == GyroUnit::MilliDegS)
                    .unwrap_or(GyroUnit::DegS),
            );
        }
        tilt
    }

    /// Read as deg/s by the range alone while most samples lie beyond it and the tilt fit
    /// says nothing: a deg/s gyro turning above 35 °/s most of the time, or an mdeg/s one at
    /// rest — worth a warning, not a guess.
    fn maybe_milli(&self, decided: GyroUnit) -> bool {
        decided == GyroUnit::DegS
            && self.over_range()
            && 2 * self.over > self.n
            && self.tilt.and_then(|t| t.unit()).is_none()
    }

    fn over_range(&self) -> bool {
        self.n > 0 && self.over as f64 >= GYRO_OVER_FRACTION * self.n as f64
    }

    /// The evidence in words.
    pub fn describe(&self) -> String {
        if self.over_range() {
            return format!(
                "|ω| beyond {GYRO_MAX_RAD_S} as read in {} of {} samples (max {:.1}), beyond any MEMS range in rad/s",
                self.over, self.n, self.max
            );
        }
        let head = format!("max |ω| {:.3} as read", self.max);
        match self.tilt {
            None => format!("{head}; no accelerometer triad to compare the rotation with"),
            Some(t) if !t.enough() => format!(
                "{head}; too little tilting rotation to compare with the accelerometer ({} windows, {:.1}° in all; needs {} and {:.0}°)",
                t.windows,
                t.tilt_rad.to_degrees(),
                TILT_MIN_WINDOWS,
                TILT_MIN_TOTAL_RAD.to_degrees()
            ),
            Some(t) => format!(
                "{head}; gravity's direction turns with the integrated gyro at scale {} (1 for rad/s, {} for deg/s; R² {:.2}), the gyro as read predicting {}× the measured turn (RMS), over {} windows with {:.0}° of tilt",
                num(t.scale),
                num(DEG),
                t.r2,
                num(t.rms_ratio),
                t.windows,
                t.tilt_rad.to_degrees()
            ),
        }
    }
}

/// The gyro's evidence: its range, and the tilt fit against the accelerometer when the triad is
/// there (`accel_median`: its median norm, any unit). `t_s`: each sample's time, s.
pub fn gyro_evidence(samples: &[Sample], t_s: &[f64], accel_median: Option<f64>) -> GyroEvidence {
    let mut n = 0;
    let mut over = 0;
    let mut max = 0.0f64;
    for s in samples {
        // Over the axes with a value (a gyro may have one or two).
        let w = s
            .gyro
            .iter()
            .filter(|x| x.is_finite())
            .map(|x| x * x)
            .sum::<f64>()
            .sqrt();
        if s.gyro.iter().any(|x| x.is_finite()) {
            n += 1;
            over += usize::from(w > GYRO_MAX_RAD_S);
            max = max.max(w);
        }
    }
    GyroEvidence {
        n,
        over,
        max,
        tilt: accel_median
            .filter(|m| *m > 0.0)
            .map(|m| tilt_fit(samples, t_s, m)),
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Fit the gyro's scale to the turning of gravity's direction (see the module docs): windows of
/// [`TILT_WINDOW_S`] every half window; each end's direction the mean accel over
/// [`TILT_END_BLOCK_S`]; the gyro integrated between the blocks' middles.
pub fn tilt_fit(samples: &[Sample], t_s: &[f64], accel_median: f64) -> TiltFit {
    let mut fit = TiltFit {
        windows: 0,
        tilt_rad: 0.0,
        scale: f64::NAN,
        r2: f64::NAN,
        rms_ratio: f64::NAN,
    };
    let n = samples.len();
    let dt = median_interval(t_s);
    if dt.is_nan() || dt <= 0.0 || n < 4 {
        return fit;
    }
    let blk = ((TILT_END_BLOCK_S / dt).round() as usize).max(1);
    let win = ((TILT_WINDOW_S / dt).round() as usize).max(2);
    let step = (win / 2).max(1);
    let rel: Vec<f64> = samples
        .iter()
        .map(|s| (s.accel.norm() / accel_median - 1.0).abs())
        .collect();
    let mean_dir = |a: usize| -> Option<[f64; 3]> {
        let mut m = [0.0; 3];
        for s in &samples[a..a + blk] {
            for (c, v) in m.iter_mut().enumerate() {
                *v += s.accel[c];
            }
        }
        let norm = dot(m, m).sqrt() / blk as f64;
        if !norm.is_finite() || (norm / accel_median - 1.0).abs() >= TILT_END_TOL {
            return None;
        }
        let l = dot(m, m).sqrt();
        Some([m[0] / l, m[1] / l, m[2] / l])
    };
    let (mut sdb, mut sbb, mut sdd) = (0.0, 0.0, 0.0);
    let mut i = 0;
    while i + win + blk <= n {
        let j = i + win;
        let quiet = rel[i..j + blk].iter().all(|r| *r < TILT_INSIDE_TOL);
        let ends = quiet.then(|| mean_dir(i).zip(mean_dir(j))).flatten();
        if let Some((u0, u1)) = ends {
            let angle = dot(u0, u1).clamp(-1.0, 1.0).acos();
            let mut th = [0.0; 3];
            let mut ok = angle >= TILT_MIN_DEG.to_radians();
            for k in i + blk / 2..j + blk / 2 {
                if !ok {
                    break;
                }
                let d = t_s[k + 1] - t_s[k];
                let w = samples[k].gyro;
                ok = d > 0.0 && d < 5.0 * dt && w.iter().all(|x| x.is_finite());
                for (c, v) in th.iter_mut().enumerate() {
                    *v += w[c] * d;
                }
            }
            if ok {
                let du = [u1[0] - u0[0], u1[1] - u0[1], u1[2] - u0[2]];
                let um = [
                    0.5 * (u0[0] + u1[0]),
                    0.5 * (u0[1] + u1[1]),
                    0.5 * (u0[2] + u1[2]),
                ];
                let c = cross(th, um);
                let b = [-c[0], -c[1], -c[2]];
                sdb += dot(du, b);
                sbb += dot(b, b);
                sdd += dot(du, du);
                fit.windows += 1;
                fit.tilt_rad += angle;
            }
        }
        i += step;
    }
    if fit.windows > 0 && sbb > 0.0 && sdd > 0.0 {
        fit.scale = sdb / sbb;
        fit.r2 = sdb * sdb / (sbb * sdd);
        fit.rms_ratio = (sbb / sdd).sqrt();
    }
    fit
}

/// How one unit of an import was decided (import's summary, and its JSON).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct UnitFinding {
    /// `gyro`, `accel` or `time`.
    pub quantity: &'static str,
    pub unit: &'static str,
    /// `option` (a flag), `name` (the column name), `convention` (canonical or ROS names, the
    /// data not telling otherwise) or `data` (inferred from the data).
    pub source: &'static str,
    /// Where it came from, with the evidence.
    pub how: String,
}

impl std::fmt::Display for UnitFinding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} unit: {} ({})", self.quantity, self.unit, self.how)
    }
}

/// A decided unit, how, and a warning when the data contradict a stated unit.
#[derive(Debug, Clone)]
pub struct Decided<U> {
    pub unit: U,
    pub finding: UnitFinding,
    pub warning: Option<String>,
}

/// The flag's spelling, as people read it too.
pub fn gyro_name(u: GyroUnit) -> &'static str {
    match u {
        GyroUnit::RadS => "rad/s",
        GyroUnit::DegS => "deg/s",
        GyroUnit::MilliDegS => "mdeg/s",
    }
}
/// As people read it; the flag's spelling is [`accel_flag`].
pub fn accel_name(u: AccelUnit) -> &'static str {
    match u {
        AccelUnit::MS2 => "m/s²",
        AccelUnit::G => "g",
        AccelUnit::MilliG => "mg",
    }
}
/// The `--accel-unit` spelling.
pub fn accel_flag(u: AccelUnit) -> &'static str {
    match u {
        AccelUnit::MS2 => "m/s2",
        AccelUnit::G => "g",
        AccelUnit::MilliG => "mg",
    }
}
/// A number for people: 4 significant digits, exponent form outside 0.001..1e6.
pub fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if x.abs() >= 1e-3 && x.abs() < 1e6 {
        let places = (3 - x.abs().log10().floor() as i64).max(0) as usize;
        crate::text::trim_decimals(x, places)
    } else {
        format!("{x:.3e}")
    }
}

/// Who stated a unit: the flag, or the column name.
fn stated_by(opt: bool, column: &str, flag: &str) -> String {
    if opt {
        flag.to_string()
    } else {
        format!("the column name {column:?}")
    }
}

/// The unit an option or the column name states: (unit, `"option"` or `"name"`, who said it).
fn stated_unit<U: Copy>(
    opt: Option<U>,
    named: &NameUnit<U>,
    flag: &str,
) -> Option<(U, &'static str, String)> {
    match (opt, named) {
        (Some(u), _) => Some((u, "option", stated_by(true, "", flag))),
        (None, NameUnit::Stated(u, col)) => Some((*u, "name", stated_by(false, col, flag))),
        _ => None,
    }
}

/// Decide the gyro unit: an option wins, then a unit in the name (both only warned about when
/// the data contradict them), then the data, then a convention; else an error asking for
/// `--gyro-unit`.
pub fn decide_gyro(
    opt: Option<GyroUnit>,
    named: &NameUnit<GyroUnit>,
    column: &str,
    ev: &GyroEvidence,
) -> Result<Decided<GyroUnit>, String> {
    let data = ev.unit();
    let finding = |u: GyroUnit, source: &'static str, how: String| UnitFinding {
        quantity: "gyro",
        unit: gyro_name(u),
        source,
        how,
    };
    if let Some((u, source, by)) = stated_unit(opt, named, "--gyro-unit") {
        let warning = data.filter(|v| *v != u).map(|v| {
            format!(
                "gyro: {by} says {}, but the data say {}: {}; if the values are in {}, pass --gyro-unit {}",
                gyro_name(u),
                gyro_name(v),
                ev.describe(),
                gyro_name(v),
                gyro_name(v)
            )
        });
        return Ok(Decided {
            unit: u,
            finding: finding(u, source, format!("stated by {by}")),
            warning,
        });
    }
    match (named, data) {
        (_, Some(v)) => Ok(Decided {
            unit: v,
            finding: finding(v, "data", format!("not stated; {}", ev.describe())),
            warning: ev.maybe_milli(v).then(|| {
                format!(
                    "gyro: read as deg/s by its range, but |ω| is beyond {GYRO_MAX_RAD_S} in {} of {} samples as read and gravity's direction tells nothing ({}): a gyro in mdeg/s reads so at rest; if so, pass --gyro-unit mdeg/s",
                    ev.over,
                    ev.n,
                    ev.tilt.map_or("no accelerometer triad".to_string(), |t| format!(
                        "{} tilt windows, {:.1}° in all",
                        t.windows,
                        t.tilt_rad.to_degrees()
                    ))
                )
            }),
        }),
        (NameUnit::Convention(u, why), None) => Ok(Decided {
            unit: *u,
            finding: finding(
                *u,
                "convention",
                format!(
                    "not stated; {why} mean {}, and the data cannot tell otherwise: {}",
                    gyro_name(*u),
                    ev.describe()
                ),
            ),
            warning: None,
        }),
        _ => Err(format!(
            "cannot tell the gyro unit from the column name {column:?} nor from the data ({}): pass --gyro-unit",
            ev.describe()
        )),
    }
}

/// Decide the accel unit from the median norm `m` of the triad over `n` rows (`None`: no full
/// triad), as [`decide_gyro`] does.
pub fn decide_accel(
    opt: Option<AccelUnit>,
    named: &NameUnit<AccelUnit>,
    column: &str,
    norm: Option<(f64, usize)>,
) -> Result<Decided<AccelUnit>, String> {
    let data = norm.map(|(m, _)| accel_unit_of_norm(m));
    let said = |u: AccelUnit| match norm {
        Some((m, n)) => format!("median |f| = {} {} over {n} samples", num(m), accel_name(u)),
        None => "no full accelerometer triad to measure |f|".to_string(),
    };
    let as_in = |v: AccelUnit| match v {
        AccelUnit::G => "≈ 1, gravity in g",
        AccelUnit::MS2 => "≈ 9.8, gravity in m/s²",
        AccelUnit::MilliG => "≈ 1000, gravity in mg",
    };
    let neither = "neither ≈ 1 g, ≈ 9.8 m/s² nor ≈ 1000 mg, as an accelerometer on Earth reads, static or moving (gravity removed? another unit?)";
    let finding = |u: AccelUnit, source: &'static str, how: String| UnitFinding {
        quantity: "accel",
        unit: accel_name(u),
        source,
        how,
    };
    if let Some((u, source, by)) = stated_unit(opt, named, "--accel-unit") {
        let warning = match data {
            Some(Some(v)) if v != u => Some(format!(
                "accel: {by} says {}, but the {}: {}; if the values are in {}, pass --accel-unit {}",
                accel_name(u),
                said(u),
                as_in(v),
                accel_name(v),
                accel_flag(v)
            )),
            Some(None) => Some(format!(
                "accel: {by} says {}, but the {}: {neither}",
                accel_name(u),
                said(u)
            )),
            _ => None,
        };
        return Ok(Decided {
            unit: u,
            finding: finding(u, source, format!("stated by {by}")),
            warning,
        });
    }
    match (named, data) {
        (_, Some(Some(v))) => Ok(Decided {
            unit: v,
            finding: finding(
                v,
                "data",
                format!(
                    "not stated; median |f| = {} over {} samples: {}",
                    num(norm.map_or(f64::NAN, |x| x.0)),
                    norm.map_or(0, |x| x.1),
                    as_in(v)
                ),
            ),
            warning: None,
        }),
        (NameUnit::Convention(u, why), d) => Ok(Decided {
            unit: *u,
            finding: finding(
                *u,
                "convention",
                format!("not stated; {why} mean {}; {}", accel_name(*u), said(*u)),
            ),
            warning: (d == Some(None)).then(|| {
                format!(
                    "accel: {why} mean {}, but the {}: {neither}; pass --accel-unit if it is another unit",
                    accel_name(*u),
                    said(*u)
                )
            }),
        }),
        (_, d) => Err(format!(
            "cannot tell the accel unit from the column name {column:?} nor from the data ({}{}): pass --accel-unit",
            norm.map_or("no full accelerometer triad".to_string(), |(m, n)| format!(
                "median |f| = {} over {n} samples",
                num(m)
            )),
            if d == Some(None) { format!(": {neither}") } else { String::new() }
        )),
    }
}

mod time;
pub use time::{decide_time, median_interval, plausible_time_unit, rate_as, time_name, unwrap_u32};

#[cfg(test)]
mod tests;
