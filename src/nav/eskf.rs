//! A loosely coupled GNSS/INS error-state extended Kalman filter (15 states, or 21 with a
//! Gauss–Markov bias augmentation).
//!
//! **Mechanisation** — local-level NED frame, curvilinear position (Groves, *Principles of GNSS,
//! Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., §5.4, simplified as
//! allowed there for a consumer-grade IMU at ≤ 100 Hz):
//! * attitude `C_b^n(+) = R(−ω_in^n Δt) · C_b^n(−) · R(ω_ib^b Δt)` with `R` the exact rotation of a
//!   rotation vector, `ω_in^n = ω_ie^n + ω_en^n` (Earth rate plus transport rate);
//! * velocity `v(+) = v(−) + (C̄ f^b + g^n − (2ω_ie^n + ω_en^n) × v(−)) Δt`, `C̄` the mean of the old
//!   and new attitude, `g^n = (0, 0, g(L, h))` the normal gravity of [`super::earth::gravity`];
//! * position by the trapezoidal rule on latitude, longitude and height with the radii of
//!   curvature.
//!
//! **Error state** `x = [ψ, δv, δr, δb_a, δb_g (, δm_a, δm_g)]`, every error *true minus
//! estimate*: the true attitude is `(I + [ψ×]) Ĉ_b^n`, `δr` is the position error in NED metres.
//! Its continuous-time dynamics (Groves §14.2, the NED forms, keeping the terms that matter over
//! a one-minute outage at car speed):
//!
//! ```text
//!   ψ̇  = −[ω_in^n ×] ψ − Ĉ (δb_g + δm_g) − Ĉ w_g
//!   δv̇ = −[f^n ×] ψ − [(2ω_ie^n + ω_en^n) ×] δv + (0, 0, 2g/R·δr_D) − Ĉ (δb_a + δm_a) − Ĉ w_a
//!   δṙ = δv
//!   δḃ = w_b               (bias: random walk)
//!   δṁ = −δm / T_c + w_m   (optional first-order Gauss–Markov part, stationary σ_m:
//!                           PSD of w_m = 2σ_m²/T_c)
//! ```
//!
//! discretised as `Φ = I + FΔt`, `Q_k = S Δt` (Groves 3.44/14.82 to first order). Updates in the
//! Joseph form; closed-loop correction after each (the error state is reset to zero).
//!
//! **Measurements**: GNSS antenna position (with the lever arm `l^b`: `r_a = r + Ĉ l^b`, so
//! `δr_a = δr − [(Ĉ l^b)×] ψ`) and NED velocity, each axis with its own σ; a zero-velocity and
//! zero-angular-rate update (ZUPT/ZARU) after `window` consecutive still epochs; a one-time yaw
//! alignment to the GNSS course once the speed exceeds a threshold (heading is unobservable
//! before the vehicle moves).

use super::earth::{self, euler_to_ctm, rotation, skew};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// Indices of the error-state blocks.
pub mod idx {
    pub const ATT: usize = 0;
    pub const VEL: usize = 3;
    pub const POS: usize = 6;
    pub const BA: usize = 9;
    pub const BG: usize = 12;
    /// Gauss–Markov accelerometer part (augmented filter only).
    pub const MA: usize = 15;
    /// Gauss–Markov gyro part (augmented filter only).
    pub const MG: usize = 18;
}

/// Continuous-time noise of the IMU (SI).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ImuNoise {
    /// Gyro white noise (angle random walk), rad/s/√Hz.
    pub gyro_psd: f64,
    /// Accelerometer white noise (velocity random walk), m/s²/√Hz.
    pub accel_psd: f64,
    /// Gyro bias random walk, rad/s/√s.
    pub gyro_bias_rw: f64,
    /// Accelerometer bias random walk, m/s²/√s.
    pub accel_bias_rw: f64,
}

/// A first-order Gauss–Markov process: stationary σ and correlation time.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GaussMarkov {
    pub sigma: f64,
    pub tc_s: f64,
}

