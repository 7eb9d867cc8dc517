//! Sinks: stdout, file, TCP server, UDP, inline (the input's own protocol to a serial device,
//! file or pseudo-terminal). Each runs as its own task behind a bounded queue.
//!
//! The runtime hands every sink the same `Arc` batch and never waits long for any of them:
//!
//! * Network sinks (TCP, UDP) are offered the batch with `try_send`; a full queue drops the
//!   batch for that consumer only, counted. The TCP server repeats that per client: each client
//!   has its own bounded queue and lag counter; what a client was sent counts bytes written to
//!   its socket, not bytes queued; a client that leaves is folded into the sink's totals.
//! * Local sinks (stdout, file, inline) are wanted complete, so a full queue is waited for — but
//!   only up to the sink's stall time ([`DEFAULT_STALL`]). A sink whose queue stays full that long
//!   is *stuck* (a `| (sleep 20; cat)` pipe, a full disk, a FIFO nobody reads): from then on it
//!   is offered like a network sink — batches it cannot take are dropped and counted — until
//!   its queue has drained to half, when it is waited for again. A stuck consumer therefore
//!   costs the stream one stall time, once, and never freezes the daemon or its health reports.
//! * Inline sinks (serial device, file, pseudo-terminal) are local sinks too, with one more
//!   duty: each sample must meet its own carrier, which travels ahead of it in the side stream.
//!   What a stuck inline sink drops (sample batches, side batches) is told to its writer by a
//!   [`SinkItem::Skip`] marker queued before the next item that gets through, so the writer
//!   knows the index of every sample and carrier: a sample whose carrier was dropped, and a
//!   carrier whose sample was dropped, are dropped too (counted), and a frame that carries
//!   several samples (UBX ESF-RAW) is dropped whole when one of them was, so nothing raw is
//!   ever written as cleaned and no sample lands in another's carrier.

use crate::config::{Format, Sink};
use crate::frame::Descriptor;
use crate::frame::health::HealthFrame;
use crate::io::format::Encoder;
use crate::sample::Sample;
use bytes::{Bytes, BytesMut};
use serde::Serialize;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

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

/// One TCP client's view.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct ClientStats {
    pub peer: String,
    /// Samples written to this client's socket.
    pub samples_sent: u64,
    /// Samples this client missed because its queue was full (it fell behind).
    pub samples_dropped: u64,
    pub connected: bool,
}

/// Live counters of one TCP client (updated by the server and the client's writer task).
#[derive(Debug, Default)]
pub struct ClientCounters {
    pub peer: String,
    pub sent: AtomicU64,
    pub dropped: AtomicU64,
    /// Set while the client is behind (its queue full), to log the start of a lag once.
    lagging: AtomicBool,
}

impl ClientCounters {
    fn snapshot(&self) -> ClientStats {
        ClientStats {
            peer: self.peer.clone(),
            samples_sent: self.sent.load(Relaxed),
            samples_dropped: self.dropped.load(Relaxed),
            connected: true,
        }
    }
}

/// The TCP clients that have left, folded together (their per-client entries are freed).
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct GoneClients {
    pub clients: u64,
    pub samples_sent: u64,
    pub samples_dropped: u64,
}

/// Counters of one sink, shared with the runtime's health report.
#[derive(Debug, Default)]
pub struct SinkStats {
    /// Samples handed to the consumer (written to stdout/file, datagrams sent, or queued to
    /// the TCP clients; each client's own count is what was written to it).
    pub samples_out: AtomicU64,
    /// Samples this sink (as a whole) missed because its queue was full.
    pub dropped: AtomicU64,
    /// Health reports written.
    pub health_out: AtomicU64,
    /// Write/send errors.
    pub errors: AtomicU64,
    /// Inline sinks: pass-through messages (not IMU data) dropped with a side batch while stuck.
    pub messages_dropped: AtomicU64,
    /// TCP clients connected now.
    pub clients: Mutex<Vec<Arc<ClientCounters>>>,
    /// TCP clients that have left.
    pub gone: Mutex<GoneClients>,
}

