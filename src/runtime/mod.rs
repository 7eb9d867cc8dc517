//! The one async loop in the middle: receive from the source, run the synchronous pipeline,
//! offer the result to every sink — and publish health beside the data.

use crate::config::{Config, SourceConfig};
use crate::io::sink::{self, SinkHandle, SinkItem};
use crate::io::source::{self, SourceEvent};
use crate::sample::Sample;
use crate::stage::Pipeline;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, watch};

mod health;
mod out_spec;

pub use health::{Health, NO_CLEANING};
pub use out_spec::parse_out_spec;

/// The cleaning stages of `p`, by name (the summary's `stages` line).
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
    // One Zenoh session for the source and every sink that use Zenoh (`[zenoh]`); a session
    // that cannot open is a startup error naming its endpoints.
    #[cfg(feature = "zenoh")]
    let zenoh = if cfg.uses_zenoh() {
        Some(
            crate::io::zenoh::ZenohSession::open(&cfg.zenoh)
                .await
                .map_err(anyhow::Error::msg)?,
        )
    } else {
        None
    };
    // SIGINT/SIGTERM, watched by a task of its own from before the sinks start: a sink waited
    // for without limit must still let a signal stop the run while the loop awaits it, and so
    // must a zenoh sink's wait for its first subscriber (`wait=S`) while the sinks start.
    let (sig_tx, sig_rx) = watch::channel::<Option<&'static str>>(None);
    let (stop_tx, stop_rx) = watch::channel(false);
    let signals = tokio::spawn(async move {
        let sig = shutdown_signal().await;
        let _ = stop_tx.send(true);
        let _ = sig_tx.send(Some(sig));
    });
    let ctx = sink::SinkContext {
        #[cfg(feature = "zenoh")]
        zenoh: zenoh.clone(),
        #[cfg(feature = "zenoh")]
        stop: Some(stop_rx.clone()),
    };
    // Samples on stdout, in the terminal the bars draw on: no bars, or they would tear the lines.
    if cfg
        .sinks
        .iter()
        .any(|s| matches!(s, crate::config::Sink::Stdout { .. }))
        && std::io::IsTerminal::is_terminal(&std::io::stdout())
    {
        crate::progress::hide();
    }
    // Sinks first: a bad address or path fails before any data is read.
    let mut sinks = Vec::new();
    for s in &cfg.sinks {
        sinks.push(sink::start_with(s, &ctx).await?);
    }
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
        #[cfg(feature = "zenoh")]
        SourceConfig::Zenoh { key, stall_ms } => {
            let z = zenoh.as_ref().expect("a zenoh source opens the session");
            let sub = z
                .session
                .declare_subscriber(key.clone())
                .await
                .map_err(|e| anyhow::anyhow!("zenoh source {key}: cannot subscribe: {e}"))?;
            tokio::spawn(source::zenoh_with(
                sub,
                (*stall_ms > 0).then(|| Duration::from_millis(*stall_ms)),
                proto,
                side,
                tx,
            ))
        }
        #[cfg(not(feature = "zenoh"))]
        SourceConfig::Zenoh { .. } => anyhow::bail!(
            "[source] kind = \"zenoh\": {}",
            crate::config::ZENOH_NOT_BUILT
        ),
    };
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
    // What the Zenoh sinks put is still in Zenoh's queues: closing the session sends it.
    #[cfg(feature = "zenoh")]
    if let Some(z) = &zenoh {
        z.close().await;
    }
    health.elapsed_s = started.elapsed().as_secs_f64();
    health.stages = pipeline.health();
    health.cleaning_stages = cleaning_stages(&pipeline);
    health.sinks = closing.iter().map(|(n, s, ..)| s.report(n)).collect();
    Ok(health)
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
        SourceConfig::Stdin | SourceConfig::Serial { .. } | SourceConfig::Zenoh { .. } => false,
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
