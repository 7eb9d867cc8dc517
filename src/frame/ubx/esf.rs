//! UBX-ESF-RAW and UBX-ESF-MEAS payloads: data words, their types and scale factors, time-tag
//! groups, and writing values back (inline output, export, tests).
//!
//! ```text
//! UBX frame: B5 62 | class | id | len u16 LE | payload (len) | CK_A CK_B
//!            checksum: 8-bit Fletcher over class..payload
//! ESF-RAW payload : reserved U4, then N blocks of { data X4, sTtag U4 }
//! ESF-MEAS payload: timeTag U4, flags X2 (numMeas = bits 11..15, calibTtagValid = bit 3), id U2,
//!                   numMeas × data X4, [calibTtag U4]
//! data X4         : bits 0..23 value (24-bit two's complement), bits 24..29 (MEAS) / 24..31 (RAW)
//!                   data type
//! ```
//!
//! Data types and scale factors (u-blox interface description, "sensor data types"): gyro
//! x/y/z = 14/13/5 in 2⁻¹² deg/s, accel x/y/z = 16/17/18 in 2⁻¹⁰ m/s², gyro temperature = 12 in
//! 10⁻² °C.

use super::port::SYNC;
use crate::sample::Sample;
use bytes::BytesMut;
use std::ops::Range;

/// UBX class of the external-sensor-fusion messages.
pub const CLASS_ESF: u8 = 0x10;
pub const ID_ESF_MEAS: u8 = 0x02;
pub const ID_ESF_RAW: u8 = 0x03;
/// Data types (bits 24.. of a data word).
pub const TYPE_GYRO_X: u8 = 14;
pub const TYPE_GYRO_Y: u8 = 13;
pub const TYPE_GYRO_Z: u8 = 5;
pub const TYPE_GYRO_TEMP: u8 = 12;
pub const TYPE_ACCEL_X: u8 = 16;
pub const TYPE_ACCEL_Y: u8 = 17;
pub const TYPE_ACCEL_Z: u8 = 18;
/// Data type of channel `c` (gx gy gz ax ay az).
pub const CHANNEL_TYPES: [u8; 6] = [
    TYPE_GYRO_X,
    TYPE_GYRO_Y,
    TYPE_GYRO_Z,
    TYPE_ACCEL_X,
    TYPE_ACCEL_Y,
    TYPE_ACCEL_Z,
];

/// One count of a gyro value, deg/s.
pub const GYRO_LSB_DEG_S: f64 = 1.0 / 4096.0;
/// One count of an accel value, m/s².
pub const ACCEL_LSB_M_S2: f64 = 1.0 / 1024.0;
/// One count of the gyro temperature, °C.
pub const TEMP_LSB_C: f64 = 0.01;

/// 8-bit Fletcher checksum over `bytes` (UBX: class, id, length and payload).
///
/// Eight bytes at a time: after bytes x0..x7 the running sums are `a + Σxⱼ` and
/// `b + 8a + Σ(8-j)xⱼ`, so the 16 dependent byte additions become two per block. Both block
/// sums come from one 64-bit load: the even and the odd bytes spread into four 16-bit lanes
/// each, and a multiply by lane weights gathers their weighted sum in the top lane (at most
/// 255·20 = 5100, and every lower lane at most 255·12, so no lane carries into the next).
/// Only the low byte of each running sum is the checksum; wrapping u32 arithmetic keeps it.
#[inline]
pub fn checksum(bytes: &[u8]) -> [u8; 2] {
    const LANES: u64 = 0x00FF_00FF_00FF_00FF;
    const ONES: u64 = 0x0001_0001_0001_0001;
    // Top lane = lane0·w3 + lane1·w2 + lane2·w1 + lane3·w0 for weights w0 | w1<<16 | …
    const EVEN: u64 = 2 | 4 << 16 | 6 << 32 | 8 << 48; // x0·8 + x2·6 + x4·4 + x6·2
    const ODD: u64 = 1 | 3 << 16 | 5 << 32 | 7 << 48; // x1·7 + x3·5 + x5·3 + x7·1
    let (mut a, mut b) = (0u32, 0u32);
    let mut blocks = bytes.chunks_exact(8);
    for c in &mut blocks {
        let w = u64::from_le_bytes(c.try_into().expect("8 bytes"));
        let (e, o) = (w & LANES, (w >> 8) & LANES);
        let s = ((e + o).wrapping_mul(ONES) >> 48) as u32;
        let t = ((e.wrapping_mul(EVEN) >> 48) + (o.wrapping_mul(ODD) >> 48)) as u32;
        b = b.wrapping_add(a.wrapping_mul(8)).wrapping_add(t);
        a = a.wrapping_add(s);
    }
    for &x in blocks.remainder() {
        a = a.wrapping_add(x as u32);
        b = b.wrapping_add(a);
    }
    [a as u8, b as u8]
}

