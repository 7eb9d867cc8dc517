//! `imuprep fit`: the ARIMA model per channel (gross-error stage) and the AR bias model per
//! channel (bias stage) from one span of a recording, written as `arima.toml` and `bias.toml`.
//! A partial sensor's absent channels ([`Sample::absent`]) get no model and are named in the
//! report and in both files' header; a log with no channel present is an error.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, ensure};
use serde::Serialize;

use super::{load_span_to, present_channels};
use crate::model::arima::{ArimaModelFile, IdentifySettings, identify};
use crate::model::bias_model::{BiasModelFile, ChannelBiasModel, MAX_FILE_AR_ORDER};
use crate::model::fos::FosSettings;
use crate::model::fos_model::{FosModel, FosModelSpec};
use crate::model::{ArFit, ModelError};
use crate::sample::{CHANNEL_NAMES, N_CHANNELS, Sample};
use crate::stage::bias::stillness::{StillnessDetector, StillnessSettings};
use crate::stage::gross_error::GrossErrorStage;
use crate::stage::gross_error::identify::{hampel_cleaned, window_line};

/// How `fit` estimates the bias model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum BiasMethod {
    Burg,
    YuleWalker,
    Covariance,
    Fos,
}

impl BiasMethod {
    /// The `method` string written to the bias model file.
    pub fn file_name(self) -> &'static str {
        match self {
            BiasMethod::Burg => "burg",
            BiasMethod::YuleWalker => "yule_walker",
            BiasMethod::Covariance => "covariance",
            BiasMethod::Fos => "fos",
        }
    }

    /// The order used when none is given: 10 (the FOS paper's L) for `fos`, 64 for the AR
    /// methods (the bias stage splits the fitted spectrum into a slow bias and white noise,
    /// which a short AR cannot describe).
    pub fn default_order(self) -> usize {
        match self {
            BiasMethod::Fos => 10,
            _ => 64,
        }
    }
}

/// What to fit on.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Seconds of data used for identification (after `skip_s`).
    pub train_s: f64,
    /// Seconds skipped at the start.
    pub skip_s: f64,
    pub bias_method: BiasMethod,
    /// AR order of the bias model (for `fos`: the largest lag L).
    pub bias_order: usize,
    /// Shortest still stretch (seconds) the bias model may be fitted on.
    pub min_still_s: f64,
}

/// The longest still stretch of the training span, by the bias stage's own stillness test
/// (default settings: stillness relative to the sensor's learned noise floor).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StillStretch {
    /// First sample of the stretch (index into the training span).
    pub start: usize,
    /// Its length, samples.
    pub len: usize,
    /// Samples of the whole span judged still.
    pub still_total: usize,
}

/// The longest run of samples the stillness detector calls still.
pub fn longest_still_stretch(samples: &[Sample], rate: f64) -> StillStretch {
    let mut det = StillnessDetector::new(&StillnessSettings::default(), rate);
    let (mut best, mut run_start, mut still_total) = ((0, 0), None, 0);
    for (i, s) in samples.iter().enumerate() {
        let g = [s.gyro[0], s.gyro[1], s.gyro[2]];
        let a = [s.accel[0], s.accel[1], s.accel[2]];
        // Absent channels take no part (a gyro-only sensor's stillness is its gyros').
        if det.update_present(&g, &a, &[None; 3], s.absent) {
            still_total += 1;
            let start = *run_start.get_or_insert(i);
            if i + 1 - start > best.1 {
                best = (start, i + 1 - start);
            }
        } else {
            run_start = None;
        }
    }
    StillStretch {
        start: best.0,
        len: best.1,
        still_total,
    }
}

/// One channel's ARIMA identification.
#[derive(Clone, Debug, Serialize)]
pub struct ArimaRow {
    pub channel: String,
    pub p: usize,
    pub d: usize,
    pub q: usize,
    pub adf_stat: f64,
    pub adf_p: f64,
    pub sigma: f64,
    pub ljung_box_q: f64,
    pub ljung_box_p: f64,
    /// A vibration line taken out before identification: frequency, Hz, and amplitude (channel
    /// unit) on the training span.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line: Option<(f64, f64)>,
}

