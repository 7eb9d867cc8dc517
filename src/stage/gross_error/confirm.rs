//! Two-sided confirmation of a gross-error candidate: does the event break the signal around it,
//! by more than that signal's own roughness?
//!
//! The causal gate (`gate.rs`) only knows that a sample surprised the forecast. Real motion
//! surprises a forecast made at rest too (a knock, a hand starting to move), but it is
//! *continuous*: the samples after it carry on from it. A gross error is a break: the signal
//! around it joins up without it. With the samples before the event (`pre`, oldest first) and
//! after it (`post`), both at unit spacing from the event's ends:
//!
//! ```text
//!   p_k  = low-order least-squares polynomial through the nearest ≤ 3 samples each side, at the
//!          event's sample k (quadratic with ≥ 2 samples on each side, else a line)
//!   v_k  = gᵀ (AᵀA)⁻¹ g, g = (1, t_k, t_k²): the interpolation's variance factor
//!   σ̂    = white-noise-equivalent roughness of the context: the RMS of the centred second
//!          differences d_j = x_j − (x_{j−1} + x_{j+1})/2 over √1.5 (σ for white noise σ), the
//!          larger of the pre and post sides (a motion onset is rough after, not before)
//!   z_k  = (x_k − p_k) / (σ̂ √(1 + v_k))        ~ N(0, 1) for white noise
//!   e_in  = x_first − (2 x_{−1} − x_{−2})      the break at the event's start (a second
//!   e_out = x_last − (2 x_{+1} − x_{+2})        difference), and at its end, seen from after
//!   z_in, z_out = |e| / (σ̂ √6)                 ~ |N(0, 1)| for white noise
//!   z_ctx = max_j |d_j| / (σ̂ √1.5) over the context: its sharpest ordinary sample
//!   gross ⇔ median_k |z_k| ≥ max(confirm_k, ρ z_ctx)
//!          ∧ min(z_in, z_out) ≥ max(edge_k, ρ_e z_ctx / 2)
//!          ∧ (fewer than four samples ∨ max |Δ²| ≥ 0.45 max |x_k − p_k|)
//! ```
//!
//! Units of the two stand-out bars: a lone spike of height A has centred second difference A
//! (z_ctx counts it as A / (σ̂ √1.5)), interpolation residual A (z = A / (σ̂ √1.5) for one
//! sample: v = 0.5 with three points each side) and edge second differences A (z_in = A /
//! (σ̂ √6), half as many σ). So `ρ z_ctx` on z asks the event to be ρ times as high as the
//! sharpest ordinary sample, and `ρ_e z_ctx / 2` on the edges asks ρ_e times as high.
//! `edge_stand_out` ρ_e defaults to 4 (the edges' bar before it was a setting: ρ z_ctx with
//! ρ = 2, unaware of the units); ρ_e = ρ = 2 is the consistent bar, measured as a trade-off in
//! `docs/gross_error_results.md` (more injected errors caught, more real motion replaced).
//!
//! A context sample the caller left out (NaN: a neighbouring outlier) is skipped everywhere: in
//! the fit, in σ̂ and z_ctx, and in the edges, which then extrapolate linearly from the two
//! nearest finite samples among the three on that side (no two: no evidence of a break).
//!
//! The last line: a glitch run is a square or jagged pulse, its second differences as large as
//! its excursion; a real transient of four samples or more is smooth at the sample scale (a
//! half-sine of m samples has max |Δ²| = (π/(m+1))² of its height), whatever its size.
//!
//! ρ (`stand_out`) makes the test relative to the signal's own tails: real vibration and a
//! hand's motion are heavy-tailed at the sample scale (a few samples in a hundred at 4–8 σ̂), and
//! a glitch must stand out from the sharpest of them, while in a quiet, Gaussian stretch the
//! sharpest of ~20 samples is ~2.5 σ̂ and the fixed thresholds rule.
//!
//! The edge tests carry the decision for long events: a smooth motion the forecast missed for
//! ten samples sits far from any interpolation across those ten samples (its curvature is not
//! in the roughness scale), but it enters and leaves without a break. A gross error, single or a
//! run, breaks in and breaks out.
//!
//! On white noise, z is standard normal. A motion transient is confirmed only when it is sharper than the
//! roughness of the signal on *both* sides of it — which is exactly what "not physically
//! continuous with its surroundings" means at the sample scale. Weak evidence is no evidence:
//! the caller passes such events unchanged, flagged suspect.

