//! `tokio_util::codec` decoder and encoder for the native frame format.
//!
//! The decoder never returns `Err` for bad data: a bad frame is a counted fault, and the stream
//! goes on. On any fault it advances a single byte past the suspect sync word and searches again,
//! so a good frame that sits next to garbage — even inside a frame whose length lied — is still
//! found. It also tracks the sample sequence counter (gaps, duplicates, restarts) and flags
//! non-finite and saturated values using the last descriptor's ranges.

use super::*;
use bytes::{Buf, BytesMut};
use tokio_util::codec::Decoder;

/// Every fault and every frame the decoder has seen, since it was created.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct DecoderStats {
    /// Bytes fed to the decoder.
    pub bytes_in: u64,
    /// Good frames decoded (descriptors and samples).
    pub frames_ok: u64,
    pub descriptors: u64,
    pub samples: u64,
    /// Bytes skipped while searching for a sync word.
    pub garbage_bytes: u64,
    /// Times the decoder had to search for the next sync word after a fault or garbage.
    pub resyncs: u64,
    /// Headers whose CRC-16 failed (includes corrupt lengths).
    pub header_errors: u64,
    /// Headers that passed the check but declared an impossible length or unknown version.
    pub bad_length: u64,
    /// Frames whose CRC-32C failed.
    pub crc_errors: u64,
    /// Good frames of a message type this build does not know (skipped).
    pub unknown_type: u64,
    /// Good frames whose payload length does not match their type (skipped).
    pub bad_payload: u64,
    /// Partial frames left at end of stream.
    pub truncated: u64,
    /// Sequence gaps seen, and frames missing in them.
    pub gaps: u64,
    pub missing_frames: u64,
    /// Samples repeating (or going back to) a sequence number already seen.
    pub duplicates: u64,
    /// Large backward sequence jumps taken as a sensor restart.
    pub seq_restarts: u64,
    /// Samples with a NaN/Inf channel, and samples with a saturated axis.
    pub non_finite: u64,
    pub saturated: u64,
    /// Samples whose time stamp went backwards (protocols that carry time but no counter).
    pub time_backwards: u64,
    /// Good messages that are not IMU data of the selected stream (NMEA, GNSS, heartbeats, other
    /// topics, other IMU instances): skipped by the sample path, passed through by inline sinks.
    pub other_messages: u64,
    /// Bytes of those messages.
    pub other_bytes: u64,
    /// Samples assembled with a channel missing (e.g. a UBX time tag without all six axes);
    /// the missing channel is NaN and flagged non-finite.
    pub partial_samples: u64,
    /// Messages passed through whose checksum could not be verified (MAVLink message ids
    /// without a known CRC-extra).
    pub unverified: u64,
    /// Health reports ([`MSG_HEALTH`] frames) met in the stream: not samples, skipped by the
    /// sample path.
    pub health_frames: u64,
}

/// Share of the input bytes that may be garbage before a run is called mostly garbage.
pub const GARBAGE_LIMIT: f64 = 0.5;

impl DecoderStats {
    /// What is wrong with an input that produced `samples` samples, if anything an offline
    /// command must not pass over in silence: nothing decoded at all, or most of the bytes
    /// garbage (more than [`GARBAGE_LIMIT`] of them skipped while searching for frames, or lost
    /// in frames that failed their checks).
    pub fn input_problem(&self, samples: u64) -> Option<String> {
        use crate::text::count;
        let lost = self.garbage_bytes;
        if samples == 0 {
            return Some(format!(
                "no samples decoded from {} of input ({}, {}, {}, {}): nothing was published",
                count(self.bytes_in, "byte", "bytes"),
                count(lost, "garbage byte", "garbage bytes"),
                count(self.crc_errors, "CRC error", "CRC errors"),
                count(self.header_errors, "header error", "header errors"),
                count(self.truncated, "truncated frame", "truncated frames")
            ));
        }
        if self.bytes_in > 0 && lost as f64 > GARBAGE_LIMIT * self.bytes_in as f64 {
            return Some(format!(
                "most of the input was garbage: {} of {} bytes ({:.0} %) skipped; only {} decoded",
                lost,
                self.bytes_in,
                100.0 * lost as f64 / self.bytes_in as f64,
                count(samples, "sample", "samples")
            ));
        }
        None
    }
}

