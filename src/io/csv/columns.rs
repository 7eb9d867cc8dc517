//! Which column is which: a CSV header → the columns of t, gx..az and temp, and the units their
//! names state.
//!
//! A name is split into lowercase tokens: at every non-alphanumeric character, at camelCase
//! boundaries (`rotationRateX` → rotation, rate, x) and before a trailing axis letter of a short
//! stem (`accx` → acc, x; `wx` → w, x). A sensor column is a name with one axis token (x, y or z)
//! and a family:
//!
//! * gyro — a token starting `gyr` (gyro, gyroscope, GyrX), `omega` (Kalibr), `angular velocity` /
//!   `angular rate` / `ang vel` (ROS `field.angular_velocity.x`), `rotation rate` (iOS
//!   `rotationRateX`), or a first token `g` / `w` (`gX` of a SparkFun OpenLog, `wx`, EuRoC's
//!   `w_RS_S_x`);
//! * accel — a token `acc` or starting `accel` (acc, accel, accelerometer, acceleration, AccX),
//!   `alpha` (Kalibr's `alpha_x`), or a first token `a` (`aX`, EuRoC's `a_RS_S_x`); not after
//!   `angular` (angular acceleration).
//!
//! Never a sensor column, whatever else the name says: estimates and derived quantities
//! ([`EXCLUDED`]: bias, gravity, CoreMotion's gravity-free `userAcceleration`, Xsens' `FreeAcc`,
//! orientation, quaternion, Euler angles, magnetometer, covariance, ...). An exact canonical name
//! (`gx`) wins over token matches; two token matches for one channel are an error naming both.

use super::streams::Triad;
use super::{AccelUnit, CANON, GyroUnit, ImportOptions, TimeUnit};

/// Tokens that make a column no sensor column (an estimate or a derived quantity).
pub const EXCLUDED: &[&str] = &[
    "bias",
    "gravity",
    "grav",
    "user",
    "free",
    "orientation",
    "quat",
    "quaternion",
    "euler",
    "angle",
    "angles",
    "roll",
    "pitch",
    "yaw",
    "heading",
    "attitude",
    "mag",
    "magn",
    "magnetometer",
    "magnetic",
    "cov",
    "std",
    "sigma",
    "var",
    "variance",
];

/// Stems a trailing axis letter is split from (`accx` → acc, x).
const AXIS_STEMS: &[&str] = &["a", "g", "w", "acc", "accel", "gyr", "gyro", "omega"];

/// The lowercase tokens of a column name (see the module docs).
pub fn tokens(name: &str) -> Vec<String> {
    // µ and ° are the only non-ASCII characters a unit needs: `(µs)` is microseconds, `(°/s)`
    // degrees per second.
    let name = name.replace(['µ', 'μ'], "u").replace('°', " deg ");
    let mut out = Vec::new();
    for word in name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
    {
        // camelCase: a break before an upper-case letter that follows a lower-case one, and
        // before the last capital of a capital run followed by a lower-case letter (IMUAcc).
        let b = word.as_bytes();
        let mut start = 0;
        for i in 1..b.len() {
            let lower_upper = b[i - 1].is_ascii_lowercase() && b[i].is_ascii_uppercase();
            let run_end = b[i - 1].is_ascii_uppercase()
                && b[i].is_ascii_uppercase()
                && b.get(i + 1).is_some_and(u8::is_ascii_lowercase);
            if lower_upper || run_end {
                out.push(word[start..i].to_ascii_lowercase());
                start = i;
            }
        }
        out.push(word[start..].to_ascii_lowercase());
    }
    out.into_iter()
        .flat_map(|t| {
            let n = t.len();
            match t.as_bytes().last() {
                Some(b'x' | b'y' | b'z') if n >= 2 && AXIS_STEMS.contains(&&t[..n - 1]) => {
                    vec![t[..n - 1].to_string(), t[n - 1..].to_string()]
                }
                _ => vec![t],
            }
        })
        .collect()
}

fn adjacent(t: &[String], a: &[&str], b: &[&str]) -> bool {
    t.windows(2)
        .any(|w| a.contains(&w[0].as_str()) && b.contains(&w[1].as_str()))
}

