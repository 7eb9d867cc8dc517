//! The diagnosis report: JSON (serde), a text formatter, and the SVG plots of each channel
//! (residual spectrum before/after, Allan deviation before/after, each effect over the residual).

use super::paper_split::{ChannelDiagnosis, Findings, ResidualPlots, TestMetrics};
use crate::analysis::line_plot::{Plot, Series, render};
use crate::analysis::spectrum::Psd;
use crate::model::bias_model::Effect;
use serde::Serialize;
use std::fmt::Write;

/// A report over several channels of one log.
#[derive(Clone, Debug, Serialize)]
pub struct DiagnoseReport {
    /// What was analysed (file, stretch, units).
    pub source: String,
    /// One diagnosis per channel.
    pub channels: Vec<ChannelDiagnosis>,
    /// What makes the effects doubtful (a record not at rest), one line each.
    pub warnings: Vec<String>,
}

impl DiagnoseReport {
    /// Pretty JSON.
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string_pretty(self)
    }

    /// Human-readable text.
    pub fn to_text(&self) -> String {
        let mut o = format!("diagnose: {}\n", self.source);
        for w in &self.warnings {
            o.push_str(&format!("WARNING: {w}\n"));
        }
        for c in &self.channels {
            o.push_str(&channel_text(c));
        }
        o
    }
}

/// One line describing an effect and its parameters.
pub fn effect_text(e: &Effect) -> String {
    match e {
        Effect::VibrationLine {
            freq_hz,
            amplitude,
            phase_rad,
        } => {
            format!(
                "vibration line f = {freq_hz:.5} Hz, A = {amplitude:.4e}, phase = {phase_rad:.3} rad"
            )
        }
        Effect::Temperature(term) => term.to_string(),
        Effect::Step { t_s, size } => format!("bias step at t = {t_s:.2} s, size {size:.4e}"),
        Effect::GSensitivity { coeffs_per_m_s2: k } => {
            format!(
                "g-sensitivity k = [{:.4e}, {:.4e}, {:.4e}] per m/s²",
                k[0], k[1], k[2]
            )
        }
        Effect::RateRandomWalk { q_per_s } => {
            format!("rate random walk q = {q_per_s:.4e} units²/s")
        }
    }
}

fn metrics_text(m: &TestMetrics) -> String {
    let lb = m.ljung_box.as_ref().map_or("n/a".to_string(), |l| {
        format!("Q({}) = {:.1}, p = {:.2e}", l.lags, l.q, l.p_value)
    });
    format!(
        "AR({}) one-step MSE {:.4e}, open-loop MSE {:.4e}, Ljung-Box {lb}",
        m.ar_order, m.mse_one_step, m.mse_open_loop
    )
}

fn findings_text(f: &Findings) -> String {
    let mut o = String::new();
    if let Some(l) = &f.ljung_box {
        let _ = writeln!(
            o,
            "    whiteness: Q({}) = {:.1}, p = {:.2e}, ACF outside ±{:.4}: {}/{}",
            l.lags, l.q, l.p_value, l.acf_bound, l.acf_outside, l.lags
        );
    }
    for p in f.spectral_peaks.iter().take(5) {
        let _ = writeln!(
            o,
            "    line: {:.4} Hz, power {:.3e}, ratio {:.1}, p {:.1e}",
            p.freq_hz, p.power, p.ratio, p.p_value
        );
    }
    for c in f.change_points.iter().take(5) {
        let _ = writeln!(
            o,
            "    step: t = {:.2} s, size {:.3e}, p {:.1e}",
            c.t_s, c.size, c.p_value
        );
    }
    if let Some(x) = &f.exogenous {
        if let Some(t) = &x.temperature {
            let _ = writeln!(
                o,
                "    temperature: lag {:.0} s explains {:.1} %",
                t.lag_s,
                100.0 * t.fit.explained_share
            );
        }
        if let Some(r) = &x.specific_force {
            let _ = writeln!(
                o,
                "    specific force xyz explains {:.1} %",
                100.0 * r.explained_share
            );
        }
        for a in &x.other_axes {
            let _ = writeln!(o, "    corr with {}: {:.3}", a.name, a.correlation);
        }
    }
    if let Some(a) = &f.allan {
        let _ = writeln!(
            o,
            "    Allan vs white residual: {:?}{}",
            a.kind,
            a.excess_from_tau_s
                .map_or(String::new(), |t| format!(" from tau = {t:.2} s"))
        );
    }
    o
}

