//! The recorded log: the one writer and the one reader of imuprep's native log files.
//!
//! A log is the 12-byte file header ([`crate::frame::LOG_MAGIC`], version, reserved) followed
//! by exactly the frames a serial port carries, starting with a descriptor. Every place that
//! writes a log (`import`, `simulate`, `export --to native`, a `file:` sink) goes through
//! [`LogWriter`] or [`encode_log`]; every place that reads one goes through [`read_log`],
//! [`read_descriptor`] or (for the streaming replay source) [`open_log`], all of which check
//! the header the same way and decode with the live [`FrameDecoder`].

use crate::frame::{
    DecoderStats, Descriptor, FrameDecoder, LOG_HEADER_LEN, LogHeaderError, Message,
    check_log_header, encode_log_header, encode_sample,
};
use crate::sample::{Sample, SampleSink};
use bytes::{Buf, BytesMut};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use tokio_util::codec::Decoder;

/// Why a log could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    #[error("{path}: {err}")]
    Io { path: PathBuf, err: std::io::Error },
    #[error("{path}: {err}")]
    Header { path: PathBuf, err: LogHeaderError },
}

/// The error of a refused file header; a wrong magic says which protocol the file looks like
/// when its first bytes decode as one.
fn header_error(path: &Path) -> impl FnOnce(LogHeaderError) -> LogError + '_ {
    move |err| {
        let err = match err {
            LogHeaderError::BadMagic(m) => match crate::frame::detect::file_protocol(path) {
                Some(p) => LogHeaderError::LooksLike(p, m),
                None => LogHeaderError::BadMagic(m),
            },
            e => e,
        };
        LogError::Header {
            path: path.into(),
            err,
        }
    }
}

impl LogError {
    fn io(path: &Path) -> impl FnOnce(std::io::Error) -> LogError + '_ {
        move |err| LogError::Io {
            path: path.into(),
            err,
        }
    }
}

/// Append a whole log (header, descriptor, every sample) to `buf`.
pub fn encode_log(d: &Descriptor, samples: &[Sample], buf: &mut BytesMut) {
    buf.reserve(64 + samples.len() * crate::frame::SAMPLE_FRAME_LEN);
    encode_log_header(d, buf);
    for s in samples {
        encode_sample(s, buf);
    }
}

/// Streaming log writer: the header and descriptor at creation, then frames as they come,
/// written in blocks of about 32 KiB.
pub struct LogWriter<W: Write> {
    w: W,
    buf: BytesMut,
    bytes: u64,
    frames: u64,
}

impl<W: Write> LogWriter<W> {
    /// Start a log on `w` for a sensor described by `d`.
    pub fn new(w: W, d: &Descriptor) -> Self {
        let mut buf = BytesMut::with_capacity(1 << 16);
        encode_log_header(d, &mut buf);
        LogWriter {
            w,
            buf,
            bytes: 0,
            frames: 0,
        }
    }

    /// Append one sample frame.
    pub fn sample(&mut self, s: &Sample) -> std::io::Result<()> {
        encode_sample(s, &mut self.buf);
        self.frames += 1;
        self.spill()
    }

    fn spill(&mut self) -> std::io::Result<()> {
        if self.buf.len() > 1 << 15 {
            self.w.write_all(&self.buf)?;
            self.bytes += self.buf.len() as u64;
            self.buf.clear();
        }
        Ok(())
    }

    /// Sample frames written so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Write what is held, flush, and return the writer with the total bytes written.
    pub fn finish(mut self) -> std::io::Result<(W, u64)> {
        self.w.write_all(&self.buf)?;
        self.bytes += self.buf.len() as u64;
        self.w.flush()?;
        Ok((self.w, self.bytes))
    }
}

