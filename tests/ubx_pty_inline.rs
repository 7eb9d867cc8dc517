//! A pseudo-terminal pair end to end: the pyubx2-made UBX stream (ESF-RAW and ESF-MEAS with NMEA
//! sentences and other UBX messages interleaved, tests/reference/ubx_stream.bin) is written into
//! one pty; `imuprep run` reads it as a serial port and writes the inline UBX stream to a new
//! pty (`--out pty:`, path printed on stderr); the test reads that pty and decodes it. Every NMEA
//! sentence and every other message comes out in order, and the IMU values equal pyubx2's reading
//! of the input (stages off, so the cleaned values are the raw ones).
#![cfg(unix)]

use bytes::BytesMut;
use imuprep::frame::ubx::UbxDecoder;
use imuprep::frame::{Decoded, ProtocolDecoder};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::{SerialPort, SerialPortBuilderExt, SerialStream};

const UBX: &[u8] = include_bytes!("reference/ubx_stream.bin");
const UBX_EXPECTED: &str = include_str!("reference/ubx_expected.csv");

/// NMEA sentences (`$…\r\n`) of a byte stream, in order.
fn nmea(b: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'$'
            && let Some(n) = b[i..].windows(2).position(|w| w == b"\r\n")
            && b[i..i + n]
                .iter()
                .all(|c| c.is_ascii_graphic() || *c == b' ')
        {
            out.push(b[i..i + n + 2].to_vec());
            i += n + 2;
            continue;
        }
        i += 1;
    }
    out
}

fn decode(b: &[u8]) -> (Vec<imuprep::Sample>, Vec<Vec<u8>>) {
    let mut d = UbxDecoder::default();
    let mut buf = BytesMut::from(b);
    let (mut s, mut o) = (Vec::new(), Vec::new());
    while let Some(x) = d.decode_item_eof(&mut buf) {
        match x {
            Decoded::Sample(x, _) => s.push(x),
            Decoded::Other(b) => o.push(b.to_vec()),
            Decoded::Descriptor(_) => {}
        }
    }
    (s, o)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ubx_with_nmea_through_a_pty_pair_comes_out_inline_in_order() {
    let dir = tempfile::tempdir().unwrap();
    // Input pty: the test writes the master, imuprep opens the slave by a stable link.
    let (mut master, slave) = SerialStream::pair().expect("pty pair");
    let link = dir.path().join("ttyUBX");
    std::os::unix::fs::symlink(slave.name().unwrap(), &link).unwrap();
    drop(slave);
    let cfg = dir.path().join("ubx.toml");
    std::fs::write(
        &cfg,
        format!(
            "[source]\nkind = \"serial\"\nport = \"{}\"\nbaud = 115200\nprotocol = \"ubx\"\n\
             [health]\ninterval_s = 0.0\n[gross_error]\nenabled = false\n[bias]\nenabled = false\n",
            link.display()
        ),
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_imuprep"))
        .args(["run", "--config", cfg.to_str().unwrap(), "--out", "pty:"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // stderr: the output pty's path, then the serial port being opened.
    let (ltx, lrx) = std::sync::mpsc::channel::<String>();
    let err = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for l in BufReader::new(err).lines().map_while(Result::ok) {
            if ltx.send(l).is_err() {
                break;
            }
        }
    });
    let mut out_path = None;
    let mut open = false;
    let until = Instant::now() + Duration::from_secs(30);
    while !(open && out_path.is_some()) {
        let l = lrx
            .recv_timeout(until.saturating_duration_since(Instant::now()))
            .expect("imuprep printed its pty and opened the port");
        if let Some(p) = l.split("inline output on pseudo-terminal ").nth(1) {
            out_path = Some(p.trim().to_string());
        }
        open |= l.contains("serial port open");
    }
    let mut out = tokio_serial::new(out_path.unwrap(), 115_200)
        .open_native_async()
        .expect("open the output pty");
    let reader = tokio::spawn(async move {
        let mut got = Vec::new();
        let mut b = [0u8; 4096];
        // Until imuprep closes its end (EOF / EIO) or nothing comes for 3 s after the end.
        while let Ok(Ok(n)) = tokio::time::timeout(Duration::from_secs(3), out.read(&mut b)).await {
            if n == 0 {
                break;
            }
            got.extend_from_slice(&b[..n]);
        }
        got
    });
    // Write at a serial-like pace: 256-byte bursts.
    for c in UBX.chunks(256) {
        master.write_all(c).await.unwrap();
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // Let the pipeline catch up, then stop the daemon (it flushes held samples on SIGTERM).
    tokio::time::sleep(Duration::from_millis(1500)).await;
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM);
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "imuprep exit: {status}");
    let got = reader.await.unwrap();

    // Every NMEA sentence, in order.
    let want_nmea = nmea(UBX);
    assert_eq!(want_nmea.len(), 16);
    assert_eq!(nmea(&got), want_nmea);
    // Every message that is not IMU data, in order, and every IMU sample.
    let (s_in, o_in) = decode(UBX);
    let (s_out, o_out) = decode(&got);
    assert_eq!(o_out, o_in);
    assert_eq!(s_out.len(), 58);
    // The values are pyubx2's reading of the input (stages off: cleaned = raw), to the
    // protocol's resolution: the same 24-bit integers; 1e-12 covers the float rounding of the
    // scale factors, far below 2^-12 deg/s.
    let rows: Vec<Vec<f64>> = UBX_EXPECTED
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').skip(2).map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 58);
    for ((s, r), i) in s_out.iter().zip(&rows).zip(&s_in) {
        for (c, want) in r.iter().take(6).enumerate() {
            assert!((s.channel(c) - want).abs() < 1e-12, "channel {c}");
        }
        assert_eq!(s.t_ns, i.t_ns);
    }
    // With the values unchanged, the inline stream is the input byte for byte.
    assert!(got == UBX, "inline output differs from the input");
}