/// Shortest correlation time a Gauss–Markov bias part may have, s. GNSS arrives every 0.25 s
/// (4 Hz): a part that decorrelates within a few GNSS intervals cannot be told from the white
/// noise the filter already carries (angle / velocity random walk), and its transition
/// `Φ = 1 − Δt/T_c` needs `T_c ≫ Δt` (T_c → 0 makes it diverge). 1 s = 4 GNSS intervals, 100
/// IMU epochs at 100 Hz. A shorter T_c comes from a bad fit (an Allan curve without a minimum,
/// an AR pole near zero), not from the sensor.
pub const MIN_GM_TC_S: f64 = 1.0;

impl GaussMarkov {
    /// `Err(why)` when the part cannot be a bias process: σ not finite and positive, or T_c not
    /// finite or below [`MIN_GM_TC_S`].
    pub fn check(&self) -> Result<(), String> {
        if !(self.sigma.is_finite() && self.sigma > 0.0) {
            return Err(format!("σ {:e} is not finite and positive", self.sigma));
        }
        if !(self.tc_s.is_finite() && self.tc_s >= MIN_GM_TC_S) {
            return Err(format!(
                "T_c {:e} s is not a finite correlation time of at least {MIN_GM_TC_S} s",
                self.tc_s
            ));
        }
        Ok(())
    }
}

/// Bias augmentation: a Gauss–Markov part per axis on top of the random-walk bias. `None` on
/// an axis: no Gauss–Markov part there — its state is held at zero (no initial σ, no noise),
/// so that axis's bias is the random walk alone.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BiasAugmentation {
    pub accel: [Option<GaussMarkov>; 3],
    pub gyro: [Option<GaussMarkov>; 3],
}

impl BiasAugmentation {
    /// Every part that fails [`GaussMarkov::check`] replaced by `None` (random walk only);
    /// returns the refused parts as (axis name, why), axes `ax ay az gx gy gz` (filter axes).
    pub fn guarded(&self) -> (BiasAugmentation, Vec<(String, String)>) {
        let mut out = *self;
        let mut refused = vec![];
        for (kind, parts) in [("a", &mut out.accel), ("g", &mut out.gyro)] {
            for (i, part) in parts.iter_mut().enumerate() {
                if let Some(gm) = part
                    && let Err(why) = gm.check()
                {
                    refused.push((format!("{kind}{}", ["x", "y", "z"][i]), why));
                    *part = None;
                }
            }
        }
        (out, refused)
    }

    /// True when no axis keeps a Gauss–Markov part.
    pub fn is_empty(&self) -> bool {
        self.accel
            .iter()
            .chain(self.gyro.iter())
            .all(Option::is_none)
    }
}

/// Zero-velocity / zero-rate update settings.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ZuptConfig {
    /// Consecutive still epochs that trigger one update.
    pub window: usize,
    /// The still test runs on moving averages over this many epochs (a causal low-pass: engine
    /// vibration would fail a per-sample threshold).
    pub smooth: usize,
    /// |‖f‖ − g| below this, m/s².
    pub accel_thresh: f64,
    /// ‖ω‖ below this, rad/s.
    pub gyro_thresh: f64,
    /// σ of the zero-velocity measurement, m/s.
    pub vel_sd: f64,
    /// σ of the zero-rate measurement (mean gyro over the window), rad/s.
    pub rate_sd: f64,
}

impl ZuptConfig {
    /// The reference GPS/INS filter's settings: 50 still epochs judged on 10-epoch averages,
    /// |‖f‖ − g| < 0.25 m/s² and ‖ω‖ < 0.25 °/s; σ 0.01 m/s and 0.01 °/s.
    pub const REFERENCE: ZuptConfig = ZuptConfig {
        window: 50,
        smooth: 10,
        accel_thresh: 0.25,
        gyro_thresh: 0.25f64.to_radians(),
        vel_sd: 0.01,
        rate_sd: 0.01f64.to_radians(),
    };
}

