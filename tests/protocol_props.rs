//! Property per protocol decoder: corrupt random bytes of a stream of good messages; no panic,
//! and every untouched IMU message still comes out, in order, whatever the chunking.
use bytes::BytesMut;
use imuprep::frame::mavlink::{self, MavlinkDecoder};
use imuprep::frame::ubx::{self, UbxDecoder};
use imuprep::frame::ulog::{self, UlogDecoder};
use imuprep::frame::{Decoded, ProtocolDecoder};
use imuprep::sample::Sample;
use proptest::prelude::*;

fn sample(i: usize) -> Sample {
    let mut s = Sample {
        t_ns: 1_000_000_000 + i as u64 * 10_000_000,
        temp_c: Some(30.0),
        ..Sample::default()
    };
    // Channel gx carries the message index, so a decoded sample names its message.
    s.set_channels(&[i as f64 * 1e-2, 0.1, -0.1, 0.2, -0.2, -9.8]);
    s
}

/// Messages (one sample each) of a protocol; ULog also needs its header and definitions first.
fn messages(proto: u8, n: usize) -> (Vec<u8>, Vec<Vec<u8>>) {
    let mut head = BytesMut::new();
    let msgs = (0..n)
        .map(|i| {
            let mut b = BytesMut::new();
            match proto {
                0 => ubx::encode_esf_raw(&[((i as u32) * 256, sample(i))], &mut b),
                1 => mavlink::encode_v2(
                    i as u8,
                    1,
                    1,
                    mavlink::MSG_HIGHRES_IMU,
                    &mavlink::highres_payload(&sample(i), 0),
                    &mut b,
                ),
                _ => {
                    let mut all = BytesMut::new();
                    ulog::encode_sensor_combined_log(&[sample(i)], &mut all);
                    let mut hd = BytesMut::new();
                    ulog::encode_sensor_combined_log(&[], &mut hd);
                    b.extend_from_slice(&all[hd.len()..]);
                }
            }
            b.to_vec()
        })
        .collect();
    if proto == 2 {
        ulog::encode_sensor_combined_log(&[], &mut head);
    }
    (head.to_vec(), msgs)
}

fn decoder(proto: u8) -> Box<dyn ProtocolDecoder> {
    match proto {
        0 => Box::new(UbxDecoder::default()),
        1 => Box::new(MavlinkDecoder::default()),
        _ => Box::new(UlogDecoder::default()),
    }
}

fn decode(proto: u8, bytes: &[u8], chunk: usize) -> Vec<usize> {
    let mut d = decoder(proto);
    let mut buf = BytesMut::new();
    let mut out = Vec::new();
    let mut take = |x: Decoded| {
        if let Decoded::Sample(s, _) = x {
            out.push((s.gyro[0] * 100.0).round() as usize);
        }
    };
    for c in bytes.chunks(chunk) {
        buf.extend_from_slice(c);
        while let Some(x) = d.decode_item(&mut buf) {
            take(x);
        }
    }
    while let Some(x) = d.decode_item_eof(&mut buf) {
        take(x);
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(1414), ..ProptestConfig::default() })]
    #[test]
    fn untouched_messages_survive_random_corruption(
        proto in 0u8..3,
        n in 1usize..40,
        hits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..20),
        chunk in 1usize..200,
    ) {
        let (head, mut msgs) = messages(proto, n);
        let mut touched = vec![false; n];
        for (i, v) in &hits {
            let f = i.index(n);
            let pos = i.index(msgs[f].len());
            if msgs[f][pos] != *v {
                msgs[f][pos] = *v;
                touched[f] = true;
            }
        }
        let mut stream = head;
        for m in &msgs {
            stream.extend_from_slice(m);
        }
        let got = decode(proto, &stream, chunk);
        let mut it = got.iter();
        for (f, t) in touched.iter().enumerate() {
            // ULog has no checksum: a corrupt message may hide the next one's start, so only
            // the checksummed protocols promise every untouched message.
            if !t && proto < 2 {
                prop_assert!(it.any(|g| *g == f), "proto {} lost untouched message {}; got {:?}", proto, f, got);
            }
        }
    }
}

