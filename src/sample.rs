//! The unit that flows through imuprep: one IMU measurement with its flags.
//!
//! Channels are indexed 0..6 as `gx, gy, gz, ax, ay, az` (see [`CHANNEL_NAMES`]); per-channel
//! stages use [`Sample::channel`] / [`Sample::set_channel`] so they need not know which sensor a
//! channel belongs to. Gyro in rad/s, accel (specific force) in m/s², temperature in °C.

use nalgebra::Vector3;

/// Number of inertial channels in a sample (3 gyro + 3 accel).
pub const N_CHANNELS: usize = 6;
/// Channel names in index order, as used in CSV headers, configs and reports.
pub const CHANNEL_NAMES: [&str; N_CHANNELS] = ["gx", "gy", "gz", "ax", "ay", "az"];

/// Bit mask of all six channels (`absent` masks: bit `c` for channel `c`).
pub const ALL_CHANNELS: u8 = 0x3f;

/// The names of the channels set in `mask` (bit `c` = channel `c`), in index order.
pub fn channel_names_of(mask: u8) -> Vec<&'static str> {
    CHANNEL_NAMES
        .iter()
        .enumerate()
        .filter(|(c, _)| mask & (1 << c) != 0)
        .map(|(_, n)| *n)
        .collect()
}

/// Index of a channel by its name (`gx` … `az`).
pub fn channel_index(name: &str) -> Option<usize> {
    CHANNEL_NAMES.iter().position(|n| *n == name)
}

/// Status and processing flags carried on every sample (and on the wire as a `u32`).
///
/// Bits 0–7 come from the sensor (or the import / simulator acting as one); bits 8 and up are
/// set by imuprep itself.
pub mod flags {
    /// Gyro x/y/z saturated (at or beyond the descriptor's range). Bit `i` for axis `i`.
    pub const SAT_GYRO_X: u32 = 1 << 0;
    pub const SAT_GYRO_Y: u32 = 1 << 1;
    pub const SAT_GYRO_Z: u32 = 1 << 2;
    /// Accel x/y/z saturated. Bit `3 + i` for axis `i`.
    pub const SAT_ACCEL_X: u32 = 1 << 3;
    pub const SAT_ACCEL_Y: u32 = 1 << 4;
    pub const SAT_ACCEL_Z: u32 = 1 << 5;
    /// All six saturation bits.
    pub const SAT_ANY: u32 = 0x3f;
    /// The sensor reported an internal fault for this sample.
    pub const SENSOR_FAULT: u32 = 1 << 6;
    /// One or more frames are missing before this sample (sequence gap).
    pub const GAP: u32 = 1 << 8;
    /// This sample repeats the sequence number of one already seen.
    pub const DUPLICATE: u32 = 1 << 9;
    /// At least one channel held NaN or ±Inf on arrival.
    pub const NON_FINITE: u32 = 1 << 10;
    /// The bias stage ran an estimate for this sample and publishes it with its σ (`bias`,
    /// `bias_sd`). `bias[c]` is what it subtracted from channel `c`: 0 for a gyro whose warm-up
    /// estimate is not yet beyond `apply_k` σ of zero (published, not subtracted). Whether
    /// anything was subtracted: [`Sample::bias_subtracted`](crate::sample::Sample::bias_subtracted).
    pub const BIAS_REMOVED: u32 = 1 << 11;
    /// A stage is still identifying its model; its correction was not applied.
    pub const WARMING_UP: u32 = 1 << 12;
    /// The gross-error stage gave up on a run longer than its limit and accepted a level change.
    pub const LEVEL_CHANGE: u32 = 1 << 13;
    /// The stillness detector considers the sensor at rest.
    pub const STILL: u32 = 1 << 14;
    /// At least one channel was replaced by the gross-error stage (see the per-channel bits).
    pub const REPLACED: u32 = 1 << 15;
    /// Per-channel replaced bits: bit `16 + c` for channel `c` (gx..az).
    pub const REPLACED_CH0: u32 = 1 << 16;
    /// All six per-channel replaced bits.
    pub const REPLACED_ANY: u32 = 0x3f << 16;
    /// A learned effect (temperature, vibration line, g-sensitivity, step) was compensated.
    pub const EFFECT_COMPENSATED: u32 = 1 << 22;
    /// Per-channel suspect bits, bit `24 + c` for channel `c`: the gross-error gate fired on
    /// this value but the evidence did not show a gross error (it may be real motion), so the
    /// value was passed unchanged. A filter may down-weight it; nothing was replaced.
    pub const SUSPECT_CH0: u32 = 1 << 24;
    /// All six per-channel suspect bits.
    pub const SUSPECT_ANY: u32 = 0x3f << 24;
    /// All six channels are bit-identical to the previous sample's: a stale repeat (a logger
    /// writing faster than its sensor, a stuck bus), not a new measurement. Stages give it the
    /// verdicts of the measurement it repeats and learn nothing from it.
    pub const REPEATED: u32 = 1 << 30;

