//! `imuprep import` of the CSV layouts a new user brings: EuRoC / TUM-VI `imu0/data.csv`, Kalibr's `imu0.csv`, a ROS
//! `rostopic echo -p` export of sensor_msgs/Imu, camelCase (`accX`, `GyrX`), short (`aX`, `gX`,
//! `wx`) and iOS-style (`rotationRateX`) names; units the header does not state checked against
//! the data (a canonical `t,gx,..` file holding g and deg/s is read as such and says so, a static
//! one keeps SI); stated units the data contradict warned about, never overridden; two columns
//! for one channel an error naming both; gravity, user acceleration, orientation and bias
//! columns never taken for the sensor; date-time stamps read as seconds since 1970 UTC.
//!
//! Synthetic recordings are seeded: 40 s at 200 Hz of a sensor rolling ±20° about x (period 6 s,
//! peak rate 21 °/s, so a deg/s gyro stays below the 35 "rad/s" over-range rule and the
//! gravity-direction fit must decide), with white noise. Values are written with Rust's
//! shortest round-trip formatting, so an import in the right unit reproduces the truth to
//! 1e-9 (one unit conversion's rounding).
mod common;

use imuprep::io::csv::{ImportOptions, ImportReport, read_csv_report};
use imuprep::sample::Sample;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const FS: f64 = 200.0;
const N: usize = 8000;
const G0: f64 = 9.80665;
const D2R: f64 = PI / 180.0;
/// An EuRoC-like start, ns.
const T0_NS: u64 = 1_403_636_579_758_555_392;

use common::TruthRow as Row;

/// The rolling sensor of [`common::rocking`] from t = 0; `amp_deg` 0 is a static bench.
fn motion(amp_deg: f64, seed: u64) -> Vec<Row> {
    common::rocking(N, FS, 0.0, amp_deg, seed)
}

/// Write `header` and one line per row.
fn write(
    dir: &Path,
    name: &str,
    header: &str,
    rows: &[Row],
    line: impl Fn(usize, &Row) -> String,
) -> PathBuf {
    let mut s = String::from(header);
    s.push('\n');
    for (i, r) in rows.iter().enumerate() {
        s += &line(i, r);
        s.push('\n');
    }
    let p = dir.join(name);
    std::fs::write(&p, s).unwrap();
    p
}

/// A row as EuRoC and Kalibr write it: ns from [`T0_NS`] at 200 Hz, gyro, then accel.
fn ns_gyro_accel(i: usize, r: &Row) -> String {
    format!(
        "{},{},{}",
        T0_NS + i as u64 * 5_000_000,
        join(&r.g),
        join(&r.f)
    )
}

fn join(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(",")
}
fn deg(g: &[f64; 3]) -> [f64; 3] {
    g.map(|x| x / D2R)
}
fn in_g(f: &[f64; 3]) -> [f64; 3] {
    f.map(|x| x / G0)
}

fn import(p: &Path) -> (f64, Vec<Sample>, ImportReport) {
    let (d, s, rep) = read_csv_report(p, &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    (d.sample_rate_hz, s, rep)
}

/// The unit the import decided for `q` (gyro, accel, time) and its source.
fn unit<'a>(rep: &'a ImportReport, q: &str) -> (&'a str, &'a str, &'a str) {
    let u = rep
        .units
        .iter()
        .find(|u| u.quantity == q)
        .unwrap_or_else(|| panic!("no {q} unit in {rep}"));
    (u.unit, u.source, u.how.as_str())
}

/// Every channel equals the truth within 1e-9 (rad/s, m/s²), the rate is 200 Hz within 1e-6.
fn assert_truth(label: &str, rate: f64, s: &[Sample], rows: &[Row]) {
    common::assert_rows(label, (rate, FS), s, rows);
}

/// (unit, source) decided for `q`.
fn us<'a>(rep: &'a ImportReport, q: &str) -> (&'a str, &'a str) {
    let (u, s, _) = unit(rep, q);
    (u, s)
}

fn columns(rep: &ImportReport) -> String {
    rep.columns
        .iter()
        .map(|c| format!("{}={}", c.key, c.column))
        .collect::<Vec<_>>()
        .join(",")
}

#[test]
fn euroc_imu0_data_csv_imports_with_ns_time_and_bracketed_si_units() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 1);
    let p = write(
        dir.path(),
        "data.csv",
        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]",
        &rows,
        ns_gyro_accel,
    );
    let (rate, s, rep) = import(&p);
    assert_truth("euroc", rate, &s, &rows);
    assert_eq!(unit(&rep, "time").0, "ns", "{rep}");
    assert_eq!(us(&rep, "gyro"), ("rad/s", "name"), "{rep}");
    assert_eq!(us(&rep, "accel"), ("m/s²", "name"), "{rep}");
    // ns stamps of 1.4e18 pass through f64: within 256 ns of the integer.
    for (i, s) in s.iter().enumerate().step_by(997) {
        let want = T0_NS + i as u64 * 5_000_000;
        assert!(
            s.t_ns.abs_diff(want) <= 256,
            "row {i}: {} vs {want}",
            s.t_ns
        );
    }
    assert!(rep.warnings.is_empty(), "{rep}");
}

#[test]
fn ros_imu_export_takes_angular_velocity_and_linear_acceleration_and_reads_percent_time_as_ns() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 2);
    let mut h = String::from("%time,field.header.seq,field.header.stamp,field.header.frame_id");
    for c in ["x", "y", "z", "w"] {
        let _ = write!(h, ",field.orientation.{c}");
    }
    for (f, n) in [
        ("orientation", 0),
        ("angular_velocity", 1),
        ("linear_acceleration", 2),
    ] {
        if n > 0 {
            for c in ["x", "y", "z"] {
                let _ = write!(h, ",field.{f}.{c}");
            }
        }
        for j in 0..9 {
            let _ = write!(h, ",field.{f}_covariance{j}");
        }
    }
    let zeros = ["0"; 9].join(",");
    let p = write(dir.path(), "ros.csv", &h, &rows, |i, r| {
        let t = T0_NS + i as u64 * 5_000_000;
        format!(
            "{t},{i},{t},imu_link,0.1,0.2,0.3,0.9,{zeros},{},{zeros},{},{zeros}",
            join(&r.g),
            join(&r.f)
        )
    });
    let (rate, s, rep) = import(&p);
    assert_truth("ros", rate, &s, &rows);
    assert_eq!(
        columns(&rep),
        "t=%time,gx=field.angular_velocity.x,gy=field.angular_velocity.y,gz=field.angular_velocity.z,\
         ax=field.linear_acceleration.x,ay=field.linear_acceleration.y,az=field.linear_acceleration.z"
    );
    let (tu, ts, th) = unit(&rep, "time");
    assert_eq!((tu, ts), ("ns", "data"), "{th}");
    assert!(th.contains("as ns it gives 200 Hz"), "{th}");
    // The motion tilts: the gravity-direction fit confirms the message's rad/s.
    assert_eq!(us(&rep, "gyro"), ("rad/s", "data"), "{rep}");
    assert_eq!(us(&rep, "accel"), ("m/s²", "data"), "{rep}");
}

