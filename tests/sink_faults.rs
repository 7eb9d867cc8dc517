//! Sinks under faults (issue 13, items 2 and 9, and health as data): a stuck local consumer
//! never freezes the stream, TCP clients that leave are freed, "sent" means written, and health
//! reports travel beside the samples on every sink whose format carries them.
#![cfg(unix)]
mod common;

use imuprep::config::{Config, Format, Sink, SourceConfig};
use imuprep::frame::{FrameDecoder, Message};
use imuprep::io::sink::{self, SinkItem};
use imuprep::stage::Pipeline;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;
use tokio_util::codec::Decoder;

/// A FIFO whose read end is open (so a writer can open it) but never read: the writer blocks
/// once the pipe's buffer (64 KiB on Linux) is full — a consumer that is stuck for good.
fn stuck_fifo(path: &Path) -> std::fs::File {
    let c = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "mkfifo");
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .unwrap()
}

/// The embedded default config replaying `n` samples (`common::samples(n, seed)`, written to
/// `dir/in.log`) at `speed`× into `sinks`, health published every 0.1 s.
fn replay_config(dir: &Path, n: usize, seed: u64, speed: f64, sinks: Vec<Sink>) -> Config {
    let log = dir.join("in.log");
    imuprep::io::log::write_log(&log, &common::descriptor(), &common::samples(n, seed)).unwrap();
    let mut cfg = Config::default_embedded().unwrap();
    cfg.source = SourceConfig::Replay { path: log, speed };
    cfg.sinks = sinks;
    cfg.health.interval_s = 0.1;
    cfg
}

/// The daemon's loop over `cfg` with no cleaning stage; panics with `froze` if it has not ended
/// within `secs` seconds.
async fn run_within(cfg: &Config, secs: u64, froze: &str) -> imuprep::runtime::Health {
    tokio::time::timeout(
        Duration::from_secs(secs),
        imuprep::runtime::run(cfg, Pipeline::pass_through()),
    )
    .await
    .expect(froze)
    .unwrap()
}