/// Gyro family (see the module docs).
fn is_gyro(t: &[String]) -> bool {
    t.iter().any(|x| x.starts_with("gyr") || x == "omega")
        || adjacent(t, &["angular", "ang"], &["velocity", "vel", "rate"])
        || adjacent(t, &["rotation", "rot"], &["rate"])
        || matches!(t.first().map(String::as_str), Some("g" | "w"))
}

/// Accelerometer family (see the module docs).
fn is_accel(t: &[String]) -> bool {
    let acc = |x: &str| x == "acc" || x == "accl" || x.starts_with("accel");
    let angular = t
        .windows(2)
        .any(|w| (w[0] == "angular" || w[0] == "ang") && acc(&w[1]));
    !angular && (t.iter().any(|x| acc(x) || x == "alpha") || t.first().is_some_and(|x| x == "a"))
}

/// The one axis a name's tokens give (x, y, z as 0, 1, 2), if exactly one.
fn axis_of(t: &[String]) -> Option<usize> {
    let mut found = None;
    for x in t {
        let a = match x.as_str() {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => continue,
        };
        if found.is_some_and(|f| f != a) {
            return None;
        }
        found = Some(a);
    }
    found
}

/// The channel (0..6: gx, gy, gz, ax, ay, az) a column's tokens name, if any.
pub fn channel_of(t: &[String]) -> Result<Option<usize>, &'static str> {
    if t.iter()
        .any(|x| EXCLUDED.contains(&x.as_str()) || x.starts_with("covariance"))
    {
        return Ok(None);
    }
    let Some(axis) = axis_of(t) else {
        return Ok(None);
    };
    match (is_gyro(t), is_accel(t)) {
        (true, true) => Err("names both a gyro and an accelerometer family"),
        (true, false) => Ok(Some(axis)),
        (false, true) => Ok(Some(3 + axis)),
        (false, false) => Ok(None),
    }
}

/// A time column: the first token `t`, `time`, `timestamp` or `gpst`, no `tick`; Arduino's
/// `micros` / `millis` (the functions' names, as sketches print them); or Xsens'
/// `SampleTimeFine`.
fn is_time(t: &[String]) -> bool {
    (matches!(
        t.first().map(String::as_str),
        Some("t" | "time" | "timestamp" | "gpst")
    ) && !t.iter().any(|x| x == "tick"))
        || matches!(t, [x] if x == "micros" || x == "millis")
        || xsens_fine(t)
}

/// Xsens' `SampleTimeFine` (MT Manager's exports): a 10 kHz counter, 100 µs per tick.
fn xsens_fine(t: &[String]) -> bool {
    t == ["sample", "time", "fine"]
}

/// Resolve the columns of t, gx, gy, gz, ax, ay, az, temp: `--col` names, exact canonical names,
/// then token matches. `Err` is the message of a column problem.
pub fn resolve(header: &[String], o: &ImportOptions) -> Result<[Option<usize>; 8], String> {
    let toks: Vec<Vec<String>> = header.iter().map(|h| tokens(h)).collect();
    let mut idx = [None; 8];
    // Candidates per channel (gx..az) among the columns, in header order.
    let mut cand: [Vec<usize>; 6] = Default::default();
    for (p, t) in toks.iter().enumerate() {
        if let Some(c) = channel_of(t).map_err(|m| format!("column {:?} {m}", header[p]))? {
            cand[c].push(p);
        }
    }
    // One table per sensor: its triad's columns only, and bare `x`, `y`, `z` are its axes.
    if let Some(only) = o.only {
        let first = if only == Triad::Gyro { 0 } else { 3 };
        for (c, v) in cand.iter_mut().enumerate() {
            if !(first..first + 3).contains(&c) {
                v.clear();
            }
        }
        for (p, t) in toks.iter().enumerate() {
            if let [x] = t.as_slice()
                && let Some(a) = ["x", "y", "z"].iter().position(|n| n == x)
                && cand[first + a].is_empty()
            {
                cand[first + a].push(p);
            }
        }
    }
    for (k, canon) in CANON.iter().enumerate() {
        if let Some(name) = &o.columns[k] {
            idx[k] = Some(
                header
                    .iter()
                    .position(|h| h.trim() == name)
                    .ok_or_else(|| format!("no column named {name:?} (given for {canon})"))?,
            );
            continue;
        }
        if let Some(p) = header.iter().position(|h| h.trim() == *canon) {
            idx[k] = Some(p);
            continue;
        }
        idx[k] = match k {
            // Time and temperature: the first match ("bias" columns are never the sensor's).
            0 | 7 => toks.iter().position(|t| {
                !t.iter().any(|x| x == "bias")
                    && if k == 0 {
                        is_time(t)
                    } else {
                        t.iter().any(|x| x.starts_with("temp"))
                    }
            }),
            _ => match cand[k - 1].as_slice() {
                [] => None,
                [p] => Some(*p),
                ps => {
                    let names: Vec<String> =
                        ps.iter().map(|&p| format!("{:?}", header[p])).collect();
                    return Err(format!(
                        "{} columns could be {canon}: {} — name the one to use with --col {canon}=NAME",
                        ps.len(),
                        names.join(" and ")
                    ));
                }
            },
        };
    }
    Ok(idx)
}

