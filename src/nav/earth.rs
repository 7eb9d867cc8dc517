//! WGS-84 Earth model for a local-level (north-east-down) mechanisation at car and walking scale.
//!
//! Sources (equations re-derived, not copied): P. D. Groves, *Principles of GNSS, Inertial, and
//! Multisensor Integrated Navigation Systems*, 2nd ed., 2013 — WGS-84 constants (§2.4), radii of
//! curvature (eqs. 2.105–2.106), curvilinear ↔ ECEF (2.112), the Somigliana normal gravity on the
//! ellipsoid with a first-order height correction (2.134, 2.139), and the Euler-angle
//! coordinate transformation matrix (2.22).

use nalgebra::{Matrix3, Vector3};

/// WGS-84 equatorial radius, m.
pub const R0: f64 = 6_378_137.0;
/// WGS-84 eccentricity.
pub const ECC: f64 = 0.081_819_190_842_5;
/// WGS-84 flattening.
pub const FLAT: f64 = 1.0 / 298.257_223_563;
/// Earth rotation rate, rad/s.
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// WGS-84 gravitational constant GM, m³/s².
pub const MU: f64 = 3.986_004_418e14;

/// Meridian (north-south) and transverse (east-west) radii of curvature at latitude `lat`, m.
pub fn radii(lat: f64) -> (f64, f64) {
    let s2 = (ECC * lat.sin()).powi(2);
    let d = 1.0 - s2;
    (R0 * (1.0 - ECC * ECC) / d.powf(1.5), R0 / d.sqrt())
}

/// Magnitude of gravity (gravitation + centrifugal) at latitude `lat` (rad) and height `h` (m):
/// Somigliana's normal gravity on the ellipsoid, reduced with height by the free-air term of
/// Groves (2.139) (first and second order in h/R0).
pub fn gravity(lat: f64, h: f64) -> f64 {
    let s2 = lat.sin().powi(2);
    let g0 = 9.780_325_335_9 * (1.0 + 0.001_931_852_652_41 * s2) / (1.0 - ECC * ECC * s2).sqrt();
    let m = OMEGA_IE * OMEGA_IE * R0 * R0 * (R0 * (1.0 - FLAT)) / MU;
    g0 * (1.0 - 2.0 / R0 * (1.0 + FLAT + m - 2.0 * FLAT * s2) * h + 3.0 * h * h / (R0 * R0))
}

/// Earth rate resolved in the local NED frame at latitude `lat`, rad/s.
pub fn earth_rate_ned(lat: f64) -> Vector3<f64> {
    Vector3::new(OMEGA_IE * lat.cos(), 0.0, -OMEGA_IE * lat.sin())
}

/// Transport rate (rotation of the NED frame over the curved Earth) for NED velocity `v`, rad/s.
pub fn transport_rate_ned(lat: f64, h: f64, v: &Vector3<f64>) -> Vector3<f64> {
    let (rn, re) = radii(lat);
    Vector3::new(
        v[1] / (re + h),
        -v[0] / (rn + h),
        -v[1] * lat.tan() / (re + h),
    )
}

/// Geodetic latitude, longitude (rad) and height (m) → ECEF, m.
pub fn llh_to_ecef(lat: f64, lon: f64, h: f64) -> Vector3<f64> {
    let (_, re) = radii(lat);
    Vector3::new(
        (re + h) * lat.cos() * lon.cos(),
        (re + h) * lat.cos() * lon.sin(),
        ((1.0 - ECC * ECC) * re + h) * lat.sin(),
    )
}

/// ECEF (m) → geodetic latitude, longitude (rad) and height (m): fixed-point iteration on the
/// latitude (Groves §2.4.2); six steps converge to far below a millimetre at any height a
/// vehicle reaches.
pub fn ecef_to_llh(r: &Vector3<f64>) -> (f64, f64, f64) {
    let lon = r[1].atan2(r[0]);
    let p = r[0].hypot(r[1]);
    let mut lat = r[2].atan2(p * (1.0 - ECC * ECC));
    let mut h = 0.0;
    for _ in 0..6 {
        let (_, re) = radii(lat);
        h = p / lat.cos() - re;
        lat = r[2].atan2(p * (1.0 - ECC * ECC * re / (re + h)));
    }
    (lat, lon, h)
}

/// Rotation from ECEF to the NED frame at (`lat`, `lon`).
pub fn ecef_to_ned(lat: f64, lon: f64) -> Matrix3<f64> {
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    Matrix3::new(
        -sl * co,
        -sl * so,
        cl, //
        -so,
        co,
        0.0, //
        -cl * co,
        -cl * so,
        -sl,
    )
}

/// A fixed local NED frame (origin at a reference point) for comparing positions in metres.
#[derive(Clone, Copy, Debug)]
pub struct LocalFrame {
    origin: Vector3<f64>,
    rot: Matrix3<f64>,
}

