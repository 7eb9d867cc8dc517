//! What the whole-file bag importers share (`io::ros1` for ROS 1 bags, `io::ros2_db3` for ROS 2
//! bags in SQLite): the samples read with what was found, the time rule, the temperature join
//! over the whole file, and the import's first line.

use crate::frame::ros2::McapOptions;
use crate::frame::{AxisConvention, DecoderStats, Descriptor};
use crate::sample::Sample;
use crate::text::count;

/// A bag's Imu topic read whole.
#[derive(Debug, Clone)]
pub struct BagRead {
    pub descriptor: Descriptor,
    pub samples: Vec<Sample>,
    /// Counts: samples and good messages, messages that are no Imu of the expected layout
    /// (`bad_payload`), damaged records (`truncated`).
    pub stats: DecoderStats,
    /// One line: the topic read, what else the bag holds, what could not be read.
    pub found: String,
}

/// Why no topic could be chosen.
#[derive(Debug, thiserror::Error)]
pub enum TopicError {
    #[error("no {0} topic in the bag (its topics: {1})")]
    NoImuTopic(&'static str, String),
    #[error("no {ty} topic {asked:?} in the bag (its {ty} topics: {have})")]
    NoSuchTopic {
        ty: &'static str,
        asked: String,
        have: String,
    },
}

/// A bag's topics, (name, message type) each once, in the order the bag declares them.
#[derive(Debug, Default)]
pub struct Topics(Vec<(String, String)>);

impl Topics {
    pub fn add(&mut self, name: &str, ty: &str) {
        if !self.0.iter().any(|(n, t)| n == name && t == ty) {
            self.0.push((name.to_string(), ty.to_string()));
        }
    }

    /// The names of the topics of type `ty`, or every topic with its type; "none".
    fn names(&self, ty: Option<&str>) -> String {
        let v: Vec<String> = self
            .0
            .iter()
            .filter(|(_, t)| ty.is_none_or(|ty| t == ty))
            .map(|(n, t)| match ty {
                Some(_) => n.clone(),
                None => format!("{n} ({t})"),
            })
            .collect();
        if v.is_empty() {
            "none".into()
        } else {
            v.join(", ")
        }
    }

    /// The topic of type `ty` to read: `asked` (an error naming the bag's topics of that type
    /// when it has no such one), else the first of that type, if any.
    fn pick(&self, ty: &'static str, asked: Option<&str>) -> Result<Option<String>, TopicError> {
        match asked {
            Some(a) if self.0.iter().any(|(n, t)| n == a && t == ty) => Ok(Some(a.to_string())),
            Some(a) => Err(TopicError::NoSuchTopic {
                ty,
                asked: a.to_string(),
                have: self.names(Some(ty)),
            }),
            None => Ok(self.0.iter().find(|(_, t)| t == ty).map(|(n, _)| n.clone())),
        }
    }

    /// The Imu topic (`opts.topic`, else the first of `imu_ty`) and the Temperature topic
    /// (`opts.temperature_topic`, else the first of `temp_ty`; `""`: none) to read.
    pub fn choose(
        &self,
        imu_ty: &'static str,
        temp_ty: &'static str,
        opts: &McapOptions,
    ) -> Result<(String, Option<String>), TopicError> {
        let imu = self
            .pick(imu_ty, opts.topic.as_deref())?
            .ok_or_else(|| TopicError::NoImuTopic(imu_ty, self.names(None)))?;
        let temp = match opts.temperature_topic.as_deref() {
            Some("") => None,
            t => self.pick(temp_ty, t)?,
        };
        Ok((imu, temp))
    }

