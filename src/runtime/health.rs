//! A run's health: the counters published at intervals and at the end, the summary people read
//! and the frame consumers receive.

use serde::Serialize;

use crate::frame::health::HealthFrame;
use crate::frame::{DecoderStats, Descriptor};
use crate::io::sink::SinkReport;
use crate::sample::{Sample, channel_names_of, flags};
use crate::stage::health::PipelineHealth;
use crate::text::{count, trim_decimals};

/// Health of one run: published at intervals and at the end.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Health {
    pub elapsed_s: f64,
    pub decoder: DecoderStats,
    pub descriptor: Option<Descriptor>,
    pub samples_in: u64,
    pub samples_out: u64,
    /// Output samples carrying each flag of interest.
    pub flagged_replaced: u64,
    /// Any channel suspect: the gross-error gate fired, the evidence did not confirm it.
    pub flagged_suspect: u64,
    /// Stale repeats of the previous sample.
    pub flagged_repeated: u64,
    pub flagged_gap: u64,
    pub flagged_duplicate: u64,
    pub flagged_non_finite: u64,
    pub flagged_saturated: u64,
    pub flagged_warming_up: u64,
    pub flagged_bias_removed: u64,
    pub source_outages: u64,
    /// The cleaning stages the pipeline runs, in order; empty = samples are published raw.
    pub cleaning_stages: Vec<String>,
    /// Times the source stayed open but silent for its stall time (serial: then reopened;
    /// zenoh: still listened to).
    pub source_stalls: u64,
    /// Sensor time of the last sample published, ns.
    pub last_t_ns: u64,
    /// Whether the last sample published was flagged warming up.
    pub warming_up_now: bool,
    /// Channels absent in the last sample published (bit `c` for channel `c`): a partial
    /// sensor's channels that carry no data.
    pub absent_channels: u8,
    /// Samples published with at least one absent channel.
    pub samples_partial: u64,
    /// Health reports published beside the samples.
    pub health_reports: u64,
    /// Every stage's typed health (the monitor's model-health status included).
    pub stages: PipelineHealth,
    pub sinks: Vec<SinkReport>,
    /// Why the run ended: "end of input", "signal", ...
    pub ended_by: String,
    /// What the source's decoder found (protocol, streams, topics).
    pub source_found: String,
}

impl Health {
    pub(super) fn count(&mut self, s: &Sample) {
        self.samples_out += 1;
        self.last_t_ns = s.t_ns;
        self.warming_up_now = s.flags & flags::WARMING_UP != 0;
        self.absent_channels = s.absent;
        self.samples_partial += u64::from(s.absent != 0);
        let f = s.flags;
        self.flagged_replaced += u64::from(f & flags::REPLACED != 0);
        self.flagged_suspect += u64::from(f & flags::SUSPECT_ANY != 0);
        self.flagged_repeated += u64::from(f & flags::REPEATED != 0);
        self.flagged_gap += u64::from(f & flags::GAP != 0);
        self.flagged_duplicate += u64::from(f & flags::DUPLICATE != 0);
        self.flagged_non_finite += u64::from(f & flags::NON_FINITE != 0);
        self.flagged_saturated += u64::from(f & flags::SAT_ANY != 0);
        self.flagged_warming_up += u64::from(f & flags::WARMING_UP != 0);
        self.flagged_bias_removed += u64::from(s.bias_subtracted());
    }