/// Initial 1-σ uncertainties.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct InitSd {
    /// Roll, pitch, yaw, rad.
    pub att: [f64; 3],
    /// NED, m/s.
    pub vel: [f64; 3],
    /// NED, m.
    pub pos: [f64; 3],
    pub accel_bias: f64,
    pub gyro_bias: f64,
}

/// Everything the filter needs besides the data.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EskfConfig {
    pub noise: ImuNoise,
    pub init: InitSd,
    /// IMU → GNSS antenna, body frame, m.
    pub lever_arm_b: [f64; 3],
    pub zupt: Option<ZuptConfig>,
    /// Align the yaw to the GNSS course once the horizontal speed exceeds this (m/s); `None`:
    /// never (the initial yaw is then taken as known).
    pub yaw_align_speed: Option<f64>,
    /// σ of the yaw after the alignment, rad.
    pub yaw_align_sd: f64,
    /// Gauss–Markov bias parts; the filter applies [`BiasAugmentation::guarded`] itself (an
    /// implausible part falls back to the random walk, counted in [`EskfStats`]), and runs with
    /// 15 states when no part is left.
    pub augmentation: Option<BiasAugmentation>,
}

/// Navigation solution at the IMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState {
    /// Geodetic latitude, rad.
    pub lat: f64,
    /// Longitude, rad.
    pub lon: f64,
    /// Ellipsoidal height, m.
    pub h: f64,
    /// NED velocity, m/s.
    pub v: Vector3<f64>,
    /// Body-to-NED attitude `C_b^n`.
    pub c_bn: Matrix3<f64>,
}

impl NavState {
    /// Free-inertial mechanisation step with bias-corrected rate `w` (rad/s) and specific force
    /// `f` (m/s²) over `dt` seconds (module docs). `earth_rate = false` drops the Earth-rate and
    /// transport-rate terms (a bench whose latitude is unknown).
    pub fn mechanise(&mut self, dt: f64, w: &Vector3<f64>, f: &Vector3<f64>, earth_rate: bool) {
        let (rn, re) = earth::radii(self.lat);
        let (w_ie, w_en) = if earth_rate {
            (
                earth::earth_rate_ned(self.lat),
                earth::transport_rate_ned(self.lat, self.h, &self.v),
            )
        } else {
            (Vector3::zeros(), Vector3::zeros())
        };
        let c_old = self.c_bn;
        self.c_bn = rotation(&(-(w_ie + w_en) * dt)) * c_old * rotation(&(w * dt));
        let f_n = 0.5 * (c_old + self.c_bn) * f;
        let g = Vector3::new(0.0, 0.0, earth::gravity(self.lat, self.h));
        let v_old = self.v;
        self.v = v_old + (f_n + g - (2.0 * w_ie + w_en).cross(&v_old)) * dt;
        let h_old = self.h;
        self.h = h_old - 0.5 * (v_old[2] + self.v[2]) * dt;
        let lat_old = self.lat;
        self.lat = lat_old + 0.5 * (v_old[0] / (rn + h_old) + self.v[0] / (rn + self.h)) * dt;
        let (_, re2) = earth::radii(self.lat);
        self.lon += 0.5
            * (v_old[1] / ((re + h_old) * lat_old.cos())
                + self.v[1] / ((re2 + self.h) * self.lat.cos()))
            * dt;
    }

    /// Roll, pitch, yaw, rad.
    pub fn euler(&self) -> Vector3<f64> {
        earth::ctm_to_euler(&self.c_bn)
    }

    /// Position of a point at `l_b` (body frame, m) from the IMU, geodetic.
    pub fn point(&self, l_b: &Vector3<f64>) -> (f64, f64, f64) {
        let d = self.c_bn * l_b;
        let (rn, re) = earth::radii(self.lat);
        (
            self.lat + d[0] / (rn + self.h),
            self.lon + d[1] / ((re + self.h) * self.lat.cos()),
            self.h - d[2],
        )
    }
}