    /// Per-channel replaced bit for channel `c`.
    #[inline]
    pub const fn replaced_ch(c: usize) -> u32 {
        REPLACED_CH0 << c
    }
    /// Per-channel suspect bit for channel `c`.
    #[inline]
    pub const fn suspect_ch(c: usize) -> u32 {
        SUSPECT_CH0 << c
    }
    /// Saturation bit for channel `c`.
    #[inline]
    pub const fn sat_ch(c: usize) -> u32 {
        1 << c
    }
}

/// One IMU measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Frame sequence counter from the wire (wraps at `u32::MAX`).
    pub seq: u32,
    /// Sensor time, ns (monotonic, from the sensor; never the host clock).
    pub t_ns: u64,
    /// Angular rate, rad/s, body frame.
    pub gyro: Vector3<f64>,
    /// Specific force, m/s², body frame (gravity included).
    pub accel: Vector3<f64>,
    /// Sensor temperature, °C; `None` when the sensor does not report it.
    pub temp_c: Option<f64>,
    /// Bit set of [`flags`].
    pub flags: u32,
    /// Bias estimate subtracted by the bias stage, per channel (rad/s or m/s²); zero if none.
    pub bias: [f32; N_CHANNELS],
    /// 1-σ uncertainty of `bias`, per channel; zero if no estimate.
    pub bias_sd: [f32; N_CHANNELS],
    /// Channels the sensor does not have (bit `c` for channel `c`; a gyro-only recording has
    /// `0b111000`). An absent channel holds NaN, which is no measurement: stages leave it alone
    /// (no bias learned, no gross-error decision, no stillness vote) and it is neither flagged
    /// non-finite nor replaced. On the wire it is the descriptor's absent mask
    /// (`docs/frame-format.md`).
    pub absent: u8,
}

impl Default for Sample {
    fn default() -> Self {
        Sample {
            seq: 0,
            t_ns: 0,
            gyro: Vector3::zeros(),
            accel: Vector3::zeros(),
            temp_c: None,
            flags: 0,
            bias: [0.0; N_CHANNELS],
            bias_sd: [0.0; N_CHANNELS],
            absent: 0,
        }
    }
}

impl Sample {
    /// The `i`-th sample of a stream that starts at t = 0 with one sample every `period_ns`:
    /// `seq` = i (wrapping as the wire's counter does), `t_ns` = i · `period_ns`, the rest as
    /// [`Sample::default`] (channels 0, no temperature, no flags).
    pub fn nth(i: usize, period_ns: u64) -> Sample {
        Sample {
            seq: i as u32,
            t_ns: i as u64 * period_ns,
            ..Sample::default()
        }
    }

    /// Value of channel `c` (0..6: gx gy gz ax ay az).
    #[inline]
    pub fn channel(&self, c: usize) -> f64 {
        if c < 3 {
            self.gyro[c]
        } else {
            self.accel[c - 3]
        }
    }

    /// Set channel `c` (0..6: gx gy gz ax ay az).
    #[inline]
    pub fn set_channel(&mut self, c: usize, v: f64) {
        if c < 3 {
            self.gyro[c] = v
        } else {
            self.accel[c - 3] = v
        }
    }

