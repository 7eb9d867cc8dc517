fn main() {
    afl::fuzz!(|data: &[u8]| {
        let mut d = imuprep::frame::ubx::UbxDecoder::new(Default::default());
        imuprep_fuzz::drive(&mut d, data);
    });
}