/// Write a recorded log: file header, descriptor, sample frames.
pub fn write_log(path: &Path, d: &Descriptor, samples: &[Sample]) -> Result<(), LogError> {
    let f = std::fs::File::create(path).map_err(LogError::io(path))?;
    let mut w = LogWriter::new(std::io::BufWriter::with_capacity(1 << 16, f), d);
    for s in samples {
        w.sample(s).map_err(LogError::io(path))?;
    }
    w.finish().map_err(LogError::io(path))?;
    Ok(())
}

/// What [`read_log`] found.
pub type LogContents = (Option<Descriptor>, Vec<Sample>, DecoderStats);

/// Decode a whole log held in memory (header checked) through the live decoder.
pub fn decode_log(bytes: &[u8]) -> Result<LogContents, LogHeaderError> {
    check_log_header(bytes)?;
    let mut buf = BytesMut::from(&bytes[LOG_HEADER_LEN..]);
    let mut dec = FrameDecoder::new();
    let mut out = Vec::new();
    let mut desc = None;
    // `decode_eof` never fails for the native decoder: bad bytes are counted, not errors.
    while let Ok(Some(m)) = dec.decode_eof(&mut buf) {
        match m {
            Message::Sample(s) => out.push(s),
            Message::Descriptor(d) => desc = desc.or(Some(d)),
            Message::Health(_) => {}
        }
    }
    Ok((desc, out, dec.stats()))
}

/// `samples` as the log [`write_log`] would write of them (with `d`) reads back: what
/// [`decode_log`] gives for [`encode_log`]'s bytes (single-precision values, the decoder's
/// flags), with the descriptor read back and the decoder's counters — converted in place, one
/// frame at a time, so neither the log's bytes nor a second set of samples is held.
pub fn through_log(
    d: &Descriptor,
    samples: &mut Vec<Sample>,
) -> (Option<Descriptor>, DecoderStats) {
    let mut buf = BytesMut::with_capacity(256);
    encode_log_header(d, &mut buf);
    buf.advance(LOG_HEADER_LEN);
    let mut dec = FrameDecoder::new();
    let mut desc = None;
    // Decoded samples overwrite the ones already encoded: a frame gives at most one, so the
    // write position never passes the read one.
    let mut w = 0;
    let mut drain = |buf: &mut BytesMut, samples: &mut Vec<Sample>, w: &mut usize| {
        // `decode_eof` never fails for the native decoder: bad bytes are counted, not errors.
        while let Ok(Some(m)) = dec.decode_eof(buf) {
            match m {
                Message::Sample(s) => {
                    samples[*w] = s;
                    *w += 1;
                }
                Message::Descriptor(d) => desc = desc.or(Some(d)),
                Message::Health(_) => {}
            }
        }
    };
    drain(&mut buf, samples, &mut w);
    for r in 0..samples.len() {
        encode_sample(&samples[r], &mut buf);
        drain(&mut buf, samples, &mut w);
    }
    samples.truncate(w);
    (desc, dec.stats())
}

/// Read every sample of a recorded log (through the live decoder), with its decoder counters.
///
/// Streams the file (see [`read_log_span`]); memory is the samples only.
pub fn read_log(path: &Path) -> Result<LogContents, LogError> {
    read_log_span(path, 0.0, None)
}

/// Read the samples of a recorded log from `skip_s` after its start, at most `span_s` of them
/// (all to the end if `None`); with the first descriptor and the decoder statistics of what was
/// read.
///
/// The file is decoded in 64 KiB reads, never held whole, and reading stops once the span is
/// complete, so the cost of reading the first minutes of a long log does not grow with its
/// length. Times are counted in samples at the descriptor's rate (samples seen before the
/// first descriptor are held until it arrives); a log without a descriptor is read whole.
pub fn read_log_span(
    path: &Path,
    skip_s: f64,
    span_s: Option<f64>,
) -> Result<LogContents, LogError> {
    let mut out = Vec::new();
    let (desc, stats) = read_log_span_into(path, skip_s, span_s, &mut out)?;
    Ok((desc, out, stats))
}

