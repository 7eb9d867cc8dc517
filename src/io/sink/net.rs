//! Network sinks: the TCP server (a bounded queue and a lag counter per client) and UDP.

use super::{ClientCounters, SinkItem, SinkStats};
use crate::config::Format;
use crate::frame::Descriptor;
use crate::io::format::Encoder;
use bytes::{Bytes, BytesMut};
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;

struct Client {
    tx: mpsc::Sender<(Bytes, u64)>,
    counters: Arc<ClientCounters>,
}

pub(super) async fn tcp_server(
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

pub(super) async fn udp_sender(
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