/// One channel's bias model.
#[derive(Clone, Debug, Serialize)]
pub struct BiasRow {
    pub channel: String,
    pub method: String,
    pub mean: f64,
    /// One-step innovation standard deviation, channel unit.
    pub innovation_sd: f64,
    /// The FOS terms chosen (`fos` only).
    pub fos_terms: Option<Vec<String>>,
}

/// What `fit` did: the identification tables and the two files written.
#[derive(Clone, Debug, Serialize)]
pub struct FitReport {
    /// Samples used.
    pub samples: usize,
    pub sample_rate_hz: f64,
    pub arima: Vec<ArimaRow>,
    pub arima_path: PathBuf,
    pub bias_method: BiasMethod,
    pub bias_order: usize,
    /// The still stretch the bias model was fitted on (or the longest one found).
    pub still: StillStretch,
    /// Why no bias model was fitted (no still stretch long enough), if so.
    pub bias_skipped: Option<String>,
    /// Channels absent in the log (a partial sensor), with the reason: no model for them.
    pub absent: Vec<(String, String)>,
    pub bias: Vec<BiasRow>,
    pub bias_path: PathBuf,
}

/// Fit both models on `log` and write them into `out_dir` (created if needed).
pub fn fit(log: &super::Recording, out_dir: &Path, o: &FitOptions) -> Result<FitReport> {
    let bias_order = o.bias_order;
    ensure!(
        (1..=MAX_FILE_AR_ORDER).contains(&bias_order),
        "--bias-order must be in 1..={MAX_FILE_AR_ORDER} (got {bias_order})"
    );
    // Only the training span is read.
    let (rate, samples) = load_span_to(log, o.skip_s, Some(o.train_s))?;
    let n = ((o.train_s * rate).round() as usize).min(samples.len());
    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    let series = |c: usize| -> Vec<f64> { samples[..n].iter().map(|s| s.channel(c)).collect() };
    let (present, mut absent) =
        present_channels(log, &samples[..n], &(0..N_CHANNELS).collect::<Vec<_>>())?;
    // A channel with NaN/Inf in the span (missing values, an all-NaN column) cannot be
    // identified: it is left out with the reason, like an absent one, instead of failing the
    // fit of the channels that are whole.
    let mut whole = Vec::with_capacity(present.len());
    for c in present {
        match super::non_finite(&samples[..n], c) {
            None => whole.push(c),
            Some((k, first_s)) => absent.push((
                CHANNEL_NAMES[c].to_string(),
                format!(
                    "{} in the training span (first at {first_s:.3} s of the log): ARIMA and \
                     bias fits need a gap-free series; the stages learn this channel at warm-up",
                    crate::text::count(k as u64, "non-finite sample", "non-finite samples"),
                ),
            )),
        }
    }
    ensure!(
        !whole.is_empty(),
        "{}: no channel to fit: {}",
        log.display(),
        absent
            .iter()
            .map(|(c, why)| format!("{c}: {why}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    let present = whole;
    let header = absent_header(&absent);

    let mut file = ArimaModelFile::default();
    let mut arima = Vec::new();
    for &c in &present {
        let name = CHANNEL_NAMES[c];
        // A vibration line the stage's tests should not see is taken out first, as the stage
        // does on its own warm-up window (`stage::gross_error::identify::window_line`).
        let mut x = series(c);
        let line = window_line(&hampel_cleaned(&x));
        if let Some(l) = &line {
            l.subtract_from(&mut x, 0);
        }
        let id = identify(&x, &IdentifySettings::default()).map_err(|e| {
            anyhow!(
                "{}: ARIMA identification of {name} on {} ({:.1} s at {} Hz): {e}",
                log.display(),
                crate::text::count(n as u64, "sample", "samples"),
                n as f64 / rate,
                crate::text::trim_decimals(rate, 3)
            )
        })?;
        let mut m = id.to_channel_model(name);
        m.line_per_sample = line.map(|l| l.omega / std::f64::consts::TAU);
        arima.push(ArimaRow {
            channel: name.to_string(),
            p: m.p,
            d: m.d,
            q: m.q,
            adf_stat: id.diagnostics.adf.stat,
            adf_p: id.diagnostics.adf.p_value,
            sigma: m.sigma,
            ljung_box_q: id.diagnostics.ljung_box.q,
            ljung_box_p: id.diagnostics.ljung_box.p_value,
            line: line.map(|l| (l.omega / std::f64::consts::TAU * rate, l.amplitude())),
        });
        file.channels.push(m);
    }
    let arima_path = out_dir.join("arima.toml");
    std::fs::write(
        &arima_path,
        header.clone() + &file.to_toml_string().map_err(|e| anyhow!("{e}"))?,
    )
    .with_context(|| format!("writing {}", arima_path.display()))?;

    // The bias model describes the sensor's bias, not the vehicle's motion: fit it only where
    // the sensor was still (a model fitted on motion takes the motion's mean and dynamics for
    // bias, and the bias stage then subtracts them). Stillness and the fit are judged on what
    // the bias stage sees in the daemon: the span after the gross-error stage with the models
    // just identified — a single spike must not break a still stretch, nor enter the bias fit.
    let cleaned = after_gross_errors(&samples[..n], &file)?;
    let samples = &cleaned;
    let still = longest_still_stretch(samples, rate);
    let need = ((o.min_still_s * rate).ceil() as usize).max(4 * bias_order);
    let bias_skipped = (still.len < need).then(|| {
        format!(
            "no still stretch of {:.0} s (and {} samples for order {bias_order}) in the training span: \
             the longest is {:.1} s ({} samples still in all); bias.toml holds no channel models, \
             so the bias stage learns each gyro's bias at warm-up",
            o.min_still_s,
            4 * bias_order,
            still.len as f64 / rate,
            still.still_total
        )
    });
    let still_span = still.start..still.start + still.len;
    let still_series = |c: usize| -> Vec<f64> {
        samples[still_span.clone()]
            .iter()
            .map(|s| s.channel(c))
            .collect()
    };
    let mut bias = BiasModelFile::default();
    let mut rows = Vec::new();
    for &c in &present {
        let name = CHANNEL_NAMES[c];
        if bias_skipped.is_some() {
            break;
        }
        let (m, terms) = fit_bias_channel(name, &still_series(c), rate, o.bias_method, bias_order)?;
        rows.push(BiasRow {
            channel: name.to_string(),
            method: m.method.clone(),
            mean: m.mean,
            innovation_sd: m.innovation_var.sqrt(),
            fos_terms: terms,
        });
        bias.channels.push(m);
    }
    bias.validate()
        .map_err(|e| anyhow!("bias model: {}", e.join("; ")))?;
    let bias_path = out_dir.join("bias.toml");
    let mut text = header;
    if let Some(why) = &bias_skipped {
        text += &format!("# imuprep fit: {why}\n");
    }
    text += &bias.to_toml_string().map_err(|e| anyhow!(e.to_string()))?;
    std::fs::write(&bias_path, text).with_context(|| format!("writing {}", bias_path.display()))?;
    Ok(FitReport {
        samples: n,
        sample_rate_hz: rate,
        arima,
        arima_path,
        bias_method: o.bias_method,
        bias_order,
        still,
        bias_skipped,
        absent,
        bias: rows,
        bias_path,
    })
}

/// `samples` through the gross-error stage of the embedded default configuration (its gate
/// settings) with the ARIMA models `file`; unchanged when that configuration has the stage off.
fn after_gross_errors(samples: &[Sample], file: &ArimaModelFile) -> Result<Vec<Sample>> {
    let cfg = crate::config::Config::default_embedded().map_err(|e| anyhow!("{e}"))?;
    let Some(g) = cfg.stages.gross_error else {
        return Ok(samples.to_vec());
    };
    let mut stage = GrossErrorStage::new(&g.settings, Some(file))
        .map_err(|e| anyhow!("gross-error stage: {e}"))?;
    let out = crate::stage::run_through(&mut stage, samples);
    ensure!(
        out.len() == samples.len(),
        "gross-error stage returned {} samples for {}",
        out.len(),
        samples.len()
    );
    Ok(out)
}

/// The model files' first line when channels were left out: which, and why.
fn absent_header(absent: &[(String, String)]) -> String {
    absent
        .iter()
        .map(|(c, why)| format!("# imuprep fit: {c}: no model: {why}\n"))
        .collect()
}

/// One channel's bias model by `method`; the FOS terms chosen when the method is `fos`.
fn fit_bias_channel(
    name: &str,
    x: &[f64],
    rate: f64,
    method: BiasMethod,
    order: usize,
) -> Result<(ChannelBiasModel, Option<Vec<String>>)> {
    let err = |e: ModelError| anyhow!("{name}: {e}");
    let from_ar = |f: ArFit| ChannelBiasModel {
        channel: name.to_string(),
        method: method.file_name().into(),
        sample_rate_hz: rate,
        mean: f.mean,
        ar: f.coeffs,
        innovation_var: f.noise_var,
        white_noise_var: 0.0,
        ..Default::default()
    };
    Ok(match method {
        BiasMethod::Burg => (from_ar(crate::model::burg(x, order).map_err(err)?), None),
        BiasMethod::YuleWalker => (
            from_ar(crate::model::yule_walker(x, order).map_err(err)?),
            None,
        ),
        BiasMethod::Covariance => (
            from_ar(crate::model::covariance(x, order).map_err(err)?),
            None,
        ),
        BiasMethod::Fos => {
            let (f, _) = FosModel::fit(
                x,
                &[],
                &FosModelSpec::paper(order, 1),
                &FosSettings::default(),
            )
            .map_err(err)?;
            // One-step residuals on the fit rows (those with a full L-sample past), y units.
            let r = f.residuals(x, &[], order..x.len());
            ensure!(
                !r.is_empty(),
                "{name}: no fit rows for FOS with L = {order}"
            );
            let mse = r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64;
            let m = ChannelBiasModel::from_linear_fos(name, rate, &f, mse)
                .map_err(|e| anyhow!("{name}: {e}"))?;
            (m, Some(f.terms.iter().map(|t| t.name()).collect()))
        }
    })
}

impl fmt::Display for FitReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let rate = self.sample_rate_hz;
        writeln!(
            f,
            "ARIMA identification on {} samples ({:.0} s at {} Hz; sigma in the channel's unit, rad/s or m/s²):",
            self.samples,
            self.samples as f64 / rate,
            crate::text::trim_decimals(rate, 3)
        )?;
        writeln!(
            f,
            "{:<4} {:>9} {:>10} {:>8} {:>12} {:>12} {:>10}",
            "ch", "(p,d,q)", "ADF stat", "ADF p", "sigma", "Ljung-Box Q", "LB p"
        )?;
        for r in &self.arima {
            writeln!(
                f,
                "{:<4} {:>9} {:>10.3} {:>8.4} {:>12.4e} {:>12.2} {:>10.4}",
                r.channel,
                format!("({},{},{})", r.p, r.d, r.q),
                r.adf_stat,
                r.adf_p,
                r.sigma,
                r.ljung_box_q,
                r.ljung_box_p
            )?;
        }
        for r in &self.arima {
            if let Some((hz, amp)) = r.line {
                writeln!(
                    f,
                    "{:<4} a vibration line at {hz:.3} Hz (amplitude {amp:.3e}) was taken out before identification; the daemon fits it on its warm-up and judges the channel without it",
                    r.channel
                )?;
            }
        }
        for (c, why) in &self.absent {
            writeln!(f, "{c:<4} not fitted: {why}")?;
        }
        let p = self.arima_path.display();
        writeln!(f, "wrote {p} (use it as [gross_error] model = \"{p}\")")?;
        let order = self.bias_order;
        let p = self.bias_path.display();
        if let Some(why) = &self.bias_skipped {
            writeln!(f, "bias model: NOT FITTED — {why}")?;
            return writeln!(f, "wrote {p} (no channel models)");
        }
        let on = format!(
            "on the longest still stretch after the gross-error stage, {:.1} s from {:.1} s of the span",
            self.still.len as f64 / rate,
            self.still.start as f64 / rate
        );
        match self.bias_method {
            BiasMethod::Fos => writeln!(
                f,
                "bias model: FOS CP=1 L={order} (constant + lags, as AR) per channel {on}:"
            )?,
            m => writeln!(
                f,
                "bias model: {} AR({order}) per channel {on}:",
                m.file_name()
            )?,
        }
        for r in &self.bias {
            let detail = match &r.fos_terms {
                None => String::new(),
                Some(t) if t.is_empty() => "  terms none (white)".to_string(),
                Some(t) => format!("  terms {}", t.join(" ")),
            };
            writeln!(
                f,
                "{:<4} {:<11} mean {:>12.4e}  one-step innovation sd {:>10.4e}{detail}",
                r.channel, r.method, r.mean, r.innovation_sd
            )?;
        }
        writeln!(f, "wrote {p} (use it as [bias] model = \"{p}\")")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// 100 Hz: `still_a` s at rest, 5 s of a 1 Hz, 0.5 rad/s rotation, `still_b` s at rest;
    /// seeded white noise 0.005 rad/s and 0.02 m/s² on every axis.
    fn record(still_a: f64, still_b: f64) -> Vec<Sample> {
        let mut rng = crate::rng::Rng::new(7);
        let n_a = (still_a * 100.0) as usize;
        let n_m = 500;
        let n = n_a + n_m + (still_b * 100.0) as usize;
        (0..n)
            .map(|i| {
                let t = i as f64 / 100.0;
                let w = if (n_a..n_a + n_m).contains(&i) {
                    0.5 * (std::f64::consts::TAU * t).sin()
                } else {
                    0.0
                };
                Sample {
                    t_ns: (t * 1e9) as u64,
                    gyro: Vector3::new(
                        0.01 + 0.005 * rng.normal(),
                        w + 0.005 * rng.normal(),
                        0.005 * rng.normal(),
                    ),
                    accel: Vector3::new(
                        0.02 * rng.normal(),
                        0.02 * rng.normal(),
                        9.81 + 0.02 * rng.normal(),
                    ),
                    ..Default::default()
                }
            })
            .collect()
    }

    #[test]
    fn the_longest_still_stretch_excludes_the_motion() {
        let s = record(20.0, 70.0);
        let st = longest_still_stretch(&s, 100.0);
        // The stretch after the rotation: it starts after the rotation ends (2500) and the
        // detector's entry delay (window 0.5 s + enter_after 1 s, plus the floor's first
        // window), so it lies inside 2500..9500 and covers most of it (≥ 65 of the 70 s).
        assert!(st.start >= 2500, "{st:?}");
        assert_eq!(st.start + st.len, s.len(), "{st:?}");
        assert!(st.len >= 6500, "{st:?}");
    }

    #[test]
    fn a_record_in_motion_throughout_has_no_long_still_stretch() {
        let mut s = record(0.0, 0.0);
        // 100 s of the rotation: nothing is still for longer than a fraction of a cycle.
        s = (0..20).flat_map(|_| s.clone()).collect();
        let st = longest_still_stretch(&s, 100.0);
        assert!(st.len < 100, "{st:?}");
    }
}
