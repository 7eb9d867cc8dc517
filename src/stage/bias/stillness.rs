//! Stillness (zero-velocity) detector with hysteresis, judged against the sensor's own noise.
//!
//! Over a sliding window of the last N samples (fixed-size ring buffer, running sums recomputed
//! exactly once per window to cancel round-off drift) it computes
//!
//! ```text
//!   gyro_sd    = sqrt( sum_axes var_N(ω_a) )              rad/s    (vibration, changing rate)
//!   accel_sd   = sqrt( sum_axes var_N(f_a) )                m/s²     (road vibration, rotation of g)
//!   gyro_inst  = max_a | ω_k,a − mean_N(ω_a) | / σ_a        (onset of motion, per sample; σ_a the
//!   accel_inst = max_a | f_k,a − mean_N(f_a) | / σ_a         window's own, no lower than the floor's)
//!   gyro_mean  = | mean_N(ω_a) − b_a | per axis, in σ of the window mean (its lag-1
//!                autocorrelation accounted for) and of the bias estimate b_a
//!   accel_norm = | mean_N(|f|) − g |                       m/s²     (sustained acceleration)
//! ```
//!
//! **Thresholds follow the sensor.** The detector learns the *noise floor* of both triads as the
//! quietest windows it has seen (minimum statistics: the floor falls at once to a quieter window
//! and may rise by at most a factor 2 per `floor_rise_s`, so a warmer, noisier sensor is
//! followed while minutes of motion are not mistaken for noise). A window is a candidate when its
//! sds are within `noise_factor` of the floors, no sample of it leaves the window mean by more
//! than `instant_k` per-axis floor σ, and — once a confident bias estimate exists — its gyro mean
//! is within `mean_k` σ of that estimate (a slow constant turn has no variance). Nothing here is
//! a rate in rad/s that fits one sensor class: an ADIS16405 at rest (0.66 °/s three-axis sd) and
//! a foot-mounted MEMS at rest (0.04 °/s) are both still against their own floors.
//!
//! **No floor below the sensor's resolution.** A quantised channel whose noise is below its LSB
//! sits on one code at rest, or toggles one LSB: its quietest windows have an sd near 0, and the
//! minimum statistics would learn that, so that every ordinary rest window (dithered by the real
//! noise, ≈ LSB/√12 per axis) looks like motion. Each floor is therefore no lower than its
//! triad's quantisation noise, √(Σ_axes LSB²/12), with each channel's LSB learned as the grid its
//! values lie on ([`crate::stats::grid::grid_step`], on each full window with at least
//! `GRID_MIN_DIFFS` non-zero differences; the smallest such grid seen so far, since a window can
//! only show a whole multiple of the LSB). A channel on no grid (unquantised, or calibrated off
//! its grid) has LSB 0 and the floor is the learned one alone.
//!
//! The only
//! absolute numbers are plausibility ceilings no sensor at rest exceeds (`gyro_sd_max_rad_s`,
//! `accel_sd_max_m_s2`: a moving car's road vibration does), which keep a recording that never
//! rests from calling its quietest motion "still".
//!
//! **Steady turns.** A constant rate has no variance: after the onset, a turntable at 10 °/s is
//! as quiet as rest, and only the mean test (against a confident bias) tells them apart. For
//! `mean_veto_s` it vetoes rest; after that a quiet offset may be a bias that moved (a shock)
//! or a turn that goes on (a turntable, a robot turning in place, a slow pan). The detector
//! splits the disagreement d = mean − bias along and across the window's mean specific force
//! (gravity at rest, to within the accelerometer's offsets, `accel_norm_dev_max_m_s2` of g):
//! - *across* gravity a turn turns gravity in the accelerometer: by the integral of the
//!   offsets. Each window's mean specific force is compared with where it was 2–4 s earlier
//!   (`PATH_LAG_S`): staying there, or turned by the offsets' integral over that lag. Whichever
//!   prediction it has followed more closely (summed squared distances, the last
//!   `PATH_MEMORY_S` = 10 s weighing most) decides: a tilt held (a slow pan about a horizontal
//!   axis, too slow to raise the accelerometer's window sd), or the bias's. The path, not where
//!   gravity is now: a sway (a ship's roll) brings gravity back to where the veto began, and
//!   there the two predictions meet; and over a lag, not since the veto began: the integral
//!   carries the bias estimate's own error, which over minutes outgrows a small roll;
//! - *along* gravity it is ambiguous. It is taken for the bias only when no larger than the
//!   bias it departs from (|d∥| ≤ |b∥|): were it a turn, erasing it would leave an error no
//!   larger than the raw data's own bias — never worse than no preprocessing.
//!
//! A turn is held off (`features().turn_held`; not still) for as long as it lasts. Without all
//! three accelerometer axes no direction is across gravity, and the size bound holds per axis.
//! An offset on a *free* axis is the bias's whatever it is
//! ([`StillnessDetector::set_free_axes`]: the axis's model declares a step, no still measurement
//! has anchored its estimate yet — a model file's prior —, or its still measurements do not fit
//! its model, so that the estimate is no measured rest).
//!
//! The price: a bias that moves about the vertical by more than its own size without a
//! declared step is not re-learned (the estimate keeps its value; the raw data would carry the
//! whole bias). A turn slower than about `mean_k` σ of a window's mean (≈ 0.2 °/s for a gyro
//! of 0.3 °/s per-sample noise at 100 Hz) is within the mean test's noise, and the bias filter
//! takes it up at its own pace, as a bias. The veto counts over a quiet stretch, not per
//! offset: a sway's offsets use it up within seconds, and each later one is judged at once, so
//! a sway about gravity a few times the mean test's bound and no larger than the bias is
//! learned unevenly (docs/real-data.md, "A sway is neither rest nor bias", stop 42: why, and
//! the per-offset vetoes tried, which hid a wandering bias from the model-health monitor).
//!
//! Hysteresis: the detector enters STILL after `enter_after_s` of quiet windows free of motion
//! whose last is a candidate, and leaves at the first non-candidate (or non-finite) sample.
//! Motion is a held turn, or an offset beyond three times the mean test's bound that went away
//! before the veto lifted. A mean-test veto alone does not restart the run: a near-threshold
//! offset of coloured rest noise flickers, and an offset that outlasts the veto is the bias's (a
//! shock) and STILL at once. Motion does: a sway's zero crossings pass the mean test for a
//! moment, and with a run of quiet samples alone they were STILL at once (docs/real-data.md, "A
//! sway is neither rest nor bias"). This is the generalised-likelihood-
//! ratio ZUPT family (Skog et al., "Zero-velocity detection — an algorithm evaluation", IEEE
//! Trans. Biomed. Eng. 57(11), 2010) with separate, interpretable tests, and its noise level
//! learned instead of configured.

