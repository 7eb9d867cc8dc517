//! The truth sidecar: one CSV row per sample instant with the true signal and every error
//! component separately, so that any metric can be computed exactly.
//!
//! Invariant (per channel c, before the frame codec's f32 rounding):
//!   measured_c = true_c + Σ_effects component_c        (to f64 rounding)
//! where the components include `road_vibration_*`, which is *real motion* (a preprocessor must
//! keep it), and the sensor errors, which it should remove. Columns, in order:
//! `t_s, seq, t_ns, true_gx … true_az, [temp_c], <effect>_gx … <effect>_az for each enabled
//! effect, [gross_mask_gx … gross_mask_az], dropped, duplicated`.
//! `t_s` is the true sample instant (k / rate); `t_ns` the sensor timestamp as sent (with jitter).
//! Values are written with Rust's shortest round-trip formatting (plain, or scientific below
//! 1e-5), so parsing the text gives back the exact f64; [`TruthPrecision::F32`] trades that for
//! size.

use crate::sample::{CHANNEL_NAMES, N_CHANNELS};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Every component column family, in column order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(usize)]
pub enum Effect {
    /// Real motion (vibration of the vehicle / bench), not a sensor error.
    RoadVibration = 0,
    Noise,
    TurnOnBias,
    ScaleFactor,
    Misalignment,
    GSensitivity,
    GaussMarkov,
    ArBias,
    RandomWalk,
    Temperature,
    Vibration,
    Step,
    Gross,
    Saturation,
    Quantisation,
}

/// Number of [`Effect`] families.
pub const N_EFFECTS: usize = 15;

impl Effect {
    /// All effects in column order.
    pub const ALL: [Effect; N_EFFECTS] = [
        Effect::RoadVibration,
        Effect::Noise,
        Effect::TurnOnBias,
        Effect::ScaleFactor,
        Effect::Misalignment,
        Effect::GSensitivity,
        Effect::GaussMarkov,
        Effect::ArBias,
        Effect::RandomWalk,
        Effect::Temperature,
        Effect::Vibration,
        Effect::Step,
        Effect::Gross,
        Effect::Saturation,
        Effect::Quantisation,
    ];

    /// Column prefix (`noise` → `noise_gx` …).
    pub const fn name(self) -> &'static str {
        match self {
            Effect::RoadVibration => "road_vibration",
            Effect::Noise => "noise",
            Effect::TurnOnBias => "turn_on_bias",
            Effect::ScaleFactor => "scale_factor",
            Effect::Misalignment => "misalignment",
            Effect::GSensitivity => "g_sensitivity",
            Effect::GaussMarkov => "gauss_markov",
            Effect::ArBias => "ar_bias",
            Effect::RandomWalk => "random_walk",
            Effect::Temperature => "temperature",
            Effect::Vibration => "vibration",
            Effect::Step => "step",
            Effect::Gross => "gross",
            Effect::Saturation => "saturation",
            Effect::Quantisation => "quantisation",
        }
    }

    /// Bit of this effect in an enabled-set mask.
    pub const fn bit(self) -> u32 {
        1 << (self as u32)
    }
}

/// The truth of one sample instant. Fixed size, `Copy`: no allocation per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthRow {
    /// True sample instant, s from the first sample.
    pub t_s: f64,
    pub seq: u32,
    /// Sensor timestamp as sent, ns.
    pub t_ns: u64,
    /// True angular rate (rad/s) and specific force (m/s²), gx … az, without vibration.
    pub true_signal: [f64; N_CHANNELS],
    /// True temperature, °C (when a profile is configured).
    pub temp_c: Option<f64>,
    /// Component per effect (indexed by `Effect as usize`) and channel; zero when disabled.
    pub components: [[f64; N_CHANNELS]; N_EFFECTS],
    /// Set of enabled effects ([`Effect::bit`]); decides which columns are written.
    pub enabled: u32,
    /// Channels carrying a gross error at this instant.
    pub gross_mask: [bool; N_CHANNELS],
    /// The frame was not sent.
    pub dropped: bool,
    /// The frame was sent twice.
    pub duplicated: bool,
}

