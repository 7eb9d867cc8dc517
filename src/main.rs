//! imuprep command line: parse the flags, dispatch to the command's driver in `imuprep::report`
//! (one short function per command), print its report, map the outcome to an exit code.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use imuprep::config::Config;
use imuprep::report::{self, fit::BiasMethod, write_json};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "imuprep",
    version,
    about = "Real-time preprocessor for low-cost MEMS IMUs"
)]
struct Cli {
    /// Log level filter (error, warn, info, debug) for messages on stderr.
    #[arg(long = "log-level", global = true, default_value = "info")]
    log_level: String,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// The daemon: source from config (serial, replay, stdin or zenoh) → pipeline → sinks, until SIGINT/SIGTERM.
    Run {
        /// Config file (default: the embedded config/default.toml).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Extra outputs, repeatable: stdout[:csv|jsonl|native], file:PATH, csv:PATH, jsonl:PATH,
        /// tcp:HOST:PORT, udp:HOST:PORT, inline:PATH, pty:, mcap:PATH (a build with --features ros2),
        /// zenoh:KEY[?format=jsonl&queue=N&wait=S&congestion=block] (a build with --features zenoh).
        #[arg(long = "out")]
        out: Vec<String>,
        /// Also write the final health summary as JSON to this file.
        #[arg(long)]
        summary_json: Option<PathBuf>,
    },
    /// Run the daemon's pipeline on a recorded log and print a health summary. A native log, UBX,
    /// MAVLink, ULog or MCAP is streamed (a protocol detected when no --protocol names one); a
    /// CSV or a bag, or with an import flag any file that is no imuprep log, is imported into a
    /// temporary log and that replayed.
    Replay {
        #[command(flatten)]
        log: report::Recording,
        /// Config file (default: the embedded config/default.toml).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Outputs, repeatable: stdout[:csv|jsonl|native], file:PATH, csv:PATH, jsonl:PATH,
        /// tcp:HOST:PORT, udp:HOST:PORT, inline:PATH, pty:, mcap:PATH (a build with --features ros2),
        /// zenoh:KEY[?format=jsonl&queue=N&wait=S&congestion=block] (a build with --features zenoh).
        #[arg(long = "out")]
        out: Vec<String>,
        /// Pace by sensor time at this speed factor, × real time (0 = as fast as possible).
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        speed: f64,
        /// Also write the final health summary as JSON to this file.
        #[arg(long)]
        summary_json: Option<PathBuf>,
    },
    /// Convert a recording into a replay log: a text table (CSV in a canonical or vendor layout;
    /// semicolon, tab or whitespace separated, decimal commas, comment lines, no header with
    /// --columns; optionally .gz), or UBX / MAVLink / ULog (with --protocol, or any binary file
    /// that is not .csv: detected).
    Import {
        /// Input recording: a text table (.csv, .csv.gz, or any text file whose lines split into
        /// the same cells: .txt, .tsv, .dat, ...) or a protocol file.
        input: PathBuf,
        #[command(flatten)]
        proto: imuprep::frame::detect::ProtocolArgs,
        /// Output replay log (native).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        import: report::convert::ImportArgs,
    },
    /// Simulate a MEMS IMU (scenario TOML, see docs/scenario.md) into a replay log + truth sidecar.
    Simulate {
        /// Scenario TOML (docs/scenario.md).
        scenario: PathBuf,
        /// Output replay log (native).
        #[arg(short, long)]
        output: PathBuf,
        /// Truth sidecar CSV (gzip when it ends in .gz).
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Seed (default: the scenario's `seed`, else 0). Same seed → same bytes.
        #[arg(long, allow_negative_numbers = true)]
        seed: Option<u64>,
        /// Override a scenario key, repeatable: --set errors.gross.rate_per_sample=2e-3
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
    /// Fit models from a recording: ARIMA per channel (gross-error stage) → DIR/arima.toml, and
    /// the AR bias model per channel (bias stage; Burg, Yule-Walker, covariance or linear FOS)
    /// → DIR/bias.toml.
    Fit {
        #[command(flatten)]
        log: report::Recording,
        /// Directory for the model files (created if needed).
        #[arg(long, default_value = "models")]
        out_dir: PathBuf,
        /// Data used for identification, s (the paper's training span).
        #[arg(long, allow_negative_numbers = true, default_value_t = 180.0)]
        train_s: f64,
        /// Skip this much at the start (start-up transients), s.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        skip_s: f64,
        /// Fitting method of the bias model. `fos`: fast orthogonal search over a constant and
        /// lags 1..=L (CP degree 1, the linear model the online Kalman filter can run),
        /// converted to the equivalent AR model.
        #[arg(long, value_enum, default_value_t = BiasMethod::Burg)]
        bias_method: BiasMethod,
        /// AR order of the bias model (for `fos`: the largest lag L). Default 64 for the AR
        /// methods: the bias stage splits the fitted signal spectrum into a slow bias and white
        /// noise, which a short AR cannot describe; default 10 (the paper's L) for `fos`.
        #[arg(long, allow_negative_numbers = true)]
        bias_order: Option<usize>,
        /// Shortest still stretch, seconds, the bias model may be fitted on. The bias model
        /// describes the sensor's bias, so it is fitted only on the longest still stretch of the
        /// training span (the bias stage's own stillness test, on the span after the gross-error
        /// stage with the ARIMA models just identified); without one this long, bias.toml
        /// holds no channel models and the stage learns each gyro's bias at warm-up.
        #[arg(long, allow_negative_numbers = true, default_value_t = 60.0)]
        min_still_s: f64,
    },
    /// Score the configured pipeline against a calibration-only baseline on a simulated scenario
    /// (truth known): RMS of 1-s mean error, 60-s heading drift, manoeuvre integrals (gyros).
    Evaluate {
        /// Scenario TOML to simulate (truth known).
        #[arg(long)]
        scenario: PathBuf,
        /// Seed (default: the scenario's `seed`, else 0).
        #[arg(long, allow_negative_numbers = true)]
        seed: Option<u64>,
        /// Config whose pipeline is scored (default: embedded).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Override a scenario key, repeatable: --set errors.gross.rate_per_sample=2e-3
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
    /// Close the loop over the whole recording: vibration lines (tracked block by block), bias
    /// steps, temperature, g-sensitivity and wander (Gauss-Markov or random walk), each proposed
    /// on the even blocks and kept only if it lowers the error on the odd (held-out) blocks by
    /// more than its noise; one report, plots, and one bias model (DIR/bias.toml) that the
    /// daemon's [bias] model can load.
    Diagnose {
        #[command(flatten)]
        log: report::Recording,
        /// Channels (gx gy gz ax ay az); repeatable; default all.
        #[arg(long = "channel")]
        channels: Vec<String>,
        /// Analyse only from this time, s from the start of the log...
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        from_s: f64,
        /// ...to this time, s (default: the end). Use it to pick a still stretch of a moving log.
        #[arg(long, allow_negative_numbers = true)]
        to_s: Option<f64>,
        /// Output directory: report.txt, report.json, bias.toml, plots/*.svg.
        #[arg(long, default_value = "diagnose-out")]
        out_dir: PathBuf,
        /// The close-the-loop iteration of issue 6 instead: effects chosen on the first 3 min
        /// (train) and the next 3 min (validation), tested on the rest.
        #[arg(long)]
        paper_split: bool,
        /// Write bias.toml even when the record is not at rest (by default it is not written
        /// then: its effects would be fitted to the motion and subtract it from real motion).
        #[arg(long)]
        allow_motion: bool,
    },
    /// Accelerometer bias, scale factor and misalignment from the still stretches of a moving
    /// recording (multi-position calibration without a turntable), each kept only if it
    /// lowers the held-out | |f| - g | error on attitudes it was not fitted on by more than its
    /// noise; then gyro scale and misalignment from the rotations between still stretches,
    /// tested on held-out motions; "not identifiable" when the attitudes do not span enough
    /// directions. Writes DIR/report.txt, DIR/report.json and, when something is kept,
    /// DIR/calibration.toml ([bias.settings.accel], [bias.settings.gyro], usable as --config).
    Calibrate {
        #[command(flatten)]
        log: report::Recording,
        /// Analyse only from this time, s from the start of the log...
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        from_s: f64,
        /// ...to this time, s (default: the end).
        #[arg(long, allow_negative_numbers = true)]
        to_s: Option<f64>,
        /// Local gravity, m/s² (the common scale of the three axes is relative to it).
        #[arg(long, allow_negative_numbers = true, default_value_t = 9.80665)]
        gravity: f64,
        /// Output directory.
        #[arg(long, default_value = "calibrate-out")]
        out_dir: PathBuf,
        /// RTKLIB .pos solution with velocities, on the log's clock: also fit the gyro's scale
        /// about the vertical from the turns of a drive.
        #[arg(long)]
        gnss: Option<PathBuf>,
    },
    /// Compare methods on the same data. `--detectors --scenario S.toml`: gross-error detectors
    /// against the simulator's truth. `LOG --channel C`: the bias models of the FOS paper.
    Compare {
        /// Recorded log for the bias-model comparison (or any recording `import` reads: a CSV, UBX, MAVLink, ULog or MCAP file, a bag; read as `import` reads it with the import flags given, none by default, what it found said on stderr).
        log: Option<PathBuf>,
        /// Compare gross-error detectors (needs --scenario: truth comes from the simulator).
        #[arg(long, conflicts_with_all = ["log", "channels", "skip_s", "temp_exo"])]
        detectors: bool,
        /// Scenario TOML to simulate (with --detectors).
        #[arg(long, conflicts_with = "log")]
        scenario: Option<PathBuf>,
        /// Override a scenario key, repeatable: --set errors.gross.rate_per_sample=2e-3
        #[arg(long = "set", value_name = "KEY=VALUE", conflicts_with = "log")]
        sets: Vec<String>,
        /// Seed of the simulation (default: the scenario's `seed`, else 0).
        #[arg(long, allow_negative_numbers = true, conflicts_with = "log")]
        seed: Option<u64>,
        /// Config whose [gross_error.settings] the online stage uses (default: embedded).
        #[arg(long, conflicts_with = "log")]
        config: Option<PathBuf>,
        /// Channels for the bias comparison (gx gy gz ax ay az); repeatable; default all.
        #[arg(long = "channel")]
        channels: Vec<String>,
        /// Skip this much at the start (start-up transients), s.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        skip_s: f64,
        /// Use the temperature channel as an exogenous FOS input.
        #[arg(long)]
        temp_exo: bool,
        /// Write the report as JSON here (and CSV beside it for the bias comparison).
        #[arg(long)]
        json: Option<PathBuf>,
        #[command(flatten)]
        proto: imuprep::frame::detect::ProtocolArgs,
        #[command(flatten)]
        import: report::convert::ImportArgs,
    },
    /// Do-no-harm audit: the embedded default pipeline over every recording under DIR (CSV as
    /// `import` reads it, or native logs), scored against the targets of issue 12, with seeded
    /// injections of spikes, outliers and bad values.
    Audit {
        /// Folder searched recursively for .csv, .csv.gz and .log recordings.
        #[arg(default_value = "../shared/data/real")]
        dir: PathBuf,
        /// First seed of the injections.
        #[arg(long, allow_negative_numbers = true, default_value_t = 12)]
        seed: u64,
        /// How many seeds (SEED, SEED+1, …): each injection is made once per seed and scored
        /// on the pooled counts, so a short recording's F1 does not hang on one draw.
        #[arg(long, allow_negative_numbers = true, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
        seeds: u64,
        /// Audit this config's pipeline instead of the embedded default.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Noise parameters of a static recording: overlapping Allan deviation per channel with
    /// confidence bands, the IEEE-952 terms fitted to it, a plot, and exports (Kalibr imu.yaml,
    /// GNSS_IMU config lines, bias model TOML) in OUT_DIR. The samples are taken as equally
    /// spaced at the recording's rate.
    Allan {
        #[command(flatten)]
        log: report::Recording,
        /// Channels (gx gy gz in rad/s, ax ay az in m/s^2); repeatable; default all.
        #[arg(long = "channel")]
        channels: Vec<String>,
        /// Skip this many seconds at the start (start-up transients), s.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        skip_s: f64,
        /// Output directory: report.txt/.json, allan.svg, imu.yaml (densities in rad/s/sqrt(Hz),
        /// m/s^2/sqrt(Hz); random walks in rad/s^2/sqrt(Hz), m/s^3/sqrt(Hz)), gnss_imu_config.txt
        /// (deg/s/sqrt(Hz), ug/sqrt(Hz)), bias.toml.
        #[arg(long, default_value = "allan-out")]
        out_dir: PathBuf,
        /// Also write the report as JSON here (tau in s, deviations in the channel's unit).
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Navigation test: imuprep's GNSS/INS filter on the rtklibexplorer drive and walk with
    /// simulated 10/30/60-s GNSS outages, fed the raw IMU, the cleaned IMU, and the raw IMU with
    /// an Allan-derived Gauss–Markov bias model; plus free-inertial drift on the static benches.
    Navtest {
        /// Folder of the real recordings.
        #[arg(long, default_value = "../shared/data/real")]
        data: PathBuf,
        /// Pipeline config for the cleaned variant (default: the embedded one).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Also write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Skip the static-bench drift (ADIS16405, MPU6050).
        #[arg(long)]
        no_static: bool,
    },
    /// Write a recording's samples as canonical CSV plus seq and flags, or (--to) as a native
    /// log, UBX ESF-RAW, MAVLink HIGHRES_IMU or ULog sensor_combined stream.
    Export {
        #[command(flatten)]
        log: report::Recording,
        /// Output file.
        #[arg(short, long)]
        output: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "csv")]
        to: imuprep::io::convert::ExportFormat,
    },
}

fn main() -> ExitCode {
    imuprep::progress::begin();
    let cli = Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_new(&cli.log_level)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(|| AboveBars)
        // Colour codes only for a terminal: a log file or a pipe gets plain text.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false)
        .init();
    match run(cli.cmd) {
        Ok(code) => code,
        Err(e) if e.downcast_ref::<report::InputProblem>().is_some() => {
            eprintln!("imuprep: ERROR: {e:#}");
            ExitCode::from(report::INPUT_PROBLEM_EXIT)
        }
        Err(e) => {
            eprintln!("imuprep: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// stderr for the log: each line written with the progress bars taken off the screen, so it
/// lands above them instead of inside one.
struct AboveBars;

impl std::io::Write for AboveBars {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        imuprep::progress::suspend(|| std::io::stderr().write_all(buf)).map(|()| buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        std::io::stderr().flush()
    }
}

/// The config of a command that brings its own input (the file's `[source]` is optional).
fn load_config(path: &Option<PathBuf>) -> Result<Config> {
    load_with(path, Config::from_file_source_replaced)
}

/// The daemon's config: its source comes from the file, which must name one.
fn load_daemon_config(path: &Option<PathBuf>) -> Result<Config> {
    load_with(path, Config::from_file)
}

fn load_with(
    path: &Option<PathBuf>,
    read: fn(&std::path::Path) -> Result<Config, imuprep::config::ConfigErrors>,
) -> Result<Config> {
    match path {
        // Say which file: a config may come from a script far from the command line.
        Some(p) => read(p).map_err(|e| anyhow::anyhow!("config {}: {e}", p.display())),
        None => Config::default_embedded().map_err(|e| anyhow::anyhow!("{e}")),
    }
}

/// Write `value` as JSON when a path was given.
fn maybe_json<T: serde::Serialize + ?Sized>(path: Option<PathBuf>, value: &T) -> Result<()> {
    path.map_or(Ok(()), |p| write_json(&p, value))
}

fn run(cmd: Cmd) -> Result<ExitCode> {
    match cmd {
        Cmd::Audit {
            dir,
            seed,
            seeds,
            config,
            json,
        } => {
            let seeds = report::audit::Seeds {
                first: seed,
                count: seeds,
            };
            let cfg = load_config(&config)?;
            audit(dir, seeds, cfg, config, json)
        }
        Cmd::Run {
            config,
            out,
            summary_json,
        } => {
            // A replay source is read as `imuprep replay` reads its file; the config's
            // `protocol` counts as named unless it is the default, "native" (as `replay`
            // without --protocol, a file that decodes as a sensor protocol is then detected).
            // The outputs are added first: a bad one, or one that is the recording, is refused
            // before anything is read or imported.
            let mut cfg = load_daemon_config(&config)?;
            report::daemon::add_outs(&mut cfg, &out)?;
            let named = !matches!(
                cfg.protocol.protocol,
                imuprep::frame::detect::ProtocolChoice::Native
            );
            let replay = report::daemon::replay_source(
                cfg,
                named,
                &Default::default(),
                summary_json.as_deref(),
            )?;
            // `replay.imported` (a CSV's or bag's log) lives until the run has ended.
            daemon(replay.cfg, summary_json)
        }
        Cmd::Replay {
            log,
            config,
            out,
            speed,
            summary_json,
        } => {
            let mut cfg = load_config(&config)?;
            report::daemon::add_outs(&mut cfg, &out)?;
            let replay = report::daemon::replay_config(cfg, &log, speed, summary_json.as_deref())?;
            // `replay.imported` (a CSV's or bag's log) lives until the run has ended.
            daemon(replay.cfg, summary_json)
        }
        Cmd::Import {
            input,
            proto,
            output,
            import,
        } => {
            let r = report::convert::import(&input, &proto, &import, &output)?;
            eprint!("{r}");
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Simulate {
            scenario,
            output,
            truth,
            seed,
            sets,
        } => {
            let r = report::convert::simulate(&scenario, &sets, seed, &output, truth.as_deref())?;
            eprint!("{r}");
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Fit {
            log,
            out_dir,
            train_s,
            skip_s,
            bias_method,
            bias_order,
            min_still_s,
        } => {
            let o = report::fit::FitOptions {
                train_s,
                skip_s,
                bias_method,
                bias_order: bias_order.unwrap_or(bias_method.default_order()),
                min_still_s,
            };
            print!("{}", report::fit::fit(&log, &out_dir, &o)?);
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Evaluate {
            scenario,
            seed,
            config,
            json,
            sets,
        } => {
            let mut cfg = load_config(&config)?;
            let r = report::evaluate::evaluate_scenario(&scenario, seed, &mut cfg, &sets)?;
            print!("{r}");
            // The JSON file holds the per-channel results (as it always has).
            maybe_json(json, &r.channels)?;
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Diagnose {
            log,
            channels,
            from_s,
            to_s,
            out_dir,
            paper_split,
            allow_motion,
        } => {
            let mut stdout = std::io::stdout();
            report::diagnose::diagnose(
                &log,
                &channels,
                (from_s, to_s),
                &out_dir,
                (paper_split, allow_motion),
                &mut stdout,
            )?;
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Calibrate {
            log,
            from_s,
            to_s,
            gravity,
            out_dir,
            gnss,
        } => {
            let o = report::calibrate::CalibrateOptions {
                from_s,
                to_s,
                gravity_m_s2: gravity,
                out_dir,
                gnss,
            };
            let r = report::calibrate::calibrate(&log, &o)?;
            print!("{}", r.to_text());
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Compare {
            log,
            detectors,
            scenario,
            seed,
            config,
            channels,
            skip_s,
            temp_exo,
            json,
            sets,
            proto,
            import,
        } => {
            if detectors {
                // The simulator makes the recording: a flag that reads one would be ignored.
                let flags = [proto.given(), import.given()].concat();
                anyhow::ensure!(
                    flags.is_empty(),
                    "--detectors simulates its recording from --scenario: {} read a recording, for the bias-model comparison (compare LOG)",
                    flags.join(", ")
                );
                let scenario = scenario.context(
                    "--detectors needs --scenario S.toml (the truth comes from the simulator)",
                )?;
                let cfg = load_config(&config)?;
                let r = report::compare::detectors(&scenario, seed, &cfg, &sets)?;
                print!("{r}");
                maybe_json(json, &r)?;
            } else {
                let log = report::Recording {
                    path: log.context(
                        "compare needs a LOG (bias models) or --detectors --scenario S.toml",
                    )?,
                    proto,
                    import,
                };
                let r = report::compare::bias_models(&log, &channels, skip_s, temp_exo)?;
                print!("{r}");
                if let Some(p) = json {
                    let csv = p.with_extension("csv");
                    std::fs::write(&csv, r.to_csv())
                        .with_context(|| format!("writing {}", csv.display()))?;
                    write_json(&p, &r)?;
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Allan {
            log,
            channels,
            skip_s,
            out_dir,
            json,
        } => {
            let r = report::allan::allan(&log, &channels, skip_s, &out_dir)?;
            maybe_json(json, &r.report)?;
            print!("{r}");
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Navtest {
            data,
            config,
            json,
            no_static,
        } => {
            let cfg = load_config(&config)?;
            let rep = report::navtest::navtest(&data, &cfg, !no_static);
            print!("{rep}");
            maybe_json(json, &rep)?;
            Ok(if rep.records.is_empty() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
        Cmd::Export { log, output, to } => {
            eprint!("{}", report::convert::export(&log, &output, to)?);
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `audit`: the report on stdout; exit 1 when a target is missed.
fn audit(
    dir: PathBuf,
    seeds: report::audit::Seeds,
    cfg: Config,
    config_path: Option<PathBuf>,
    json: Option<PathBuf>,
) -> Result<ExitCode> {
    let mut report = report::audit::audit_dir(&dir, seeds, &cfg)
        .with_context(|| format!("cannot read {}", dir.display()))?;
    // The header and the JSON say whose pipeline was audited.
    report.config = config_path;
    if report.recordings.is_empty() {
        // Nothing audited is an input problem (status 3), not a missed target (status 1); say
        // what was looked at and why each file was left out.
        let why = if report.skipped.is_empty() {
            " (no .log, .csv, .csv.gz or .ulg file in it)".to_string()
        } else {
            report.skipped.iter().map(|s| format!("\n  {s}")).collect()
        };
        return Err(report::InputProblem(format!(
            "no recording under {} could be audited{why}",
            dir.display()
        ))
        .into());
    }
    print!("{report}");
    maybe_json(json, &report)?;
    Ok(if report.missed().is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// `run` / `replay`: the daemon, then its health summary on stderr (and as JSON if asked).
fn daemon(cfg: Config, summary_json: Option<PathBuf>) -> Result<ExitCode> {
    let health = report::daemon::run(&cfg)?;
    eprint!("{}", health.text());
    report::daemon::write_summary(&health, summary_json.as_deref())?;
    // An input that ended by itself (a replayed log, stdin) with nothing or mostly garbage in
    // it is a failed run, said loudly; a live daemon stopped by a signal only warns. A replayed
    // file in a format imuprep does not read is said as such.
    let foreign = match &cfg.source {
        imuprep::config::SourceConfig::Replay { path, .. } if health.samples_in == 0 => {
            imuprep::frame::detect::foreign_file(path).map(|w| format!("{}: {w}", path.display()))
        }
        _ => None,
    };
    if let Some(problem) = foreign.or_else(|| health.input_problem()) {
        if health.ended_by == "end of input" {
            eprintln!("imuprep: ERROR: {problem}");
            return Ok(ExitCode::from(report::INPUT_PROBLEM_EXIT));
        }
        eprintln!("imuprep: WARNING: {problem}");
    }
    Ok(ExitCode::SUCCESS)
}