use nalgebra::{Rotation3, Vector3};

pub use super::settings::StillnessSettings;
use crate::stats::grid::grid_step_counted;

/// Longest window, samples (fixed-size ring buffer; 0.5 s up to 1 kHz).
pub const MAX_WINDOW: usize = 512;
/// Shortest window, samples (the default 0.5 s at 50 Hz). The floors are the quietest windows'
/// sds, and a window's three-axis sd of `n` samples has `3(n − 1)` degrees of freedom: with 5
/// samples (the default 0.5 s at 10 Hz: 12 of them) the quietest windows fall so far below the
/// typical one that ordinary rest windows often exceed `noise_factor` = 2 times the floor; with
/// 25 (72) they rarely do. A 10-Hz bench of 5 min at rest (white noise, replayed as a CSV) was
/// still for 3 s of it and its gyros never warmed up; with 25 samples, 98 % (docs/real-data.md).
pub const MIN_WINDOW: usize = 25;

/// The window features of the last sample (diagnostics; units as in the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StillnessFeatures {
    pub gyro_sd_rad_s: f64,
    /// Largest per-axis |mean − bias| in σ (NaN when no confident estimate was given).
    pub gyro_mean_sigma: f64,
    /// The rate of the steady turn held (the norm of the window's mean gyro minus the bias),
    /// rad/s; NaN when none is held.
    pub gyro_turn_rad_s: f64,
    /// A quiet window past `mean_veto_s` not taken for rest because its offset is a steady turn
    /// (module docs, "Steady turns").
    pub turn_held: bool,
    /// That turn turns gravity: the accelerometer saw it (else it is about gravity, or no
    /// gravity direction is known).
    pub turn_tilts: bool,
    /// Largest per-axis |sample − window mean| in the window's own per-axis σ (no lower than the
    /// floor's share).
    pub gyro_instant_sigma: f64,
    pub accel_sd_m_s2: f64,
    pub accel_norm_dev_m_s2: f64,
    pub accel_instant_sigma: f64,
    /// The learned noise floors (three-axis window sd), NaN before the first full window.
    pub gyro_floor_rad_s: f64,
    pub accel_floor_m_s2: f64,
    /// All tests passed on a full window.
    pub candidate: bool,
}

