//! The framing rules of the three protocols a u-blox port carries: UBX, NMEA 0183 and RTCM 3.
//! Each looks at bytes that start like one of its messages and says whether a whole, checked
//! message is there ([`Front`]).

use super::esf::checksum;
use crate::frame::framing::{Fault, Front};
use crc::{CRC_24_LTE_A, Crc};

/// The two UBX sync bytes.
pub const SYNC: [u8; 2] = [0xB5, 0x62];
/// Largest UBX payload accepted; longer lengths are taken as corrupt (the receivers' largest
/// messages are a few kB).
pub const MAX_PAYLOAD: usize = 8192;
/// Longest NMEA sentence accepted (the standard says 82 characters; some talkers exceed it).
const MAX_NMEA: usize = 160;
/// First byte of an RTCM 3 frame.
const RTCM3_PREAMBLE: u8 = 0xD3;

const CRC24Q: Crc<u32> = Crc::<u32>::new(&CRC_24_LTE_A);

/// A byte that can start a message on the port (UBX, NMEA `$` / `!`, RTCM 3).
#[inline]
pub fn is_start(b: u8) -> bool {
    b == SYNC[0] || b == b'$' || b == b'!' || b == RTCM3_PREAMBLE
}

/// The framing rule for the message type the first byte (one of [`is_start`]) announces.
pub fn front(buf: &[u8]) -> Front {
    match buf[0] {
        0xB5 => ubx(buf),
        b'$' | b'!' => nmea(buf),
        _ => rtcm3(buf),
    }
}

/// UBX: B5 62, class, id, u16 length, payload, 8-bit Fletcher checksum.
fn ubx(buf: &[u8]) -> Front {
    if buf.len() < 2 {
        return Front::Need(None);
    }
    if buf[1] != SYNC[1] {
        return Front::Bad(Fault::Sync);
    }
    if buf.len() < 6 {
        return Front::Need(None);
    }
    let len = u16::from_le_bytes([buf[4], buf[5]]) as usize;
    if len > MAX_PAYLOAD {
        return Front::Bad(Fault::Length);
    }
    let total = 6 + len + 2;
    if buf.len() < total {
        return Front::Need(Some(total));
    }
    if checksum(&buf[2..6 + len]) != [buf[6 + len], buf[7 + len]] {
        return Front::Bad(Fault::Crc);
    }
    Front::Whole(total)
}

/// NMEA: printable characters up to "*HH\r\n", XOR checksum of the characters between the
/// start and the '*'.
fn nmea(buf: &[u8]) -> Front {
    let lim = buf.len().min(MAX_NMEA);
    let Some(lf) = buf[..lim].iter().position(|&b| b == b'\n') else {
        if buf.len() >= MAX_NMEA || buf[1..].iter().any(|b| !is_nmea_char(*b)) {
            return Front::Bad(Fault::Header);
        }
        return Front::Need(None);
    };
    if nmea_ok(&buf[..=lf]) {
        Front::Whole(lf + 1)
    } else {
        Front::Bad(Fault::Crc)
    }
}

/// RTCM 3: D3, 6 zero bits + 10-bit length, payload, CRC-24Q.
fn rtcm3(buf: &[u8]) -> Front {
    if buf.len() < 3 {
        return Front::Need(None);
    }
    if buf[1] & 0xFC != 0 {
        return Front::Bad(Fault::Sync);
    }
    let len = (((buf[1] & 0x03) as usize) << 8) | buf[2] as usize;
    let total = 3 + len + 3;
    if buf.len() < total {
        return Front::Need(None);
    }
    let crc = ((buf[3 + len] as u32) << 16) | ((buf[4 + len] as u32) << 8) | buf[5 + len] as u32;
    if CRC24Q.checksum(&buf[..3 + len]) != crc {
        return Front::Bad(Fault::Crc);
    }
    Front::Whole(total)
}

fn is_nmea_char(b: u8) -> bool {
    (0x20..0x7f).contains(&b) || b == b'\r' || b == b'\n'
}

/// A complete NMEA line (start to '\n') with a valid "*HH" checksum.
fn nmea_ok(line: &[u8]) -> bool {
    if line.len() < 6 || line[line.len() - 2] != b'\r' {
        return false;
    }
    let body = &line[1..line.len() - 2];
    let Some(star) = body.iter().rposition(|&b| b == b'*') else {
        return false;
    };
    if star + 3 != body.len() || body.iter().any(|b| !is_nmea_char(*b)) {
        return false;
    }
    let x = body[..star].iter().fold(0u8, |a, b| a ^ b);
    let hex = std::str::from_utf8(&body[star + 1..])
        .ok()
        .and_then(|h| u8::from_str_radix(h, 16).ok());
    hex == Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nmea_lines_checked_and_cut_short() {
        let gga = b"$GNGGA,,,,,,0,00,99.99,,,,,,*56\r\n";
        assert_eq!(front(gga), Front::Whole(gga.len()));
        assert_eq!(front(&gga[..10]), Front::Need(None));
        let mut bad = gga.to_vec();
        bad[5] = b'X';
        assert_eq!(front(&bad), Front::Bad(Fault::Crc));
        assert_eq!(front(b"$GN\x01"), Front::Bad(Fault::Header));
    }

    #[test]
    fn rtcm3_frame_with_crc24q() {
        // An empty-payload RTCM 3 frame: D3 00 00 and the CRC-24Q of those three bytes.
        let c = CRC24Q.checksum(&[0xD3, 0, 0]);
        let f = [0xD3, 0, 0, (c >> 16) as u8, (c >> 8) as u8, c as u8];
        assert_eq!(front(&f), Front::Whole(6));
        assert_eq!(front(&[0xD3, 0x04, 0]), Front::Bad(Fault::Sync));
        let mut g = f;
        g[5] ^= 1;
        assert_eq!(front(&g), Front::Bad(Fault::Crc));
    }
}
