//! Throughput of the Zenoh sink, with the `file:` sink as the in-run baseline (docs/zenoh.md).
//!
//! Run: `cargo run --release --features zenoh --example zenoh_throughput [-- SAMPLES RUNS]`
//! (default 200 000 samples, 5 runs).
//!
//! Each run hands the same seeded clean samples to a sink the way the runtime does (an `Arc`
//! batch at a time), but waits for room in the sink's queue instead of dropping, so what is
//! timed is the sink's own rate: from the first batch offered to the sink's task ending after
//! the last (for Zenoh: every sample put; a subscriber in another session of this process, over
//! localhost TCP, counts what arrives). Two batch sizes: 512 (an offline replay's batches) and
//! 1 (a live sensor at 1 kHz-class rates hands the runtime a sample or a few at a time).
//! Prints the median samples/s over the runs of each sink and batch size.

use imuprep::config::{Format, Sink, ZenohConfig};
use imuprep::io::sink::{SinkContext, SinkItem, start_with};
use imuprep::io::zenoh::ZenohSession;
use imuprep::sample::Sample;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};

fn samples(n: usize) -> Vec<Sample> {
    let mut r = imuprep::rng::Rng::new(11);
    (0..n)
        .map(|i| {
            let mut s = Sample {
                temp_c: Some(25.0),
                ..Sample::nth(i, 1_000_000)
            };
            s.set_channels(&[
                0.01 * r.normal(),
                0.01 * r.normal(),
                0.3 + 0.01 * r.normal(),
                0.05 * r.normal(),
                0.05 * r.normal(),
                -9.80665 + 0.05 * r.normal(),
            ]);
            s
        })
        .collect()
}

/// Seconds the sink took for `data` in batches of `batch`.
async fn run(sink: &Sink, ctx: &SinkContext, data: &[Sample], batch: usize) -> f64 {
    let h = start_with(sink, ctx).await.expect("sink starts");
    let batches: Vec<_> = data.chunks(batch).map(|b| Arc::new(b.to_vec())).collect();
    let t = Instant::now();
    h.tx.send(SinkItem::Descriptor(Default::default()))
        .await
        .unwrap();
    for b in batches {
        h.tx.send(SinkItem::Samples(b)).await.unwrap();
    }
    let imuprep::io::sink::SinkHandle {
        tx, task, stats, ..
    } = h;
    drop(tx);
    task.await.unwrap();
    assert_eq!(stats.samples_out.load(Relaxed), data.len() as u64);
    t.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(200_000);
    let runs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(5);
    let data = samples(n);
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let ep = format!("tcp/127.0.0.1:{port}");
    let sub_cfg = ZenohConfig {
        listen: vec![ep.clone()],
        multicast_scouting: false,
        ..ZenohConfig::default()
    }
    .validate()
    .unwrap();
    let pub_cfg = ZenohConfig {
        connect: vec![ep],
        listen: vec!["tcp/127.0.0.1:0".into()],
        multicast_scouting: false,
        ..ZenohConfig::default()
    }
    .validate()
    .unwrap();
    let subscriber = ZenohSession::open(&sub_cfg).await.unwrap();
    let received = Arc::new(AtomicU64::new(0));
    let r = received.clone();
    let _sub = subscriber
        .session
        .declare_subscriber("imuprep/bench/imu")
        .callback(move |_| {
            r.fetch_add(1, Relaxed);
        })
        .await
        .unwrap();
    let publisher = ZenohSession::open(&pub_cfg).await.unwrap();
    let ctx = SinkContext {
        zenoh: Some(publisher.clone()),
        stop: None,
    };
    let dir = tempfile::tempdir().unwrap();
    let file = Sink::File {
        path: dir.path().join("bench.log"),
        format: Format::Native,
    };
    let zenoh = |format| Sink::Zenoh {
        key: "imuprep/bench/imu".into(),
        format,
        queue: 64,
        wait_s: 10.0,
        congestion: imuprep::config::ZenohCongestion::Drop,
    };
    println!(
        "{n} samples, {runs} runs, median samples/s (2-core machine shared with other builds)"
    );
    println!("| sink | batch 512 | batch 1 | received by the subscriber |");
    println!("|---|---|---|---|");
    for (name, sink) in [
        ("file: (native)", file),
        ("zenoh: (native)", zenoh(Format::Native)),
        ("zenoh: (jsonl)", zenoh(Format::Jsonl)),
    ] {
        let mut cells = Vec::new();
        let mut got = String::from("—");
        for batch in [512, 1] {
            let mut rates = Vec::new();
            for _ in 0..runs {
                let before = received.load(Relaxed);
                let s = run(&sink, &ctx, &data, batch).await;
                rates.push(n as f64 / s);
                if let Sink::Zenoh { format, .. } = &sink {
                    // Every sample, and the descriptor frame in the native format; what is
                    // still in flight arrives within a moment.
                    let want = n as u64 + u64::from(*format == Format::Native);
                    let t = Instant::now();
                    while received.load(Relaxed) - before < want
                        && t.elapsed() < Duration::from_secs(5)
                    {
                        tokio::time::sleep(Duration::from_millis(10)).await;
                    }
                    got = format!("{} of {want} (last run)", received.load(Relaxed) - before);
                }
            }
            cells.push(format!("{:.0}", median(rates)));
        }
        println!("| {name} | {} | {} | {got} |", cells[0], cells[1]);
    }
    publisher.close().await;
    subscriber.close().await;
}
