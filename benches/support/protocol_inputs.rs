//! The inputs of the protocol throughput bench: the same 100 000 seeded samples encoded once
//! per decoder, as the device (or recorder) would send them, with the decoder that reads them.

use bytes::BytesMut;
use imuprep::frame::mavlink::{self, MavlinkDecoder, MavlinkOptions};
use imuprep::frame::ubx::{self, UbxDecoder};
use imuprep::frame::ulog::{self, UlogDecoder};
use imuprep::frame::{FrameDecoder, ProtocolDecoder, encode_sample};
use imuprep::rng::Rng;
use imuprep::sample::Sample;

/// IMU samples per input.
pub const N: usize = 100_000;
/// RAW_IMU scales of the bench streams (±2000 °/s and ±16 g at 16 bits: rad/s and m/s² per
/// count), as a user would pass them.
const RAW_GYRO: f64 = 1.065e-3;
const RAW_ACCEL: f64 = 4.788e-3;

/// One decoder's input: its bench name, the encoded bytes, and the decoder that reads them.
pub struct Input {
    pub name: &'static str,
    pub bytes: Vec<u8>,
    pub decoder: fn() -> Box<dyn ProtocolDecoder>,
}

/// 200 Hz, seeded: gyro ~0.1 rad/s, accel ~1 m/s² around gravity, 25 °C.
pub fn samples() -> Vec<Sample> {
    let mut r = Rng::new(1);
    (0..N)
        .map(|i| {
            let mut s = Sample {
                seq: i as u32,
                t_ns: 1_000_000_000 + i as u64 * 5_000_000,
                temp_c: Some(25.0),
                ..Sample::default()
            };
            s.set_channels(&[
                0.1 * r.normal(),
                0.1 * r.normal(),
                0.1 * r.normal(),
                r.normal(),
                r.normal(),
                9.8 + r.normal(),
            ]);
            s
        })
        .collect()
}

/// ESF-MEAS, one message per sample: time tag (ms), flags (numMeas = 7), id, then gyro x/y/z,
/// accel x/y/z and gyro temperature words, as a ZED-F9R sends them.
fn esf_meas(ss: &[Sample], out: &mut BytesMut) {
    for s in ss {
        let mut p = Vec::with_capacity(8 + 7 * 4);
        p.extend_from_slice(&((s.t_ns / 1_000_000) as u32).to_le_bytes());
        p.extend_from_slice(&(7u16 << 11).to_le_bytes());
        p.extend_from_slice(&0u16.to_le_bytes());
        let ch = s.channels();
        let vals = ubx::CHANNEL_TYPES
            .iter()
            .zip(ch)
            .chain([(&ubx::TYPE_GYRO_TEMP, 25.0)]);
        for (&ty, v) in vals {
            let raw = ubx::raw_of(ty, v).expect("finite");
            p.extend_from_slice(&(((ty as u32) << 24) | (raw as u32 & 0x00FF_FFFF)).to_le_bytes());
        }
        ubx::encode_frame(ubx::CLASS_ESF, ubx::ID_ESF_MEAS, &p, out);
    }
}

/// RAW_IMU payload (29 bytes): time µs, accel and gyro counts, mag 0, instance 0, temperature.
fn raw_imu_payload(s: &Sample) -> Vec<u8> {
    let mut p = Vec::with_capacity(29);
    p.extend_from_slice(&(s.t_ns / 1000).to_le_bytes());
    let ch = s.channels();
    let count = |v: f64, unit: f64| ((v / unit).round() as i16).to_le_bytes();
    for a in &ch[3..] {
        p.extend_from_slice(&count(*a, RAW_ACCEL));
    }
    for g in &ch[..3] {
        p.extend_from_slice(&count(*g, RAW_GYRO));
    }
    p.extend_from_slice(&[0u8; 6]); // mag
    p.push(0); // id
    p.extend_from_slice(&2500i16.to_le_bytes()); // 25.00 °C
    p
}

