//! Sinks: stdout, file, TCP server, UDP, inline (the input's own protocol to a serial device,
//! file or pseudo-terminal). Each runs as its own task behind a bounded queue.
//!
//! The runtime hands every sink the same `Arc` batch. How long it waits for a sink depends on
//! the source:
//!
//! * Live runs (serial, stdin) and paced replays (`--speed` > 0, standing in for a live
//!   sensor): never long for any sink — the stall rule of the items below.
//! * An offline replay (a recorded regular file at `--speed 0`, see
//!   [`crate::runtime::offline_replay`]): the source is a file and can wait, so local sinks
//!   apply back-pressure — a full queue is waited for without limit
//!   ([`SinkHandle::wait_without_limit`]) and nothing is dropped. A wait past the stall time is
//!   warned about once (until the queue has drained to half), so a FIFO nobody reads does not
//!   hang silently; a signal (SIGINT/SIGTERM) ends the wait, and what the sink then cannot take
//!   is dropped, counted. A consumer that closes its end (`| head`) is not a stall: the sink
//!   ends, its unwritten samples are counted as dropped, the replay goes on for the other
//!   sinks. Network sinks keep their rule below in every mode.
//!
//! * Network sinks (TCP, UDP) are offered the batch with `try_send`; a full queue drops the
//!   batch for that consumer only, counted. The TCP server repeats that per client: each client
//!   has its own bounded queue and lag counter; what a client was sent counts bytes written to
//!   its socket, not bytes queued; a client that leaves is folded into the sink's totals.
//! * Local sinks (stdout, file, inline, mcap) are wanted complete, so a full queue is waited
//!   for — in a live or paced run only up to the sink's stall time ([`DEFAULT_STALL`]). A sink
//!   whose queue stays full that long is *stuck* (a `| (sleep 20; cat)` pipe, a full disk, a
//!   FIFO nobody reads): from then on it is offered like a network sink — batches it cannot
//!   take are dropped and counted — until its queue has drained to half, when it is waited for
//!   again. A stuck consumer therefore costs the stream one stall time, once, and never freezes
//!   the daemon or its health reports.
//! * Inline sinks (serial device, file, pseudo-terminal) are local sinks too, with one more
//!   duty: each sample must meet its own carrier, which travels ahead of it in the side stream.
//!   What a stuck inline sink drops (sample batches, side batches) is told to its writer by a
//!   [`SinkItem::Skip`] marker queued before the next item that gets through, so the writer
//!   knows the index of every sample and carrier: a sample whose carrier was dropped, and a
//!   carrier whose sample was dropped, are dropped too (counted), and a frame that carries
//!   several samples (UBX ESF-RAW) is dropped whole when one of them was, so nothing raw is
//!   ever written as cleaned and no sample lands in another's carrier.
//!
//! The files: this one holds the fan-out side (the queue, the stall and stuck rule, the skip
//! markers) and [`start`]; [`stats`] the counters and their reports; `stream.rs` stdout and
//! files; `net.rs` the TCP server and UDP; `inline.rs` the inline writer and its pairing of
//! samples with carriers.

use crate::config::Sink;
use crate::frame::Descriptor;
use crate::frame::health::HealthFrame;
use crate::sample::Sample;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::{mpsc, watch};
use tokio::task::JoinHandle;

mod inline;
mod net;
mod stats;
mod stream;
#[cfg(feature = "zenoh")]
mod zenoh;

pub use stats::{ClientCounters, ClientStats, GoneClients, SinkReport, SinkStats};

/// What flows to a sink.
#[derive(Debug, Clone)]
pub enum SinkItem {
    Descriptor(Descriptor),
    Samples(Arc<Vec<Sample>>),
    /// Carriers and pass-through messages, ahead of their samples (inline sinks only).
    Side(Arc<Vec<crate::io::source::SideItem>>),
    /// A health report, written beside the samples by sinks whose format carries it (native
    /// frames, JSON lines); CSV and inline sinks skip it.
    Health(Box<HealthFrame>),
    /// Inline sinks only: since the previous item, this many samples and sample carriers were
    /// dropped (the sink was stuck); see the module docs.
    Skip {
        samples: u64,
        carriers: u64,
        /// The protocol announced in a dropped side batch (it applies to what follows).
        protocol: Option<crate::frame::Protocol>,
    },
}