    /// All six channels as an array.
    #[inline]
    pub fn channels(&self) -> [f64; N_CHANNELS] {
        [
            self.gyro[0],
            self.gyro[1],
            self.gyro[2],
            self.accel[0],
            self.accel[1],
            self.accel[2],
        ]
    }

    /// Build from six channel values.
    #[inline]
    pub fn set_channels(&mut self, v: &[f64; N_CHANNELS]) {
        self.gyro = Vector3::new(v[0], v[1], v[2]);
        self.accel = Vector3::new(v[3], v[4], v[5]);
    }

    /// Sensor time in seconds.
    #[inline]
    pub fn t_s(&self) -> f64 {
        self.t_ns as f64 * 1e-9
    }

    /// True if channel `c` is absent (the sensor has no such channel; see [`Sample::absent`]).
    #[inline]
    pub fn is_absent(&self, c: usize) -> bool {
        self.absent & (1 << c) != 0
    }

    #[inline]
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag != 0
    }

    /// The bias stage subtracted something from this sample (a running estimate beyond its
    /// evidence bar, a provisional warm-up mean, or an effect): `BIAS_REMOVED` with a non-zero
    /// published `bias` on some channel.
    #[inline]
    pub fn bias_subtracted(&self) -> bool {
        self.has(flags::BIAS_REMOVED) && self.bias.iter().any(|b| *b != 0.0)
    }
}

/// Where a reader puts the samples it keeps, in order: a `Vec<Sample>`, or [`Channels`], which
/// holds only what the whole-log analyses read.
pub trait SampleSink {
    /// At most `n` more samples will come (reserve once instead of growing by doubling).
    fn expect(&mut self, n: usize);
    fn push(&mut self, s: Sample);
}

impl SampleSink for Vec<Sample> {
    fn expect(&mut self, n: usize) {
        self.reserve(n);
    }
    fn push(&mut self, s: Sample) {
        Vec::push(self, s);
    }
}

/// A recording held by channel: the time stamps, each channel's values, the temperature while
/// every sample has one, and in how many samples each channel is absent. 64 bytes per sample
/// with the temperature where a [`Sample`] takes 136: what the whole-log analyses (`diagnose`,
/// `allan`, `compare`) hold of a log instead of its samples.
#[derive(Debug, Clone, Default)]
pub struct Channels {
    /// Each sample's sensor time, ns ([`Sample::t_ns`]).
    pub t_ns: Vec<u64>,
    /// Channel `c`'s values (0..6: gx gy gz ax ay az), one per sample.
    pub values: [Vec<f64>; N_CHANNELS],
    /// The temperature of every sample, °C; `None` once a sample has none.
    pub temp_c: Option<Vec<f64>>,
    /// The samples in which channel `c` is absent ([`Sample::absent`]).
    pub absent_in: [usize; N_CHANNELS],
    len: usize,
    /// Samples announced by [`SampleSink::expect`]: the temperature's reserve.
    expected: usize,
}

impl Channels {
    /// Samples held.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The channels absent in any sample (bit `c` for channel `c`).
    pub fn absent(&self) -> u8 {
        (0..N_CHANNELS)
            .filter(|&c| self.absent_in[c] > 0)
            .fold(0, |m, c| m | 1 << c)
    }

    /// Sample `i`'s sensor time, s ([`Sample::t_s`]).
    pub fn t_s(&self, i: usize) -> f64 {
        self.t_ns[i] as f64 * 1e-9
    }

    /// Sample `i`'s angular rate, rad/s ([`Sample::gyro`]).
    pub fn gyro(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.values[0][i], self.values[1][i], self.values[2][i])
    }

    /// Sample `i`'s specific force, m/s² ([`Sample::accel`]).
    pub fn accel(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.values[3][i], self.values[4][i], self.values[5][i])
    }

    /// The channels absent in sample `i` ([`Sample::absent`]): of the channels absent in any
    /// sample, those holding NaN here (an absent channel holds NaN). A channel present in every
    /// sample is never absent; one absent in only some samples (a descriptor changed mid-log)
    /// is taken as absent wherever it holds NaN, not flagged non-finite there.
    pub fn absent_at(&self, i: usize) -> u8 {
        (0..N_CHANNELS)
            .filter(|&c| self.absent_in[c] > 0 && self.values[c][i].is_nan())
            .fold(0, |m, c| m | 1 << c)
    }

    /// The first `n` samples only.
    pub fn truncate(&mut self, n: usize) {
        self.t_ns.truncate(n);
        for v in &mut self.values {
            v.truncate(n);
        }
        if let Some(t) = &mut self.temp_c {
            t.truncate(n);
        }
        self.len = self.len.min(n);
    }
}

