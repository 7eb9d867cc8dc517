//! ROS 2 bags in SQLite (`.db3`, rosbag2's default storage from Foxy to Humble) for `imuprep
//! import`: the `sensor_msgs/msg/Imu` messages of one topic, with a `sensor_msgs/msg/Temperature`
//! topic joined when the bag has one.
//!
//! The database is read with `rusqlite` (SQLite compiled in, behind the `ros2-sqlite` feature):
//! rosbag2's schema is two tables, `topics(id, name, type, serialization_format, …)` and
//! `messages(id, topic_id, timestamp, data)`, the data CDR — read by `frame::ros2`, as in MCAP
//! bags. The input is a `.db3` file or a bag directory (its `.db3` files in the order of their
//! split index, `bag_0.db3`, `bag_1.db3`, …; topic ids are per file). Messages are read in the
//! order rosbag2 plays them (by the recorder's time stamp, then as stored); time is
//! `header.stamp` (the recorder's when the stamp is zero, or always with `time = "log"`), the
//! covariance −1 convention and the temperature join as for the other bags (`io::bag`).

use std::path::{Path, PathBuf};

use rusqlite::{Connection, OpenFlags, params};

use super::bag::{
    BagRead, Found, TopicError, Topics, imu_sample, join_temperature, ros_descriptor, stamp_or_log,
};
use crate::frame::DecoderStats;
use crate::frame::ros2::{McapOptions, decode_imu_fast, decode_temperature};
use crate::text::count;

/// The first bytes of every SQLite 3 database.
pub const MAGIC: &[u8] = b"SQLite format 3\0";

const IMU_TYPE: &str = "sensor_msgs/msg/Imu";
const TEMPERATURE_TYPE: &str = "sensor_msgs/msg/Temperature";

/// Why a bag could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum Db3Error {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("{0}: {1}")]
    Sqlite(PathBuf, rusqlite::Error),
    #[error("no .db3 file in the directory {0}")]
    Empty(PathBuf),
    #[error(
        "{0}: an SQLite database, but not a rosbag2 bag (it has no `topics` and `messages` tables)"
    )]
    NotABag(PathBuf),
    #[error(transparent)]
    Topic(#[from] TopicError),
}

/// Whether `path` is a `.db3` bag: an SQLite file, or a directory holding `.db3` files.
pub fn is_db3(path: &Path) -> bool {
    if path.is_dir() {
        return crate::io::convert::split_files(path, "db3").is_ok_and(|f| !f.is_empty());
    }
    use std::io::Read;
    let mut head = [0u8; 16];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|_| head == MAGIC)
}

/// One file's topics: (id, name, type), CDR only.
fn file_topics(c: &Connection, path: &Path) -> Result<Vec<(i64, String, String)>, Db3Error> {
    let sql = |e| Db3Error::Sqlite(path.to_path_buf(), e);
    let tables: i64 = c
        .query_row(
            "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name IN ('topics', 'messages')",
            [],
            |r| r.get(0),
        )
        .map_err(sql)?;
    if tables != 2 {
        return Err(Db3Error::NotABag(path.to_path_buf()));
    }
    let mut st = c
        .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
        .map_err(sql)?;
    let rows = st
        .query_map([], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, String>(1)?,
                r.get::<_, String>(2)?,
                r.get::<_, String>(3)?,
            ))
        })
        .map_err(sql)?;
    let mut v = Vec::new();
    for r in rows {
        let (id, name, ty, format) = r.map_err(sql)?;
        if format == "cdr" {
            v.push((id, name, ty));
        }
    }
    Ok(v)
}

