//! The signals and the driver shared by the detectors' unit tests (`step`, `wander`,
//! `whiteness`): a record at [`FS`], white noise with a first-order Gauss–Markov component.

use crate::rng::Rng;

/// Sample rate of the test records, Hz.
pub const FS: f64 = 100.0;

/// Feeds `xs` to `push` as samples `t0..` of a record at [`FS`]; the events it raised.
pub fn feed<E>(xs: &[f64], t0: usize, mut push: impl FnMut(u64, f64) -> Option<E>) -> Vec<E> {
    xs.iter()
        .enumerate()
        .filter_map(|(i, &x)| push(((t0 + i) as f64 / FS * 1e9) as u64, x))
        .collect()
}

/// Unit white noise plus a first-order Gauss–Markov (AR(1)) component of pole `phi` and
/// stationary sd `sd`.
pub fn coloured(r: &mut Rng, n: usize, phi: f64, sd: f64) -> Vec<f64> {
    let mut a = sd * r.normal();
    (0..n)
        .map(|_| {
            a = phi * a + sd * (1.0 - phi * phi).sqrt() * r.normal();
            r.normal() + a
        })
        .collect()
}

/// `n` samples of unit white noise.
pub fn white(r: &mut Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| r.normal()).collect()
}
