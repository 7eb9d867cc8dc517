//! The fitted model per channel and the model file (`arima.toml`) written by `imuprep fit`.

use super::*;

/// What identification found, stored with a model (informative, not used online).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArimaDiagnostics {
    /// Samples the model was identified from.
    pub n_obs: usize,
    /// ADF on the raw series.
    pub adf: AdfResult,
    /// 95 % bound of the ACF/PACF below.
    pub acf_bound: f64,
    /// ACF / PACF of the differenced series, lags 0..
    pub acf: Vec<f64>,
    pub pacf: Vec<f64>,
    /// Classical ACF/PACF order suggestions.
    pub suggested_p: usize,
    pub suggested_q: usize,
    /// AIC of the chosen model and of every candidate.
    pub aic: f64,
    pub aic_table: Vec<AicEntry>,
    /// LM converged for the chosen model.
    pub converged: bool,
    /// Ljung–Box on the residuals.
    pub ljung_box: LjungBox,
    /// Residual ACF / PACF (lags 0..) and their bound.
    pub resid_bound: f64,
    pub resid_acf: Vec<f64>,
    pub resid_pacf: Vec<f64>,
}

/// One channel's ARIMA model as written by `fit` and read by the daemon.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArimaChannelModel {
    /// Channel name, `gx` … `az`.
    pub channel: String,
    /// AR order.
    pub p: usize,
    /// Differencing order (0 or 1).
    pub d: usize,
    /// MA order.
    pub q: usize,
    /// Intercept c of the differenced equation (rad/s or m/s²; per sample for d = 1).
    pub constant: f64,
    /// φ_1..φ_p.
    pub ar: Vec<f64>,
    /// θ_1..θ_q (w_t = c + Σφ w + e_t + Σθ e).
    pub ma: Vec<f64>,
    /// Innovation standard deviation σ (rad/s or m/s²).
    pub sigma: f64,
    /// The vibration line taken out of the training data before identification, cycles per
    /// sample (0 < f < 0.5): the model is the channel's without it. The daemon fits the line's
    /// amplitude and phase on its warm-up window, and its gross-error tests judge the channel
    /// with the line taken out (docs/gross_error_results.md, "The warm-up's line").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_per_sample: Option<f64>,
    /// What identification found (optional in hand-written files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diagnostics: Option<ArimaDiagnostics>,
}

impl ArimaChannelModel {
    /// Consistency checks; `online` additionally requires the predictor's fixed-size limits.
    pub fn validate(&self, online: bool) -> Result<(), ArimaError> {
        let mut e = Vec::new();
        if self.ar.len() != self.p {
            e.push(format!(
                "ar has {} coefficients, p = {}",
                self.ar.len(),
                self.p
            ));
        }
        if self.ma.len() != self.q {
            e.push(format!(
                "ma has {} coefficients, q = {}",
                self.ma.len(),
                self.q
            ));
        }
        let (pm, qm) = if online {
            (MAX_P, MAX_Q)
        } else {
            (MAX_FIT_ORDER, MAX_FIT_ORDER)
        };
        if self.p > pm || self.q > qm || self.d > MAX_D {
            e.push(format!(
                "order ({}, {}, {}) exceeds ({pm}, {MAX_D}, {qm})",
                self.p, self.d, self.q
            ));
        }
        if !self.constant.is_finite() || self.ar.iter().chain(&self.ma).any(|v| !v.is_finite()) {
            e.push("non-finite coefficient".into());
        }
        if !(self.sigma > 0.0 && self.sigma.is_finite()) {
            e.push(format!("sigma = {} must be positive", self.sigma));
        }
        if let Some(f) = self.line_per_sample
            && !(f > 0.0 && f < 0.5)
        {
            e.push(format!(
                "line_per_sample = {f} must be a frequency in cycles per sample, 0 < f < 0.5"
            ));
        }
        if self.ar.len() == self.p && !is_stable(&self.ar, 0.0) {
            e.push("AR polynomial is not stationary".into());
        }
        if self.ma.len() == self.q
            && !is_stable(&self.ma.iter().map(|t| -t).collect::<Vec<_>>(), 0.0)
        {
            e.push("MA polynomial is not invertible".into());
        }
        if e.is_empty() {
            Ok(())
        } else {
            Err(ArimaError::InvalidModel(format!(
                "channel {}: {}",
                self.channel,
                e.join("; ")
            )))
        }
    }

