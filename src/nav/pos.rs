//! RTKLIB `.pos` solution files (lat/lon/height format with velocities), as the GNSS input of
//! the filter and as its reference.
//!
//! Columns after the date and time (GPST): latitude °, longitude °, height m, Q (1 fix, 2 float,
//! 5 single), ns, sdn sde sdu sdne sdeu sdun (m), age, ratio, and when the solution has
//! velocities: vn ve vu (m/s) and sdvn sdve sdvu sdvne sdveu sdvun. Time is returned as GPST
//! seconds in the Unix-epoch convention (RTKLIB's `gtime_t`: the calendar date and time read as
//! if they were UTC), the convention of the converted IMU files.

use std::path::Path;

/// One epoch of the solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosEpoch {
    /// GPST, s (Unix-epoch convention).
    pub t: f64,
    /// rad
    pub lat: f64,
    /// rad
    pub lon: f64,
    /// m
    pub h: f64,
    /// 1 fix, 2 float, 5 single, …
    pub q: u8,
    /// σ north, east, up, m.
    pub sd: [f64; 3],
    /// Velocity north, east, up, m/s (zero when absent).
    pub v_neu: [f64; 3],
    /// σ of the velocity, m/s (`None` when absent).
    pub sdv: Option<[f64; 3]>,
}

/// Why a `.pos` file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum PosError {
    #[error("{0}: {1}")]
    Io(String, std::io::Error),
    #[error("{path}:{line}: {msg}")]
    Line {
        path: String,
        line: usize,
        msg: String,
    },
    #[error("{0}: no solution epochs")]
    Empty(String),
}

/// Days from 1970-01-01 to the civil date (proleptic Gregorian).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

fn parse_time(date: &str, time: &str) -> Option<f64> {
    let d: Vec<i64> = date
        .split('/')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let t: Vec<&str> = time.split(':').collect();
    if d.len() != 3 || t.len() != 3 {
        return None;
    }
    let (hh, mm): (i64, i64) = (t[0].parse().ok()?, t[1].parse().ok()?);
    let ss: f64 = t[2].parse().ok()?;
    Some((days_from_civil(d[0], d[1], d[2]) * 86_400 + hh * 3600 + mm * 60) as f64 + ss)
}

/// Parse the text of a `.pos` file (`name` for messages). Header lines start with `%`.
pub fn parse(text: &str, name: &str) -> Result<Vec<PosEpoch>, PosError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('%') {
            continue;
        }
        let err = |msg: &str| PosError::Line {
            path: name.to_string(),
            line: i + 1,
            msg: msg.to_string(),
        };
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() < 15 {
            return Err(err(
                "fewer than 15 columns (not a lat/lon/height solution?)",
            ));
        }
        let t = parse_time(f[0], f[1]).ok_or_else(|| err("cannot read the date and time"))?;
        let num = |k: usize| -> Result<f64, PosError> {
            f[k].parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err(&format!("column {} is not a number: {:?}", k + 1, f[k])))
        };
        let q = num(5)?;
        let (v_neu, sdv) = if f.len() >= 21 {
            (
                [num(15)?, num(16)?, num(17)?],
                Some([num(18)?, num(19)?, num(20)?]),
            )
        } else {
            ([0.0; 3], None)
        };
        out.push(PosEpoch {
            t,
            lat: num(2)?.to_radians(),
            lon: num(3)?.to_radians(),
            h: num(4)?,
            q: q as u8,
            sd: [num(7)?, num(8)?, num(9)?],
            v_neu,
            sdv,
        });
    }
    if out.is_empty() {
        return Err(PosError::Empty(name.to_string()));
    }
    Ok(out)
}

/// Read a `.pos` file.
pub fn read(path: &Path) -> Result<Vec<PosEpoch>, PosError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| PosError::Io(name.clone(), e))?;
    parse(&text, &name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_line_and_gpst_unix_convention() {
        let t = "% header\n2025/07/08 19:34:18.499 40.0966268 -105.1474483 1601.4740000 1 21 \
                 0.0099 0.0099 0.0100 0 0 0 0 0 0.0100 -0.0020 0.0090 0.0587 0.0587 0.0587 0 0 0\n";
        let e = parse(t, "x").unwrap();
        assert_eq!(e.len(), 1);
        // 2025-07-08 19:34:18.499 read as UTC is 1752003258.499 s after 1970-01-01.
        assert!((e[0].t - 1_752_003_258.499).abs() < 1e-6);
        assert_eq!(e[0].q, 1);
        assert_eq!(e[0].v_neu, [0.01, -0.002, 0.009]);
        assert!(parse("2025/07/08 19:34:18.499 40.0 -105.0\n", "x").is_err());
    }
}
