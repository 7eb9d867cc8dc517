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
        "mcap" | "mcap+lz4" if !rest.is_empty() => Ok(Sink::Mcap {
            path: rest.into(),
            topic: "/imu/clean".into(),
            frame_id: "imu_link".into(),
            health_topic: "/imuprep/health".into(),
            compression: if kind == "mcap" {
                McapCompression::None
            } else {
                McapCompression::Lz4
            },
        }),
        _ => Err(format!(
            "unknown output {spec:?}: use stdout[:csv|jsonl|native], file:PATH, csv:PATH, jsonl:PATH, tcp:ADDR, udp:ADDR, inline:PATH (the input's own protocol, to a serial device or file), pty: (the same on a new pseudo-terminal, its path printed), mcap:PATH (ROS 2 bag, sensor_msgs/msg/Imu; mcap+lz4:PATH with LZ4 chunks)"
        )),
    }
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
}
