//! ULog format definitions ('F' messages): the fields of each topic, and from them where the
//! IMU values of a subscribed topic sit in its data messages. Offsets follow the definitions
//! (nested types and arrays included); trailing padding may be omitted on the wire.

use std::collections::HashMap;

/// One field of a format: type name, array length (1 if scalar), field name.
#[derive(Clone, Debug)]
struct Field {
    ty: String,
    n: usize,
    name: String,
}

fn primitive_size(ty: &str) -> Option<usize> {
    Some(match ty {
        "int8_t" | "uint8_t" | "bool" | "char" => 1,
        "int16_t" | "uint16_t" => 2,
        "int32_t" | "uint32_t" | "float" => 4,
        "int64_t" | "uint64_t" | "double" => 8,
        _ => return None,
    })
}

/// A format message's body ("name:type field;type field;…") → topic name and fields.
fn parse_format(body: &[u8]) -> Option<(String, Vec<Field>)> {
    let text = std::str::from_utf8(body).ok()?;
    let (name, rest) = text.split_once(':')?;
    let mut fields = Vec::new();
    for f in rest.split(';').filter(|f| !f.is_empty()) {
        let (ty, fname) = f.trim().split_once(' ')?;
        let (ty, n) = match ty.split_once('[') {
            Some((t, k)) => (t, k.trim_end_matches(']').parse::<usize>().ok()?),
            None => (ty, 1),
        };
        fields.push(Field {
            ty: ty.to_string(),
            n,
            name: fname.to_string(),
        });
    }
    Some((name.to_string(), fields))
}

/// Whether a format message's body parses (a content check against misread headers).
pub fn is_format(body: &[u8]) -> bool {
    parse_format(body).is_some()
}

/// PX4's `sensor_combined.RELATIVE_TIMESTAMP_INVALID`: a relative time stamp with this value
/// says the associated sensor values are invalid.
pub const RELATIVE_TIMESTAMP_INVALID: i32 = i32::MAX;

/// Where the IMU values of a subscribed topic sit in its data message (offsets from the start
/// of the fields, after msg_id).
#[derive(Clone, Copy, Debug, Default)]
pub struct Layout {
    pub time: usize,
    /// Offset of three consecutive f32: gyro (sensor_combined `gyro_rad`, sensor_gyro x y z) or
    /// accel.
    pub xyz: usize,
    /// sensor_combined: offset of `accelerometer_m_s2`.
    pub accel: Option<usize>,
    /// sensor_combined: offset of `accelerometer_timestamp_relative` (int32;
    /// [`RELATIVE_TIMESTAMP_INVALID`] there = the accelerometer values are invalid).
    pub accel_rel: Option<usize>,
    pub temp: Option<usize>,
    /// Bytes of fields needed.
    pub need: usize,
}

/// What an IMU topic gives a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// `sensor_combined`: gyro and accel in one message.
    Combined,
    /// `sensor_gyro` / `sensor_accel`: one half each, paired.
    Gyro,
    Accel,
}

/// Field name → (byte offset, type, array length).
type FieldOffsets = HashMap<String, (usize, String, usize)>;

/// The format definitions seen so far.
#[derive(Clone, Debug, Default)]
pub struct Formats {
    formats: HashMap<String, Vec<Field>>,
}

impl Formats {
    /// Learn a format message's body; `false` when it does not parse.
    pub fn add(&mut self, body: &[u8]) -> bool {
        match parse_format(body) {
            Some((name, fields)) => {
                self.formats.insert(name, fields);
                true
            }
            None => false,
        }
    }

    fn size_of(&self, ty: &str, depth: usize) -> Option<usize> {
        if let Some(s) = primitive_size(ty) {
            return Some(s);
        }
        if depth > 8 {
            return None;
        }
        let fields = self.formats.get(ty)?;
        fields
            .iter()
            .map(|f| self.size_of(&f.ty, depth + 1).map(|s| s * f.n))
            .sum()
    }

    /// Byte offset of each named field of `topic`, and the topic's size.
    fn offsets(&self, topic: &str) -> Option<(FieldOffsets, usize)> {
        let fields = self.formats.get(topic)?;
        let mut o = 0;
        let mut m = HashMap::new();
        for f in fields {
            let s = self.size_of(&f.ty, 0)?;
            m.insert(f.name.clone(), (o, f.ty.clone(), f.n));
            o += s * f.n;
        }
        Some((m, o))
    }

    /// Bytes of a topic's fields, when its format (and every nested one) is known.
    pub fn topic_size(&self, topic: &str) -> Option<usize> {
        self.offsets(topic).map(|(_, n)| n)
    }

    /// Where the IMU values of `topic` are for `role`; `None` when a field is missing or has
    /// another type.
    pub fn layout(&self, topic: &str, role: Role) -> Option<Layout> {
        let (m, _) = self.offsets(topic)?;
        let at = |name: &str, ty: &str, n: usize| {
            m.get(name)
                .filter(|(_, t, k)| t == ty && *k >= n)
                .map(|(o, _, _)| *o)
        };
        let time =
            at("timestamp_sample", "uint64_t", 1).or_else(|| at("timestamp", "uint64_t", 1))?;
        let (xyz, accel) = match role {
            Role::Combined => (
                at("gyro_rad", "float", 3)?,
                Some(at("accelerometer_m_s2", "float", 3)?),
            ),
            _ => {
                let x = at("x", "float", 1)?;
                if at("y", "float", 1)? != x + 4 || at("z", "float", 1)? != x + 8 {
                    return None;
                }
                (x, None)
            }
        };
        let temp = at("temperature", "float", 1);
        let accel_rel = accel.and(at("accelerometer_timestamp_relative", "int32_t", 1));
        let need = [
            time + 8,
            xyz + 12,
            accel.map_or(0, |a| a + 12),
            temp.map_or(0, |t| t + 4),
            accel_rel.map_or(0, |r| r + 4),
        ]
        .into_iter()
        .max()
        .unwrap_or(0);
        Some(Layout {
            time,
            xyz,
            accel,
            accel_rel,
            temp,
            need,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_types_and_arrays_give_offsets() {
        let mut f = Formats::default();
        assert!(f.add(b"vec3:float x;float y;float z;"));
        assert!(f.add(b"imu:uint64_t timestamp;uint8_t[3] pad;vec3[2] v;float temperature;"));
        assert!(!f.add(b"no colon here"));
        assert_eq!(f.topic_size("imu"), Some(8 + 3 + 24 + 4));
        assert_eq!(f.topic_size("unknown"), None);
        // `x y z` are not fields of `imu` itself: no gyro layout.
        assert!(f.layout("imu", Role::Gyro).is_none());
        let g = f.layout("vec3", Role::Gyro);
        assert!(g.is_none(), "no timestamp");
    }
}