/// Backward sequence jumps up to this many frames are late duplicates; larger ones a restart.
const DUPLICATE_WINDOW: i32 = 1024;

/// Native-frame decoder with fault counting and sequence tracking.
#[derive(Debug, Default, Clone)]
pub struct FrameDecoder {
    stats: DecoderStats,
    last_seq: Option<u32>,
    descriptor: Option<Descriptor>,
    /// Bytes of the buffer already counted in `bytes_in`.
    counted: usize,
    /// True while skipping garbage (so a run of garbage counts as one resync).
    in_garbage: bool,
}

impl FrameDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// A decoder that already knows the sensor (e.g. from a log header).
    pub fn with_descriptor(d: Descriptor) -> Self {
        FrameDecoder {
            descriptor: Some(d),
            ..Self::default()
        }
    }

    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// The last descriptor seen, if any.
    pub fn descriptor(&self) -> Option<Descriptor> {
        self.descriptor
    }

    fn skip(&mut self, buf: &mut BytesMut, n: usize) {
        buf.advance(n);
        self.counted = self.counted.saturating_sub(n);
    }

    /// Drop one byte after a fault at a sync word and note the resync.
    fn fault_skip(&mut self, buf: &mut BytesMut) {
        self.skip(buf, 1);
        self.stats.resyncs += 1;
        self.in_garbage = true;
    }

    fn track_sequence(&mut self, s: &mut Sample) {
        if let Some(last) = self.last_seq {
            let diff = s.seq.wrapping_sub(last) as i32;
            if diff == 1 {
                self.last_seq = Some(s.seq);
            } else if diff > 1 {
                s.flags |= flags::GAP;
                self.stats.gaps += 1;
                self.stats.missing_frames += (diff - 1) as u64;
                self.last_seq = Some(s.seq);
            } else if diff > -DUPLICATE_WINDOW {
                // Same or slightly older number: a repeat. Keep our place in the sequence.
                s.flags |= flags::DUPLICATE;
                self.stats.duplicates += 1;
            } else {
                s.flags |= flags::GAP;
                self.stats.seq_restarts += 1;
                self.last_seq = Some(s.seq);
            }
        } else {
            self.last_seq = Some(s.seq);
        }
    }

    /// Try to take one good frame from the front of `buf`. `Ok(None)` = need more bytes.
    fn decode_one(&mut self, buf: &mut BytesMut) -> Option<Message> {
        loop {
            // 1. Find the sync word; everything before it is garbage.
            let pos = buf.windows(2).position(|w| w == SYNC);
            let skip = match pos {
                Some(p) => p,
                // Keep a trailing 0xA5: it may be the first half of the next sync word.
                None => buf.len() - usize::from(buf.last() == Some(&SYNC[0])),
            };
            if skip > 0 {
                self.stats.garbage_bytes += skip as u64;
                if !self.in_garbage {
                    self.stats.resyncs += 1;
                    self.in_garbage = true;
                }
                self.skip(buf, skip);
            }
            if pos.is_none() || buf.len() < HEADER_LEN {
                return None;
            }
            // 2. Header check before trusting the length.
            let hc = u16::from_le_bytes([buf[10], buf[11]]);
            if CRC16.checksum(&buf[..10]) != hc {
                self.stats.header_errors += 1;
                self.fault_skip(buf);
                continue;
            }
            let len = u16::from_le_bytes([buf[4], buf[5]]) as usize;
            if buf[2] != VERSION || len > MAX_PAYLOAD {
                self.stats.bad_length += 1;
                self.fault_skip(buf);
                continue;
            }
            let total = HEADER_LEN + len + TRAILER_LEN;
            if buf.len() < total {
                buf.reserve(total - buf.len());
                return None;
            }
            // 3. Whole-frame CRC.
            let crc = u32::from_le_bytes(buf[total - 4..total].try_into().expect("4 bytes"));
            if crc32c(&buf[..total - 4]) != crc {
                self.stats.crc_errors += 1;
                self.fault_skip(buf);
                continue;
            }
            // A good frame: its boundaries are now trustworthy.
            self.in_garbage = false;
            let ty = buf[3];
            let seq = u32::from_le_bytes(buf[6..10].try_into().expect("4 bytes"));
            let payload = &buf[HEADER_LEN..HEADER_LEN + len];
            let msg = match (ty, len) {
                (MSG_DESCRIPTOR, DESCRIPTOR_PAYLOAD) => {
                    let d = parse_descriptor(payload);
                    self.descriptor = Some(d);
                    self.stats.descriptors += 1;
                    Some(Message::Descriptor(d))
                }
                (MSG_SAMPLE, SAMPLE_PAYLOAD) | (MSG_CLEAN_SAMPLE, CLEAN_SAMPLE_PAYLOAD) => {
                    let mut s = parse_sample(seq, payload, ty == MSG_CLEAN_SAMPLE);
                    self.track_sequence(&mut s);
                    // The channels the last descriptor declares absent are no measurement,
                    // then the same value rule as every protocol's decoder.
                    let absent = self.descriptor.map_or(0, |d| d.absent);
                    protocol::mark_absent(&mut s, absent);
                    protocol::flag_values(&mut s, self.descriptor.as_ref(), &mut self.stats);
                    self.stats.samples += 1;
                    Some(Message::Sample(s))
                }
                (MSG_HEALTH, _) => match health::parse_health(payload) {
                    Some(h) => {
                        self.stats.health_frames += 1;
                        Some(Message::Health(h))
                    }
                    None => {
                        self.stats.bad_payload += 1;
                        None
                    }
                },
                (MSG_DESCRIPTOR | MSG_SAMPLE | MSG_CLEAN_SAMPLE, _) => {
                    self.stats.bad_payload += 1;
                    None
                }
                _ => {
                    self.stats.unknown_type += 1;
                    None
                }
            };
            self.skip(buf, total);
            if let Some(m) = msg {
                self.stats.frames_ok += 1;
                return Some(m);
            }
        }
    }

    fn count_input(&mut self, buf: &BytesMut) {
        if buf.len() > self.counted {
            self.stats.bytes_in += (buf.len() - self.counted) as u64;
        }
        self.counted = buf.len();
    }
}