/// Sign-extend the 24-bit value field of a data word.
#[inline]
pub fn value24(word: u32) -> i32 {
    ((word << 8) as i32) >> 8
}

/// Per data type (0..=255): the slot it fills (0..6 = gx gy gz ax ay az, 6 = temperature,
/// `NOT_IMU` = none) and one count in imuprep units (gyro rad/s, accel m/s², temperature °C).
/// One indexed load per data word instead of two matches. The gyro count is 2⁻¹² deg/s times
/// π/180 as `to_radians` multiplies; scaling by a power of two is exact, so `raw × count` is
/// the same double as `(raw × 2⁻¹²).to_radians()`.
pub const TYPES: [(u8, f64); 256] = {
    let mut t = [(NOT_IMU, 0.0); 256];
    let gyro = GYRO_LSB_DEG_S * (std::f64::consts::PI / 180.0);
    t[TYPE_GYRO_X as usize] = (0, gyro);
    t[TYPE_GYRO_Y as usize] = (1, gyro);
    t[TYPE_GYRO_Z as usize] = (2, gyro);
    t[TYPE_ACCEL_X as usize] = (3, ACCEL_LSB_M_S2);
    t[TYPE_ACCEL_Y as usize] = (4, ACCEL_LSB_M_S2);
    t[TYPE_ACCEL_Z as usize] = (5, ACCEL_LSB_M_S2);
    t[TYPE_GYRO_TEMP as usize] = (6, TEMP_LSB_C);
    t
};
/// Slot of a data type that is not IMU data ([`TYPES`]).
pub const NOT_IMU: u8 = u8::MAX;

/// Physical value of a data word's field for a data type, in imuprep units (gyro rad/s, accel
/// m/s², temperature °C); `None` for types that are not IMU data.
#[inline]
pub fn physical(ty: u8, raw: i32) -> Option<f64> {
    let (slot, lsb) = TYPES[ty as usize];
    (slot != NOT_IMU).then_some(raw as f64 * lsb)
}

/// Inverse of [`physical`]: the 24-bit field for a value, rounded to the protocol's resolution
/// and clamped to the field's range; `None` when the value is not finite.
pub fn raw_of(ty: u8, v: f64) -> Option<i32> {
    if !v.is_finite() {
        return None;
    }
    let counts = match ty {
        TYPE_GYRO_X | TYPE_GYRO_Y | TYPE_GYRO_Z => v.to_degrees() / GYRO_LSB_DEG_S,
        TYPE_ACCEL_X | TYPE_ACCEL_Y | TYPE_ACCEL_Z => v / ACCEL_LSB_M_S2,
        TYPE_GYRO_TEMP => v / TEMP_LSB_C,
        _ => return None,
    };
    Some(counts.round().clamp(-8_388_608.0, 8_388_607.0) as i32)
}

/// Which channel (0..6) a data type fills, 6 for the temperature.
#[inline]
pub fn slot_of(ty: u8) -> Option<usize> {
    let slot = TYPES[ty as usize].0;
    (slot != NOT_IMU).then_some(slot as usize)
}

/// ESF-RAW payload (4 reserved bytes, then 8-byte blocks) → (time tag, block index range) per
/// group of consecutive equal tags, without allocating.
pub fn raw_groups(p: &[u8]) -> RawGroups<'_> {
    RawGroups {
        p,
        b: 0,
        n: p.len().saturating_sub(4) / 8,
    }
}

/// Iterator of [`raw_groups`].
pub struct RawGroups<'a> {
    p: &'a [u8],
    b: usize,
    n: usize,
}

