//! Model health: the pipeline watching its own innovations at rest.
//!
//! Placed after the cleaning stages, the monitor changes no sample. While the sensor is still
//! (the bias stage's `STILL` flag) the pipeline's output is the bias stage's innovation: the
//! measurement minus the predicted bias and every modelled effect. Where the model holds that is
//! zero-mean noise with a smooth spectrum; the monitor looks, per channel, for
//!
//! - an **offset** the model does not explain — a step, a drift, a temperature term it lacks
//!   ([`step::LevelDetector`]: a window's mean output against the channel's own history; on an
//!   accelerometer, whose output at rest holds gravity's projection, the change of its median
//!   level from a reference level before it), and
//! - a **spectral line** — a vibration or an electrical line appearing ([`line::LineDetector`]:
//!   a moving Welch average, each bin against its neighbours), and
//! - a **wander** — the output losing its whiteness at tens of seconds, a bias instability the
//!   model lacks ([`wander::WanderDetector`]: the Allan variance's slope between two τ, or the
//!   variance of τ-means, against the channel's own, with an F-quantile bar from the estimates'
//!   degrees of freedom), and
//! - a **colour** at short lags — the output losing its whiteness within a few samples
//!   ([`whiteness::WhitenessDetector`]: the Ljung–Box statistic of the window's autocorrelations
//!   against the channel's own, with an F-quantile bar),
//!
//! and publishes a status — `model fits`, `learning`, or `effect suspected: …` with the channel,
//! the size and the time — in the health data, so the user learns that `imuprep diagnose` should
//! be rerun before the error reaches the navigation solution. Every test learns its scale from
//! the channel itself (no absolute threshold), so they follow the sensor's own noise. Motion is
//! not tested (the output then is motion, not innovation). A sample that cannot be used — not
//! judged still, or a replaced, saturated or non-finite value — is skipped: the offset, wander
//! and whiteness tests bridge up to a second of them in a row ([`learn::Bridge`]); more, or a
//! gap, break the still run and each test starts its run again. The line test starts a new
//! segment at every skip (a short stillness dropout can be a knock whose ringing would enter
//! the segment: bridged, it raised a transient 24.8-Hz "line" on the ADIS16405 bench).

pub mod learn;
pub mod line;
pub mod settings;
pub mod step;
#[cfg(test)]
mod test_signals;
pub mod wander;
pub mod whiteness;

use crate::sample::{ALL_CHANNELS, CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use crate::stage::Stage;
use crate::stage::health::StageHealth;
use line::{LineDetector, LineEvent};
pub use settings::{MonitorSettings, WanderStatistic};
use std::collections::VecDeque;
use step::LevelDetector;
use wander::WanderDetector;
use whiteness::WhitenessDetector;

/// Positive sample intervals used to learn the rate.
const RATE_INTERVALS: usize = 64;
/// Alarms kept for the status.
const KEEP_EVENTS: usize = 16;

/// What an alarm found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Finding {
    /// A window's mean output off zero by this much (channel unit).
    Offset(f64),
    /// A line at this frequency, Hz (and its index among the channel's lines).
    Line(f64, usize),
    /// More variance at this τ (s) than the channel's own (the ratio is the score; Allan
    /// variance or the τ-means' variance, [`WanderStatistic`]).
    Wander(f64),
    /// Autocorrelations at short lags changed: the window's Ljung–Box `Q` and the channel's
    /// own (the score is the change in the channel's own scatter, an F variate).
    Whiteness(f64, f64),
}

/// One alarm of the monitor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alarm {
    pub channel: usize,
    /// Sensor time the effect was first seen, ns.
    pub t_ns: u64,
    pub finding: Finding,
    /// Its size against the channel's own scale (σ for an offset, power ratio for a line,
    /// variance ratio for a wander, the F score of the autocorrelations' change for whiteness).
    pub score: f64,
}

