//! Decompression for the bags: LZ4 frames (MCAP chunks) and zstd frames (MCAP chunks, and
//! rosbag2's message and file compression), both by pure-Rust crates (`lz4_flex`, `ruzstd`), so
//! no build needs a C compiler to read a bag as ROS 2 writes it. Every call is bounded: at most
//! the size the caller allows is produced, so a corrupt length or a crafted frame cannot
//! allocate without bound; a frame that ends early, a checksum that fails or more output than
//! allowed is an error, never a panic and never a silently short result.

use std::borrow::Cow;

/// The first four bytes of a zstd frame (RFC 8878 §3.1.1).
pub const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];

/// `b` starts like a zstd frame.
pub fn is_zstd(b: &[u8]) -> bool {
    b.starts_with(&ZSTD_MAGIC)
}

/// The most one compressed message may inflate to (an Imu message is about 330 bytes plus
/// its frame id).
pub const MAX_MESSAGE: u64 = 1 << 20;

/// A message's CDR: its data, or the data inflated when rosbag2 compressed the message on its
/// own (one zstd frame; CDR never starts so, its first byte being 0). A compressed message that
/// does not inflate gives no bytes (its CDR then fails as any bad CDR does, counted).
pub fn message(data: &[u8]) -> Cow<'_, [u8]> {
    if !is_zstd(data) {
        return Cow::Borrowed(data);
    }
    Cow::Owned(zstd(data, MAX_MESSAGE).unwrap_or_default())
}

/// The records of an LZ4-frame chunk: exactly `size` bytes (the chunk's declared uncompressed
/// size); fewer or more is an error.
#[cfg(feature = "ros2")]
pub fn lz4(data: &[u8], size: u64) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let mut out = Vec::with_capacity(size.min(1 << 26) as usize);
    lz4_flex::frame::FrameDecoder::new(data)
        .take(size + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("LZ4 chunk: {e}"))?;
    exactly(out, size, "LZ4")
}

/// Exactly `size` bytes from the zstd frames in `data` (an MCAP chunk of declared size).
pub fn zstd_sized(data: &[u8], size: u64) -> Result<Vec<u8>, String> {
    exactly(zstd(data, size)?, size, "zstd")
}

fn exactly(out: Vec<u8>, size: u64, what: &str) -> Result<Vec<u8>, String> {
    if out.len() as u64 != size {
        return Err(format!(
            "{what} data inflates to {} bytes, not the {size} declared",
            out.len()
        ));
    }
    Ok(out)
}

/// The bytes of every zstd frame in `data`, one after another (skippable frames skipped), at
/// most `limit` of them. A frame's content checksum, where it carries one, is checked.
pub fn zstd(data: &[u8], limit: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    zstd_into(data, limit, &mut out)?;
    Ok(out)
}

/// [`zstd`] written to `out` as it is inflated (a whole bag file need not be held twice);
/// returns the bytes written.
pub fn zstd_into(data: &[u8], limit: u64, out: &mut impl std::io::Write) -> Result<u64, String> {
    use ruzstd::decoding::FrameDecoder;
    // One decoder per thread, reused: its buffers are allocated once, not per message (a bag
    // compressed message by message inflates one frame per sample).
    thread_local! {
        static DECODER: std::cell::RefCell<FrameDecoder> =
            std::cell::RefCell::new(FrameDecoder::new());
    }
    DECODER.with_borrow_mut(|dec| frames_into(dec, data, limit, out))
}