/// Memory of the steady-turn test's path evidence, s: long enough that a sway bringing gravity
/// back to where a veto began was seen moving (a ship's 10-s roll, a 60-s one), short enough
/// that minutes of rest before a tilt do not outvote it.
const PATH_MEMORY_S: f64 = 10.0;

/// Lag of the steady-turn test's path comparison, s: each window's mean specific force is
/// compared with where it was between `PATH_LAG_S` and twice that earlier (staying there, or
/// turned by the offsets' integral over the lag). Long enough that a turn at the mean test's
/// threshold (≈ 0.2 °/s) moves gravity by 0.4–0.8° (0.07–0.14 m/s², many times a window mean's
/// noise); short enough that the bias estimate's own error, integrated over the lag, stays a
/// small fraction of a degree (0.05 °/s × 4 s = 0.2°). Integrated from the start of a long veto
/// instead, that error grew without bound: after 150 s of a ±1.2° roll the predicted turn had
/// drifted further than the roll itself, the roll was taken for rest and its rate learned as
/// bias (docs/real-data.md, "A sway is neither rest nor bias").
const PATH_LAG_S: f64 = 2.0;

/// A quiet window whose gyro mean is beyond this many times `mean_k` σ from the bias, and whose
/// offset goes away before the mean test's veto lifts, was motion, not a near-threshold flicker
/// of coloured rest noise: the run towards STILL starts again when it goes. PX4's filtered gyro
/// at rest (`px4_sensor_combined_sample`) has 1,770 vetoed windows beyond `mean_k` σ, one
/// beyond twice it and none beyond three times (at twice, that one cost the drive 0.1 % of its
/// still share); a sway's peak rate is tens of σ.
const MOTION_MEAN_FACTOR: f64 = 3.0;

/// Number of window columns: gyro xyz, accel xyz, |accel|, gyro xyz lag-1 products.
const COLS: usize = 10;

/// Non-zero successive differences a window needs before its grid is taken for the channel's
/// LSB: 8 differences of an unquantised channel all within 1 % of whole multiples of the
/// smallest happen by chance with probability ~0.02^7 ≈ 1e-12; a quantised channel at rest
/// toggling its LSB shows 8 in a 0.5-s window or in a later one.
const GRID_MIN_DIFFS: usize = 8;

/// A point of the steady-turn test's path: the window's mean specific force (m/s²) and the
/// offsets' integral (rad) then.
#[derive(Debug, Clone, Copy, Default)]
struct PathPoint {
    f: [f64; 3],
    rot: [f64; 3],
}

/// Add (`sign = 1`) or remove (`sign = -1`) one window row to the running sums.
#[inline]
fn accumulate(sum: &mut [f64; COLS], sumsq: &mut [f64; COLS], row: &[f64; COLS], sign: f64) {
    for ((s, s2), v) in sum.iter_mut().zip(sumsq.iter_mut()).zip(row.iter()) {
        *s += sign * v;
        *s2 += sign * v * v;
    }
}