/// Snapshot of a sink for reports.
#[derive(Debug, Clone, Serialize)]
pub struct SinkReport {
    pub name: String,
    pub samples_out: u64,
    pub dropped: u64,
    pub health_out: u64,
    pub errors: u64,
    /// Inline sinks: pass-through messages dropped while stuck.
    pub messages_dropped: u64,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub clients: Vec<ClientStats>,
    #[serde(skip_serializing_if = "is_zero_gone")]
    pub clients_gone: GoneClients,
}

fn is_zero_gone(g: &GoneClients) -> bool {
    g.clients == 0
}

impl SinkReport {
    /// Samples this sink lost, including every client's lag (present and gone).
    pub fn dropped_total(&self) -> u64 {
        self.dropped
            + self.clients.iter().map(|c| c.samples_dropped).sum::<u64>()
            + self.clients_gone.samples_dropped
    }
}

/// A running sink.
pub struct SinkHandle {
    pub name: String,
    pub tx: mpsc::Sender<SinkItem>,
    /// Waited for (up to `stall`) when true; see the module docs.
    pub lossless: bool,
    /// Wants the side stream ([`SinkItem::Side`]): inline sinks.
    pub wants_side: bool,
    pub stats: Arc<SinkStats>,
    pub task: JoinHandle<()>,
    /// How long a full queue is waited for before the sink counts as stuck.
    pub stall: Duration,
    /// Set while the sink is stuck (dropping instead of waiting).
    stuck: AtomicBool,
    /// Inline sinks: samples and carriers dropped since the last item that got through, not
    /// yet told to the writer (a [`SinkItem::Skip`] goes ahead of the next item).
    skip_samples: AtomicU64,
    skip_carriers: AtomicU64,
    skip_protocol: Mutex<Option<crate::frame::Protocol>>,
}

impl SinkStats {
    pub fn report(&self, name: &str) -> SinkReport {
        SinkReport {
            name: name.to_string(),
            samples_out: self.samples_out.load(Relaxed),
            dropped: self.dropped.load(Relaxed),
            health_out: self.health_out.load(Relaxed),
            errors: self.errors.load(Relaxed),
            messages_dropped: self.messages_dropped.load(Relaxed),
            clients: self
                .clients
                .lock()
                .map(|c| c.iter().map(|k| k.snapshot()).collect())
                .unwrap_or_default(),
            clients_gone: self.gone.lock().map(|g| *g).unwrap_or_default(),
        }
    }

    /// A client has left: free its entry, keep its counts in the totals.
    fn client_left(&self, c: &Arc<ClientCounters>) {
        if let Ok(mut live) = self.clients.lock() {
            let before = live.len();
            live.retain(|k| !Arc::ptr_eq(k, c));
            if live.len() < before
                && let Ok(mut g) = self.gone.lock()
            {
                g.clients += 1;
                g.samples_sent += c.sent.load(Relaxed);
                g.samples_dropped += c.dropped.load(Relaxed);
            }
        }
    }
}

