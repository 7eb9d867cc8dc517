//! Sources: a recorded log, standard input, or a serial port — all through the same
//! [`FrameDecoder`]. Each runs as a tokio task and sends [`SourceEvent`]s to the runtime.

use crate::frame::{
    DecoderStats, Descriptor, FrameDecoder, LOG_HEADER_LEN, LOG_MAGIC, Message, check_log_header,
};
use crate::sample::Sample;
use futures_util::StreamExt;
use std::path::{Path, PathBuf};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt};
use tokio::sync::mpsc;
use tokio_util::codec::FramedRead;

/// Decoded items are handed over in batches of at most this many (fewer when the input pauses).
pub const BATCH: usize = 512;

/// What a source tells the runtime.
#[derive(Debug)]
pub enum SourceEvent {
    Descriptor(Descriptor),
    /// Samples in arrival order, with the decoder's counters after them.
    Samples(Vec<Sample>, DecoderStats),
    /// The source lost its device (e.g. the serial port vanished) and is retrying.
    Outage {
        reason: String,
        outages: u64,
    },
    /// The device is (back) up.
    Connected {
        name: String,
    },
    /// No more data: end of file or stream.
    End(DecoderStats),
}

/// Why a source could not start.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    #[error("cannot open {path}: {err}")]
    Open { path: PathBuf, err: std::io::Error },
    #[error("{path}: {err}")]
    Header {
        path: PathBuf,
        err: crate::frame::LogHeaderError,
    },
}

/// Open a recorded log and check its file header; the returned reader starts at the first frame.
pub async fn open_log(path: &Path) -> Result<tokio::fs::File, SourceError> {
    let mut f = tokio::fs::File::open(path)
        .await
        .map_err(|err| SourceError::Open {
            path: path.into(),
            err,
        })?;
    let mut h = [0u8; LOG_HEADER_LEN];
    let mut n = 0;
    while n < LOG_HEADER_LEN {
        let k = f.read(&mut h[n..]).await.map_err(|err| SourceError::Open {
            path: path.into(),
            err,
        })?;
        if k == 0 {
            break;
        }
        n += k;
    }
    check_log_header(&h[..n]).map_err(|err| SourceError::Header {
        path: path.into(),
        err,
    })?;
    Ok(f)
}

/// Pump one byte stream through the decoder to the runtime. Returns the decoder (so a serial
/// source can carry its sequence tracking across a reconnect), the error that ended the stream if
/// any, and whether the runtime is still listening.
async fn pump<R: AsyncRead + Unpin>(
    reader: R,
    decoder: FrameDecoder,
    tx: &mpsc::Sender<SourceEvent>,
    pace: Option<f64>,
) -> (FrameDecoder, Option<std::io::Error>, bool) {
    let mut framed = FramedRead::new(reader, decoder);
    let mut batch = Vec::with_capacity(BATCH);
    let mut pacer = pace.map(Pacer::new);
    let mut failure = None;
    loop {
        // Pull what is ready, up to a batch, without waiting once we hold something.
        let item = if batch.is_empty() {
            framed.next().await
        } else {
            match futures_util::FutureExt::now_or_never(framed.next()) {
                Some(i) => i,
                None => {
                    let stats = framed.decoder().stats();
                    let b = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                    if tx.send(SourceEvent::Samples(b, stats)).await.is_err() {
                        return (framed.into_parts().codec, None, false);
                    }
                    continue;
                }
            }
        };
        match item {
            Some(Ok(Message::Sample(s))) => {
                if let Some(wait) = pacer.as_mut().and_then(|p| p.wait_for(s.t_ns)) {
                    {
                        // Hand over what we hold before sleeping, so pacing is visible downstream.
                        if !batch.is_empty() {
                            let stats = framed.decoder().stats();
                            let b = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                            if tx.send(SourceEvent::Samples(b, stats)).await.is_err() {
                                return (framed.into_parts().codec, None, false);
                            }
                        }
                        tokio::time::sleep(wait).await;
                    }
                }
                batch.push(s);
                if batch.len() == BATCH {
                    let stats = framed.decoder().stats();
                    let b = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                    if tx.send(SourceEvent::Samples(b, stats)).await.is_err() {
                        return (framed.into_parts().codec, None, false);
                    }
                }
            }
            Some(Ok(Message::Descriptor(d))) => {
                let stats = framed.decoder().stats();
                let b = std::mem::take(&mut batch);
                if (!b.is_empty() && tx.send(SourceEvent::Samples(b, stats)).await.is_err())
                    || tx.send(SourceEvent::Descriptor(d)).await.is_err()
                {
                    return (framed.into_parts().codec, None, false);
                }
            }
            Some(Err(e)) => {
                failure = Some(e);
                break;
            }
            None => break,
        }
    }
    let stats = framed.decoder().stats();
    let alive = batch.is_empty() || tx.send(SourceEvent::Samples(batch, stats)).await.is_ok();
    (framed.into_parts().codec, failure, alive)
}