impl std::fmt::Display for Alarm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = CHANNEL_NAMES[self.channel];
        let t = self.t_ns as f64 * 1e-9;
        match self.finding {
            Finding::Offset(v) if self.channel < 3 => write!(
                f,
                "{name} offset {:+.4} °/s since {t:.1} s ({:.1} σ)",
                v.to_degrees(),
                self.score
            ),
            Finding::Offset(v) => write!(
                f,
                "{name} offset {v:+.5} m/s² since {t:.1} s ({:.1} σ)",
                self.score
            ),
            Finding::Line(hz, _) => write!(
                f,
                "{name} line ≈ {hz:.3} Hz since {t:.1} s ({:.0}× its neighbours)",
                self.score
            ),
            Finding::Wander(tau) => write!(
                f,
                "{name} wander since {t:.1} s (variance at {tau:.0} s {:.1}× its own)",
                self.score
            ),
            Finding::Whiteness(q, q0) => write!(
                f,
                "{name} output no longer white since {t:.1} s (Ljung–Box Q {q:.0} vs its own \
                 {q0:.0}; change {:.1}× its own scatter)",
                self.score
            ),
        }
    }
}

struct Channel {
    level: LevelDetector,
    line: LineDetector,
    wander: WanderDetector,
    whiteness: WhitenessDetector,
}

impl Channel {
    /// A sample that cannot be used (not still, or a bad value): the detectors that bridge short
    /// skips skip it; the line detector's segment is broken.
    fn skip(&mut self) {
        self.level.skip();
        self.line.interrupt();
        self.wander.skip();
        self.whiteness.skip();
    }

    /// The still run is broken (a gap): every detector starts a new run.
    fn interrupt(&mut self) {
        self.level.interrupt();
        self.line.interrupt();
        self.wander.interrupt();
        self.whiteness.interrupt();
    }
}

/// The monitor's health: its counters since the start and its status now.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MonitorHealth {
    /// Offsets the model does not explain, raised so far.
    pub offset_alarms: u64,
    /// New spectral lines raised so far (a returning line is not counted again).
    pub line_alarms: u64,
    /// Wanders (Allan-slope changes) raised so far.
    pub wander_alarms: u64,
    /// Losses of whiteness (Ljung–Box changes) raised so far.
    pub whiteness_alarms: u64,
    /// Channels whose offset test has learned enough to be armed now.
    pub armed_channels: u64,
    /// Still samples watched.
    pub still_samples: u64,
    /// "model fits …", "learning …" or "effect suspected: …".
    pub status: String,
}

/// The model-health monitor (a pass-through stage).
pub struct MonitorStage {
    settings: MonitorSettings,
    last_t_ns: Option<u64>,
    intervals: Vec<u64>,
    fs: Option<f64>,
    ch: Vec<Channel>,
    alarms: VecDeque<Alarm>,
    offset_alarms: u64,
    line_alarms: u64,
    wander_alarms: u64,
    whiteness_alarms: u64,
    still_samples: u64,
    line_events: Vec<LineEvent>,
    /// Whether the bias stage subtracted a bias from each channel in the last sample.
    subtracting: [bool; N_CHANNELS],
    /// Channels present in any sample so far (bit c; a gyro-only table has 3).
    present: u8,
}

impl MonitorStage {
    /// A monitor for a sensor at `rate_hz` (declared, e.g. by a log's descriptor); `None`:
    /// learned from the first time stamps (their median interval).
    pub fn new(settings: MonitorSettings, rate_hz: Option<f64>) -> Result<Self, String> {
        settings.validate().map_err(|e| e.join("; "))?;
        let mut m = MonitorStage {
            settings,
            last_t_ns: None,
            intervals: Vec::with_capacity(RATE_INTERVALS),
            fs: None,
            ch: Vec::new(),
            alarms: VecDeque::with_capacity(KEEP_EVENTS),
            offset_alarms: 0,
            line_alarms: 0,
            wander_alarms: 0,
            whiteness_alarms: 0,
            still_samples: 0,
            line_events: Vec::new(),
            subtracting: [false; N_CHANNELS],
            present: 0,
        };
        if let Some(fs) = rate_hz.filter(|f| f.is_finite() && *f > 0.0) {
            m.start(fs);
        }
        Ok(m)
    }