    /// Mean of the differenced series, `c / (1 − Σφ)`.
    pub fn mean(&self) -> f64 {
        self.constant / (1.0 - self.ar.iter().sum::<f64>())
    }

    /// The vibration line the model holds, as its angular frequency in rad per sample: when the
    /// AR part sits on the stationarity boundary (as [`ArimaFit::at_boundary`] judges it) and
    /// its root nearest the unit circle is a complex pair, that pair's angle. `None` otherwise
    /// (a stationary AR part, or a real unit root: a level, not a line).
    pub fn line(&self) -> Option<f64> {
        let p = self.ar.len();
        if p < 2 || is_stable(&self.ar, 2.0 * AR_MARGIN) {
            return None;
        }
        // The companion matrix's eigenvalues are the inverse roots of 1 − Σ φ_i B^i.
        let companion = nalgebra::DMatrix::from_fn(p, p, |i, j| {
            if i == 0 {
                self.ar[j]
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        let ev = companion.complex_eigenvalues();
        let top = ev.iter().max_by(|a, b| a.norm().total_cmp(&b.norm()))?;
        let omega = top.im.atan2(top.re).abs();
        (top.im.abs() > 1e-9 * top.norm() && omega.is_finite()).then_some(omega)
    }
}

impl ArimaIdentification {
    /// The model file entry for `channel`, with diagnostics.
    pub fn to_channel_model(&self, channel: &str) -> ArimaChannelModel {
        ArimaChannelModel {
            channel: channel.to_string(),
            p: self.fit.p,
            d: self.fit.d,
            q: self.fit.q,
            constant: self.fit.constant,
            ar: self.fit.ar.clone(),
            ma: self.fit.ma.clone(),
            sigma: self.fit.sigma2.sqrt(),
            line_per_sample: None,
            diagnostics: Some(self.diagnostics.clone()),
        }
    }
}

/// ψ-weights `ψ_0..ψ_{n−1}` of the full ARIMA (differencing included): `x_t = Σ ψ_i e_{t−i}`, from
/// `ψ_j = θ_j + Σ_i φ*_i ψ_{j−i}` with `φ*(B) = φ(B)(1−B)^d`. The h-step forecast error variance is
/// `σ² Σ_{i<h} ψ_i²`.
pub fn psi_weights(model: &ArimaChannelModel, out: &mut [f64]) {
    // φ*(B) coefficients (at most MAX_FIT_ORDER + MAX_D).
    let mut phi_star = [0.0f64; MAX_FIT_ORDER + MAX_D];
    let np = model.ar.len().min(MAX_FIT_ORDER);
    phi_star[..np].copy_from_slice(&model.ar[..np]);
    let mut n_star = np;
    if model.d == 1 {
        // (1 − Σφ_i B^i)(1 − B) = 1 − (φ_1 + 1)B − Σ_{i≥2} (φ_i − φ_{i−1}) B^i + φ_p B^{p+1}
        let mut d = [0.0f64; MAX_FIT_ORDER + MAX_D];
        d[0] = 1.0 + if np > 0 { phi_star[0] } else { 0.0 };
        for i in 1..np {
            d[i] = phi_star[i] - phi_star[i - 1];
        }
        if np > 0 {
            d[np] = -phi_star[np - 1];
        }
        n_star = np + 1;
        phi_star = d;
    }
    for j in 0..out.len() {
        let mut v = if j == 0 {
            1.0
        } else {
            model.ma.get(j - 1).copied().unwrap_or(0.0)
        };
        for i in 0..n_star.min(j) {
            v += phi_star[i] * out[j - 1 - i];
        }
        out[j] = v;
    }
}

/// A model file: one table per channel (`[[channels]]`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArimaModelFile {
    pub channels: Vec<ArimaChannelModel>,
}

impl ArimaModelFile {
    /// Parse and validate (offline limits) a TOML model file.
    pub fn from_toml_str(s: &str) -> Result<Self, ArimaError> {
        let f: ArimaModelFile = toml::from_str(s).map_err(|e| ArimaError::Toml(e.to_string()))?;
        for c in &f.channels {
            c.validate(false)?;
        }
        Ok(f)
    }

    /// Serialise to TOML.
    pub fn to_toml_string(&self) -> Result<String, ArimaError> {
        toml::to_string(self).map_err(|e| ArimaError::Toml(e.to_string()))
    }

    /// The model of a channel by name.
    pub fn channel(&self, name: &str) -> Option<&ArimaChannelModel> {
        self.channels.iter().find(|c| c.channel == name)
    }
}