impl SinkHandle {
    /// Offer an item. Network sinks: dropped (and counted) when the queue is full. Local sinks
    /// (inline ones included): waited for up to `stall`, then dropped while the sink is stuck
    /// (see the module docs).
    pub async fn offer(&self, item: SinkItem) {
        let item = match self.try_put(item) {
            Put::Sent | Put::Closed => return,
            Put::Full(item) => *item,
        };
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

/// Start the task for one configured sink (binds sockets and creates files now, so a bad
/// address or path fails before any data flows).
pub async fn start(sink: &Sink) -> std::io::Result<SinkHandle> {
    let (tx, rx) = mpsc::channel(SINK_QUEUE);
    let stats = Arc::new(SinkStats::default());
    let st = stats.clone();
    let (name, lossless, task) = match sink.clone() {
        Sink::Stdout { format } => {
            let out = tokio::io::stdout();
            (
                "stdout".to_string(),
                true,
                tokio::spawn(write_stream(out, format, false, rx, st)),
            )
        }
        Sink::File { path, format } => {
            let f = tokio::fs::File::create(&path)
                .await
                .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
            let w = tokio::io::BufWriter::with_capacity(1 << 16, f);
            (
                format!("file:{}", path.display()),
                true,
                tokio::spawn(write_stream(w, format, true, rx, st)),
            )
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
                false,
                tokio::spawn(tcp_server(l, format, queue, rx, st)),
            )
        }
        Sink::Udp { targets, format } => {
            let sock = tokio::net::UdpSocket::bind("0.0.0.0:0").await?;
            (
                format!("udp:{}", targets.len()),
                false,
                tokio::spawn(udp_sender(sock, targets, format, rx, st)),
            )
        }
        Sink::Mcap {
            path,
            topic,
            frame_id,
            health_topic,
        } => {
            #[cfg(feature = "ros2")]
            {
                let opts = crate::io::mcap_sink::McapSinkOptions {
                    topic,
                    frame_id,
                    health_topic,
                };
                (
                    format!("mcap:{}", path.display()),
                    true,
                    crate::io::mcap_sink::start(path, opts, rx, st)?,
                )
            }
            #[cfg(not(feature = "ros2"))]
            {
                let _ = (path, topic, frame_id, health_topic, rx, st);
                return Err(std::io::Error::other(
                    "mcap sink: this build has no ROS 2 support (cargo build --release --features ros2)",
                ));
            }
        }
        Sink::Inline { path } => {
            let (name, task) = start_inline(path, rx, st).await?;
            return Ok(SinkHandle {
                name,
                tx,
                lossless: true,
                wants_side: true,
                stats,
                task,
                stall: DEFAULT_STALL,
                stuck: AtomicBool::new(false),
                skip_samples: AtomicU64::new(0),
                skip_carriers: AtomicU64::new(0),
                skip_protocol: Mutex::new(None),
            });
        }
    };
    Ok(SinkHandle {
        name,
        tx,
        lossless,
        wants_side: false,
        stats,
        task,
        stall: DEFAULT_STALL,
        stuck: AtomicBool::new(false),
        skip_samples: AtomicU64::new(0),
        skip_carriers: AtomicU64::new(0),
        skip_protocol: Mutex::new(None),
    })
}

/// stdout and files: preamble at the first item, then every batch, flushed per batch.
async fn write_stream<W: tokio::io::AsyncWrite + Unpin>(
    mut w: W,
    format: Format,
    as_file: bool,
    mut rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) {
    let mut enc = Encoder::new(format);
    let mut started = false;
    let mut buf = BytesMut::with_capacity(1 << 16);
    while let Some(item) = rx.recv().await {
        buf.clear();
        match &item {
            SinkItem::Descriptor(d) if !started => enc.preamble(d, as_file, &mut buf),
            SinkItem::Descriptor(d) => enc.descriptor(d, &mut buf),
            SinkItem::Side(_) | SinkItem::Skip { .. } => continue,
            SinkItem::Health(h) => {
                if !started || !enc.health(h, &mut buf) {
                    // Nothing to say before the stream's preamble, or a format without health.
                    continue;
                }
            }
            SinkItem::Samples(b) => {
                if !started {
                    enc.preamble(&Descriptor::default(), as_file, &mut buf);
                }
                for s in b.iter() {
                    enc.sample(s, &mut buf);
                }
            }
        }
        started = true;
        if w.write_all(&buf).await.is_err() || w.flush().await.is_err() {
            stats.errors.fetch_add(1, Relaxed);
            // A closed stdout (e.g. `| head`) ends this sink only; the others go on.
            break;
        }
        match &item {
            SinkItem::Samples(b) => {
                stats.samples_out.fetch_add(b.len() as u64, Relaxed);
            }
            SinkItem::Health(_) => {
                stats.health_out.fetch_add(1, Relaxed);
            }
            _ => {}
        }
    }
    let _ = w.flush().await;
}

struct Client {
    tx: mpsc::Sender<(Bytes, u64)>,
    counters: Arc<ClientCounters>,
}

async fn tcp_server(
    listener: tokio::net::TcpListener,
    format: Format,
    queue: usize,
    mut rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) {
    let mut enc = Encoder::new(format);
    let mut clients: Vec<Client> = Vec::new();
    let mut descriptor = Descriptor::default();
    let mut buf = BytesMut::new();
    loop {
        tokio::select! {
            acc = listener.accept() => {
                let Ok((sock, peer)) = acc else {
                    stats.errors.fetch_add(1, Relaxed);
                    continue;
                };
                let _ = sock.set_nodelay(true);
                let (ctx, crx) = mpsc::channel::<(Bytes, u64)>(queue);
                let mut pre = BytesMut::new();
                enc.preamble(&descriptor, false, &mut pre);
                let _ = ctx.try_send((pre.freeze(), 0));
                let counters = Arc::new(ClientCounters { peer: peer.to_string(), ..Default::default() });
                stats.clients.lock().expect("stats lock").push(counters.clone());
                tokio::spawn(tcp_client(sock, crx, stats.clone(), counters.clone()));
                tracing::info!(%peer, "tcp client connected");
                clients.push(Client { tx: ctx, counters });
            }
            item = rx.recv() => {
                let Some(item) = item else { break };
                buf.clear();
                let n = match &item {
                    SinkItem::Descriptor(d) => { descriptor = *d; enc.descriptor(d, &mut buf); 0 }
                    SinkItem::Samples(b) => { for s in b.iter() { enc.sample(s, &mut buf); } b.len() as u64 }
                    SinkItem::Side(_) | SinkItem::Skip { .. } => 0,
                    SinkItem::Health(h) => { enc.health(h, &mut buf); 0 }
                };
                if buf.is_empty() { continue; }
                let bytes = buf.split().freeze();
                clients.retain(|c| match c.tx.try_send((bytes.clone(), n)) {
                    Ok(()) => {
                        if c.counters.lagging.swap(false, Relaxed) {
                            tracing::info!(peer = %c.counters.peer, "tcp client caught up");
                        }
                        true
                    }
                    Err(mpsc::error::TrySendError::Full(_)) => {
                        c.counters.dropped.fetch_add(n, Relaxed);
                        if n > 0 && !c.counters.lagging.swap(true, Relaxed) {
                            tracing::warn!(peer = %c.counters.peer, "tcp client behind: dropping its batches, counted");
                        }
                        true
                    }
                    Err(mpsc::error::TrySendError::Closed(_)) => false,
                });
                if matches!(item, SinkItem::Health(_)) {
                    stats.health_out.fetch_add(1, Relaxed);
                }
                stats.samples_out.fetch_add(n, Relaxed);
            }
        }
    }
}

/// One client's writer: counts what reached its socket; on leaving, its entry is freed and its
/// counts folded into the sink's totals.
async fn tcp_client(
    mut sock: tokio::net::TcpStream,
    mut rx: mpsc::Receiver<(Bytes, u64)>,
    stats: Arc<SinkStats>,
    counters: Arc<ClientCounters>,
) {
    use tokio::io::AsyncReadExt;
    let (mut rd, mut wr) = sock.split();
    let mut scratch = [0u8; 256];
    loop {
        tokio::select! {
            item = rx.recv() => {
                let Some((b, n)) = item else { break };
                if wr.write_all(&b).await.is_err() {
                    break;
                }
                counters.sent.fetch_add(n, Relaxed);
            }
            // A client that hangs up is noticed at once, not at the next failed write.
            r = rd.read(&mut scratch) => {
                if matches!(r, Ok(0) | Err(_)) {
                    break;
                }
            }
        }
    }
    // Whatever was still queued was never written: lost to this client.
    rx.close();
    while let Ok((_, n)) = rx.try_recv() {
        counters.dropped.fetch_add(n, Relaxed);
    }
    stats.client_left(&counters);
    tracing::info!(peer = %counters.peer, "tcp client left");
}

async fn udp_sender(
    sock: tokio::net::UdpSocket,
    targets: Vec<std::net::SocketAddr>,
    format: Format,
    mut rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) {
    let mut enc = Encoder::new(format);
    let mut buf = BytesMut::new();
    while let Some(item) = rx.recv().await {
        if let SinkItem::Health(h) = &item {
            buf.clear();
            if enc.health(h, &mut buf) {
                for t in &targets {
                    if sock.send_to(&buf, t).await.is_err() {
                        stats.errors.fetch_add(1, Relaxed);
                    }
                }
                stats.health_out.fetch_add(1, Relaxed);
            }
            continue;
        }
        let SinkItem::Samples(b) = item else { continue };
        for s in b.iter() {
            buf.clear();
            enc.sample(s, &mut buf);
            for t in &targets {
                if sock.send_to(&buf, t).await.is_err() {
                    stats.errors.fetch_add(1, Relaxed);
                }
            }
        }
        stats.samples_out.fetch_add(b.len() as u64, Relaxed);
    }
}

/// Open the inline target: a path (serial device, pseudo-terminal or file; created if absent,
/// written at the device's current line settings), or a new pseudo-terminal whose path is
/// printed on stderr and logged.
async fn start_inline(
    path: Option<std::path::PathBuf>,
    rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) -> std::io::Result<(String, JoinHandle<()>)> {
    match path {
        Some(p) => {
            let f = tokio::fs::OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(!is_char_device(&p))
                .open(&p)
                .await
                .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", p.display())))?;
            Ok((
                format!("inline:{}", p.display()),
                tokio::spawn(inline_writer(f, None::<()>, rx, stats)),
            ))
        }
        None => {
            #[cfg(unix)]
            {
                use tokio_serial::SerialPort;
                let (master, slave) = tokio_serial::SerialStream::pair()
                    .map_err(|e| std::io::Error::other(format!("pty: {e}")))?;
                let name = slave.name().unwrap_or_else(|| "?".into());
                eprintln!("imuprep: inline output on pseudo-terminal {name}");
                tracing::info!(pty = %name, "inline output on a pseudo-terminal");
                // The slave end stays open while we write, so the master never sees a hang-up
                // before a reader attaches.
                Ok((
                    format!("pty:{name}"),
                    tokio::spawn(inline_writer(master, Some(slave), rx, stats)),
                ))
            }
            #[cfg(not(unix))]
            {
                Err(std::io::Error::other("pty: needs a Unix system"))
            }
        }
    }
}

fn is_char_device(p: &std::path::Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        std::fs::metadata(p).is_ok_and(|m| m.file_type().is_char_device())
    }
    #[cfg(not(unix))]
    {
        let _ = p;
        false
    }
}