/// Least jaggedness of a gross event of three samples or more (see [`Evidence::jaggedness`]).
pub(super) const JAGGED: f64 = 0.45;
/// Fewest samples on which the smoothness test judges an event (module docs: a half-sine of
/// three samples is as jagged as a glitch can be smooth). A shorter event's shape cannot tell
/// motion from a glitch; the stage then asks for the level test as well (`verdict.rs`).
pub const SMOOTH_MIN: usize = 4;
/// Points on each side used by the interpolation of an event of up to three samples.
const FIT_SIDE: usize = 3;
/// Most points on each side the interpolation of a run may use (see [`confirm_with`]).
pub const MAX_FIT_SIDE: usize = 10;

/// The thresholds of [`Evidence::gross`] (the settings of the same names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    pub confirm_k: f64,
    pub edge_k: f64,
    pub stand_out: f64,
    pub edge_stand_out: f64,
}

/// The outcome of the test for one event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// Median |z| over the event's samples.
    pub z_median: f64,
    /// The breaks at the event's start and end, in σ (module docs).
    pub z_in: f64,
    pub z_out: f64,
    /// The sharpest ordinary sample of the context, |d_j| / (σ̂ √1.5): what the event must
    /// stand out from.
    pub z_context: f64,
    /// The event's largest second difference (from the sample before it to the one after)
    /// over its largest residual: ~1 for a break (a spike, a square or jagged run), ≤ 0.39 for
    /// a smooth excursion of four samples or more (a half-sine of m samples gives (π/(m+1))²).
    pub jaggedness: f64,
    /// White-noise-equivalent roughness σ̂ of the context.
    pub sigma: f64,
}

/// |d_j| of consecutive values `x`, the largest tenth dropped (with ≥ 10 of them), sorted
/// ascending into `buf`; returns how many are kept and how many were dropped.
fn trimmed_d(x: &[f64], buf: &mut [f64; 128]) -> (usize, usize) {
    let mut n = 0;
    for w in x.windows(3) {
        let v = (w[1] - 0.5 * (w[0] + w[2])).abs();
        if v.is_finite() && n < buf.len() {
            buf[n] = v;
            n += 1;
        }
    }
    let drop = if n >= 10 { n / 10 } else { 0 };
    buf[..n].sort_unstable_by(f64::total_cmp);
    (n - drop, drop)
}

/// White-noise-equivalent scale of consecutive values `x` from their centred second
/// differences (module docs): their RMS / √1.5, the largest tenth left out (a missed glitch or
/// an undecided neighbour in the context must not set the scale) and the Gaussian consistency
/// factor put back; `None` with fewer than 3 finite values. An RMS, not a median: real motion
/// is heavy-tailed at the sample scale (a hand's jerks, a foot's impacts), and those tails
/// below the top tenth are the roughness an event must stand out from.
pub fn roughness(x: &[f64]) -> Option<f64> {
    let mut buf = [0.0f64; 128];
    let (n, drop) = trimmed_d(x, &mut buf);
    if n == 0 {
        return None;
    }
    let ms = buf[..n].iter().map(|v| v * v).sum::<f64>() / n as f64;
    // E[Z² | |Z| below its 90th percentile] = 0.6232 for a standard normal Z.
    let consistency = if drop > 0 { 1.0 / 0.6232 } else { 1.0 };
    Some((ms * consistency / 1.5).sqrt())
}

