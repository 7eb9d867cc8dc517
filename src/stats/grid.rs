//! The grid a quantised channel's values lie on (its LSB), and the rails it was clipped at, learned
//! from the values themselves.
//!
//! A sensor that reports whole multiples of an LSB shows it in its successive differences: every
//! one is a whole number of steps. Both stages floor a noise estimate learned from a channel at
//! rest at that channel's quantisation noise, LSB/√12: the gross-error stage's confirmation scale
//! (`stage::gross_error::gate`) and the stillness detector's noise floors
//! (`stage::bias::stillness`). Without it a channel that sits on one code, or toggles one LSB,
//! reads as (nearly) noiseless, and every real rest looks like motion.

/// Share of a quantised channel's non-zero successive differences that must be whole multiples
/// of its smallest one: a quantised sensor's are all (its gross errors too); a non-quantised
/// channel's nearly none are.
const GRID_SHARE: f64 = 0.99;

/// The quantisation step of `x` (its LSB): the smallest non-zero |successive difference|, when
/// at least `GRID_SHARE` of the non-zero differences are whole multiples of it (within 1 % of a
/// step: values printed in decimal carry rounding far below that); else 0.
pub fn grid_step(x: &[f64]) -> f64 {
    grid_step_counted(x).0
}

/// [`grid_step`] and the number of non-zero successive differences it was judged on (a grid
/// read from a handful of differences can be chance: a caller may ask for more).
pub fn grid_step_counted(x: &[f64]) -> (f64, usize) {
    let diffs = || {
        x.windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .filter(|d| d.is_finite() && *d > 0.0)
    };
    let q = diffs().fold(f64::INFINITY, f64::min);
    if !q.is_finite() {
        return (0.0, 0);
    }
    let (mut n, mut on) = (0usize, 0usize);
    for d in diffs() {
        n += 1;
        let m = d / q;
        if (m - m.round()).abs() <= 0.01 {
            on += 1;
        }
    }
    if on as f64 >= GRID_SHARE * n as f64 {
        (q, n)
    } else {
        (0.0, n)
    }
}

/// Shortest run of one value at a channel's extreme that makes it a rail: a sensor holds its
/// full-scale code while the motion lies beyond it; an unclipped extreme is passed through.
pub const RAIL_RUN: usize = 3;
/// How far beyond the channel's median a rail lies, in its noise scale (the robust σ of its
/// successive differences over √2, floored at its LSB): a channel at rest that repeats its top
/// code is no rail.
const RAIL_FAR: f64 = 10.0;

/// A rail a channel held: the value and how often it held it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rail {
    pub value: f64,
    /// Samples on it, and runs of at least [`RAIL_RUN`] of them that the signal came to and left.
    pub samples: usize,
    pub runs: usize,
}