/// How long a local sink's full queue is waited for before the sink counts as stuck.
pub const DEFAULT_STALL: Duration = Duration::from_millis(500);

/// A running sink.
pub struct SinkHandle {
    pub name: String,
    pub tx: mpsc::Sender<SinkItem>,
    /// Local sink: waited for (up to `stall`, or without limit under back-pressure) when true;
    /// see the module docs.
    pub lossless: bool,
    /// Wants the side stream ([`SinkItem::Side`]): inline sinks.
    pub wants_side: bool,
    pub stats: Arc<SinkStats>,
    pub task: JoinHandle<()>,
    /// How long a full queue is waited for before the sink counts as stuck.
    pub stall: Duration,
    /// Set while the sink is stuck (dropping instead of waiting).
    stuck: AtomicBool,
    /// Network sinks: set from a full queue's first drop until an item gets through again
    /// (each such episode is warned about once, and its end said).
    dropping: AtomicBool,
    /// Local sinks of an offline replay at speed 0: wait without a stall limit (back-pressure),
    /// until this says the run is stopping (a signal); see the module docs and
    /// [`SinkHandle::wait_without_limit`]. `None`: the stall rule.
    backpressure: Option<watch::Receiver<bool>>,
    /// Set while a back-pressured sink has been waited for beyond its stall time (warned once).
    waiting: AtomicBool,
    /// Inline sinks: samples and carriers dropped since the last item that got through, not
    /// yet told to the writer (a [`SinkItem::Skip`] goes ahead of the next item).
    skip_samples: AtomicU64,
    skip_carriers: AtomicU64,
    skip_protocol: Mutex<Option<crate::frame::Protocol>>,
}

impl SinkHandle {
    /// A sink fed through `tx`, its task running, nothing stuck, dropped or pending yet.
    fn new(
        name: String,
        tx: mpsc::Sender<SinkItem>,
        lossless: bool,
        wants_side: bool,
        stats: Arc<SinkStats>,
        task: JoinHandle<()>,
    ) -> Self {
        SinkHandle {
            name,
            tx,
            lossless,
            wants_side,
            stats,
            task,
            stall: DEFAULT_STALL,
            stuck: AtomicBool::new(false),
            dropping: AtomicBool::new(false),
            backpressure: None,
            waiting: AtomicBool::new(false),
            skip_samples: AtomicU64::new(0),
            skip_carriers: AtomicU64::new(0),
            skip_protocol: Mutex::new(None),
        }
    }

    /// Back-pressure instead of the stall rule (offline replays at speed 0): a full queue is
    /// waited for without limit, with a warning once the wait passes the stall time, until
    /// `stop` turns true (SIGINT/SIGTERM); from then on what the sink cannot take is dropped,
    /// counted. Network sinks keep their rule (never waited for): this does nothing to them.
    pub fn wait_without_limit(&mut self, stop: watch::Receiver<bool>) {
        if self.lossless {
            self.backpressure = Some(stop);
        }
    }

    /// True when this sink is waited for without a stall limit (see [`Self::wait_without_limit`]).
    pub fn waits_without_limit(&self) -> bool {
        self.backpressure.is_some()
    }

    /// Offer an item. Network sinks: dropped (and counted) when the queue is full. Local sinks
    /// (inline ones included): waited for up to `stall`, then dropped while the sink is stuck
    /// (see the module docs).
    pub async fn offer(&self, item: SinkItem) {
        let item = match self.try_put(item) {
            Put::Sent => {
                if !self.lossless && self.dropping.swap(false, Relaxed) {
                    tracing::info!(sink = %self.name, "sink's queue has room again; no longer dropping");
                }
                return;
            }
            Put::Closed => return,
            Put::Full(item) => *item,
        };
        if let Some(stop) = &self.backpressure {
            match self.put_until_stopped(item, stop.clone()).await {
                Put::Sent | Put::Closed => {}
                Put::Full(item) => self.dropped(*item),
            }
            return;
        }
        if self.lossless && self.stuck.load(Relaxed) && self.tx.capacity() * 2 >= SINK_QUEUE {
            self.stuck.store(false, Relaxed);
            tracing::info!(sink = %self.name, "sink caught up; no longer dropping");
        }
        let item = if self.lossless && !self.stuck.load(Relaxed) {
            match self.put_within_stall(item).await {
                Put::Sent | Put::Closed => return,
                Put::Full(item) => {
                    let item = *item;
                    self.stuck.store(true, Relaxed);
                    tracing::warn!(
                        sink = %self.name,
                        stall_ms = self.stall.as_millis() as u64,
                        "sink stuck (its consumer took nothing for the stall time): dropping what it cannot take, counted"
                    );
                    item
                }
            }
        } else {
            if !self.lossless && !self.dropping.swap(true, Relaxed) {
                tracing::warn!(
                    sink = %self.name,
                    "network sink's queue is full (its consumer or the network is behind): dropping what it cannot take, counted (the summary's and health reports' 'dropped'); a network sink is never waited for"
                );
            }
            item
        };
        self.dropped(item);
    }