/// [`read_log_span`] into `out`: the same samples in the same order, never held as a
/// `Vec<Sample>` unless `out` is one; the first descriptor and the decoder statistics.
pub fn read_log_span_into(
    path: &Path,
    skip_s: f64,
    span_s: Option<f64>,
    out: &mut impl SampleSink,
) -> Result<(Option<Descriptor>, DecoderStats), LogError> {
    let io = |err| LogError::Io {
        path: path.into(),
        err,
    };
    let mut f = std::fs::File::open(path).map_err(io)?;
    let file_len = f.metadata().map_err(io)?.len();
    let mut head = [0u8; crate::frame::LOG_HEADER_LEN];
    let got = read_full(&mut f, &mut head).map_err(io)?;
    check_log_header(&head[..got]).map_err(header_error(path))?;
    // A bar over the frames' bytes once the read has taken a second (a long log read whole).
    let mut f = crate::progress::ReadBar::new(f, file_len.saturating_sub(got as u64), "read");
    const CHUNK: usize = 64 * 1024;
    let mut buf = BytesMut::with_capacity(2 * CHUNK);
    let mut dec = FrameDecoder::new();
    let mut desc: Option<Descriptor> = None;
    // Before the descriptor: held samples. After: (to skip, to keep).
    let mut held: Vec<Sample> = Vec::new();
    let mut window: Option<(usize, usize)> = None;
    /// Skip, then keep, then stop: whether more are wanted.
    fn keep(out: &mut impl SampleSink, w: &mut (usize, usize), s: Sample) -> bool {
        if w.0 > 0 {
            w.0 -= 1;
        } else if w.1 > 0 {
            out.push(s);
            w.1 -= 1;
        }
        w.1 > 0
    }
    let mut eof = false;
    'read: loop {
        let m = if eof {
            dec.decode_eof(&mut buf).map_err(io)?
        } else {
            dec.decode(&mut buf).map_err(io)?
        };
        match m {
            Some(Message::Descriptor(d)) => {
                if desc.is_none() {
                    desc = Some(d);
                    let rate = d.sample_rate_hz;
                    let to_samples = |t: f64| (t * rate).round().max(0.0) as usize;
                    let skip = to_samples(skip_s);
                    let take = span_s.map_or(usize::MAX, to_samples);
                    // At most this many plain sample frames.
                    let frames = (file_len / crate::frame::SAMPLE_FRAME_LEN as u64) as usize;
                    out.expect(take.min(frames.saturating_sub(skip)) + held.len());
                    let mut w = (skip, take);
                    let mut more = w.1 > 0;
                    for s in held.drain(..) {
                        more = keep(out, &mut w, s);
                    }
                    window = Some(w);
                    if !more {
                        break 'read;
                    }
                }
            }
            Some(Message::Health(_)) => {}
            Some(Message::Sample(s)) => match window.as_mut() {
                Some(w) => {
                    if !keep(out, w, s) {
                        break 'read;
                    }
                }
                None => held.push(s),
            },
            None if eof => break 'read,
            None => {
                let len = buf.len();
                buf.resize(len + CHUNK, 0);
                let n = read_full(&mut f, &mut buf[len..]).map_err(io)?;
                buf.truncate(len + n);
                eof = n == 0;
            }
        }
    }
    if desc.is_none() {
        out.expect(held.len());
        for s in held {
            out.push(s);
        }
    }
    Ok((desc, dec.stats()))
}