/// Text block of one channel.
pub fn channel_text(c: &ChannelDiagnosis) -> String {
    let mut o = String::new();
    let hz = c.sample_rate_hz;
    let _ = writeln!(
        o,
        "\n== {} ({} samples at {:.2} Hz; train {:.0}-{:.0} s, validation -{:.0} s, test -{:.0} s{})",
        c.channel,
        c.n,
        hz,
        c.split.train.start as f64 / hz,
        c.split.train.end as f64 / hz,
        c.split.validation.end as f64 / hz,
        c.split.test.end as f64 / hz,
        if c.split.proportional {
            ", proportional split"
        } else {
            ""
        }
    );
    if let Some(q) = &c.quantisation {
        match q.lsb {
            Some(l) => {
                let _ = writeln!(
                    o,
                    "  quantised: LSB {:.4e} ({} distinct values), q²/12 = {:.2} of the variance",
                    l,
                    q.distinct_values,
                    q.share_of_variance.unwrap_or(0.0)
                );
            }
            None => {
                let _ = writeln!(
                    o,
                    "  not visibly quantised ({} distinct values)",
                    q.distinct_values
                );
            }
        }
    }
    if let Some(s) = &c.saturation
        && (s.clipped_high || s.clipped_low)
    {
        let _ = writeln!(
            o,
            "  SATURATION: high {} ({}×{}), low {} ({}×{})",
            s.clipped_high, s.at_max, s.max, s.clipped_low, s.at_min, s.min
        );
    }
    let _ = writeln!(o, "  first model: {}", metrics_text(&c.baseline));
    o.push_str("  what it left (test):\n");
    o.push_str(&findings_text(&c.baseline_findings));
    for it in &c.iterations {
        let _ = writeln!(
            o,
            "  [{}] + {}  (Q_val = {:.3e}, LR = {:.1}, p = {:.2e})",
            it.index,
            effect_text(&it.effect),
            it.score.q,
            it.score.lr,
            it.score.p_value
        );
        if it.family == "rate_random_walk" {
            // Which Allan slope called for the walk term (flicker has no term of its own).
            let _ = writeln!(o, "      ({})", it.score.description);
        }
        for r in &it.removed {
            let _ = writeln!(o, "      dropped (no longer significant with it): {r}");
        }
        let _ = writeln!(o, "      before: {}", metrics_text(&it.before));
        let _ = writeln!(o, "      after:  {}", metrics_text(&it.after));
        let _ = writeln!(
            o,
            "      removed {:.1} % of the one-step, {:.1} % of the open-loop test MSE",
            100.0 * it.share_removed_one_step,
            100.0 * it.share_removed_open_loop
        );
    }
    if c.iterations.is_empty() {
        o.push_str("  nothing added\n");
    }
    for r in &c.rejected {
        let _ = writeln!(
            o,
            "  not added: {} ({}): Q_val = {:.3e}, p = {:.2e}",
            r.family, r.description, r.q, r.p_value
        );
    }
    let _ = writeln!(o, "  final model: {}", metrics_text(&c.final_metrics));
    o.push_str("  what remains (test):\n");
    o.push_str(&findings_text(&c.final_findings));
    o
}