    /// The topics of type `ty` other than `topic`.
    pub fn others(&self, ty: &str, topic: &str) -> Vec<String> {
        self.0
            .iter()
            .filter(|(n, t)| t == ty && n != topic)
            .map(|(n, _)| n.clone())
            .collect()
    }
}

/// What a bag reader found, for [`Found::line`].
#[derive(Debug, Default)]
pub struct Found {
    /// The Imu message type as the bag names it, and the topic read.
    pub imu_type: &'static str,
    pub topic: String,
    /// The bag's containers read: "5 chunks", "1 file".
    pub containers: String,
    /// The Temperature topic joined: its name, readings that could not be read.
    pub temperature: Option<(String, u64)>,
    /// Samples the temperature reached.
    pub joined: u64,
    /// The other Imu topics, not read.
    pub other_imu: Vec<String>,
    /// Messages on the other topics.
    pub other: u64,
    /// Damage, each said as a `WARNING:` clause.
    pub warnings: Vec<String>,
}

impl Found {
    /// The import's first line (after "<format> input: ").
    pub fn line(&self, stats: &DecoderStats) -> String {
        let ty = self.imu_type;
        let mut f = format!(
            "{} on {} ({}",
            count(
                stats.samples,
                &format!("{ty} message"),
                &format!("{ty} messages")
            ),
            self.topic,
            self.containers
        );
        if stats.bad_payload > 0 {
            f += &format!(
                ", {} not a {ty} of the expected layout, left out",
                count(stats.bad_payload, "message", "messages")
            );
        }
        f += ")";
        match &self.temperature {
            Some((t, bad)) => {
                f += &format!(
                    "; temperature from {t}, joined to {} of {} samples",
                    self.joined, stats.samples
                );
                if *bad > 0 {
                    f += &format!(" ({} unreadable)", count(*bad, "reading", "readings"));
                }
            }
            None => f += "; no temperature topic",
        }
        if !self.other_imu.is_empty() {
            f += &format!(
                "; other Imu topics not read: {} (choose with --topic)",
                self.other_imu.join(", ")
            );
        }
        f += &format!(
            "; {} on other topics",
            count(self.other, "message", "messages")
        );
        for w in &self.warnings {
            f += &format!("; WARNING: {w}");
        }
        f
    }
}

/// A message's time: its header stamp, or the time the recorder logged it when the stamp is
/// zero or `header_time` is false (`time = "log"`), ns.
pub fn stamp_or_log(header_time: bool, sec: u64, nanosec: u64, log_ns: u64) -> u64 {
    if header_time && (sec, nanosec) != (0, 0) {
        sec * 1_000_000_000 + nanosec
    } else {
        log_ns
    }
}

/// Joins `temps` (time ns, °C) to `samples` over the whole file: each sample gets the latest
/// reading stamped at or before it, unless older than `max_age_s` (0 = no limit). Returns the
/// samples reached.
pub fn join_temperature(samples: &mut [Sample], mut temps: Vec<(u64, f64)>, max_age_s: f64) -> u64 {
    temps.sort_by_key(|t| t.0);
    let max_age_ns = max_age_s * 1e9;
    let mut joined = 0;
    for s in samples {
        let at = temps.partition_point(|(t, _)| *t <= s.t_ns);
        if let Some(&(t, c)) = at.checked_sub(1).map(|i| &temps[i])
            && (max_age_ns <= 0.0 || (s.t_ns - t) as f64 <= max_age_ns)
        {
            s.temp_c = Some(c);
            joined += 1;
        }
    }
    joined
}

/// A sample from an Imu message's time, six channels and the channels it declares not
/// available.
pub fn imu_sample(t_ns: u64, channels: &[f64; 6], absent: u8) -> Sample {
    let mut s = Sample {
        t_ns,
        ..Sample::default()
    };
    s.set_channels(channels);
    crate::frame::protocol::mark_absent(&mut s, absent);
    s
}

/// ROS's axes (REP 103: x forward, y left, z up).
pub fn ros_descriptor() -> Descriptor {
    Descriptor {
        axes: AxisConvention::Flu,
        ..Descriptor::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temperature_joins_the_latest_reading_at_or_before_unless_too_old() {
        let mut s: Vec<Sample> = [5u64, 10, 15, 3_000_000_020]
            .iter()
            .map(|&t| imu_sample(t, &[0.0; 6], 0))
            .collect();
        // Out of order on purpose: the join sorts.
        let n = join_temperature(&mut s, vec![(12, 21.0), (10, 20.0)], 1.0);
        let got: Vec<Option<f64>> = s.iter().map(|s| s.temp_c).collect();
        assert_eq!(got, vec![None, Some(20.0), Some(21.0), None]);
        assert_eq!(n, 2);
        assert_eq!(stamp_or_log(true, 0, 0, 77), 77);
        assert_eq!(stamp_or_log(true, 2, 5, 77), 2_000_000_005);
        assert_eq!(stamp_or_log(false, 2, 5, 77), 77);
    }
}
