//! ROS 2 bags: `McapDecoder` (records, chunks, CRCs, CDR sensor_msgs/msg/Imu).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let mut d = imuprep::frame::mcap::McapDecoder::new(Default::default());
        imuprep_fuzz::drive(&mut d, data);
    });
}
