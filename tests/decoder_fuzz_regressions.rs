//! Inputs the fuzz targets (fuzz/) found to crash, kept as regression tests. Needs
//! `--features ros2` (the MCAP decoder).
//!
//! The three of the 2026-11-24 run (10.3 M executions) all panicked inside the `mcap` crate
//! (read.rs:176, an attachment body sliced before its length is checked) under `frame::mcap`;
//! the decoder now hands the crate only the records it uses (schema, channel, chunk).
#![cfg(feature = "ros2")]

use imuprep::frame::mcap::{McapDecoder, McapOptions};

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(format!(
        "{}/tests/fixtures/fuzz_crashes/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

#[test]
fn mcap_fuzz_crashes_do_not_panic() {
    for name in ["mcap_0.bin", "auto_0.bin", "auto_1.bin"] {
        let data = fixture(name);
        let r = std::panic::catch_unwind(|| {
            if name.starts_with("auto") {
                // The `auto` target: detection + whole-file decoding.
                let cfg = imuprep::frame::detect::ProtocolConfig::auto();
                let _ = imuprep::frame::detect::decode_bytes(&data, &cfg);
                return;
            }
            // The `mcap` target: the first byte is the chunk size; end of stream drains.
            let mut d = McapDecoder::new(McapOptions::default());
            let mut buf = bytes::BytesMut::from(&data[1..]);
            use imuprep::frame::protocol::ProtocolDecoder;
            while d.decode_item_eof(&mut buf).is_some() {}
        });
        assert!(r.is_ok(), "{name} panics");
    }
}