/// (file, header, time as written, gyro in deg/s?, accel in g?)
type Case = (&'static str, &'static str, fn(&Row) -> String, bool, bool);

#[test]
fn camel_case_and_short_layouts_import_in_g_and_deg_s_from_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 3);
    let cases: [Case; 5] = [
        (
            "camel.csv",
            "timestamp,accX,accY,accZ,gyroX,gyroY,gyroZ",
            |r| format!("{}", r.t),
            true,
            true,
        ),
        (
            "openlog.csv",
            "time_ms,aX,aY,aZ,gX,gY,gZ,mX,mY,mZ",
            |r| format!("{}", r.t * 1e3),
            true,
            true,
        ),
        (
            "xsens.csv",
            "Time,AccX,AccY,AccZ,GyrX,GyrY,GyrZ",
            |r| format!("{}", r.t * 1e6),
            true,
            false,
        ),
        (
            "wit.csv",
            "time,ax,ay,az,wx,wy,wz",
            |r| format!("{}", r.t),
            false,
            true,
        ),
        (
            "ios.csv",
            "timestamp,accelerationX,accelerationY,accelerationZ,rotationRateX,rotationRateY,rotationRateZ",
            |r| format!("{}", r.t),
            false,
            true,
        ),
    ];
    for (name, header, time, gdeg, ag) in cases {
        let short = name == "openlog.csv";
        let p = write(dir.path(), name, header, &rows, |_, r| {
            let g = if gdeg { deg(&r.g) } else { r.g };
            let f = if ag { in_g(&r.f) } else { r.f };
            // Every header here has the accelerometer first.
            format!(
                "{},{},{}{}",
                time(r),
                join(&f),
                join(&g),
                if short { ",20,-3,41" } else { "" }
            )
        });
        let (rate, s, rep) = import(&p);
        assert_truth(name, rate, &s, &rows);
        assert_eq!(
            unit(&rep, "gyro").0,
            if gdeg { "deg/s" } else { "rad/s" },
            "{name}: {rep}"
        );
        assert_eq!(
            unit(&rep, "accel").0,
            if ag { "g" } else { "m/s²" },
            "{name}: {rep}"
        );
        assert_eq!(unit(&rep, "gyro").1, "data", "{name}: {rep}");
        assert!(rep.warnings.is_empty(), "{name}: {rep}");
    }
}

/// Millidegrees per second and thousandths of g, as ST's MEMS datalogs write them: stated by
/// the name (`acc_x[mg]`, `gyro_x[mdps]`), or told by the data (median |f| ≈ 1000; gravity
/// turning with the gyro at scale π/180 000).
#[test]
fn mg_and_mdeg_s_import_from_the_name_or_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 8);
    let milli = |v: &[f64; 3], k: f64| v.map(|x| x / k * 1e3);
    for (name, header, source) in [
        (
            "st.csv",
            "time[us],acc_x[mg],acc_y[mg],acc_z[mg],gyro_x[mdps],gyro_y[mdps],gyro_z[mdps]",
            "name",
        ),
        (
            "bare.csv",
            "timestamp,accX,accY,accZ,gyroX,gyroY,gyroZ",
            "data",
        ),
    ] {
        let p = write(dir.path(), name, header, &rows, |_, r| {
            format!(
                "{},{},{}",
                r.t * 1e6,
                join(&milli(&r.f, G0)),
                join(&milli(&r.g, D2R))
            )
        });
        let (rate, s, rep) = import(&p);
        assert_truth(name, rate, &s, &rows);
        assert_eq!(us(&rep, "gyro"), ("mdeg/s", source), "{name}: {rep}");
        assert_eq!(us(&rep, "accel"), ("mg", source), "{name}: {rep}");
        assert!(rep.warnings.is_empty(), "{name}: {rep}");
    }
    // The flags name them too.
    let o = ImportOptions {
        gyro_unit: Some(imuprep::io::csv::GyroUnit::MilliDegS),
        accel_unit: Some(imuprep::io::csv::AccelUnit::MilliG),
        ..ImportOptions::default()
    };
    let (_, s, rep) = read_csv_report(&dir.path().join("bare.csv"), &o).unwrap();
    assert_truth("flags", FS, &s, &rows);
    assert_eq!(us(&rep, "gyro"), ("mdeg/s", "option"), "{rep}");
    // At rest the data cannot tell mdeg/s from deg/s (both beyond 35 "rad/s", no tilt): the
    // range says deg/s, and a warning names the other reading and its flag.
    let bench = motion(0.0, 9);
    let p = write(
        dir.path(),
        "bench.csv",
        "timestamp,accX,accY,accZ,gyroX,gyroY,gyroZ",
        &bench,
        |_, r| {
            // A 0.5 °/s bias, as MEMS gyros have: 500 mdeg/s on every sample.
            let g = r.g.map(|x| x / D2R * 1e3 + 500.0);
            format!("{},{},{}", r.t, join(&milli(&r.f, G0)), join(&g))
        },
    );
    let (_, _, rep) = import(&p);
    assert_eq!(us(&rep, "gyro"), ("deg/s", "data"), "{rep}");
    assert!(
        rep.warnings
            .iter()
            .any(|w| w.contains("pass --gyro-unit mdeg/s")),
        "{rep}"
    );
}

