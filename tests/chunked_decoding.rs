//! A file decoded 64 KiB at a time (`decode_file_into`, what `read_any` and `export` use) gives
//! exactly what its bytes decoded whole give (`decode_bytes`): the same protocol, samples (bit
//! for bit), descriptor, counters and findings — on clean streams of every protocol, on the same
//! streams corrupted (seeded byte flips, garbage across the read boundaries, a cut end), on the
//! fuzzer's crash inputs and on the real PX4 ULogs of `../shared` (skipped, said so, if absent).

use imuprep::frame::detect::{DecodedFile, ProtocolConfig, decode_bytes, decode_file_into};
use imuprep::io::convert::{ExportFormat, encode_stream};
use imuprep::rng::Rng;
use imuprep::sample::Sample;
use std::path::Path;

/// A sample as bits: NaN (an absent channel) compares equal to itself.
fn bits(s: &Sample) -> (u32, u64, u32, u8, [u64; 6], Option<u64>) {
    let c = s.channels();
    (
        s.seq,
        s.t_ns,
        s.flags,
        s.absent,
        std::array::from_fn(|i| c[i].to_bits()),
        s.temp_c.map(f64::to_bits),
    )
}

/// Decode `bytes` both ways (written to a file for the chunked one) and compare all.
fn same_both_ways(bytes: &[u8], what: &str) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("input.bin");
    std::fs::write(&path, bytes).unwrap();
    let c = ProtocolConfig::auto();
    let whole: DecodedFile = decode_bytes(bytes, &c);
    let mut samples = Vec::new();
    let chunked = decode_file_into(&path, &c, &mut samples)
        .unwrap()
        .with(samples);
    assert_eq!(chunked.protocol, whole.protocol, "{what}: protocol");
    assert_eq!(chunked.stats, whole.stats, "{what}: counters");
    assert_eq!(chunked.found, whole.found, "{what}: findings");
    assert_eq!(
        format!("{:?}", chunked.descriptor),
        format!("{:?}", whole.descriptor),
        "{what}: descriptor"
    );
    assert_eq!(
        chunked.samples.len(),
        whole.samples.len(),
        "{what}: sample count"
    );
    for (i, (a, b)) in chunked.samples.iter().zip(&whole.samples).enumerate() {
        assert_eq!(bits(a), bits(b), "{what}: sample {i}");
    }
    whole.samples.len()
}

/// The bundled drive log's samples, as a stream in `to`.
fn stream(to: ExportFormat) -> Vec<u8> {
    let (d, s, _) = imuprep::io::log::read_log(Path::new("replay/drive.log")).unwrap();
    // 20 000 samples: every stream spans several 64-KiB reads.
    encode_stream(to, &d.unwrap(), &s[..20_000])
        .unwrap()
        .to_vec()
}

/// `bytes` with `n` seeded byte flips, and garbage straddling each 64-KiB read boundary.
fn corrupted(bytes: &[u8], seed: u64) -> Vec<u8> {
    let mut rng = Rng::new(seed);
    let mut b = bytes.to_vec();
    for _ in 0..200 {
        let i = rng.below(b.len() as u64) as usize;
        b[i] ^= 1 << rng.below(8);
    }
    let mut out = Vec::with_capacity(b.len() + 1024);
    for (i, x) in b.iter().enumerate() {
        if i > 0 && i % 65_536 == 65_536 - 7 {
            out.extend((0..13).map(|_| rng.below(256) as u8));
        }
        out.push(*x);
    }
    out
}

#[test]
fn every_protocol_decodes_the_same_in_pieces_as_whole() {
    let mut formats = vec![
        ExportFormat::Native,
        ExportFormat::Ubx,
        ExportFormat::Mavlink,
        ExportFormat::Ulog,
    ];
    if cfg!(feature = "ros2") {
        formats.push(ExportFormat::Mcap);
    }
    for to in formats {
        let clean = stream(to);
        assert!(clean.len() > 3 * 65_536, "{to:?}: spans several reads");
        // Every sample of a clean stream comes out (a check that the comparison compares).
        assert_eq!(same_both_ways(&clean, &format!("{to:?} clean")), 20_000);
        for seed in 1..=3 {
            let bad = corrupted(&clean, seed);
            same_both_ways(&bad, &format!("{to:?} corrupted, seed {seed}"));
            let cut = &bad[..bad.len() - 1 - (seed as usize * 37) % 200];
            same_both_ways(cut, &format!("{to:?} corrupted and cut, seed {seed}"));
        }
    }
}

#[test]
fn the_fuzzers_inputs_and_empty_files_decode_the_same_in_pieces() {
    same_both_ways(&[], "empty file");
    let dir = Path::new("tests/fixtures/fuzz_crashes");
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        same_both_ways(&std::fs::read(&p).unwrap(), &p.display().to_string());
        n += 1;
    }
    assert!(n > 0, "no fuzz inputs in {}", dir.display());
}

#[test]
fn the_real_ulogs_decode_the_same_in_pieces() {
    let dir = Path::new("../shared/data/real/px4_ulog");
    if !dir.is_dir() {
        eprintln!("SKIPPED: {} is absent", dir.display());
        return;
    }
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "ulg") {
            let got = same_both_ways(&std::fs::read(&p).unwrap(), &p.display().to_string());
            assert!(got > 0, "{}: no samples", p.display());
            n += 1;
        }
    }
    assert_eq!(n, 5, "the five PX4 ULogs");
}