fn frames_into(
    dec: &mut ruzstd::decoding::FrameDecoder,
    mut input: &[u8],
    limit: u64,
    out: &mut impl std::io::Write,
) -> Result<u64, String> {
    use ruzstd::decoding::BlockDecodingStrategy;
    use ruzstd::decoding::errors::{FrameDecoderError, ReadFrameHeaderError};
    let mut written = 0u64;
    let mut put = |b: Vec<u8>| -> Result<(), String> {
        written += b.len() as u64;
        if written > limit {
            return Err(format!("zstd data inflates to more than {limit} bytes"));
        }
        out.write_all(&b)
            .map_err(|e| format!("zstd: writing the inflated data: {e}"))
    };
    // No window larger than the output allowed (a frame may not refer further back than its
    // content), and never under 1 MiB nor over 128 MiB (zstd's `--long` default).
    dec.set_max_window_size(limit.clamp(1 << 20, 1 << 27));
    let mut frames = 0usize;
    while !input.is_empty() {
        match dec.init(&mut input) {
            Ok(()) => {}
            Err(FrameDecoderError::ReadFrameHeaderError(ReadFrameHeaderError::SkipFrame {
                length,
                ..
            })) => {
                input = input
                    .get(length as usize..)
                    .ok_or("zstd: a skippable frame runs past the end")?;
                continue;
            }
            Err(e) => {
                return Err(if frames == 0 {
                    format!("zstd: {e}")
                } else {
                    format!(
                        "zstd: after frame {frames}, {} bytes that are no frame: {e}",
                        input.len()
                    )
                });
            }
        }
        frames += 1;
        loop {
            dec.decode_blocks(&mut input, BlockDecodingStrategy::UptoBytes(1 << 20))
                .map_err(|e| format!("zstd frame {frames}: {e}"))?;
            if let Some(b) = dec.collect() {
                put(b)?;
            }
            if dec.is_finished() {
                break;
            }
        }
        if let Some(b) = dec.collect() {
            put(b)?;
        }
        if let (Some(stated), Some(seen)) =
            (dec.get_checksum_from_data(), dec.get_calculated_checksum())
            && stated != seen
        {
            return Err(format!("zstd frame {frames}: checksum fails"));
        }
    }
    if frames == 0 {
        return Err("zstd: no frame".into());
    }
    Ok(written)
}

/// `data` as one zstd frame (ruzstd's fastest level, about zstd's level 1): the inline output's
/// form of a message the input carried compressed, and the `mcap+zstd:` sink's chunks.
pub fn zstd_compress(data: &[u8]) -> Vec<u8> {
    ruzstd::encoding::compress_to_vec(data, ruzstd::encoding::CompressionLevel::Fastest)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames made by the encoder of the same crate round-trip; the checks below are what a
    /// reader of untrusted files needs: a cut, a changed byte, a limit, trailing junk.
    fn frame(data: &[u8]) -> Vec<u8> {
        ruzstd::encoding::compress_to_vec(data, ruzstd::encoding::CompressionLevel::Fastest)
    }

    fn text(n: usize) -> Vec<u8> {
        (0..n).map(|i| (i * 7 % 251) as u8).collect()
    }

    #[test]
    fn frames_one_after_another_inflate_whole_and_skippable_frames_are_skipped() {
        let (a, b) = (text(5000), text(300));
        let mut z = frame(&a);
        // A skippable frame (magic 0x184D2A50, u32 length, payload) between the two.
        z.extend_from_slice(&[0x50, 0x2A, 0x4D, 0x18, 3, 0, 0, 0, 9, 9, 9]);
        z.extend_from_slice(&frame(&b));
        assert!(is_zstd(&z));
        let out = zstd(&z, 1 << 20).unwrap();
        assert_eq!(out, [a.clone(), b].concat());
        assert_eq!(zstd_sized(&frame(&a), 5000).unwrap(), a);
    }

    #[test]
    fn a_cut_frame_junk_after_it_or_too_much_output_is_an_error() {
        let a = text(20_000);
        let z = frame(&a);
        for cut in [1, 4, 10, z.len() / 2, z.len() - 1] {
            assert!(zstd(&z[..cut], 1 << 20).is_err(), "cut at {cut}");
        }
        let mut junk = z.clone();
        junk.extend_from_slice(b"not a frame");
        assert!(zstd(&junk, 1 << 20).unwrap_err().contains("no frame"));
        assert!(zstd(&z, 19_999).unwrap_err().contains("more than"));
        assert!(
            zstd_sized(&z, 20_001)
                .unwrap_err()
                .contains("not the 20001")
        );
        assert!(zstd(&[], 10).is_err());
        // This encoder writes the content checksum (the last 4 bytes): a changed one is caught.
        let mut sum = z.clone();
        *sum.last_mut().unwrap() ^= 0x10;
        assert!(zstd(&sum, 1 << 20).unwrap_err().contains("checksum fails"));
    }

    #[test]
    fn changed_bytes_give_a_result_or_an_error_never_a_panic() {
        // Seeded: every byte of a frame flipped in turn (a corrupt file must not panic).
        let z = frame(&text(3000));
        let mut rng = crate::rng::Rng::new(41);
        for i in 0..z.len() {
            let mut c = z.clone();
            c[i] ^= 1 + (rng.next_u64() % 255) as u8;
            if let Ok(v) = zstd(&c, 1 << 16) {
                assert!(v.len() <= 1 << 16);
            }
        }
    }
}