    /// The rate the monitor learned from the time stamps, Hz.
    pub fn sample_rate_hz(&self) -> Option<f64> {
        self.fs
    }

    /// Every alarm kept (the last 16), oldest first.
    pub fn alarms(&self) -> impl Iterator<Item = &Alarm> {
        self.alarms.iter()
    }

    /// The offset (level) detector of channel `c` (its learned scale), once the rate is known.
    pub fn level(&self, c: usize) -> Option<&LevelDetector> {
        self.ch.get(c).map(|ch| &ch.level)
    }

    /// The wander detector of channel `c` (its learned baseline and bar), once the rate is known.
    pub fn wander(&self, c: usize) -> Option<&WanderDetector> {
        self.ch.get(c).map(|ch| &ch.wander)
    }

    /// The whiteness detector of channel `c`, once the rate is known.
    pub fn whiteness(&self, c: usize) -> Option<&WhitenessDetector> {
        self.ch.get(c).map(|ch| &ch.whiteness)
    }

    /// Channels whose offset test is armed.
    pub fn armed_channels(&self) -> usize {
        self.ch.iter().filter(|c| c.level.armed()).count()
    }

    /// One line for people and for the health record.
    pub fn status(&self) -> String {
        let now = self.last_t_ns.unwrap_or(0);
        let hold = (self.settings.hold_s * 1e9) as u64;
        let recent: Vec<String> = self
            .alarms
            .iter()
            .filter(|a| now.saturating_sub(a.t_ns) <= hold || self.holding(a))
            .map(|a| a.to_string())
            .collect();
        if !recent.is_empty() {
            return format!("effect suspected: {}", recent.join("; "));
        }
        let armed = self.armed_channels();
        if armed > 0 {
            // Of the channels the sensor has: a gyro-only table's 3 of 3, not 3 of 6.
            let of = match self.present.count_ones() {
                0 => N_CHANNELS,
                n => n as usize,
            };
            return format!("model fits ({armed} of {of} channels armed)");
        }
        let Some(fs) = self.fs else {
            return "learning the sample rate".into();
        };
        let seen = self.still_samples as f64 / fs;
        if seen < self.settings.learn_s {
            return format!(
                "learning ({seen:.0} s still seen of {:.0} s needed)",
                self.settings.learn_s
            );
        }
        // Enough still time, but the offset test also needs quiet windows of unbroken still
        // data to learn its scale from: say so rather than repeat a need already met.
        // The channel nearest to arming (the accelerometers' tests need more, and longer, runs).
        let (learned, needed, blocks) = self
            .ch
            .iter()
            .map(|c| {
                let (l, n) = c.level.learned_windows();
                (l, n, c.level.test_blocks())
            })
            .max_by(|a, b| (a.0 * b.1 as u64).cmp(&(b.0 * a.1 as u64)))
            .unwrap_or((0, 0, 0));
        format!(
            "learning ({seen:.0} s still seen; the offset test has learned {learned} of the \
             {needed} window means it needs, each from {:.0} s of unbroken still data)",
            blocks as f64 * self.settings.block_s
        )
    }

    /// Whether the alarm's effect is still present (an offset alarm holding, a line active).
    fn holding(&self, a: &Alarm) -> bool {
        let Some(c) = self.ch.get(a.channel) else {
            return false;
        };
        match a.finding {
            Finding::Offset(_) => c.level.active(),
            Finding::Line(_, id) => c.line.is_active(id),
            Finding::Wander(_) => c.wander.active(),
            Finding::Whiteness(..) => c.whiteness.active(),
        }
    }

    fn record(&mut self, a: Alarm) {
        if self.alarms.len() == KEEP_EVENTS {
            self.alarms.pop_front();
        }
        tracing::warn!(alarm = %a, "model health: effect suspected — rerun `imuprep diagnose`");
        self.alarms.push_back(a);
    }