/// The sharpest ordinary |d_j| / √1.5 of consecutive values `x` (the largest tenth left out, as
/// in [`roughness`]; 0 with fewer than 3 values).
fn sharpest(x: &[f64]) -> f64 {
    let mut buf = [0.0f64; 128];
    let (n, _) = trimmed_d(x, &mut buf);
    if n == 0 {
        0.0
    } else {
        buf[n - 1] / 1.5f64.sqrt()
    }
}

/// White-noise-equivalent roughness of the context on both sides (the larger), floored.
fn context_sigma(pre: &[f64], post: &[f64], floor: f64) -> f64 {
    match (roughness(pre), roughness(post)) {
        (Some(a), Some(b)) => a.max(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => 0.0,
    }
    .max(floor)
}

/// Which of the event's samples to judge, `lead..keep`: its leading samples that continue
/// smoothly from the samples before it (each within `edge_k` σ of the forward extrapolation
/// from the two before), and its trailing ones that continue smoothly into the samples after it
/// (backward extrapolation from the next two), are not part of the break — the gate's trigger
/// can fire a sample early on noise, and its run hysteresis can carry an event a few samples
/// past the end of a gross error. At least one sample is kept.
pub fn trim(
    pre: &[f64],
    event: &[f64],
    post: &[f64],
    edge_k: f64,
    sigma_floor: f64,
) -> (usize, usize) {
    let m = event.len();
    if post.len() < 2 || pre.len() < 2 || m < 2 {
        return (0, m);
    }
    let sigma = context_sigma(pre, post, sigma_floor);
    let tol = edge_k * sigma * 6f64.sqrt();
    let np = pre.len();
    let at = |i: isize| -> f64 {
        if i < 0 {
            pre[(np as isize + i) as usize]
        } else if (i as usize) < m {
            event[i as usize]
        } else {
            post[i as usize - m]
        }
    };
    let smooth = |e: f64| e.is_finite() && e.abs() <= tol;
    let mut keep = m;
    while keep > 1
        && smooth(at(keep as isize - 1) - (2.0 * at(keep as isize) - at(keep as isize + 1)))
    {
        keep -= 1;
    }
    let mut lead = 0;
    while keep - lead > 1
        && smooth(at(lead as isize) - (2.0 * at(lead as isize - 1) - at(lead as isize - 2)))
    {
        lead += 1;
    }
    (lead, keep)
}

/// Least-squares polynomial through `(t, x)` points, of degree `deg` (1 or 2): returns the
/// inverse normal matrix and the coefficients; `None` if singular.
fn fit(pts: &[(f64, f64)], deg: usize) -> Option<([[f64; 3]; 3], [f64; 3])> {
    let m = deg + 1;
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for &(t, x) in pts {
        let g = [1.0, t, t * t];
        for i in 0..m {
            b[i] += g[i] * x;
            for j in 0..m {
                a[i][j] += g[i] * g[j];
            }
        }
    }
    let inv = invert(&a, m)?;
    let mut c = [0.0f64; 3];
    for i in 0..m {
        for j in 0..m {
            c[i] += inv[i][j] * b[j];
        }
    }
    Some((inv, c))
}

/// Inverse of the leading `m`×`m` block of `a` (m ≤ 3) by cofactors; `None` if singular.
#[allow(clippy::needless_range_loop)] // index arithmetic of the cofactors reads best as loops
fn invert(a: &[[f64; 3]; 3], m: usize) -> Option<[[f64; 3]; 3]> {
    let mut inv = [[0.0f64; 3]; 3];
    match m {
        2 => {
            let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
            if det.abs() < 1e-12 {
                return None;
            }
            inv[0][0] = a[1][1] / det;
            inv[0][1] = -a[0][1] / det;
            inv[1][0] = -a[1][0] / det;
            inv[1][1] = a[0][0] / det;
        }
        3 => {
            let c = |i: usize, j: usize| {
                let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
                let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
                a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]
            };
            let det = a[0][0] * c(0, 0) + a[0][1] * c(0, 1) + a[0][2] * c(0, 2);
            if det.abs() < 1e-12 {
                return None;
            }
            for i in 0..3 {
                for j in 0..3 {
                    inv[j][i] = c(i, j) / det;
                }
            }
        }
        _ => return None,
    }
    Some(inv)
}

