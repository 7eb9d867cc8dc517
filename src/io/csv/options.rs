//! What the caller says about a table: the input units, the import options, and the column keys
//! (`--col`, `--columns` by position).

/// Standard gravity, m/s² per g.
pub const G0: f64 = 9.80665;

/// Angular-rate unit of the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GyroUnit {
    #[value(name = "rad/s")]
    RadS,
    #[value(name = "deg/s")]
    DegS,
    // Millidegrees per second (ST's datalogs: `gyro_x[mdps]`).
    #[value(name = "mdeg/s", alias = "mdps")]
    MilliDegS,
}
/// Specific-force unit of the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AccelUnit {
    #[value(name = "m/s2")]
    MS2,
    #[value(name = "g")]
    G,
    // Thousandths of g (ST's datalogs: `acc_x[mg]`).
    #[value(name = "mg")]
    MilliG,
}
/// Time unit of the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TimeUnit {
    S,
    Ms,
    Us,
    Ns,
    /// Ticks of 100 µs (a 10 kHz clock: Xsens' `SampleTimeFine`).
    #[value(name = "100us")]
    Tick100Us,
}

impl GyroUnit {
    /// rad/s per unit.
    pub fn to_rad_s(self) -> f64 {
        match self {
            GyroUnit::RadS => 1.0,
            GyroUnit::DegS => std::f64::consts::PI / 180.0,
            GyroUnit::MilliDegS => std::f64::consts::PI / 180.0 * 1e-3,
        }
    }
}

impl AccelUnit {
    /// m/s² per unit.
    pub fn to_m_s2(self) -> f64 {
        match self {
            AccelUnit::MS2 => 1.0,
            AccelUnit::G => G0,
            AccelUnit::MilliG => G0 * 1e-3,
        }
    }
}

impl TimeUnit {
    pub(super) fn ns_per_unit(self) -> f64 {
        match self {
            TimeUnit::S => 1e9,
            TimeUnit::Ms => 1e6,
            TimeUnit::Us => 1e3,
            TimeUnit::Ns => 1.0,
            TimeUnit::Tick100Us => 1e5,
        }
    }
}

/// How to read a CSV. `None` fields are detected from the header.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// Column names for t, gx, gy, gz, ax, ay, az, temp (in that order); `None` = detect.
    pub columns: [Option<String>; 8],
    /// The columns by position (`--columns t,gx,gy,gz,ax,ay,az`): for each column of the file in
    /// order, the key it holds (0..8 as in `columns`) or `None` (`_`, skipped); columns past the
    /// list are skipped too. Empty: the header names them. A header line, if the file has one,
    /// is then skipped and its names not used.
    pub positions: Vec<Option<usize>>,
    pub gyro_unit: Option<GyroUnit>,
    pub accel_unit: Option<AccelUnit>,
    pub time_unit: Option<TimeUnit>,
    /// Ignore the time column and use index / rate (for bursty host timestamps).
    pub time_from_index_hz: Option<f64>,
    /// Subtract the first time stamp so the log starts at t = 0.
    pub rebase_time: bool,
    pub gyro_range_rad_s: f32,
    pub accel_range_m_s2: f32,
    pub device_id: u32,
    /// The file holds this triad only (one table per sensor, `import --accel-file`): the other
    /// triad's columns are not read, and bare `x`, `y`, `z` columns are this triad's.
    pub only: Option<super::streams::Triad>,
    /// `--where COL=VALUE`: only the rows whose COL cell is VALUE (one sensor of several in one
    /// table, [`super::instance`]).
    pub select: Option<(String, String)>,
}

/// The keys of `--col` and `--columns`, in the order of [`ImportOptions::columns`].
pub const CANON: [&str; 8] = ["t", "gx", "gy", "gz", "ax", "ay", "az", "temp"];

/// `--columns t,gx,gy,gz,ax,ay,az`: the key of each column by position (`_` skips one); each key
/// at most once.
pub fn parse_positions(spec: &str) -> Result<Vec<Option<usize>>, String> {
    let mut out = Vec::new();
    for (i, k) in spec.split(',').map(str::trim).enumerate() {
        if k == "_" {
            out.push(None);
            continue;
        }
        let key = CANON.iter().position(|c| *c == k).ok_or_else(|| {
            format!(
                "--columns {spec:?}: {k:?} (column {}) is not one of t gx gy gz ax ay az temp or _",
                i + 1
            )
        })?;
        if out.contains(&Some(key)) {
            return Err(format!("--columns {spec:?}: {k} named twice"));
        }
        out.push(Some(key));
    }
    if out.iter().all(Option::is_none) {
        return Err(format!("--columns {spec:?}: names no column"));
    }
    Ok(out)
}

/// A `--columns` example for a row of `n` cells: t, gx..az in order, `_` for the rest.
pub(super) fn positions_example(n: usize) -> String {
    (0..n.max(2))
        .map(|i| *CANON[..7].get(i).unwrap_or(&"_"))
        .collect::<Vec<_>>()
        .join(",")
}