/// Roll and pitch (rad) of a body at rest from its mean specific force `f` (m/s²), NED.
pub fn level(f: &Vector3<f64>) -> (f64, f64) {
    // At rest f^b = C_n^b (0, 0, −g): roll = atan2(−f_y, −f_z), pitch = atan(f_x / √(f_y²+f_z²)).
    let roll = (-f[1]).atan2(-f[2]);
    let pitch = f[0].atan2((f[1] * f[1] + f[2] * f[2]).sqrt());
    (roll, pitch)
}

/// A GNSS fix as the filter reads it.
#[derive(Clone, Copy, Debug)]
pub struct GnssFix {
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
    /// NED velocity, m/s.
    pub v: Vector3<f64>,
    /// σ of north, east, down position, m.
    pub pos_sd: Vector3<f64>,
    /// σ of the NED velocity, m/s; `None`: position only.
    pub vel_sd: Option<Vector3<f64>>,
}

/// Counters of what the filter did.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct EskfStats {
    pub gnss_updates: usize,
    pub zupt_updates: usize,
    pub yaw_aligned_at_update: Option<usize>,
    /// Gauss–Markov bias parts of the configuration the filter refused ([`GaussMarkov::check`]).
    pub gm_parts_refused: usize,
}

/// The filter (module docs).
#[derive(Clone, Debug)]
pub struct Eskf {
    pub nav: NavState,
    /// Accelerometer bias estimate (random-walk part), m/s².
    pub ba: Vector3<f64>,
    /// Gyro bias estimate (random-walk part), rad/s.
    pub bg: Vector3<f64>,
    /// Gauss–Markov parts (zero without augmentation).
    pub ma: Vector3<f64>,
    pub mg: Vector3<f64>,
    pub p: DMatrix<f64>,
    cfg: EskfConfig,
    n: usize,
    last_w: Vector3<f64>,
    still_count: usize,
    still_gyro_sum: Vector3<f64>,
    hist: Vec<(Vector3<f64>, Vector3<f64>)>,
    hist_pos: usize,
    hist_sum: (Vector3<f64>, Vector3<f64>),
    yaw_aligned: bool,
    pub stats: EskfStats,
}

impl Eskf {
    /// A filter at `nav` with zero bias estimates and the configured initial uncertainty.
    pub fn new(mut cfg: EskfConfig, nav: NavState) -> Self {
        let mut refused = 0;
        if let Some(a) = cfg.augmentation {
            let (g, r) = a.guarded();
            refused = r.len();
            cfg.augmentation = (!g.is_empty()).then_some(g);
        }
        let n = if cfg.augmentation.is_some() { 21 } else { 15 };
        let mut p = DMatrix::zeros(n, n);
        for i in 0..3 {
            p[(idx::ATT + i, idx::ATT + i)] = cfg.init.att[i].powi(2);
            p[(idx::VEL + i, idx::VEL + i)] = cfg.init.vel[i].powi(2);
            p[(idx::POS + i, idx::POS + i)] = cfg.init.pos[i].powi(2);
            p[(idx::BA + i, idx::BA + i)] = cfg.init.accel_bias.powi(2);
            p[(idx::BG + i, idx::BG + i)] = cfg.init.gyro_bias.powi(2);
        }
        if let Some(a) = &cfg.augmentation {
            for i in 0..3 {
                p[(idx::MA + i, idx::MA + i)] = a.accel[i].map_or(0.0, |g| g.sigma.powi(2));
                p[(idx::MG + i, idx::MG + i)] = a.gyro[i].map_or(0.0, |g| g.sigma.powi(2));
            }
        }
        let smooth = cfg.zupt.map_or(1, |z| z.smooth.max(1));
        Eskf {
            nav,
            ba: Vector3::zeros(),
            bg: Vector3::zeros(),
            ma: Vector3::zeros(),
            mg: Vector3::zeros(),
            p,
            n,
            last_w: Vector3::zeros(),
            still_count: 0,
            still_gyro_sum: Vector3::zeros(),
            hist: vec![(Vector3::zeros(), Vector3::zeros()); smooth],
            hist_pos: 0,
            hist_sum: (Vector3::zeros(), Vector3::zeros()),
            yaw_aligned: cfg.yaw_align_speed.is_none(),
            stats: EskfStats {
                gm_parts_refused: refused,
                ..Default::default()
            },
            cfg,
        }
    }

