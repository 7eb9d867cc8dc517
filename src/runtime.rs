//! The one async loop in the middle: receive from the source, run the synchronous pipeline,
//! offer the result to every sink — and publish health beside the data.

use crate::config::{Config, McapCompression, Sink, SourceConfig};
use crate::frame::health::HealthFrame;
use crate::frame::{DecoderStats, Descriptor};
use crate::io::sink::{self, SinkHandle, SinkItem, SinkReport};
use crate::io::source::{self, SourceEvent};
use crate::sample::{Sample, channel_names_of, flags};
use crate::stage::Pipeline;
use crate::stage::health::PipelineHealth;
use crate::text::count;
use serde::Serialize;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, watch};

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
    /// Times the source stayed open but silent for its stall time (serial) and was reopened.
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
    fn count(&mut self, s: &Sample) {
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
                "  source     : {} (open but silent; reopened)",
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
    fn line(&self) -> String {
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

fn cleaning_stages(p: &Pipeline) -> Vec<String> {
    p.cleaning_stage_names()
        .iter()
        .map(|s| s.to_string())
        .collect()
}

/// Run source → pipeline → sinks until the input ends or a signal arrives.
pub async fn run(cfg: &Config, mut pipeline: Pipeline) -> anyhow::Result<Health> {
    if pipeline.cleaning_stage_names().is_empty() {
        tracing::warn!("cleaning: {NO_CLEANING}");
    }
    // Sinks first: a bad address or path fails before any data is read.
    let mut sinks = Vec::new();
    for s in &cfg.sinks {
        sinks.push(sink::start(s).await?);
    }
    // SIGINT/SIGTERM, watched by a task of its own (started below, once nothing can fail): a
    // sink waited for without limit must still let a signal stop the run while the loop awaits it.
    let (sig_tx, sig_rx) = watch::channel::<Option<&'static str>>(None);
    let (stop_tx, stop_rx) = watch::channel(false);
    // An offline replay at speed 0 gains nothing by dropping: its local sinks are waited for
    // without a stall limit (back-pressure). Live sources and paced replays keep the stall rule.
    if offline_replay(&cfg.source) {
        for k in &mut sinks {
            k.wait_without_limit(stop_rx.clone());
        }
    }
    let (tx, mut rx) = mpsc::channel::<SourceEvent>(16);
    // Carriers and pass-through messages flow only when an inline sink wants them.
    let side = sinks.iter().any(|k| k.wants_side);
    let proto = cfg.protocol.clone();
    let src = match &cfg.source {
        SourceConfig::Replay { path, speed } => {
            let (f, dec) = source::open_replay(path, &proto).await?;
            tokio::spawn(source::replay_with(f, dec, *speed, side, tx))
        }
        SourceConfig::Stdin => tokio::spawn(source::stdin_with(proto, side, tx)),
        SourceConfig::Serial {
            port,
            baud,
            retry_initial_ms,
            retry_max_ms,
            stall_ms,
        } => tokio::spawn(source::serial_watched(
            port.clone(),
            *baud,
            Duration::from_millis(*retry_initial_ms),
            Duration::from_millis(*retry_max_ms),
            (*stall_ms > 0).then(|| Duration::from_millis(*stall_ms)),
            proto,
            side,
            tx,
        )),
    };
    let signals = tokio::spawn(async move {
        let sig = shutdown_signal().await;
        let _ = stop_tx.send(true);
        let _ = sig_tx.send(Some(sig));
    });
    let started = Instant::now();
    let mut health = Health {
        cleaning_stages: cleaning_stages(&pipeline),
        ..Health::default()
    };
    let interval = cfg.health.interval_s;
    let mut tick = tokio::time::interval(Duration::from_secs_f64(if interval > 0.0 {
        interval
    } else {
        3600.0
    }));
    tick.tick().await;
    let mut shutdown = Box::pin(signalled(sig_rx.clone()));
    loop {
        tokio::select! {
            ev = rx.recv() => match ev {
                Some(SourceEvent::Samples(batch, stats)) => {
                    health.decoder = stats;
                    health.samples_in += batch.len() as u64;
                    // With a stage that looks ahead, what comes out lags what went in.
                    let mut out = Vec::with_capacity(batch.len());
                    for s in batch {
                        pipeline.push(s, &mut out);
                    }
                    publish(out, &mut health, &sinks).await;
                }
                Some(SourceEvent::Descriptor(d)) => {
                    health.descriptor = Some(d);
                    for k in &sinks {
                        k.offer(SinkItem::Descriptor(d)).await;
                    }
                }
                Some(SourceEvent::Side(items)) => {
                    let items = Arc::new(items);
                    for k in sinks.iter().filter(|k| k.wants_side) {
                        k.offer(SinkItem::Side(items.clone())).await;
                    }
                }
                Some(SourceEvent::Found(f)) => health.source_found = f,
                Some(SourceEvent::Outage { reason, outages }) => {
                    health.source_outages = outages;
                    tracing::warn!("source outage #{outages}: {reason}");
                }
                Some(SourceEvent::Connected { name }) => tracing::info!("source connected: {name}"),
                Some(SourceEvent::Stall { reason, stalls }) => {
                    health.source_stalls = stalls;
                    tracing::warn!("source stall #{stalls}: {reason}");
                }
                Some(SourceEvent::End(stats)) => {
                    health.decoder = stats;
                    health.ended_by = "end of input".into();
                    break;
                }
                None => {
                    health.ended_by = "source stopped".into();
                    break;
                }
            },
            _ = tick.tick(), if interval > 0.0 => {
                fill(&mut health, &pipeline, &sinks, started);
                tracing::info!("health: {}", health.line());
                // Health as data: beside the samples, on every sink whose format carries it.
                let frame = health.frame(pipeline.cleaning_stage_names().len());
                health.health_reports += 1;
                for k in &sinks {
                    k.offer(SinkItem::Health(Box::new(frame))).await;
                }
            }
            sig = &mut shutdown => {
                health.ended_by = format!("signal {sig}");
                break;
            }
        }
    }
    src.abort();
    let stopped = *stop_rx.borrow();
    // Samples a stage still holds for its look-ahead are final now: publish them too.
    let mut held = Vec::new();
    pipeline.flush(&mut held);
    publish(held, &mut health, &sinks).await;
    // A last health report closes every stream that carries them.
    fill(&mut health, &pipeline, &sinks, started);
    let frame = health.frame(pipeline.cleaning_stage_names().len());
    health.health_reports += 1;
    for k in &sinks {
        k.offer(SinkItem::Health(Box::new(frame))).await;
    }
    // Dropping each sink's sender closes its queue; the task flushes and ends.
    let mut closing: Vec<_> = sinks
        .into_iter()
        .map(|k| {
            let waits = k.waits_without_limit();
            (k.name, k.stats, k.task, k.lossless, waits)
        })
        .collect();
    for (name, stats, task, lossless, waits) in closing.iter_mut() {
        // A back-pressured sink writes all its queue out, however long its consumer takes,
        // unless a signal stops the run (then the rule below).
        let mut done = false;
        if *waits && !stopped {
            let mut stop = stop_rx.clone();
            tokio::select! {
                _ = &mut *task => done = true,
                signalled = async { stop.wait_for(|s| *s).await.is_ok() } => {
                    // The sender is gone only if the signal task ended without a signal.
                    if !signalled {
                        let _ = (&mut *task).await;
                        done = true;
                    }
                }
            }
        }
        // Network sinks may hold clients open; give them a moment, then stop.
        if !done
            && tokio::time::timeout(Duration::from_secs(2), &mut *task)
                .await
                .is_err()
        {
            // Still blocked on its consumer: stop it, so that its counts are final. A sink on
            // a blocking thread (mcap) cannot be stopped: give it a moment, never wait for it.
            task.abort();
            let _ = tokio::time::timeout(Duration::from_millis(200), &mut *task).await;
        }
        if *lossless {
            account_unwritten(name, stats, health.samples_out);
        }
    }
    signals.abort();
    health.elapsed_s = started.elapsed().as_secs_f64();
    health.stages = pipeline.health();
    health.cleaning_stages = cleaning_stages(&pipeline);
    health.sinks = closing.iter().map(|(n, s, ..)| s.report(n)).collect();
    Ok(health)
}

/// `v` with at most `places` decimals, trailing zeros dropped (100 → "100", 104.26409 →
/// "104.264" at 3): a rate or range for people, not the float's every digit.
pub fn trim_decimals(v: f64, places: usize) -> String {
    let s = format!("{v:.places$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
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

/// A local sink must account for every sample published to it: written, or dropped. What
/// its queue still held when it ended (its consumer closed, e.g. `| head`, or was still stuck
/// when the input ended) was never written: count it as dropped, and say so.
fn account_unwritten(name: &str, stats: &sink::SinkStats, published: u64) {
    use std::sync::atomic::Ordering::Relaxed;
    let done = stats.samples_out.load(Relaxed) + stats.dropped.load(Relaxed);
    let unwritten = published.saturating_sub(done);
    if unwritten > 0 {
        stats.dropped.fetch_add(unwritten, Relaxed);
        tracing::warn!(
            sink = %name,
            samples = unwritten,
            "sink ended before writing everything queued to it (its consumer closed or was still stuck at the end of input): counted as dropped"
        );
    }
}

/// Count a batch of pipeline output and offer it to every sink.
async fn publish(out: Vec<Sample>, health: &mut Health, sinks: &[SinkHandle]) {
    if out.is_empty() {
        return;
    }
    for s in &out {
        health.count(s);
    }
    let out = Arc::new(out);
    for k in sinks {
        k.offer(SinkItem::Samples(out.clone())).await;
    }
}

fn fill(h: &mut Health, p: &Pipeline, sinks: &[SinkHandle], started: Instant) {
    h.elapsed_s = started.elapsed().as_secs_f64();
    h.stages = p.health();
    h.cleaning_stages = cleaning_stages(p);
    h.sinks = sinks.iter().map(|s| s.stats.report(&s.name)).collect();
}

/// True when the source is a recorded file replayed at speed 0 (as fast as possible): nothing
/// waits on it, so its local sinks apply back-pressure instead of the stall rule. A replay of
/// something other than a regular file (a FIFO, `/dev/stdin` on a pipe) may be fed live: the
/// stall rule, as for stdin and serial sources and paced replays (which stand in for a sensor).
pub fn offline_replay(source: &SourceConfig) -> bool {
    match source {
        SourceConfig::Replay { path, speed } => {
            *speed == 0.0 && std::fs::metadata(path).is_ok_and(|m| m.is_file())
        }
        SourceConfig::Stdin | SourceConfig::Serial { .. } => false,
    }
}

/// Resolves with the signal's name once the signal task has seen SIGINT or SIGTERM; never if
/// that task ended without one.
async fn signalled(mut rx: watch::Receiver<Option<&'static str>>) -> &'static str {
    let sig = match rx.wait_for(|s| s.is_some()).await {
        Ok(s) => *s,
        Err(_) => None,
    };
    match sig {
        Some(s) => s,
        None => std::future::pending().await,
    }
}

/// Resolves on SIGINT or SIGTERM with the signal's name.
async fn shutdown_signal() -> &'static str {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        let mut term = match signal(SignalKind::terminate()) {
            Ok(s) => s,
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
                return "SIGINT";
            }
        };
        tokio::select! {
            _ = tokio::signal::ctrl_c() => "SIGINT",
            _ = term.recv() => "SIGTERM",
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
        "SIGINT"
    }
}

/// Sinks given on the command line (`--out SPEC`), e.g. `csv:out.csv`, `stdout:jsonl`,
/// `file:clean.log`, `tcp:127.0.0.1:7700`, `udp:127.0.0.1:7701`.
pub fn parse_out_spec(spec: &str) -> Result<Sink, String> {
    use crate::config::Format;
    let (kind, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let fmt = |s: &str| match s {
        "" | "csv" => Ok(Format::Csv),
        "jsonl" | "json" => Ok(Format::Jsonl),
        "native" => Ok(Format::Native),
        o => Err(format!("unknown stdout format {o:?} (csv, jsonl, native)")),
    };
    let path = |what: &str| -> Result<std::path::PathBuf, String> {
        if rest.trim().is_empty() {
            Err(format!(
                "{what}: needs a path, e.g. {what}:out.{}",
                match what {
                    "csv" => "csv",
                    "jsonl" => "jsonl",
                    _ => "log",
                }
            ))
        } else {
            Ok(rest.into())
        }
    };
    // Host names (`localhost:7700`) are resolved here, once; an IPv4 address is preferred.
    let addr = |what: &str| -> Result<std::net::SocketAddr, String> {
        use std::net::ToSocketAddrs;
        let all: Vec<std::net::SocketAddr> = rest
            .to_socket_addrs()
            .map_err(|e| format!("bad {what} address {rest:?} (HOST:PORT): {e}"))?
            .collect();
        all.iter()
            .find(|a| a.is_ipv4())
            .or(all.first())
            .copied()
            .ok_or_else(|| format!("{what} address {rest:?} resolves to nothing"))
    };
    match kind {
        "stdout" | "-" => Ok(Sink::Stdout { format: fmt(rest)? }),
        "file" | "log" => Ok(Sink::File {
            path: path(kind)?,
            format: Format::Native,
        }),
        "csv" => Ok(Sink::File {
            path: path("csv")?,
            format: Format::Csv,
        }),
        "jsonl" => Ok(Sink::File {
            path: path("jsonl")?,
            format: Format::Jsonl,
        }),
        "tcp" => Ok(Sink::Tcp {
            bind: addr("tcp")?,
            format: Format::Native,
            queue: 256,
        }),
        "udp" => Ok(Sink::Udp {
            targets: vec![addr("udp")?],
            format: Format::Native,
        }),
        "inline" => Ok(Sink::Inline {
            path: if rest.is_empty() || rest == "pty" {
                None
            } else {
                Some(rest.into())
            },
        }),
        "pty" => Ok(Sink::Inline { path: None }),
        "mcap" | "mcap+lz4" if !rest.is_empty() => Ok(Sink::Mcap {
            path: rest.into(),
            topic: "/imu/clean".into(),
            frame_id: "imu_link".into(),
            health_topic: "/imuprep/health".into(),
            compression: if kind == "mcap" {
                McapCompression::None
            } else {
                McapCompression::Lz4
            },
        }),
        _ => Err(format!(
            "unknown output {spec:?}: use stdout[:csv|jsonl|native], file:PATH, csv:PATH, jsonl:PATH, tcp:ADDR, udp:ADDR, inline:PATH (the input's own protocol, to a serial device or file), pty: (the same on a new pseudo-terminal, its path printed), mcap:PATH (ROS 2 bag, sensor_msgs/msg/Imu; mcap+lz4:PATH with LZ4 chunks)"
        )),
    }
}

#[cfg(test)]
mod out_spec_tests {
    use super::*;

    #[test]
    fn tcp_localhost_is_accepted() {
        let Ok(Sink::Tcp { bind, .. }) = parse_out_spec("tcp:localhost:7700") else {
            panic!("tcp:localhost:7700 refused")
        };
        assert!(bind.ip().is_loopback());
        assert_eq!(bind.port(), 7700);
    }

    #[test]
    fn file_outputs_without_a_path_are_clear_errors() {
        for spec in ["csv:", "jsonl:", "file:", "csv"] {
            let e = parse_out_spec(spec).unwrap_err();
            assert!(e.contains("needs a path"), "{spec}: {e}");
        }
    }
}