impl LocalFrame {
    pub fn new(lat: f64, lon: f64, h: f64) -> Self {
        LocalFrame {
            origin: llh_to_ecef(lat, lon, h),
            rot: ecef_to_ned(lat, lon),
        }
    }

    /// NED coordinates (m) of a geodetic point.
    pub fn ned(&self, lat: f64, lon: f64, h: f64) -> Vector3<f64> {
        self.rot * (llh_to_ecef(lat, lon, h) - self.origin)
    }
}

/// Coordinate transformation matrix from the reference frame to a frame rotated by the Euler
/// angles roll, pitch, yaw (rad; z-y-x order) — Groves (2.22). With the body attitude's angles
/// this is `C_n^b`; its transpose is `C_b^n`.
pub fn euler_to_ctm(roll: f64, pitch: f64, yaw: f64) -> Matrix3<f64> {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    Matrix3::new(
        cp * cy,
        cp * sy,
        -sp,
        -cr * sy + sr * sp * cy,
        cr * cy + sr * sp * sy,
        sr * cp,
        sr * sy + cr * sp * cy,
        -sr * cy + cr * sp * sy,
        cr * cp,
    )
}

/// Roll, pitch, yaw (rad) of the body attitude `c_bn` (= `C_b^n`), inverse of [`euler_to_ctm`].
pub fn ctm_to_euler(c_bn: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(
        c_bn[(2, 1)].atan2(c_bn[(2, 2)]),
        -(c_bn[(2, 0)].clamp(-1.0, 1.0)).asin(),
        c_bn[(1, 0)].atan2(c_bn[(0, 0)]),
    )
}

/// Skew-symmetric (cross-product) matrix of `v`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v[2], v[1], v[2], 0.0, -v[0], -v[1], v[0], 0.0)
}

/// Rotation matrix of the rotation vector `a` (Rodrigues' formula; exact for any angle).
pub fn rotation(a: &Vector3<f64>) -> Matrix3<f64> {
    let th = a.norm();
    let k = skew(a);
    if th < 1e-8 {
        return Matrix3::identity() + k + 0.5 * k * k;
    }
    Matrix3::identity() + k * (th.sin() / th) + k * k * ((1.0 - th.cos()) / (th * th))
}

/// Nearest orthonormal matrix (polar decomposition by SVD) — keeps the attitude a rotation.
pub fn orthonormalise(c: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = c.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => u * vt,
        _ => *c,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ecef_round_trip() {
        // Round trip at the comma2k19 segment's place (37.7° N, −122.5°, 33 m) and at 8 km:
        // 1 mm and 1e-10 rad (0.6 mm) are far above the iteration's residual.
        for (lat, lon, h) in [(0.658, -2.1376, 33.0), (-0.2, 1.0, 8000.0)] {
            let (la, lo, hh) = ecef_to_llh(&llh_to_ecef(lat, lon, h));
            assert!(
                (la - lat).abs() < 1e-10 && (lo - lon).abs() < 1e-10,
                "{la} {lo}"
            );
            assert!((hh - h).abs() < 1e-3, "{hh}");
        }
    }

    #[test]
    fn gravity_matches_known_values() {
        // Normal gravity is 9.780 33 at the equator and 9.832 18 at the poles (WGS-84); the
        // free-air gradient is about −3.086e-6 s⁻² per metre. Tolerances: 1e-5 m/s² covers the
        // rounding of the published values.
        assert!((gravity(0.0, 0.0) - 9.780_325).abs() < 1e-5);
        assert!((gravity(std::f64::consts::FRAC_PI_2, 0.0) - 9.832_185).abs() < 1e-5);
        let grad = (gravity(0.7, 1000.0) - gravity(0.7, 0.0)) / 1000.0;
        assert!((grad + 3.086e-6).abs() < 0.01e-6, "{grad}");
    }

    #[test]
    fn euler_round_trip_and_local_frame() {
        let (r, p, y) = (0.3, -0.2, 2.5);
        let c_bn = euler_to_ctm(r, p, y).transpose();
        let e = ctm_to_euler(&c_bn);
        assert!((e - Vector3::new(r, p, y)).norm() < 1e-12);
        // 1e-4 rad of latitude north at 100 m is (R_N + h)·1e-4 m along the arc; 1 m up is −1 m
        // down, less the Earth's curvature over the arc, d²/(2R) (3 cm). Tolerance 1 mm: the
        // chord-versus-arc and ellipsoid terms are below it over 636 m.
        let lat = 0.7;
        let f = LocalFrame::new(lat, 0.1, 100.0);
        let (rn, _) = radii(lat);
        let d = f.ned(lat + 1e-4, 0.1, 101.0);
        let arc = (rn + 100.0) * 1e-4;
        assert!((d[0] - arc).abs() < 1e-3, "{d}");
        assert!((d[2] + 1.0 - arc * arc / (2.0 * rn)).abs() < 1e-3, "{d}");
    }
}