#[test]
fn a_canonical_file_holding_g_and_deg_s_with_tilting_motion_is_read_as_such_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 4);
    let p = write(
        dir.path(),
        "canon.csv",
        "t,gx,gy,gz,ax,ay,az",
        &rows,
        |_, r| format!("{},{},{}", r.t, join(&deg(&r.g)), join(&in_g(&r.f))),
    );
    let (rate, s, rep) = import(&p);
    assert_truth("canonical g, deg/s", rate, &s, &rows);
    let (gu, gs, gh) = unit(&rep, "gyro");
    assert_eq!((gu, gs), ("deg/s", "data"), "{gh}");
    // Peak 21 °/s: decided by the gravity-direction fit, not by over-range.
    assert!(
        gh.contains("gravity's direction turns with the integrated gyro"),
        "{gh}"
    );
    let (au, as_, ah) = unit(&rep, "accel");
    assert_eq!((au, as_), ("g", "data"), "{ah}");
    assert!(ah.contains("median |f| = 1"), "{ah}");
    // And the CLI prints it in import's summary.
    let log = dir.path().join("canon.log");
    let out = common::run_cli(&["import", p.to_str().unwrap(), "-o", log.to_str().unwrap()]);
    assert!(
        out.contains("import: gyro unit: deg/s (not stated;"),
        "{out}"
    );
    assert!(
        out.contains("import: accel unit: g (not stated; median |f| = 1"),
        "{out}"
    );
}

#[test]
fn a_static_canonical_file_keeps_si() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(0.0, 5);
    let p = write(
        dir.path(),
        "static.csv",
        "t,gx,gy,gz,ax,ay,az",
        &rows,
        |_, r| format!("{},{},{}", r.t, join(&r.g), join(&r.f)),
    );
    let (rate, s, rep) = import(&p);
    assert_truth("static SI", rate, &s, &rows);
    let (gu, gs, gh) = unit(&rep, "gyro");
    assert_eq!((gu, gs), ("rad/s", "convention"), "{gh}");
    assert!(
        gh.contains("canonical names mean rad/s") && gh.contains("too little tilting"),
        "{gh}"
    );
    assert_eq!(unit(&rep, "accel").0, "m/s²", "{rep}");
    // The same static bench under names without a unit: the data cannot tell, so it asks.
    let p = write(
        dir.path(),
        "static_named.csv",
        "time,gyroX,gyroY,gyroZ,accX,accY,accZ",
        &rows,
        |_, r| format!("{},{},{}", r.t, join(&r.g), join(&r.f)),
    );
    let e = read_csv_report(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cannot tell the gyro unit") && e.contains("pass --gyro-unit"),
        "{e}"
    );
    // ... and an option always wins.
    let o = ImportOptions {
        gyro_unit: Some(imuprep::io::csv::GyroUnit::RadS),
        ..ImportOptions::default()
    };
    let (_, _, rep) = read_csv_report(&p, &o).unwrap();
    assert_eq!(us(&rep, "gyro"), ("rad/s", "option"));
}

/// Kalibr's `imu0.csv` (`timestamp,omega_x,…,alpha_z`; ns, rad/s, m/s² by its format) of a
/// static bench, where the data cannot tell the gyro unit: before the names were known it
/// asked for `--gyro-unit`.
#[test]
fn a_static_kalibr_imu_csv_imports_in_si_by_its_format() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(0.0, 6);
    let p = write(
        dir.path(),
        "imu0.csv",
        "timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z",
        &rows,
        ns_gyro_accel,
    );
    let (rate, s, rep) = import(&p);
    assert_truth("kalibr", rate, &s, &rows);
    assert_eq!(unit(&rep, "time").0, "ns", "{rep}");
    let (gu, gs, gh) = unit(&rep, "gyro");
    assert_eq!((gu, gs), ("rad/s", "convention"), "{gh}");
    assert!(gh.contains("Kalibr"), "{gh}");
    assert_eq!(unit(&rep, "accel").0, "m/s²", "{rep}");
    assert!(rep.warnings.is_empty(), "{rep}");
}

#[test]
fn a_static_ardupilot_imu_export_imports_in_si_by_its_message_fields() {
    // `mavlogdump.py --types IMU --format csv`: timestamp (s), TimeUS, instance, GyrX.. (rad/s),
    // AccX.. (m/s²), error counts, temperature, health and rates. At rest the data cannot tell
    // the gyro unit; the message defines it.
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(0.0, 12);
    let p = write(
        dir.path(),
        "imu.csv",
        "timestamp,TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz",
        &rows,
        |i, r| {
            format!(
                "{},{},0,{},{},0,0,45.5,1,1,200,200",
                1.7e9 + r.t,
                123_456 + i * 5000,
                join(&r.g),
                join(&r.f)
            )
        },
    );
    let (rate, s, rep) = import(&p);
    // Seconds since 1970 in f64: within 1e-6 s of 200 Hz spacing, so the rate to 1e-6 Hz.
    assert!((rate - FS).abs() < 1e-3, "{rate}");
    assert_eq!(s.len(), N);
    assert!((s[7].gyro[1] - rows[7].g[1]).abs() < 1e-12);
    assert_eq!(
        columns(&rep),
        "t=timestamp,gx=GyrX,gy=GyrY,gz=GyrZ,ax=AccX,ay=AccY,az=AccZ"
    );
    let (gu, gs, gh) = unit(&rep, "gyro");
    assert_eq!((gu, gs), ("rad/s", "convention"), "{gh}");
    assert!(gh.contains("ArduPilot"), "{gh}");
    // The data tell the accelerometer's (median |f| ≈ 9.8): they win over any convention.
    assert_eq!(us(&rep, "accel"), ("m/s²", "data"), "{rep}");
    assert!(rep.warnings.is_empty(), "{rep}");
}

