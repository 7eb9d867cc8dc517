//! Sources: a recorded log, standard input, a serial port, or (a build with `--features zenoh`)
//! payloads of a Zenoh key — all through the same [`FrameDecoder`]. Each runs as a tokio task
//! and sends [`SourceEvent`]s to the runtime.

use crate::frame::detect::{DETECT_BYTES, ProtocolConfig};
use crate::frame::{
    Carrier, Codec, Decoded, DecoderStats, Descriptor, FrameDecoder, LOG_HEADER_LEN, LOG_MAGIC,
    Protocol, ProtocolDecoder, check_log_header,
};
use crate::sample::Sample;
use bytes::Bytes;
use futures_util::StreamExt;
use std::path::{Path, PathBuf};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncSeekExt};
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
    /// The device stayed open but sent nothing for the stall time; it is being reopened.
    Stall {
        reason: String,
        stalls: u64,
    },
    /// The device is (back) up.
    Connected {
        name: String,
    },
    /// What inline sinks need, in input order, sent before the samples it belongs to: the
    /// protocol, each sample's carrier and the messages that are not IMU data.
    Side(Vec<SideItem>),
    /// What the decoder found (protocol, streams), sent before `End`.
    Found(String),
    /// No more data: end of file or stream.
    End(DecoderStats),
}