    pub fn config(&self) -> &EskfConfig {
        &self.cfg
    }

    /// Number of error states (15, or 21 augmented).
    pub fn n_states(&self) -> usize {
        self.n
    }

    /// Total gyro bias estimate, rad/s.
    pub fn gyro_bias(&self) -> Vector3<f64> {
        self.bg + self.mg
    }

    /// Total accelerometer bias estimate, m/s².
    pub fn accel_bias(&self) -> Vector3<f64> {
        self.ba + self.ma
    }

    pub fn yaw_aligned(&self) -> bool {
        self.yaw_aligned
    }

    fn lever(&self) -> Vector3<f64> {
        Vector3::from(self.cfg.lever_arm_b)
    }

    /// GNSS antenna position, geodetic.
    pub fn antenna(&self) -> (f64, f64, f64) {
        self.nav.point(&self.lever())
    }

    /// GNSS antenna velocity, NED, m/s.
    pub fn antenna_velocity(&self) -> Vector3<f64> {
        self.nav.v + self.nav.c_bn * self.last_w.cross(&self.lever())
    }

    /// One IMU epoch: raw gyro `w_raw` (rad/s) and specific force `f_raw` (m/s²) over `dt`
    /// seconds since the previous one: bias correction, mechanisation, covariance propagation,
    /// and the still detector (with a ZUPT/ZARU update when it fires).
    pub fn propagate(&mut self, dt: f64, w_raw: &Vector3<f64>, f_raw: &Vector3<f64>) {
        let w = w_raw - self.gyro_bias();
        let f = f_raw - self.accel_bias();
        self.last_w = w;
        if dt > 0.0 {
            self.nav.mechanise(dt, &w, &f, true);
            self.propagate_cov(dt, &f);
            self.decay_gauss_markov(dt);
        }
        if let Some(z) = self.cfg.zupt {
            self.still_detector(&z, &w, &f);
        }
    }

    fn propagate_cov(&mut self, dt: f64, f_b: &Vector3<f64>) {
        let n = self.n;
        let nav = &self.nav;
        let c = nav.c_bn;
        let w_ie = earth::earth_rate_ned(nav.lat);
        let w_en = earth::transport_rate_ned(nav.lat, nav.h, &nav.v);
        let f_n = c * f_b;
        let (rn, re) = earth::radii(nav.lat);
        let r = (rn * re).sqrt() + nav.h;
        let g = earth::gravity(nav.lat, nav.h);
        let mut phi = DMatrix::<f64>::identity(n, n);
        let mut put = |r0: usize, c0: usize, m: &Matrix3<f64>| {
            for i in 0..3 {
                for j in 0..3 {
                    phi[(r0 + i, c0 + j)] += m[(i, j)] * dt;
                }
            }
        };
        put(idx::ATT, idx::ATT, &(-skew(&(w_ie + w_en))));
        put(idx::ATT, idx::BG, &(-c));
        put(idx::VEL, idx::ATT, &(-skew(&f_n)));
        put(idx::VEL, idx::VEL, &(-skew(&(2.0 * w_ie + w_en))));
        put(idx::VEL, idx::BA, &(-c));
        let mut grav = Matrix3::zeros();
        grav[(2, 2)] = 2.0 * g / r;
        put(idx::VEL, idx::POS, &grav);
        put(idx::POS, idx::VEL, &Matrix3::identity());
        if let Some(a) = &self.cfg.augmentation {
            put(idx::ATT, idx::MG, &(-c));
            put(idx::VEL, idx::MA, &(-c));
            let mut da = Matrix3::zeros();
            let mut dg = Matrix3::zeros();
            for i in 0..3 {
                da[(i, i)] = a.accel[i].map_or(0.0, |g| -1.0 / g.tc_s);
                dg[(i, i)] = a.gyro[i].map_or(0.0, |g| -1.0 / g.tc_s);
            }
            put(idx::MA, idx::MA, &da);
            put(idx::MG, idx::MG, &dg);
        }
        let mut p = &phi * &self.p * phi.transpose();
        let nz = &self.cfg.noise;
        for i in 0..3 {
            p[(idx::ATT + i, idx::ATT + i)] += nz.gyro_psd.powi(2) * dt;
            p[(idx::VEL + i, idx::VEL + i)] += nz.accel_psd.powi(2) * dt;
            p[(idx::BA + i, idx::BA + i)] += nz.accel_bias_rw.powi(2) * dt;
            p[(idx::BG + i, idx::BG + i)] += nz.gyro_bias_rw.powi(2) * dt;
        }
        if let Some(a) = &self.cfg.augmentation {
            let q =
                |g: &Option<GaussMarkov>| g.map_or(0.0, |g| 2.0 * g.sigma.powi(2) / g.tc_s * dt);
            for i in 0..3 {
                p[(idx::MA + i, idx::MA + i)] += q(&a.accel[i]);
                p[(idx::MG + i, idx::MG + i)] += q(&a.gyro[i]);
            }
        }
        self.p = 0.5 * (&p + p.transpose());
    }

