//! The inline sink: cleaned samples back into their own carriers (the input's protocol), on a
//! serial device, a file or a pseudo-terminal; see the module docs of [`super`] for what a stuck
//! inline sink drops and how its writer is told.

use super::{SinkItem, SinkStats};
use crate::sample::Sample;
use bytes::{Bytes, BytesMut};
use std::sync::Arc;
use std::sync::atomic::Ordering::Relaxed;
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

/// Open the inline target: a path (serial device, pseudo-terminal or file; created if absent,
/// written at the device's current line settings), or a new pseudo-terminal whose path is
/// printed on stderr and logged.
pub(super) async fn start_inline(
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
