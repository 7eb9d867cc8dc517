//! The audit report as text: per recording its figures and injections, then the targets missed.

use super::AuditReport;
use crate::sample::CHANNEL_NAMES;

impl std::fmt::Display for AuditReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let config = match &self.config {
            None => "embedded default config".to_string(),
            Some(p) => format!("config {} over the embedded default", p.display()),
        };
        writeln!(f, "imuprep audit of {} ({config})", self.dir.display())?;
        for r in &self.recordings {
            writeln!(
                f,
                "\n## {} — {:?}, {} samples, {:.1} s at {:.2} Hz",
                r.name, r.class, r.samples, r.duration_s, r.rate_hz
            )?;
            writeln!(
                f,
                "still {:.1} %, bias engaged {:.1} % (first at {}), {} motion onsets (worst bias move {:.2} × 3σ)",
                100.0 * r.harm.still_share,
                100.0 * r.harm.bias_engaged_share,
                r.harm
                    .bias_first_engaged_s
                    .map_or("never".to_string(), |t| format!("{t:.1} s")),
                r.harm.onsets,
                r.harm.onset_worst_move_3sigma
            )?;
            writeln!(
                f,
                "| ch | replaced | per ch-sample | suspect | invented angle ° | ADEV worst out/raw/(1+1σ) | ADEV at longest τ |"
            )?;
            writeln!(f, "|---|---|---|---|---|---|---|")?;
            for (c, ch) in r.harm.channels.iter().enumerate() {
                let opt =
                    |v: Option<f64>, p: usize| v.map_or("–".to_string(), |v| format!("{v:.p$}"));
                writeln!(
                    f,
                    "| {} | {} | {:.1e} | {} | {} | {} | {} |",
                    CHANNEL_NAMES[c],
                    ch.replaced,
                    ch.replaced_rate,
                    ch.suspect,
                    opt(ch.invented_angle_deg, 3),
                    opt(ch.adev_worst_ratio, 3),
                    ch.adev_longest_change_pct
                        .map_or("–".to_string(), |v| format!("{v:+.1} %")),
                )?;
            }
            let seeds = seed_span(&r.seeds);
            if let (Some(k), Some(f1)) = (r.injected, r.injected_f1) {
                writeln!(
                    f,
                    "injected spikes and runs: F1 {f1:.4} ({seeds}: {} labelled channel-samples, {} missed, {} false; F1 per seed {})",
                    k.tp + k.fn_,
                    k.fn_,
                    k.fp,
                    range(&r.injected_f1_per_seed)
                )?;
            }
            if let (Some(k), Some(rc), Some(p)) = (
                r.contamination,
                r.contamination_recall,
                r.contamination_precision,
            ) {
                writeln!(
                    f,
                    "2 % gyro outliers: recall {rc:.4}, precision {p:.4} ({seeds}: {} outliers, {} missed, {} false; recall per seed {})",
                    k.tp + k.fn_,
                    k.fn_,
                    k.fp,
                    range(&r.contamination_recall_per_seed)
                )?;
            }
            writeln!(
                f,
                "bad values: {} injected, {} unflagged or non-finite in the output",
                r.bad_values_injected, r.bad_values_unflagged
            )?;
        }
        for s in &self.skipped {
            writeln!(f, "\n{s}")?;
        }
        let missed = self.missed();
        let total = self.targets().count();
        writeln!(f, "\ntargets: {} of {} met", total - missed.len(), total)?;
        for t in missed {
            writeln!(
                f,
                "  MISSED {} {}: {} = {} (limit {} {})",
                t.recording,
                t.channel,
                t.target,
                four_figures(t.measured),
                if t.at_most { "≤" } else { "≥" },
                t.limit
            )?;
        }
        Ok(())
    }
}

/// "seed 12" or "seeds 12–16 pooled".
fn seed_span(seeds: &[u64]) -> String {
    match seeds {
        [one] => format!("seed {one}"),
        // Consecutive seeds as a span; seeds that wrapped past u64::MAX are listed.
        [first, .., last] if last > first => format!("seeds {first}–{last} pooled"),
        [] => "no seed".to_string(),
        many => format!(
            "seeds {} pooled",
            many.iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// "0.9012–0.9378" (the smallest and largest), or the one value.
fn range(v: &[f64]) -> String {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if v.len() < 2 {
        format!("{lo:.4}")
    } else {
        format!("{lo:.4}–{hi:.4}")
    }
}

/// A measured value to four significant figures: fixed below 1e-2 would print a rate of
/// 1.17e-4 as 0.0001, which reads as meeting a limit of 1e-4.
fn four_figures(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-2 {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}
