//! Fan-out: two TCP clients, one never reads. The reader gets every frame; the stalled one's
//! lag counter rises; the stream never waits.
mod common;

use imuprep::frame::{FrameDecoder, Message};
use imuprep::io::sink::SinkItem;
use std::sync::Arc;
use tokio::io::AsyncReadExt;
use tokio_util::codec::Decoder;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_tcp_client_falls_behind_and_never_stalls_the_other() {
    let (h, addr) = common::tcp_native_sink().await;
    let _stalled = tokio::net::TcpStream::connect(addr).await.unwrap(); // never reads
    let mut reader = tokio::net::TcpStream::connect(addr).await.unwrap();
    // Wait until the server has registered both clients.
    for _ in 0..200 {
        if h.stats.clients.lock().unwrap().len() == 2 {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
    assert_eq!(h.stats.clients.lock().unwrap().len(), 2);

    // Enough data to fill the stalled client's socket buffers and its queue many times over
    // (300 batches × 512 frames × 56 B ≈ 8.6 MB); the reader drains concurrently.
    let batches = 300usize;
    let per = 512usize;
    let total = batches * per;
    // The reader publishes its progress, so the producer can stay within its queue by
    // construction (a timing-based pace is not deterministic on a loaded machine).
    let progress = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let prog = progress.clone();
    let read_task = tokio::spawn(async move {
        let mut dec = FrameDecoder::new();
        let mut buf = bytes::BytesMut::new();
        let mut seqs = Vec::with_capacity(total);
        while seqs.len() < total {
            let mut chunk = [0u8; 65536];
            let n = reader.read(&mut chunk).await.unwrap();
            assert!(n > 0, "server closed early after {} frames", seqs.len());
            buf.extend_from_slice(&chunk[..n]);
            while let Some(m) = dec.decode(&mut buf).unwrap() {
                if let Message::Sample(s) = m {
                    seqs.push(s.seq);
                }
            }
            prog.store(seqs.len(), std::sync::atomic::Ordering::Release);
        }
        // Keep the connection open: a client that leaves is folded into the sink's totals.
        (seqs, reader)
    });
    let all = common::samples(total, 3);
    for (i, b) in all.chunks(per).enumerate() {
        // Keep at most 4 batches in flight to the reader (its queue holds 8): the reader never
        // falls behind; the stalled client does, whatever the pace.
        while i >= 4 && progress.load(std::sync::atomic::Ordering::Acquire) < (i - 4) * per {
            tokio::time::sleep(std::time::Duration::from_micros(200)).await;
        }
        h.offer(SinkItem::Samples(Arc::new(b.to_vec()))).await;
    }
    let (seqs, _reader) =
        match tokio::time::timeout(std::time::Duration::from_secs(30), read_task).await {
            Ok(r) => r.unwrap(),
            Err(_) => panic!(
                "reader did not get every frame: {:?}",
                h.stats.report("tcp").clients
            ),
        };
    assert_eq!(
        seqs,
        (0..total as u32).collect::<Vec<_>>(),
        "reader got every frame, in order"
    );
    let clients = h.stats.report("tcp").clients;
    let stalled = &clients[0];
    let good = &clients[1];
    assert_eq!(good.samples_dropped, 0, "{clients:?}");
    assert!(
        stalled.samples_dropped > 0,
        "lag counter must rise: {clients:?}"
    );
    // "sent" counts what reached the stalled client's socket: what still waits in its queue is
    // neither sent nor dropped yet.
    assert!(
        stalled.samples_sent + stalled.samples_dropped <= total as u64,
        "{clients:?}"
    );
}
