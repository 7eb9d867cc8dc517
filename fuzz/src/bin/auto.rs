//! Protocol detection and whole-file decoding, as `imuprep import`/`replay` run them.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let f = imuprep::frame::detect::decode_bytes(data, &imuprep::frame::detect::ProtocolConfig::auto());
        assert!(f.samples.len() <= data.len(), "more samples than bytes");
    });
}
