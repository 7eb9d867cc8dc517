//! `--out SPEC`: a sink given on the command line.

use crate::config::{McapCompression, Sink};

/// Sinks given on the command line (`--out SPEC`), e.g. `csv:out.csv`, `stdout:jsonl`,
/// `file:clean.log`, `tcp:127.0.0.1:7700`, `udp:127.0.0.1:7701`.
pub fn parse_out_spec(spec: &str) -> Result<Sink, String> {
    use crate::config::Format;
    let (kind, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let fmt = |s: &str| match s {
        "" | "csv" => Ok(Format::Csv),
        "jsonl" | "json" => Ok(Format::Jsonl),
        "native" => Ok(Format::Native),
        o => Err(format!("unknown stdout format {o:?} (csv, jsonl, native)")),
    };
    let path = |what: &str| -> Result<std::path::PathBuf, String> {
        if rest.trim().is_empty() {
            Err(format!(
                "{what}: needs a path, e.g. {what}:out.{}",
                match what {
                    "csv" => "csv",
                    "jsonl" => "jsonl",
                    _ => "log",
                }
            ))
        } else {
            Ok(rest.into())
        }
    };
    // Host names (`localhost:7700`) are resolved here, once; an IPv4 address is preferred.
    let addr = |what: &str| -> Result<std::net::SocketAddr, String> {
        use std::net::ToSocketAddrs;
        let all: Vec<std::net::SocketAddr> = rest
            .to_socket_addrs()
            .map_err(|e| format!("bad {what} address {rest:?} (HOST:PORT): {e}"))?
            .collect();
        all.iter()
            .find(|a| a.is_ipv4())
            .or(all.first())
            .copied()
            .ok_or_else(|| format!("{what} address {rest:?} resolves to nothing"))
    };
    match kind {
        "stdout" | "-" => Ok(Sink::Stdout { format: fmt(rest)? }),
        "file" | "log" => Ok(Sink::File {
            path: path(kind)?,
            format: Format::Native,
        }),
        "csv" => Ok(Sink::File {
            path: path("csv")?,
            format: Format::Csv,
        }),
        "jsonl" => Ok(Sink::File {
            path: path("jsonl")?,
            format: Format::Jsonl,
        }),
        "tcp" => Ok(Sink::Tcp {
            bind: addr("tcp")?,
            format: Format::Native,
            queue: 256,
        }),
        "udp" => Ok(Sink::Udp {
            targets: vec![addr("udp")?],
            format: Format::Native,
        }),
        "inline" => Ok(Sink::Inline {
            path: if rest.is_empty() || rest == "pty" {
                None
            } else {
                Some(rest.into())
            },
        }),
        "pty" => Ok(Sink::Inline { path: None }),
        "mcap" | "mcap+lz4" | "mcap+zstd" if !rest.is_empty() => Ok(Sink::Mcap {
            path: rest.into(),
            topic: "/imu/clean".into(),
            frame_id: "imu_link".into(),
            health_topic: "/imuprep/health".into(),
            compression: match kind {
                "mcap+lz4" => McapCompression::Lz4,
                "mcap+zstd" => McapCompression::Zstd,
                _ => McapCompression::None,
            },
        }),
        "zenoh" => parse_zenoh(rest),
        _ => Err(format!(
            "unknown output {spec:?}: use stdout[:csv|jsonl|native], file:PATH, csv:PATH, jsonl:PATH, tcp:ADDR, udp:ADDR, inline:PATH (the input's own protocol, to a serial device or file), pty: (the same on a new pseudo-terminal, its path printed), mcap:PATH (ROS 2 bag, sensor_msgs/msg/Imu; mcap+lz4:PATH or mcap+zstd:PATH with LZ4 or zstd chunks), zenoh:KEY[?format=jsonl&queue=N&wait=S&congestion=block] (a build with --features zenoh)"
        )),
    }
}

/// `zenoh:KEY[?format=native|jsonl&queue=N&wait=S&congestion=drop|block]` (the `[[sinks]]`
/// keys `format`, `queue`, `wait_s`, `congestion`). Whether this build has Zenoh is checked when
/// the sink starts. Every mistake is reported, in one message (`zenoh: …; …`): the key's, each
/// option's, and an option given twice (which would otherwise silently take the last value).
fn parse_zenoh(rest: &str) -> Result<Sink, String> {
    use crate::config::{Format, ZenohCongestion};
    let (key, opts) = rest.split_once('?').unwrap_or((rest, ""));
    let mut errors = Vec::new();
    if let Err(e) = crate::config::check_zenoh_key(key, false) {
        errors.push(format!(
            "{e} (zenoh:KEY[?format=jsonl&queue=N&wait=S&congestion=block], e.g. zenoh:imuprep/imu0/imu)"
        ));
    }
    let (mut format, mut queue, mut wait_s) = (Format::Native, 64usize, 0.0f64);
    let mut congestion = ZenohCongestion::Drop;
    let mut seen: Vec<&str> = Vec::new();
    for kv in opts.split('&').filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
        let name = if k == "wait_s" { "wait" } else { k };
        if ["format", "queue", "wait", "congestion"].contains(&name) {
            if seen.contains(&name) {
                errors.push(format!("option {name:?} given twice"));
                continue;
            }
            seen.push(name);
        }
        match name {
            "format" => match v {
                "native" => format = Format::Native,
                "jsonl" | "json" => format = Format::Jsonl,
                o => errors.push(format!("format {o:?}: native or jsonl")),
            },
            "queue" => match v.parse().ok().filter(|q| *q > 0) {
                Some(q) => queue = q,
                None => errors.push(format!("queue {v:?}: a count of batches > 0")),
            },
            "wait" => match v.parse().ok().filter(|w: &f64| w.is_finite() && *w >= 0.0) {
                Some(w) => wait_s = w,
                None => errors.push(format!("wait {v:?}: seconds ≥ 0")),
            },
            "congestion" => match v {
                "drop" => congestion = ZenohCongestion::Drop,
                "block" => congestion = ZenohCongestion::Block,
                o => errors.push(format!("congestion {o:?}: drop or block")),
            },
            o => errors.push(format!(
                "unknown option {o:?} (format, queue, wait, congestion)"
            )),
        }
    }
    if !errors.is_empty() {
        return Err(format!("zenoh: {}", errors.join("; ")));
    }
    Ok(Sink::Zenoh {
        key: key.to_string(),
        format,
        queue,
        wait_s,
        congestion,
    })
}