/// Date-time stamps (ISO 8601 as loggers, spreadsheets and pandas write them; RFC 3339 with a
/// zone) are read as seconds since 1970 UTC; they asked for a number before. A number among
/// date-times (or the reverse) and `--time-unit` with date-times are errors.
#[test]
fn date_time_stamps_import_as_utc_seconds() {
    // 2024-05-01T12:00:00Z.
    const T0_S: u64 = 1_714_564_800;
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 7);
    let stamp = |i: usize, sep: char, zone: &str| {
        let ms = i * 5;
        let (s, frac) = (ms / 1000, ms % 1000);
        format!(
            "2024-05-01{sep}{:02}:{:02}:{:02}.{frac:03}000{zone}",
            12 + s / 3600,
            s / 60 % 60,
            s % 60
        )
    };
    let stamp_row = |i: usize| {
        let r = &rows[i];
        format!("{},{},{}", stamp(i, 'T', ""), join(&r.g), join(&r.f))
    };
    for (name, sep, zone, how) in [
        ("pandas.csv", ' ', "", "no zone given: taken as UTC"),
        ("rfc3339.csv", 'T', "Z", "each with its zone"),
        ("offset.csv", 'T', "+00:00", "each with its zone"),
    ] {
        let p = write(dir.path(), name, "time,gx,gy,gz,ax,ay,az", &rows, |i, r| {
            format!("{},{},{}", stamp(i, sep, zone), join(&r.g), join(&r.f))
        });
        let (rate, s, rep) = import(&p);
        assert_truth(name, rate, &s, &rows);
        let (u, src, h) = unit(&rep, "time");
        assert_eq!((u, src), ("s", "date-time"), "{name}: {h}");
        assert!(h.ends_with(how), "{name}: {h}");
        // Seconds since 1970 pass through f64 (ns of 1.7e18): within 256 ns of the stamp.
        for (i, x) in s.iter().enumerate().step_by(997) {
            let want = T0_S * 1_000_000_000 + i as u64 * 5_000_000;
            assert!(x.t_ns.abs_diff(want) <= 256, "{name} row {i}: {}", x.t_ns);
        }
        assert!(rep.warnings.is_empty(), "{rep}");
    }
    // A zone other than UTC moves the stamps by it.
    let p = write(
        dir.path(),
        "cest.csv",
        "time,gx,gy,gz,ax,ay,az",
        &rows,
        |i, r| {
            let t = stamp(i, 'T', "+02:00").replacen("T12", "T14", 1);
            format!("{t},{},{}", join(&r.g), join(&r.f))
        },
    );
    let (_, s, _) = import(&p);
    assert!(
        s[0].t_ns.abs_diff(T0_S * 1_000_000_000) <= 256,
        "{}",
        s[0].t_ns
    );
    // Kinds never mix in one column, and a time unit does not apply.
    let mixed = |name: &str, line: &dyn Fn(usize, &Row) -> String| {
        let p = write(dir.path(), name, "time,gx,gy,gz,ax,ay,az", &rows, line);
        read_csv_report(&p, &ImportOptions::default())
            .unwrap_err()
            .to_string()
    };
    let e = mixed("num_after.csv", &|i, r| {
        let t = if i == 100 {
            "1714564800.5".to_string()
        } else {
            stamp(i, 'T', "")
        };
        format!("{t},{},{}", join(&r.g), join(&r.f))
    });
    assert!(
        e.contains("num_after.csv:102:")
            && e.contains("is a number, but the column's first stamp was a date-time"),
        "{e}"
    );
    let e = mixed("dt_after.csv", &|i, r| {
        let t = if i == 100 {
            stamp(i, 'T', "")
        } else {
            format!("{}", i as f64 * 0.005)
        };
        format!("{t},{},{}", join(&r.g), join(&r.f))
    });
    assert!(
        e.contains("dt_after.csv:102:")
            && e.contains("is a date-time, but the column's first stamp was a number"),
        "{e}"
    );
    // Headerless: a date-time row is data, not a header (it was taken for one, and with
    // --columns silently dropped).
    let p = write(dir.path(), "bare.csv", &stamp_row(0), &rows[1..], |i, r| {
        format!("{},{},{}", stamp(i + 1, 'T', ""), join(&r.g), join(&r.f))
    });
    let e = read_csv_report(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("bare.csv:1: no header"), "{e}");
    let o = ImportOptions {
        positions: imuprep::io::csv::parse_positions("t,gx,gy,gz,ax,ay,az").unwrap(),
        ..ImportOptions::default()
    };
    let (d, s, _) = read_csv_report(&p, &o).unwrap();
    assert_truth("bare", d.sample_rate_hz, &s, &rows);
    let p = dir.path().join("pandas.csv");
    let o = ImportOptions {
        time_unit: Some(imuprep::io::csv::TimeUnit::Ms),
        ..ImportOptions::default()
    };
    let e = read_csv_report(&p, &o).unwrap_err().to_string();
    assert!(
        e.contains("--time-unit applies to numeric time stamps"),
        "{e}"
    );
}

#[test]
fn stated_units_the_data_contradict_are_kept_with_a_warning_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 6);
    // Names say rad/s and m/s²; the values are deg/s and g.
    let p = write(
        dir.path(),
        "lying.csv",
        "t_s,gyro_x_rps,gyro_y_rps,gyro_z_rps,acc_x_mps2,acc_y_mps2,acc_z_mps2",
        &rows,
        |_, r| format!("{},{},{}", r.t, join(&deg(&r.g)), join(&in_g(&r.f))),
    );
    let (_, s, rep) = import(&p);
    assert_eq!(unit(&rep, "gyro").0, "rad/s", "stated: not overridden");
    assert_eq!(unit(&rep, "accel").0, "m/s²", "stated: not overridden");
    assert!((s[0].accel.norm() - 1.0).abs() < 0.1, "values as stated");
    assert_eq!(rep.warnings.len(), 2, "{rep}");
    assert!(
        rep.warnings[0].contains("--gyro-unit deg/s"),
        "{}",
        rep.warnings[0]
    );
    assert!(
        rep.warnings[1].contains("median |f| = ") && rep.warnings[1].contains("--accel-unit g"),
        "{}",
        rep.warnings[1]
    );
    let log = dir.path().join("lying.log");
    let out = common::run_cli(&["import", p.to_str().unwrap(), "-o", log.to_str().unwrap()]);
    assert!(
        out.lines().any(|l| l.starts_with("WARNING: accel:")),
        "{out}"
    );
    // An analysis command given the CSV imports it so and keeps the warning a warning.
    let out = common::run_cli(&[
        "allan",
        p.to_str().unwrap(),
        "--out-dir",
        dir.path().join("allan").to_str().unwrap(),
    ]);
    assert!(
        out.lines()
            .any(|l| l.contains(" WARN ") && l.contains("import: accel:")),
        "{out}"
    );
    // An option that the data contradict: the same.
    let p = write(
        dir.path(),
        "si.csv",
        "t,gx,gy,gz,ax,ay,az",
        &rows,
        |_, r| format!("{},{},{}", r.t, join(&r.g), join(&r.f)),
    );
    let o = ImportOptions {
        accel_unit: Some(imuprep::io::csv::AccelUnit::G),
        ..ImportOptions::default()
    };
    let (_, _, rep) = read_csv_report(&p, &o).unwrap();
    assert_eq!(us(&rep, "accel"), ("g", "option"));
    assert!(
        rep.warnings
            .iter()
            .any(|w| w.contains("--accel-unit says g") && w.contains("--accel-unit m/s2")),
        "{rep}"
    );
}

