//! Sinks: stdout, file, TCP server, UDP, inline (the input's own protocol to a serial device,
//! file or pseudo-terminal). Each runs as its own task behind a bounded queue.
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
    /// Carriers and pass-through messages, ahead of their samples (inline sinks only).
    Side(Arc<Vec<crate::io::source::SideItem>>),
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
    /// Wants the side stream ([`SinkItem::Side`]): inline sinks.
    pub wants_side: bool,
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
            SinkItem::Side(_) => continue,
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
                    SinkItem::Side(_) => 0,
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
/// every sample before it has been.
async fn inline_writer<W: tokio::io::AsyncWrite + Unpin, K: Send + 'static>(
    mut w: W,
    _keep: Option<K>,
    mut rx: mpsc::Receiver<SinkItem>,
    stats: Arc<SinkStats>,
) {
    use crate::frame::inline::InlineEncoder;
    use crate::io::source::SideItem;
    use std::collections::VecDeque;
    let mut enc: Option<InlineEncoder> = None;
    let mut queue: VecDeque<SideItem> = VecDeque::new();
    let mut buf = BytesMut::with_capacity(1 << 16);
    let mut unmatched = 0u64;
    while let Some(item) = rx.recv().await {
        buf.clear();
        match item {
            SinkItem::Descriptor(_) => continue,
            SinkItem::Side(items) => queue.extend(items.iter().cloned()),
            SinkItem::Samples(b) => {
                for s in b.iter() {
                    drain_others(&mut queue, &mut enc, &mut buf);
                    match queue.pop_front() {
                        Some(SideItem::Sample(c)) => {
                            let e = enc.get_or_insert_with(|| {
                                InlineEncoder::new(crate::frame::Protocol::Native, 0.0, 0.0)
                            });
                            e.sample(c.as_ref(), s, &mut buf);
                        }
                        _ => unmatched += 1,
                    }
                }
                stats.samples_out.fetch_add(b.len() as u64, Relaxed);
            }
        }
        drain_others(&mut queue, &mut enc, &mut buf);
        if !buf.is_empty() && (w.write_all(&buf).await.is_err() || w.flush().await.is_err()) {
            stats.errors.fetch_add(1, Relaxed);
            break;
        }
    }
    // End of stream: what is left (messages after the last sample, a half-filled frame).
    buf.clear();
    while let Some(it) = queue.pop_front() {
        if let SideItem::Other(b) = it {
            enc.get_or_insert_with(|| InlineEncoder::new(crate::frame::Protocol::Native, 0.0, 0.0))
                .other(&b, &mut buf);
        }
    }
    if let Some(e) = enc.as_mut() {
        e.flush(&mut buf);
    }
    if unmatched > 0 {
        stats.errors.fetch_add(unmatched, Relaxed);
        tracing::warn!(unmatched, "inline sink: samples without a carrier");
    }
    let _ = w.write_all(&buf).await;
    let _ = w.flush().await;
}

/// Write the pass-through messages at the front of the queue (no sample precedes them).
fn drain_others(
    queue: &mut std::collections::VecDeque<crate::io::source::SideItem>,
    enc: &mut Option<crate::frame::inline::InlineEncoder>,
    buf: &mut BytesMut,
) {
    use crate::frame::inline::InlineEncoder;
    use crate::io::source::SideItem;
    while let Some(front) = queue.front() {
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