/// What a triad's column names say of its unit.
#[derive(Debug, Clone, PartialEq)]
pub enum NameUnit<U> {
    /// A unit in the name (`_dps`, `(g)`, `[rad s^-1]`); the column.
    Stated(U, String),
    /// No unit in the name, but names with a documented convention (canonical `gx`, ROS
    /// `sensor_msgs/Imu` fields): SI unless the data say otherwise; the convention's name.
    Convention(U, &'static str),
    /// Nothing: the data must tell, else the user.
    Unknown,
}

/// Units read from name tokens: `dps`/`deg` → deg/s, `rps`/`rad` → rad/s.
fn gyro_unit_of(t: &[String]) -> Option<GyroUnit> {
    if t.iter().any(|x| x == "mdps" || x == "mdeg") {
        Some(GyroUnit::MilliDegS)
    } else if t.iter().any(|x| x == "dps" || x.starts_with("deg")) {
        Some(GyroUnit::DegS)
    } else if t.iter().any(|x| x == "rps" || x.starts_with("rad")) {
        Some(GyroUnit::RadS)
    } else {
        None
    }
}

/// `g` → g, `mps2`/`ms2`/`m` → m/s² (EuRoC's `[m s^-2]` is m, s, 2).
fn accel_unit_of(t: &[String]) -> Option<AccelUnit> {
    if t.iter().any(|x| x == "mg") {
        Some(AccelUnit::MilliG)
    } else if t.iter().any(|x| x == "g") {
        Some(AccelUnit::G)
    } else if t.iter().any(|x| x == "mps2" || x == "ms2" || x == "m") {
        Some(AccelUnit::MS2)
    } else {
        None
    }
}

/// A time unit in the name: ms, us, ns, s (and their longer spellings).
fn time_unit_of(t: &[String]) -> Option<TimeUnit> {
    let has = |xs: &[&str]| t.iter().any(|x| xs.contains(&x.as_str()));
    if has(&["ms", "msec", "millis", "milliseconds"]) {
        Some(TimeUnit::Ms)
    } else if has(&["ns", "nsec", "nanos", "nanoseconds"]) {
        Some(TimeUnit::Ns)
    } else if has(&["us", "usec", "micros", "microseconds"]) {
        Some(TimeUnit::Us)
    } else if has(&["s", "sec", "secs", "second", "seconds"]) {
        Some(TimeUnit::S)
    } else {
        None
    }
}

/// The tokens and name of a triad's first present column (`ks` channel keys 1..=3 or 4..=6).
fn first_of<'a>(
    header: &'a [String],
    idx: &[Option<usize>; 8],
    ks: std::ops::RangeInclusive<usize>,
) -> Option<(usize, &'a str)> {
    ks.into_iter()
        .find_map(|k| idx[k].map(|p| (k, header[p].trim())))
}

/// Kalibr's `imu0.csv` names, `omega_x` and `alpha_x` with nothing else: its format fixes rad/s
/// and m/s² (and time stamps in ns, which the data tell anyway).
fn kalibr(t: &[String], stem: &str) -> bool {
    matches!(t, [a, x] if a == stem && ["x", "y", "z"].contains(&x.as_str()))
}

/// ArduPilot's IMU message as pymavlink's `mavlogdump.py --format csv` writes it: `TimeUS`
/// beside `GyrX` / `AccX`, whose units the message defines (rad/s, m/s²).
fn ardupilot(header: &[String], name: &str, stem: &str) -> bool {
    header.iter().any(|h| h.trim() == "TimeUS") && name.len() == 4 && name.starts_with(stem)
}