/// The rails of `x` (finite values; others ignored), top and bottom: its largest (smallest)
/// value, when it lies beyond zero on its side, the channel came to it and held it for at least
/// [`RAIL_RUN`] samples in a row before leaving it (a run inside the record), more samples lie
/// on it than on the code next to it (a pile-up at a clip, not the end of a tail; a channel
/// with no LSB has no next code), and it lies [`RAIL_FAR`] noise scales beyond the median.
pub fn rails(x: &[f64]) -> [Option<Rail>; 2] {
    let v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.len() < 2 * RAIL_RUN {
        return [None, None];
    }
    let lsb = grid_step(&v);
    let diffs: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
    let scale = (crate::stats::robust::robust_sigma(&diffs) / std::f64::consts::SQRT_2).max(lsb);
    let median = crate::stats::robust::median(&mut v.clone());
    let top = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bottom = v.iter().copied().fold(f64::INFINITY, f64::min);
    let rail = |edge: f64, inward: f64| -> Option<Rail> {
        // A full scale lies beyond zero on its side (a constant pre-roll of zeros below a
        // gyro's bias is the smallest value, held, but no rail), and far from the median.
        if edge * inward >= 0.0 || (edge - median).abs() <= RAIL_FAR * scale {
            return None;
        }
        let samples = v.iter().filter(|&&y| y == edge).count();
        let next = if lsb > 0.0 {
            let code = edge + inward * lsb;
            v.iter().filter(|&&y| (y - code).abs() < 0.5 * lsb).count()
        } else {
            0
        };
        // Runs the signal came to and left: a value a logger writes before the sensor starts
        // (or after it stops) is held at the file's edge, not reached.
        let (mut runs, mut len) = (0, 0);
        for (i, &y) in v.iter().enumerate() {
            if y == edge {
                len += 1;
            } else {
                if len >= RAIL_RUN && len < i {
                    runs += 1;
                }
                len = 0;
            }
        }
        (runs > 0 && samples > next).then_some(Rail {
            value: edge,
            samples,
            runs,
        })
    };
    [rail(top, -1.0), rail(bottom, 1.0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_step_finds_a_quantised_channels_lsb_and_no_other() {
        // The ADIS16405's accelerometer LSB (3.33 mg) in m/s², on seeded white noise of 1 LSB:
        // every difference is a whole number of steps, the smallest one step.
        let lsb = 0.00333 * 9.80665;
        let noise = crate::rng::normal_vec(2000, 3);
        let q: Vec<f64> = noise.iter().map(|v| v.round() * lsb + 9.8).collect();
        let g = grid_step(&q);
        assert!((g / lsb - 1.0).abs() < 1e-9, "{g}");
        // Unquantised noise lies on no grid; nor does a constant (no difference at all).
        assert_eq!(grid_step(&noise), 0.0);
        assert_eq!(grid_step(&[1.0; 50]), 0.0);
        // 2 % off-grid values (a processed stretch) are more than GRID_SHARE allows.
        let mut m = q.clone();
        for v in m.iter_mut().step_by(50) {
            *v += 0.37 * lsb;
        }
        assert_eq!(grid_step(&m), 0.0);
    }

    #[test]
    fn a_rail_is_a_held_pile_up_at_an_extreme_far_from_the_median() {
        // A quantised gyro (LSB 1e-3, noise 13 LSB) at rest, with three half-sine turns to 2.0
        // clipped at the top code 1.5: the top is a rail (held 3 times), the bottom is not
        // (an unclipped extreme, reached once).
        let lsb = 1e-3;
        let noise = crate::rng::normal_vec(30_000, 7);
        let mut x: Vec<f64> = noise.iter().map(|n| 0.013 * n).collect();
        for k in 0..3 {
            for j in 0..300 {
                let s = (std::f64::consts::PI * j as f64 / 300.0).sin();
                x[5000 + 8000 * k + j] += 2.0 * s;
                x[9000 + 8000 * k + j] -= 0.5 * s;
            }
        }
        let q: Vec<f64> = x
            .iter()
            .map(|v| ((v / lsb).round() * lsb).min(1.5))
            .collect();
        let [top, bottom] = rails(&q);
        let top = top.expect("the clip is a rail");
        assert_eq!(top.value, 1.5);
        assert_eq!(top.runs, 3);
        assert!(bottom.is_none(), "{bottom:?}");
        // At rest only, nothing: a channel quieter than its LSB repeats its top code in runs,
        // and piles on it when the level lies nearer it, but that code is the median's neighbour.
        let rest: Vec<f64> = noise
            .iter()
            .map(|n| ((0.6 + 0.3 * n).round()) * lsb)
            .collect();
        assert_eq!(rails(&rest), [None, None]);
        // A constant channel has no rail; nor has unquantised motion that reaches its extreme
        // once.
        assert_eq!(rails(&[0.25; 100]), [None, None]);
        // A logger's pre-roll, held before the sensor starts: zeros below a gyro whose bias
        // (0.5) is 40 times its noise, or a sentinel beyond its values, at the file's start.
        let mut pre: Vec<f64> = noise
            .iter()
            .map(|n| ((0.5 + 0.013 * n) / lsb).round() * lsb)
            .collect();
        pre[..200].fill(0.0);
        assert_eq!(rails(&pre), [None, None]);
        pre[..200].fill(-1.0);
        assert_eq!(rails(&pre), [None, None]);
        let smooth: Vec<f64> = (0..5000).map(|i| (i as f64 * 0.01).sin() * 3.0).collect();
        assert_eq!(rails(&smooth), [None, None]);
    }
}