/// Interpolate the event from its surroundings: `pre` (oldest first, ending just before the
/// event) and `post` (starting just after it); for each of the `event.len()` samples write the
/// interpolated value to `out`. Returns the evidence, or `None` when a side has no finite sample
/// or the context has no roughness to measure.
/// `sigma_floor` bounds σ̂ from below (a stuck or coarsely quantised context has no roughness,
/// yet a break in it is the clearest gross error there is).
pub fn confirm(
    pre: &[f64],
    event: &[f64],
    post: &[f64],
    sigma_floor: f64,
    out: &mut [f64],
) -> Option<Evidence> {
    confirm_with(pre, event, post, sigma_floor, FIT_SIDE, out)
}

/// [`confirm`] with the interpolation of an event of `m` samples fitted to the nearest
/// `clamp(m, 3, run_side)` samples on each side (`run_side` ≤ [`MAX_FIT_SIDE`]; 3 is
/// [`confirm`]). A longer gap needs a longer baseline: with three points a side the quadratic's
/// own variance factor v at a run's middle grows from 0.5 (one sample) to 1.7 (eight samples),
/// so a run of eight samples must be √(2.7/1.5) ≈ 1.3× as high as a spike to reach the same z;
/// with eight before and the four after it is 0.35.
pub fn confirm_with(
    pre: &[f64],
    event: &[f64],
    post: &[f64],
    sigma_floor: f64,
    run_side: usize,
    out: &mut [f64],
) -> Option<Evidence> {
    let m = event.len();
    if m == 0 || out.len() < m {
        return None;
    }
    let side_n = m.clamp(FIT_SIDE, run_side.clamp(FIT_SIDE, MAX_FIT_SIDE));
    // Points: pre at t = −1, −2, … before the event's first sample (t = 0 … m−1), post at m, m+1….
    let mut pts = [(0.0f64, 0.0f64); 2 * MAX_FIT_SIDE];
    let mut np = 0;
    let mut side = [0usize; 2];
    for (i, &x) in pre.iter().rev().take(side_n).enumerate() {
        if x.is_finite() {
            pts[np] = (-(i as f64) - 1.0, x);
            np += 1;
            side[0] += 1;
        }
    }
    for (i, &x) in post.iter().take(side_n).enumerate() {
        if x.is_finite() {
            pts[np] = ((m + i) as f64, x);
            np += 1;
            side[1] += 1;
        }
    }
    if side[0] == 0 || side[1] == 0 || pre.len() < 2 || post.len() < 2 {
        return None;
    }
    // Centre the abscissa on the event for conditioning.
    let centre = 0.5 * (m as f64 - 1.0);
    for p in pts[..np].iter_mut() {
        p.0 -= centre;
    }
    let deg = if side[0] >= 2 && side[1] >= 2 { 2 } else { 1 };
    let (inv, c) = fit(&pts[..np], deg)?;
    let sigma = context_sigma(pre, post, sigma_floor);
    if sigma.is_nan() || sigma <= 0.0 {
        return None;
    }
    let mut z = [0.0f64; 64];
    let n = m.min(z.len());
    for k in 0..m {
        let t = k as f64 - centre;
        let g = [1.0, t, t * t];
        let mut p = 0.0;
        let mut v = 0.0;
        for i in 0..=deg {
            p += c[i] * g[i];
            for j in 0..=deg {
                v += g[i] * inv[i][j] * g[j];
            }
        }
        out[k] = p;
        if k < n {
            let r = event[k] - p;
            // A non-finite event sample is as far off as it gets.
            z[k] = if r.is_finite() {
                (r / (sigma * (1.0 + v).sqrt())).abs()
            } else {
                f64::INFINITY
            };
        }
    }
    let z = &mut z[..n];
    let z_median = crate::stats::robust::median(z);
    // A non-finite event value breaks in as far as it gets; a side without two finite values
    // near the event gives no evidence of a break.
    let edge = |x: f64, p: f64| {
        if !x.is_finite() {
            f64::INFINITY
        } else if !p.is_finite() {
            0.0
        } else {
            ((x - p) / (sigma * 6f64.sqrt())).abs()
        }
    };
    let np = pre.len();
    let z_in = edge(event[0], extrapolate(pre.iter().rev()));
    let z_out = edge(event[m - 1], extrapolate(post.iter()));
    let z_context = sharpest(pre).max(sharpest(post)) / sigma;
    // Jaggedness: the largest |Δ²| along pre[last], event, post[0] over the largest residual.
    let mut seq = [0.0f64; 66];
    let ns = (m + 2).min(seq.len());
    seq[0] = pre[np - 1];
    seq[1..=m.min(64)].copy_from_slice(&event[..m.min(64)]);
    seq[ns - 1] = post[0];
    let max_d2 = seq[..ns]
        .windows(3)
        .map(|w| (w[0] - 2.0 * w[1] + w[2]).abs())
        .fold(0.0, f64::max);
    let max_r = (0..m.min(64))
        .map(|k| (event[k] - out[k]).abs())
        .fold(0.0, f64::max);
    let jaggedness = if max_r > 0.0 { max_d2 / max_r } else { 0.0 };
    Some(Evidence {
        z_median,
        z_in,
        z_out,
        z_context,
        jaggedness,
        sigma,
    })
}