/// Read until `buf` is full or the file ends; the number of bytes read.
fn read_full(f: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// The descriptor at the start of a recorded log (reads only the first frames).
pub fn read_descriptor(path: &Path) -> Result<Option<Descriptor>, LogError> {
    let f = std::fs::File::open(path).map_err(LogError::io(path))?;
    let mut head = Vec::with_capacity(4096);
    f.take(4096)
        .read_to_end(&mut head)
        .map_err(LogError::io(path))?;
    check_log_header(&head).map_err(header_error(path))?;
    let mut buf = BytesMut::from(&head[LOG_HEADER_LEN..]);
    let mut dec = FrameDecoder::new();
    while let Ok(Some(m)) = dec.decode(&mut buf) {
        if let Message::Descriptor(d) = m {
            return Ok(Some(d));
        }
    }
    Ok(None)
}

/// Open a recorded log for streaming and check its file header; the returned reader starts at
/// the first frame (the replay source decodes the rest as a serial port's bytes).
pub async fn open_log(path: &Path) -> Result<tokio::fs::File, LogError> {
    use tokio::io::AsyncReadExt;
    let mut f = tokio::fs::File::open(path)
        .await
        .map_err(LogError::io(path))?;
    let mut h = [0u8; LOG_HEADER_LEN];
    let mut n = 0;
    while n < LOG_HEADER_LEN {
        let k = f.read(&mut h[n..]).await.map_err(LogError::io(path))?;
        if k == 0 {
            break;
        }
        n += k;
    }
    check_log_header(&h[..n]).map_err(header_error(path))?;
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(n: u32) -> Vec<Sample> {
        (0..n)
            .map(|i| {
                let mut s = Sample {
                    seq: i,
                    t_ns: 10_000_000 * i as u64,
                    ..Sample::default()
                };
                s.set_channels(&[0.01, 0.02, 0.03, 0.1, 0.2, 9.8]);
                s
            })
            .collect()
    }

    #[test]
    fn a_round_trip_in_place_is_the_whole_log_decoded() {
        let d = Descriptor {
            sample_rate_hz: 100.0,
            absent: 0b100000,
            ..Descriptor::default()
        };
        let mut rng = crate::rng::Rng::new(7);
        let mut s = samples(3000);
        for (i, x) in s.iter_mut().enumerate() {
            // Values f32 cannot hold, sequence faults the decoder flags (repeats, jumps,
            // steps back), a removed bias (the longer frame), NaN and an absent channel.
            x.set_channels(&std::array::from_fn(|_| rng.normal()));
            x.seq = match i % 97 {
                5 => x.seq - 1,
                6 => x.seq + 40,
                7 => x.seq.saturating_sub(3000),
                _ => x.seq,
            };
            if i % 3 == 0 {
                x.flags |= crate::sample::flags::BIAS_REMOVED;
                x.bias = [1e-3; 6];
            }
            if i % 50 == 0 {
                x.gyro[1] = f64::NAN;
            }
            x.absent = 0b100000;
        }
        let mut whole = BytesMut::new();
        encode_log(&d, &s, &mut whole);
        let (want_d, want, want_st) = decode_log(&whole).unwrap();
        let (got_d, got_st) = through_log(&d, &mut s);
        assert_eq!((got_d, got_st), (want_d, want_st));
        assert!(want_st.duplicates > 0 && want_st.gaps > 0, "{want_st:?}");
        let bits = |v: &[Sample]| format!("{v:?}");
        assert_eq!(s.len(), want.len());
        assert_eq!(bits(&s), bits(&want));
    }

    #[test]
    fn streaming_writer_and_whole_log_encoder_write_the_same_bytes() {
        let d = Descriptor {
            sample_rate_hz: 100.0,
            ..Descriptor::default()
        };
        let s = samples(2000); // > 32 KiB, so the writer spills mid-way
        let mut whole = BytesMut::new();
        encode_log(&d, &s, &mut whole);
        let mut w = LogWriter::new(Vec::new(), &d);
        for x in &s {
            w.sample(x).unwrap();
        }
        let (streamed, n) = w.finish().unwrap();
        assert_eq!(n as usize, streamed.len());
        assert_eq!(&streamed[..], &whole[..]);
        let (desc, got, st) = decode_log(&streamed).unwrap();
        assert_eq!(desc, Some(d));
        assert_eq!(got.len(), 2000);
        assert_eq!(st.crc_errors + st.resyncs, 0);
    }
}