#[test]
fn two_candidate_columns_for_one_channel_are_an_error_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 7);
    let p = write(
        dir.path(),
        "two.csv",
        "timestamp,gyroX,gyroY,gyroZ,gyro_x_raw,accX,accY,accZ",
        &rows,
        |_, r| format!("{},{},{},{}", r.t, join(&r.g), r.g[0], join(&r.f)),
    );
    let out = common::import(&p, &dir.path().join("two.log"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("2 columns could be gx: \"gyroX\" and \"gyro_x_raw\"")
            && err.contains("--col gx=NAME"),
        "{err}"
    );
}

#[test]
fn gravity_user_acceleration_orientation_and_bias_columns_never_match() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 8);
    let decoys = "userAccelerationX,userAccelerationY,userAccelerationZ,gravityX,gravityY,gravityZ,\
                  field.orientation.x,field.orientation.y,field.orientation.z,gyro_bias_x,gyro_bias_y,gyro_bias_z,\
                  FreeAcc_X,FreeAcc_Y,FreeAcc_Z,Mag_X,Mag_Y,Mag_Z";
    let p = write(
        dir.path(),
        "ios.csv",
        &format!(
            "time,{decoys},accelerationX,accelerationY,accelerationZ,rotationRateX,rotationRateY,rotationRateZ"
        ),
        &rows,
        |_, r| {
            format!(
                "{},{},{},{}",
                r.t,
                ["7"; 18].join(","),
                join(&r.f),
                join(&r.g)
            )
        },
    );
    let (rate, s, rep) = import(&p);
    assert_truth("decoys", rate, &s, &rows);
    assert_eq!(
        columns(&rep),
        "t=time,gx=rotationRateX,gy=rotationRateY,gz=rotationRateZ,ax=accelerationX,ay=accelerationY,az=accelerationZ"
    );
    // Only decoys: no sensor column at all.
    let p = write(
        dir.path(),
        "decoys.csv",
        &format!("time,{decoys}"),
        &rows,
        |_, r| format!("{},{}", r.t, ["7"; 18].join(",")),
    );
    let e = read_csv_report(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no sensor column"), "{e}");
}

#[test]
fn time_in_ms_us_or_ns_without_a_unit_in_the_name_is_inferred_from_the_rate() {
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 9);
    for (u, per_s, name) in [
        ("s", 1.0, "s"),
        ("ms", 1e3, "ms"),
        ("us", 1e6, "us"),
        ("ns", 1e9, "ns"),
    ] {
        let p = write(
            dir.path(),
            &format!("{u}.csv"),
            "timestamp,gx,gy,gz,ax,ay,az",
            &rows,
            |_, r| {
                format!(
                    "{},{},{}",
                    // Whole ms, µs, ns (as loggers write them); seconds as they are.
                    1000.0 * per_s
                        + if per_s > 1.0 {
                            (r.t * per_s).round()
                        } else {
                            r.t
                        },
                    join(&r.g),
                    join(&r.f)
                )
            },
        );
        let (rate, _, rep) = import(&p);
        assert!((rate - FS).abs() < 1e-6, "{u}: {rate} Hz; {rep}");
        assert_eq!(unit(&rep, "time").0, name, "{rep}");
    }
}

/// The walk recording rewritten in EuRoC layout (ns, rad/s, m/s², converted here) imports to
/// the same samples as the original, to f32 precision.
#[test]
fn the_real_walk_in_euroc_layout_imports_to_the_same_samples_as_the_original() {
    let Some(src) = common::real_data("rtklibexplorer_drive_walk/walk_0827_imu.csv") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&src).unwrap();
    let mut lines = text.lines();
    let h: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| h.iter().position(|x| *x == n).unwrap();
    let (it, ig, ia) = (
        col("gpst_s"),
        ["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"].map(col),
        ["acc_x_g", "acc_y_g", "acc_z_g"].map(col),
    );
    let mut out = String::from(
        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n",
    );
    for l in lines.filter(|l| !l.is_empty()) {
        let c: Vec<&str> = l.split(',').collect();
        // gpst_s text → integer ns exactly.
        let (sec, frac) = c[it].split_once('.').unwrap_or((c[it], ""));
        let ns = sec.parse::<u64>().unwrap() * 1_000_000_000
            + format!("{frac:0<9}")[..9].parse::<u64>().unwrap();
        let g = ig.map(|i| c[i].parse::<f64>().unwrap() * D2R);
        let a = ia.map(|i| c[i].parse::<f64>().unwrap() * G0);
        let _ = writeln!(out, "{ns},{},{}", join(&g), join(&a));
    }
    let euroc = dir.path().join("walk_euroc.csv");
    std::fs::write(&euroc, out).unwrap();
    let (r0, s0, _) = import(&src);
    let (r1, s1, rep) = import(&euroc);
    assert_eq!(s0.len(), s1.len());
    assert!((r0 - r1).abs() < 1e-3, "{r0} vs {r1} Hz");
    assert!(rep.warnings.is_empty(), "{rep}");
    let mut worst_t = 0u64;
    for (k, (a, b)) in s0.iter().zip(&s1).enumerate() {
        // gpst_s (1.76e9 s) as f64 × 1e9 and the ns integer as f64 each round by < 256 ns.
        worst_t = worst_t.max(a.t_ns.abs_diff(b.t_ns));
        assert_eq!(a.seq, b.seq, "row {k}");
        assert_eq!(a.flags, b.flags, "row {k}");
        for c in 0..3 {
            assert_eq!(a.gyro[c] as f32, b.gyro[c] as f32, "row {k} g{c}");
            assert_eq!(a.accel[c] as f32, b.accel[c] as f32, "row {k} a{c}");
        }
    }
    assert!(worst_t <= 512, "time differs by {worst_t} ns");
}