impl Decoder for FrameDecoder {
    type Item = Message;
    type Error = std::io::Error;

    fn decode(&mut self, buf: &mut BytesMut) -> Result<Option<Message>, std::io::Error> {
        self.count_input(buf);
        Ok(self.decode_one(buf))
    }

    fn decode_eof(&mut self, buf: &mut BytesMut) -> Result<Option<Message>, std::io::Error> {
        self.count_input(buf);
        loop {
            if let Some(m) = self.decode_one(buf) {
                return Ok(Some(m));
            }
            if buf.is_empty() {
                return Ok(None);
            }
            // What is left cannot complete: a truncated frame (or a lone sync byte). With no
            // other sync word in it, it is that one frame's bytes, counted as the truncated
            // frame only (not also as a resync and garbage); else step past its first byte in
            // case a complete frame hides inside it.
            if buf.len() >= 2 && buf[..2] == SYNC {
                self.stats.truncated += 1;
                if buf[1..].windows(2).any(|w| w == SYNC) {
                    self.fault_skip(buf);
                } else {
                    let n = buf.len();
                    self.skip(buf, n);
                    return Ok(None);
                }
            } else {
                self.stats.garbage_bytes += buf.len() as u64;
                let n = buf.len();
                self.skip(buf, n);
                return Ok(None);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn sample(seq: u32) -> Sample {
        let mut s = Sample {
            seq,
            t_ns: 5_000_000 * seq as u64,
            temp_c: Some(25.5),
            ..Sample::default()
        };
        s.set_channels(&[0.01 * seq as f64, -0.02, 0.03, 0.1, -0.2, 9.81]);
        s
    }

    fn stream(n: u32) -> (BytesMut, Vec<Sample>) {
        let mut b = BytesMut::new();
        let mut v = Vec::new();
        for i in 0..n {
            let s = sample(i);
            encode_sample(&s, &mut b);
            v.push(s);
        }
        (b, v)
    }

    /// Feed all of `bytes` in chunks of `chunk` and collect the samples.
    fn decode_all(bytes: &[u8], chunk: usize) -> (Vec<Sample>, DecoderStats) {
        let mut d = FrameDecoder::new();
        let mut buf = BytesMut::new();
        let mut out = Vec::new();
        for c in bytes.chunks(chunk.max(1)) {
            buf.extend_from_slice(c);
            while let Some(m) = d.decode(&mut buf).unwrap() {
                if let Message::Sample(s) = m {
                    out.push(s);
                }
            }
        }
        while let Some(m) = d.decode_eof(&mut buf).unwrap() {
            if let Message::Sample(s) = m {
                out.push(s);
            }
        }
        (out, d.stats())
    }

    /// Values as they survive the f32 wire.
    fn wire(s: &Sample) -> [f32; 6] {
        s.channels().map(|v| v as f32)
    }

    #[test]
    fn crc32c_matches_the_standard_check_value() {
        // CRC-32C check value of "123456789" (RFC 3720 / the CRC catalogue): 0xE3069283.
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    }

    #[test]
    fn round_trip_descriptor_and_sample() {
        let d = Descriptor {
            sample_rate_hz: 200.0,
            gyro_range_rad_s: 8.7,
            accel_range_m_s2: 156.9,
            axes: AxisConvention::Frd,
            device_id: 42,
            absent: 0,
        };
        let mut b = BytesMut::new();
        encode_descriptor(&d, &mut b);
        let s = sample(3);
        encode_sample(&s, &mut b);
        assert_eq!(
            b.len(),
            HEADER_LEN + DESCRIPTOR_PAYLOAD + 4 + SAMPLE_FRAME_LEN
        );
        let mut dec = FrameDecoder::new();
        assert_eq!(dec.decode(&mut b).unwrap(), Some(Message::Descriptor(d)));
        let Some(Message::Sample(got)) = dec.decode(&mut b).unwrap() else {
            panic!("expected a sample")
        };
        assert_eq!(got.seq, 3);
        assert_eq!(got.t_ns, s.t_ns);
        assert_eq!(wire(&got), wire(&s));
        assert_eq!(got.temp_c, Some(25.5));
    }

    #[test]
    fn descriptor_absent_mask_marks_the_samples_and_old_descriptors_read_all_present() {
        let d = Descriptor {
            sample_rate_hz: 100.0,
            gyro_range_rad_s: 4.0,
            absent: 0b111_000, // gyro-only
            ..Descriptor::default()
        };
        let mut b = BytesMut::new();
        encode_descriptor(&d, &mut b);
        // Byte 17 of the payload (reserved, 0, before partial sensors) holds the mask.
        assert_eq!(b[HEADER_LEN + 17], 0b111_000);
        let mut s = sample(0);
        s.absent = 0b111_000;
        s.accel[0] = 0.0; // whatever an absent channel holds, the wire says NaN
        encode_sample(&s, &mut b);
        let mut s1 = sample(1);
        s1.accel[2] = 1e9; // beyond no range: absent, so not saturated either
        encode_sample(&s1, &mut b);
        let (got, st) = {
            let mut dec = FrameDecoder::new();
            let mut out = Vec::new();
            while let Some(m) = dec.decode(&mut b).unwrap() {
                if let Message::Sample(x) = m {
                    out.push(x);
                }
            }
            (out, dec.stats())
        };
        assert_eq!(got.len(), 2);
        for g in &got {
            assert_eq!(g.absent, 0b111_000);
            assert!(g.accel.iter().all(|v| v.is_nan()));
            assert!(g.gyro.iter().all(|v| v.is_finite()));
            assert_eq!(g.flags & (flags::NON_FINITE | flags::SAT_ANY), 0);
        }
        assert_eq!((st.non_finite, st.saturated), (0, 0));
        // A descriptor from before (byte 17 = 0): all present, NaN is a non-finite value.
        let mut b = BytesMut::new();
        encode_descriptor(&Descriptor::default(), &mut b);
        let mut s = sample(0);
        s.accel[0] = f64::NAN;
        encode_sample(&s, &mut b);
        let (got, st) = decode_all(&b, b.len());
        assert_eq!(got[0].absent, 0);
        assert!(got[0].has(flags::NON_FINITE));
        assert_eq!(st.non_finite, 1);
    }

    #[test]
    fn clean_sample_carries_bias_and_sigma() {
        let mut s = sample(1);
        s.flags |= flags::BIAS_REMOVED;
        s.bias = [1e-3, 2e-3, 3e-3, 0.01, 0.02, 0.03];
        s.bias_sd = [1e-4; 6];
        s.temp_c = None;
        let mut b = BytesMut::new();
        encode_sample(&s, &mut b);
        let (out, _) = decode_all(&b, b.len());
        assert_eq!(out[0].bias, s.bias);
        assert_eq!(out[0].bias_sd, s.bias_sd);
        assert_eq!(out[0].temp_c, None, "absent temperature survives as absent");
    }

    #[test]
    fn frames_split_at_every_byte_boundary() {
        let (b, want) = stream(5);
        for chunk in 1..=b.len() {
            let (got, st) = decode_all(&b, chunk);
            assert_eq!(got.len(), want.len(), "chunk {chunk}");
            assert_eq!(st.resyncs, 0, "chunk {chunk}");
            assert_eq!(st.bytes_in, b.len() as u64, "chunk {chunk}");
        }
    }

    #[test]
    fn garbage_prefix_is_skipped_and_counted() {
        let (b, want) = stream(3);
        let mut bytes = vec![0x00, 0xA5, 0x13, 0x5A, 0xA5, 0xFF, 0x42];
        bytes.extend_from_slice(&b);
        let (got, st) = decode_all(&bytes, 3);
        assert_eq!(got.len(), want.len());
        assert_eq!(st.garbage_bytes, 7);
        assert_eq!(st.resyncs, 1);
    }

    #[test]
    fn bad_crc_loses_only_that_frame() {
        let (mut b, _) = stream(3);
        b[SAMPLE_FRAME_LEN + 20] ^= 0x01; // payload of frame 1
        let (got, st) = decode_all(&b, 7);
        assert_eq!(got.iter().map(|s| s.seq).collect::<Vec<_>>(), vec![0, 2]);
        assert_eq!(st.crc_errors, 1);
        assert_eq!(got[1].flags & flags::GAP, flags::GAP);
        assert_eq!(st.missing_frames, 1);
    }

    #[test]
    fn lying_length_with_valid_header_check_does_not_swallow_next_frame() {
        // A sender bug: header says 200 bytes (header CRC recomputed, so it passes), but the
        // frame is a normal sample. The CRC-32C then fails and the next frame is still found.
        // Five frames, so that the lied-about 216 bytes are all there and the CRC is checked.
        let (mut b, _) = stream(5);
        b[4..6].copy_from_slice(&200u16.to_le_bytes());
        let hc = CRC16.checksum(&b[..10]);
        b[10..12].copy_from_slice(&hc.to_le_bytes());
        let (got, st) = decode_all(&b, 5);
        assert_eq!(
            got.iter().map(|s| s.seq).collect::<Vec<_>>(),
            vec![1, 2, 3, 4]
        );
        assert_eq!(st.crc_errors, 1);
    }

    #[test]
    fn corrupt_length_is_caught_by_the_header_check() {
        let (mut b, _) = stream(2);
        b[5] = 0xFF; // length 65k+: the decoder must not wait for it
        let (got, st) = decode_all(&b, b.len());
        assert_eq!(got.len(), 1);
        assert_eq!(st.header_errors, 1);
    }

    #[test]
    fn truncated_frame_at_end_is_counted() {
        let (b, _) = stream(3);
        let cut = &b[..b.len() - 10];
        let (got, st) = decode_all(cut, 16);
        assert_eq!(got.len(), 2);
        assert_eq!(st.truncated, 1);
        // Its bytes are the truncated frame's, not also a resync and garbage.
        assert_eq!((st.resyncs, st.garbage_bytes), (0, 0));
    }

    #[test]
    fn truncated_frame_mid_stream_does_not_hide_the_next() {
        let (b, _) = stream(3);
        let mut bytes = b[..SAMPLE_FRAME_LEN + 20].to_vec(); // frame 1 cut after 20 bytes
        bytes.extend_from_slice(&b[2 * SAMPLE_FRAME_LEN..]);
        let (got, _) = decode_all(&bytes, 9);
        assert_eq!(got.iter().map(|s| s.seq).collect::<Vec<_>>(), vec![0, 2]);
    }

    #[test]
    fn duplicate_and_gap_are_flagged() {
        let mut b = BytesMut::new();
        for seq in [0, 1, 1, 2, 5, 6] {
            encode_sample(&sample(seq), &mut b);
        }
        let (got, st) = decode_all(&b, b.len());
        let f: Vec<u32> = got.iter().map(|s| s.flags).collect();
        assert_eq!(f[2], flags::DUPLICATE);
        assert_eq!(f[4], flags::GAP);
        assert_eq!((st.duplicates, st.gaps, st.missing_frames), (1, 1, 2));
    }

    #[test]
    fn sequence_wraps_without_a_gap() {
        let mut b = BytesMut::new();
        for seq in [u32::MAX - 1, u32::MAX, 0, 1] {
            encode_sample(&sample(seq), &mut b);
        }
        let (got, st) = decode_all(&b, b.len());
        assert_eq!(got.len(), 4);
        assert_eq!(st.gaps + st.duplicates + st.seq_restarts, 0);
    }

    #[test]
    fn nan_and_saturation_are_flagged_not_dropped() {
        let d = Descriptor {
            sample_rate_hz: 100.0,
            gyro_range_rad_s: 4.0,
            accel_range_m_s2: 80.0,
            ..Descriptor::default()
        };
        let mut b = BytesMut::new();
        encode_descriptor(&d, &mut b);
        let mut s0 = sample(0);
        s0.gyro[1] = f64::NAN;
        let mut s1 = sample(1);
        s1.gyro[2] = 4.0;
        s1.accel[0] = -90.0;
        encode_sample(&s0, &mut b);
        encode_sample(&s1, &mut b);
        let (got, st) = decode_all(&b, b.len());
        assert_eq!(got.len(), 2);
        assert!(got[0].has(flags::NON_FINITE));
        assert_eq!(
            got[1].flags & flags::SAT_ANY,
            flags::SAT_GYRO_Z | flags::SAT_ACCEL_X
        );
        assert_eq!((st.non_finite, st.saturated), (1, 1));
    }

    #[test]
    fn random_corruption_never_loses_an_untouched_frame() {
        // Deterministic version of the property test in tests/decoder_props.rs (which uses
        // proptest): flip bytes in a few frames, every untouched frame must come out in order.
        let mut rng = Rng::new(99);
        for _round in 0..200 {
            let n = 50;
            let (mut b, _) = stream(n);
            let mut touched = vec![false; n as usize];
            for _ in 0..rng.below(20) {
                let pos = rng.below(b.len() as u64) as usize;
                b[pos] = rng.next_u64() as u8;
                touched[pos / SAMPLE_FRAME_LEN] = true;
            }
            let (got, _) = decode_all(&b, 1 + rng.below(100) as usize);
            let got_seq: Vec<u32> = got.iter().map(|s| s.seq).collect();
            let want: Vec<u32> = (0..n).filter(|i| !touched[*i as usize]).collect();
            // Every untouched frame is present, in order (a touched frame may survive too if the
            // flipped byte kept its value).
            let mut it = got_seq.iter();
            for w in &want {
                assert!(it.any(|g| g == w), "lost frame {w}");
            }
        }
    }
}
