//! Text and binary encodings of output samples, shared by every sink and by `export`.

use crate::config::Format;
use crate::frame::health::{HealthFrame, encode_health, write_health_json};
use crate::frame::{Descriptor, encode_descriptor, encode_log_header, encode_sample};
use crate::sample::Sample;
use bytes::{BufMut, BytesMut};
use std::fmt::Write as _;

/// Header line of the canonical CSV export (sensor columns, then `seq` and the flag bits).
pub const CSV_HEADER: &str = "t,gx,gy,gz,ax,ay,az,temp,seq,flags";

/// Sensor time as seconds with all nine decimals, exact from the ns counter.
pub fn t_seconds(t_ns: u64) -> String {
    format!("{}.{:09}", t_ns / 1_000_000_000, t_ns % 1_000_000_000)
}

/// Append one CSV row (values at the f32 precision of the wire, shortest round-trip form).
pub fn write_csv_row(s: &Sample, out: &mut String) {
    out.push_str(&t_seconds(s.t_ns));
    for (c, v) in s.channels().into_iter().enumerate() {
        if s.is_absent(c) {
            out.push(','); // absent: an empty cell (NaN is a present channel's non-finite value)
        } else {
            let _ = write!(out, ",{}", v as f32);
        }
    }
    out.push(',');
    if let Some(t) = s.temp_c {
        let _ = write!(out, "{}", t as f32);
    }
    let _ = writeln!(out, ",{},{}", s.seq, s.flags);
}

fn json_num(out: &mut String, v: f32) {
    if v.is_finite() {
        let _ = write!(out, "{v}");
    } else {
        out.push_str("null");
    }
}

fn json_array(out: &mut String, key: &str, vals: impl Iterator<Item = f32>) {
    let _ = write!(out, ",\"{key}\":[");
    for (i, v) in vals.enumerate() {
        if i > 0 {
            out.push(',');
        }
        json_num(out, v);
    }
    out.push(']');
}

/// Append one JSON line: time, channels, temperature, flags, and the bias estimate with its σ.
pub fn write_json_row(s: &Sample, out: &mut String) {
    let _ = write!(out, "{{\"seq\":{},\"t_ns\":{}", s.seq, s.t_ns);
    let ch = s.channels();
    json_array(out, "gyro", ch[..3].iter().map(|v| *v as f32));
    json_array(out, "accel", ch[3..].iter().map(|v| *v as f32));
    out.push_str(",\"temp\":");
    json_num(out, s.temp_c.map_or(f32::NAN, |t| t as f32));
    let _ = write!(out, ",\"flags\":{}", s.flags);
    json_array(out, "bias", s.bias.iter().copied());
    json_array(out, "bias_sd", s.bias_sd.iter().copied());
    if s.absent != 0 {
        // Absent channels are null above like a non-finite value; this key says which are
        // absent (the sensor has no such channel), not bad.
        out.push_str(",\"absent\":[");
        for (i, n) in crate::sample::channel_names_of(s.absent).iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            let _ = write!(out, "\"{n}\"");
        }
        out.push(']');
    }
    out.push_str("}\n");
}

/// Encodes batches of samples in one format, with the stream preamble each format needs.
pub struct Encoder {
    format: Format,
    text: String,
    /// Number of the next health frame (native format).
    health_seq: u32,
}

impl Encoder {
    pub fn new(format: Format) -> Self {
        Encoder {
            format,
            text: String::new(),
            health_seq: 0,
        }
    }

    /// What a consumer must read first: the log header (native file), the CSV header, or nothing.
    pub fn preamble(&self, d: &Descriptor, as_file: bool, buf: &mut BytesMut) {
        match self.format {
            Format::Native if as_file => encode_log_header(d, buf),
            Format::Native => encode_descriptor(d, buf),
            Format::Csv => {
                buf.put_slice(CSV_HEADER.as_bytes());
                buf.put_u8(b'\n');
            }
            Format::Jsonl => {}
        }
    }

    /// A descriptor met mid-stream (only the native format carries it).
    pub fn descriptor(&self, d: &Descriptor, buf: &mut BytesMut) {
        if self.format == Format::Native {
            encode_descriptor(d, buf);
        }
    }

    /// A health report, in the formats that carry one (native frame, JSON line); returns
    /// whether anything was written (CSV has no place for it).
    pub fn health(&mut self, h: &HealthFrame, buf: &mut BytesMut) -> bool {
        match self.format {
            Format::Native => {
                encode_health(h, self.health_seq, buf);
                self.health_seq = self.health_seq.wrapping_add(1);
                true
            }
            Format::Jsonl => {
                self.text.clear();
                write_health_json(h, &mut self.text);
                buf.put_slice(self.text.as_bytes());
                true
            }
            Format::Csv => false,
        }
    }

    pub fn sample(&mut self, s: &Sample, buf: &mut BytesMut) {
        match self.format {
            Format::Native => encode_sample(s, buf),
            Format::Csv => {
                self.text.clear();
                write_csv_row(s, &mut self.text);
                buf.put_slice(self.text.as_bytes());
            }
            Format::Jsonl => {
                self.text.clear();
                write_json_row(s, &mut self.text);
                buf.put_slice(self.text.as_bytes());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_line_is_valid_json_with_null_for_absent_values() {
        let mut s = Sample {
            seq: 3,
            t_ns: 10,
            ..Sample::default()
        };
        s.gyro[0] = f64::NAN;
        let mut o = String::new();
        write_json_row(&s, &mut o);
        let v: serde_json::Value = serde_json::from_str(o.trim()).unwrap();
        assert_eq!(v["seq"], 3);
        assert!(v["gyro"][0].is_null());
        assert!(v["temp"].is_null());
        assert_eq!(v["bias_sd"].as_array().unwrap().len(), 6);
    }
}
