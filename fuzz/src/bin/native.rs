fn main() {
    afl::fuzz!(|data: &[u8]| {
        let mut d = imuprep::frame::FrameDecoder::new();
        imuprep_fuzz::drive(&mut d, data);
    });
}