    /// The pending skip marker of an inline sink, if any.
    fn pending_skip(&self) -> Option<SinkItem> {
        let (samples, carriers) = (
            self.skip_samples.load(Relaxed),
            self.skip_carriers.load(Relaxed),
        );
        let protocol = self.skip_protocol.lock().ok().and_then(|p| *p);
        (self.wants_side && (samples + carriers > 0 || protocol.is_some())).then_some(
            SinkItem::Skip {
                samples,
                carriers,
                protocol,
            },
        )
    }

    fn skip_sent(&self) {
        self.skip_samples.store(0, Relaxed);
        self.skip_carriers.store(0, Relaxed);
        if let Ok(mut p) = self.skip_protocol.lock() {
            *p = None;
        }
    }

    /// Queue `item` now (after the pending skip marker).
    fn try_put(&self, item: SinkItem) -> Put {
        if let Some(skip) = self.pending_skip() {
            match self.tx.try_send(skip) {
                Ok(()) => self.skip_sent(),
                Err(mpsc::error::TrySendError::Full(_)) => return Put::Full(Box::new(item)),
                Err(mpsc::error::TrySendError::Closed(_)) => return Put::Closed,
            }
        }
        match self.tx.try_send(item) {
            Ok(()) => Put::Sent,
            Err(mpsc::error::TrySendError::Full(item)) => Put::Full(Box::new(item)),
            Err(mpsc::error::TrySendError::Closed(_)) => Put::Closed,
        }
    }

    /// Queue `item` (after the pending skip marker), waiting at most the stall time in all.
    async fn put_within_stall(&self, item: SinkItem) -> Put {
        let deadline = tokio::time::Instant::now() + self.stall;
        if let Some(skip) = self.pending_skip() {
            match self.tx.send_timeout(skip, self.stall).await {
                Ok(()) => self.skip_sent(),
                Err(mpsc::error::SendTimeoutError::Timeout(_)) => return Put::Full(Box::new(item)),
                Err(mpsc::error::SendTimeoutError::Closed(_)) => return Put::Closed,
            }
        }
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        match self.tx.send_timeout(item, left).await {
            Ok(()) => Put::Sent,
            Err(mpsc::error::SendTimeoutError::Timeout(item)) => Put::Full(Box::new(item)),
            Err(mpsc::error::SendTimeoutError::Closed(_)) => Put::Closed,
        }
    }

    /// Queue `item` (after the pending skip marker), waiting as long as it takes, until `stop`
    /// turns true: then the item is handed back (to be dropped, counted). A wait past the stall
    /// time is warned about once, until the queue has drained to half again.
    async fn put_until_stopped(&self, item: SinkItem, mut stop: watch::Receiver<bool>) -> Put {
        if self.waiting.load(Relaxed) && self.tx.capacity() * 2 >= SINK_QUEUE {
            self.waiting.store(false, Relaxed);
            tracing::info!(sink = %self.name, "sink caught up");
        }
        // Resolves once the run is stopping; never if the runtime has gone (no stop can come).
        let stopping = async move {
            if stop.wait_for(|s| *s).await.is_err() {
                std::future::pending::<()>().await;
            }
        };
        tokio::pin!(stopping);
        loop {
            // `reserve` keeps the item here while waiting, so a stop loses nothing uncounted.
            let permit = tokio::select! {
                biased;
                () = &mut stopping => return Put::Full(Box::new(item)),
                r = tokio::time::timeout(self.stall, self.tx.reserve()) => match r {
                    Ok(Ok(permit)) => permit,
                    Ok(Err(_)) => return Put::Closed,
                    Err(_) => {
                        if !self.waiting.swap(true, Relaxed) {
                            tracing::warn!(
                                sink = %self.name,
                                "waiting for sink {}: its consumer has taken nothing for {:.1} s; the replay waits for it, nothing is dropped (Ctrl-C stops)",
                                self.name,
                                self.stall.as_secs_f64()
                            );
                        }
                        continue;
                    }
                },
            };
            if let Some(skip) = self.pending_skip() {
                permit.send(skip);
                self.skip_sent();
                continue;
            }
            permit.send(item);
            return Put::Sent;
        }
    }

