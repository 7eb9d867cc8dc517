//! The flags of `import` that every command reading a recording takes, and what they set: the
//! importer's options (`ImportOptions`) and the protocol options (`ProtocolConfig`).

use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::frame::detect::{ProtocolArgs, ProtocolChoice, ProtocolConfig};
use crate::io::csv::{self as csvio, ImportOptions};

/// The flags of `imuprep import` that say how a recording it imports is read (a text table's
/// columns and units, its rate, …). Every command that reads a recording takes them.
#[derive(Clone, Debug, Default, clap::Args)]
#[command(next_help_heading = "Reading a recording that is no imuprep log (import's flags)")]
pub struct ImportArgs {
    /// The accelerometer's own table, when each sensor has a file (phone sensor apps): the input
    /// is then the gyro's. Bare x, y, z columns are each file's triad; the rows are merged onto
    /// the file with more rows, the other interpolated between its rows on each side.
    #[arg(long, value_name = "FILE")]
    pub accel_file: Option<PathBuf>,
    /// Only the rows whose COLUMN cell is VALUE: one sensor of several in one table (a
    /// multi-IMU rig's id column, ArduPilot's IMU instance `I`).
    #[arg(long = "where", value_name = "COLUMN=VALUE")]
    pub select: Option<String>,
    /// Column mapping by header name, repeatable: --col gx=gyro_x_dps (keys: t gx gy gz ax ay
    /// az temp).
    #[arg(long = "col")]
    pub cols: Vec<String>,
    /// Columns by position, for a file without a header (or to ignore its header): each
    /// column's key in order, `_` to skip one, later columns skipped: --columns
    /// t,gx,gy,gz,ax,ay,az (keys as --col; units from the flags, else the data).
    #[arg(long, value_name = "KEYS", conflicts_with = "cols")]
    pub columns: Option<String>,
    /// Unit of the gyro columns (default: the column name's; else checked against the data:
    /// range, and the turning of gravity's direction; canonical names = rad/s when they cannot tell).
    #[arg(long, value_enum)]
    pub gyro_unit: Option<csvio::GyroUnit>,
    /// Unit of the accel columns (default: the column name's; else the data's median |f|:
    /// ≈ 1 is g, ≈ 9.8 m/s2).
    #[arg(long, value_enum)]
    pub accel_unit: Option<csvio::AccelUnit>,
    /// Unit of the time column (default: the column name's; else s, or the first of ms, us, ns
    /// giving 2 Hz–100 kHz).
    #[arg(long, value_enum)]
    pub time_unit: Option<csvio::TimeUnit>,
    /// Ignore the time column; time = row index / RATE (Hz).
    #[arg(long, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Start the log at t = 0 (subtract the first time stamp).
    #[arg(long)]
    pub rebase_time: bool,
    /// Gyro full-scale range, deg/s: values at or beyond it are flagged saturated. Without it a
    /// text table's range is read from the rails its data hold (a channel holding its extreme
    /// value, piled up, far from its median), if any, and the import says so.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub gyro_range_dps: f64,
    /// Accelerometer full-scale range, g (as --gyro-range-dps).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub accel_range_g: f64,
}

impl ImportArgs {
    /// The flags given, by name (`--gyro-unit`, …).
    pub fn given(&self) -> Vec<&'static str> {
        crate::text::flags_set([
            ("--accel-file", self.accel_file.is_some()),
            ("--where", self.select.is_some()),
            ("--col", !self.cols.is_empty()),
            ("--columns", self.columns.is_some()),
            ("--gyro-unit", self.gyro_unit.is_some()),
            ("--accel-unit", self.accel_unit.is_some()),
            ("--time-unit", self.time_unit.is_some()),
            ("--rate", self.rate.is_some()),
            ("--rebase-time", self.rebase_time),
            ("--gyro-range-dps", self.gyro_range_dps != 0.0),
            ("--accel-range-g", self.accel_range_g != 0.0),
        ])
    }

    /// The importer's options these flags set (a malformed `--col`, `--columns` or `--where`
    /// said).
    pub fn options(&self) -> Result<ImportOptions> {
        let mut o = ImportOptions {
            gyro_unit: self.gyro_unit,
            accel_unit: self.accel_unit,
            time_unit: self.time_unit,
            time_from_index_hz: self.rate,
            rebase_time: self.rebase_time,
            gyro_range_rad_s: self.gyro_range_dps.to_radians() as f32,
            accel_range_m_s2: (self.accel_range_g * csvio::G0) as f32,
            ..Default::default()
        };
        parse_columns(&self.cols, &mut o)?;
        if let Some(w) = &self.select {
            let (c, v) = w
                .split_once('=')
                .with_context(|| format!("--where {w:?}: expected COLUMN=VALUE"))?;
            o.select = Some((c.trim().to_string(), v.trim().to_string()));
        }
        parse_positions(self.columns.as_deref(), &mut o)?;
        Ok(o)
    }
}

/// `--col KEY=COLUMN` mappings → the importer's column names (keys: t gx gy gz ax ay az temp).
pub fn parse_columns(cols: &[String], o: &mut ImportOptions) -> Result<()> {
    for c in cols {
        let (k, v) = c
            .split_once('=')
            .with_context(|| format!("--col {c:?}: expected KEY=COLUMN"))?;
        let i = ["t", "gx", "gy", "gz", "ax", "ay", "az", "temp"]
            .iter()
            .position(|x| *x == k)
            .with_context(|| format!("--col {c:?}: key must be one of t gx gy gz ax ay az temp"))?;
        o.columns[i] = Some(v.to_string());
    }
    Ok(())
}

/// The protocol options a streaming command (`replay`, `export`) reads a file through `import`
/// with (one [`super::through_import`] sends there, or any with import flags): `pc` as it is
/// when its protocol was `named`; else `pc`'s options (a bag's topic, …) with no protocol named,
/// as `import` without `--protocol` reads it (a table as one, any other file detected).
pub fn for_import(pc: &ProtocolConfig, named: bool) -> ProtocolConfig {
    if named {
        return pc.clone();
    }
    ProtocolConfig {
        protocol: ProtocolChoice::Auto,
        ..pc.clone()
    }
}

/// `--columns t,gx,gy,gz,ax,ay,az` → the importer's columns by position.
pub fn parse_positions(spec: Option<&str>, o: &mut ImportOptions) -> Result<()> {
    if let Some(spec) = spec {
        o.positions = csvio::parse_positions(spec).map_err(anyhow::Error::msg)?;
    }
    Ok(())
}

/// The protocol options as the flags set them on the detecting default (`Auto`: no protocol
/// named, a text table read as one).
pub fn protocol_config(proto: &ProtocolArgs) -> ProtocolConfig {
    let mut pc = ProtocolConfig::auto();
    proto.apply(&mut pc);
    pc
}