    fn learn_rate(&mut self, t_ns: u64) {
        if let Some(prev) = self.last_t_ns
            && t_ns > prev
        {
            self.intervals.push(t_ns - prev);
        }
        if self.intervals.len() < RATE_INTERVALS {
            return;
        }
        let mid = self.intervals.len() / 2;
        let (_, m, _) = self.intervals.select_nth_unstable(mid);
        let fs = 1e9 / *m as f64;
        self.start(fs);
    }

    fn start(&mut self, fs: f64) {
        self.ch = (0..N_CHANNELS).map(|c| self.channel(c, fs)).collect();
        self.subtracting = [false; N_CHANNELS];
        self.fs = Some(fs);
        self.intervals = Vec::new();
    }

    /// Channel `c`'s detectors, learning from nothing, at `fs` Hz.
    fn channel(&self, c: usize, fs: f64) -> Channel {
        let st = &self.settings;
        let seg_n = (st.line_segment_s * fs).round() as usize;
        let wb_n = (st.wander_block_s * fs).round().max(1.0) as usize;
        let wb_s = wb_n as f64 / fs;
        let w_blocks = (st.wander_window_s / wb_s).round() as usize;
        let w_m = (st.wander_tau_s / wb_s).round() as usize;
        let w_learn = (st.learn_s / wb_s).ceil() as usize;
        let wh_n = (st.whiteness_block_s * fs).round().max(1.0) as usize;
        let wh_blocks = (st.whiteness_window_s / st.whiteness_block_s).round() as usize;
        let wh_learn = (st.learn_s * fs).ceil() as u64;
        let bridge = bridge_samples(fs);
        Channel {
            level: self.level_detector(c, fs),
            line: LineDetector::new(seg_n, st.line_averages, st.line_k, fs),
            wander: WanderDetector::new(wb_n, wb_s, w_blocks, w_m, st.wander_p, w_learn)
                .with_statistic(st.wander_statistic),
            whiteness: WhitenessDetector::new(
                (st.whiteness_segment_s * fs).round() as usize,
                wh_n,
                wh_blocks,
                st.whiteness_lags,
                st.whiteness_p,
                wh_learn,
                bridge,
            ),
        }
    }

    /// Channel `c`'s offset (level) detector, learning from nothing, at `fs` Hz.
    fn level_detector(&self, c: usize, fs: f64) -> LevelDetector {
        let st = &self.settings;
        let block_n = (st.block_s * fs).round().max(1.0) as usize;
        let window_blocks = (st.window_s / st.block_s).round().max(1.0) as usize;
        let learn_blocks = (st.learn_s / st.block_s).ceil() as usize;
        let level = LevelDetector::new(
            block_n,
            window_blocks,
            st.offset_k,
            learn_blocks,
            bridge_samples(fs),
        );
        // An accelerometer's output at rest holds gravity's projection: its level is tested
        // against a reference level before it, not against zero.
        if c >= 3 {
            level.against_reference()
        } else {
            level
        }
    }

    /// A channel's output is the model's innovation only once the bias stage subtracts its
    /// estimate there; the engagement (at most once a channel and run) is a step of the whole
    /// bias. What the detectors saw before it was the raw value:
    /// - A line segment across it saw that step, not noise: its spectrum falls off from the
    ///   lowest bins, and on a sensor whose bias is hundreds of times its noise the first average
    ///   raised a "line" at 0.4–0.5 Hz (7 of 12 simulated white-noise benches, 10 min each). The
    ///   segment is dropped (complete segments before it carry a constant bias, which each
    ///   segment's mean removes).
    /// - The offset test starts learning again: a window mean holding seconds of the raw bias
    ///   had entered its learned scale, 9–34× the innovation's on such benches, and no step
    ///   below that was ever flagged. Its bar follows the degrees of freedom the scale is
    ///   learned from ([`LevelDetector::bar`]).
    ///
    /// The wander and whiteness tests (off by default) are left as they are: see
    /// docs/model-health.md, "The bias stage's engagement".
    fn restart_at_engagement(&mut self, s: &Sample) {
        let Some(fs) = self.fs else {
            return;
        };
        for c in 0..N_CHANNELS {
            let subtracting = s.bias[c] != 0.0;
            if subtracting && !self.subtracting[c] {
                let fresh = self.level_detector(c, fs);
                let ch = &mut self.ch[c];
                ch.line.interrupt();
                ch.level = fresh;
            }
            self.subtracting[c] = subtracting;
        }
    }