/// The detector (heap-free; ~14 KB inline).
#[derive(Debug, Clone)]
pub struct StillnessDetector {
    s: StillnessSettings,
    enter_samples: u64,
    buf: [[f64; COLS]; MAX_WINDOW],
    head: usize,
    filled: usize,
    since_recompute: usize,
    sum: [f64; COLS],
    sumsq: [f64; COLS],
    run: u64,
    still: bool,
    features: StillnessFeatures,
    /// Learned noise floors (NaN until the first full window) and their growth per sample.
    floor_g: f64,
    floor_a: f64,
    rise: f64,
    /// The previous sample's gyro (lag-1 products), NaN before the first.
    prev_g: [f64; 3],
    /// Quiet samples so far on which the mean test disagreed, and how many lift its veto.
    vetoed: u64,
    veto_samples: u64,
    /// The current veto has seen an offset beyond `MOTION_MEAN_FACTOR` × `mean_k` σ.
    moved: bool,
    /// Gyro axes free of the steady-turn rule ([`StillnessDetector::set_free_axes`]).
    free_axes: u8,
    /// The rotation vector (rad) the mean test's offsets have turned through since the current
    /// veto began, and the samples since then.
    veto_rot: [f64; 3],
    veto_n: u64,
    /// Path points `PATH_LAG_S` apart: `path_from` is compared with now, `path_next` takes its
    /// place at the next step (`path_lag` samples).
    path_from: PathPoint,
    path_next: PathPoint,
    path_lag: u64,
    /// Summed squared distances (m²/s⁴) of the window's mean specific force from
    /// `path_from.f` (rest: a bias that moved) and from it turned by the offsets' integral
    /// since (a turn), each sample's weight falling by 1/e in `PATH_MEMORY_S` (`path_keep` per
    /// sample).
    veto_sse_rest: f64,
    veto_sse_turn: f64,
    path_keep: f64,
    /// Sample interval, s.
    dt_s: f64,
    /// Window length, samples.
    window: usize,
    /// Each channel's LSB (gx gy gz ax ay az; 0 while none is known) and the quantisation noise
    /// of each triad, √(Σ LSB²/12), below which no floor falls (module docs).
    lsb: [f64; 6],
    quant_g: f64,
    quant_a: f64,
}

/// A steady turn the mean test's disagreement is taken for (module docs, "Steady turns").
#[derive(Debug, Clone, Copy, PartialEq)]
struct Turn {
    /// Its rate: the norm of the disagreement, rad/s.
    rate_rad_s: f64,
    /// It turns gravity: the accelerometer saw gravity turn with it.
    tilts: bool,
}

/// The window of `window_s` at `sample_rate_hz`, in samples (`MIN_WINDOW..=MAX_WINDOW`).
pub fn window_samples(window_s: f64, sample_rate_hz: f64) -> usize {
    let n = (window_s.max(0.0) * sample_rate_hz.max(0.0)).round();
    (n.min(MAX_WINDOW as f64) as usize).clamp(MIN_WINDOW, MAX_WINDOW)
}

impl StillnessDetector {
    /// A detector for a stream at `sample_rate_hz`. Settings must have passed validation; out of
    /// range values are clamped so that construction cannot fail.
    pub fn new(settings: &StillnessSettings, sample_rate_hz: f64) -> Self {
        let s = *settings;
        let window = window_samples(s.window_s, sample_rate_hz);
        let enter = (s.enter_after_s.max(0.0) * sample_rate_hz.max(0.0)).ceil();
        StillnessDetector {
            s,
            window,
            enter_samples: (enter as u64).max(1),
            buf: [[0.0; COLS]; MAX_WINDOW],
            head: 0,
            filled: 0,
            since_recompute: 0,
            sum: [0.0; COLS],
            sumsq: [0.0; COLS],
            run: 0,
            still: false,
            features: StillnessFeatures::default(),
            floor_g: f64::NAN,
            floor_a: f64::NAN,
            rise: (std::f64::consts::LN_2 / (s.floor_rise_s * sample_rate_hz.max(1e-6))).exp(),
            prev_g: [f64::NAN; 3],
            vetoed: 0,
            moved: false,
            veto_samples: ((s.mean_veto_s.max(0.0) * sample_rate_hz.max(0.0)).ceil() as u64).max(1),
            free_axes: 0,
            veto_rot: [0.0; 3],
            veto_n: 0,
            path_from: PathPoint::default(),
            path_next: PathPoint::default(),
            path_lag: ((PATH_LAG_S * sample_rate_hz.max(0.0)).ceil() as u64).max(1),
            veto_sse_rest: 0.0,
            veto_sse_turn: 0.0,
            path_keep: (-1.0 / (PATH_MEMORY_S * sample_rate_hz.max(1e-6))).exp(),
            dt_s: 1.0 / sample_rate_hz.max(1e-6),
            lsb: [0.0; 6],
            quant_g: 0.0,
            quant_a: 0.0,
        }
    }