/// Inline output: each cleaned sample goes back into its carrier, messages that are not IMU data
/// are written unchanged, all in input order. The side stream arrives ahead of the samples (the
/// pipeline may hold samples for its look-ahead); a pass-through message is written as soon as
/// every sample before it has been. Samples and carriers are paired by index, so what a stuck
/// sink dropped ([`SinkItem::Skip`]) never shifts a sample into another's carrier.
async fn inline_writer<W: tokio::io::AsyncWrite + Unpin, K: Send + 'static>(
    mut w: W,
    _keep: Option<K>,
    mut rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) {
    use crate::frame::inline::InlineEncoder;
    use crate::io::source::SideItem;
    let mut p = InlinePairing::default();
    let mut buf = BytesMut::with_capacity(1 << 16);
    while let Some(item) = rx.recv().await {
        buf.clear();
        match item {
            SinkItem::Descriptor(_) | SinkItem::Health(_) => continue,
            SinkItem::Side(items) => p.side(&items),
            SinkItem::Skip {
                samples,
                carriers,
                protocol,
            } => p.skip(samples, carriers, protocol),
            SinkItem::Samples(b) => {
                let (written, dropped) = p.samples(&b, &mut buf);
                stats.samples_out.fetch_add(written, Relaxed);
                stats.dropped.fetch_add(dropped, Relaxed);
            }
        }
        drain_others(&mut p.queue, &mut p.enc, &mut buf);
        if !buf.is_empty() && (w.write_all(&buf).await.is_err() || w.flush().await.is_err()) {
            stats.errors.fetch_add(1, Relaxed);
            break;
        }
    }
    // End of stream: what is left (messages after the last sample, a half-filled frame).
    buf.clear();
    while let Some((_, it)) = p.queue.pop_front() {
        if let SideItem::Other(b) = it {
            p.enc
                .get_or_insert_with(|| InlineEncoder::new(crate::frame::Protocol::Native, 0.0, 0.0))
                .other(&b, &mut buf);
        }
    }
    if let Some(e) = p.enc.as_mut() {
        e.flush(&mut buf);
    }
    if p.unmatched > 0 {
        stats.errors.fetch_add(p.unmatched, Relaxed);
        tracing::warn!(
            unmatched = p.unmatched,
            "inline sink: samples without a carrier"
        );
    }
    let _ = w.write_all(&buf).await;
    let _ = w.flush().await;
}