/// Linear extrapolation to distance 0 from the two nearest finite values among the first three
/// of `side` (nearest first, at distances 1, 2, 3): `2 x₁ − x₂` when both are finite; NaN
/// without two.
fn extrapolate<'a>(side: impl Iterator<Item = &'a f64>) -> f64 {
    let mut got = [(0.0f64, 0.0f64); 2];
    let mut n = 0;
    for (i, &x) in side.take(3).enumerate() {
        if x.is_finite() {
            got[n] = ((i + 1) as f64, x);
            n += 1;
            if n == 2 {
                let ((da, a), (db, b)) = (got[0], got[1]);
                return a + (a - b) * da / (db - da);
            }
        }
    }
    f64::NAN
}

/// The first test of [`Evidence::gross`] an event fails, in the order the module docs list them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Rejection {
    /// median |z| < `confirm_k`: not off the interpolation by enough σ̂.
    Interpolation,
    /// median |z| ≥ `confirm_k` but < ρ z_ctx: not standing out from the sharpest ordinary sample.
    StandOut,
    /// The smaller edge break < `edge_k`.
    Edge,
    /// The smaller edge break ≥ `edge_k` but < ρ_e z_ctx / 2.
    EdgeStandOut,
    /// Four samples or more and smooth (jaggedness < 0.45): motion.
    Smooth,
}

impl Evidence {
    /// The event is a gross error at these thresholds (module docs): `len` samples long;
    /// `stand_out` ρ and `edge_stand_out` ρ_e as heights over the sharpest ordinary sample.
    pub fn gross(&self, len: usize, k: &Thresholds) -> bool {
        self.rejection(len, k).is_none()
    }