#[cfg(test)]
mod out_spec_tests {
    use super::*;

    #[test]
    fn tcp_localhost_is_accepted() {
        let Ok(Sink::Tcp { bind, .. }) = parse_out_spec("tcp:localhost:7700") else {
            panic!("tcp:localhost:7700 refused")
        };
        assert!(bind.ip().is_loopback());
        assert_eq!(bind.port(), 7700);
    }

    #[test]
    fn file_outputs_without_a_path_are_clear_errors() {
        for spec in ["csv:", "jsonl:", "file:", "csv"] {
            let e = parse_out_spec(spec).unwrap_err();
            assert!(e.contains("needs a path"), "{spec}: {e}");
        }
    }

    #[test]
    fn zenoh_keys_and_options() {
        use crate::config::Format;
        assert_eq!(
            parse_out_spec("zenoh:imuprep/imu0/imu?format=jsonl&queue=8&wait=2.5&congestion=block"),
            Ok(Sink::Zenoh {
                key: "imuprep/imu0/imu".into(),
                format: Format::Jsonl,
                queue: 8,
                wait_s: 2.5,
                congestion: crate::config::ZenohCongestion::Block,
            })
        );
        let Ok(Sink::Zenoh {
            format,
            queue,
            congestion,
            ..
        }) = parse_out_spec("zenoh:a")
        else {
            panic!("zenoh:a refused")
        };
        assert_eq!(
            (format, queue, congestion),
            (Format::Native, 64, crate::config::ZenohCongestion::Drop)
        );
        for bad in [
            "zenoh:",
            "zenoh:a/*/b",
            "zenoh:/a",
            "zenoh:a//b",
            "zenoh:a?format=csv",
            "zenoh:a?queue=0",
            "zenoh:a?wait=-1",
            "zenoh:a?speed=2",
            "zenoh:a?congestion=wait",
        ] {
            let e = parse_out_spec(bad).unwrap_err();
            assert!(e.starts_with("zenoh:"), "{bad}: {e}");
        }
    }

    /// `--out zenoh:KEY?…` once stopped at its first mistake (`queue=-3&wait=x&format=xml` named
    /// only the queue) and took an option given twice silently (`format=jsonl&format=native`
    /// published native frames). Every mistake is now named in one message, a repeat included.
    #[test]
    fn zenoh_spec_names_every_mistake_and_a_repeated_option() {
        let e = parse_out_spec("zenoh:a/*?queue=-3&wait=x&format=xml&speed=2&congestion=no")
            .unwrap_err();
        for want in [
            "a published key names one resource",
            "queue \"-3\"",
            "wait \"x\"",
            "format \"xml\"",
            "unknown option \"speed\"",
            "congestion \"no\"",
        ] {
            assert!(e.contains(want), "missing {want:?} in {e}");
        }
        assert!(
            e.starts_with("zenoh: ") && !e[1..].contains("zenoh: "),
            "{e}"
        );
        for twice in [
            "zenoh:a?format=jsonl&format=native",
            "zenoh:a?wait=1&wait_s=2",
            "zenoh:a?queue=8&queue=8",
        ] {
            let e = parse_out_spec(twice).unwrap_err();
            assert!(e.contains("given twice"), "{twice}: {e}");
        }
    }
}