/// Paces replay by sensor time: sample k is released at (t_k − t_0) / speed after the first.
struct Pacer {
    speed: f64,
    start: Option<(u64, tokio::time::Instant)>,
}

impl Pacer {
    fn new(speed: f64) -> Self {
        Pacer { speed, start: None }
    }
    fn wait_for(&mut self, t_ns: u64) -> Option<Duration> {
        let (t0, i0) = *self
            .start
            .get_or_insert((t_ns, tokio::time::Instant::now()));
        let due = i0 + Duration::from_secs_f64(t_ns.saturating_sub(t0) as f64 * 1e-9 / self.speed);
        due.checked_duration_since(tokio::time::Instant::now())
            .filter(|d| *d > Duration::from_micros(200))
    }
}

/// Replay a recorded log (already opened by [`open_log`]). `speed` 0 = as fast as possible.
pub async fn replay(file: tokio::fs::File, speed: f64, tx: mpsc::Sender<SourceEvent>) {
    let pace = (speed > 0.0).then_some(speed);
    let (dec, err, alive) = pump(file, FrameDecoder::new(), &tx, pace).await;
    if let Some(e) = err {
        tracing::error!("replay read failed: {e}");
    }
    if alive {
        let _ = tx.send(SourceEvent::End(dec.stats())).await;
    }
}

/// Frames on standard input; a log file header at the start is recognised and skipped.
pub async fn stdin(tx: mpsc::Sender<SourceEvent>) {
    let mut input = tokio::io::stdin();
    let mut head = Vec::with_capacity(LOG_HEADER_LEN);
    let mut buf = [0u8; LOG_HEADER_LEN];
    while head.len() < LOG_HEADER_LEN {
        match input.read(&mut buf[..LOG_HEADER_LEN - head.len()]).await {
            Ok(0) | Err(_) => break,
            Ok(k) => head.extend_from_slice(&buf[..k]),
        }
    }
    let prefix = if head.len() == LOG_HEADER_LEN && head[..8] == LOG_MAGIC {
        if let Err(e) = check_log_header(&head) {
            tracing::error!("stdin: {e}");
            let _ = tx.send(SourceEvent::End(DecoderStats::default())).await;
            return;
        }
        Vec::new()
    } else {
        head
    };
    let reader = std::io::Cursor::new(prefix).chain(input);
    let (dec, err, alive) = pump(reader, FrameDecoder::new(), &tx, None).await;
    if let Some(e) = err {
        tracing::error!("stdin read failed: {e}");
    }
    if alive {
        let _ = tx.send(SourceEvent::End(dec.stats())).await;
    }
}

/// A serial port that may vanish: on open failure, read error or EOF, it reports an outage and
/// retries with exponential back-off, forever, keeping one decoder so the gap is flagged.
pub async fn serial(
    port: String,
    baud: u32,
    retry_initial: Duration,
    retry_max: Duration,
    tx: mpsc::Sender<SourceEvent>,
) {
    use tokio_serial::SerialPortBuilderExt;
    let mut decoder = FrameDecoder::new();
    let mut outages = 0u64;
    let mut delay = retry_initial;
    loop {
        match tokio_serial::new(&port, baud).open_native_async() {
            Ok(stream) => {
                tracing::info!(port = %port, baud, "serial port open");
                if tx
                    .send(SourceEvent::Connected { name: port.clone() })
                    .await
                    .is_err()
                {
                    return;
                }
                delay = retry_initial;
                let (dec, err, alive) = pump(stream, decoder, &tx, None).await;
                decoder = dec;
                if !alive {
                    return;
                }
                outages += 1;
                let reason = match err {
                    Some(e) => format!("read failed: {e}"),
                    None => "port closed".to_string(),
                };
                tracing::warn!(port = %port, outages, "serial port lost ({reason}); retrying");
                if tx
                    .send(SourceEvent::Outage { reason, outages })
                    .await
                    .is_err()
                {
                    return;
                }
            }
            Err(e) => {
                tracing::debug!(port = %port, "cannot open serial port: {e}");
                if outages == 0 {
                    // First failure at start-up is an outage too: the daemon keeps trying.
                    outages += 1;
                    tracing::warn!(port = %port, "cannot open serial port ({e}); retrying");
                    if tx
                        .send(SourceEvent::Outage {
                            reason: e.to_string(),
                            outages,
                        })
                        .await
                        .is_err()
                    {
                        return;
                    }
                }
            }
        }
        tokio::time::sleep(delay).await;
        delay = (delay * 2).min(retry_max);
    }
}
