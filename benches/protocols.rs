//! Decoder throughput per protocol beside the native decoder, same run, one core.
//!
//! `cargo bench --features ros2 --bench protocols` — every decoder on the same 100 000 seeded
//! samples (`support/protocol_inputs.rs`): native, UBX ESF-RAW (4 sets per message, as
//! receivers batch them) and ESF-MEAS (one message per sample), MAVLink v1 and v2 HIGHRES_IMU
//! and RAW_IMU, ULog `sensor_combined`, and with `ros2` a ROS 2 bag (MCAP as the `mcap:` sink
//! writes it: 1 MiB chunks with CRCs, one `sensor_msgs/msg/Imu` per sample, CRCs checked).
//! Before timing, each decoder is checked to give all 100 000 samples.
//!
//! Groups (criterion prints samples/s as `elem/s`; the medians are in
//! `target/criterion/GROUP/DECODER/new/estimates.json`):
//! - `decode_cpu`: decoding only, in the thread's CPU time (`support/thread_cpu.rs`, which a
//!   loaded shared machine inflates far less than wall time). The whole input is copied into
//!   a fresh buffer and the decoder made in criterion's set-up, outside the timed part; the
//!   buffer and decoder are dropped outside it too (`iter_batched`, one input per iteration).
//! - `decode_wall`: the same in wall time.
//! - `decode_64k_reads_cpu`: 64 KiB reads appended to one reused buffer, each decoded until
//!   the decoder needs more, then end of input — as the replay source (`FramedRead`) and the
//!   log reader feed a decoder: decoding plus one copy of every byte, CPU time.
//!
//! Groups `ubx_rework_64k_reads` (wall time) and `ubx_rework_64k_reads_cpu`: the UBX decoder
//! before the per-sample rework (`support/ubx_before.rs`, kept verbatim as the in-run
//! baseline) and now, on the same stream and reads, one right after the other
//! (`-- ubx_rework`). For a count that load does not move, `--test` runs each routine once, so
//! the instructions of one 100 000-sample decode are those of `valgrind --tool=cachegrind
//! --cache-sim=no BENCH --bench --test ubx_rework_64k_reads/before` minus those with a filter
//! that matches nothing (the stream set-up); `cg_annotate` splits them by function.

use bytes::BytesMut;
use criterion::measurement::Measurement;
use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use imuprep::frame::ubx::UbxDecoder;
use imuprep::frame::{Decoded, ProtocolDecoder};
use std::hint::black_box;

#[path = "support/protocol_inputs.rs"]
mod protocol_inputs;
#[path = "support/thread_cpu.rs"]
mod thread_cpu;
#[path = "support/ubx_before.rs"]
mod ubx_before;
use protocol_inputs::{Input, N, inputs, samples};
use thread_cpu::ThreadCpu;

/// Bytes per read in the `_64k_reads` groups (the log reader's read size).
const READ: usize = 64 * 1024;

/// Samples decoded and the sum of their sequence numbers (so nothing is optimised away).
#[derive(Default)]
struct Tally {
    samples: u64,
    seq_sum: u64,
}

impl Tally {
    fn add(&mut self, x: Decoded) {
        if let Decoded::Sample(s, _) = x {
            self.samples += 1;
            self.seq_sum += s.seq as u64;
        }
    }
}

/// Decode a whole buffer, then end of input.
fn drain(d: &mut dyn ProtocolDecoder, buf: &mut BytesMut) -> Tally {
    let mut t = Tally::default();
    while let Some(x) = d.decode_item(buf) {
        t.add(x);
    }
    while let Some(x) = d.decode_item_eof(buf) {
        t.add(x);
    }
    t
}

/// Feed `bytes` in 64 KiB reads into one buffer, decoding after each, then end of input.
fn count_reads(mut d: Box<dyn ProtocolDecoder>, bytes: &[u8]) -> Tally {
    let mut buf = BytesMut::with_capacity(2 * READ);
    let mut t = Tally::default();
    for c in bytes.chunks(READ) {
        buf.extend_from_slice(c);
        while let Some(x) = d.decode_item(&mut buf) {
            t.add(x);
        }
    }
    while let Some(x) = d.decode_item_eof(&mut buf) {
        t.add(x);
    }
    t
}

/// Decoding only: input buffer and decoder made in the set-up, both dropped after timing.
fn whole<M: Measurement>(c: &mut Criterion<M>, group: &str, ins: &[Input]) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(N as u64));
    for i in ins {
        g.bench_function(i.name, |b| {
            b.iter_batched(
                || ((i.decoder)(), BytesMut::from(&i.bytes[..])),
                |(mut d, mut buf)| {
                    let t = drain(d.as_mut(), &mut buf);
                    (black_box(t.seq_sum), d, buf)
                },
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

fn reads<M: Measurement>(c: &mut Criterion<M>, group: &str, ins: &[Input]) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(N as u64));
    for i in ins {
        g.bench_function(i.name, |b| {
            b.iter(|| black_box(count_reads((i.decoder)(), &i.bytes).seq_sum))
        });
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    let ins = inputs(&samples());
    for i in &ins {
        // A decoder that lost samples would be measured on less work: refuse to time it.
        let got = drain((i.decoder)().as_mut(), &mut BytesMut::from(&i.bytes[..])).samples;
        assert_eq!(got, N as u64, "{}: decoded {got} of {N} samples", i.name);
    }
    let mut cpu = Criterion::default()
        .with_measurement(ThreadCpu)
        .configure_from_args();
    whole(&mut cpu, "decode_cpu", &ins);
    whole(c, "decode_wall", &ins);
    reads(&mut cpu, "decode_64k_reads_cpu", &ins);
    let ubx_b = &ins
        .iter()
        .find(|i| i.name == "ubx_esf_raw")
        .expect("ubx")
        .bytes;
    ubx_rework(c, "ubx_rework_64k_reads", ubx_b);
    ubx_rework(&mut cpu, "ubx_rework_64k_reads_cpu", ubx_b);
}

/// The UBX decoder before the rework and now, same stream, same reads, one after the other.
fn ubx_rework<M: Measurement>(c: &mut Criterion<M>, name: &str, ubx_b: &[u8]) {
    let mut g = c.benchmark_group(name);
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("before", |b| {
        b.iter(|| {
            black_box(count_reads(Box::<ubx_before::UbxDecoderBefore>::default(), ubx_b).seq_sum)
        })
    });
    g.bench_function("after", |b| {
        b.iter(|| black_box(count_reads(Box::<UbxDecoder>::default(), ubx_b).seq_sum))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