    fn watch(&mut self, s: &Sample) {
        self.present |= !s.absent & ALL_CHANNELS;
        if self.fs.is_none() {
            self.learn_rate(s.t_ns);
            self.last_t_ns = Some(s.t_ns);
            return;
        }
        self.last_t_ns = Some(s.t_ns);
        if s.has(flags::REPEATED) {
            return; // no new measurement
        }
        self.restart_at_engagement(s);
        if !s.has(flags::STILL) || s.has(flags::GAP) {
            for c in &mut self.ch {
                if s.has(flags::GAP) {
                    c.interrupt();
                } else {
                    c.skip();
                }
            }
            return;
        }
        self.still_samples += 1;
        let mut found = Vec::new();
        for (i, c) in self.ch.iter_mut().enumerate() {
            let v = s.channel(i);
            let bad = flags::replaced_ch(i) | flags::sat_ch(i) | flags::SENSOR_FAULT;
            if !v.is_finite() || s.flags & bad != 0 {
                c.skip();
                continue;
            }
            let alarm = |t_ns, finding, score| Alarm {
                channel: i,
                t_ns,
                finding,
                score,
            };
            if let Some(e) = c.level.push(s.t_ns, v) {
                found.push(alarm(e.t_ns, Finding::Offset(e.offset), e.z));
            }
            if self.settings.wander
                && let Some(e) = c.wander.push(s.t_ns, v)
            {
                found.push(alarm(e.t_ns, Finding::Wander(e.tau_s), e.ratio));
            }
            if self.settings.whiteness
                && let Some(e) = c.whiteness.push(s.t_ns, v)
            {
                found.push(alarm(e.t_ns, Finding::Whiteness(e.q, e.q0), e.score));
            }
            self.line_events.clear();
            c.line.push(s.t_ns, v, &mut self.line_events);
            for e in &self.line_events {
                found.push(alarm(e.t_ns, Finding::Line(e.freq_hz, e.id), e.ratio));
            }
        }
        for a in found {
            match a.finding {
                Finding::Offset(_) => self.offset_alarms += 1,
                Finding::Line(..) => self.line_alarms += 1,
                Finding::Wander(_) => self.wander_alarms += 1,
                Finding::Whiteness(..) => self.whiteness_alarms += 1,
            }
            self.record(a);
        }
    }
}

/// Skipped samples bridged by the offset, wander and whiteness tests at `fs` Hz: up to a second
/// (the bias stage's stillness drops out for 10–90 ms now and then at rest, and a replaced sample
/// is one).
fn bridge_samples(fs: f64) -> usize {
    fs.round().max(1.0) as usize
}