#[test]
fn gyro_and_accel_on_separate_rows_merge_onto_one_stream_and_say_so() {
    // A logger writing each sensor event on its own row (phone apps, two ROS topics merged):
    // gyro rows and accel rows, the other triad's cells empty, in deg/s and g (so the units are
    // decided on the merged samples, by the gravity-direction fit).
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 11);
    let empty = ",,";
    // Both stamped alike, the accel row first: each gyro row's accel is its own time's (the
    // interpolation weight is 0), so the merged samples are the truth.
    let p = write(
        dir.path(),
        "same_time.csv",
        "t,gx,gy,gz,ax,ay,az",
        &rows,
        |_, r| {
            format!(
                "{t},{empty},{}\n{t},{},{empty}",
                join(&in_g(&r.f)),
                join(&deg(&r.g)),
                t = r.t
            )
        },
    );
    let (rate, s, rep) = import(&p);
    assert_truth("separate rows, same stamps", rate, &s, &rows);
    let m = rep.streams.as_ref().expect("merged");
    assert_eq!(
        (m.rows_read, m.gyro_only, m.accel_only),
        (2 * N as u64, N as u64, N as u64)
    );
    assert_eq!((m.same_time, m.interpolated, m.unpaired), (N as u64, 0, 0));
    assert_eq!(
        (us(&rep, "gyro"), us(&rep, "accel")),
        (("deg/s", "data"), ("g", "data"))
    );
    assert!(rep.empty_cells.is_empty(), "{rep}");

    // The accel half a sample late, after its gyro row: a gyro row's accel is the mean of the
    // accel rows on each side; the first gyro row has none before it, so its accel is missing.
    let p = write(
        dir.path(),
        "offset.csv",
        "t,gx,gy,gz,ax,ay,az",
        &rows,
        |_, r| {
            format!(
                "{},{},{empty}\n{},{empty},{}",
                r.t,
                join(&r.g),
                r.t + 0.5 / FS,
                join(&r.f)
            )
        },
    );
    let (rate, s, rep) = import(&p);
    assert!((rate - FS).abs() < 1e-6, "{rate}");
    assert_eq!(s.len(), N);
    assert!(s[0].accel.iter().all(|v| v.is_nan()));
    for k in 1..N {
        for c in 0..3 {
            let want = 0.5 * (rows[k - 1].f[c] + rows[k].f[c]);
            assert!((s[k].accel[c] - want).abs() < 1e-9, "row {k} a{c}");
            assert!((s[k].gyro[c] - rows[k].g[c]).abs() < 1e-9, "row {k} g{c}");
        }
    }
    let m = rep.streams.as_ref().expect("merged");
    assert_eq!(
        (m.same_time, m.interpolated, m.unpaired),
        (0, N as u64 - 1, 1)
    );
    assert_eq!(rep.empty_cells.len(), 3, "{rep}");
    // The CLI says it.
    let log = dir.path().join("offset.log");
    let out = common::run_cli(&["import", p.to_str().unwrap(), "-o", log.to_str().unwrap()]);
    assert!(
        out.contains("two streams in one table (16000 rows read: 8000 with only the gyro, 8000 with only the accel, 0 with both): merged onto the gyro's time stamps"),
        "{out}"
    );
    assert!(
        out.contains("1 sample with no accel row on each side"),
        "{out}"
    );
    assert!(out.contains("imported 8000 samples"), "{out}");
}

#[test]
fn xsens_exports_are_timed_by_sample_time_fine_in_the_product_s_ticks() {
    // MT Manager's export of an MTi: a comment preamble, tab-separated, PacketCounter, then
    // SampleTimeFine in 100-µs ticks (10 kHz), Acc_X.. in m/s², Gyr_X.. in rad/s (the data
    // decide the gyro unit: the sensor rolls).
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 5);
    let mut text = String::from(
        "// Start Time: Unknown\n// Update Rate: 200.0Hz\n// Filter Profile: human (46.1)\n\
         PacketCounter\tSampleTimeFine\tAcc_X\tAcc_Y\tAcc_Z\tGyr_X\tGyr_Y\tGyr_Z\n",
    );
    let tab = |v: &[f64; 3]| join(v).replace(',', "\t");
    for (i, r) in rows.iter().enumerate() {
        // 50 ticks per sample from an arbitrary start.
        writeln!(
            text,
            "{}\t{}\t{}\t{}",
            i % 65536,
            7_000_000 + 50 * i,
            tab(&r.f),
            tab(&r.g)
        )
        .unwrap();
    }
    let p = dir.path().join("MT_01.txt");
    std::fs::write(&p, text).unwrap();
    let (rate, s, rep) = import(&p);
    common::assert_rows("xsens mti", (rate, FS), &s, &rows);
    let (u, src, how) = unit(&rep, "time");
    assert_eq!((u, src), ("100us", "name"), "{how}");
    assert!(how.contains("as the Xsens MTi counts it"), "{how}");
    assert_eq!(s[1].t_ns - s[0].t_ns, 5_000_000);
    assert!(
        columns(&rep).starts_with("t=SampleTimeFine,gx=Gyr_X"),
        "{rep}"
    );

    // Xsens DOT (at most 120 Hz) counts µs: at 60 Hz, 16667 apart, which as 100-µs ticks
    // would be 0.6 Hz.
    let dot = common::rocking(2400, 60.0, 0.0, 20.0, 6);
    let p = write(
        dir.path(),
        "dot.csv",
        "PacketCounter,SampleTimeFine,Acc_X,Acc_Y,Acc_Z,Gyr_X,Gyr_Y,Gyr_Z",
        &dot,
        |i, r| {
            let us = (i as f64 * 1e6 / 60.0).round() as u64;
            format!("{i},{},{},{}", 1_000_000 + us, join(&r.f), join(&deg(&r.g)))
        },
    );
    let (rate, s, rep) = import(&p);
    assert!((rate - 60.0).abs() < 0.01, "{rate}");
    assert_eq!(s.len(), dot.len());
    let (u, src, how) = unit(&rep, "time");
    assert_eq!((u, src), ("us", "name"), "{how}");
    assert!(how.contains("as Xsens DOT counts it"), "{how}");
    assert_eq!(us(&rep, "gyro"), ("deg/s", "data"), "{rep}");
    assert!(rep.warnings.is_empty(), "{rep}");
    assert!(rep.notes.is_empty(), "{rep}");

    // DOT's µs counter wraps at 2³² (1.2 h): started 10 s before the wrap, the stamps run on.
    let start = (1u64 << 32) - 10_000_000;
    let p = write(
        dir.path(),
        "dot_wrap.csv",
        "PacketCounter,SampleTimeFine,Acc_X,Acc_Y,Acc_Z,Gyr_X,Gyr_Y,Gyr_Z",
        &dot,
        |i, r| {
            let us = start + (i as f64 * 1e6 / 60.0).round() as u64;
            format!("{i},{},{},{}", us % (1 << 32), join(&r.f), join(&deg(&r.g)))
        },
    );
    let (rate, s, rep) = import(&p);
    assert!((rate - 60.0).abs() < 0.01, "{rate}");
    assert_eq!(
        (rep.time.gaps, rep.time.backwards, rep.time.restarts),
        (0, 0, 0),
        "{rep}"
    );
    let span = s.last().unwrap().t_ns - s[0].t_ns;
    assert_eq!(span, (2399.0f64 * 1e6 / 60.0).round() as u64 * 1000);
    assert!(
        rep.to_string()
            .contains("the 32-bit counter \"SampleTimeFine\" wrapped 1 time"),
        "{rep}"
    );
}

