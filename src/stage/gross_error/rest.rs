//! At rest the channel's level is known: an event the shape tests of `confirm.rs` let pass is
//! judged against it (`rest_k`, `verdict.rs`; measured in `docs/gross_error_results.md`, "At
//! rest: the event against the resting level").

use super::confirm::{JAGGED, SMOOTH_MIN, roughness};
use super::{MAX_CONTEXT, MAX_POST};
use crate::stats::robust::{median, sigma_from_abs_dev, upper_median};

/// Most context values [`at_rest`] reads (`context_samples` and `post_samples` at their most).
const MAX_CONTEXT_REST: usize = MAX_CONTEXT + MAX_POST;

/// A channel at rest around an event ([`at_rest`]): its level and the spread about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rest {
    pub level: f64,
    pub spread: f64,
    /// The MAD's σ alone (floored): the spread a few outliers in the context do not inflate.
    pub mad: f64,
}

impl Rest {
    /// |x − level| in spreads (a non-finite value is as far off as it gets).
    pub fn z(&self, x: f64) -> f64 {
        if x.is_finite() {
            (x - self.level).abs() / self.spread
        } else {
            f64::INFINITY
        }
    }

    /// |x − level| in the MAD's σ ([`Rest::mad`]): stricter where the context holds outliers
    /// (or is quantised), for judging whether another channel moved with an event.
    pub fn z_robust(&self, x: f64) -> f64 {
        if x.is_finite() {
            (x - self.level).abs() / self.mad
        } else {
            f64::INFINITY
        }
    }

    /// Median of [`Rest::z`] over `xs` (at most 64 of them; 0 for none).
    pub fn z_median(&self, xs: &[f64]) -> f64 {
        let mut z = [0.0f64; 64];
        let m = xs.len().min(z.len());
        if m == 0 {
            return 0.0;
        }
        for (o, &x) in z.iter_mut().zip(xs) {
            *o = self.z(x);
        }
        median(&mut z[..m])
    }

    /// `span` (the samples off the level, between `before` and `after`) is a break at rest: a
    /// median of at least `k` spreads off the level, and — four samples or more — as jagged as
    /// a glitch (the largest |Δ²| along before, span, after over the largest departure from
    /// the level, against [`JAGGED`] as the shape tests ask): a smooth excursion is motion at
    /// rest too (a yaw twitch moves no accelerometer).
    pub fn is_break(&self, before: f64, span: &[f64], after: f64, k: f64) -> bool {
        if span.is_empty() || self.z_median(span) < k {
            return false;
        }
        if span.len() < SMOOTH_MIN {
            return true;
        }
        let or_level = |v: f64| if v.is_finite() { v } else { self.level };
        let mut seq = [0.0f64; 66];
        let m = span.len().min(64);
        seq[0] = or_level(before);
        for (o, &x) in seq[1..=m].iter_mut().zip(span) {
            *o = or_level(x);
        }
        seq[m + 1] = or_level(after);
        let max_d2 = seq[..m + 2]
            .windows(3)
            .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
            .fold(0.0, f64::max);
        let max_r = seq[1..=m]
            .iter()
            .map(|x| (x - self.level).abs())
            .fold(0.0, f64::max);
        max_r > 0.0 && max_d2 / max_r >= JAGGED
    }
}

/// Is the channel at rest around an event (`rest_k` in `settings.rs`)? The context — `pre`
/// (at least 16 finite values with `post`) and `post` (at least 3) — is at rest when its spread
/// about its median is at most `ratio` times its white-noise-equivalent roughness (at rest the
/// two agree; a trend or a slow manoeuvre inflates the spread) and every sample after the event
/// is back within 3 spreads of that median. The spread is the larger of the MAD's σ and the RMS
/// about the median with the largest tenth left out (a quantised or low-passed context's MAD
/// can sit far below its sd), no lower than `floor`.
pub fn at_rest(pre: &[f64], post: &[f64], floor: f64, ratio: f64) -> Option<Rest> {
    let mut buf = [0.0f64; MAX_CONTEXT_REST];
    let mut n = 0;
    for &v in pre.iter().chain(post) {
        if v.is_finite() && n < buf.len() {
            buf[n] = v;
            n += 1;
        }
    }
    let n_post = post.iter().filter(|v| v.is_finite()).count();
    if n < 16 || n_post < 3 {
        return None;
    }
    let level = upper_median(&mut buf[..n]);
    for v in buf[..n].iter_mut() {
        *v = (*v - level).abs();
    }
    let mad = sigma_from_abs_dev(&mut buf[..n]);
    buf[..n].sort_unstable_by(f64::total_cmp);
    let kept = n - n / 10;
    // E[Z² | |Z| below its 90th percentile] = 0.6232 for a standard normal Z (as `roughness`).
    let rms = (buf[..kept].iter().map(|v| v * v).sum::<f64>() / kept as f64 / 0.6232).sqrt();
    let spread = mad.max(rms).max(floor);
    let rough = roughness(pre)?.max(floor);
    if spread.is_nan() || spread <= 0.0 || spread > ratio * rough {
        return None;
    }
    let rest = Rest {
        level,
        spread,
        mad: mad.max(floor).max(f64::MIN_POSITIVE),
    };
    post.iter()
        .all(|&v| !v.is_finite() || rest.z(v) <= 3.0)
        .then_some(rest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn at_rest_sees_a_spike_off_the_level_and_no_rest_in_a_ramp_or_an_onset() {
        // White noise of σ 1 about a level of 5: 32 samples before, 4 after, a 7σ spike.
        let mut r = Rng::new(7);
        let pre: Vec<f64> = (0..32).map(|_| 5.0 + r.normal()).collect();
        let post: Vec<f64> = (0..4).map(|_| 5.0 + r.normal()).collect();
        let rest = at_rest(&pre, &post, 0.0, 1.5).expect("at rest");
        // The median of 36 values: within 0.5 σ (its sd is ≈ 0.21 σ); the spread's own sampling
        // error (≈ 12 % at 36 values) within ±35 %, so the 7σ spike reads 4.9–10.
        assert!((rest.level - 5.0).abs() < 0.5, "{rest:?}");
        assert!((4.9..=10.0).contains(&rest.z_median(&[12.0])), "{rest:?}");
        assert_eq!(rest.z(f64::NAN), f64::INFINITY);
        // A ramp of 0.3 σ per sample: the spread about the median is ≈ 3× the roughness.
        let ramp: Vec<f64> = pre
            .iter()
            .enumerate()
            .map(|(i, v)| v + 0.3 * i as f64)
            .collect();
        let post_ramp: Vec<f64> = post
            .iter()
            .enumerate()
            .map(|(i, v)| v + 0.3 * (33 + i) as f64)
            .collect();
        assert_eq!(at_rest(&ramp, &post_ramp, 0.0, 1.5), None);
        // An onset: the samples after the event do not come back to the level.
        let moved: Vec<f64> = post.iter().map(|v| v + 8.0).collect();
        assert_eq!(at_rest(&pre, &moved, 0.0, 1.5), None);
        // Too little context, or too few samples after: no verdict.
        assert_eq!(at_rest(&pre[..10], &post, 0.0, 1.5), None);
        assert_eq!(at_rest(&pre, &post[..2], 0.0, 1.5), None);
    }
}
