use super::*;
use crate::io::csv::TimeUnit;
use crate::rng::Rng;

/// A seeded IMU tilting ±`amp_deg` about a horizontal axis (period `period_s`) at 100 Hz,
/// gyro scaled by `gyro_scale` (1 = rad/s), accel in g, with white noise.
fn tilting(amp_deg: f64, period_s: f64, gyro_scale: f64, seconds: f64) -> (Vec<Sample>, Vec<f64>) {
    let mut r = Rng::new(7);
    let fs = 100.0;
    let w0 = 2.0 * std::f64::consts::PI / period_s;
    let amp = amp_deg.to_radians();
    let mut out = Vec::new();
    let mut t = Vec::new();
    for i in 0..(seconds * fs) as usize {
        let ti = i as f64 / fs;
        // Roll φ(t) about x: gravity in the body frame (0, sin φ, cos φ) g, ω_x = φ'.
        let phi = amp * (w0 * ti).sin();
        let rate = amp * w0 * (w0 * ti).cos();
        let mut s = Sample::default();
        s.set_channels(&[
            (rate + 0.002 * r.normal()) / gyro_scale,
            0.002 * r.normal() / gyro_scale,
            0.002 * r.normal() / gyro_scale,
            0.003 * r.normal(),
            phi.sin() + 0.003 * r.normal(),
            phi.cos() + 0.003 * r.normal(),
        ]);
        out.push(s);
        t.push(ti);
    }
    (out, t)
}

#[test]
fn the_tilt_fit_recovers_the_gyro_scale_within_10_percent() {
    for (scale, unit) in [(1.0, GyroUnit::RadS), (DEG, GyroUnit::DegS)] {
        let (s, t) = tilting(20.0, 6.0, scale, 60.0);
        let m = accel_median_norm(&s).unwrap().0;
        let f = tilt_fit(&s, &t, m);
        assert!((f.scale / scale - 1.0).abs() < 0.1, "{f:?}");
        assert!(f.r2 > 0.9, "{f:?}");
        assert_eq!(f.unit(), Some(unit), "{f:?}");
    }
}

#[test]
fn a_static_record_leaves_the_gyro_unit_undecided() {
    let (s, t) = tilting(0.0, 6.0, DEG, 60.0);
    let ev = gyro_evidence(&s, &t, accel_median_norm(&s).map(|x| x.0));
    assert_eq!(ev.unit(), None, "{}", ev.describe());
    assert!(
        ev.describe().contains("too little tilting"),
        "{}",
        ev.describe()
    );
}

#[test]
fn accel_bands_and_time_units() {
    assert_eq!(accel_unit_of_norm(1.003), Some(AccelUnit::G));
    assert_eq!(accel_unit_of_norm(9.79), Some(AccelUnit::MS2));
    assert_eq!(accel_unit_of_norm(3.0), None);
    assert_eq!(accel_unit_of_norm(0.1), None);
    assert_eq!(plausible_time_unit(0.005), Some(TimeUnit::S));
    assert_eq!(plausible_time_unit(5.0), Some(TimeUnit::Ms));
    assert_eq!(plausible_time_unit(4000.0), Some(TimeUnit::Us));
    assert_eq!(plausible_time_unit(5e6), Some(TimeUnit::Ns));
    assert_eq!(plausible_time_unit(1e12), None);
}

#[test]
fn a_stated_time_unit_is_warned_about_only_when_it_gives_no_imu_rate() {
    let ms = Some((TimeUnit::Ms, "time_ms".to_string()));
    // 2 kHz stamped in ms (0.5 ms apart) is an IMU's rate: read as s it would be 2 Hz, which
    // contradicts nothing.
    let d = decide_time(None, ms.as_ref(), 0.5);
    assert_eq!(d.unit, TimeUnit::Ms);
    assert!(d.warning.is_none(), "{:?}", d.warning);
    // 1 Hz in "ms" (1000 apart) is none; as µs it is 1 kHz: warned, kept.
    let d = decide_time(None, ms.as_ref(), 1000.0);
    assert_eq!(d.unit, TimeUnit::Ms);
    assert!(d.warning.unwrap().contains("--time-unit us"));
    // Xsens' SampleTimeFine: the rate picks the product's tick.
    let fine = Some((TimeUnit::Tick100Us, "SampleTimeFine".to_string()));
    assert_eq!(
        decide_time(None, fine.as_ref(), 10.0).unit,
        TimeUnit::Tick100Us
    );
    assert_eq!(decide_time(None, fine.as_ref(), 8333.0).unit, TimeUnit::Us);
    assert_eq!(
        decide_time(Some(TimeUnit::Ns), fine.as_ref(), 8333.0).unit,
        TimeUnit::Ns
    );
}