    fn still_detector(&mut self, z: &ZuptConfig, w: &Vector3<f64>, f: &Vector3<f64>) {
        let k = self.hist.len();
        let (ow, of) = self.hist[self.hist_pos];
        self.hist_sum.0 += w - ow;
        self.hist_sum.1 += f - of;
        self.hist[self.hist_pos] = (*w, *f);
        self.hist_pos = (self.hist_pos + 1) % k;
        let mw = self.hist_sum.0 / k as f64;
        let mf = self.hist_sum.1 / k as f64;
        let g = earth::gravity(self.nav.lat, self.nav.h);
        let still = (mf.norm() - g).abs() < z.accel_thresh && mw.norm() < z.gyro_thresh;
        if !still {
            self.still_count = 0;
            self.still_gyro_sum = Vector3::zeros();
            return;
        }
        self.still_count += 1;
        self.still_gyro_sum += w;
        if self.still_count >= z.window {
            let mean_w = self.still_gyro_sum / self.still_count as f64;
            self.still_count = 0;
            self.still_gyro_sum = Vector3::zeros();
            self.zupt(z, &mean_w);
        }
    }

    /// Zero-velocity and zero-rate update; `mean_w` is the mean bias-corrected gyro over the
    /// still window, which at rest measures the Earth rate plus the remaining bias error.
    fn zupt(&mut self, z: &ZuptConfig, mean_w: &Vector3<f64>) {
        let n = self.n;
        let mut h = DMatrix::zeros(6, n);
        let mut y = DVector::zeros(6);
        let mut r = DVector::zeros(6);
        let w_earth_b = self.nav.c_bn.transpose() * earth::earth_rate_ned(self.nav.lat);
        for i in 0..3 {
            h[(i, idx::VEL + i)] = 1.0;
            y[i] = -self.nav.v[i];
            r[i] = z.vel_sd.powi(2);
            h[(3 + i, idx::BG + i)] = 1.0;
            if self.cfg.augmentation.is_some() {
                h[(3 + i, idx::MG + i)] = 1.0;
            }
            y[3 + i] = mean_w[i] - w_earth_b[i];
            r[3 + i] = z.rate_sd.powi(2);
        }
        self.update(&h, &y, &r);
        self.stats.zupt_updates += 1;
    }