    /// Human-readable summary (several lines).
    pub fn text(&self) -> String {
        use std::fmt::Write;
        let d = &self.decoder;
        let mut o = String::new();
        let _ = writeln!(
            o,
            "imuprep summary ({}; {:.3} s)",
            self.ended_by, self.elapsed_s
        );
        if let Some(desc) = &self.descriptor {
            let _ = writeln!(o, "  sensor     : {}", sensor_text(desc));
        }
        let _ = writeln!(
            o,
            "  frames     : {} in, {} ({}, {})",
            count(d.bytes_in, "byte", "bytes"),
            count(d.frames_ok, "good frame", "good frames"),
            count(d.samples, "sample", "samples"),
            count(d.descriptors, "descriptor", "descriptors")
        );
        let faults = [
            count(d.crc_errors, "CRC error", "CRC errors"),
            count(d.header_errors, "header error", "header errors"),
            count(d.bad_length, "bad length", "bad lengths"),
            count(d.resyncs, "resync", "resyncs"),
            count(d.garbage_bytes, "garbage byte", "garbage bytes"),
            format!("{} truncated", d.truncated),
            format!("{} unknown type", d.unknown_type),
            format!("{} bad payload", d.bad_payload),
        ]
        .join(", ");
        let _ = writeln!(o, "  faults     : {faults}");
        let _ = writeln!(
            o,
            "  sequence   : {} ({} missing), {}, {}",
            count(d.gaps, "gap", "gaps"),
            count(d.missing_frames, "frame", "frames"),
            count(d.duplicates, "duplicate", "duplicates"),
            count(d.seq_restarts, "restart", "restarts")
        );
        let flagged = counts(&[
            (self.flagged_replaced, "replaced"),
            (self.flagged_suspect, "suspect"),
            (self.flagged_repeated, "repeated"),
            (self.flagged_non_finite, "non-finite"),
            (self.flagged_saturated, "saturated"),
            (self.flagged_warming_up, "warming up"),
            (self.flagged_bias_removed, "bias removed"),
        ]);
        let _ = writeln!(
            o,
            "  samples    : {} in, {} out; flagged: {flagged}",
            self.samples_in, self.samples_out
        );
        // Clipping on more than 1 % of the samples is no rare shock: said, with what it may
        // mean (a log at 1 °/s and 0.5 g of range said "37125 saturated" and nothing else).
        if self.flagged_saturated > 0 && self.flagged_saturated * 100 >= self.samples_in {
            let _ = writeln!(
                o,
                "  WARNING    : {} of {} samples ({:.1} %) clipped at the sensor's range (flagged saturated: their values are the range, not the motion); if the motion should fit, the range or the units may be wrong",
                self.flagged_saturated,
                self.samples_in,
                100.0 * self.flagged_saturated as f64 / self.samples_in.max(1) as f64
            );
        }
        if self.samples_partial > 0 {
            let _ = writeln!(
                o,
                "  absent     : {} without channel(s) {} (published as absent, never as zeros; not cleaned)",
                count(self.samples_partial, "sample", "samples"),
                channel_names_of(self.absent_channels).join(" ")
            );
        }
        if !self.source_found.is_empty() {
            let _ = writeln!(o, "  found      : {}", self.source_found);
        }
        if d.other_messages + d.partial_samples + d.time_backwards + d.unverified > 0 {
            let _ = writeln!(
                o,
                "  protocol   : {} ({}) passed by, {}, {} behind the latest time, {} unverified",
                count(d.other_messages, "other message", "other messages"),
                count(d.other_bytes, "byte", "bytes"),
                count(d.partial_samples, "partial sample", "partial samples"),
                count(d.time_backwards, "sample stamped", "samples stamped"),
                d.unverified
            );
        }
        if self.source_outages > 0 {
            let _ = writeln!(
                o,
                "  source     : {}",
                count(self.source_outages, "outage", "outages")
            );
        }
        if self.cleaning_stages.is_empty() {
            let _ = writeln!(o, "  cleaning   : {NO_CLEANING}");
        }
        // Non-zero stage counters only (the JSON summary has them all, and the stages' state).
        let nz = self.stages.nonzero_counters();
        if !nz.is_empty() {
            let _ = writeln!(o, "  stages     : {nz}");
        }
        if let Some(m) = &self.stages.monitor {
            let _ = writeln!(o, "  model      : {}", m.status);
        }
        if self.source_stalls > 0 {
            let _ = writeln!(
                o,
                "  source     : {} (open but silent for the stall time)",
                count(self.source_stalls, "stall", "stalls")
            );
        }
        for s in &self.sinks {
            let _ = writeln!(
                o,
                "  sink       : {} — {} out, {} dropped, {}, {}{}",
                s.name,
                s.samples_out,
                s.dropped,
                count(s.errors, "error", "errors"),
                count(s.health_out, "health report", "health reports"),
                if s.messages_dropped > 0 {
                    format!(
                        ", {} dropped",
                        count(
                            s.messages_dropped,
                            "pass-through message",
                            "pass-through messages"
                        )
                    )
                } else {
                    String::new()
                }
            );
            if s.congestion_dropped + s.no_subscriber > 0 {
                let _ = writeln!(
                    o,
                    "               zenoh — {} dropped by its congestion control (a subscriber or router behind), {} published while no subscriber matched",
                    s.congestion_dropped, s.no_subscriber
                );
            }
            let g = &s.clients_gone;
            if g.clients > 0 {
                let _ = writeln!(
                    o,
                    "               {} gone — {} sent, {} dropped (lag)",
                    count(g.clients, "client", "clients"),
                    g.samples_sent,
                    g.samples_dropped
                );
            }
            for c in &s.clients {
                let _ = writeln!(
                    o,
                    "               client {} — {} sent, {} dropped (lag){}",
                    c.peer,
                    c.samples_sent,
                    c.samples_dropped,
                    if c.connected { "" } else { ", gone" }
                );
            }
        }
        o
    }

    /// What an offline user must be told about the input, if anything: it decoded to nothing,
    /// or most of it was garbage (see [`DecoderStats::input_problem`]).
    pub fn input_problem(&self) -> Option<String> {
        self.decoder.input_problem(self.samples_in)
    }

    /// Samples lost by every sink and TCP client (present and gone).
    pub fn sink_dropped(&self) -> u64 {
        self.sinks.iter().map(|s| s.dropped_total()).sum()
    }