impl RawGroups<'_> {
    #[inline]
    fn tag(&self, b: usize) -> u32 {
        let o = 4 + 8 * b + 4;
        u32::from_le_bytes([self.p[o], self.p[o + 1], self.p[o + 2], self.p[o + 3]])
    }
}

impl Iterator for RawGroups<'_> {
    type Item = (u32, Range<usize>);
    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.b >= self.n {
            return None;
        }
        let start = self.b;
        let tag = self.tag(start);
        self.b += 1;
        while self.b < self.n && self.tag(self.b) == tag {
            self.b += 1;
        }
        Some((tag, start..self.b))
    }
}

/// ESF-MEAS payload → (time tag, data words), or `None` when the length does not match numMeas.
pub fn meas_words(p: &[u8]) -> Option<(u32, impl Iterator<Item = u32> + '_)> {
    if p.len() < 8 {
        return None;
    }
    let tag = u32::from_le_bytes([p[0], p[1], p[2], p[3]]);
    let flags = u16::from_le_bytes([p[4], p[5]]);
    let n = (flags >> 11) as usize;
    let calib = flags & 0x08 != 0;
    if p.len() != 8 + 4 * n + if calib { 4 } else { 0 } {
        return None;
    }
    Some((
        tag,
        (0..n).map(move |i| {
            let o = 8 + 4 * i;
            u32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]])
        }),
    ))
}

/// Write the cleaned values of `s` into its slot of a copy of the carrier frame(s): gyro,
/// accel and temperature fields at the protocol's resolution; a non-finite cleaned value keeps
/// the original field. The checksum is fixed by [`finish`].
pub fn patch(frame: &mut [u8], slot: u16, s: &Sample) {
    if frame.len() < 8 || frame[2] != CLASS_ESF {
        return;
    }
    let plen = frame.len() - 8;
    let ch = s.channels();
    let value = |ty: u8| -> Option<f64> {
        match slot_of(ty)? {
            6 => s.temp_c,
            k => Some(ch[k]),
        }
    };
    let put = |frame: &mut [u8], o: usize, ty_mask: u32| {
        let word = u32::from_le_bytes([frame[o], frame[o + 1], frame[o + 2], frame[o + 3]]);
        let ty = ((word >> 24) & ty_mask) as u8;
        if let Some(raw) = value(ty).and_then(|v| raw_of(ty, v)) {
            let w = (word & 0xFF00_0000) | (raw as u32 & 0x00FF_FFFF);
            frame[o..o + 4].copy_from_slice(&w.to_le_bytes());
        }
    };
    match frame[3] {
        ID_ESF_RAW if plen >= 4 && (plen - 4).is_multiple_of(8) => {
            let group = raw_groups(&frame[6..6 + plen]).nth(slot as usize);
            if let Some((_, r)) = group {
                for b in r.clone() {
                    put(frame, 6 + 4 + 8 * b, 0xFF);
                }
            }
        }
        ID_ESF_MEAS if plen >= 8 => {
            let flags = u16::from_le_bytes([frame[10], frame[11]]);
            let n = (flags >> 11) as usize;
            if 8 + 4 * n <= plen {
                for i in 0..n {
                    put(frame, 6 + 8 + 4 * i, 0x3F);
                }
            }
        }
        _ => {}
    }
}

/// Recompute the checksum of a UBX frame in place.
pub fn finish(frame: &mut [u8]) {
    let n = frame.len();
    if n >= 8 {
        let c = checksum(&frame[2..n - 2]);
        frame[n - 2..].copy_from_slice(&c);
    }
}

/// Append one UBX frame.
pub fn encode_frame(class: u8, id: u8, payload: &[u8], out: &mut BytesMut) {
    let start = out.len();
    out.extend_from_slice(&SYNC);
    out.extend_from_slice(&[class, id]);
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    out.extend_from_slice(payload);
    let c = checksum(&out[start + 2..]);
    out.extend_from_slice(&c);
}