/// What the gyro columns' names say of their unit (`Unknown` too when there is no gyro).
pub fn gyro_named(header: &[String], idx: &[Option<usize>; 8]) -> NameUnit<GyroUnit> {
    let Some((k, name)) = first_of(header, idx, 1..=3) else {
        return NameUnit::Unknown;
    };
    let t = tokens(name);
    if ardupilot(header, name, "Gyr") {
        return NameUnit::Convention(GyroUnit::RadS, "ArduPilot IMU message fields (GyrX …)");
    }
    if name == CANON[k] {
        NameUnit::Convention(GyroUnit::RadS, "canonical names")
    } else if let Some(u) = gyro_unit_of(&t) {
        NameUnit::Stated(u, name.to_string())
    } else if adjacent(&t, &["angular"], &["velocity"]) {
        NameUnit::Convention(GyroUnit::RadS, "ROS sensor_msgs/Imu field")
    } else if kalibr(&t, "omega") {
        NameUnit::Convention(GyroUnit::RadS, "Kalibr imu.csv names (omega_x …)")
    } else {
        NameUnit::Unknown
    }
}

/// What the accel columns' names say of their unit.
pub fn accel_named(header: &[String], idx: &[Option<usize>; 8]) -> NameUnit<AccelUnit> {
    let Some((k, name)) = first_of(header, idx, 4..=6) else {
        return NameUnit::Unknown;
    };
    let t = tokens(name);
    if ardupilot(header, name, "Acc") {
        return NameUnit::Convention(AccelUnit::MS2, "ArduPilot IMU message fields (AccX …)");
    }
    if name == CANON[k] {
        NameUnit::Convention(AccelUnit::MS2, "canonical names")
    } else if let Some(u) = accel_unit_of(&t) {
        NameUnit::Stated(u, name.to_string())
    } else if adjacent(&t, &["linear"], &["acceleration"]) {
        NameUnit::Convention(AccelUnit::MS2, "ROS sensor_msgs/Imu field")
    } else if kalibr(&t, "alpha") {
        NameUnit::Convention(AccelUnit::MS2, "Kalibr imu.csv names (alpha_x …)")
    } else {
        NameUnit::Unknown
    }
}