/// The inline writer's pairing of samples with their carriers by index (module docs).
#[derive(Default)]
struct InlinePairing {
    enc: Option<crate::frame::inline::InlineEncoder>,
    /// Side items not yet written, each carrier with its index.
    queue: std::collections::VecDeque<(u64, crate::io::source::SideItem)>,
    /// Index of the next carrier and of the next sample to arrive (dropped ones counted).
    carriers_in: u64,
    samples_in: u64,
    /// A multi-sample frame one of whose samples was dropped: its other samples go too.
    poisoned: Option<Bytes>,
    /// Samples that came with no carrier at all (a source bug, counted as errors).
    unmatched: u64,
}

impl InlinePairing {
    fn side(&mut self, items: &[crate::io::source::SideItem]) {
        use crate::io::source::SideItem;
        for it in items {
            let k = self.carriers_in;
            if matches!(it, SideItem::Sample(_)) {
                self.carriers_in += 1;
            }
            self.queue.push_back((k, it.clone()));
        }
    }

    fn skip(&mut self, samples: u64, carriers: u64, protocol: Option<crate::frame::Protocol>) {
        self.samples_in += samples;
        self.carriers_in += carriers;
        if let Some(p) = protocol {
            self.enc = Some(crate::frame::inline::InlineEncoder::new(p, 0.0, 0.0));
        }
    }

