#![cfg(feature = "zenoh")]
//! The Zenoh sink and source (a build with `--features zenoh`; docs/zenoh.md), end to end with
//! the built binary and Zenoh sessions of the test's own, on localhost TCP endpoints with
//! multicast scouting off (free ports picked per test):
//!
//! * a replay published with `--out zenoh:KEY` arrives whole, in order, byte for byte the frames
//!   a `file:` sink of the same run writes, with health on `KEY/health`; the summary lines agree
//!   with what eclipse-zenoh (Python) read from the same replay (tests/reference/zenoh_sub.py,
//!   its printed result committed as tests/reference/zenoh_sub_result.txt);
//! * the Zenoh source decodes frames the test publishes, a corrupted one counted and the good
//!   ones kept; a silent key is a counted stall; `KEY/health` and `KEY/descriptor` answer queries;
//! * a stalled subscriber (another process whose subscriber never returns) neither stalls the
//!   replay nor the subscriber beside it, and what Zenoh dropped to it is counted;
//! * the only subscriber leaving mid-run is warned about and counted, not fatal;
//! * an endpoint that cannot be used is a startup error naming it.
mod common;

use imuprep::frame::{FrameDecoder, Message};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio_util::codec::Decoder;
use zenoh::Wait;

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

/// A peer session of the test: listening on `listen`, connecting to `connect`, no scouting.
fn session(listen: &[String], connect: &[String]) -> zenoh::Session {
    let mut c = zenoh::Config::default();
    let json = |v: &[String]| serde_json::to_string(v).unwrap();
    c.insert_json5("mode", "\"peer\"").unwrap();
    c.insert_json5("listen/endpoints", &json(listen)).unwrap();
    c.insert_json5("connect/endpoints", &json(connect)).unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    zenoh::open(c).wait().unwrap()
}

/// Payloads received on a key, in arrival order.
type Received = Arc<Mutex<Vec<Vec<u8>>>>;

fn collect(s: &zenoh::Session, key: &str) -> (zenoh::pubsub::Subscriber<()>, Received) {
    let got: Received = Arc::default();
    let g = got.clone();
    let sub = s
        .declare_subscriber(key.to_string())
        .callback(move |smp| {
            g.lock()
                .unwrap()
                .push(smp.payload().to_bytes().into_owned())
        })
        .wait()
        .unwrap();
    (sub, got)
}

/// Wait until `got` holds `n` payloads (or 20 s); its count then.
fn wait_for(got: &Received, n: usize) -> usize {
    let t = Instant::now();
    while got.lock().unwrap().len() < n && t.elapsed() < Duration::from_secs(20) {
        std::thread::sleep(Duration::from_millis(20));
    }
    got.lock().unwrap().len()
}

/// The daemon's config: `extra` TOML, then `[zenoh]` connecting to `connect`, listening on
/// localhost only, scouting off.
fn config(dir: &Path, connect: &[String], extra: &str) -> std::path::PathBuf {
    let p = dir.join("zenoh.toml");
    let text = format!(
        "{extra}\n[zenoh]\nmode = \"peer\"\nconnect = {}\nlisten = [\"tcp/127.0.0.1:0\"]\nmulticast_scouting = false\nconnect_timeout_ms = 5000\n",
        serde_json::to_string(connect).unwrap()
    );
    std::fs::write(&p, text).unwrap();
    p
}

fn imuprep(args: &[&str]) -> std::process::Output {
    std::process::Command::new(common::bin())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap()
}

/// The frames of a native byte stream, each as its bytes (split by their length fields).
fn split_frames(mut b: &[u8]) -> Vec<&[u8]> {
    let mut out = Vec::new();
    while b.len() >= 12 {
        assert_eq!(&b[..2], &[0xA5, 0x5A], "not at a frame");
        let n = 12 + u16::from_le_bytes([b[4], b[5]]) as usize + 4;
        out.push(&b[..n]);
        b = &b[n..];
    }
    assert!(b.is_empty(), "a partial frame at the end");
    out
}

fn decode(bytes: &[u8]) -> Vec<Message> {
    let mut dec = FrameDecoder::new();
    let mut buf = bytes::BytesMut::from(bytes);
    let mut out = Vec::new();
    while let Some(m) = dec.decode(&mut buf).unwrap() {
        out.push(m);
    }
    out
}

