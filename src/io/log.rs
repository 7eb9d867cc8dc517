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
use crate::sample::Sample;
use bytes::BytesMut;
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

/// Read every sample of a recorded log (through the live decoder), with its decoder counters.
pub fn read_log(path: &Path) -> Result<LogContents, LogError> {
    let bytes = std::fs::read(path).map_err(LogError::io(path))?;
    decode_log(&bytes).map_err(|err| LogError::Header {
        path: path.into(),
        err,
    })
}

/// The descriptor at the start of a recorded log (reads only the first frames).
pub fn read_descriptor(path: &Path) -> Result<Option<Descriptor>, LogError> {
    let f = std::fs::File::open(path).map_err(LogError::io(path))?;
    let mut head = Vec::with_capacity(4096);
    f.take(4096)
        .read_to_end(&mut head)
        .map_err(LogError::io(path))?;
    check_log_header(&head).map_err(|err| LogError::Header {
        path: path.into(),
        err,
    })?;
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
    check_log_header(&h[..n]).map_err(|err| LogError::Header {
        path: path.into(),
        err,
    })?;
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
