//! Streaming log reader: `read_log_span` against decoding the whole file at once (what
//! `read_log` did before it streamed), on a log longer than many 64 KiB reads, with a
//! corrupted stretch and a truncated last frame.
use bytes::BytesMut;
use imuprep::Sample;
use imuprep::frame::{Descriptor, FrameDecoder, LOG_HEADER_LEN, Message};
use imuprep::io::csv::{read_log, read_log_span, write_log};
use tokio_util::codec::Decoder;

fn samples(n: usize) -> Vec<Sample> {
    (0..n)
        .map(|i| {
            let mut s = Sample::nth(i, 10_000_000);
            s.gyro[0] = i as f64 * 1e-3;
            s.accel[2] = 9.8 + (i % 7) as f64 * 1e-2;
            s
        })
        .collect()
}

/// The whole file decoded in one buffer.
fn decode_whole(
    bytes: &[u8],
) -> (
    Option<Descriptor>,
    Vec<Sample>,
    imuprep::frame::DecoderStats,
) {
    let mut buf = BytesMut::from(&bytes[LOG_HEADER_LEN..]);
    let mut dec = FrameDecoder::new();
    let (mut desc, mut out) = (None, Vec::new());
    while let Some(m) = dec.decode_eof(&mut buf).unwrap() {
        match m {
            Message::Sample(s) => out.push(s),
            Message::Descriptor(d) => desc = desc.or(Some(d)),
            Message::Health(_) => {}
        }
    }
    (desc, out, dec.stats())
}

#[test]
fn streamed_read_equals_whole_file_decode_and_spans_cut_by_time() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.log");
    let d = Descriptor {
        sample_rate_hz: 100.0,
        ..Default::default()
    };
    let all = samples(20_000); // 1.1 MB: ~17 reads of 64 KiB
    write_log(&path, &d, &all).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // corrupt a stretch in the middle (decoder resynchronises, counts it) and cut the last
    // frame short (counted as truncated)
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 100] {
        *b = 0x5a;
    }
    bytes.truncate(bytes.len() - 10);
    std::fs::write(&path, &bytes).unwrap();

    let want = decode_whole(&bytes);
    let got = read_log(&path).unwrap();
    assert_eq!(got.0, want.0);
    assert_eq!(got.1, want.1);
    assert_eq!(got.2, want.2);
    assert!(
        want.1.len() < 20_000 && want.1.len() > 19_990,
        "{}",
        want.1.len()
    );

    // 10 s in, 5 s long at 100 Hz: the 1000th..1499th samples decoded
    let (desc, span, _) = read_log_span(&path, 10.0, Some(5.0)).unwrap();
    assert_eq!(desc, want.0);
    assert_eq!(span, want.1[1000..1500].to_vec());
    // past the end: empty; no span: to the end
    assert!(read_log_span(&path, 1e6, None).unwrap().1.is_empty());
    assert_eq!(
        read_log_span(&path, 150.0, None).unwrap().1,
        want.1[15_000..].to_vec()
    );
}

/// The columns a log is streamed into (`diagnose` holds these, not the samples) are the
/// samples' own values: channel by channel, the temperature only while every sample has one,
/// the absent channels counted.
#[test]
fn a_log_streamed_into_channels_holds_what_its_samples_hold() {
    use imuprep::io::log::read_log_span_into;
    use imuprep::sample::Channels;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.log");
    let d = Descriptor {
        sample_rate_hz: 100.0,
        absent: 0b100000, // no az: a partial sensor
        ..Default::default()
    };
    let mut all = samples(3_000);
    for (i, s) in all.iter_mut().enumerate() {
        s.temp_c = Some(20.0 + i as f64 * 1e-3);
        s.accel[2] = f64::NAN;
        s.absent = 0b100000;
    }
    write_log(&path, &d, &all).unwrap();
    let (_, want, _) = read_log_span(&path, 5.0, Some(20.0)).unwrap();
    let mut got = Channels::default();
    let (desc, _) = read_log_span_into(&path, 5.0, Some(20.0), &mut got).unwrap();
    assert_eq!(desc.unwrap().absent, 0b100000);
    assert_eq!(got.len(), want.len());
    assert_eq!(want.len(), 2_000);
    for c in 0..5 {
        let col: Vec<f64> = want.iter().map(|s| s.channel(c)).collect();
        assert_eq!(got.values[c], col, "channel {c}");
    }
    assert_eq!(got.absent_in, [0, 0, 0, 0, 0, 2_000]);
    assert_eq!(got.absent(), 0b100000);
    let temps: Vec<f64> = want.iter().map(|s| s.temp_c.unwrap()).collect();
    assert_eq!(got.temp_c.as_ref(), Some(&temps));
    // the same columns as collected from the samples (az is NaN: no measurement)
    let from_samples: Channels = want.iter().collect();
    assert_eq!(from_samples.values[..5], got.values[..5]);
    assert!(from_samples.values[5].iter().all(|v| v.is_nan()));
    assert_eq!(from_samples.temp_c, got.temp_c);
    assert_eq!(from_samples.absent_in, got.absent_in);

    // one sample without a temperature: no temperature series at all (a partial one would
    // misalign with the channels)
    let mut some = want.clone();
    some[1_500].temp_c = None;
    let ch: Channels = some.iter().collect();
    assert_eq!(ch.temp_c, None);
    let mut cut = ch.clone();
    cut.truncate(10);
    assert_eq!(cut.len(), 10);
    assert!(cut.values.iter().all(|v| v.len() == 10));
}