fn summary(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The summary's entry of the sink named `name`.
fn sink<'a>(s: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    s["sinks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|k| k["name"] == name)
        .unwrap_or_else(|| panic!("no sink {name} in {}", s["sinks"]))
}

/// What tests/reference/zenoh_sub.py prints after its first line, computed from the samples a
/// subscriber received and the rows of the `csv:` sink of the same replay.
fn cross_check_lines(payloads: &[Vec<u8>], csv: &str, last_health: &serde_json::Value) -> String {
    let mut lines = Vec::new();
    let (mut descriptors, mut samples) = (Vec::new(), Vec::new());
    for p in payloads {
        let m = decode(p);
        assert_eq!(m.len(), 1, "one frame per payload");
        match m.into_iter().next().unwrap() {
            Message::Descriptor(d) => descriptors.push(d),
            Message::Sample(s) => samples.push(s),
            Message::Health(_) => panic!("health frames go to KEY/health"),
        }
    }
    let d = descriptors[0];
    lines.push(format!(
        "payloads: {} ({} descriptor, {} samples), each one whole frame with a good CRC-32C",
        payloads.len(),
        descriptors.len(),
        samples.len()
    ));
    lines.push(format!(
        "descriptor: rate {} Hz, gyro range {} rad/s, accel range {} m/s2, device {}, absent mask {}",
        d.sample_rate_hz, d.gyro_range_rad_s, d.accel_range_m_s2, d.device_id, d.absent
    ));
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    let csv_seqs: Vec<u32> = rows
        .iter()
        .map(|r| r.split(',').nth(8).unwrap().parse().unwrap())
        .collect();
    let same = samples.iter().map(|s| s.seq).eq(csv_seqs);
    lines.push(format!(
        "sequence: {}..{}, {} the csv: sink's seq column",
        samples[0].seq,
        samples.last().unwrap().seq,
        if same { "as in" } else { "NOT as in" }
    ));
    let mut equal = 0;
    for (s, row) in samples.iter().zip(&rows) {
        let mut text = String::new();
        imuprep::io::format::write_csv_row(s, &mut text);
        equal += usize::from(text.trim_end() == *row);
    }
    lines.push(format!(
        "values: {equal} of {} csv: rows equal (t, gx..az, temp, seq, flags)",
        rows.len()
    ));
    let sum: f64 = samples
        .iter()
        .flat_map(|s| s.channels())
        .map(|v| v as f32 as f64)
        .sum();
    lines.push(format!("sum of gx..az over every sample: {sum:.6}"));
    lines.push(format!(
        "health: last report samples_out={} sink_dropped={}",
        last_health["samples_out"], last_health["sink_dropped"]
    ));
    lines.join("\n") + "\n"
}

