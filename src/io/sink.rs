//! Sinks: stdout, file, TCP server, UDP. Each runs as its own task behind a bounded queue.
//!
//! The runtime hands every sink the same `Arc` batch. Lossless sinks (stdout, file: local, and
//! wanted complete) are awaited; network sinks are offered the batch with `try_send`, and a full
//! queue drops the batch for that consumer only, counted — the stream never waits for them. The
//! TCP server repeats that per client: each client has its own bounded queue and lag counter.

use crate::config::{Format, Sink};
use crate::frame::Descriptor;
use crate::io::format::Encoder;
use crate::sample::Sample;
use bytes::{Bytes, BytesMut};
use serde::Serialize;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

/// What flows to a sink.
#[derive(Debug, Clone)]
pub enum SinkItem {
    Descriptor(Descriptor),
    Samples(Arc<Vec<Sample>>),
}

/// One TCP client's view.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct ClientStats {
    pub peer: String,
    /// Samples queued to this client.
    pub samples_sent: u64,
    /// Samples this client missed because its queue was full (it fell behind).
    pub samples_dropped: u64,
    pub connected: bool,
}

/// Counters of one sink, shared with the runtime's health report.
#[derive(Debug, Default)]
pub struct SinkStats {
    /// Samples handed to the consumer (written, or queued to clients/datagrams).
    pub samples_out: AtomicU64,
    /// Samples this sink (as a whole) missed because its queue was full.
    pub dropped: AtomicU64,
    /// Write/send errors.
    pub errors: AtomicU64,
    pub clients: Mutex<Vec<ClientStats>>,
}

/// Snapshot of a sink for reports.
#[derive(Debug, Clone, Serialize)]
pub struct SinkReport {
    pub name: String,
    pub samples_out: u64,
    pub dropped: u64,
    pub errors: u64,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub clients: Vec<ClientStats>,
}

/// A running sink.
pub struct SinkHandle {
    pub name: String,
    pub tx: mpsc::Sender<SinkItem>,
    /// Awaited by the runtime (never drops) when true.
    pub lossless: bool,
    pub stats: Arc<SinkStats>,
    pub task: JoinHandle<()>,
}

impl SinkStats {
    pub fn report(&self, name: &str) -> SinkReport {
        SinkReport {
            name: name.to_string(),
            samples_out: self.samples_out.load(Relaxed),
            dropped: self.dropped.load(Relaxed),
            errors: self.errors.load(Relaxed),
            clients: self.clients.lock().map(|c| c.clone()).unwrap_or_default(),
        }
    }
}

impl SinkHandle {
    /// Offer an item: awaited if lossless, else dropped (and counted) when the queue is full.
    pub async fn offer(&self, item: SinkItem) {
        if self.lossless {
            let _ = self.tx.send(item).await;
        } else if let Err(mpsc::error::TrySendError::Full(SinkItem::Samples(b))) =
            self.tx.try_send(item)
        {
            self.stats.dropped.fetch_add(b.len() as u64, Relaxed);
        }
    }
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
    };
    Ok(SinkHandle {
        name,
        tx,
        lossless,
        stats,
        task,
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
        if let SinkItem::Samples(b) = &item {
            stats.samples_out.fetch_add(b.len() as u64, Relaxed);
        }
    }
    let _ = w.flush().await;
}

struct Client {
    tx: mpsc::Sender<Bytes>,
    index: usize,
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
                let (ctx, crx) = mpsc::channel::<Bytes>(queue);
                let mut pre = BytesMut::new();
                enc.preamble(&descriptor, false, &mut pre);
                let _ = ctx.try_send(pre.freeze());
                let index = {
                    let mut c = stats.clients.lock().expect("stats lock");
                    c.push(ClientStats { peer: peer.to_string(), connected: true, ..Default::default() });
                    c.len() - 1
                };
                tokio::spawn(tcp_client(sock, crx, stats.clone(), index));
                tracing::info!(%peer, "tcp client connected");
                clients.push(Client { tx: ctx, index });
            }
            item = rx.recv() => {
                let Some(item) = item else { break };
                buf.clear();
                let n = match &item {
                    SinkItem::Descriptor(d) => { descriptor = *d; enc.descriptor(d, &mut buf); 0 }
                    SinkItem::Samples(b) => { for s in b.iter() { enc.sample(s, &mut buf); } b.len() as u64 }
                };
                if buf.is_empty() { continue; }
                let bytes = buf.split().freeze();
                let mut cs = stats.clients.lock().expect("stats lock");
                clients.retain(|c| match c.tx.try_send(bytes.clone()) {
                    Ok(()) => { cs[c.index].samples_sent += n; true }
                    Err(mpsc::error::TrySendError::Full(_)) => { cs[c.index].samples_dropped += n; true }
                    Err(mpsc::error::TrySendError::Closed(_)) => { cs[c.index].connected = false; false }
                });
                stats.samples_out.fetch_add(n, Relaxed);
            }
        }
    }
}

async fn tcp_client(
    mut sock: tokio::net::TcpStream,
    mut rx: mpsc::Receiver<Bytes>,
    stats: Arc<SinkStats>,
    index: usize,
) {
    while let Some(b) = rx.recv().await {
        if sock.write_all(&b).await.is_err() {
            break;
        }
    }
    if let Ok(mut c) = stats.clients.lock() {
        c[index].connected = false;
    }
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