/// The `sensor_msgs/msg/Imu` messages of `opts.topic` (else the first Imu topic) in the bag at
/// `path` (a `.db3` file or a bag directory), as samples, with the temperature of
/// `opts.temperature_topic` (else the first Temperature topic; `""` none) joined over the
/// whole bag.
pub fn read_db3(path: &Path, opts: &McapOptions) -> Result<BagRead, Db3Error> {
    let files = if path.is_dir() {
        crate::io::convert::split_files(path, "db3")?
    } else {
        vec![path.to_path_buf()]
    };
    if files.is_empty() {
        return Err(Db3Error::Empty(path.to_path_buf()));
    }
    let mut dbs = Vec::new();
    let mut topics = Topics::default();
    for f in &files {
        let c = Connection::open_with_flags(
            f,
            OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
        )
        .map_err(|e| Db3Error::Sqlite(f.clone(), e))?;
        let t = file_topics(&c, f)?;
        for (_, n, ty) in &t {
            topics.add(n, ty);
        }
        dbs.push((f.clone(), c, t));
    }
    let (topic, temp) = topics.choose(IMU_TYPE, TEMPERATURE_TYPE, opts)?;
    let header_time = opts.time != "log";

    let mut stats = DecoderStats::default();
    let mut samples = Vec::new();
    let mut temps = Vec::new();
    let mut compressed = 0u64;
    let (mut bad_temp, mut other) = (0u64, 0u64);
    let mut warnings = Vec::new();
    for (f, c, t) in &dbs {
        stats.bytes_in += std::fs::metadata(f).map_or(0, |m| m.len());
        let id_of = |want: Option<&str>, ty: &str| {
            t.iter()
                .find(|(_, n, tt)| Some(n.as_str()) == want && tt == ty)
                .map_or(-1, |x| x.0)
        };
        let (imu_id, temp_id) = (
            id_of(Some(&topic), IMU_TYPE),
            id_of(temp.as_deref(), TEMPERATURE_TYPE),
        );
        let sql = |e| Db3Error::Sqlite(f.clone(), e);
        // SQLite pages carry no checksum; its own structural check (one pass over the file)
        // is what can tell a damaged database, said but not refused: what it holds may be
        // mostly good.
        let check: String = c
            .query_row("PRAGMA quick_check(1)", [], |r| r.get(0))
            .unwrap_or_else(|e| e.to_string());
        if check != "ok" {
            stats.truncated += 1;
            warnings.push(format!(
                "{} is damaged (SQLite's quick_check: {}): values or rows read from it may be wrong",
                f.display(),
                check.replace('\n', " ")
            ));
        }
        let n_other: i64 = c
            .query_row(
                "SELECT COUNT(*) FROM messages WHERE topic_id <> ?1 AND topic_id <> ?2",
                params![imu_id, temp_id],
                |r| r.get(0),
            )
            .map_err(sql)?;
        other += n_other as u64;
        let mut st = c
            .prepare(
                "SELECT topic_id, timestamp, data FROM messages \
                 WHERE topic_id = ?1 OR topic_id = ?2 ORDER BY timestamp, id",
            )
            .map_err(sql)?;
        let mut rows = st.query(params![imu_id, temp_id]).map_err(sql)?;
        loop {
            let row = match rows.next() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => {
                    // A damaged database: what was read is kept, the rest of this file is lost.
                    stats.truncated += 1;
                    warnings.push(format!(
                        "{} is damaged ({e}): its messages after the {}th read are lost",
                        f.display(),
                        stats.samples
                    ));
                    break;
                }
            };
            let id: i64 = row.get(0).unwrap_or(-2);
            let log = row.get::<_, i64>(1).map_or(0, |v| v.max(0) as u64);
            let blob = row
                .get_ref(2)
                .ok()
                .and_then(|v| v.as_blob().ok())
                .unwrap_or(&[]);
            // rosbag2's message compression: each blob one zstd frame.
            let data = &*crate::frame::inflate::message(blob);
            if id == imu_id {
                compressed += u64::from(crate::frame::inflate::is_zstd(blob));
                match decode_imu_fast(data) {
                    Ok(m) => {
                        let t_ns =
                            stamp_or_log(header_time, m.sec.max(0) as u64, m.nanosec.into(), log);
                        samples.push(imu_sample(t_ns, &m.channels, m.absent));
                        stats.frames_ok += 1;
                        stats.samples += 1;
                    }
                    Err(_) => stats.bad_payload += 1,
                }
            } else {
                match decode_temperature(data) {
                    Ok((sec, ns, c)) if c.is_finite() => temps.push((
                        stamp_or_log(header_time, sec.max(0) as u64, ns.into(), log),
                        c,
                    )),
                    _ => bad_temp += 1,
                }
            }
        }
    }
    let joined = join_temperature(&mut samples, temps, opts.temperature_max_age_s);
    let found = Found {
        imu_type: IMU_TYPE,
        other_imu: topics.others(IMU_TYPE, &topic),
        topic,
        containers: format!(
            "{}{}",
            count(files.len() as u64, "file", "files"),
            if compressed > 0 {
                format!(", {compressed} of its Imu messages zstd-compressed one by one")
            } else {
                String::new()
            }
        ),
        temperature: temp.map(|t| (t, bad_temp)),
        joined,
        other,
        warnings,
    };
    Ok(BagRead {
        descriptor: ros_descriptor(),
        samples,
        found: found.line(&stats),
        stats,
    })
}