    /// The counters as published beside the samples (native health frame, JSON line).
    pub fn frame(&self, n_stages: usize) -> HealthFrame {
        let d = &self.decoder;
        HealthFrame {
            elapsed_ms: (self.elapsed_s * 1e3) as u64,
            last_t_ns: self.last_t_ns,
            samples_in: self.samples_in,
            samples_out: self.samples_out,
            bytes_in: d.bytes_in,
            frames_ok: d.frames_ok,
            crc_errors: d.crc_errors,
            header_errors: d.header_errors,
            garbage_bytes: d.garbage_bytes,
            resyncs: d.resyncs,
            gaps: d.gaps,
            missing_frames: d.missing_frames,
            duplicates: d.duplicates,
            flagged_replaced: self.flagged_replaced,
            flagged_suspect: self.flagged_suspect,
            flagged_non_finite: self.flagged_non_finite,
            flagged_saturated: self.flagged_saturated,
            flagged_warming_up: self.flagged_warming_up,
            flagged_bias_removed: self.flagged_bias_removed,
            source_outages: self.source_outages,
            source_stalls: self.source_stalls,
            sink_dropped: self.sink_dropped(),
            sink_errors: self.sinks.iter().map(|s| s.errors).sum(),
            tcp_clients: self.sinks.iter().map(|s| s.clients.len() as u64).sum(),
            stages: n_stages as u64,
            warming_up: u64::from(self.warming_up_now),
            absent_channels: u64::from(self.absent_channels),
            ..self.stages.frame_fields()
        }
    }

    /// One-line form for interval logging.
    pub(super) fn line(&self) -> String {
        let line = format!(
            "in={} out={} crc_err={} resyncs={} gaps={} dup={} nan={} sat={} replaced={} outages={} stalls={} sink_dropped={}",
            self.samples_in,
            self.samples_out,
            self.decoder.crc_errors,
            self.decoder.resyncs,
            self.decoder.gaps,
            self.decoder.duplicates,
            self.flagged_non_finite,
            self.flagged_saturated,
            self.flagged_replaced,
            self.source_outages,
            self.source_stalls,
            self.sink_dropped()
        );
        let line = if self
            .stages
            .monitor
            .as_ref()
            .is_some_and(|m| m.status.starts_with("effect"))
        {
            line + " model=EFFECT_SUSPECTED"
        } else {
            line
        };
        // Which sink lost what, as it happens (the total alone does not say who is behind).
        let per_sink: Vec<String> = self
            .sinks
            .iter()
            .filter(|k| k.dropped_total() > 0)
            .map(|k| format!("{}={}", k.name, k.dropped_total()))
            .collect();
        let line = if per_sink.is_empty() {
            line
        } else {
            format!("{line} ({})", per_sink.join(" "))
        };
        let line = if self.absent_channels != 0 {
            format!(
                "{line} absent={}",
                channel_names_of(self.absent_channels).join(",")
            )
        } else {
            line
        };
        if self.cleaning_stages.is_empty() {
            line + " cleaning=NONE"
        } else {
            format!("{line} {}", self.stages.state_line())
        }
    }
}

/// What the summary and the log say when no cleaning stage runs.
pub const NO_CLEANING: &str = "NONE — no cleaning stage is enabled ([gross_error] and [bias] are off): samples are published raw";

/// `"n1 what1, n2 what2, …"`: a summary line's counters, in order.
fn counts(items: &[(u64, &str)]) -> String {
    let parts: Vec<String> = items
        .iter()
        .map(|(n, what)| format!("{n} {what}"))
        .collect();
    parts.join(", ")
}

/// The summary's sensor line: rate to 1 mHz, and a range or rate of 0 (the descriptor's
/// "unknown") said as unknown rather than printed as a 0 that reads like a measurement.
fn sensor_text(d: &Descriptor) -> String {
    let known = |v: f64| v > 0.0 && v.is_finite();
    let rate = if known(d.sample_rate_hz) {
        format!("{} Hz", trim_decimals(d.sample_rate_hz, 3))
    } else {
        "unknown rate".to_string()
    };
    let range = |v: f32, unit: &str| {
        if known(f64::from(v)) {
            format!("{} {unit}", trim_decimals(f64::from(v), 4))
        } else {
            "unknown (no saturation flags)".to_string()
        }
    };
    let axes = match d.axes {
        crate::frame::AxisConvention::Frd => "FRD",
        crate::frame::AxisConvention::Flu => "FLU",
        crate::frame::AxisConvention::Unknown => "unknown",
    };
    let ranges = if known(f64::from(d.gyro_range_rad_s)) || known(f64::from(d.accel_range_m_s2)) {
        format!(
            "gyro range {}, accel range {}",
            range(d.gyro_range_rad_s, "rad/s"),
            range(d.accel_range_m_s2, "m/s²")
        )
    } else {
        "ranges unknown (no saturation flags)".to_string()
    };
    format!("device {} at {rate}, {ranges}, axes {axes}", d.device_id)
}