#[test]
fn one_table_per_sensor_imports_merged_with_accel_file() {
    // A phone sensor app's export: Gyroscope.csv and TotalAcceleration.csv, each `time` (ns since
    // 1970), `seconds_elapsed`, then bare z, y, x; the accelerometer 1 ms after the gyro. Units
    // are stated nowhere: the gravity-direction fit decides them on the merged samples.
    use imuprep::io::csv::read_per_sensor_report;
    const T0: u64 = 1_700_000_000_000_000_000;
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 8);
    let header = "time,seconds_elapsed,z,y,x";
    let zyx = |v: &[f64; 3]| format!("{},{},{}", v[2], v[1], v[0]);
    let stamp = |i: usize, late_ns: u64| T0 + i as u64 * 5_000_000 + late_ns;
    let g = write(dir.path(), "Gyroscope.csv", header, &rows, |i, r| {
        format!("{},{},{}", stamp(i, 0), r.t, zyx(&r.g))
    });
    let a = write(
        dir.path(),
        "TotalAcceleration.csv",
        header,
        &rows,
        |i, r| format!("{},{},{}", stamp(i, 1_000_000), r.t + 0.001, zyx(&r.f)),
    );
    let (d, s, rep) =
        read_per_sensor_report(&g, &a, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!((d.sample_rate_hz - FS).abs() < 1e-6);
    assert_eq!(s.len(), N);
    // Gyro rows unaltered; each accel the linear interpolation between the accel rows on each
    // side, at the weight the stamps give as read (f64 of the ns integers); the first gyro row
    // has none before it.
    assert!(s[0].accel.iter().all(|v| v.is_nan()));
    for k in 1..N {
        let (ta, tb, ti) = (
            stamp(k - 1, 1_000_000) as f64,
            stamp(k, 1_000_000) as f64,
            stamp(k, 0) as f64,
        );
        let w = (ti - ta) / (tb - ta);
        for c in 0..3 {
            let want = rows[k - 1].f[c] + w * (rows[k].f[c] - rows[k - 1].f[c]);
            assert!((s[k].accel[c] - want).abs() < 1e-9, "row {k} a{c}");
            assert!((s[k].gyro[c] - rows[k].g[c]).abs() < 1e-9, "row {k} g{c}");
        }
    }
    let m = rep.streams.as_ref().expect("merged");
    assert_eq!(
        (m.gyro_only, m.accel_only, m.interpolated, m.unpaired),
        (8000, 8000, 7999, 1)
    );
    assert_eq!(us(&rep, "gyro"), ("rad/s", "data"), "{rep}");
    assert_eq!(us(&rep, "accel"), ("m/s²", "data"), "{rep}");
    assert_eq!(us(&rep, "time"), ("ns", "data"), "{rep}");
    assert!(
        columns(&rep).contains("gx=Gyroscope.csv:x")
            && columns(&rep).contains("az=TotalAcceleration.csv:z"),
        "{rep}"
    );
    // Each file's own time column is named, and the line of the one missing accel is the
    // gyro file's (the samples are its rows).
    assert!(
        columns(&rep)
            .contains("t=Gyroscope.csv:time (gyro rows), TotalAcceleration.csv:time (accel rows)"),
        "{rep}"
    );
    assert!(
        rep.empty_cells
            .iter()
            .all(|e| e.first_line == 2 && e.file.as_deref() == Some("Gyroscope.csv")),
        "{rep}"
    );
    // The CLI.
    let log = dir.path().join("phone.log");
    let out = common::run_cli(&[
        "import",
        g.to_str().unwrap(),
        "--accel-file",
        a.to_str().unwrap(),
        "-o",
        log.to_str().unwrap(),
    ]);
    assert!(
        out.contains("two streams in two files (16000 rows read"),
        "{out}"
    );
    assert!(out.contains("TotalAcceleration.csv into"), "{out}");

    // Refused, each with the reason: the same file twice, time in different units, no overlap.
    let refused = |accel: &Path, why: &str| {
        let e = read_per_sensor_report(&g, accel, &ImportOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(why), "{e}");
    };
    refused(&g, "names the input itself");
    let grav = write(dir.path(), "Gravity.csv", header, &rows, |i, r| {
        format!("{},{},{}", stamp(i, 1_000_000), r.t, zyx(&r.f))
    });
    refused(&grav, "the file name says \"gravity\"");
    let secs = write(dir.path(), "acc_s.csv", header, &rows, |_, r| {
        format!("{},{},{}", r.t + 1.7e9, r.t, zyx(&r.f))
    });
    refused(&secs, "two time units?");
    let later = write(dir.path(), "acc_later.csv", header, &rows, |i, r| {
        format!("{},{},{}", stamp(i + 2 * N, 0), r.t, zyx(&r.f))
    });
    refused(&later, "do not overlap");

    // Both files stamped by a 32-bit µs counter that wraps 10 s in: each file's wrap is undone
    // before the rows are interleaved (after it, one file's wrapped rows would sort first).
    let start = (1u64 << 32) - 10_000_000;
    let us = |i: usize, late: u64| (start + i as u64 * 5_000 + late) % (1 << 32);
    let gw = write(
        dir.path(),
        "gyro_us.csv",
        "micros,gx,gy,gz",
        &rows,
        |i, r| format!("{},{}", us(i, 0), join(&r.g)),
    );
    let aw = write(
        dir.path(),
        "acc_us.csv",
        "micros,ax,ay,az",
        &rows,
        |i, r| format!("{},{}", us(i, 2_500), join(&r.f)),
    );
    let (_, s, rep) = read_per_sensor_report(&gw, &aw, &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.len(), N);
    assert_eq!((rep.time.backwards, rep.time.gaps), (0, 0), "{rep}");
    let m = rep.streams.as_ref().expect("merged");
    assert_eq!((m.interpolated, m.unpaired), (N as u64 - 1, 1), "{rep}");
    assert_eq!(rep.notes.len(), 2, "{rep}");
    for k in [1, N / 2, N - 1] {
        let want = 0.5 * (rows[k - 1].f[2] + rows[k].f[2]);
        assert!((s[k].accel[2] - want).abs() < 1e-9, "row {k}");
    }
}