/// A log-log plot of two residual spectra, before and after (the DC bin left out).
fn spectrum_plot(
    title: String,
    before: (&str, &Psd),
    after: (&str, &Psd),
) -> Result<String, String> {
    let skip0 = |v: &Vec<f64>| v.iter().skip(1).copied().collect::<Vec<f64>>();
    let series = [before, after]
        .into_iter()
        .map(|(label, p)| Series {
            label: label.into(),
            x: skip0(&p.freq_hz),
            y: skip0(&p.density),
        })
        .collect();
    let plot = Plot {
        title,
        x_label: "frequency (Hz)".into(),
        y_label: "PSD (units²/Hz)".into(),
        log_x: true,
        log_y: true,
        series,
    };
    render(&plot, 800, 480)
}

/// How a diagnosis names the residual it plots before and after its effects.
pub struct ResidualCaptions<'a> {
    /// Spectrum title, after "{channel}: ".
    pub spectrum: &'a str,
    /// Allan deviation title, after "{channel}: ".
    pub allan: &'a str,
    /// Legends of the residual before and after.
    pub before: &'a str,
    pub after: &'a str,
    /// Also draw white noise (slope −1/2) through the first point after.
    pub white_reference: bool,
}

/// The residual's spectrum (`{channel}_spectrum`) and Allan deviation (`{channel}_allan`) before
/// and after the effects, each where both curves are there: (file stem, svg).
pub fn residual_plots(
    channel: &str,
    p: &ResidualPlots,
    c: &ResidualCaptions,
) -> Result<Vec<(String, String)>, String> {
    let mut out = Vec::new();
    if let (Some(a), Some(b)) = (&p.spectrum_before, &p.spectrum_after) {
        let title = format!("{channel}: {}", c.spectrum);
        let svg = spectrum_plot(title, (c.before, a), (c.after, b))?;
        out.push((format!("{channel}_spectrum"), svg));
    }
    if let (Some(b0), Some(a0)) = (p.allan_before.first(), p.allan_after.first()) {
        let taus = |v: &[(f64, f64)]| v.iter().map(|p| p.0).collect();
        let curve = |v: &[(f64, f64)], label: &str| Series {
            label: label.into(),
            x: taus(v),
            y: v.iter().map(|p| p.1).collect(),
        };
        let mut series = vec![
            curve(&p.allan_before, c.before),
            curve(&p.allan_after, c.after),
        ];
        if c.white_reference {
            series.push(Series {
                label: "white (slope -1/2)".into(),
                x: taus(&p.allan_before),
                y: p.allan_before
                    .iter()
                    .map(|v| a0.1 * (v.0 / b0.0).powf(-0.5))
                    .collect(),
            });
        }
        let plot = Plot {
            title: format!("{channel}: {}", c.allan),
            x_label: "tau (s)".into(),
            y_label: "Allan deviation".into(),
            log_x: true,
            log_y: true,
            series,
        };
        out.push((format!("{channel}_allan"), render(&plot, 800, 480)?));
    }
    Ok(out)
}

/// SVG plots of one channel: (file stem, svg text).
pub fn channel_plots(c: &ChannelDiagnosis) -> Result<Vec<(String, String)>, String> {
    let captions = ResidualCaptions {
        spectrum: "residual spectrum (test, Welch)",
        allan: "Allan deviation of the residual (test)",
        before: "first model",
        after: "final model",
        white_reference: true,
    };
    let p = &c.plots;
    let mut out = residual_plots(&c.channel, &p.residual, &captions)?;
    for (i, ov) in p.overlays.iter().enumerate() {
        let (fam, t, r, e) = (&ov.family, &ov.t_s, &ov.residual, &ov.effect);
        let plot = Plot {
            title: format!(
                "{}: effect {} ({fam}) over the residual before it",
                c.channel,
                i + 1
            ),
            x_label: "t (s)".into(),
            y_label: "residual".into(),
            log_x: false,
            log_y: false,
            series: vec![
                Series {
                    label: "residual before".into(),
                    x: t.clone(),
                    y: r.clone(),
                },
                Series {
                    label: format!("fitted {fam}"),
                    x: t.clone(),
                    y: e.clone(),
                },
            ],
        };
        out.push((
            format!("{}_effect{}_{fam}", c.channel, i + 1),
            render(&plot, 800, 480)?,
        ));
    }
    Ok(out)
}
