//! Serial source over a pseudo-terminal pair: frames written to one end come out of the
//! pipeline; the port vanishing and coming back is survived (outage counted, gap flagged).
#![cfg(unix)]
mod common;

use bytes::BytesMut;
use imuprep::frame::encode_sample;
use imuprep::io::source::{self, SourceEvent};
use std::time::Duration;
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;
use tokio_serial::{SerialPort, SerialStream};

fn frames(range: std::ops::Range<u32>) -> Vec<u8> {
    let all = common::samples(range.end as usize, 5);
    let mut b = BytesMut::new();
    for s in &all[range.start as usize..] {
        encode_sample(s, &mut b);
    }
    b.to_vec()
}

/// A pty pair; the device path of the slave side is published through a stable symlink, as a
/// udev rule would, so the source can reopen "the same port" after it vanished.
fn pty_at(link: &std::path::Path) -> SerialStream {
    let (master, slave) = SerialStream::pair().expect("pty pair");
    let name = slave.name().expect("slave path");
    drop(slave);
    let _ = std::fs::remove_file(link);
    std::os::unix::fs::symlink(&name, link).unwrap();
    master
}

/// Wait until the source has (re)opened the port, keeping the outage count it reports on the
/// way in `outages`.
async fn connected(rx: &mut mpsc::Receiver<SourceEvent>, outages: &mut u64) {
    loop {
        match tokio::time::timeout(Duration::from_secs(10), rx.recv())
            .await
            .unwrap()
        {
            Some(SourceEvent::Connected { .. }) => return,
            Some(SourceEvent::Outage { outages: n, .. }) => *outages = n,
            Some(_) => {}
            None => panic!("source ended"),
        }
    }
}

async fn collect(
    rx: &mut mpsc::Receiver<SourceEvent>,
    want: usize,
    out: &mut Vec<imuprep::Sample>,
    outages: &mut u64,
) {
    while out.len() < want {
        match tokio::time::timeout(Duration::from_secs(10), rx.recv())
            .await
            .expect("source went quiet")
        {
            Some(SourceEvent::Samples(b, _)) => out.extend(b),
            Some(SourceEvent::Outage { outages: n, .. }) => *outages = n,
            Some(_) => {}
            None => panic!("source ended"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn frames_over_a_pty_arrive_and_a_vanished_port_is_survived() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttyIMU");
    let mut master = pty_at(&link);
    let (tx, mut rx) = mpsc::channel(64);
    let task = tokio::spawn(source::serial(
        link.to_string_lossy().into_owned(),
        115_200,
        Duration::from_millis(20),
        Duration::from_millis(200),
        tx,
    ));
    // Give the source time to open the port before writing (a pty drops nothing, but the
    // slave must be open for the line discipline to hold the bytes).
    let mut got = Vec::new();
    let mut outages = 0;
    connected(&mut rx, &mut 0).await;
    master.write_all(&frames(0..100)).await.unwrap();
    collect(&mut rx, 100, &mut got, &mut outages).await;
    assert_eq!(
        got.iter().map(|s| s.seq).collect::<Vec<_>>(),
        (0..100).collect::<Vec<_>>()
    );

    // The port vanishes: close the master and remove the device link.
    drop(master);
    std::fs::remove_file(&link).unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    // It comes back (a new pty at the same path); frames 150.. are sent, 100..150 were lost.
    let mut master = pty_at(&link);
    connected(&mut rx, &mut outages).await;
    master.write_all(&frames(150..200)).await.unwrap();
    collect(&mut rx, 150, &mut got, &mut outages).await;
    assert!(outages >= 1, "the outage is counted");
    let resumed = &got[100];
    assert_eq!(resumed.seq, 150);
    assert!(
        resumed.has(imuprep::flags::GAP),
        "the frames lost in the outage show as a gap"
    );
    task.abort();
}

#[tokio::test]
async fn a_serial_port_that_does_not_exist_is_retried_not_fatal() {
    let (tx, mut rx) = mpsc::channel(8);
    let task = tokio::spawn(source::serial(
        "/dev/imuprep-no-such-port".into(),
        115_200,
        Duration::from_millis(10),
        Duration::from_millis(20),
        tx,
    ));
    match tokio::time::timeout(Duration::from_secs(5), rx.recv())
        .await
        .unwrap()
    {
        Some(SourceEvent::Outage { outages, reason }) => {
            assert_eq!(outages, 1);
            assert!(!reason.is_empty());
        }
        other => panic!("expected an outage, got {other:?}"),
    }
    // Still running (retrying) a while later.
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert!(!task.is_finished());
    task.abort();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_open_port_is_reported_as_a_stall_and_reopened() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttyIMU");
    let mut master = pty_at(&link);
    let (tx, mut rx) = mpsc::channel(64);
    let task = tokio::spawn(source::serial_watched(
        link.to_string_lossy().into_owned(),
        115_200,
        Duration::from_millis(20),
        Duration::from_millis(200),
        Some(Duration::from_millis(300)),
        imuprep::frame::detect::ProtocolConfig::default(),
        false,
        tx,
    ));
    let mut connects = 0;
    let mut got = Vec::new();
    let mut stalls = 0;
    // Frames, then silence with the port left open: a stall is reported and the port reopened.
    while stalls == 0 {
        match tokio::time::timeout(Duration::from_secs(10), rx.recv())
            .await
            .expect("no stall reported within 10 s of silence")
        {
            Some(SourceEvent::Connected { .. }) => {
                connects += 1;
                if connects == 1 {
                    master.write_all(&frames(0..50)).await.unwrap();
                }
            }
            Some(SourceEvent::Samples(b, _)) => got.extend(b),
            Some(SourceEvent::Stall { stalls: n, .. }) => stalls = n,
            Some(_) => {}
            None => panic!("source ended"),
        }
    }
    assert_eq!(got.len(), 50);
    assert_eq!(stalls, 1);
    // Reopened, and data flows again.
    connected(&mut rx, &mut 0).await;
    master.write_all(&frames(50..60)).await.unwrap();
    let mut outages = 0;
    collect(&mut rx, 60, &mut got, &mut outages).await;
    assert_eq!(got[59].seq, 59);
    task.abort();
}
