//! Identification: ADF for d, ACF/PACF suggestions, the AIC grid, residual diagnosis (module docs
//! of [`super`]).

use super::*;

/// Settings of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentifySettings {
    /// Largest AR order in the AIC grid (default 3).
    pub p_max: usize,
    /// Largest MA order in the AIC grid (default 2).
    pub q_max: usize,
    /// Largest differencing order (0 or 1; default 1). d itself comes from the ADF test.
    pub d_max: usize,
    /// ADF significance level: unit root rejected at p < adf_alpha ⇒ d = 0 (default 0.05).
    pub adf_alpha: f64,
    /// ADF lag rule (default: AIC over 0..=⌈12 (N/100)^¼⌉, as statsmodels).
    pub adf_lag: AdfLag,
    /// Lags of the reported ACF/PACF (default 20).
    pub acf_lags: usize,
    /// Ljung–Box lags on the residuals (default 20; dof = lags − p − q).
    pub ljung_box_lags: usize,
    /// LM options.
    pub css: CssOptions,
}

impl Default for IdentifySettings {
    fn default() -> Self {
        IdentifySettings {
            p_max: 3,
            q_max: 2,
            d_max: 1,
            adf_alpha: 0.05,
            adf_lag: AdfLag::default(),
            acf_lags: 20,
            ljung_box_lags: 20,
            css: CssOptions::default(),
        }
    }
}

impl IdentifySettings {
    /// All problems at once (empty = valid).
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut e = Vec::new();
        if self.p_max > MAX_FIT_ORDER {
            e.push(format!("p_max = {} exceeds {MAX_FIT_ORDER}", self.p_max));
        }
        if self.q_max > MAX_FIT_ORDER {
            e.push(format!("q_max = {} exceeds {MAX_FIT_ORDER}", self.q_max));
        }
        if self.d_max > MAX_D {
            e.push(format!("d_max = {} exceeds {MAX_D}", self.d_max));
        }
        if !(self.adf_alpha > 0.0 && self.adf_alpha < 1.0) {
            e.push(format!("adf_alpha = {} must be in (0, 1)", self.adf_alpha));
        }
        if self.acf_lags == 0 {
            e.push("acf_lags must be ≥ 1".into());
        }
        if self.ljung_box_lags <= self.p_max + self.q_max {
            e.push(format!(
                "ljung_box_lags = {} must exceed p_max + q_max = {}",
                self.ljung_box_lags,
                self.p_max + self.q_max
            ));
        }
        if self.css.max_iter == 0 {
            e.push("css.max_iter must be ≥ 1".into());
        }
        if !(self.css.rel_tol >= 0.0 && self.css.rel_tol < 1.0) {
            e.push(format!(
                "css.rel_tol = {} must be in [0, 1)",
                self.css.rel_tol
            ));
        }
        if e.is_empty() { Ok(()) } else { Err(e) }
    }

    /// Shortest series `identify` accepts with these settings.
    pub fn min_len(&self) -> usize {
        // Enough for the long AR (n/10 ≥ 2 max(p,q)), the ACF lags and a few dozen residuals.
        (20 * (self.p_max + self.q_max + 1))
            .max(2 * self.acf_lags + 2)
            .max(2 * self.ljung_box_lags + 2)
            .max(50)
    }
}

/// One row of the AIC table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AicEntry {
    pub p: usize,
    pub q: usize,
    /// Conditional-likelihood AIC (common conditioning on p_max values).
    pub aic: f64,
    /// Innovation standard deviation of this candidate.
    pub sigma: f64,
    /// The fit ended on the admissibility boundary: its AR part (a line; eligible) or its MA
    /// part (not eligible; see `identify`).
    #[serde(default)]
    pub at_boundary: bool,
}

/// Everything `identify` found.
#[derive(Debug, Clone, PartialEq)]
pub struct ArimaIdentification {
    /// The chosen model.
    pub fit: ArimaFit,
    /// What identification found on the way: ADF, ACF/PACF of the differenced series and their
    /// order suggestions, the AIC of every candidate that fitted, the residual diagnosis (the
    /// model file stores it as found).
    pub diagnostics: ArimaDiagnostics,
    /// The chosen model's CSS residuals.
    pub residuals: Vec<f64>,
}