/// A MAVLink v1 frame (the whole payload: v1 does not truncate trailing zeros).
fn encode_v1(seq: u8, msgid: u32, payload: &[u8], out: &mut BytesMut) {
    let start = out.len();
    out.extend_from_slice(&[mavlink::STX_V1, payload.len() as u8, seq, 1, 1, msgid as u8]);
    out.extend_from_slice(payload);
    let extra = mavlink::crc_extra(msgid).expect("IMU message");
    let c = mavlink::checksum(&out[start + 1..], extra);
    out.extend_from_slice(&c.to_le_bytes());
}

fn mavlink_stream(ss: &[Sample], v2: bool, msgid: u32) -> Vec<u8> {
    let mut out = BytesMut::new();
    for (i, s) in ss.iter().enumerate() {
        let p = match msgid {
            mavlink::MSG_HIGHRES_IMU => mavlink::highres_payload(s, 0),
            _ => raw_imu_payload(s),
        };
        if v2 {
            mavlink::encode_v2(i as u8, 1, 1, msgid, &p, &mut out);
        } else {
            encode_v1(i as u8, msgid, &p, &mut out);
        }
    }
    out.to_vec()
}

fn raw_imu_decoder() -> Box<dyn ProtocolDecoder> {
    Box::new(MavlinkDecoder::new(MavlinkOptions {
        message: Some("raw_imu".into()),
        gyro_scale_rad_s: RAW_GYRO,
        accel_scale_m_s2: RAW_ACCEL,
        ..MavlinkOptions::default()
    }))
}

/// Every decoder's input, from the same samples.
pub fn inputs(ss: &[Sample]) -> Vec<Input> {
    let mut native = BytesMut::new();
    for s in ss {
        encode_sample(s, &mut native);
    }
    let mut raw = BytesMut::new();
    for (k, chunk) in ss.chunks(4).enumerate() {
        let sets: Vec<(u32, Sample)> = chunk
            .iter()
            .enumerate()
            .map(|(j, s)| ((((4 * k + j) as u32) * 128) & 0xFF_FFFF, *s))
            .collect();
        ubx::encode_esf_raw(&sets, &mut raw);
    }
    let mut meas = BytesMut::new();
    esf_meas(ss, &mut meas);
    let mut ulg = BytesMut::new();
    ulog::encode_sensor_combined_log(ss, &mut ulg);
    let highres = mavlink::MSG_HIGHRES_IMU;
    let raw_imu = mavlink::MSG_RAW_IMU;
    let mav: fn() -> Box<dyn ProtocolDecoder> = || Box::<MavlinkDecoder>::default();
    let ubx: fn() -> Box<dyn ProtocolDecoder> = || Box::<UbxDecoder>::default();
    #[allow(unused_mut)]
    let mut v = vec![
        Input {
            name: "native",
            bytes: native.to_vec(),
            decoder: || Box::new(FrameDecoder::new()),
        },
        Input {
            name: "ubx_esf_raw",
            bytes: raw.to_vec(),
            decoder: ubx,
        },
        Input {
            name: "ubx_esf_meas",
            bytes: meas.to_vec(),
            decoder: ubx,
        },
        Input {
            name: "mavlink_v1_highres_imu",
            bytes: mavlink_stream(ss, false, highres),
            decoder: mav,
        },
        Input {
            name: "mavlink_v2_highres_imu",
            bytes: mavlink_stream(ss, true, highres),
            decoder: mav,
        },
        Input {
            name: "mavlink_v1_raw_imu",
            bytes: mavlink_stream(ss, false, raw_imu),
            decoder: raw_imu_decoder,
        },
        Input {
            name: "mavlink_v2_raw_imu",
            bytes: mavlink_stream(ss, true, raw_imu),
            decoder: raw_imu_decoder,
        },
        Input {
            name: "ulog_sensor_combined",
            bytes: ulg.to_vec(),
            decoder: || Box::<UlogDecoder>::default(),
        },
    ];
    #[cfg(feature = "ros2")]
    v.push(Input {
        name: "mcap_ros2_imu",
        bytes: imuprep::io::mcap_sink::encode_bag(
            &imuprep::frame::Descriptor::default(),
            ss,
            Default::default(),
        )
        .expect("bag"),
        decoder: || Box::<imuprep::frame::mcap::McapDecoder>::default(),
    });
    v
}
