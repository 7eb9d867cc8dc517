//! Property: corrupt random bytes of a stream of N good frames; every untouched frame comes
//! out, in order, whatever the chunking.
mod common;

use bytes::BytesMut;
use imuprep::frame::{FrameDecoder, Message, SAMPLE_FRAME_LEN, encode_sample};
use proptest::prelude::*;
use tokio_util::codec::Decoder;

fn decode(bytes: &[u8], chunk: usize) -> Vec<u32> {
    let mut d = FrameDecoder::new();
    let mut buf = BytesMut::new();
    let mut out = Vec::new();
    for c in bytes.chunks(chunk) {
        buf.extend_from_slice(c);
        while let Some(m) = d.decode(&mut buf).unwrap() {
            if let Message::Sample(s) = m {
                out.push(s.seq);
            }
        }
    }
    while let Some(m) = d.decode_eof(&mut buf).unwrap() {
        if let Message::Sample(s) = m {
            out.push(s.seq);
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(20261122), ..ProptestConfig::default() })]
    #[test]
    fn untouched_frames_survive_random_corruption(
        n in 1usize..60,
        hits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..30),
        inserts in proptest::collection::vec((any::<prop::sample::Index>(), proptest::collection::vec(any::<u8>(), 1..40)), 0..4),
        chunk in 1usize..300,
    ) {
        let samples = common::samples(n, 1);
        let mut frames: Vec<Vec<u8>> = samples.iter().map(|s| { let mut b = BytesMut::new(); encode_sample(s, &mut b); b.to_vec() }).collect();
        let mut touched = vec![false; n];
        for (i, v) in &hits {
            let pos = i.index(n * SAMPLE_FRAME_LEN);
            let f = pos / SAMPLE_FRAME_LEN;
            if frames[f][pos % SAMPLE_FRAME_LEN] != *v {
                frames[f][pos % SAMPLE_FRAME_LEN] = *v;
                touched[f] = true;
            }
        }
        // Garbage inserted between frames touches no frame.
        let mut gaps: Vec<Vec<u8>> = vec![Vec::new(); n + 1];
        for (i, g) in &inserts {
            gaps[i.index(n + 1)].extend_from_slice(g);
        }
        let mut stream = Vec::new();
        for f in 0..n {
            stream.extend_from_slice(&gaps[f]);
            stream.extend_from_slice(&frames[f]);
        }
        stream.extend_from_slice(&gaps[n]);
        let got = decode(&stream, chunk);
        let mut it = got.iter();
        for (f, t) in touched.iter().enumerate() {
            if !t {
                prop_assert!(it.any(|g| *g == f as u32), "untouched frame {} lost; got {:?}", f, got);
            }
        }
    }
}