    /// The learned noise floors (gyro rad/s, accel m/s², three-axis window sd); NaN before the
    /// first full window.
    pub fn floors(&self) -> (f64, f64) {
        (self.floor_g, self.floor_a)
    }

    /// Gyro axes (bit `a` for axis `a`) whose steady offset is taken for the bias after
    /// `mean_veto_s` whatever its size, even about gravity: the bias stage frees an axis whose
    /// model declares a step, whose estimate no still measurement has anchored yet (a model
    /// file's prior mean is no rest the sensor was seen at), or whose still measurements do not
    /// fit its model (mean ν²/S above 2 over rest that lasts 3 s: an unmodelled vibration
    /// line, a wrong noise level).
    pub fn set_free_axes(&mut self, mask: u8) {
        self.free_axes = mask & 0b111;
    }

    /// Whether the mean test's disagreement `d` (per axis, 0 where `dv` is 0: no reference;
    /// `dv` its variance; `gyro_ref` the bias it departs from), vetoed for `mean_veto_s`
    /// already, is a steady turn (module docs, "Steady turns"), judged with the window's mean
    /// specific force `f` now (gravity at rest). Across gravity a turn would have turned it
    /// along the path of the offsets' integral over `PATH_LAG_S` (`veto_sse_turn` against
    /// `veto_sse_rest`); along it, only the sizes can tell.
    /// Without all three accelerometer axes (`norm_on` false) every axis is judged by the sizes.
    fn turn_test(
        &self,
        gyro_ref: &[Option<(f64, f64)>; 3],
        d: &[f64; 3],
        dv: &[f64; 3],
        f: &[f64],
        norm_on: bool,
    ) -> Option<Turn> {
        let k = self.s.mean_k;
        let b = |a: usize| gyro_ref[a].map_or(0.0, |r| r.0);
        let has = |a: usize| dv[a] > 0.0;
        let off = |a: usize| has(a) && d[a].abs() > k * dv[a].sqrt();
        if (0..3).any(|a| off(a) && self.free_axes & (1 << a) != 0) {
            return None;
        }
        let rate_rad_s = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let g = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        if !norm_on || g <= 0.0 {
            // No gravity direction: any axis may be turning.
            let turn = (0..3).any(|a| off(a) && d[a].abs() > b(a).abs());
            return turn.then_some(Turn {
                rate_rad_s,
                tilts: false,
            });
        }
        let u = [f[0] / g, f[1] / g, f[2] / g];
        let (mut along, mut var, mut bias_along) = (0.0, 0.0, 0.0);
        for a in (0..3).filter(|a| has(*a)) {
            along += u[a] * d[a];
            var += u[a] * u[a] * dv[a];
            bias_along += u[a] * b(a);
        }
        // Gravity's direction is known to within the accelerometer's offsets (up to
        // `accel_norm_dev_max_m_s2` of g: `tilt`), and a turn about it reaches the other axes
        // by that much.
        let tilt = self.s.accel_norm_dev_max_m_s2 / self.s.gravity_m_s2;
        let across = (0..3)
            .filter(|a| has(*a))
            .any(|a| (d[a] - along * u[a]).abs() > k * dv[a].sqrt() + tilt * along.abs());
        if across {
            // Did gravity turn as the offsets over the lag would have turned it, or
            // stay? The prediction it followed more closely wins (a tilt of any size keeps
            // being predicted).
            let tilts = self.veto_sse_turn < self.veto_sse_rest;
            return tilts.then_some(Turn {
                rate_rad_s,
                tilts: true,
            });
        }
        let about_gravity =
            var > 0.0 && along.abs() > k * var.sqrt() && along.abs() > bias_along.abs();
        about_gravity.then_some(Turn {
            rate_rad_s,
            tilts: false,
        })
    }

    /// Each channel's learned LSB (gx gy gz ax ay az; 0 while none is known).
    pub fn lsb(&self) -> [f64; 6] {
        self.lsb
    }

    /// True while in the STILL state.
    pub fn is_still(&self) -> bool {
        self.still
    }

    /// Features of the last sample.
    pub fn features(&self) -> StillnessFeatures {
        self.features
    }

    /// Leave STILL and forget the window (e.g. after a long gap).
    pub fn reset(&mut self) {
        self.filled = 0;
        self.head = 0;
        self.sum = [0.0; COLS];
        self.sumsq = [0.0; COLS];
        self.since_recompute = 0;
        self.run = 0;
        self.vetoed = 0;
        self.moved = false;
        self.still = false;
    }

