fn main() {
    afl::fuzz!(|data: &[u8]| {
        let mut d = imuprep::frame::mavlink::MavlinkDecoder::new(Default::default());
        imuprep_fuzz::drive(&mut d, data);
    });
}