/// A JSON-lines output: how many sample records, and the health records in order.
fn jsonl_samples_and_health(path: &Path) -> (usize, Vec<serde_json::Value>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut samples = 0;
    let mut reports = Vec::new();
    for line in text.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        if v.get("type").and_then(|t| t.as_str()) == Some("health") {
            reports.push(v);
        } else {
            samples += 1;
        }
    }
    (samples, reports)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stuck_file_sink_drops_counted_and_never_blocks_the_stream() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("stuck.csv");
    let reader = stuck_fifo(&fifo);
    let mut h = sink::start(&Sink::File {
        path: fifo.clone(),
        format: Format::Csv,
    })
    .await
    .unwrap();
    h.stall = Duration::from_millis(100);
    // 300 batches × 100 samples of CSV (~30 MB of text... far beyond the 64 KiB pipe and the
    // sink's 64-batch queue): on a blocking fan-out this never finishes.
    let all = common::samples(30_000, 5);
    let offered = tokio::time::timeout(Duration::from_secs(20), async {
        for b in all.chunks(100) {
            h.offer(SinkItem::Samples(Arc::new(b.to_vec()))).await;
        }
    })
    .await;
    assert!(
        offered.is_ok(),
        "offering to a stuck file sink blocked the stream"
    );
    assert!(h.is_stuck(), "the sink must know it is stuck");
    let r = h.stats.report(&h.name);
    assert!(r.dropped > 0, "drops must be counted: {r:?}");
    assert!(r.samples_out + r.dropped <= all.len() as u64, "{r:?}");
    // Unblock the sink's pending write so the runtime can shut down.
    drop(reader);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcp_clients_that_leave_are_freed_and_folded_into_totals() {
    let (h, addr) = common::tcp_native_sink().await;
    let batch = Arc::new(common::samples(10, 1));
    for _ in 0..50 {
        let c = tokio::net::TcpStream::connect(addr).await.unwrap();
        h.offer(SinkItem::Samples(batch.clone())).await;
        drop(c);
    }
    // Each leaving client is noticed by its writer task (EOF on its socket) and folded in.
    let mut r = h.stats.report(&h.name);
    for _ in 0..1000 {
        r = h.stats.report(&h.name);
        if r.clients_gone.clients == 50 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(
        r.clients.is_empty(),
        "per-client entries must be freed: {r:?}"
    );
    assert_eq!(r.clients_gone.clients, 50, "{r:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcp_sent_counts_what_was_written_not_what_was_queued() {
    let (h, addr) = common::tcp_native_sink().await;
    let stalled = tokio::net::TcpStream::connect(addr).await.unwrap(); // reads nothing yet
    for _ in 0..200 {
        if h.stats.report(&h.name).clients.len() == 1 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // 1000 batches × 512 frames × 56 B ≈ 29 MB, offered slowly enough for the sink's own
    // queue: far more than loopback socket buffers hold (a few MB with autotuning), so the
    // writer blocks and the client's queue fills and stays full.
    let per = 512;
    let total = 1000 * per;
    let all = common::samples(total, 2);
    for (i, b) in all.chunks(per).enumerate() {
        h.offer(SinkItem::Samples(Arc::new(b.to_vec()))).await;
        if i % 4 == 0 {
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
    }
    // Wait until the counters settle (the writer is blocked on the full socket).
    let mut last = (u64::MAX, u64::MAX);
    for _ in 0..100 {
        tokio::time::sleep(Duration::from_millis(50)).await;
        let c = h.stats.report(&h.name).clients[0].clone();
        let now = (c.samples_sent, c.samples_dropped);
        if now == last {
            break;
        }
        last = now;
    }
    let r = h.stats.report(&h.name);
    // Batches the sink's own queue could not take never reached the client's queue.
    let total = total as u64 - r.dropped;
    let c = r.clients[0].clone();
    let r = r.clone();
    assert!(c.samples_dropped > 0, "{c:?}");
    // What still waits in the client's queue is neither sent nor dropped.
    assert!(
        c.samples_sent + c.samples_dropped < total,
        "queued samples were counted as sent: {c:?} total {total} {r:?}"
    );
    // Now read everything: the client receives exactly what "sent" counts.
    let mut stalled = stalled;
    let mut dec = FrameDecoder::new();
    let mut buf = bytes::BytesMut::new();
    let mut got = 0u64;
    let want_done = |g: u64, h: &sink::SinkHandle| {
        let c = h.stats.report(&h.name).clients[0].clone();
        c.samples_sent + c.samples_dropped == total && g == c.samples_sent
    };
    let done = tokio::time::timeout(Duration::from_secs(20), async {
        use tokio::io::AsyncReadExt;
        let mut chunk = vec![0u8; 1 << 16];
        while !want_done(got, &h) {
            let n = match tokio::time::timeout(Duration::from_millis(200), stalled.read(&mut chunk))
                .await
            {
                Ok(r) => r.unwrap(),
                Err(_) => continue,
            };
            buf.extend_from_slice(&chunk[..n]);
            while let Some(m) = dec.decode(&mut buf).unwrap() {
                if let Message::Sample(_) = m {
                    got += 1;
                }
            }
        }
    })
    .await;
    let c = h.stats.report(&h.name).clients[0].clone();
    assert!(done.is_ok(), "received {got}, counters {c:?}");
    assert_eq!(got, c.samples_sent);
}

/// The daemon's loop with a stuck consumer beside a healthy one: the run ends, the healthy sink
/// gets every sample and the health reports, the stuck one's drops are counted.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stuck_consumer_never_freezes_the_run_and_health_travels_with_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let n = 4000; // 20 s at 200 Hz, replayed at 20× ≈ 1 s
    let fifo = dir.path().join("stuck.csv");
    let reader = stuck_fifo(&fifo);
    let jsonl = dir.path().join("out.jsonl");
    let native = dir.path().join("out.log");
    let cfg = replay_config(
        dir.path(),
        n,
        9,
        20.0,
        vec![
            Sink::File {
                path: fifo,
                format: Format::Csv,
            },
            Sink::File {
                path: jsonl.clone(),
                format: Format::Jsonl,
            },
            Sink::File {
                path: native.clone(),
                format: Format::Native,
            },
        ],
    );
    let health = run_within(&cfg, 30, "a stuck sink froze the run").await;
    drop(reader);
    assert_eq!(health.samples_out, n as u64);
    assert!(health.sinks[0].dropped > 0, "{:?}", health.sinks[0]);
    // Every sample published to the stuck sink is accounted for: written, or dropped — what
    // its queue still held when the run ended (it was still stuck) included.
    let stuck = &health.sinks[0];
    assert_eq!(stuck.samples_out + stuck.dropped, n as u64, "{stuck:?}");
    assert_eq!(health.sinks[1].dropped, 0, "{:?}", health.sinks[1]);

    // JSON lines: every sample, and health records beside them. The run lasts ≥ 1 s of wall
    // time (paced replay) with a 0.1-s interval; ≥ 3 reports leaves room for a loaded machine.
    let (samples, reports) = jsonl_samples_and_health(&jsonl);
    assert_eq!(samples, n);
    assert!(reports.len() >= 3, "{} health records", reports.len());
    let last = reports.last().unwrap();
    assert_eq!(last["samples_out"], n as u64);
    assert!(
        reports.iter().any(|r| r["sink_dropped"].as_u64() > Some(0)),
        "the stuck sink's drops must show in the published health"
    );

    // Native log: health frames among the sample frames; the log reader still reads every
    // sample and skips the reports.
    let bytes = std::fs::read(&native).unwrap();
    let mut dec = FrameDecoder::new();
    let mut buf = bytes::BytesMut::from(&bytes[imuprep::frame::LOG_HEADER_LEN..]);
    let mut frames = Vec::new();
    while let Some(m) = dec.decode_eof(&mut buf).unwrap() {
        if let Message::Health(h) = m {
            frames.push(h);
        }
    }
    assert!(frames.len() >= 3);
    assert_eq!(frames.last().unwrap().samples_out, n as u64);
    let (_, s, st) = imuprep::io::log::read_log(&native).unwrap();
    assert_eq!(s.len(), n);
    assert_eq!(st.health_frames as usize, frames.len());
    assert_eq!(st.unknown_type + st.crc_errors + st.bad_payload, 0);
}

/// A pseudo-terminal nobody reads (inline sink, `--out pty:`) beside a healthy sink: the run
/// ends, the healthy sink gets every sample, and the pty's drops show in the health published
/// while the run goes on, not only at the end.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stuck_pty_inline_sink_never_freezes_the_run_and_its_drops_show_as_they_happen() {
    let dir = tempfile::tempdir().unwrap();
    // 40 000 native frames (2.2 MB, far beyond a pty's buffer) at 200 Hz = 200 s, replayed at
    // 100× ≈ 2 s of wall time.
    let n = 40_000;
    let jsonl = dir.path().join("out.jsonl");
    let cfg = replay_config(
        dir.path(),
        n,
        13,
        100.0,
        vec![
            Sink::Inline { path: None },
            Sink::File {
                path: jsonl.clone(),
                format: Format::Jsonl,
            },
        ],
    );
    let health = run_within(&cfg, 60, "a pty nobody reads froze the run").await;
    assert_eq!(health.samples_out, n as u64);
    let pty = &health.sinks[0];
    assert!(pty.name.starts_with("pty:"), "{pty:?}");
    assert!(pty.dropped > 0, "{pty:?}");
    // Written or dropped, nothing in between (what the queue held at the end is dropped).
    assert_eq!(pty.samples_out + pty.dropped, n as u64, "{pty:?}");
    assert_eq!(health.sinks[1].dropped, 0, "{:?}", health.sinks[1]);
    let (samples, reports) = jsonl_samples_and_health(&jsonl);
    assert_eq!(samples, n);
    // Drops in a report published before the end (the last one is the closing report).
    assert!(
        reports[..reports.len() - 1]
            .iter()
            .any(|r| r["sink_dropped"].as_u64() > Some(0)),
        "the pty's drops must show in the health published during the run ({} reports)",
        reports.len()
    );
}

/// `imuprep replay LOG --out stdout:csv | head -c 100`: the consumer closes its end early. The
/// summary must still account for every sample — written or dropped — and say so (before, the
/// queue's contents at the close were in neither count: 145 out + 0 dropped of 29 982).
#[test]
fn stdout_closed_by_its_consumer_counts_every_unwritten_sample_as_dropped() {
    use std::io::Read;
    let n = 20_000;
    let ((), err, status, h) = replay_to_consumer(n, 21, |_, mut out, _| {
        let mut first = [0u8; 100];
        out.read_exact(&mut first).unwrap();
        drop(out); // like `head -c 100`: the pipe's read end closes
    });
    assert!(status.success(), "{err}");
    assert_eq!(h["samples_out"], n as u64);
    let s = &h["sinks"][0];
    let (written, dropped) = (
        s["samples_out"].as_u64().unwrap(),
        s["dropped"].as_u64().unwrap(),
    );
    assert_eq!(written + dropped, n as u64, "{s}");
    assert!(
        dropped > 0,
        "a closed stdout cannot have taken all {n}: {s}"
    );
    assert!(
        err.contains("counted as dropped"),
        "the loss is said: {err}"
    );
}

/// `imuprep replay LOG --out stdout:csv` (a recorded file at speed 0) into `consumer`, which
/// gets the child's stdout and its stderr as it arrives; returns (what `consumer` returned,
/// stderr, exit status, summary).
fn replay_to_consumer<T>(
    n: usize,
    seed: u64,
    consumer: impl FnOnce(&mut std::process::Child, std::process::ChildStdout, &Stderr) -> T,
) -> (T, String, std::process::ExitStatus, serde_json::Value) {
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("in.log");
    imuprep::io::log::write_log(&log, &common::descriptor(), &common::samples(n, seed)).unwrap();
    let summary = dir.path().join("summary.json");
    let mut child = Command::new(common::bin())
        .arg("replay")
        .arg(&log)
        .args(["--out", "stdout:csv", "--summary-json"])
        .arg(&summary)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = child.stdout.take().unwrap();
    let stderr = Stderr::collect(child.stderr.take().unwrap());
    let got = consumer(&mut child, out, &stderr);
    let status = child.wait().unwrap();
    let err = stderr.finish();
    assert!(!err.contains("panicked"), "{err}");
    let h: serde_json::Value = common::read_json(&summary);
    (got, err, status, h)
}

/// A child's stderr, read on a thread as it arrives, so a test can wait for what the child
/// says instead of sleeping for a time a loaded machine may not keep.
struct Stderr {
    text: std::sync::Arc<std::sync::Mutex<String>>,
    reader: std::thread::JoinHandle<()>,
}

impl Stderr {
    fn collect(mut from: std::process::ChildStderr) -> Self {
        use std::io::Read;
        let text = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        let sink = text.clone();
        let reader = std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(k) = from.read(&mut buf) {
                if k == 0 {
                    break;
                }
                sink.lock()
                    .unwrap()
                    .push_str(&String::from_utf8_lossy(&buf[..k]));
            }
        });
        Self { text, reader }
    }

    /// Wait until stderr contains `what`; panics after `limit` (a hung child, not a slow one:
    /// the limit is far beyond any run's time).
    fn wait_for(&self, what: &str, limit: Duration) {
        let t0 = std::time::Instant::now();
        while !self.text.lock().unwrap().contains(what) {
            assert!(
                t0.elapsed() < limit,
                "{what:?} not said within {limit:?}: {}",
                self.text.lock().unwrap()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Everything the child wrote, once it has closed stderr.
    fn finish(self) -> String {
        self.reader.join().unwrap();
        std::sync::Arc::try_unwrap(self.text)
            .unwrap()
            .into_inner()
            .unwrap()
    }
}

/// `imuprep replay LOG --out stdout:csv | (sleep 1.5; cat)`: an offline replay at speed 0 waits
/// for its slow consumer (back-pressure) instead of counting it stuck after 0.5 s and dropping
/// (before: 11 680 of 29 982 samples of replay/drive.log reached a consumer that slept 0.6 s,
/// exit 0). Every sample arrives, the summary says 0 dropped, and the wait is said on stderr.
#[test]
fn offline_replay_at_speed_0_waits_for_a_slow_stdout_consumer_and_drops_nothing() {
    use std::io::Read;
    // 30 000 samples of CSV (~2.6 MB): far beyond a pipe's 64 KiB and the sink's 64-batch
    // queue, so the replay has to wait for the consumer. The consumer reads nothing until the
    // replay says it is waiting (once a wait passes the 0.5-s stall time), however slowly a
    // loaded machine runs it; 60 s is a hung replay, not a slow one.
    let n = 30_000;
    let (text, err, status, h) = replay_to_consumer(n, 33, |_, mut out, stderr| {
        stderr.wait_for("waiting for sink stdout", Duration::from_secs(60));
        let mut text = String::new();
        out.read_to_string(&mut text).unwrap();
        text
    });
    assert!(status.success(), "{err}");
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("t,"), "CSV header: {}", lines[0]);
    assert_eq!(lines.len() - 1, n, "every sample arrives");
    assert_eq!(h["samples_out"], n as u64);
    let s = &h["sinks"][0];
    assert_eq!(s["samples_out"], n as u64, "{s}");
    assert_eq!(s["dropped"], 0, "{s}");
    assert!(
        err.contains("waiting for sink stdout") && err.contains("the replay waits"),
        "the wait is said: {err}"
    );
    assert!(!err.contains("sink stuck"), "no stall rule offline: {err}");
}

/// An offline replay waiting for a consumer that never reads still stops on SIGINT, and its
/// summary accounts for every published sample (written or dropped).
#[test]
fn offline_replay_waiting_for_its_consumer_stops_on_sigint() {
    let n = 30_000;
    let (_, err, status, h) = replay_to_consumer(n, 34, |child, out, stderr| {
        // Hold the read end open, read nothing: the replay waits. SIGINT once it says so.
        stderr.wait_for("waiting for sink stdout", Duration::from_secs(60));
        assert_eq!(
            unsafe { libc::kill(child.id() as i32, libc::SIGINT) },
            0,
            "kill"
        );
        // The run must end on its own now; the read end stays open until it has.
        let t0 = std::time::Instant::now();
        while child.try_wait().unwrap().is_none() {
            assert!(
                t0.elapsed() < Duration::from_secs(20),
                "SIGINT did not stop a replay waiting for its sink"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        drop(out);
    });
    assert!(status.success(), "{err}");
    assert!(err.contains("waiting for sink stdout"), "{err}");
    assert_eq!(h["ended_by"], "signal SIGINT", "{h}");
    let published = h["samples_out"].as_u64().unwrap();
    assert!(published < n as u64, "it stopped before the end: {h}");
    let s = &h["sinks"][0];
    let (written, dropped) = (
        s["samples_out"].as_u64().unwrap(),
        s["dropped"].as_u64().unwrap(),
    );
    assert_eq!(written + dropped, published, "{s}");
}

/// Which runs wait for their local sinks without limit: a recorded (regular) file replayed at
/// speed 0 only. Paced replays stand in for a live sensor, and a FIFO may be fed live: the
/// stall rule, as for stdin and serial sources.
#[test]
fn only_a_recorded_file_at_speed_0_applies_back_pressure() {
    use imuprep::runtime::offline_replay;
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("in.log");
    imuprep::io::log::write_log(&log, &common::descriptor(), &common::samples(10, 1)).unwrap();
    let fifo = dir.path().join("live.log");
    let _reader = stuck_fifo(&fifo);
    let replay = |path: &Path, speed: f64| SourceConfig::Replay {
        path: path.to_path_buf(),
        speed,
    };
    assert!(offline_replay(&replay(&log, 0.0)));
    assert!(!offline_replay(&replay(&log, 1.0)));
    assert!(!offline_replay(&replay(&log, 20.0)));
    assert!(!offline_replay(&replay(&fifo, 0.0)));
    assert!(!offline_replay(&replay(
        &dir.path().join("missing.log"),
        0.0
    )));
    assert!(!offline_replay(&SourceConfig::Stdin));
}