impl Stage for MonitorStage {
    fn name(&self) -> &'static str {
        "monitor"
    }

    fn push(&mut self, s: Sample, out: &mut Vec<Sample>) {
        self.watch(&s);
        out.push(s);
    }

    fn health(&self) -> StageHealth {
        StageHealth::Monitor(MonitorHealth {
            offset_alarms: self.offset_alarms,
            line_alarms: self.line_alarms,
            wander_alarms: self.wander_alarms,
            whiteness_alarms: self.whiteness_alarms,
            armed_channels: self.armed_channels() as u64,
            still_samples: self.still_samples,
            status: self.status(),
        })
    }

    fn cleans(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use nalgebra::Vector3;

    fn still(seq: u32, fs: f64, g: [f64; 3], a: [f64; 3]) -> Sample {
        let mut s = Sample {
            seq,
            t_ns: (seq as f64 / fs * 1e9) as u64,
            gyro: Vector3::from(g),
            accel: Vector3::from(a),
            ..Default::default()
        };
        s.flags |= flags::STILL;
        s
    }

    #[test]
    fn status_goes_learning_then_fits_then_names_the_effect() {
        let fs = 100.0;
        let mut m = MonitorStage::new(MonitorSettings::default(), None).unwrap();
        let mut r = Rng::new(21);
        let mut out = Vec::new();
        let mut seen = Vec::new();
        // 20 min at rest; from 700 s on gz carries the default model's transient of a
        // 0.084 °/s step (an ADIS16405-class gyro at 0.35 °/s sample noise): its window mean
        // peaks at 12 σ of the white 60-s mean (0.0044 °/s). At 700 s the scale is learned from
        // 104 windows, ν = 13, and the bar is 9.0 σ ([`LevelDetector::bar`]): the half-size step
        // this test used before that bar (6 σ) is not flagged there.
        let step = 0.084_f64.to_radians();
        for i in 0..120_000u32 {
            let t = i as f64 / fs;
            let tr = if t >= 700.0 {
                step * (-(t - 700.0) / 60.0).exp()
            } else {
                0.0
            };
            let g = [
                0.006 * r.normal(),
                0.006 * r.normal(),
                0.006 * r.normal() + tr,
            ];
            let a = [
                0.01 * r.normal(),
                0.01 * r.normal(),
                9.81 + 0.01 * r.normal(),
            ];
            let s = still(i, fs, g, a);
            m.push(s, &mut out);
            out.clear();
            if i == 10_000 || i == 60_000 || i == 76_000 {
                seen.push((t, m.status()));
            }
        }
        assert!(seen[0].1.starts_with("learning"), "{seen:?}");
        assert!(seen[1].1.starts_with("model fits"), "{seen:?}");
        assert!(seen[2].1.contains("gz offset"), "{seen:?}");
        let a: Vec<&Alarm> = m.alarms().collect();
        assert_eq!(a.len(), 1, "{a:?}");
        assert_eq!(a[0].channel, 2);
        let StageHealth::Monitor(h) = m.health() else {
            panic!()
        };
        assert_eq!((h.offset_alarms, h.line_alarms), (1, 0));
    }

    #[test]
    fn a_gyro_only_sensor_is_armed_on_all_of_its_channels() {
        // A table with gyro columns only (the accelerometer channels absent on every sample):
        // 20 min at rest arms its three offset tests, and the status counts the channels the
        // sensor has (it said "3 of 6", as if half the sensor were not yet learned).
        let fs = 100.0;
        let mut m = MonitorStage::new(MonitorSettings::default(), None).unwrap();
        let mut r = Rng::new(22);
        let mut out = Vec::new();
        for i in 0..120_000u32 {
            let g = [0.006 * r.normal(), 0.006 * r.normal(), 0.006 * r.normal()];
            let mut s = still(i, fs, g, [f64::NAN; 3]);
            s.absent = 0b111_000;
            m.push(s, &mut out);
            out.clear();
        }
        assert_eq!(m.status(), "model fits (3 of 3 channels armed)");
    }

    #[test]
    fn motion_is_not_tested_and_nothing_is_changed() {
        let fs = 100.0;
        let mut m = MonitorStage::new(MonitorSettings::default(), None).unwrap();
        let mut out = Vec::new();
        for i in 0..100_000u32 {
            // Moving: a large slow rotation, never flagged still.
            let w = (i as f64 * 0.01).sin();
            let mut s = still(i, fs, [w, 0.0, 0.0], [0.0, 0.0, 9.81]);
            s.flags = 0;
            m.push(s, &mut out);
            assert_eq!(out.pop().unwrap(), s);
        }
        assert_eq!(m.alarms().count(), 0);
        assert!(m.status().starts_with("learning (0 s"), "{}", m.status());
    }
}