#[test]
fn a_replay_published_over_zenoh_arrives_whole_as_the_file_sink_writes_it() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let s = session(&[endpoint(port)], &[]);
    let key = "imuprep/t1/imu";
    let (_sub, got) = collect(&s, key);
    let (_hsub, health) = collect(&s, &format!("{key}/health"));
    let cfg = config(
        dir.path(),
        &[endpoint(port)],
        "[health]\ninterval_s = 0.05\n",
    );
    let (log, csv, sum) = (
        dir.path().join("clean.log"),
        dir.path().join("clean.csv"),
        dir.path().join("summary.json"),
    );
    let out = imuprep(&[
        "replay",
        "replay/drive.log",
        "--config",
        cfg.to_str().unwrap(),
        // `block`: every sample, at the subscriber's pace (the offline replay is back-pressured);
        // the default, `drop`, is the stalled-subscriber test's.
        "--out",
        &format!("zenoh:{key}?wait=10&congestion=block"),
        "--out",
        &format!("file:{}", log.display()),
        "--out",
        &format!("csv:{}", csv.display()),
        "--summary-json",
        sum.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    // The file sink's frames after the log header, health frames (type 4) left out: what KEY
    // carries, one frame per put.
    let file = std::fs::read(&log).unwrap();
    let want: Vec<&[u8]> = split_frames(&file[12..])
        .into_iter()
        .filter(|f| f[3] != 4)
        .collect();
    let n = wait_for(&got, want.len());
    let got = got.lock().unwrap().clone();
    assert_eq!(n, want.len(), "every frame arrives\n{err}");
    if let Some(i) = (0..n).find(|&i| got[i] != want[i]) {
        panic!("payload {i} differs from the file sink's frame {i}");
    }
    assert_eq!(want[0][3], 1, "the descriptor first");
    let samples = want.len() as u64 - 1;
    assert_eq!(samples, 29982);
    // Health: JSON on KEY/health, at the interval and at the end.
    wait_for(&health, 1);
    let health: Vec<serde_json::Value> = health
        .lock()
        .unwrap()
        .iter()
        .map(|h| serde_json::from_slice(h).unwrap())
        .collect();
    let last = health.last().expect("a health record");
    assert_eq!(last["type"], "health");
    assert_eq!(last["samples_out"], samples);
    assert_eq!(last["sink_dropped"], 0);
    let summary = summary(&sum);
    let z = sink(&summary, &format!("zenoh:{key}"));
    assert_eq!(z["samples_out"], samples, "{z}");
    assert_eq!(z["dropped"], 0, "{z}");
    assert!(z.get("congestion_dropped").is_none(), "{z}");
    assert_eq!(z["health_out"], health.len() as u64, "{z}");
    // What eclipse-zenoh read from the same replay (tests/reference/zenoh_sub.py).
    let lines = cross_check_lines(&got, &std::fs::read_to_string(&csv).unwrap(), last);
    let fixture = include_str!("reference/zenoh_sub_result.txt");
    let python = fixture.split_once('\n').unwrap().1;
    assert_eq!(lines, python, "Rust subscriber vs eclipse-zenoh (Python)");
}

/// A frame with one payload byte flipped: its CRC-32C fails.
fn corrupt(frame: &mut [u8]) {
    frame[20] ^= 0x40;
}

/// Send SIGTERM to the daemon and wait for it (with a limit).
fn stop(mut child: std::process::Child) -> std::process::Output {
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM);
    }
    let t = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t.elapsed() > Duration::from_secs(20) {
            child.kill().unwrap();
            panic!("the daemon did not stop on SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// The replies to a query on `sel`: (key, payload).
fn query(s: &zenoh::Session, sel: &str) -> Vec<(String, Vec<u8>)> {
    let replies = s.get(sel).timeout(Duration::from_secs(3)).wait().unwrap();
    let mut out = Vec::new();
    while let Ok(r) = replies.recv() {
        if let Ok(smp) = r.result() {
            out.push((
                smp.key_expr().to_string(),
                smp.payload().to_bytes().into_owned(),
            ));
        }
    }
    out
}

#[test]
fn the_zenoh_source_decodes_published_frames_counts_a_corrupt_one_and_answers_queries() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let s = session(&[endpoint(port)], &[]);
    let out_log = dir.path().join("out.log");
    let sum = dir.path().join("summary.json");
    let cfg = config(
        dir.path(),
        &[endpoint(port)],
        &format!(
            "[source]\nkind = \"zenoh\"\nkey = \"imuprep/t2/raw\"\nstall_ms = 300\n\n\
             [health]\ninterval_s = 0.1\n\n\
             [gross_error]\nenabled = false\n[bias]\nenabled = false\n[monitor]\nenabled = false\n\n\
             [[sinks]]\nkind = \"zenoh\"\nkey = \"imuprep/t2/imu\"\n\n\
             [[sinks]]\nkind = \"file\"\npath = \"{}\"\n",
            out_log.display()
        ),
    );
    let child = std::process::Command::new(common::bin())
        .args([
            "run",
            "--config",
            cfg.to_str().unwrap(),
            "--summary-json",
            sum.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let publisher = s
        .declare_publisher("imuprep/t2/raw")
        .congestion_control(zenoh::qos::CongestionControl::Block)
        .wait()
        .unwrap();
    // The daemon subscribes once its session is up.
    let t = Instant::now();
    while !publisher.matching_status().wait().unwrap().matching() {
        assert!(t.elapsed() < Duration::from_secs(20), "no subscriber");
        std::thread::sleep(Duration::from_millis(20));
    }
    let d = common::descriptor();
    let mut buf = bytes::BytesMut::new();
    imuprep::frame::encode_descriptor(&d, &mut buf);
    let descriptor = buf.split().to_vec();
    publisher.put(descriptor.clone()).wait().unwrap();
    let sent = common::samples(200, 5);
    for (i, smp) in sent.iter().enumerate() {
        imuprep::frame::encode_sample(smp, &mut buf);
        let mut frame = buf.split().to_vec();
        if i == 50 {
            corrupt(&mut frame);
        }
        publisher.put(frame).wait().unwrap();
    }
    // Health reports the 199 good samples; the queries find them under the fleet's wildcard.
    let t = Instant::now();
    let health = loop {
        let r = query(&s, "imuprep/**/health");
        if let Some((k, h)) = r.first() {
            let h: serde_json::Value = serde_json::from_slice(h).unwrap();
            if h["samples_in"] == 199 {
                assert_eq!(r.len(), 1, "one daemon answers");
                assert_eq!(k, "imuprep/t2/imu/health");
                break h;
            }
        }
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "no health reply: {r:?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(health["type"], "health");
    assert_eq!(health["crc_errors"], 1, "{health}");
    assert_eq!(health["gaps"], 1, "{health}");
    assert_eq!(health["missing_frames"], 1, "{health}");
    let r = query(&s, "imuprep/t2/imu/descriptor");
    assert_eq!(r, vec![("imuprep/t2/imu/descriptor".into(), descriptor)]);
    // Silence past stall_ms is a stall, counted.
    std::thread::sleep(Duration::from_millis(800));
    let out = stop(child);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    // Said once per stall (it was said twice: by the source and by the runtime).
    assert!(
        err.contains("source stall #1: zenoh source silent"),
        "{err}"
    );
    assert_eq!(
        err.matches("zenoh source silent").count(),
        err.matches("source stall #").count(),
        "{err}"
    );
    let summary = summary(&sum);
    let dec = &summary["decoder"];
    assert_eq!(dec["crc_errors"], 1, "{dec}");
    assert_eq!(dec["gaps"], 1, "{dec}");
    assert_eq!(summary["samples_in"], 199);
    assert!(summary["source_stalls"].as_u64().unwrap() >= 1, "{summary}");
    // The good frames, decoded as published (f32 on the wire), in order; the one after the
    // corrupted frame flagged as following a gap.
    let written: Vec<_> = decode(&std::fs::read(&out_log).unwrap()[12..])
        .into_iter()
        .filter_map(|m| match m {
            Message::Sample(s) => Some(s),
            _ => None,
        })
        .collect();
    let mut all = bytes::BytesMut::new();
    for smp in &sent {
        imuprep::frame::encode_sample(smp, &mut all);
    }
    let want: Vec<_> = decode(&all)
        .into_iter()
        .filter_map(|m| match m {
            Message::Sample(s) => Some(s),
            _ => None,
        })
        .filter(|s| s.seq != 50)
        .collect();
    assert_eq!(written.len(), 199);
    for (w, g) in want.iter().zip(&written) {
        assert_eq!((w.seq, w.t_ns), (g.seq, g.t_ns));
        assert_eq!(w.channels(), g.channels(), "seq {}", w.seq);
        let gap = imuprep::sample::flags::GAP;
        assert_eq!(g.flags & gap != 0, g.seq == 51, "seq {}", g.seq);
    }
}

/// Not a test on its own: the stalled subscriber of the next test, in a process of its own
/// (its subscriber never returns, so its session stops reading its socket).
#[test]
#[ignore]
fn stalled_subscriber_process() {
    let Ok(port) = std::env::var("IMUPREP_ZENOH_STALLED_PORT") else {
        return;
    };
    // Small socket buffers: Zenoh's queue towards it fills after a few hundred kB.
    let ep = format!("tcp/127.0.0.1:{port}#so_rcvbuf=8192;so_sndbuf=8192");
    let s = session(&[ep], &[]);
    let _sub = s
        .declare_subscriber("imuprep/t3/imu")
        .callback(|_| std::thread::sleep(Duration::from_secs(3600)))
        .wait()
        .unwrap();
    println!("stalled subscriber ready");
    std::thread::sleep(Duration::from_secs(120));
}

#[test]
fn a_stalled_subscriber_stalls_neither_the_replay_nor_the_other_subscriber_and_its_drops_are_counted()
 {
    let dir = tempfile::tempdir().unwrap();
    let (good_port, stalled_port) = (free_port(), free_port());
    let mut stalled = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "stalled_subscriber_process",
            "--exact",
            "--ignored",
            "--nocapture",
        ])
        .env("IMUPREP_ZENOH_STALLED_PORT", stalled_port.to_string())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::BufRead;
        let mut line = String::new();
        let mut r = std::io::BufReader::new(stalled.stdout.as_mut().unwrap());
        while !line.contains("stalled subscriber ready") {
            line.clear();
            assert!(r.read_line(&mut line).unwrap() > 0, "helper ended");
        }
    }
    let s = session(&[endpoint(good_port)], &[]);
    let key = "imuprep/t3/imu";
    let (_sub, got) = collect(&s, key);
    let connect = [
        endpoint(good_port),
        format!("{}#so_sndbuf=8192", endpoint(stalled_port)),
    ];
    let cfg = config(dir.path(), &connect, "[health]\ninterval_s = 0.2\n");
    let sum = dir.path().join("summary.json");
    let t = Instant::now();
    // Paced at 100× (3 s): the good subscriber keeps up on a loaded machine; the stalled one
    // takes nothing after its first few hundred kB.
    let out = imuprep(&[
        "replay",
        "replay/drive.log",
        "--speed",
        "100",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        &format!("zenoh:{key}?wait=10"),
        "--summary-json",
        sum.to_str().unwrap(),
    ]);
    let took = t.elapsed();
    let _ = stalled.kill();
    let _ = stalled.wait();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let n = wait_for(&got, 29983);
    assert_eq!(n, 29983, "the good subscriber gets every frame\n{err}");
    let summary = summary(&sum);
    let z = sink(&summary, &format!("zenoh:{key}"));
    let congestion = z["congestion_dropped"].as_u64().unwrap_or(0);
    // About 29 000 here; Zenoh may also close a link it cannot push its own control messages
    // to, after which nothing more is sent (or dropped) to it: the bound leaves room for that.
    assert!(
        congestion > 1_000,
        "Zenoh's drops to the stalled subscriber are counted: {z}\n{err}"
    );
    assert_eq!(z["samples_out"], 29982, "{z}");
    assert!(err.contains("Zenoh dropped messages"), "{err}");
    assert!(
        err.contains(&format!("{congestion} dropped by its congestion control")),
        "{err}"
    );
    eprintln!(
        "stalled subscriber: replay of 29982 samples at 100x took {:.1} s; {congestion} messages dropped by Zenoh, counted",
        took.as_secs_f64()
    );
}

#[test]
fn the_only_subscriber_leaving_mid_run_is_warned_and_counted_not_fatal() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let s = session(&[endpoint(port)], &[]);
    let key = "imuprep/t4/imu";
    let (sub, got) = collect(&s, key);
    let cfg = config(dir.path(), &[endpoint(port)], "");
    let sum = dir.path().join("summary.json");
    let child = std::process::Command::new(common::bin())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "replay",
            "replay/drive.log",
            "--speed",
            "50",
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            &format!("zenoh:{key}?wait=10"),
            "--summary-json",
            sum.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Some samples arrive, then the peer (standing in for a router) goes away.
    wait_for(&got, 500);
    drop(sub);
    s.close().wait().unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("no subscriber matches any more"), "{err}");
    let summary = summary(&sum);
    let z = sink(&summary, &format!("zenoh:{key}"));
    assert_eq!(z["samples_out"], 29982, "{z}");
    assert!(z["no_subscriber"].as_u64().unwrap() > 1000, "{z}");
    assert!(
        err.contains("published while no subscriber matched"),
        "{err}"
    );
}

