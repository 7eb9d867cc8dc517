//! Decode + pass-through pipeline + encode throughput on one core (issue 2's figure).
//!
//! `cargo bench --bench pipeline` — criterion prints the median time per 100 000 frames and the
//! throughput in frames/s (elements/s).

use bytes::BytesMut;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imuprep::frame::{FrameDecoder, Message, encode_sample};
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use imuprep::stage::Pipeline;
use std::hint::black_box;
use tokio_util::codec::Decoder;

const N: usize = 100_000;

fn input() -> Vec<u8> {
    let mut r = Rng::new(1);
    let mut b = BytesMut::new();
    for i in 0..N {
        let mut s = Sample {
            temp_c: Some(25.0),
            ..Sample::nth(i, 5_000_000)
        };
        s.set_channels(&[
            r.normal(),
            r.normal(),
            r.normal(),
            r.normal(),
            r.normal(),
            9.8 + r.normal(),
        ]);
        encode_sample(&s, &mut b);
    }
    b.to_vec()
}

fn bench(c: &mut Criterion) {
    let bytes = input();
    let mut g = c.benchmark_group("spine");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("decode_passthrough_encode_100k", |b| {
        let mut out = BytesMut::with_capacity(bytes.len() + 1024);
        b.iter(|| {
            let mut dec = FrameDecoder::new();
            let mut p = Pipeline::pass_through();
            let mut buf = BytesMut::from(&bytes[..]);
            out.clear();
            let mut done = Vec::with_capacity(1);
            while let Some(m) = dec.decode(&mut buf).unwrap() {
                if let Message::Sample(s) = m {
                    done.clear();
                    p.push(s, &mut done);
                    for o in &done {
                        encode_sample(o, &mut out);
                    }
                }
            }
            black_box(out.len())
        })
    });
    g.bench_function("decode_only_100k", |b| {
        b.iter(|| {
            let mut dec = FrameDecoder::new();
            let mut buf = BytesMut::from(&bytes[..]);
            let mut n = 0u64;
            while let Some(m) = dec.decode(&mut buf).unwrap() {
                if let Message::Sample(s) = m {
                    n += s.seq as u64;
                }
            }
            black_box(n)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