impl TruthRow {
    /// Component of `effect` on channel `c`.
    pub fn component(&self, effect: Effect, c: usize) -> f64 {
        self.components[effect as usize][c]
    }

    /// true + Σ components for channel `c`, summed in column order.
    pub fn reconstructed(&self, c: usize) -> f64 {
        let mut v = self.true_signal[c];
        for e in Effect::ALL {
            v += self.components[e as usize][c];
        }
        v
    }

    /// Write this row (with trailing newline) in the column order of [`truth_header`], every
    /// value exact ([`TruthPrecision::Exact`]).
    pub fn write_csv_row(&self, out: &mut impl Write) -> io::Result<()> {
        self.write_csv_row_with(out, TruthPrecision::Exact)
    }

    /// Write this row with the given precision for the signal, temperature and component
    /// values (`t_s`, `seq`, `t_ns`, masks and markers are always exact).
    pub fn write_csv_row_with(
        &self,
        out: &mut impl Write,
        precision: TruthPrecision,
    ) -> io::Result<()> {
        write_f64(out, self.t_s)?;
        write!(out, ",{},{}", self.seq, self.t_ns)?;
        for v in &self.true_signal {
            out.write_all(b",")?;
            write_value(out, *v, precision)?;
        }
        if let Some(t) = self.temp_c {
            out.write_all(b",")?;
            write_value(out, t, precision)?;
        }
        for e in Effect::ALL {
            if self.enabled & e.bit() != 0 {
                for v in &self.components[e as usize] {
                    out.write_all(b",")?;
                    write_value(out, *v, precision)?;
                }
            }
        }
        if self.enabled & Effect::Gross.bit() != 0 {
            for m in &self.gross_mask {
                out.write_all(if *m { b",1" } else { b",0" })?;
            }
        }
        writeln!(
            out,
            ",{},{}",
            u8::from(self.dropped),
            u8::from(self.duplicated)
        )
    }
}

/// How many digits the truth sidecar keeps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TruthPrecision {
    /// Shortest text that parses back to the identical f64 (the invariant holds exactly).
    #[default]
    Exact,
    /// Shortest text of the value rounded to f32 (≤ 9 significant digits): the precision the
    /// wire carries, for compact committed sidecars; the invariant then holds to f32 rounding
    /// of each term (relative 6e-8).
    F32,
}

/// Shortest round-trip decimal of an f64: plain notation for 1e-5 ≤ |v| < 1e16 and zero,
/// scientific otherwise (Rust's `{}` never switches to an exponent, so 1e-300 would take 300
/// characters). Both forms are shortest round-trip in Rust.
fn write_f64(out: &mut impl Write, v: f64) -> io::Result<()> {
    let plain = v == 0.0 || (1e-5..1e16).contains(&v.abs()) || !v.is_finite();
    write_float(out, v, plain)
}

/// [`write_f64`]'s rule with the bounds as f32 values.
fn write_f32(out: &mut impl Write, v: f32) -> io::Result<()> {
    let plain = v == 0.0 || (1e-5..1e16).contains(&v.abs()) || !v.is_finite();
    write_float(out, v, plain)
}

/// `v` in plain notation or with an exponent.
fn write_float<T: std::fmt::Display + std::fmt::LowerExp>(
    out: &mut impl Write,
    v: T,
    plain: bool,
) -> io::Result<()> {
    if plain {
        write!(out, "{v}")
    } else {
        write!(out, "{v:e}")
    }
}

fn write_value(out: &mut impl Write, v: f64, precision: TruthPrecision) -> io::Result<()> {
    match precision {
        TruthPrecision::Exact => write_f64(out, v),
        TruthPrecision::F32 => write_f32(out, v as f32),
    }
}