    /// Drop carrier `c` (its sample was dropped): and the whole frame it is part of.
    fn discard(&mut self, c: Option<crate::frame::protocol::Carrier>) {
        if let Some(c) = c {
            if let Some(e) = self.enc.as_mut() {
                e.discard(&c.frame);
            }
            if c.slots > 1 {
                self.poisoned = Some(c.frame);
            }
        }
    }

    fn is_poisoned(&self, c: &Option<crate::frame::protocol::Carrier>) -> bool {
        matches!((&self.poisoned, c), (Some(p), Some(c)) if p.as_ptr() == c.frame.as_ptr() && p.len() == c.frame.len())
    }

    /// Write a batch of samples into their carriers; (written, dropped).
    fn samples(&mut self, b: &[Sample], buf: &mut BytesMut) -> (u64, u64) {
        use crate::frame::inline::InlineEncoder;
        use crate::io::source::SideItem;
        let (mut written, mut dropped) = (0, 0);
        for s in b {
            let i = self.samples_in;
            self.samples_in += 1;
            loop {
                drain_others(&mut self.queue, &mut self.enc, buf);
                match self.queue.front() {
                    Some((k, SideItem::Sample(_))) if *k < i => {
                        // A carrier whose sample was dropped.
                        if let Some((_, SideItem::Sample(c))) = self.queue.pop_front() {
                            self.discard(c);
                        }
                    }
                    Some((k, SideItem::Sample(_))) if *k == i => {
                        let Some((_, SideItem::Sample(c))) = self.queue.pop_front() else {
                            unreachable!("front is a carrier")
                        };
                        if self.is_poisoned(&c) {
                            self.discard(c);
                            dropped += 1;
                        } else {
                            let e = self.enc.get_or_insert_with(|| {
                                InlineEncoder::new(crate::frame::Protocol::Native, 0.0, 0.0)
                            });
                            e.sample(c.as_ref(), s, buf);
                            written += 1;
                        }
                        break;
                    }
                    _ => {
                        if i < self.carriers_in {
                            dropped += 1; // its carrier was dropped
                        } else {
                            self.unmatched += 1;
                        }
                        break;
                    }
                }
            }
        }
        (written, dropped)
    }
}

