//! The do-no-harm score of one pipeline run ([`HarmScore`]): replacements, invented angle, the bias across
//! motion onsets and, on a static recording, bias engagement and Allan deviation.

use super::class::{percentile, window_gyro_sd};
use super::{ChannelFigures, Class, HarmScore, TargetRow};
use crate::analysis::allan::overlapping_adev;
use crate::sample::{CHANNEL_NAMES, Sample, flags};

/// Score `out`, the pipeline's output for `raw` (same samples, same order), against the
/// do-no-harm targets of a `class` recording sampled at `rate` Hz; what `audit_recording`
/// measures before its injections.
pub fn score_harm(
    name: &str,
    class: Class,
    rate: f64,
    raw: &[Sample],
    out: &[Sample],
) -> HarmScore {
    let n = raw.len().min(out.len());
    let duration_s = if n > 0 {
        raw[n - 1].t_s() - raw[0].t_s()
    } else {
        0.0
    };
    let mut targets = Vec::new();
    let mut target = |channel: &str, what: &str, measured: f64, limit: f64, at_most: bool| {
        targets.push(TargetRow::new(
            name, channel, what, measured, limit, at_most,
        ));
    };

    // Replacements, suspects, invented angle.
    let max_dt = 5.0 / rate;
    let mut channels = Vec::new();
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let bit = flags::replaced_ch(c);
        let replaced = out.iter().filter(|s| s.flags & bit != 0).count() as u64;
        let suspect = out
            .iter()
            .filter(|s| s.flags & flags::suspect_ch(c) != 0)
            .count() as u64;
        let invented = (c < 3).then(|| {
            let mut acc = 0.0;
            for i in 1..n {
                let dt = ((out[i].t_ns as f64 - out[i - 1].t_ns as f64) * 1e-9).clamp(0.0, max_dt);
                let d = out[i].channel(c) - raw[i].channel(c) + f64::from(out[i].bias[c]);
                if d.is_finite() {
                    acc += d * dt;
                }
            }
            acc.abs().to_degrees()
        });
        let rate_c = replaced as f64 / n as f64;
        target(name, "replaced per channel-sample", rate_c, 1e-4, true);
        if let Some(a) = invented {
            target(name, "invented angle, deg", a, 0.5, true);
        }
        channels.push(ChannelFigures {
            replaced,
            replaced_rate: rate_c,
            suspect,
            invented_angle_deg: invented,
            adev_worst_ratio: None,
            adev_longest_change_pct: None,
        });
    }

    // Bias engagement and motion onsets.
    let engaged = |s: &Sample| s.bias_subtracted() && !s.has(flags::WARMING_UP);
    let n_engaged = out.iter().filter(|s| engaged(s)).count();
    let bias_first_engaged_s = out
        .iter()
        .position(engaged)
        .map(|i| out[i].t_s() - out[0].t_s());
    let still_share = out.iter().filter(|s| s.has(flags::STILL)).count() as f64 / n as f64;
    let w2 = (2.0 * rate).round() as usize;
    let mut onsets = 0;
    let mut worst_onset: f64 = 0.0;
    // A motion onset, independently of the detector: within 1 s after it a 1-s window of the raw
    // gyro is at least 3× as rough (three-axis sd) as the recording's quietest windows.
    let sd_1s = window_gyro_sd(raw, rate);
    let quiet = percentile(&mut sd_1s.clone(), 0.01);
    let w1 = (rate.round() as usize).max(10);
    let moving_after =
        |i: usize| (i / w1..=(i + w1) / w1).any(|k| sd_1s.get(k).is_some_and(|v| *v > 3.0 * quiet));
    for i in 1..n {
        if out[i - 1].has(flags::STILL)
            && !out[i].has(flags::STILL)
            && i > w2
            && i + w2 < n
            && moving_after(i)
        {
            // Only an estimate that existed before the onset can be moved by it.
            if !(engaged(&out[i - w2]) && out[i - w2].bias_sd[..3].iter().all(|v| *v > 0.0)) {
                continue;
            }
            onsets += 1;
            for c in 0..3 {
                let b0 = f64::from(out[i - w2].bias[c]);
                for s in &out[i - w2..=i + w2] {
                    let sd = f64::from(s.bias_sd[c]);
                    let mv = (f64::from(s.bias[c]) - b0).abs();
                    if sd > 0.0 && engaged(s) {
                        worst_onset = worst_onset.max(mv / (3.0 * sd));
                    }
                }
            }
        }
    }
    if onsets > 0 {
        target(
            "gyro",
            "bias move across a motion onset / own 3σ",
            worst_onset,
            1.0,
            true,
        );
    }
    let bias_engaged_share = n_engaged as f64 / n as f64;
    if class == Class::Static {
        target(
            "gyro",
            "bias engaged, share",
            bias_engaged_share,
            0.95,
            false,
        );
        target(
            "gyro",
            "bias engaged after, s",
            bias_first_engaged_s.unwrap_or(f64::INFINITY),
            60.0,
            true,
        );
        // Allan deviation, output against raw, from the first sample with a running estimate
        // on: removing a turn-on bias is a step from 0 to the bias, the stage doing its job, not
        // noise it adds.
        let from = out.iter().position(engaged).unwrap_or(n);
        let span_s = if from < n {
            out[n - 1].t_s() - out[from].t_s()
        } else {
            0.0
        };
        for (c, fig) in channels.iter_mut().enumerate() {
            if n - from < 1000 {
                break;
            }
            let x: Vec<f64> = raw[from..].iter().map(|s| s.channel(c)).collect();
            let y: Vec<f64> = out[from..].iter().map(|s| s.channel(c)).collect();
            if x.iter().chain(&y).any(|v| !v.is_finite()) {
                continue;
            }
            let a = overlapping_adev(&x, rate);
            let b = overlapping_adev(&y, rate);
            let mut worst: f64 = 0.0;
            let mut longest = None;
            for i in 0..a.tau_s.len().min(b.tau_s.len()) {
                let k = (span_s / a.tau_s[i]).floor();
                if k < 2.0 {
                    break;
                }
                let one_sigma = 1.0 / (2.0 * (k - 1.0)).sqrt();
                worst = worst.max(b.adev[i] / a.adev[i] / (1.0 + one_sigma));
                if k >= 9.0 {
                    longest = Some(100.0 * (b.adev[i] / a.adev[i] - 1.0));
                }
            }
            fig.adev_worst_ratio = Some(worst);
            fig.adev_longest_change_pct = longest;
            target(
                CHANNEL_NAMES[c],
                "ADEV out/raw / (1 + 1σ), worst τ",
                worst,
                1.0,
                true,
            );
            if c < 3
                && duration_s >= 3600.0
                && let Some(l) = longest
            {
                target(
                    CHANNEL_NAMES[c],
                    "ADEV change at the longest τ (≥ 9 clusters), %",
                    l,
                    -50.0,
                    true,
                );
            }
        }
    }

    HarmScore {
        channels,
        bias_engaged_share,
        bias_first_engaged_s,
        still_share,
        onsets,
        onset_worst_move_3sigma: worst_onset,
        targets,
    }
}
