//! Static or moving: a recording classed by how evenly its gyro roughness is spread over 1-s
//! windows (the rule in the parent module's docs).

use serde::Serialize;

use crate::sample::{Channels, Sample};

/// Static or moving, decided from the data (the parent module's docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    Static,
    Moving,
}

/// Three-axis gyro sd of consecutive 1-s windows.
pub(super) fn window_gyro_sd(samples: &[Sample], rate_hz: f64) -> Vec<f64> {
    window_gyro_sd_by(samples.len(), rate_hz, |i, a| samples[i].gyro[a])
}

/// [`window_gyro_sd`] of `n` samples whose gyro axis `a` at sample `i` is `gyro(i, a)`.
fn window_gyro_sd_by(n: usize, rate_hz: f64, gyro: impl Fn(usize, usize) -> f64) -> Vec<f64> {
    let w = (rate_hz.round() as usize).max(10);
    (0..n / w)
        .map(|k| {
            let c = k * w..(k + 1) * w;
            let len = w as f64;
            (0..3)
                .map(|a| {
                    let m = c.clone().map(|i| gyro(i, a)).sum::<f64>() / len;
                    c.clone().map(|i| (gyro(i, a) - m).powi(2)).sum::<f64>() / len
                })
                .sum::<f64>()
                .sqrt()
        })
        .filter(|v| v.is_finite())
        .collect()
}

pub(super) fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// How unevenly a record's gyro roughness is spread: the 99th over the 1st percentile of the
/// three-axis gyro sd of its 1-s windows, the statistic [`classify`] calls static below 2.
/// `None` when it cannot tell: no gyro, or fewer than 10 whole windows.
pub fn gyro_roughness_ratio(samples: &[Sample], rate_hz: f64) -> Option<f64> {
    roughness_ratio(window_gyro_sd(samples, rate_hz))
}

/// [`gyro_roughness_ratio`] of a recording held by channel.
pub fn gyro_roughness_ratio_of(ch: &Channels, rate_hz: f64) -> Option<f64> {
    let g = &ch.values[..3];
    roughness_ratio(window_gyro_sd_by(ch.len(), rate_hz, |i, a| g[a][i]))
}

fn roughness_ratio(mut sd: Vec<f64>) -> Option<f64> {
    if sd.len() < 10 {
        return None;
    }
    let lo = percentile(&mut sd, 0.01);
    let hi = percentile(&mut sd, 0.99);
    Some(if hi == 0.0 { 1.0 } else { hi / lo })
}

/// Static or moving (the parent module's docs).
pub fn classify(samples: &[Sample], rate_hz: f64) -> Class {
    let mut sd = window_gyro_sd(samples, rate_hz);
    let lo = percentile(&mut sd, 0.01);
    let hi = percentile(&mut sd, 0.99);
    if hi < 2.0 * lo {
        Class::Static
    } else {
        Class::Moving
    }
}