    /// GNSS position (and velocity) update at the antenna.
    pub fn update_gnss(&mut self, m: &GnssFix) {
        let n = self.n;
        let with_vel = m.vel_sd.is_some();
        let rows = if with_vel { 6 } else { 3 };
        let mut h = DMatrix::zeros(rows, n);
        let mut y = DVector::zeros(rows);
        let mut r = DVector::zeros(rows);
        let (la, lo, ha) = self.antenna();
        let (rn, re) = earth::radii(la);
        let dpos = Vector3::new(
            (m.lat - la) * (rn + ha),
            (m.lon - lo) * (re + ha) * la.cos(),
            -(m.h - ha),
        );
        let cl = skew(&(self.nav.c_bn * self.lever()));
        for i in 0..3 {
            h[(i, idx::POS + i)] = 1.0;
            for j in 0..3 {
                h[(i, idx::ATT + j)] = -cl[(i, j)];
            }
            y[i] = dpos[i];
            r[i] = m.pos_sd[i].powi(2);
        }
        if let Some(vs) = m.vel_sd {
            let va = self.antenna_velocity();
            for i in 0..3 {
                h[(3 + i, idx::VEL + i)] = 1.0;
                y[3 + i] = m.v[i] - va[i];
                r[3 + i] = vs[i].powi(2);
            }
        }
        self.update(&h, &y, &r);
        self.stats.gnss_updates += 1;
        if !self.yaw_aligned
            && let Some(s) = self.cfg.yaw_align_speed
            && m.v.xy().norm() > s
        {
            self.align_yaw(m.v[1].atan2(m.v[0]));
            self.stats.yaw_aligned_at_update = Some(self.stats.gnss_updates);
        }
    }

    /// Set the yaw (rad) keeping roll and pitch; the yaw error's covariance is reset.
    pub fn align_yaw(&mut self, yaw: f64) {
        let e = self.nav.euler();
        self.nav.c_bn = euler_to_ctm(e[0], e[1], yaw).transpose();
        for j in 0..self.n {
            self.p[(idx::ATT + 2, j)] = 0.0;
            self.p[(j, idx::ATT + 2)] = 0.0;
        }
        self.p[(idx::ATT + 2, idx::ATT + 2)] = self.cfg.yaw_align_sd.powi(2);
        self.yaw_aligned = true;
    }

    /// Kalman update with innovation `y = z − ẑ`, measurement matrix `h`, diagonal noise `r`
    /// (Joseph form), then closed-loop correction.
    fn update(&mut self, h: &DMatrix<f64>, y: &DVector<f64>, r: &DVector<f64>) {
        let ph = &self.p * h.transpose();
        let mut s = h * &ph;
        for i in 0..r.len() {
            s[(i, i)] += r[i];
        }
        let Some(s_inv) = s.try_inverse() else {
            return;
        };
        let k = &ph * s_inv;
        let x = &k * y;
        let ikh = DMatrix::<f64>::identity(self.n, self.n) - &k * h;
        let mut p = &ikh * &self.p * ikh.transpose();
        let kr = DMatrix::from_diagonal(r);
        p += &k * kr * k.transpose();
        self.p = 0.5 * (&p + p.transpose());
        self.correct(&x);
    }

    fn correct(&mut self, x: &DVector<f64>) {
        let v3 = |i: usize| Vector3::new(x[i], x[i + 1], x[i + 2]);
        let psi = v3(idx::ATT);
        self.nav.c_bn = earth::orthonormalise(&(rotation(&psi) * self.nav.c_bn));
        self.nav.v += v3(idx::VEL);
        let dr = v3(idx::POS);
        let (rn, re) = earth::radii(self.nav.lat);
        self.nav.lat += dr[0] / (rn + self.nav.h);
        self.nav.lon += dr[1] / ((re + self.nav.h) * self.nav.lat.cos());
        self.nav.h -= dr[2];
        self.ba += v3(idx::BA);
        self.bg += v3(idx::BG);
        if self.n == 21 {
            self.ma += v3(idx::MA);
            self.mg += v3(idx::MG);
        }
    }

    /// Propagate the Gauss–Markov bias estimates' mean over `dt` (they decay towards zero).
    fn decay_gauss_markov(&mut self, dt: f64) {
        if let Some(a) = &self.cfg.augmentation {
            let k = |g: &Option<GaussMarkov>| g.map_or(0.0, |g| (-dt / g.tc_s).exp());
            for i in 0..3 {
                self.ma[i] *= k(&a.accel[i]);
                self.mg[i] *= k(&a.gyro[i]);
            }
        }
    }
}