    fn recompute_sums(&mut self) {
        self.sum = [0.0; COLS];
        self.sumsq = [0.0; COLS];
        let n = self.window;
        for row in self.buf.iter().take(self.filled.min(n)) {
            accumulate(&mut self.sum, &mut self.sumsq, row, 1.0);
        }
        self.since_recompute = 0;
        if self.filled == n {
            self.learn_grid();
        }
    }

    /// Each channel's LSB from the full window (once per window, with the exact sums): the
    /// smallest grid seen on a window with `GRID_MIN_DIFFS` non-zero differences. The ring's
    /// order is kept but for its seam, whose difference lies on the same grid.
    fn learn_grid(&mut self) {
        let n = self.window;
        let mut col = [0.0; MAX_WINDOW];
        for c in 0..6 {
            for (v, row) in col.iter_mut().zip(self.buf.iter()).take(n) {
                *v = row[c];
            }
            let (q, diffs) = grid_step_counted(&col[..n]);
            if q > 0.0 && diffs >= GRID_MIN_DIFFS && (self.lsb[c] == 0.0 || q < self.lsb[c]) {
                self.lsb[c] = q;
            }
        }
        let quant = |l: &[f64]| (l.iter().map(|q| q * q).sum::<f64>() / 12.0).sqrt();
        self.quant_g = quant(&self.lsb[..3]);
        self.quant_a = quant(&self.lsb[3..]);
    }

    /// Feed one sample (calibrated gyro, rad/s; specific force, m/s²) with the current gyro bias
    /// estimate and its 1-σ for each axis that has one (`None` skips that axis in the mean
    /// test); returns the STILL state after this sample.
    #[inline]
    pub fn update(
        &mut self,
        gyro_rad_s: &[f64; 3],
        accel_m_s2: &[f64; 3],
        gyro_ref: &[Option<(f64, f64)>; 3],
    ) -> bool {
        self.update_present(gyro_rad_s, accel_m_s2, gyro_ref, 0)
    }

