//! The health frame (message type 4): the daemon's counters, published beside the samples at
//! the health interval, so a consumer of the data stream sees faults and drops as they happen.
//!
//! Payload: a sequence of u64 little-endian counters in the order of [`HealthFrame::FIELDS`].
//! A reader takes the fields it knows and ignores any further ones (a later version may append
//! counters; it never reorders or removes them), so the payload length is `8 × n` with
//! `n ≥ HealthFrame::FIELDS.len()`. Decoders built before this frame existed count it as an
//! unknown message type and skip it (see `docs/frame-format.md`).

use super::{HEADER_LEN, MSG_HEALTH, TRAILER_LEN, crc32c, put_header};
use bytes::{BufMut, BytesMut};

/// The counters of one health report (every one cumulative since the run started, except
/// `tcp_clients` and `warming_up`, which describe the moment of the report).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct HealthFrame {
    /// Time since the run started, ms (host clock: the only host time imuprep publishes).
    pub elapsed_ms: u64,
    /// Sensor time of the last sample published, ns (aligns the report with the data).
    pub last_t_ns: u64,
    pub samples_in: u64,
    pub samples_out: u64,
    pub bytes_in: u64,
    pub frames_ok: u64,
    pub crc_errors: u64,
    pub header_errors: u64,
    pub garbage_bytes: u64,
    pub resyncs: u64,
    pub gaps: u64,
    pub missing_frames: u64,
    pub duplicates: u64,
    pub flagged_replaced: u64,
    pub flagged_suspect: u64,
    pub flagged_non_finite: u64,
    pub flagged_saturated: u64,
    pub flagged_warming_up: u64,
    pub flagged_bias_removed: u64,
    pub source_outages: u64,
    pub source_stalls: u64,
    /// Samples every sink (and every TCP client, present or gone) dropped because it was behind.
    pub sink_dropped: u64,
    pub sink_errors: u64,
    /// TCP clients connected now.
    pub tcp_clients: u64,
    /// Cleaning stages in the pipeline (0: samples pass uncleaned; the monitor is not one).
    pub stages: u64,
    /// 1 when the last sample published was flagged warming up (a stage still identifying).
    pub warming_up: u64,
    /// Channels the last sample published does not have (bit `c` for channel `c`, gx..az; 0 =
    /// all present): a partial sensor's absent channels. Appended in field 27; a payload of 26
    /// counters (older writers) reads as 0.
    pub absent_channels: u64,
}

impl HealthFrame {
    /// Field names in payload order (also the JSON keys).
    pub const FIELDS: [&'static str; 27] = [
        "elapsed_ms",
        "last_t_ns",
        "samples_in",
        "samples_out",
        "bytes_in",
        "frames_ok",
        "crc_errors",
        "header_errors",
        "garbage_bytes",
        "resyncs",
        "gaps",
        "missing_frames",
        "duplicates",
        "flagged_replaced",
        "flagged_suspect",
        "flagged_non_finite",
        "flagged_saturated",
        "flagged_warming_up",
        "flagged_bias_removed",
        "source_outages",
        "source_stalls",
        "sink_dropped",
        "sink_errors",
        "tcp_clients",
        "stages",
        "warming_up",
        "absent_channels",
    ];

    /// Counters of the first version of this frame: a shorter payload is a bad payload; the
    /// fields appended since read as 0 when a payload stops after these.
    pub const MIN_FIELDS: usize = 26;

    /// Payload bytes this build writes.
    pub const PAYLOAD: usize = 8 * Self::FIELDS.len();

    fn values(&self) -> [u64; 27] {
        [
            self.elapsed_ms,
            self.last_t_ns,
            self.samples_in,
            self.samples_out,
            self.bytes_in,
            self.frames_ok,
            self.crc_errors,
            self.header_errors,
            self.garbage_bytes,
            self.resyncs,
            self.gaps,
            self.missing_frames,
            self.duplicates,
            self.flagged_replaced,
            self.flagged_suspect,
            self.flagged_non_finite,
            self.flagged_saturated,
            self.flagged_warming_up,
            self.flagged_bias_removed,
            self.source_outages,
            self.source_stalls,
            self.sink_dropped,
            self.sink_errors,
            self.tcp_clients,
            self.stages,
            self.warming_up,
            self.absent_channels,
        ]
    }