#[test]
fn a_micros_wrap_is_unwrapped_and_a_restart_is_not() {
    // An Arduino sketch printing micros(): the 32-bit µs count wraps 71.6 min after boot; this
    // log starts 20 s before it.
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(20.0, 9);
    let start = (1u64 << 32) - 20_000_000;
    let p = write(
        dir.path(),
        "ard.csv",
        "micros,gx,gy,gz,ax,ay,az",
        &rows,
        |i, r| {
            let us = (start + i as u64 * 5_000) % (1 << 32);
            format!("{us},{},{}", join(&r.g), join(&r.f))
        },
    );
    let (rate, s, rep) = import(&p);
    assert_truth("micros across the wrap", rate, &s, &rows);
    assert_eq!(us(&rep, "time"), ("us", "name"));
    assert_eq!((rep.time.backwards, rep.time.gaps), (0, 0), "{rep}");
    assert_eq!(s[N - 1].t_ns - s[0].t_ns, (N as u64 - 1) * 5_000_000);
    assert!(
        rep.to_string().contains("\"micros\" wrapped 1 time"),
        "{rep}"
    );
    // A reboot half-way (the count restarts near 0.3 s of uptime): kept as a restart.
    let p = write(
        dir.path(),
        "reboot.csv",
        "micros,gx,gy,gz,ax,ay,az",
        &rows,
        |i, r| {
            let us = if i < N / 2 {
                3_000_000_000 + i as u64 * 5_000
            } else {
                300_000 + (i - N / 2) as u64 * 5_000
            };
            format!("{us},{},{}", join(&r.g), join(&r.f))
        },
    );
    let (_, _, rep) = import(&p);
    assert_eq!((rep.time.backwards, rep.time.restarts), (1, 1), "{rep}");
    assert!(rep.notes.is_empty(), "{rep}");
}

#[test]
fn rows_of_several_sensors_are_refused_until_where_picks_one() {
    // An ArduPilot IMU export with two instances: each time stamp has a row of IMU 0 and one of
    // IMU 1 (here the second sensor reads twice the first's rate and 0.5 m/s² more on x).
    let dir = tempfile::tempdir().unwrap();
    let rows = motion(0.0, 13);
    let header = "timestamp,TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ";
    let p = write(dir.path(), "two.csv", header, &rows, |i, r| {
        let second = [2.0 * r.g[0], 2.0 * r.g[1], 2.0 * r.g[2]];
        let f2 = [r.f[0] + 0.5, r.f[1], r.f[2]];
        let t = 123_456 + i * 5000;
        format!(
            "{s},{t},0,{},{}\n{s},{t},1,{},{}",
            join(&r.g),
            join(&r.f),
            join(&second),
            join(&f2),
            s = 1.7e9 + r.t
        )
    });
    let e = read_csv_report(&p, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("column \"I\" holds the rows of several sensors (0: 8000 rows, 1: 8000 rows)")
            && e.contains("--where I=0"),
        "{e}"
    );
    for (want, scale, dx) in [("1", 2.0, 0.5), ("0.0", 1.0, 0.0)] {
        let o = ImportOptions {
            select: Some(("I".into(), want.into())),
            ..Default::default()
        };
        let (_, s, rep) = read_csv_report(&p, &o).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.len(), N);
        assert_eq!(rep.time.duplicates, 0, "{rep}");
        for k in (0..N).step_by(997) {
            assert!((s[k].gyro[2] - scale * rows[k].g[2]).abs() < 1e-12);
            assert!((s[k].accel[0] - rows[k].f[0] - dx).abs() < 1e-12);
        }
        assert!(
            rep.to_string().contains(&format!(
                "rows where I = {want}: 8000 read, 8000 of other values left out"
            )),
            "{rep}"
        );
    }
    let none = ImportOptions {
        select: Some(("I".into(), "2".into())),
        ..Default::default()
    };
    let e = read_csv_report(&p, &none).unwrap_err().to_string();
    assert!(e.contains("no row has I = \"2\""), "{e}");
    // The CLI flag.
    let log = dir.path().join("i1.log");
    let out = common::run_cli(&[
        "import",
        p.to_str().unwrap(),
        "--where",
        "I=1",
        "-o",
        log.to_str().unwrap(),
    ]);
    assert!(out.contains("imported 8000 samples"), "{out}");
    // A sample counter named `id` is no instance column.
    let p = write(
        dir.path(),
        "ids.csv",
        "id,t,gx,gy,gz,ax,ay,az",
        &rows,
        |i, r| format!("{i},{},{},{}", r.t, join(&r.g), join(&r.f)),
    );
    assert_eq!(import(&p).1.len(), N);
}
