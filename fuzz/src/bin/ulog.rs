fn main() {
    afl::fuzz!(|data: &[u8]| {
        let mut d = imuprep::frame::ulog::UlogDecoder::new(Default::default());
        imuprep_fuzz::drive(&mut d, data);
    });
}