/// One entry of the side stream (see [`SourceEvent::Side`]).
#[derive(Debug, Clone)]
pub enum SideItem {
    /// The protocol of what follows (first item of a stream).
    Protocol(Protocol),
    /// The carrier of the next sample, in order.
    Sample(Option<Carrier>),
    /// A message that is not IMU data, to pass through unchanged.
    Other(Bytes),
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
/// (The one log reader is [`crate::io::log`]; this maps its errors to the source's.)
pub async fn open_log(path: &Path) -> Result<tokio::fs::File, SourceError> {
    use crate::io::log::LogError;
    crate::io::log::open_log(path).await.map_err(|e| match e {
        LogError::Io { path, err } => SourceError::Open { path, err },
        LogError::Header { path, err } => SourceError::Header { path, err },
    })
}

/// Pump one byte stream through the decoder to the runtime. Returns the decoder (so a serial
/// source can carry its sequence tracking across a reconnect), the error that ended the stream if
/// any, and whether the runtime is still listening. With `side`, each sample's carrier and the
/// pass-through messages are sent ahead of the samples (for inline sinks).
async fn pump<R: AsyncRead + Unpin>(
    reader: R,
    decoder: Codec,
    tx: &mpsc::Sender<SourceEvent>,
    pace: Option<f64>,
    side: bool,
) -> (Codec, Option<std::io::Error>, bool) {
    let mut framed = FramedRead::new(reader, decoder);
    let mut batch = Vec::with_capacity(BATCH);
    let mut extra: Vec<SideItem> = Vec::new();
    let mut pacer = pace.map(Pacer::new);
    let mut failure = None;
    if side {
        extra.push(SideItem::Protocol(framed.decoder().0.protocol()));
    }
    // Hand over what is held: the side items first, then the samples.
    macro_rules! send {
        () => {{
            let stats = framed.decoder().0.stats();
            let ok = (extra.is_empty()
                || tx
                    .send(SourceEvent::Side(std::mem::take(&mut extra)))
                    .await
                    .is_ok())
                && (batch.is_empty()
                    || tx
                        .send(SourceEvent::Samples(
                            std::mem::replace(&mut batch, Vec::with_capacity(BATCH)),
                            stats,
                        ))
                        .await
                        .is_ok());
            if !ok {
                return (framed.into_parts().codec, None, false);
            }
        }};
    }
    loop {
        // Pull what is ready, up to a batch, without waiting once we hold something.
        let item = if batch.is_empty() && extra.is_empty() {
            framed.next().await
        } else {
            match futures_util::FutureExt::now_or_never(framed.next()) {
                Some(i) => i,
                None => {
                    send!();
                    continue;
                }
            }
        };
        match item {
            Some(Ok(Decoded::Sample(s, carrier))) => {
                if let Some(wait) = pacer.as_mut().and_then(|p| p.wait_for(s.t_ns)) {
                    // Hand over what we hold before sleeping, so pacing is visible downstream.
                    send!();
                    tokio::time::sleep(wait).await;
                }
                if side {
                    extra.push(SideItem::Sample(carrier));
                }
                batch.push(s);
                if batch.len() == BATCH {
                    send!();
                }
            }
            Some(Ok(Decoded::Other(b))) => {
                if side {
                    extra.push(SideItem::Other(b));
                    if extra.len() >= BATCH * 2 {
                        send!();
                    }
                }
            }
            Some(Ok(Decoded::Descriptor(d))) => {
                send!();
                if tx.send(SourceEvent::Descriptor(d)).await.is_err() {
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
    let stats = framed.decoder().0.stats();
    let mut alive = extra.is_empty()
        || tx
            .send(SourceEvent::Side(std::mem::take(&mut extra)))
            .await
            .is_ok();
    alive =
        alive && (batch.is_empty() || tx.send(SourceEvent::Samples(batch, stats)).await.is_ok());
    let found = framed.decoder().0.found();
    if alive && !found.is_empty() {
        alive = tx.send(SourceEvent::Found(found)).await.is_ok();
    }
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
    replay_with(file, Box::new(FrameDecoder::new()), speed, false, tx).await
}

/// Open a recording in any protocol: the configured one, or detected from its first bytes when
/// `auto`. A native log's file header is checked and skipped; other files are read from the
/// start.
pub async fn open_replay(
    path: &Path,
    c: &ProtocolConfig,
) -> Result<(tokio::fs::File, Box<dyn ProtocolDecoder>), SourceError> {
    let open_err = |err| SourceError::Open {
        path: path.into(),
        err,
    };
    let mut f = tokio::fs::File::open(path).await.map_err(open_err)?;
    let mut head = vec![0u8; DETECT_BYTES];
    let mut n = 0;
    while n < head.len() {
        let k = f.read(&mut head[n..]).await.map_err(open_err)?;
        if k == 0 {
            break;
        }
        n += k;
    }
    head.truncate(n);
    let p = c.resolve(&head);
    if p == Protocol::Native {
        drop(f);
        return Ok((open_log(path).await?, c.decoder(p)));
    }
    f.seek(std::io::SeekFrom::Start(0))
        .await
        .map_err(open_err)?;
    Ok((f, c.decoder(p)))
}

/// Replay a recording through `decoder`; `side` sends carriers and pass-through messages for
/// inline sinks.
pub async fn replay_with(
    file: tokio::fs::File,
    decoder: Box<dyn ProtocolDecoder>,
    speed: f64,
    side: bool,
    tx: mpsc::Sender<SourceEvent>,
) {
    let pace = (speed > 0.0).then_some(speed);
    // A bar over the bytes still to replay, once the replay has taken a second.
    let mut file = file;
    let left = match (file.metadata().await, file.stream_position().await) {
        (Ok(m), Ok(at)) => m.len().saturating_sub(at),
        _ => 0,
    };
    let mut bar = crate::progress::Delayed::bytes(left, "replayed");
    let file = tokio_util::io::InspectReader::new(file, move |b: &[u8]| bar.inc(b.len() as u64));
    let (dec, err, alive) = pump(file, Codec(decoder), &tx, pace, side).await;
    if let Some(e) = err {
        tracing::error!("replay read failed: {e}");
    }
    if alive {
        let _ = tx.send(SourceEvent::End(dec.0.stats())).await;
    }
}

/// Frames on standard input; a log file header at the start is recognised and skipped.
pub async fn stdin(tx: mpsc::Sender<SourceEvent>) {
    stdin_with(ProtocolConfig::default(), false, tx).await
}

/// Standard input in the configured protocol (detected from the first bytes when `auto`).
pub async fn stdin_with(c: ProtocolConfig, side: bool, tx: mpsc::Sender<SourceEvent>) {
    let mut input = tokio::io::stdin();
    let want = if c.protocol == crate::frame::detect::ProtocolChoice::Auto {
        DETECT_BYTES
    } else {
        LOG_HEADER_LEN
    };
    let mut head = Vec::with_capacity(want);
    let mut buf = vec![0u8; want];
    while head.len() < want {
        match input.read(&mut buf[..want - head.len()]).await {
            Ok(0) | Err(_) => break,
            Ok(k) => head.extend_from_slice(&buf[..k]),
        }
    }
    let protocol = c.resolve(&head);
    let prefix =
        if protocol == Protocol::Native && head.len() >= LOG_HEADER_LEN && head[..8] == LOG_MAGIC {
            if let Err(e) = check_log_header(&head) {
                tracing::error!("stdin: {e}");
                let _ = tx.send(SourceEvent::End(DecoderStats::default())).await;
                return;
            }
            head[LOG_HEADER_LEN..].to_vec()
        } else {
            head
        };
    let reader = std::io::Cursor::new(prefix).chain(input);
    let (dec, err, alive) = pump(reader, Codec(c.decoder(protocol)), &tx, None, side).await;
    if let Some(e) = err {
        tracing::error!("stdin read failed: {e}");
    }
    if alive {
        let _ = tx.send(SourceEvent::End(dec.0.stats())).await;
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
    serial_with(
        port,
        baud,
        retry_initial,
        retry_max,
        ProtocolConfig::default(),
        false,
        tx,
    )
    .await
}

/// A serial port in the configured protocol (`auto` detects it from the first bytes after the
/// first open, up to [`DETECT_BYTES`] or 2 s).
pub async fn serial_with(
    port: String,
    baud: u32,
    retry_initial: Duration,
    retry_max: Duration,
    c: ProtocolConfig,
    side: bool,
    tx: mpsc::Sender<SourceEvent>,
) {
    serial_watched(port, baud, retry_initial, retry_max, None, c, side, tx).await
}

/// A reader that fails with [`std::io::ErrorKind::TimedOut`] when no byte has come for `stall`.
struct StallGuard<R> {
    inner: R,
    stall: Duration,
    timer: std::pin::Pin<Box<tokio::time::Sleep>>,
}

impl<R> StallGuard<R> {
    fn new(inner: R, stall: Duration) -> Self {
        StallGuard {
            inner,
            stall,
            timer: Box::pin(tokio::time::sleep(stall)),
        }
    }
}

impl<R: AsyncRead + Unpin> AsyncRead for StallGuard<R> {
    fn poll_read(
        mut self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &mut tokio::io::ReadBuf<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        use std::future::Future;
        use std::task::Poll;
        let before = buf.filled().len();
        match std::pin::Pin::new(&mut self.inner).poll_read(cx, buf) {
            Poll::Ready(r) => {
                if buf.filled().len() > before {
                    let next = tokio::time::Instant::now() + self.stall;
                    self.timer.as_mut().reset(next);
                }
                Poll::Ready(r)
            }
            Poll::Pending => match self.timer.as_mut().poll(cx) {
                Poll::Ready(()) => Poll::Ready(Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    format!("no byte for {:.1} s", self.stall.as_secs_f64()),
                ))),
                Poll::Pending => Poll::Pending,
            },
        }
    }
}

/// [`serial_with`] with a stall watch: a port that stays open but sends nothing for `stall` is
/// reported ([`SourceEvent::Stall`], counted) and reopened, keeping the decoder so the gap is
/// flagged.
#[allow(clippy::too_many_arguments)]
pub async fn serial_watched(
    port: String,
    baud: u32,
    retry_initial: Duration,
    retry_max: Duration,
    stall: Option<Duration>,
    c: ProtocolConfig,
    side: bool,
    tx: mpsc::Sender<SourceEvent>,
) {
    let mut stalls = 0u64;
    use tokio_serial::SerialPortBuilderExt;
    let mut decoder: Option<Codec> = None;
    let mut outages = 0u64;
    let mut delay = retry_initial;
    loop {
        match tokio_serial::new(&port, baud).open_native_async() {
            Ok(mut stream) => {
                tracing::info!(port = %port, baud, "serial port open");
                if tx
                    .send(SourceEvent::Connected { name: port.clone() })
                    .await
                    .is_err()
                {
                    return;
                }
                delay = retry_initial;
                let mut head = Vec::new();
                let codec = match decoder.take() {
                    Some(d) => d,
                    None => {
                        if c.protocol == crate::frame::detect::ProtocolChoice::Auto {
                            let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
                            let mut b = vec![0u8; DETECT_BYTES];
                            while head.len() < DETECT_BYTES {
                                match tokio::time::timeout_at(deadline, stream.read(&mut b)).await {
                                    Ok(Ok(k)) if k > 0 => head.extend_from_slice(&b[..k]),
                                    _ => break,
                                }
                            }
                        }
                        Codec(c.decoder(c.resolve(&head)))
                    }
                };
                let reader = std::io::Cursor::new(head).chain(stream);
                let (dec, err, alive) = match stall {
                    Some(d) => pump(StallGuard::new(reader, d), codec, &tx, None, side).await,
                    None => pump(reader, codec, &tx, None, side).await,
                };
                decoder = Some(dec);
                if !alive {
                    return;
                }
                let stalled = matches!(&err, Some(e) if e.kind() == std::io::ErrorKind::TimedOut);
                let event = match err {
                    Some(e) if stalled => {
                        stalls += 1;
                        // Said once, by the runtime ("source stall #N: …"), as every event.
                        let reason = format!("serial {port}: open but silent ({e}); reopening");
                        SourceEvent::Stall { reason, stalls }
                    }
                    _ => {
                        outages += 1;
                        let why = match err {
                            Some(e) => format!("read failed: {e}"),
                            None => "port closed".to_string(),
                        };
                        let reason = format!("serial {port} lost ({why}); retrying");
                        SourceEvent::Outage { reason, outages }
                    }
                };
                if tx.send(event).await.is_err() {
                    return;
                }
                if stalled {
                    // A silent port is reopened after the current delay, which does not grow.
                    tokio::time::sleep(delay).await;
                    continue;
                }
            }
            Err(e) => {
                tracing::debug!(port = %port, "cannot open serial port: {e}");
                if outages == 0 {
                    // First failure at start-up is an outage too: the daemon keeps trying.
                    outages += 1;
                    if tx
                        .send(SourceEvent::Outage {
                            reason: format!("cannot open serial port {port} ({e}); retrying"),
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

/// The payloads of a Zenoh subscription as one byte stream, through the same decoder as every
/// other source (so CRC errors, gaps and duplicates are counted as everywhere). A key silent for
/// `stall` is reported ([`SourceEvent::Stall`], counted) and still listened to, keeping the
/// decoder so the gap is flagged. Ends when the subscription closes (the session closed).
#[cfg(feature = "zenoh")]
pub async fn zenoh_with(
    sub: zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    stall: Option<Duration>,
    c: ProtocolConfig,
    side: bool,
    tx: mpsc::Sender<SourceEvent>,
) {
    let key = sub.key_expr().to_string();
    let name = format!("zenoh:{key}");
    if tx
        .send(SourceEvent::Connected { name: name.clone() })
        .await
        .is_err()
    {
        return;
    }
    let mut decoder = Codec(c.decoder(c.resolve(&[])));
    let mut stalls = 0u64;
    loop {
        // One payload after another: a payload holds whole frames (one, usually), but the
        // decoder does not rely on it.
        let payloads = futures_util::stream::unfold(&sub, |s| async move {
            let sample = s.recv_async().await.ok()?;
            let b = Bytes::from(sample.payload().to_bytes().into_owned());
            Some((Ok::<Bytes, std::io::Error>(b), s))
        });
        let reader = tokio_util::io::StreamReader::new(Box::pin(payloads));
        let (dec, err, alive) = match stall {
            Some(d) => pump(StallGuard::new(reader, d), decoder, &tx, None, side).await,
            None => pump(reader, decoder, &tx, None, side).await,
        };
        decoder = dec;
        if !alive {
            return;
        }
        match err {
            Some(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                stalls += 1;
                // Said once, by the runtime ("source stall #N: …"), as every event.
                let reason = format!(
                    "zenoh source silent: {name}: nothing published ({e}); still listening"
                );
                if tx
                    .send(SourceEvent::Stall { reason, stalls })
                    .await
                    .is_err()
                {
                    return;
                }
            }
            Some(e) => {
                tracing::error!("{name}: {e}");
                break;
            }
            None => break,
        }
    }
    let _ = tx.send(SourceEvent::End(decoder.0.stats())).await;
}
