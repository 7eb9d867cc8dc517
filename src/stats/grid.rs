//! The grid a quantised channel's values lie on (its LSB), learned from the values themselves.
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
}
