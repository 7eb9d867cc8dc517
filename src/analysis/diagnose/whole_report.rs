//! Text and plots of the whole-log diagnosis ([`super::whole`]). The text lists exactly
//! the effects of the model file (`effects`), each with its span and held-out test, then every
//! candidate not kept with its reason, so report, summary and model file agree.

use super::report::{ResidualCaptions, effect_text, residual_plots};
use super::wander::WanderKind;
use super::whole::WholeDiagnosis;
use crate::analysis::line_plot::{Plot, Series, render};
use std::fmt::Write;

/// One line per kept effect: "family: parameters [span]".
pub fn effect_lines(d: &WholeDiagnosis) -> Vec<String> {
    d.effects
        .iter()
        .map(|e| {
            format!(
                "{} [{:.0}–{:.0} s]",
                effect_text(&e.effect),
                e.span_s[0],
                e.span_s[1]
            )
        })
        .collect()
}

/// Text block of one channel.
pub fn whole_text(d: &WholeDiagnosis) -> String {
    let mut o = String::new();
    let fs = d.sample_rate_hz;
    let b = &d.blocks;
    let _ = writeln!(
        o,
        "\n== {} ({} samples, {:.1} s at {:.2} Hz; {} blocks of {:.0} s, odd blocks held out)",
        d.channel,
        d.n,
        d.n as f64 / fs,
        fs,
        b.count,
        b.len as f64 / fs
    );
    if let Some(q) = &d.quantisation {
        match q.lsb {
            Some(l) => {
                let _ = writeln!(
                    o,
                    "  quantised: LSB {l:.4e} ({} distinct values); steps and temperature terms below 1 LSB are not kept",
                    q.distinct_values
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
    let r = &d.rail;
    if r.railed_high || r.railed_low {
        let _ = writeln!(
            o,
            "  SATURATION: {}{} (at max {}: {}×, next code {}×; at min {}: {}×, next code {}×)",
            if r.railed_high { "high rail " } else { "" },
            if r.railed_low { "low rail" } else { "" },
            r.max,
            r.at_max,
            r.next_to_max,
            r.min,
            r.at_min,
            r.next_to_min
        );
    } else {
        let _ = writeln!(
            o,
            "  no rail (largest value {:.4e} seen {}×, smallest {:.4e} seen {}×)",
            r.max, r.at_max, r.min, r.at_min
        );
    }
    let h = &d.held_out;
    let pct = |a: f64, b: f64| if a > 0.0 { 100.0 * (a - b) / a } else { 0.0 };
    let _ = writeln!(
        o,
        "  held-out error ({} samples): open-loop MSE {:.4e} → {:.4e} ({:.1} % lower); one-step MSE AR({}) {:.4e} → AR({}) {:.4e} ({:.1} % lower)",
        h.samples,
        h.open_loop_before,
        h.open_loop_after,
        pct(h.open_loop_before, h.open_loop_after),
        h.ar_order_before,
        h.one_step_before,
        h.ar_order_after,
        h.one_step_after,
        pct(h.one_step_before, h.one_step_after)
    );
    if d.effects.is_empty() {
        o.push_str("  model: no effect passed the held-out test\n");
    }
    for (e, line) in d.effects.iter().zip(effect_lines(d)) {
        let t = &e.test;
        let _ = writeln!(
            o,
            "  + {line}\n      held-out: MSE {:.4e} → {:.4e} ({:.2} % removed), z = {:.1}, p = {:.1e} < {:.1e}",
            t.mse_before,
            t.mse_after,
            100.0 * t.share_removed,
            t.z,
            t.p_value,
            t.level
        );
        if !e.track.is_empty() {
            let present: Vec<_> = e.track.iter().filter(|b| b.present).collect();
            let (lo, hi) = present
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |a, b| {
                    (a.0.min(b.freq_hz), a.1.max(b.freq_hz))
                });
            let _ = writeln!(
                o,
                "      tracked: present in {} of {} blocks, frequency {lo:.4}–{hi:.4} Hz",
                present.len(),
                e.track.len()
            );
        }
    }
    if let Some(w) = &d.wander {
        let what = match w.kind {
            WanderKind::GaussMarkov => format!(
                "Gauss-Markov, tau = {:.0} s, sigma (1-s means) = {:.3e}",
                w.tau_s, w.gm_sigma
            ),
            WanderKind::RandomWalk => format!("random walk, q = {:.3e} units²/s", w.rw_q_per_s),
            WanderKind::Undecided => format!(
                "Gauss-Markov (best tau = {:.0} s) or random walk: not told apart on this record",
                w.tau_s
            ),
        };
        let _ = writeln!(
            o,
            "  wander: {what}; 2(lnL_GM - lnL_RW) = {:.1}; held-out MSE of the 1-s means {:.4e} → {:.4e}, p = {:.1e}; {}",
            w.lr_gm_vs_rw,
            w.test.mse_before,
            w.test.mse_after,
            w.test.p_value,
            match (w.written, w.kind) {
                (true, WanderKind::RandomWalk) => "written as the rate random walk",
                (true, _) =>
                    "written as the bias process (ar_of = \"bias\": its AR(1) and white noise)",
                (false, WanderKind::Undecided) => "not written (GM or random walk: not told apart)",
                (false, _) => "not written (held-out test)",
            }
        );
    }
    for r in &d.rejected {
        let _ = writeln!(
            o,
            "  not kept: {} ({}): held-out MSE {:.4e} → {:.4e}, z = {:.1}: {}",
            r.family, r.description, r.mse_before, r.mse_after, r.z, r.reason
        );
    }
    o
}

/// SVG plots of one channel: (file stem, svg).
pub fn whole_plots(d: &WholeDiagnosis) -> Result<Vec<(String, String)>, String> {
    let captions = ResidualCaptions {
        spectrum: "open-loop residual spectrum (Welch)",
        allan: "Allan deviation of the open-loop residual (1-s means)",
        before: "intercept only",
        after: "with the effects",
        white_reference: false,
    };
    let mut out = residual_plots(&d.channel, &d.plots, &captions)?;
    for (i, e) in d
        .effects
        .iter()
        .enumerate()
        .filter(|(_, e)| !e.track.is_empty())
    {
        let pres: Vec<_> = e.track.iter().filter(|b| b.present).collect();
        if pres.is_empty() {
            continue;
        }
        let plot = Plot {
            title: format!("{}: line {} tracked per block", d.channel, i + 1),
            x_label: "t (s)".into(),
            y_label: "frequency (Hz)".into(),
            log_x: false,
            log_y: false,
            series: vec![Series {
                label: "frequency where present".into(),
                x: pres.iter().map(|b| b.t_s).collect(),
                y: pres.iter().map(|b| b.freq_hz).collect(),
            }],
        };
        out.push((
            format!("{}_line{}_track", d.channel, i + 1),
            render(&plot, 800, 480)?,
        ));
    }
    Ok(out)
}