    /// Count what a full queue lost; an inline sink's writer is told before its next item.
    fn dropped(&self, item: SinkItem) {
        match item {
            SinkItem::Samples(b) => {
                self.stats.dropped.fetch_add(b.len() as u64, Relaxed);
                if self.wants_side {
                    self.skip_samples.fetch_add(b.len() as u64, Relaxed);
                }
            }
            SinkItem::Side(items) => {
                use crate::io::source::SideItem;
                let carriers = items
                    .iter()
                    .filter(|i| matches!(i, SideItem::Sample(_)))
                    .count();
                let others = items
                    .iter()
                    .filter(|i| matches!(i, SideItem::Other(_)))
                    .count();
                self.skip_carriers.fetch_add(carriers as u64, Relaxed);
                self.stats
                    .messages_dropped
                    .fetch_add(others as u64, Relaxed);
                let announced = items.iter().rev().find_map(|i| match i {
                    SideItem::Protocol(p) => Some(*p),
                    _ => None,
                });
                if let (Some(p), Ok(mut slot)) = (announced, self.skip_protocol.lock()) {
                    *slot = Some(p);
                }
            }
            _ => {}
        }
    }

    /// True while a local sink is stuck and dropping.
    pub fn is_stuck(&self) -> bool {
        self.stuck.load(Relaxed)
    }
}

/// What became of an item offered to a sink's queue.
enum Put {
    Sent,
    /// The sink has ended.
    Closed,
    /// The queue is full (or stayed full for the stall time): the item is handed back.
    Full(Box<SinkItem>),
}

/// Queue length (in batches) of a sink's own input.
const SINK_QUEUE: usize = 64;

/// What the sinks of one run share: its Zenoh session, when it has one, and its stop signal.
#[derive(Clone, Default)]
pub struct SinkContext {
    #[cfg(feature = "zenoh")]
    pub zenoh: Option<crate::io::zenoh::ZenohSession>,
    /// Becomes `true` on SIGINT/SIGTERM: a zenoh sink's wait for a subscriber (`wait_s`) ends.
    #[cfg(feature = "zenoh")]
    pub stop: Option<tokio::sync::watch::Receiver<bool>>,
}

/// Start the task for one configured sink (binds sockets and creates files now, so a bad
/// address or path fails before any data flows).
pub async fn start(sink: &Sink) -> std::io::Result<SinkHandle> {
    start_with(sink, &SinkContext::default()).await
}

