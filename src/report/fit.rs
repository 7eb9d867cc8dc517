//! `imuprep fit`: the ARIMA model per channel (gross-error stage) and the AR bias model per
//! channel (bias stage) from one span of a recording, written as `arima.toml` and `bias.toml`.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, ensure};
use serde::Serialize;

use super::load_span;
use crate::model::arima::{ArimaModelFile, IdentifySettings, identify};
use crate::model::bias_model::{BiasModelFile, ChannelBiasModel, MAX_FILE_AR_ORDER};
use crate::model::fos::FosSettings;
use crate::model::fos_model::{FosModel, FosModelSpec};
use crate::model::{ArFit, ModelError};
use crate::sample::CHANNEL_NAMES;

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
    pub bias: Vec<BiasRow>,
    pub bias_path: PathBuf,
}

/// Fit both models on `log` and write them into `out_dir` (created if needed).
pub fn fit(log: &Path, out_dir: &Path, o: &FitOptions) -> Result<FitReport> {
    let bias_order = o.bias_order;
    ensure!(
        (1..=MAX_FILE_AR_ORDER).contains(&bias_order),
        "--bias-order must be in 1..={MAX_FILE_AR_ORDER} (got {bias_order})"
    );
    let (rate, samples) = load_span(log, o.skip_s)?;
    let n = ((o.train_s * rate).round() as usize).min(samples.len());
    std::fs::create_dir_all(out_dir)?;
    let series = |c: usize| -> Vec<f64> { samples[..n].iter().map(|s| s.channel(c)).collect() };

    let mut file = ArimaModelFile::default();
    let mut arima = Vec::new();
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let id = identify(&series(c), &IdentifySettings::default())
            .map_err(|e| anyhow!("{name}: {e}"))?;
        let m = id.to_channel_model(name);
        arima.push(ArimaRow {
            channel: name.to_string(),
            p: m.p,
            d: m.d,
            q: m.q,
            adf_stat: id.adf.stat,
            adf_p: id.adf.p_value,
            sigma: m.sigma,
            ljung_box_q: id.ljung_box.q,
            ljung_box_p: id.ljung_box.p_value,
        });
        file.channels.push(m);
    }
    let arima_path = out_dir.join("arima.toml");
    std::fs::write(
        &arima_path,
        file.to_toml_string().map_err(|e| anyhow!("{e}"))?,
    )?;

    let mut bias = BiasModelFile::default();
    let mut rows = Vec::new();
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let (m, terms) = fit_bias_channel(name, &series(c), rate, o.bias_method, bias_order)?;
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
    std::fs::write(
        &bias_path,
        bias.to_toml_string().map_err(|e| anyhow!(e.to_string()))?,
    )?;
    Ok(FitReport {
        samples: n,
        sample_rate_hz: rate,
        arima,
        arima_path,
        bias_method: o.bias_method,
        bias_order,
        bias: rows,
        bias_path,
    })
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
            "ARIMA identification on {} samples ({:.0} s at {rate} Hz):",
            self.samples,
            self.samples as f64 / rate
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
        let p = self.arima_path.display();
        writeln!(f, "wrote {p} (use it as [gross_error] model = \"{p}\")")?;
        let order = self.bias_order;
        match self.bias_method {
            BiasMethod::Fos => writeln!(
                f,
                "bias model: FOS CP=1 L={order} (constant + lags, as AR) per channel on the same span:"
            )?,
            m => writeln!(
                f,
                "bias model: {} AR({order}) per channel on the same span:",
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
        let p = self.bias_path.display();
        writeln!(f, "wrote {p} (use it as [bias] model = \"{p}\")")
    }
}
