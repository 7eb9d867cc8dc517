//! Inline re-encoding: cleaned samples written back into the input's own protocol, every other
//! message passed through unchanged and in order.
//!
//! The decoder hands each sample's [`Carrier`] (the original message bytes) to the side stream;
//! the pipeline hands back the cleaned [`Sample`]s in the same order. For each one the encoder
//! copies the carrier, writes the cleaned values at the protocol's resolution (a non-finite
//! cleaned value keeps the original field), fixes the checksum and appends the message. A
//! message that carries several samples (UBX ESF-RAW) is written once its last sample is done.

use super::mcap_out::McapStream;
use super::protocol::{Carrier, Protocol};
use super::{mavlink, ubx, ulog};

use crate::sample::Sample;
use bytes::{Bytes, BytesMut};

/// Re-encodes cleaned samples into their carriers.
pub struct InlineEncoder {
    protocol: Protocol,
    /// RAW_IMU scales (rad/s and m/s² per count) for MAVLink.
    raw_gyro_scale: f64,
    raw_accel_scale: f64,
    /// A multi-sample frame being patched: original, patched copy.
    cur: Option<(Bytes, Vec<u8>)>,
    /// MCAP: the records re-chunked and indexed.
    mcap: McapStream,
}

impl InlineEncoder {
    pub fn new(protocol: Protocol, raw_gyro_scale: f64, raw_accel_scale: f64) -> Self {
        InlineEncoder {
            protocol,
            raw_gyro_scale,
            raw_accel_scale,
            cur: None,
            mcap: McapStream::default(),
        }
    }

    /// Forget the multi-sample frame being patched if it is `frame` (an inline sink dropped one
    /// of its samples: a frame with an unpatched raw slot must not be written as cleaned).
    pub fn discard(&mut self, frame: &Bytes) {
        if matches!(&self.cur, Some((o, _)) if o.as_ptr() == frame.as_ptr() && o.len() == frame.len())
        {
            self.cur = None;
        }
    }

    /// A message that is not IMU data: written unchanged (after any frame still being filled).
    /// MCAP: the records are written into new chunks with their indexes ([`McapStream`]).
    pub fn other(&mut self, b: &[u8], out: &mut BytesMut) {
        self.flush_frame(out);
        if self.protocol == Protocol::Mcap {
            self.mcap.other(b, out);
            return;
        }
        out.extend_from_slice(b);
    }

    /// At the end of the output: what is held (a multi-sample frame whose later samples never
    /// came; an MCAP whose input ended before its data-end record is closed with a summary).
    pub fn flush(&mut self, out: &mut BytesMut) {
        self.flush_frame(out);
        if self.protocol == Protocol::Mcap {
            self.mcap.finish(out);
        }
    }

    /// Write the multi-sample frame being filled, if any.
    fn flush_frame(&mut self, out: &mut BytesMut) {
        if let Some((_, mut f)) = self.cur.take() {
            if self.protocol == Protocol::Ubx {
                ubx::finish(&mut f);
            }
            out.extend_from_slice(&f);
        }
    }

    /// One cleaned sample and the carrier of its raw original.
    pub fn sample(&mut self, c: Option<&Carrier>, s: &Sample, out: &mut BytesMut) {
        let Some(c) = c else {
            if self.protocol == Protocol::Native {
                super::encode_sample(s, out);
            }
            return;
        };
        match self.protocol {
            Protocol::Native => super::encode_sample(s, out),
            Protocol::Mavlink => {
                self.flush_frame(out);
                // RAW_IMU: the scales the decoder read the counts with (from the config).
                let [g, a] = c
                    .raw_scale
                    .unwrap_or([self.raw_gyro_scale, self.raw_accel_scale]);
                mavlink::reencode(&c.frame, s, g, a, out)
            }
            Protocol::Ubx => {
                let same = matches!(&self.cur, Some((o, _)) if o.as_ptr() == c.frame.as_ptr() && o.len() == c.frame.len());
                if !same {
                    self.flush_frame(out);
                    self.cur = Some((c.frame.clone(), c.frame.to_vec()));
                }
                if let Some((_, f)) = self.cur.as_mut() {
                    ubx::patch(f, c.slot, s);
                }
                if c.slot + 1 >= c.slots {
                    self.flush_frame(out);
                    if let Some(b) = &c.between {
                        out.extend_from_slice(b);
                    }
                    if let Some(f2) = &c.frame2 {
                        let mut f2 = f2.to_vec();
                        ubx::patch(&mut f2, 0, s);
                        ubx::finish(&mut f2);
                        out.extend_from_slice(&f2);
                    }
                }
            }
            Protocol::Mcap => {
                self.flush_frame(out);
                let mut f = c.frame.to_vec();
                // offsets: angular_velocity.x in the record (in the inflated data when
                // compressed), compressed, big endian, not patchable.
                let (at, le) = (c.offsets[0] as usize, c.offsets[2] == 0);
                if c.offsets[3] != 0 {
                } else if c.offsets[1] == 0 {
                    super::ros2::patch_imu(&mut f, at, le, s);
                } else {
                    #[cfg(feature = "ros2")]
                    {
                        f = super::mcap::patch_compressed(&f, at, le, s);
                    }
                }
                self.mcap.message(&f, out);
            }
            Protocol::Ulog => {
                self.flush_frame(out);
                let mut f = c.frame.to_vec();
                let mut f2 = c.frame2.as_ref().map(|b| b.to_vec());
                ulog::patch(&mut f, f2.as_deref_mut(), c.offsets, s);
                out.extend_from_slice(&f);
                if let Some(f2) = f2 {
                    out.extend_from_slice(&f2);
                }
            }
        }
    }
}