impl SampleSink for Channels {
    fn expect(&mut self, n: usize) {
        self.t_ns.reserve(n);
        for v in &mut self.values {
            v.reserve(n);
        }
        if let Some(t) = &mut self.temp_c {
            t.reserve(n);
        }
        self.expected = self.len + n;
    }

    fn push(&mut self, s: Sample) {
        self.t_ns.push(s.t_ns);
        for (c, v) in s.channels().into_iter().enumerate() {
            self.values[c].push(v);
            self.absent_in[c] += usize::from(s.is_absent(c));
        }
        match (s.temp_c, self.len) {
            (Some(t), 0) => {
                let mut v = Vec::with_capacity(self.expected.max(1));
                v.push(t);
                self.temp_c = Some(v);
            }
            (Some(t), _) => {
                if let Some(v) = &mut self.temp_c {
                    v.push(t);
                }
            }
            (None, _) => self.temp_c = None,
        }
        self.len += 1;
    }
}

impl From<Vec<Sample>> for Channels {
    /// The samples by channel, each sample's memory given back as it is taken, so that a long
    /// recording is not held twice (136 bytes a sample as samples, 64 by channel) while it
    /// changes hands: the samples are taken from the back of the reversed vector, which is
    /// shrunk every sixteenth of the way (a large block shrinks in place).
    fn from(mut v: Vec<Sample>) -> Self {
        let mut c = Channels::default();
        c.expect(v.len());
        v.reverse();
        let step = (v.len() / 16).max(1 << 16);
        while let Some(s) = v.pop() {
            c.push(s);
            if v.len().is_multiple_of(step) {
                v.shrink_to_fit();
            }
        }
        c
    }
}

impl<'a> FromIterator<&'a Sample> for Channels {
    fn from_iter<I: IntoIterator<Item = &'a Sample>>(it: I) -> Self {
        let mut c = Channels::default();
        for s in it {
            c.push(*s);
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_ns: u64, v: [f64; 6], absent: u8) -> Sample {
        Sample {
            t_ns,
            gyro: Vector3::new(v[0], v[1], v[2]),
            accel: Vector3::new(v[3], v[4], v[5]),
            absent,
            ..Sample::default()
        }
    }

    #[test]
    fn channels_give_back_each_samples_vectors_time_and_absent_channels() {
        let nan = f64::NAN;
        let v = [
            // A gyro-only sample, a whole one with a non-finite gx, one whose gz is absent.
            sample(1_000, [1.0, 2.0, 3.0, nan, nan, nan], 0b111000),
            sample(2_000, [nan, 5.0, 6.0, 7.0, 8.0, 9.0], 0),
            sample(3_000, [1.5, 2.5, nan, 4.5, 5.5, 6.5], 0b000100),
        ];
        let ch: Channels = v.iter().collect();
        let taken = Channels::from(v.to_vec());
        assert_eq!(taken.t_ns, ch.t_ns);
        assert_eq!(taken.absent_in, ch.absent_in);
        for c in 0..N_CHANNELS {
            let bits = |x: &Channels| x.values[c].iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&taken), bits(&ch));
        }
        for (i, s) in v.iter().enumerate() {
            assert_eq!(ch.t_s(i), s.t_s());
            for c in 0..3 {
                assert_eq!(ch.gyro(i)[c].to_bits(), s.gyro[c].to_bits());
                assert_eq!(ch.accel(i)[c].to_bits(), s.accel[c].to_bits());
            }
        }
        // gx is absent nowhere, so its NaN in sample 1 is a non-finite value, not an absence.
        assert_eq!(ch.absent_at(0), 0b111000);
        assert_eq!(ch.absent_at(1), 0);
        assert_eq!(ch.absent_at(2), 0b000100);
    }
}
