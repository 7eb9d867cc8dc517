//! The health frame (message type 4): the daemon's counters, published beside the samples at
//! the health interval, so a consumer of the data stream sees faults and drops as they happen.
//!
//! Payload: a sequence of u64 little-endian counters in the order of [`HealthFrame::FIELDS`].
//! A reader takes the fields it knows and ignores any further ones (a later version may append
//! counters; it never reorders or removes them), so the payload length is `8 × n` with
//! `n ≥ 26` (version 1: 26 fields; version 2, this build: 30, the stages' health appended; a
//! version-1 payload reads with the version-2 fields 0). The payload stays within
//! `MAX_PAYLOAD` (256 bytes, 32 fields), which every decoder accepts. Decoders built before this frame existed
//! count it as an unknown message type and skip it (see `docs/frame-format.md`).

use super::{HEADER_LEN, MSG_HEALTH, TRAILER_LEN, crc32c, put_header};
use bytes::{BufMut, BytesMut};

/// Defines [`HealthFrame`] from one list of fields (payload order = declaration order), with
/// its field names, its payload values and its reading from a payload.
macro_rules! health_frame {
    ($($(#[$doc:meta])* $name:ident),+ $(,)?) => {
        /// The counters of one health report (cumulative since the run started unless the field
        /// says "now").
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
        pub struct HealthFrame {
            $($(#[$doc])* pub $name: u64,)+
        }

        impl HealthFrame {
            /// Field names in payload order (also the JSON keys).
            pub const FIELDS: &'static [&'static str] = &[$(stringify!($name)),+];

            fn values(&self) -> Vec<u64> {
                vec![$(self.$name),+]
            }

            /// From payload values in field order; fields beyond `v` (an older version's
            /// payload) are 0.
            fn from_values(v: &[u64]) -> Self {
                let mut it = v.iter().copied();
                HealthFrame {
                    $($name: it.next().unwrap_or(0),)+
                }
            }
        }
    };
}

health_frame! {
    // Version 1 (26 fields).
    /// Time since the run started, ms (host clock: the only host time imuprep publishes).
    elapsed_ms,
    /// Sensor time of the last sample published, ns (aligns the report with the data).
    last_t_ns,
    samples_in,
    samples_out,
    bytes_in,
    frames_ok,
    crc_errors,
    header_errors,
    garbage_bytes,
    resyncs,
    gaps,
    missing_frames,
    duplicates,
    flagged_replaced,
    flagged_suspect,
    flagged_non_finite,
    flagged_saturated,
    flagged_warming_up,
    flagged_bias_removed,
    source_outages,
    source_stalls,
    /// Samples every sink (and every TCP client, present or gone) dropped because it was behind.
    sink_dropped,
    sink_errors,
    /// TCP clients connected now.
    tcp_clients,
    /// Cleaning stages in the pipeline (0: samples pass uncleaned; the monitor is not one).
    stages,
    /// 1 when the last sample published was flagged warming up (a stage still identifying).
    warming_up,
    // Version 2 (32 fields): the stages' health (`stage::health`), absent channels, model health.
    /// The stages' state now, one bit each (see [`stage_flags`]).
    stage_flags,
    /// Gross-error stage: events (runs of successive candidates), summed over channels.
    gross_error_events,
    /// Bias stage: still measurements taken by the gyro filters.
    bias_updates,
    /// Bias stage: still measurements the consistency guard rejected.
    bias_rejected_updates,
    /// Channels the last sample published does not have now (bit `c` for channel `c`, gx..az;
    /// 0 = all present): a partial sensor's absent channels.
    absent_channels,
    /// Model-health monitor: effects suspected so far (offsets and new spectral lines the model
    /// lacks; the status text is in the JSON summary and the log).
    model_alarms,
}

impl HealthFrame {
    /// Fields of version 1 of the payload (a reader of this version accepts such payloads).
    pub const FIELDS_V1: usize = 26;
    /// Payload bytes this build writes.
    pub const PAYLOAD: usize = 8 * Self::FIELDS.len();
}

// Every decoder (old ones too) takes a frame of at most MAX_PAYLOAD bytes.
const _: () = assert!(HealthFrame::PAYLOAD <= super::MAX_PAYLOAD);

/// Bits of [`HealthFrame::stage_flags`]; per-channel groups have bit `c` for channel `c`
/// (0..6 = `gx` … `az`) above their base.
pub mod stage_flags {
    /// The gross-error stage runs.
    pub const GROSS_ERROR: u64 = 1 << 0;
    /// The bias stage runs.
    pub const BIAS: u64 = 1 << 1;
    /// The bias stage's stillness detector reports rest now.
    pub const STILL: u64 = 1 << 2;
    /// Base of: the channel's gross-error gate runs on its ARIMA model.
    pub const GATE_ACTIVE: u32 = 8;
    /// Base of: the channel's gross-error gate is warming up (identifying its model).
    pub const GATE_WARMING: u32 = 16;
    /// Base of: a bias filter runs on the channel and its estimate is subtracted.
    pub const BIAS_ESTIMATING: u32 = 24;
    /// Base of: the gyro channel is warming up (provisional bias, or none yet).
    pub const BIAS_WARMING: u32 = 32;
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

/// Parse a health payload: `None` when it is shorter than version 1 or not a whole number of
/// counters. Fields a version-1 payload lacks are 0; fields beyond this build's are ignored.
pub(crate) fn parse_health(p: &[u8]) -> Option<HealthFrame> {
    if p.len() < 8 * HealthFrame::FIELDS_V1 || !p.len().is_multiple_of(8) {
        return None;
    }
    let v: Vec<u64> = p
        .chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
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
    use crate::frame::{HEADER_LEN, TRAILER_LEN};

    fn sample_frame() -> HealthFrame {
        let v: Vec<u64> = (1..=HealthFrame::FIELDS.len() as u64).collect();
        HealthFrame::from_values(&v)
    }

    #[test]
    fn payload_round_trips_and_json_keys_follow_the_fields() {
        let h = sample_frame();
        assert_eq!(HealthFrame::FIELDS.len(), 32);
        assert_eq!(
            HealthFrame::FIELDS[HealthFrame::FIELDS_V1 - 1],
            "warming_up"
        );
        let mut buf = BytesMut::new();
        encode_health(&h, 0, &mut buf);
        assert_eq!(buf.len(), HEADER_LEN + HealthFrame::PAYLOAD + TRAILER_LEN);
        let payload = &buf[HEADER_LEN..HEADER_LEN + HealthFrame::PAYLOAD];
        assert_eq!(parse_health(payload), Some(h));
        let mut line = String::new();
        write_health_json(&h, &mut line);
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v["type"], "health");
        for (i, k) in HealthFrame::FIELDS.iter().enumerate() {
            assert_eq!(v[k].as_u64(), Some(i as u64 + 1), "{k}");
        }
        // The JSON line and the serde form agree.
        let mut sv = serde_json::to_value(h).unwrap();
        sv["type"] = "health".into();
        assert_eq!(sv, v);
    }

    #[test]
    fn a_version_1_payload_reads_with_the_stage_fields_zero_and_longer_ones_are_cut() {
        let h = sample_frame();
        let mut buf = BytesMut::new();
        encode_health(&h, 0, &mut buf);
        let payload = buf[HEADER_LEN..HEADER_LEN + HealthFrame::PAYLOAD].to_vec();
        let v1 = parse_health(&payload[..8 * HealthFrame::FIELDS_V1]).unwrap();
        assert_eq!(v1.warming_up, h.warming_up);
        assert_eq!((v1.stage_flags, v1.bias_rejected_updates), (0, 0));
        assert_eq!(
            parse_health(&payload[..8 * HealthFrame::FIELDS_V1 - 8]),
            None
        );
        assert_eq!(
            parse_health(&payload[..8 * HealthFrame::FIELDS_V1 + 3]),
            None
        );
        let mut longer = payload.clone();
        longer.extend_from_slice(&7u64.to_le_bytes());
        assert_eq!(parse_health(&longer), Some(h));
    }
}