/// Append an ESF-RAW message carrying `samples` (one time tag each; gyro x/y/z, accel x/y/z and
/// the temperature when present), as a receiver would send it.
pub fn encode_esf_raw(samples: &[(u32, Sample)], out: &mut BytesMut) {
    let mut p = vec![0u8; 4];
    for (tag, s) in samples {
        let ch = s.channels();
        let mut put = |ty: u8, v: f64| {
            if let Some(raw) = raw_of(ty, v) {
                let w = ((ty as u32) << 24) | (raw as u32 & 0x00FF_FFFF);
                p.extend_from_slice(&w.to_le_bytes());
                p.extend_from_slice(&(tag & 0x00FF_FFFF).to_le_bytes());
            }
        };
        for (c, ty) in CHANNEL_TYPES.iter().enumerate() {
            put(*ty, ch[c]);
        }
        if let Some(t) = s.temp_c {
            put(TYPE_GYRO_TEMP, t);
        }
    }
    encode_frame(CLASS_ESF, ID_ESF_RAW, &p, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_extension_and_scales() {
        assert_eq!(value24(0x00FF_FFFF), -1);
        assert_eq!(value24(0x0E80_0000), -8_388_608);
        assert_eq!(value24(0x107F_FFFF), 8_388_607);
        // 10091 counts of accel = 9.8545 m/s² (a real ZED-F9R z-axis reading at rest).
        assert!((physical(TYPE_ACCEL_Z, 10091).unwrap() - 10091.0 / 1024.0).abs() < 1e-12);
        assert_eq!(
            raw_of(TYPE_GYRO_X, physical(TYPE_GYRO_X, -5).unwrap()),
            Some(-5)
        );
    }

    #[test]
    fn raw_groups_join_equal_tags() {
        let mut p = vec![0u8; 4];
        for tag in [5u32, 5, 5, 9, 9, 5] {
            p.extend_from_slice(&0u32.to_le_bytes());
            p.extend_from_slice(&tag.to_le_bytes());
        }
        let g: Vec<(u32, Range<usize>)> = raw_groups(&p).collect();
        assert_eq!(g, vec![(5, 0..3), (9, 3..5), (5, 5..6)]);
        assert_eq!(raw_groups(&p[..4]).count(), 0);
    }

    #[test]
    fn blockwise_checksum_equals_the_byte_loop() {
        let bytewise = |bytes: &[u8]| {
            let (mut a, mut b) = (0u8, 0u8);
            for &x in bytes {
                a = a.wrapping_add(x);
                b = b.wrapping_add(a);
            }
            [a, b]
        };
        // Every length 0..600 (all remainders, many blocks) of a seeded byte stream, and runs
        // of 0xFF, where the u32 sums wrap the most.
        let mut rng = crate::rng::Rng::new(14);
        let bytes: Vec<u8> = (0..600).map(|_| (rng.uniform() * 256.0) as u8).collect();
        for n in 0..bytes.len() {
            assert_eq!(checksum(&bytes[..n]), bytewise(&bytes[..n]), "length {n}");
        }
        let ff = vec![0xFFu8; 70_000];
        assert_eq!(checksum(&ff), bytewise(&ff));
    }

    #[test]
    fn type_table_gives_the_same_doubles_as_the_unit_formulas() {
        // The formulas the table replaced, compared bit for bit over the whole 24-bit range
        // (every 97th value and both ends).
        let formula = |ty: u8, v: f64| match ty {
            TYPE_GYRO_X | TYPE_GYRO_Y | TYPE_GYRO_Z => Some((v * GYRO_LSB_DEG_S).to_radians()),
            TYPE_ACCEL_X | TYPE_ACCEL_Y | TYPE_ACCEL_Z => Some(v * ACCEL_LSB_M_S2),
            TYPE_GYRO_TEMP => Some(v * TEMP_LSB_C),
            _ => None,
        };
        for ty in 0..=255u8 {
            for raw in (-8_388_608..=8_388_607)
                .step_by(97)
                .chain([8_388_607, -1, 0, 1])
            {
                let want = formula(ty, raw as f64).map(f64::to_bits);
                assert_eq!(
                    physical(ty, raw).map(f64::to_bits),
                    want,
                    "type {ty} raw {raw}"
                );
                if formula(ty, 1.0).is_none() {
                    break; // the whole range for the IMU types, one value for the others
                }
            }
        }
    }
}