    /// The first test this `len`-sample event fails at these thresholds; `None` if it is a
    /// gross error ([`Evidence::gross`]).
    pub fn rejection(&self, len: usize, k: &Thresholds) -> Option<Rejection> {
        // An edge's z is half a centred second difference's for the same height (module docs).
        let edge = self.z_in.min(self.z_out);
        if self.z_median < k.confirm_k {
            Some(Rejection::Interpolation)
        } else if self.z_median < k.stand_out * self.z_context {
            Some(Rejection::StandOut)
        } else if edge < k.edge_k {
            Some(Rejection::Edge)
        } else if edge < 0.5 * k.edge_stand_out * self.z_context {
            Some(Rejection::EdgeStandOut)
        } else if len >= SMOOTH_MIN && self.jaggedness < JAGGED {
            // Four samples or more: a smooth excursion is motion, whatever its size.
            Some(Rejection::Smooth)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn roughness_of_white_noise_is_its_sigma() {
        // 2000 values: the MAD's relative sd is ~1.4 % here; 5 % bound.
        let mut r = Rng::new(3);
        let x: Vec<f64> = (0..62).map(|_| 0.7 * r.normal()).collect();
        let s = roughness(&x).unwrap();
        assert!((s / 0.7 - 1.0).abs() < 0.35, "{s}"); // 60 values: ~15 % sd, 0.35 bound
        let mut acc = 0.0;
        for k in 0..200 {
            let mut r = Rng::new(100 + k);
            let x: Vec<f64> = (0..62).map(|_| 0.7 * r.normal()).collect();
            acc += roughness(&x).unwrap();
        }
        assert!((acc / 200.0 / 0.7 - 1.0).abs() < 0.05, "{}", acc / 200.0);
    }

    #[test]
    fn a_line_and_a_parabola_are_interpolated_exactly() {
        let pre = [1.0, 2.0, 3.0];
        let post = [7.0, 8.0, 9.0];
        let mut out = [0.0; 3];
        // Context on a line with no roughness: no scale to judge by.
        assert!(confirm(&pre, &[4.0, 5.0, 6.0], &post, 0.0, &mut out).is_none());
        // Parabola x = t² with a little roughness added to the context.
        let f = |t: f64| t * t;
        let pre = [f(-3.0) + 0.01, f(-2.0) - 0.01, f(-1.0) + 0.01];
        let post = [f(2.0) + 0.01, f(3.0) - 0.01, f(4.0) + 0.01];
        let ev = [f(0.0), f(1.0)];
        let mut out = [0.0; 2];
        let e = confirm(&pre, &ev, &post, 0.0, &mut out).unwrap();
        assert!(
            (out[0] - 0.0).abs() < 0.02 && (out[1] - 1.0).abs() < 0.02,
            "{out:?}"
        );
        assert!(e.z_median < 3.0, "{e:?}");
    }

    #[test]
    fn the_edge_bar_counts_heights_in_edge_units() {
        // A spike 8 σ̂ high beside an ordinary sample 1.5 × 1.22 σ̂ high: z_in = z_out = 8/√6.
        let e = Evidence {
            z_median: 8.0 / 1.5f64.sqrt(),
            z_in: 8.0 / 6f64.sqrt(),
            z_out: 8.0 / 6f64.sqrt(),
            z_context: 1.5,
            jaggedness: 1.0,
            sigma: 1.0,
        };
        let k = |edge_stand_out| Thresholds {
            confirm_k: 6.0,
            edge_k: 2.5,
            stand_out: 2.0,
            edge_stand_out,
        };
        // z = 6.5 passes confirm_k = 6; the edges, 3.27 σ, meet ρ_e = 2 (bar 2.5 = edge_k) but
        // not ρ_e = 5 (bar 3.75); the default 4 asks 3.0.
        assert!(e.gross(1, &k(2.0)));
        assert!(e.gross(1, &k(4.0)));
        assert!(!e.gross(1, &k(5.0)));
        assert_eq!(e.rejection(1, &k(5.0)), Some(Rejection::EdgeStandOut));
    }

    #[test]
    fn the_rejection_names_the_first_test_failed() {
        let k = Thresholds {
            confirm_k: 6.0,
            edge_k: 2.5,
            stand_out: 2.0,
            edge_stand_out: 4.0,
        };
        // Passes every test: z 8 ≥ max(6, 2·1.5), edges 3.5 ≥ max(2.5, 4·1.5/2), jagged.
        let e = Evidence {
            z_median: 8.0,
            z_in: 3.5,
            z_out: 3.5,
            z_context: 1.5,
            jaggedness: 1.0,
            sigma: 1.0,
        };
        assert_eq!(e.rejection(4, &k), None);
        let with = |f: fn(&mut Evidence)| {
            let mut x = e;
            f(&mut x);
            x.rejection(4, &k)
        };
        assert_eq!(with(|x| x.z_median = 5.0), Some(Rejection::Interpolation));
        // z 8 < 2 · 4.5: the event does not stand out (nor do its edges; the first failure counts).
        assert_eq!(with(|x| x.z_context = 4.5), Some(Rejection::StandOut));
        assert_eq!(with(|x| x.z_out = 2.0), Some(Rejection::Edge));
        assert_eq!(with(|x| x.z_in = 2.8), Some(Rejection::EdgeStandOut));
        assert_eq!(with(|x| x.jaggedness = 0.3), Some(Rejection::Smooth));
        // A smooth event of three samples is not judged by its smoothness.
        let mut smooth = e;
        smooth.jaggedness = 0.3;
        assert_eq!(smooth.rejection(3, &k), None);
    }

    #[test]
    fn a_run_is_interpolated_from_a_baseline_as_long_as_it_is() {
        // Eight samples 7 σ high in seeded white noise (σ = 1), 16 samples before, the four
        // after that `post_samples` waits for. Three points a side give the quadratic a variance
        // factor ~1.7 at the run's middle, eight before and four after ~0.35: z_median grows by
        // √(2.7/1.35) ≈ 1.4 on average (the fit's own error scatters one draw's ratio by ~0.15).
        // Asserted over 200 seeds: mean ratio in 1.25..1.6.
        let mut acc = 0.0;
        for seed in 0..200 {
            let mut r = Rng::new(500 + seed);
            let x: Vec<f64> = (0..28).map(|_| r.normal()).collect();
            let run: Vec<f64> = x[16..24].iter().map(|v| v + 7.0).collect();
            let mut out = [0.0; 8];
            let three = confirm(&x[..16], &run, &x[24..], 0.0, &mut out).unwrap();
            let eight = confirm_with(&x[..16], &run, &x[24..], 0.0, 8, &mut out).unwrap();
            acc += eight.z_median / three.z_median;
        }
        let mean = acc / 200.0;
        assert!((1.25..1.6).contains(&mean), "{mean}");
        // A spike is judged on three points a side whatever `run_side` is.
        let mut r = Rng::new(9);
        let x: Vec<f64> = (0..24).map(|_| r.normal()).collect();
        let mut out = [0.0; 1];
        let a = confirm(&x[..16], &[x[16] + 9.0], &x[17..21], 0.0, &mut out).unwrap();
        let b = confirm_with(&x[..16], &[x[16] + 9.0], &x[17..21], 0.0, 10, &mut out).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn a_spike_in_noise_is_confirmed_and_a_smooth_bump_is_not() {
        let mut r = Rng::new(7);
        let x: Vec<f64> = (0..40).map(|_| r.normal()).collect();
        let mut out = [0.0; 1];
        // 12 σ spike at 20.
        let e = confirm(&x[4..20], &[x[20] + 12.0], &x[21..25], 0.0, &mut out).unwrap();
        assert!(e.z_median > 6.0, "{e:?}");
        // A smooth bump 30 σ high and 9 samples wide, the event being its top 3 samples: the
        // samples around it are rough with the bump itself.
        let bump: Vec<f64> = (0..40)
            .map(|i| {
                let u = (i as f64 - 20.0) / 4.5;
                x[i] * 0.1 + 30.0 * (-u * u).exp()
            })
            .collect();
        let mut out = [0.0; 3];
        let e = confirm(&bump[4..19], &bump[19..22], &bump[22..26], 0.0, &mut out).unwrap();
        assert!(e.z_median < 6.0, "{e:?}");
    }
}