/// Write the pass-through messages at the front of the queue (no sample precedes them).
fn drain_others(
    queue: &mut std::collections::VecDeque<(u64, crate::io::source::SideItem)>,
    enc: &mut Option<crate::frame::inline::InlineEncoder>,
    buf: &mut BytesMut,
) {
    use crate::frame::inline::InlineEncoder;
    use crate::io::source::SideItem;
    while let Some((_, front)) = queue.front() {
        match front {
            SideItem::Protocol(p) => {
                // MAVLink RAW_IMU frames carry the configured scales in their carrier; the
                // zeros here are only a fallback (RAW_IMU values then pass unchanged).
                *enc = Some(InlineEncoder::new(*p, 0.0, 0.0));
                queue.pop_front();
            }
            SideItem::Other(b) => {
                enc.get_or_insert_with(|| {
                    InlineEncoder::new(crate::frame::Protocol::Native, 0.0, 0.0)
                })
                .other(b, buf);
                queue.pop_front();
            }
            SideItem::Sample(_) => break,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::protocol::Carrier;
    use crate::io::source::SideItem;

    fn carrier(frame: &Bytes, slot: u16, slots: u16) -> SideItem {
        SideItem::Sample(Some(Carrier {
            frame: frame.clone(),
            slot,
            slots,
            ..Carrier::default()
        }))
    }

    fn samples(n: usize) -> Vec<Sample> {
        (0..n)
            .map(|i| Sample {
                seq: i as u32,
                ..Sample::default()
            })
            .collect()
    }

    #[test]
    fn pairing_by_index_survives_dropped_samples_and_dropped_carriers() {
        let mut p = InlinePairing::default();
        let mut buf = BytesMut::new();
        let frames: Vec<Bytes> = (0..10u8).map(|i| Bytes::from(vec![i; 4])).collect();
        // Carriers 0..6 arrive; samples 0, 1 are written, 2..4 dropped (Skip), 4, 5 written.
        p.side(
            &frames[..6]
                .iter()
                .map(|f| carrier(f, 0, 1))
                .collect::<Vec<_>>(),
        );
        assert_eq!(p.samples(&samples(2), &mut buf), (2, 0));
        p.skip(2, 0, None);
        assert_eq!(p.samples(&samples(2), &mut buf), (2, 0));
        assert!(
            p.queue.is_empty(),
            "the dropped samples' carriers are discarded"
        );
        // Carriers 6, 7 dropped (Skip), 8, 9 arrive: samples 6, 7 have none and are dropped.
        p.skip(0, 2, None);
        p.side(
            &frames[8..]
                .iter()
                .map(|f| carrier(f, 0, 1))
                .collect::<Vec<_>>(),
        );
        assert_eq!(p.samples(&samples(4), &mut buf), (2, 2));
        assert_eq!((p.unmatched, p.queue.len()), (0, 0));
        // A sample with no carrier ever: unmatched (an error), not a drop.
        assert_eq!(p.samples(&samples(1), &mut buf), (0, 0));
        assert_eq!(p.unmatched, 1);
    }

    #[test]
    fn a_frame_with_several_samples_is_dropped_whole_when_one_of_them_was() {
        let mut p = InlinePairing::default();
        let mut buf = BytesMut::new();
        let f = Bytes::from(vec![7u8; 8]);
        let g = Bytes::from(vec![8u8; 8]);
        p.side(&[
            carrier(&f, 0, 3),
            carrier(&f, 1, 3),
            carrier(&f, 2, 3),
            carrier(&g, 0, 1),
        ]);
        p.skip(1, 0, None); // slot 0's sample dropped
        // Slots 1 and 2 would otherwise go out in a frame whose slot 0 is still raw.
        assert_eq!(p.samples(&samples(3), &mut buf), (1, 2));
        assert!(p.queue.is_empty());
    }
}