/// [`start`] with what the run's sinks share (a Zenoh sink needs the run's session).
pub async fn start_with(sink: &Sink, ctx: &SinkContext) -> std::io::Result<SinkHandle> {
    let queue = match sink {
        Sink::Zenoh { queue, .. } => *queue,
        _ => SINK_QUEUE,
    };
    let (tx, rx) = mpsc::channel(queue);
    let stats = Arc::new(SinkStats::default());
    let st = stats.clone();
    let (name, task) = match sink.clone() {
        Sink::Stdout { format } => {
            let out = tokio::io::stdout();
            let task = tokio::spawn(stream::write_stream(out, format, false, rx, st));
            ("stdout".to_string(), task)
        }
        Sink::File { path, format } => {
            let f = tokio::fs::File::create(&path)
                .await
                .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
            let w = tokio::io::BufWriter::with_capacity(1 << 16, f);
            let task = tokio::spawn(stream::write_stream(w, format, true, rx, st));
            (format!("file:{}", path.display()), task)
        }
        Sink::Tcp {
            bind,
            format,
            queue,
        } => {
            let l = tokio::net::TcpListener::bind(bind).await.map_err(|e| {
                std::io::Error::new(e.kind(), format!("tcp sink cannot bind {bind}: {e}"))
            })?;
            let name = format!("tcp:{}", l.local_addr()?);
            (
                name,
                tokio::spawn(net::tcp_server(l, format, queue, rx, st)),
            )
        }
        Sink::Udp { targets, format } => {
            let sock = tokio::net::UdpSocket::bind("0.0.0.0:0").await?;
            let name = format!("udp:{}", targets.len());
            (
                name,
                tokio::spawn(net::udp_sender(sock, targets, format, rx, st)),
            )
        }
        Sink::Mcap {
            path,
            topic,
            frame_id,
            health_topic,
            compression,
        } => {
            #[cfg(feature = "ros2")]
            {
                use crate::frame::mcap_out::ChunkCompression;
                let opts = crate::io::mcap_sink::McapSinkOptions {
                    topic,
                    frame_id,
                    health_topic,
                    compression: match compression {
                        crate::config::McapCompression::None => ChunkCompression::None,
                        crate::config::McapCompression::Lz4 => ChunkCompression::Lz4,
                        crate::config::McapCompression::Zstd => ChunkCompression::Zstd,
                    },
                };
                let name = format!("mcap:{}", path.display());
                (name, crate::io::mcap_sink::start(path, opts, rx, st)?)
            }
            #[cfg(not(feature = "ros2"))]
            {
                let _ = (path, topic, frame_id, health_topic, compression, rx, st);
                return Err(std::io::Error::other(
                    "mcap sink: this build has no ROS 2 support (cargo build --release --features ros2)",
                ));
            }
        }
        Sink::Inline { path } => inline::start_inline(path, rx, st).await?,
        Sink::Zenoh {
            key,
            format,
            wait_s,
            congestion,
            ..
        } => {
            #[cfg(feature = "zenoh")]
            {
                let Some(z) = ctx.zenoh.clone() else {
                    return Err(std::io::Error::other(format!(
                        "zenoh sink {key}: no Zenoh session (the run opens one from [zenoh])"
                    )));
                };
                let stop = ctx.stop.clone();
                zenoh::start_zenoh(z, key, format, wait_s, congestion, stop, rx, st).await?
            }
            #[cfg(not(feature = "zenoh"))]
            {
                let _ = (key, format, wait_s, congestion, rx, st, ctx);
                return Err(std::io::Error::other(format!(
                    "--out zenoh: {}",
                    crate::config::ZENOH_NOT_BUILT
                )));
            }
        }
    };
    // Network sinks are never waited for; local ones are (up to the stall time), and so is a
    // Zenoh sink that blocks for its consumers (`congestion = "block"`).
    let lossless = !matches!(
        sink,
        Sink::Tcp { .. }
            | Sink::Udp { .. }
            | Sink::Zenoh {
                congestion: crate::config::ZenohCongestion::Drop,
                ..
            }
    );
    let wants_side = matches!(sink, Sink::Inline { .. });
    Ok(SinkHandle::new(name, tx, lossless, wants_side, stats, task))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A network sink (never waited for) whose queue holds one item and whose consumer reads
    /// nothing: the second batch is dropped, counted, and starts a dropping episode (warned
    /// once); an item that gets through again ends it.
    #[tokio::test]
    async fn a_network_sinks_full_queue_drops_counted_in_one_warned_episode() {
        let (tx, mut rx) = mpsc::channel(1);
        let stats = Arc::new(SinkStats::default());
        let h = SinkHandle::new(
            "udp:test".into(),
            tx,
            false,
            false,
            stats,
            tokio::spawn(async {}),
        );
        let batch = || SinkItem::Samples(Arc::new(vec![Sample::nth(0, 1_000); 3]));
        h.offer(batch()).await;
        assert!(!h.dropping.load(Relaxed));
        h.offer(batch()).await;
        h.offer(batch()).await;
        assert!(h.dropping.load(Relaxed));
        assert_eq!(h.stats.dropped.load(Relaxed), 6);
        rx.recv().await.unwrap();
        h.offer(batch()).await;
        assert!(
            !h.dropping.load(Relaxed),
            "the episode ends when an item gets through"
        );
        assert_eq!(h.stats.dropped.load(Relaxed), 6);
    }
}