    fn from_values(v: &[u64; 27]) -> Self {
        HealthFrame {
            elapsed_ms: v[0],
            last_t_ns: v[1],
            samples_in: v[2],
            samples_out: v[3],
            bytes_in: v[4],
            frames_ok: v[5],
            crc_errors: v[6],
            header_errors: v[7],
            garbage_bytes: v[8],
            resyncs: v[9],
            gaps: v[10],
            missing_frames: v[11],
            duplicates: v[12],
            flagged_replaced: v[13],
            flagged_suspect: v[14],
            flagged_non_finite: v[15],
            flagged_saturated: v[16],
            flagged_warming_up: v[17],
            flagged_bias_removed: v[18],
            source_outages: v[19],
            source_stalls: v[20],
            sink_dropped: v[21],
            sink_errors: v[22],
            tcp_clients: v[23],
            stages: v[24],
            warming_up: v[25],
            absent_channels: v[26],
        }
    }
}

/// Append one health frame; `seq` numbers the health reports of a stream (0, 1, 2, …).
pub fn encode_health(h: &HealthFrame, seq: u32, buf: &mut BytesMut) {
    buf.reserve(HEADER_LEN + HealthFrame::PAYLOAD + TRAILER_LEN);
    let start = buf.len();
    put_header(buf, MSG_HEALTH, HealthFrame::PAYLOAD, seq);
    for v in h.values() {
        buf.put_u64_le(v);
    }
    let c = crc32c(&buf[start..]);
    buf.put_u32_le(c);
}

/// Parse a health payload: `None` when it is shorter than this build's fields or not a whole
/// number of counters.
pub(crate) fn parse_health(p: &[u8]) -> Option<HealthFrame> {
    if p.len() < 8 * HealthFrame::MIN_FIELDS || !p.len().is_multiple_of(8) {
        return None;
    }
    let mut v = [0u64; 27];
    for (i, x) in v.iter_mut().enumerate().take(p.len() / 8) {
        *x = u64::from_le_bytes(p[8 * i..8 * i + 8].try_into().expect("8 bytes"));
    }
    Some(HealthFrame::from_values(&v))
}

/// One JSON line for a health report: `{"type":"health",...}` with the counters of
/// [`HealthFrame`] (sample lines carry no `type` key).
pub fn write_health_json(h: &HealthFrame, out: &mut String) {
    use std::fmt::Write;
    out.push_str("{\"type\":\"health\"");
    for (k, v) in HealthFrame::FIELDS.iter().zip(h.values()) {
        let _ = write!(out, ",\"{k}\":{v}");
    }
    out.push_str("}\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_round_trips_and_an_older_shorter_one_still_reads() {
        let h = HealthFrame {
            samples_in: 7,
            warming_up: 1,
            absent_channels: 0b111_000,
            ..HealthFrame::default()
        };
        let mut b = BytesMut::new();
        encode_health(&h, 0, &mut b);
        let p = &b[HEADER_LEN..b.len() - TRAILER_LEN];
        assert_eq!(p.len(), HealthFrame::PAYLOAD);
        assert_eq!(parse_health(p), Some(h));
        // A writer from before `absent_channels` (26 counters): the field reads as 0.
        let old = parse_health(&p[..8 * HealthFrame::MIN_FIELDS]).unwrap();
        assert_eq!(old.absent_channels, 0);
        assert_eq!((old.samples_in, old.warming_up), (7, 1));
        assert_eq!(parse_health(&p[..8 * HealthFrame::MIN_FIELDS - 8]), None);
    }
}