/// What the time column's name says of its unit (`None`: nothing, the data are checked).
pub fn time_named(header: &[String], idx: &[Option<usize>; 8]) -> Option<(TimeUnit, String)> {
    let name = header[idx[0]?].trim();
    let t = tokens(name);
    if xsens_fine(&t) {
        return Some((TimeUnit::Tick100Us, name.to_string()));
    }
    time_unit_of(&t).map(|u| (u, name.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: &str) -> Vec<String> {
        tokens(s)
    }

    #[test]
    fn tokens_split_camel_case_axis_letters_and_units() {
        assert_eq!(t("accX"), ["acc", "x"]);
        assert_eq!(t("rotationRateX"), ["rotation", "rate", "x"]);
        assert_eq!(t("userAccelerationX"), ["user", "acceleration", "x"]);
        assert_eq!(t("GyrX"), ["gyr", "x"]);
        assert_eq!(t("wx"), ["w", "x"]);
        assert_eq!(t("gX"), ["g", "x"]);
        assert_eq!(t("IMUAccZ"), ["imu", "acc", "z"]);
        assert_eq!(
            t("w_RS_S_x [rad s^-1]"),
            ["w", "rs", "s", "x", "rad", "s", "1"]
        );
        assert_eq!(t("#timestamp [ns]"), ["timestamp", "ns"]);
        assert_eq!(t("Time (µs)"), ["time", "us"]);
        assert_eq!(t("Gyro X (°/s)"), ["gyro", "x", "deg", "s"]);
        // Names of the real recordings keep their tokens.
        assert_eq!(t("acc_x_mps2"), ["acc", "x", "mps2"]);
        assert_eq!(t("Gyroscope X (deg/s)"), ["gyroscope", "x", "deg", "s"]);
        assert_eq!(t("imu_tick_ms"), ["imu", "tick", "ms"]);
        // Words that end in x but are no stem keep it.
        assert_eq!(t("max"), ["max"]);
        assert_eq!(t("mX"), ["m", "x"]);
    }

    #[test]
    fn families_and_axes_of_common_layouts() {
        let ch = |s: &str| channel_of(&t(s)).unwrap();
        for (name, c) in [
            ("w_RS_S_x [rad s^-1]", 0),
            ("a_RS_S_z [m s^-2]", 5),
            ("field.angular_velocity.y", 1),
            ("field.linear_acceleration.x", 3),
            ("/imu/angular_velocity/z", 2),
            ("accX", 3),
            ("gyroZ", 2),
            ("aY", 4),
            ("gX", 0),
            ("AccX", 3),
            ("GyrY", 1),
            ("Acc_X", 3),
            ("Gyr_Z", 2),
            ("wx", 0),
            ("ax(g)", 3),
            ("wz(deg/s)", 2),
            ("rotationRateX", 0),
            ("accelerationZ", 5),
            ("omega_y", 1),
            ("alpha_z", 5),
            ("ang_vel_x", 0),
            ("lin_acc_y", 4),
            ("gyro_x_dps", 0),
            ("Accelerometer Z (g)", 5),
        ] {
            assert_eq!(ch(name), Some(c), "{name}");
        }
    }

    #[test]
    fn exclusions_never_match_a_sensor_channel() {
        for name in [
            "userAccelerationX",
            "gravityX",
            "gravity_z",
            "field.orientation.x",
            "field.angular_velocity_covariance0",
            "android_gyro_bias_x_rps",
            "gyro_bias_x",
            "acc_bias_z",
            "FreeAcc_X",
            "Magnetometer X (uT)",
            "mX",
            "Roll",
            "AngleX(deg)",
            "quat_x",
            "euler_x",
            "angular_acceleration_x",
            "accuracy_x",
            "qx",
            "vx",
            "imu_tick_ms",
        ] {
            assert_eq!(channel_of(&t(name)), Ok(None), "{name}");
        }
    }

    fn hdr(s: &str) -> Vec<String> {
        s.split(',').map(str::to_string).collect()
    }

    #[test]
    fn two_candidates_for_one_channel_are_an_error_naming_both() {
        let e = resolve(
            &hdr("time,gyroX,gyro_x_raw,gyroY,gyroZ"),
            &ImportOptions::default(),
        )
        .unwrap_err();
        assert!(
            e.contains("\"gyroX\" and \"gyro_x_raw\"") && e.contains("--col gx=NAME"),
            "{e}"
        );
        // An exact canonical name wins over token matches (as before).
        let idx = resolve(&hdr("t,gx,gyro_x"), &ImportOptions::default()).unwrap();
        assert_eq!(idx[1], Some(1));
    }

    #[test]
    fn units_from_names_and_conventions() {
        let h = hdr("#timestamp [ns],w_RS_S_x [rad s^-1],a_RS_S_x [m s^-2]");
        let idx = resolve(&h, &ImportOptions::default()).unwrap();
        assert!(matches!(
            gyro_named(&h, &idx),
            NameUnit::Stated(GyroUnit::RadS, _)
        ));
        assert!(matches!(
            accel_named(&h, &idx),
            NameUnit::Stated(AccelUnit::MS2, _)
        ));
        assert_eq!(time_named(&h, &idx).map(|x| x.0), Some(TimeUnit::Ns));
        // ROS sensor_msgs/Imu fields and Kalibr's imu0.csv names: SI by their convention, no
        // time unit in the name.
        for header in [
            "%time,field.angular_velocity.x,field.linear_acceleration.x",
            "timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z",
        ] {
            let h = hdr(header);
            let idx = resolve(&h, &ImportOptions::default()).unwrap();
            assert!(
                matches!(
                    gyro_named(&h, &idx),
                    NameUnit::Convention(GyroUnit::RadS, _)
                ),
                "{header}"
            );
            assert!(
                matches!(
                    accel_named(&h, &idx),
                    NameUnit::Convention(AccelUnit::MS2, _)
                ),
                "{header}"
            );
            assert_eq!(time_named(&h, &idx), None, "{header}");
        }
        let h = hdr("timestamp,accX,gyroX");
        let idx = resolve(&h, &ImportOptions::default()).unwrap();
        assert_eq!(gyro_named(&h, &idx), NameUnit::Unknown);
        assert_eq!(accel_named(&h, &idx), NameUnit::Unknown);
        let h = hdr("t,gx,ax");
        let idx = resolve(&h, &ImportOptions::default()).unwrap();
        assert!(matches!(
            gyro_named(&h, &idx),
            NameUnit::Convention(GyroUnit::RadS, _)
        ));
        assert_eq!(time_named(&h, &idx), None);
    }
}