    /// [`StillnessDetector::update`] for a sensor without some channels: `absent` bit `c` for
    /// channel `c` (gx gy gz ax ay az). An absent axis takes no part in any test (it enters the
    /// window as a constant 0); a triad with no axis present casts no vote (its tests pass), and
    /// the gravity-norm test needs all three accel axes. With nothing present the sample is not
    /// still. `absent = 0` is exactly [`StillnessDetector::update`].
    #[inline]
    pub fn update_present(
        &mut self,
        gyro_rad_s: &[f64; 3],
        accel_m_s2: &[f64; 3],
        gyro_ref: &[Option<(f64, f64)>; 3],
        absent: u8,
    ) -> bool {
        let n = self.window;
        let on = |c: usize| absent & (1 << c) == 0;
        let gyro_on = absent & 0b000_111 != 0b000_111;
        let accel_on = absent & 0b111_000 != 0b111_000;
        let norm_on = absent & 0b111_000 == 0;
        if !(gyro_on || accel_on)
            || gyro_rad_s
                .iter()
                .chain(accel_m_s2.iter())
                .enumerate()
                .any(|(c, v)| on(c) && !v.is_finite())
        {
            self.run = 0;
            self.still = false;
            self.features.candidate = false;
            return false;
        }
        let keep = |c: usize, v: f64| if on(c) { v } else { 0.0 };
        let gyro_rad_s = &[
            keep(0, gyro_rad_s[0]),
            keep(1, gyro_rad_s[1]),
            keep(2, gyro_rad_s[2]),
        ];
        let accel_m_s2 = &[
            keep(3, accel_m_s2[0]),
            keep(4, accel_m_s2[1]),
            keep(5, accel_m_s2[2]),
        ];
        let norm = if norm_on {
            (accel_m_s2[0] * accel_m_s2[0]
                + accel_m_s2[1] * accel_m_s2[1]
                + accel_m_s2[2] * accel_m_s2[2])
                .sqrt()
        } else {
            0.0
        };
        // Lag-1 products (the first sample pairs with itself: it only biases ρ of the first
        // window, towards 1, i.e. towards caution).
        let lag = |a: usize| {
            let p = if self.prev_g[a].is_nan() {
                gyro_rad_s[a]
            } else {
                self.prev_g[a]
            };
            gyro_rad_s[a] * p
        };
        let row = [
            gyro_rad_s[0],
            gyro_rad_s[1],
            gyro_rad_s[2],
            accel_m_s2[0],
            accel_m_s2[1],
            accel_m_s2[2],
            norm,
            lag(0),
            lag(1),
            lag(2),
        ];
        self.prev_g = *gyro_rad_s;
        if self.filled == n {
            let old = self.buf[self.head];
            accumulate(&mut self.sum, &mut self.sumsq, &old, -1.0);
        } else {
            self.filled += 1;
        }
        self.buf[self.head] = row;
        accumulate(&mut self.sum, &mut self.sumsq, &row, 1.0);
        self.head = if self.head + 1 == n { 0 } else { self.head + 1 };
        self.since_recompute += 1;
        if self.since_recompute >= n {
            self.recompute_sums();
        }

        let inv = 1.0 / self.filled as f64;
        let mut mean = [0.0; COLS];
        let mut var = [0.0; COLS];
        for c in 0..COLS {
            mean[c] = self.sum[c] * inv;
            var[c] = (self.sumsq[c] * inv - mean[c] * mean[c]).max(0.0);
        }
        let gyro_sd = (var[0] + var[1] + var[2]).sqrt();
        let accel_sd = (var[3] + var[4] + var[5]).sqrt();
        let full = self.filled == n;
        if full && (!gyro_on || gyro_sd > 0.0) && (!accel_on || accel_sd > 0.0) {
            // Minimum statistics: fall at once, rise slowly.
            // Never below the triad's quantisation noise (module docs).
            if gyro_on {
                self.floor_g = if self.floor_g.is_nan() {
                    gyro_sd
                } else {
                    (self.floor_g * self.rise).min(gyro_sd)
                }
                .max(self.quant_g);
            }
            if accel_on {
                self.floor_a = if self.floor_a.is_nan() {
                    accel_sd
                } else {
                    (self.floor_a * self.rise).min(accel_sd)
                }
                .max(self.quant_a);
            }
        }
        // Per-axis σ: the window's own, no lower than the floor's share (a sample that leaves the
        // window's spread is an onset; a quiet window must not make ordinary noise look like
        // one).
        let ax_floor_g = self.floor_g * self.floor_g / 3.0;
        let ax_floor_a = self.floor_a * self.floor_a / 3.0;
        let dev = |a: usize, b: usize, floor2: f64| {
            (a..b)
                .filter(|c| on(*c))
                .map(|c| (row[c] - mean[c]).abs() / var[c].max(floor2).sqrt())
                .fold(0.0f64, f64::max)
        };
        // The window mean's variance, per axis: σ²/N inflated by (1+ρ)/(1−ρ) for the lag-1
        // autocorrelation ρ of the window (a sensor's own low-pass filter makes its noise
        // correlated, and σ²/N would then call rest a slow turn).
        let mut mean_sigma = f64::NAN;
        // Per axis: the disagreement d and its variance (both 0 for an axis without a reference).
        let mut d = [0.0; 3];
        let mut dv = [0.0; 3];
        for (a, r) in gyro_ref.iter().enumerate() {
            if let Some((b, sd)) = r {
                let v = var[a].max(ax_floor_g);
                let rho = ((mean[7 + a] - mean[a] * mean[a]) / v).clamp(0.0, 0.95);
                let mean_var = v * (1.0 + rho) / (1.0 - rho) / n as f64;
                d[a] = mean[a] - b;
                dv[a] = mean_var + sd * sd;
                let z = d[a].abs() / dv[a].sqrt();
                mean_sigma = if mean_sigma.is_nan() {
                    z
                } else {
                    mean_sigma.max(z)
                };
            }
        }
        let f = StillnessFeatures {
            gyro_sd_rad_s: gyro_sd,
            gyro_mean_sigma: mean_sigma,
            gyro_turn_rad_s: f64::NAN,
            turn_held: false,
            turn_tilts: false,
            gyro_instant_sigma: dev(0, 3, ax_floor_g),
            accel_sd_m_s2: accel_sd,
            accel_norm_dev_m_s2: (mean[6] - self.s.gravity_m_s2).abs(),
            accel_instant_sigma: dev(3, 6, ax_floor_a),
            gyro_floor_rad_s: self.floor_g,
            accel_floor_m_s2: self.floor_a,
            candidate: false,
        };
        let k = self.s.noise_factor;
        // A triad with no axis present casts no vote (its tests pass).
        let quiet = full
            && (!gyro_on
                || (f.gyro_sd_rad_s <= k * self.floor_g
                    && f.gyro_sd_rad_s <= self.s.gyro_sd_max_rad_s
                    && f.gyro_instant_sigma <= self.s.instant_k))
            && (!accel_on
                || (f.accel_sd_m_s2 <= k * self.floor_a
                    && f.accel_sd_m_s2 <= self.s.accel_sd_max_m_s2
                    && f.accel_instant_sigma <= self.s.instant_k))
            && (!norm_on || f.accel_norm_dev_m_s2 <= self.s.accel_norm_dev_max_m_s2);
        let mean_ok = f.gyro_mean_sigma.is_nan() || f.gyro_mean_sigma <= self.s.mean_k;
        if quiet {
            self.run = self.run.saturating_add(1);
            if !mean_ok {
                if self.vetoed == 0 {
                    self.veto_rot = [0.0; 3];
                    self.veto_n = 0;
                    self.path_from = PathPoint {
                        f: [mean[3], mean[4], mean[5]],
                        rot: [0.0; 3],
                    };
                    self.path_next = self.path_from;
                    self.veto_sse_rest = 0.0;
                    self.veto_sse_turn = 0.0;
                }
                self.vetoed = self.vetoed.saturating_add(1);
            }
            if self.vetoed > 0 {
                for (r, da) in self.veto_rot.iter_mut().zip(d) {
                    *r += da * self.dt_s;
                }
                self.veto_n += 1;
                if self.veto_n.is_multiple_of(self.path_lag) {
                    self.path_from = self.path_next;
                    self.path_next = PathPoint {
                        f: [mean[3], mean[4], mean[5]],
                        rot: self.veto_rot,
                    };
                }
                if norm_on {
                    let f0 = Vector3::from(self.path_from.f);
                    let f1 = Vector3::new(mean[3], mean[4], mean[5]);
                    let since = Vector3::from(self.veto_rot) - Vector3::from(self.path_from.rot);
                    let turned = Rotation3::new(-since) * f0;
                    let keep = self.path_keep;
                    self.veto_sse_rest = keep * self.veto_sse_rest + (f1 - f0).norm_squared();
                    self.veto_sse_turn = keep * self.veto_sse_turn + (f1 - turned).norm_squared();
                }
            }
        } else {
            self.run = 0;
            self.vetoed = 0;
        }
        // The mean test vetoes rest for `mean_veto_s` of otherwise perfect quiet; after that the
        // offset is taken for a bias that moved — unless it is a steady turn, held off for as
        // long as it lasts (module docs, "Steady turns").
        let expired = self.vetoed >= self.veto_samples;
        let turn = if quiet && !mean_ok && expired {
            self.turn_test(gyro_ref, &d, &dv, &mean[3..6], norm_on)
        } else {
            None
        };
        let candidate = quiet && (mean_ok || (expired && turn.is_none()));
        // Motion within a quiet stretch starts the run towards STILL again: a held turn, or an
        // offset beyond doubt that went away before the veto lifted (a bias that moved stays).
        // A sway's zero crossings pass the mean test for a moment, and were STILL at once while
        // the run counted quiet samples only.
        if quiet && !mean_ok && !expired && f.gyro_mean_sigma > MOTION_MEAN_FACTOR * self.s.mean_k {
            self.moved = true;
        }
        if turn.is_some() || (mean_ok && self.moved) {
            self.run = 0;
        }
        if !quiet || mean_ok || (expired && turn.is_none()) {
            self.moved = false;
        }
        self.features = StillnessFeatures {
            candidate,
            turn_held: turn.is_some(),
            turn_tilts: turn.is_some_and(|t| t.tilts),
            gyro_turn_rad_s: turn.map_or(f64::NAN, |t| t.rate_rad_s),
            ..f
        };
        self.still = candidate && self.run >= self.enter_samples;
        self.still
    }
}

#[cfg(test)]
mod tests;