/// Identify and fit an ARIMA(p, d, q) with constant for `x` (see the module header).
pub fn identify(x: &[f64], settings: &IdentifySettings) -> Result<ArimaIdentification, ArimaError> {
    settings.validate().map_err(ArimaError::InvalidSettings)?;
    check_finite(x)?;
    check_series(x, settings.min_len())?;
    let adf_res = adf(x, settings.adf_lag)?;
    let d = if adf_res.p_value < settings.adf_alpha {
        0
    } else {
        settings.d_max.min(1)
    };
    let w = difference(x, d);
    let acf_w = acf(&w, settings.acf_lags)?;
    let pacf_w = pacf_from_acf(&acf_w);
    let bound = acf_bound_95(w.len());
    let last_sig = |v: &[f64], max: usize| {
        (1..=max.min(v.len() - 1))
            .filter(|&k| v[k].abs() > bound)
            .max()
            .unwrap_or(0)
    };
    let suggested_p = last_sig(&pacf_w, settings.p_max);
    let suggested_q = last_sig(&acf_w, settings.q_max);

    let hr = if settings.q_max > 0 {
        Some(long_ar(
            &w,
            long_ar_order(w.len(), settings.p_max, settings.q_max),
        )?)
    } else {
        None
    };
    let n_cond = settings.p_max;
    // The grid only has to rank AICs: stop each candidate once the last LM step gains less than
    // 1e-4/n of S (the AIC then moves by ≲ 1e-2 even if ~100 such steps remained — well below any
    // AIC difference that means something); the winner is then polished to `css.rel_tol`. This
    // keeps over-parameterised candidates (near-common AR/MA factors, a flat ridge) from
    // crawling for dozens of iterations.
    let grid_css = CssOptions {
        rel_tol: settings.css.rel_tol.max(1e-4 / w.len() as f64),
        ..settings.css
    };
    let mut table = Vec::new();
    let mut best: Option<ArimaFit> = None;
    let mut last_err = None;
    for p in 0..=settings.p_max {
        for q in 0..=settings.q_max {
            match fit_css_with(&w, (p, d, q), n_cond, &grid_css, hr.as_ref(), None) {
                Ok(f) => {
                    let at_boundary = f.at_boundary();
                    table.push(AicEntry {
                        p,
                        q,
                        aic: f.aic,
                        sigma: f.sigma2.sqrt(),
                        at_boundary,
                    });
                    // A fit that ends on the invertibility boundary is an over-parameterised
                    // candidate (near-common AR/MA factors or a unit MA root): its AIC is not
                    // trustworthy and, online, an MA root on the unit circle never forgets an
                    // innovation. It is reported but not chosen. One whose AR part ends on the
                    // stationarity boundary is a line (a complex root pair on the unit circle:
                    // a channel carrying a vibration line), which is what the data hold: it is
                    // eligible.
                    if !f.ma_at_boundary() && best.as_ref().is_none_or(|b| f.aic < b.aic) {
                        best = Some(f);
                    }
                }
                Err(e) => last_err = Some(e),
            }
        }
    }
    let fit = match best {
        Some(f) => {
            let mut start = vec![f.constant];
            start.extend_from_slice(&f.ar);
            start.extend_from_slice(&f.ma);
            let polished = fit_css_with(
                &w,
                (f.p, d, f.q),
                n_cond,
                &settings.css,
                hr.as_ref(),
                Some(&start),
            )?;
            let chosen = if polished.ssr <= f.ssr { polished } else { f };
            // Report the polished AIC in the table too.
            if let Some(row) = table
                .iter_mut()
                .find(|r| r.p == chosen.p && r.q == chosen.q)
            {
                row.aic = chosen.aic;
                row.sigma = chosen.sigma2.sqrt();
            }
            chosen
        }
        None => return Err(last_err.unwrap_or(NumError::singular("every candidate").into())),
    };
    let residuals = css_residuals(&w, fit.constant, &fit.ar, &fit.ma, fit.n_cond);
    let lb_lags = settings.ljung_box_lags.min(residuals.len() / 2);
    let ljung = ljung_box(&residuals, lb_lags, fit.p + fit.q)?;
    let lags = settings.acf_lags.min(residuals.len() - 1);
    let resid_acf = acf(&residuals, lags)?;
    let resid_pacf = pacf_from_acf(&resid_acf);
    let diagnostics = ArimaDiagnostics {
        n_obs: x.len(),
        adf: adf_res,
        acf_bound: bound,
        acf: acf_w,
        pacf: pacf_w,
        suggested_p,
        suggested_q,
        aic: fit.aic,
        aic_table: table,
        converged: fit.converged,
        ljung_box: ljung,
        resid_bound: acf_bound_95(residuals.len()),
        resid_acf,
        resid_pacf,
    };
    Ok(ArimaIdentification {
        fit,
        diagnostics,
        residuals,
    })
}
