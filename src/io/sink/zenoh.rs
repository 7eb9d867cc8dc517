//! The Zenoh sink (`--out zenoh:KEY`, `[[sinks]] kind = "zenoh"`; docs/zenoh.md):
//!
//! * `KEY`: one put per sample — a native frame (type 2 or 3, the bytes `file:`/`tcp:` write) or,
//!   with `format = "jsonl"`, one JSON object (a `stdout:jsonl` line without its newline); with
//!   native frames, the descriptor frame (type 1) too, first and whenever it changes.
//! * `KEY/health`: the health record as JSON (the `{"type":"health",…}` line), put at every
//!   `[health] interval_s` and at the end, and a queryable answering the latest record (none
//!   before the first report).
//! * `KEY/descriptor`: a queryable answering the latest descriptor as a native type-1 frame,
//!   for subscribers that join after it was put.
//!
//! By default never waited for (a network sink): the runtime offers batches with `try_send`, a
//! full queue drops the batch, counted; the sample puts use `CongestionControl::Drop`, so a
//! subscriber or router that falls behind loses messages in Zenoh's queue to it without holding
//! up this task or the other subscribers — Zenoh's own count of those is read back from the
//! session's admin space ([`ZenohSession::congestion_drops`]) at every health report and at the
//! end. With `congestion = "block"` the puts wait for the slowest consumer and the sink is
//! waited for like a local sink (back-pressure in an offline replay, the stall rule live).

use super::{SinkItem, SinkStats};
use crate::config::{Format, ZenohCongestion};
use crate::frame::encode_descriptor;
use crate::frame::health::write_health_json;
use crate::io::format::Encoder;
use crate::io::zenoh::ZenohSession;
use bytes::{Bytes, BytesMut};
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use std::time::Duration;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;
use zenoh::bytes::Encoding;
use zenoh::qos::{CongestionControl, Priority};

/// Schema of the native payloads' encoding (`application/octet-stream;imuprep-frame-v1`): one
/// frame of docs/frame-format.md.
pub const NATIVE_SCHEMA: &str = "imuprep-frame-v1";

/// Declare the publishers and queryables of `key` on the run's session and start the sink's
/// task; with `wait_s` > 0, first wait up to that long for a subscriber of `key` (or until
/// `stop` turns true: a signal ends the wait, and the run stops).
#[allow(clippy::too_many_arguments)]
pub(super) async fn start_zenoh(
    z: ZenohSession,
    key: String,
    format: Format,
    wait_s: f64,
    congestion: ZenohCongestion,
    stop: Option<tokio::sync::watch::Receiver<bool>>,
    rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) -> std::io::Result<(String, JoinHandle<()>)> {
    let err = |what: &str, e: zenoh::Error| {
        std::io::Error::other(format!("zenoh sink {key}: cannot declare {what}: {e}"))
    };
    let s = &z.session;
    let encoding = match format {
        Format::Jsonl => Encoding::APPLICATION_JSON,
        _ => Encoding::APPLICATION_OCTET_STREAM.with_schema(NATIVE_SCHEMA),
    };
    let samples = s
        .declare_publisher(key.clone())
        .encoding(encoding)
        .congestion_control(match congestion {
            ZenohCongestion::Drop => CongestionControl::Drop,
            ZenohCongestion::Block => CongestionControl::Block,
        })
        .priority(Priority::Data)
        .await
        .map_err(|e| err("the publisher", e))?;
    let health_key = format!("{key}/health");
    let descriptor_key = format!("{key}/descriptor");
    let health = s
        .declare_publisher(health_key.clone())
        .encoding(Encoding::APPLICATION_JSON)
        .congestion_control(CongestionControl::Drop)
        .await
        .map_err(|e| err("the health publisher", e))?;
    let health_q = s
        .declare_queryable(health_key.clone())
        .await
        .map_err(|e| err("the health queryable", e))?;
    let descriptor_q = s
        .declare_queryable(descriptor_key.clone())
        .await
        .map_err(|e| err("the descriptor queryable", e))?;
    let matching = samples
        .matching_listener()
        .await
        .map_err(|e| err("the matching listener", e))?;
    let mut matched = samples
        .matching_status()
        .await
        .map(|m| m.matching())
        .unwrap_or(false);
    if wait_s > 0.0 && !matched {
        tracing::info!("zenoh sink {key}: waiting up to {wait_s} s for a subscriber");
        let deadline = tokio::time::Instant::now() + Duration::from_secs_f64(wait_s);
        let stopped = async move {
            match stop {
                Some(mut s) => {
                    let _ = s.wait_for(|v| *v).await;
                }
                None => std::future::pending().await,
            }
        };
        tokio::pin!(stopped);
        let mut signalled = false;
        while !matched {
            tokio::select! {
                m = matching.recv_async() => match m {
                    Ok(m) => matched = m.matching(),
                    Err(_) => break,
                },
                _ = tokio::time::sleep_until(deadline) => break,
                _ = &mut stopped => {
                    signalled = true;
                    break;
                }
            }
        }
        if signalled {
            tracing::info!("zenoh sink {key}: stopped while waiting for a subscriber");
        } else if !matched {
            tracing::warn!(
                "zenoh sink {key}: no subscriber after {wait_s} s; publishing anyway (samples sent to nobody are counted)"
            );
        }
    }
    let count_drops = z.claim_drop_count();
    let name = format!("zenoh:{key}");
    let task = tokio::spawn(async move {
        let ends = Ends {
            samples,
            health,
            health_key,
            descriptor_key,
            key,
        };
        let queries = Queries {
            health: health_q,
            descriptor: descriptor_q,
            matching,
        };
        publish(z, ends, queries, matched, count_drops, format, rx, stats).await
    });
    Ok((name, task))
}