#[test]
fn an_endpoint_that_cannot_be_used_is_a_startup_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    // Nothing listens there.
    let port = free_port();
    let cfg = config(dir.path(), &[endpoint(port)], "");
    std::fs::write(
        &cfg,
        std::fs::read_to_string(&cfg)
            .unwrap()
            .replace("connect_timeout_ms = 5000", "connect_timeout_ms = 500"),
    )
    .unwrap();
    fails_naming(&cfg, &endpoint(port));
    // A listen endpoint already taken.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let ep = endpoint(taken.local_addr().unwrap().port());
    let cfg = config(dir.path(), &[], "");
    std::fs::write(
        &cfg,
        std::fs::read_to_string(&cfg).unwrap().replace(
            "listen = [\"tcp/127.0.0.1:0\"]",
            &format!("listen = [\"{ep}\"]"),
        ),
    )
    .unwrap();
    fails_naming(&cfg, &ep);
}

/// A replay with config `cfg` and a `zenoh:` sink fails at startup, saying it cannot open the
/// session and naming `endpoint`, without a panic.
fn fails_naming(cfg: &Path, endpoint: &str) {
    let out = imuprep(&[
        "replay",
        "replay/drive.log",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        "zenoh:imuprep/t5/imu",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("zenoh: cannot open the session") && err.contains(endpoint),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// `wait=S` once ignored Ctrl-C: the sink waited for a subscriber before the run's SIGINT and
/// SIGTERM handler was installed, so a signal in the wait killed the process without a summary
/// (or, inherited as ignored, was lost: the run then waited out S and replayed everything). A
/// signal now ends the wait at once and the run stops with its summary.
#[test]
fn a_signal_while_the_sink_waits_for_a_subscriber_stops_the_run_with_its_summary() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[], "");
    let sum = dir.path().join("summary.json");
    let mut child = std::process::Command::new(common::bin())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "replay",
            "replay/drive.log",
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            "zenoh:imuprep/t6/imu?wait=60",
            "--summary-json",
            sum.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in std::io::BufReader::new(stderr)
            .lines()
            .map_while(Result::ok)
        {
            let _ = tx.send(line.clone());
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    // Signal once the sink is waiting.
    let t = Instant::now();
    loop {
        let line = rx.recv_timeout(Duration::from_secs(20)).unwrap();
        if line.contains("waiting up to 60 s for a subscriber") {
            break;
        }
    }
    std::thread::sleep(Duration::from_millis(300));
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let signalled = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if signalled.elapsed() > Duration::from_secs(10) {
            child.kill().unwrap();
            panic!(
                "SIGINT did not stop the run in the wait ({:.1} s in)",
                t.elapsed().as_secs_f64()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = child.wait().unwrap();
    let err = reader.join().unwrap();
    assert!(
        status.code().is_some(),
        "killed by the signal, no summary: {err}"
    );
    assert!(err.contains("imuprep summary (signal SIGINT"), "{err}");
    assert!(!err.contains("no subscriber after"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let summary = summary(&sum);
    let z = sink(&summary, "zenoh:imuprep/t6/imu");
    let read = summary["samples_in"].as_u64().unwrap();
    assert!(
        read < 29982,
        "the replay ran on after the signal: {summary}"
    );
    assert_eq!(
        z["samples_out"].as_u64().unwrap() + z["dropped"].as_u64().unwrap(),
        summary["samples_out"].as_u64().unwrap(),
        "{summary}"
    );
}

/// The config check of an endpoint's `?…`/`#…` options agrees with Zenoh's own parser: what
/// `[zenoh]` accepts, Zenoh accepts, and what Zenoh refuses is a config error at its key, not a
/// raw error when the session opens.
#[test]
fn the_endpoint_check_agrees_with_zenohs_parser_on_options() {
    use std::str::FromStr;
    for ep in [
        "tcp/127.0.0.1:7447",
        "tcp/127.0.0.1:7447#",
        "tcp/127.0.0.1:7447?",
        "tcp/127.0.0.1:7447#=1",
        "tcp/127.0.0.1:7447#;",
        "tcp/127.0.0.1:7447#a",
        "tcp/127.0.0.1:7447#a=",
        "tcp/127.0.0.1:7447#a=1;;b=2",
        "tcp/127.0.0.1:7447#a=1#b",
        "tcp/127.0.0.1:7447?a=1#",
        "tcp/127.0.0.1:7447?#a=1",
        "tcp/127.0.0.1:7447?a=1#b=2",
        "tcp/127.0.0.1:7447?a?b=1",
        "tcp/127.0.0.1:7447#a=1?b=2",
        "tcp/127.0.0.1:7447#so_sndbuf=65536",
    ] {
        let zenoh_ok = zenoh::config::EndPoint::from_str(ep).is_ok();
        let text = format!("[source]\nkind = \"stdin\"\n[zenoh]\nconnect = [{ep:?}]\n");
        let ours = imuprep::config::Config::from_toml_str(&text, Path::new("."));
        assert_eq!(
            ours.is_ok(),
            zenoh_ok,
            "{ep}: imuprep {:?}",
            ours.err().map(|e| e.to_string())
        );
    }
}
