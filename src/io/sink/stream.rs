//! stdout and file sinks.

use super::{SinkItem, SinkStats};
use crate::config::Format;
use crate::frame::Descriptor;
use crate::io::format::Encoder;
use bytes::BytesMut;
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;

/// stdout and files: preamble at the first item, then every batch, flushed per batch.
pub(super) async fn write_stream<W: tokio::io::AsyncWrite + Unpin>(
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