/// CSV header (no trailing newline) for rows with the given enabled set and temperature column.
pub fn truth_header(enabled: u32, has_temp: bool) -> String {
    let mut cols: Vec<String> = vec!["t_s".into(), "seq".into(), "t_ns".into()];
    cols.extend(CHANNEL_NAMES.iter().map(|c| format!("true_{c}")));
    if has_temp {
        cols.push("temp_c".into());
    }
    for e in Effect::ALL {
        if enabled & e.bit() != 0 {
            cols.extend(CHANNEL_NAMES.iter().map(|c| format!("{}_{c}", e.name())));
        }
    }
    if enabled & Effect::Gross.bit() != 0 {
        cols.extend(CHANNEL_NAMES.iter().map(|c| format!("gross_mask_{c}")));
    }
    cols.push("dropped".into());
    cols.push("duplicated".into());
    cols.join(",")
}

enum Sink {
    Plain(BufWriter<File>),
    /// Buffered *before* the encoder: rows arrive as many tiny writes, which deflate handles
    /// an order of magnitude slower than 64 KiB blocks.
    Gz(BufWriter<flate2::write::GzEncoder<File>>),
}

/// Streams truth rows to a file, gzip-compressed when the path ends in `.gz`.
pub struct TruthWriter {
    out: Sink,
    rows: u64,
    precision: TruthPrecision,
}

impl TruthWriter {
    /// Create `path` and write the header line; values exact.
    pub fn create(path: &Path, header: &str) -> io::Result<TruthWriter> {
        Self::create_with(path, header, TruthPrecision::Exact)
    }

    /// Create `path` and write the header line; values at `precision`.
    pub fn create_with(
        path: &Path,
        header: &str,
        precision: TruthPrecision,
    ) -> io::Result<TruthWriter> {
        let file = File::create(path)?;
        let gz = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
        let out = if gz {
            Sink::Gz(BufWriter::with_capacity(
                1 << 16,
                flate2::write::GzEncoder::new(file, flate2::Compression::default()),
            ))
        } else {
            Sink::Plain(BufWriter::with_capacity(1 << 16, file))
        };
        let mut w = TruthWriter {
            out,
            rows: 0,
            precision,
        };
        writeln!(w.writer(), "{header}")?;
        Ok(w)
    }

    fn writer(&mut self) -> &mut dyn Write {
        match &mut self.out {
            Sink::Plain(w) => w,
            Sink::Gz(w) => w,
        }
    }

    /// Append one row.
    pub fn write_row(&mut self, row: &TruthRow) -> io::Result<()> {
        self.rows += 1;
        match &mut self.out {
            Sink::Plain(w) => row.write_csv_row_with(w, self.precision),
            Sink::Gz(w) => row.write_csv_row_with(w, self.precision),
        }
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Write the gzip trailer (if any) and flush; returns the number of rows written.
    pub fn finish(self) -> io::Result<u64> {
        match self.out {
            Sink::Plain(mut w) => w.flush()?,
            Sink::Gz(w) => w
                .into_inner()
                .map_err(|e| e.into_error())?
                .finish()?
                .flush()?,
        }
        Ok(self.rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(v: f64, p: TruthPrecision) -> String {
        let mut out = Vec::new();
        write_value(&mut out, v, p).unwrap();
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn exact_values_round_trip_bit_for_bit_and_stay_short() {
        for v in [
            0.0,
            -0.0,
            1e-300,
            -5e-324,
            f64::MAX,
            9.999999999999999e-6,
            1e-5,
            0.1 + 0.2,
            -9.806317668891978,
            1e16,
            std::f64::consts::PI * 1e-9,
        ] {
            let t = text(v, TruthPrecision::Exact);
            assert_eq!(t.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{t}");
            // Shortest round-trip: at most 17 significant digits plus sign, point and exponent.
            assert!(t.len() <= 24, "{t} is {} chars", t.len());
        }
    }

    #[test]
    fn f32_precision_writes_the_f32_rounded_value() {
        for v in [0.0, 1.234_567_890_123e-7, -9.806317668891978, 2.5e20] {
            let t = text(v, TruthPrecision::F32);
            assert_eq!(t.parse::<f32>().unwrap(), v as f32, "{t}");
            assert!(t.len() <= 16, "{t}");
        }
    }
}