/// What the sink puts on.
struct Ends {
    samples: zenoh::pubsub::Publisher<'static>,
    health: zenoh::pubsub::Publisher<'static>,
    health_key: String,
    descriptor_key: String,
    key: String,
}

type Fifo<T> = zenoh::handlers::FifoChannelHandler<T>;

/// What the sink answers and listens to.
struct Queries {
    health: zenoh::query::Queryable<Fifo<zenoh::query::Query>>,
    descriptor: zenoh::query::Queryable<Fifo<zenoh::query::Query>>,
    matching: zenoh::matching::MatchingListener<Fifo<zenoh::matching::MatchingStatus>>,
}

#[allow(clippy::too_many_arguments)]
async fn publish(
    z: ZenohSession,
    ends: Ends,
    q: Queries,
    mut matched: bool,
    count_drops: bool,
    format: Format,
    mut rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) {
    let mut enc = Encoder::new(format);
    let mut buf = BytesMut::with_capacity(1 << 16);
    let mut text = String::new();
    let mut latest_health: Option<Bytes> = None;
    let mut latest_descriptor: Option<Bytes> = None;
    let key = &ends.key;
    let update_drops = async |stats: &SinkStats| {
        if count_drops && let Some(n) = z.congestion_drops().await {
            let before = stats.congestion_dropped.fetch_max(n, Relaxed);
            if n > before && before == 0 {
                tracing::warn!(
                    "zenoh sink {key}: Zenoh dropped messages to a subscriber or router that is behind (congestion control Drop): counted"
                );
            }
        }
    };
    loop {
        tokio::select! {
            item = rx.recv() => {
                let Some(item) = item else { break };
                match item {
                    SinkItem::Samples(b) => {
                        for s in b.iter() {
                            buf.clear();
                            enc.sample(s, &mut buf);
                            if format == Format::Jsonl {
                                buf.truncate(buf.len().saturating_sub(1)); // the line's '\n'
                            }
                            if ends.samples.put(buf.split().freeze()).await.is_err() {
                                stats.errors.fetch_add(1, Relaxed);
                            }
                        }
                        stats.samples_out.fetch_add(b.len() as u64, Relaxed);
                        if !matched {
                            stats.no_subscriber.fetch_add(b.len() as u64, Relaxed);
                        }
                    }
                    SinkItem::Descriptor(d) => {
                        buf.clear();
                        encode_descriptor(&d, &mut buf);
                        let frame = buf.split().freeze();
                        latest_descriptor = Some(frame.clone());
                        if format == Format::Native && ends.samples.put(frame).await.is_err() {
                            stats.errors.fetch_add(1, Relaxed);
                        }
                    }
                    SinkItem::Health(mut h) => {
                        // Zenoh's count, read now; the record (made by the runtime from the
                        // count read at the previous report) gets what was added since.
                        let before = stats.congestion_dropped.load(Relaxed);
                        update_drops(&stats).await;
                        h.sink_dropped += stats.congestion_dropped.load(Relaxed) - before;
                        text.clear();
                        write_health_json(&h, &mut text);
                        let json = Bytes::from(text.trim_end().to_string());
                        latest_health = Some(json.clone());
                        if ends.health.put(json).await.is_err() {
                            stats.errors.fetch_add(1, Relaxed);
                        }
                        stats.health_out.fetch_add(1, Relaxed);
                    }
                    SinkItem::Side(_) | SinkItem::Skip { .. } => {}
                }
            }
            Ok(query) = q.health.recv_async() => {
                if let Some(h) = &latest_health {
                    let _ = query
                        .reply(ends.health_key.clone(), h.clone())
                        .encoding(Encoding::APPLICATION_JSON)
                        .await;
                }
            }
            Ok(query) = q.descriptor.recv_async() => {
                if let Some(d) = &latest_descriptor {
                    let _ = query
                        .reply(ends.descriptor_key.clone(), d.clone())
                        .encoding(Encoding::APPLICATION_OCTET_STREAM.with_schema(NATIVE_SCHEMA))
                        .await;
                }
            }
            Ok(m) = q.matching.recv_async() => {
                if m.matching() != matched {
                    matched = m.matching();
                    if matched {
                        tracing::info!("zenoh sink {key}: a subscriber matches");
                    } else {
                        tracing::warn!(
                            "zenoh sink {key}: no subscriber matches any more (the router or every subscriber is gone): samples go to nobody, counted"
                        );
                    }
                }
            }
        }
    }
    update_drops(&stats).await;
}