/// A message of `proto` that is not IMU data, naming `j` (UBX MON-VER-like frame, MAVLink
/// HEARTBEAT, ULog logged string).
fn other_message(proto: u8, j: usize) -> Vec<u8> {
    let mut b = BytesMut::new();
    let id = (j as u32).to_le_bytes();
    match proto {
        0 => ubx::encode_frame(0x0A, 0x04, &id, &mut b),
        1 => {
            let mut p = [0u8; 9];
            p[..4].copy_from_slice(&id);
            mavlink::encode_v2(0, 1, 1, 0, &p, &mut b)
        }
        _ => {
            // size u16, 'L', log level, u64 time, text.
            let text = format!("note {j}");
            let size = (1 + 8 + text.len()) as u16;
            b.extend_from_slice(&size.to_le_bytes());
            b.extend_from_slice(b"L6");
            b.extend_from_slice(&0u64.to_le_bytes());
            b.extend_from_slice(text.as_bytes());
        }
    }
    b.to_vec()
}

/// What came out, in order: `S(i)` a sample of message `i` (with its seq and flags), `O(j)` the
/// inserted other message `j`, `D(rate)` a descriptor; other items (ULog's header) left out.
#[derive(Debug, PartialEq)]
enum Out {
    S(usize, u32, u32),
    O(usize),
    D(f64),
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(20261125), ..ProptestConfig::default() })]
    /// The decoders learn the period from the first 15 intervals; a gap among them (interval
    /// `at`, `missing` samples long) is flagged on the sample after it and counted, the
    /// sequence counts the missing samples (seq = message index), every sample and every other
    /// message comes out once, in input order, with the descriptor right after the sample it
    /// was learned on, whatever the chunking. Before the first samples were held, the
    /// decoders flagged no gap here.
    #[test]
    fn a_gap_among_the_first_intervals_is_flagged_and_nothing_is_lost(
        proto in 0u8..3,
        n in 1usize..40,
        at in 1usize..17,
        missing in 1usize..6,
        others in proptest::collection::vec(0usize..3, 60),
        chunk in 1usize..300,
    ) {
        let total = n + missing + at;
        let (head, msgs) = messages(proto, total);
        let kept: Vec<usize> = (0..total).filter(|i| !(at..at + missing).contains(i)).collect();
        let mut stream = head;
        let mut want = Vec::new();
        let mut j = 0;
        for (k, &i) in kept.iter().enumerate() {
            stream.extend_from_slice(&msgs[i]);
            let gap = i == at + missing;
            let flags = if gap { imuprep::sample::flags::GAP } else { 0 };
            want.push(Out::S(i, i as u32, flags));
            if k == 15 {
                // Learned on the 16th sample (15 intervals): sensor_combined and HIGHRES_IMU at
                // 10 ms, ESF-RAW tags 256 ticks of 39.0625 µs apart (10 ms).
                want.push(Out::D(100.0));
            }
            for _ in 0..others[k % others.len()] {
                stream.extend_from_slice(&other_message(proto, j));
                want.push(Out::O(j));
                j += 1;
            }
        }
        let inserted: Vec<Vec<u8>> = (0..j).map(|j| other_message(proto, j)).collect();
        let mut d = decoder(proto);
        let (items, st) = imuprep::frame::protocol::decode_chunked(d.as_mut(), &stream, chunk);
        let got: Vec<Out> = items
            .iter()
            .filter_map(|x| match x {
                Decoded::Sample(s, _) => Some(Out::S(
                    (s.gyro[0] * 100.0).round() as usize,
                    s.seq,
                    s.flags & (imuprep::sample::flags::GAP | imuprep::sample::flags::DUPLICATE),
                )),
                Decoded::Other(b) => inserted.iter().position(|m| m[..] == b[..]).map(Out::O),
                Decoded::Descriptor(d) => Some(Out::D((d.sample_rate_hz * 1e6).round() / 1e6)),
            })
            .collect();
        // With fewer than 16 samples the stream is too short to learn the period: no rate, no
        // gap flagged (the input ended first), every sample and message still out in order.
        let short = kept.len() < 16;
        let want: Vec<Out> = if short {
            want.into_iter()
                .map(|o| match o {
                    Out::S(i, _, _) => Out::S(i, kept.iter().position(|k| *k == i).unwrap() as u32, 0),
                    o => o,
                })
                .collect()
        } else {
            want
        };
        prop_assert_eq!(&got, &want, "proto {} at {} missing {} chunk {}", proto, at, missing, chunk);
        prop_assert_eq!(st.samples, kept.len() as u64);
        let (gaps, lost) = if short { (0, 0) } else { (1, missing as u64) };
        prop_assert_eq!((st.gaps, st.missing_frames, st.duplicates), (gaps, lost, 0));
    }
}
