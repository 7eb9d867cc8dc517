//! Decoder throughput per protocol beside the native decoder, same run, one core.
//!
//! `cargo bench --bench protocols` — criterion prints the median time per 100 000 IMU samples
//! and the throughput in samples/s (elements/s). Frames/s: native, MAVLink and ULog carry one
//! sample per frame; the UBX stream packs 4 sets per ESF-RAW message (as receivers batch them),
//! so its frames/s is a quarter of its samples/s. With `--features ros2`, also a ROS 2 bag
//! (MCAP as the `mcap:` sink writes it: 1 MiB chunks with CRCs, one sensor_msgs/msg/Imu per
//! sample), CRCs checked.
//!
//! Two ways of feeding the bytes, each its own group:
//! - `decode_100k_samples_64k_reads`: 64 KiB reads appended to one buffer, each decoded until
//!   the decoder needs more, then end of input — as the replay source (`FramedRead`) and the log
//!   reader feed a decoder. The decoder's own cost plus one copy of every byte.
//! - `decode_100k_samples`: the whole input copied into a fresh buffer every iteration, then
//!   decoded. For a 35 MB bag most of that time is the kernel handing out and zeroing fresh
//!   pages for the copy, not decoding (kept to compare with earlier runs).
//!
//! Groups `ubx_rework_64k_reads` (wall time) and `ubx_rework_64k_reads_cpu` (the thread's CPU
//! time, which a loaded machine inflates far less): the UBX decoder before the per-sample
//! rework (`support/ubx_before.rs`, kept verbatim as the in-run baseline) and now, on the same
//! stream and reads, one right after the other. `cargo bench --bench protocols -- ubx_rework`.
//! For a count that load does not move, `--test` runs each routine once, so the instructions
//! of one 100 000-sample decode are those of `valgrind --tool=cachegrind --cache-sim=no BENCH
//! --bench --test ubx_rework_64k_reads/before` minus those with a filter that matches nothing
//! (the stream set-up); `cg_annotate` splits them by function.

use bytes::BytesMut;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::frame::mavlink::{self, MavlinkDecoder};
use imuprep::frame::ubx::{self, UbxDecoder};
use imuprep::frame::ulog::{self, UlogDecoder};
use imuprep::frame::{Decoded, FrameDecoder, ProtocolDecoder, encode_sample};
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use std::hint::black_box;

#[path = "support/thread_cpu.rs"]
mod thread_cpu;
#[path = "support/ubx_before.rs"]
mod ubx_before;
use criterion::measurement::Measurement;
use thread_cpu::ThreadCpu;

const N: usize = 100_000;

fn samples() -> Vec<Sample> {
    let mut r = Rng::new(1);
    (0..N)
        .map(|i| {
            let mut s = Sample {
                seq: i as u32,
                t_ns: 1_000_000_000 + i as u64 * 5_000_000,
                temp_c: Some(25.0),
                ..Sample::default()
            };
            s.set_channels(&[
                0.1 * r.normal(),
                0.1 * r.normal(),
                0.1 * r.normal(),
                r.normal(),
                r.normal(),
                9.8 + r.normal(),
            ]);
            s
        })
        .collect()
}

fn count(mut d: Box<dyn ProtocolDecoder>, bytes: &[u8]) -> u64 {
    let mut buf = BytesMut::from(bytes);
    let mut n = 0u64;
    while let Some(x) = d.decode_item(&mut buf) {
        n += tally(x);
    }
    n
}

/// Bytes per read in the `_64k_reads` group (the log reader's read size).
const READ: usize = 64 * 1024;

fn tally(x: Decoded) -> u64 {
    match x {
        Decoded::Sample(s, _) => s.seq as u64,
        _ => 0,
    }
}

fn count_reads(mut d: Box<dyn ProtocolDecoder>, bytes: &[u8]) -> u64 {
    let mut buf = BytesMut::with_capacity(2 * READ);
    let mut n = 0u64;
    for c in bytes.chunks(READ) {
        buf.extend_from_slice(c);
        while let Some(x) = d.decode_item(&mut buf) {
            n += tally(x);
        }
    }
    while let Some(x) = d.decode_item_eof(&mut buf) {
        n += tally(x);
    }
    n
}

fn bench(c: &mut Criterion) {
    let ss = samples();
    let mut native = BytesMut::new();
    let mut ubx_b = BytesMut::new();
    let mut mav = BytesMut::new();
    let mut ulg = BytesMut::new();
    for s in &ss {
        encode_sample(s, &mut native);
    }
    for (k, chunk) in ss.chunks(4).enumerate() {
        let sets: Vec<(u32, Sample)> = chunk
            .iter()
            .enumerate()
            .map(|(j, s)| ((((4 * k + j) as u32) * 128) & 0xFF_FFFF, *s))
            .collect();
        ubx::encode_esf_raw(&sets, &mut ubx_b);
    }
    for (i, s) in ss.iter().enumerate() {
        mavlink::encode_v2(
            i as u8,
            1,
            1,
            mavlink::MSG_HIGHRES_IMU,
            &mavlink::highres_payload(s, 0),
            &mut mav,
        );
    }
    ulog::encode_sensor_combined_log(&ss, &mut ulg);
    #[cfg(feature = "ros2")]
    let bag = imuprep::io::mcap_sink::encode_bag(
        &imuprep::frame::Descriptor::default(),
        &ss,
        Default::default(),
    )
    .expect("bag");
    type Count = fn(Box<dyn ProtocolDecoder>, &[u8]) -> u64;
    let shapes: [(&str, Count); 2] = [
        ("decode_100k_samples_64k_reads", count_reads),
        ("decode_100k_samples", count),
    ];
    for (group, count) in shapes {
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Elements(N as u64));
        g.bench_function("native", |b| {
            b.iter(|| black_box(count(Box::new(FrameDecoder::new()), &native)))
        });
        g.bench_function("ubx_esf_raw", |b| {
            b.iter(|| black_box(count(Box::<UbxDecoder>::default(), &ubx_b)))
        });
        g.bench_function("mavlink_highres_imu", |b| {
            b.iter(|| black_box(count(Box::<MavlinkDecoder>::default(), &mav)))
        });
        g.bench_function("ulog_sensor_combined", |b| {
            b.iter(|| black_box(count(Box::<UlogDecoder>::default(), &ulg)))
        });
        #[cfg(feature = "ros2")]
        g.bench_function("mcap_ros2_imu", |b| {
            b.iter(|| {
                black_box(count(
                    Box::<imuprep::frame::mcap::McapDecoder>::default(),
                    &bag,
                ))
            })
        });
        g.finish();
    }
    ubx_rework(c, "ubx_rework_64k_reads", &ubx_b);
    let mut cpu = Criterion::default()
        .with_measurement(ThreadCpu)
        .configure_from_args();
    ubx_rework(&mut cpu, "ubx_rework_64k_reads_cpu", &ubx_b);
}

/// The UBX decoder before the rework and now, same stream, same reads, one after the other.
fn ubx_rework<M: Measurement>(c: &mut Criterion<M>, name: &str, ubx_b: &[u8]) {
    let mut g = c.benchmark_group(name);
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("before", |b| {
        b.iter(|| {
            black_box(count_reads(
                Box::<ubx_before::UbxDecoderBefore>::default(),
                ubx_b,
            ))
        })
    });
    g.bench_function("after", |b| {
        b.iter(|| black_box(count_reads(Box::<UbxDecoder>::default(), ubx_b)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
