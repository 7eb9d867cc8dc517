//! The shared harness of the fuzz targets: feed a decoder the input in chunks whose sizes come
//! from the input itself (so frames split at every boundary get exercised), then end the stream.
//! The property is the decoder contract: no panic, no hang, every call returns.

use bytes::BytesMut;
use imuprep::frame::protocol::ProtocolDecoder;

/// Drive `dec` over `data`: the first byte picks a chunk size (1..=256), the rest is the stream.
pub fn drive(dec: &mut dyn ProtocolDecoder, data: &[u8]) -> usize {
    let Some((&k, body)) = data.split_first() else {
        return 0;
    };
    let chunk = usize::from(k) + 1;
    let mut buf = BytesMut::new();
    let mut items = 0;
    for part in body.chunks(chunk) {
        buf.extend_from_slice(part);
        while dec.decode_item(&mut buf).is_some() {
            items += 1;
            assert!(items <= 4 * data.len() + 16, "more items than bytes: a decoder loops");
        }
    }
    while dec.decode_item_eof(&mut buf).is_some() {
        items += 1;
        assert!(items <= 4 * data.len() + 16, "more items than bytes at EOF: a decoder loops");
    }
    items
}
