//! imuprep command line: raw flags → validated settings in one step; `anyhow` only here.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use imuprep::config::{Config, SourceConfig};
use imuprep::io::csv::{self as csvio, AccelUnit, GyroUnit, ImportOptions, TimeUnit};
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

/// How `fit` estimates the bias model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum BiasMethod {
    Burg,
    YuleWalker,
    Covariance,
    Fos,
}

impl BiasMethod {
    /// The `method` string written to the bias model file.
    fn file_name(self) -> &'static str {
        match self {
            BiasMethod::Burg => "burg",
            BiasMethod::YuleWalker => "yule_walker",
            BiasMethod::Covariance => "covariance",
            BiasMethod::Fos => "fos",
        }
    }

    /// `--bias-order` when not given.
    fn default_order(self) -> usize {
        match self {
            BiasMethod::Fos => 10,
            _ => 64,
        }
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// The daemon: source from config (serial or replay) → pipeline → sinks, until SIGINT/SIGTERM.
    Run {
        /// Config file (default: the embedded config/default.toml).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Extra outputs: stdout[:csv|jsonl|native], file:PATH, csv:PATH, jsonl:PATH, tcp:ADDR, udp:ADDR.
        #[arg(long = "out")]
        out: Vec<String>,
        /// Also write the final health summary as JSON to this file.
        #[arg(long)]
        summary_json: Option<PathBuf>,
    },
    /// Run the daemon's pipeline on a recorded log and print a health summary.
    Replay {
        log: PathBuf,
        #[arg(long)]
        config: Option<PathBuf>,
        #[arg(long = "out")]
        out: Vec<String>,
        /// Pace by sensor time at this speed factor (0 = as fast as possible).
        #[arg(long, default_value_t = 0.0)]
        speed: f64,
        #[arg(long)]
        summary_json: Option<PathBuf>,
        #[command(flatten)]
        proto: imuprep::frame::detect::ProtocolArgs,
    },
    /// Convert a recording into a replay log: CSV (canonical or vendor layout, optionally .gz),
    /// or UBX / MAVLink / ULog (with --protocol, or any file that is not .csv: detected).
    Import {
        input: PathBuf,
        #[command(flatten)]
        proto: imuprep::frame::detect::ProtocolArgs,
        #[arg(short, long)]
        output: PathBuf,
        /// Column mapping, repeatable: --col gx=gyro_x_dps (keys: t gx gy gz ax ay az temp).
        #[arg(long = "col")]
        cols: Vec<String>,
        #[arg(long, value_enum)]
        gyro_unit: Option<GyroUnit>,
        #[arg(long, value_enum)]
        accel_unit: Option<AccelUnit>,
        #[arg(long, value_enum)]
        time_unit: Option<TimeUnit>,
        /// Ignore the time column; time = row index / RATE (Hz).
        #[arg(long)]
        rate: Option<f64>,
        /// Start the log at t = 0 (subtract the first time stamp).
        #[arg(long)]
        rebase_time: bool,
        /// Gyro full-scale range, deg/s (enables saturation flags on replay).
        #[arg(long, default_value_t = 0.0)]
        gyro_range_dps: f64,
        /// Accelerometer full-scale range, g.
        #[arg(long, default_value_t = 0.0)]
        accel_range_g: f64,
    },
    /// Simulate a MEMS IMU (scenario TOML, see docs/scenario.md) into a replay log + truth sidecar.
    Simulate {
        scenario: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Truth sidecar CSV (gzip when it ends in .gz).
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Seed (default: the scenario's `seed`, else 0). Same seed → same bytes.
        #[arg(long)]
        seed: Option<u64>,
        /// Override a scenario key, repeatable: --set errors.gross.rate_per_sample=2e-3
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
    /// Fit models from a recording: ARIMA per channel (gross-error stage) → DIR/arima.toml, and
    /// the AR bias model per channel (bias stage; Burg, Yule-Walker, covariance or linear FOS)
    /// → DIR/bias.toml.
    Fit {
        log: PathBuf,
        /// Directory for the model files (created if needed).
        #[arg(long, default_value = "models")]
        out_dir: PathBuf,
        /// Seconds of data used for identification (the paper's training span).
        #[arg(long, default_value_t = 180.0)]
        train_s: f64,
        /// Skip this many seconds at the start (start-up transients).
        #[arg(long, default_value_t = 0.0)]
        skip_s: f64,
        /// Fitting method of the bias model. `fos`: fast orthogonal search over a constant and
        /// lags 1..=L (CP degree 1, the linear model the online Kalman filter can run),
        /// converted to the equivalent AR model.
        #[arg(long, value_enum, default_value_t = BiasMethod::Burg)]
        bias_method: BiasMethod,
        /// AR order of the bias model (for `fos`: the largest lag L). Default 64 for the AR
        /// methods: the bias stage splits the fitted signal spectrum into a slow bias and white
        /// noise, which a short AR cannot describe; default 10 (the paper's L) for `fos`.
        #[arg(long)]
        bias_order: Option<usize>,
    },
    /// Score the configured pipeline against a calibration-only baseline on a simulated scenario
    /// (truth known): RMS of 1-s mean error, 60-s heading drift, manoeuvre integrals (gyros).
    Evaluate {
        #[arg(long)]
        scenario: PathBuf,
        #[arg(long)]
        seed: Option<u64>,
        #[arg(long)]
        config: Option<PathBuf>,
        #[arg(long)]
        json: Option<PathBuf>,
        /// Override a scenario key, repeatable: --set errors.gross.rate_per_sample=2e-3
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
    /// Close the loop: fit the model, analyse the held-out residual (whiteness, spectrum lines,
    /// temperature, other axes, g-sensitivity, steps, Allan slopes, quantisation), add the best
    /// significant effect, refit, repeat; report before/after, plots, and a bias model with the
    /// learned effects (DIR/bias.toml) that the daemon's [bias] model can load.
    Diagnose {
        log: PathBuf,
        /// Channels (gx gy gz ax ay az); repeatable; default all.
        #[arg(long = "channel")]
        channels: Vec<String>,
        /// Analyse only from this time (s from the start of the log)...
        #[arg(long, default_value_t = 0.0)]
        from_s: f64,
        /// ...to this time (s; default: the end). Use it to pick a still stretch of a moving log.
        #[arg(long)]
        to_s: Option<f64>,
        /// Output directory: report.txt, report.json, bias.toml, plots/*.svg.
        #[arg(long, default_value = "diagnose-out")]
        out_dir: PathBuf,
        /// Scan a long log in windows of this length (s), each with its own train / validation /
        /// test split, written to OUT_DIR/window_<start>s/; a summary lists what each window
        /// added. Effects are chosen on a window's train and validation parts only, so one run
        /// over a long log never sees an effect that starts after its first minutes.
        #[arg(long)]
        window_s: Option<f64>,
        /// Start-to-start spacing of the windows (s; default 90 = half the 180-s train part, so
        /// that every instant lies in the middle of some window's train part, where change points
        /// are searched — a step at a train part's edge looks like a trend or a level).
        #[arg(long, default_value_t = 90.0)]
        hop_s: f64,
    },
    /// Compare methods on the same data. `--detectors --scenario S.toml`: gross-error detectors
    /// against the simulator's truth. `LOG --channel C`: the bias models of the FOS paper.
    Compare {
        /// Recorded log (bias-model comparison).
        log: Option<PathBuf>,
        /// Compare gross-error detectors (needs --scenario: truth comes from the simulator).
        #[arg(long)]
        detectors: bool,
        /// Scenario TOML to simulate (with --detectors).
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// Override a scenario key, repeatable: --set errors.gross.rate_per_sample=2e-3
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
        #[arg(long)]
        seed: Option<u64>,
        /// Config whose [gross_error.settings] the online stage uses (default: embedded).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Channels for the bias comparison (gx gy gz ax ay az); repeatable; default all.
        #[arg(long = "channel")]
        channels: Vec<String>,
        /// Skip this many seconds at the start (start-up transients).
        #[arg(long, default_value_t = 0.0)]
        skip_s: f64,
        /// Use the temperature channel as an exogenous FOS input.
        #[arg(long)]
        temp_exo: bool,
        /// Write the report as JSON here (and CSV beside it for the bias comparison).
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Do-no-harm audit: the embedded default pipeline over every recording under DIR (CSV as
    /// `import` reads it, or native logs), scored against the targets of issue 12, with seeded
    /// injections of spikes, outliers and bad values.
    Audit {
        /// Folder searched recursively for .csv, .csv.gz and .log recordings.
        #[arg(default_value = "../shared/data/real")]
        dir: PathBuf,
        /// Seed of every injection.
        #[arg(long, default_value_t = 12)]
        seed: u64,
        /// Audit this config's pipeline instead of the embedded default.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Noise parameters: overlapping Allan deviation per channel with confidence bands, the
    /// IEEE-952 terms fitted to it, a plot, and exports (Kalibr imu.yaml, GNSS_IMU config lines,
    /// bias model TOML) in OUT_DIR.
    Allan {
        /// Static recording (replay log); the samples are taken as equally spaced at its rate.
        log: PathBuf,
        /// Channels (gx gy gz in rad/s, ax ay az in m/s^2); repeatable; default all.
        #[arg(long = "channel")]
        channels: Vec<String>,
        /// Skip this many seconds at the start (start-up transients), s.
        #[arg(long, default_value_t = 0.0)]
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
        log: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "csv")]
        to: imuprep::io::convert::ExportFormat,
        #[command(flatten)]
        proto: imuprep::frame::detect::ProtocolArgs,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_new(&cli.log_level)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .init();
    match run(cli.cmd) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("imuprep: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn load_config(path: &Option<PathBuf>) -> Result<Config> {
    let c = match path {
        Some(p) => Config::from_file(p),
        None => Config::default_embedded(),
    };
    c.map_err(|e| anyhow::anyhow!("{e}"))
}

fn run(cmd: Cmd) -> Result<ExitCode> {
    match cmd {
        Cmd::Audit {
            dir,
            seed,
            config,
            json,
        } => {
            let cfg = load_config(&config)?;
            audit(&dir, seed, cfg, json)
        }
        Cmd::Run {
            config,
            out,
            summary_json,
        } => {
            let mut cfg = load_config(&config)?;
            add_outs(&mut cfg, &out)?;
            daemon(cfg, summary_json)
        }
        Cmd::Replay {
            log,
            config,
            out,
            speed,
            summary_json,
            proto,
        } => {
            let mut cfg = load_config(&config)?;
            proto.apply(&mut cfg.protocol);
            let errs = cfg.protocol.validate();
            anyhow::ensure!(errs.is_empty(), "{errs:?}");
            anyhow::ensure!(speed.is_finite() && speed >= 0.0, "--speed must be ≥ 0");
            // The log declares its rate: the stages use it rather than the config's nominal one.
            if let Ok(Some(d)) = imuprep::io::csv::read_descriptor(&log) {
                cfg.stages.set_sample_rate(d.sample_rate_hz);
            }
            cfg.source = SourceConfig::Replay { path: log, speed };
            add_outs(&mut cfg, &out)?;
            daemon(cfg, summary_json)
        }
        Cmd::Import {
            input,
            proto,
            output,
            cols,
            gyro_unit,
            accel_unit,
            time_unit,
            rate,
            rebase_time,
            gyro_range_dps,
            accel_range_g,
        } => {
            let mut o = ImportOptions {
                gyro_unit,
                accel_unit,
                time_unit,
                time_from_index_hz: rate,
                rebase_time,
                gyro_range_rad_s: gyro_range_dps.to_radians() as f32,
                accel_range_m_s2: (accel_range_g * csvio::G0) as f32,
                ..Default::default()
            };
            if let Some(r) = rate {
                anyhow::ensure!(r.is_finite() && r > 0.0, "--rate must be > 0 Hz");
            }
            for c in &cols {
                let (k, v) = c
                    .split_once('=')
                    .with_context(|| format!("--col {c:?}: expected KEY=COLUMN"))?;
                let i = ["t", "gx", "gy", "gz", "ax", "ay", "az", "temp"]
                    .iter()
                    .position(|x| *x == k)
                    .with_context(|| {
                        format!("--col {c:?}: key must be one of t gx gy gz ax ay az temp")
                    })?;
                o.columns[i] = Some(v.to_string());
            }
            let is_csv = {
                let n = input.to_string_lossy().to_ascii_lowercase();
                n.ends_with(".csv") || n.ends_with(".csv.gz")
            };
            let (d, samples) = if is_csv && proto.protocol.is_none() {
                csvio::read_csv(&input, &o)?
            } else {
                let mut pc = imuprep::frame::detect::ProtocolConfig::auto();
                proto.apply(&mut pc);
                let f = imuprep::io::convert::read_any(&input, &pc)?;
                eprintln!("{} input: {}", f.protocol, f.found);
                let mut d = f.descriptor.unwrap_or_default();
                d.gyro_range_rad_s = o.gyro_range_rad_s;
                d.accel_range_m_s2 = o.accel_range_m_s2;
                (d, f.samples)
            };
            csvio::write_log(&output, &d, &samples)?;
            eprintln!(
                "imported {} samples ({:.1} s at {:.2} Hz) from {} into {}",
                samples.len(),
                samples.last().map_or(0.0, |s| s.t_s() - samples[0].t_s()),
                d.sample_rate_hz,
                input.display(),
                output.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Simulate {
            scenario,
            output,
            truth,
            seed,
            sets,
        } => {
            let scn = read_scenario(&scenario, &sets)?;
            let seed = imuprep::sim::log::effective_seed(&scn, seed);
            let s = imuprep::sim::log::write_sim_log(&scn, seed, &output, truth.as_deref())?;
            eprintln!(
                "simulated {} instants (seed {seed}): {} frames ({} dropped, {} duplicated), {} bytes → {}",
                s.instants,
                s.frames,
                s.dropped,
                s.duplicated,
                s.bytes,
                output.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Fit {
            log,
            out_dir,
            train_s,
            skip_s,
            bias_method,
            bias_order,
        } => fit(
            &log,
            &out_dir,
            train_s,
            skip_s,
            bias_method,
            bias_order.unwrap_or(bias_method.default_order()),
        ),
        Cmd::Evaluate {
            scenario,
            seed,
            config,
            json,
            sets,
        } => evaluate(&scenario, seed, &config, json, &sets),
        Cmd::Diagnose {
            log,
            channels,
            from_s,
            to_s,
            out_dir,
            window_s,
            hop_s,
        } => match window_s {
            None => diagnose(&log, &channels, from_s, to_s, &out_dir).map(|_| ExitCode::SUCCESS),
            Some(w) => diagnose_windows(&log, &channels, from_s, to_s, w, hop_s, &out_dir),
        },
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
        } => {
            if detectors {
                let scenario = scenario.context(
                    "--detectors needs --scenario S.toml (the truth comes from the simulator)",
                )?;
                compare_detectors(&scenario, seed, &config, json, &sets)
            } else {
                let log = log.context(
                    "compare needs a LOG (bias models) or --detectors --scenario S.toml",
                )?;
                compare_bias(&log, &channels, skip_s, temp_exo, json)
            }
        }
        Cmd::Allan {
            log,
            channels,
            skip_s,
            out_dir,
            json,
        } => allan(&log, &channels, skip_s, &out_dir, json),
        Cmd::Navtest {
            data,
            config,
            json,
            no_static,
        } => {
            let cfg = load_config(&config)?;
            let rep = imuprep::report::navtest::navtest(&data, &cfg, !no_static);
            print!("{rep}");
            if let Some(p) = json {
                std::fs::write(&p, serde_json::to_string_pretty(&rep)?)
                    .with_context(|| format!("writing {}", p.display()))?;
            }
            Ok(if rep.records.is_empty() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
        Cmd::Export {
            log,
            output,
            to,
            proto,
        } => {
            let mut pc = imuprep::frame::detect::ProtocolConfig::auto();
            proto.apply(&mut pc);
            let f = imuprep::io::convert::read_any(&log, &pc)?;
            let (samples, stats) = (f.samples, f.stats);
            if to == imuprep::io::convert::ExportFormat::Csv {
                csvio::write_csv(&output, &samples)?;
            } else {
                let d = f.descriptor.unwrap_or_default();
                let b = imuprep::io::convert::encode_stream(to, &d, &samples);
                std::fs::write(&output, &b)
                    .with_context(|| format!("writing {}", output.display()))?;
            }
            eprintln!(
                "exported {} samples to {} ({} CRC errors, {} resyncs in the log)",
                samples.len(),
                output.display(),
                stats.crc_errors,
                stats.resyncs
            );
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn audit(dir: &std::path::Path, seed: u64, cfg: Config, json: Option<PathBuf>) -> Result<ExitCode> {
    let report = imuprep::report::audit::audit_dir(dir, seed, &cfg)
        .with_context(|| format!("cannot read {}", dir.display()))?;
    anyhow::ensure!(
        !report.recordings.is_empty(),
        "no recording under {} could be audited",
        dir.display()
    );
    print!("{report}");
    if let Some(p) = json {
        std::fs::write(&p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(if report.missed().is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn add_outs(cfg: &mut Config, outs: &[String]) -> Result<()> {
    let mut errs = Vec::new();
    for o in outs {
        match imuprep::runtime::parse_out_spec(o) {
            Ok(s) => cfg.sinks.push(s),
            Err(e) => errs.push(format!("--out {o}: {e}")),
        }
    }
    anyhow::ensure!(errs.is_empty(), "{}", errs.join("\n"));
    Ok(())
}

fn daemon(cfg: Config, summary_json: Option<PathBuf>) -> Result<ExitCode> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let pipeline = cfg.stages.build().map_err(|e| anyhow::anyhow!(e))?;
    tracing::info!(stages = ?pipeline.stage_names(), "pipeline ready");
    let health = rt.block_on(imuprep::runtime::run(&cfg, pipeline))?;
    eprint!("{}", health.text());
    if let Some(p) = summary_json {
        std::fs::write(&p, serde_json::to_string_pretty(&health)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Read a scenario file with `--set KEY=VALUE` overrides applied.
fn read_scenario(p: &std::path::Path, sets: &[String]) -> Result<imuprep::sim::Scenario> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    let overrides = sets
        .iter()
        .map(|kv| {
            kv.split_once('=')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .with_context(|| format!("--set {kv:?}: expected KEY=VALUE"))
        })
        .collect::<Result<Vec<_>>>()?;
    imuprep::sim::Scenario::from_toml_str_with(&text, &overrides)
        .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))
}

fn compare_detectors(
    scenario: &std::path::Path,
    seed: Option<u64>,
    config: &Option<PathBuf>,
    json: Option<PathBuf>,
    sets: &[String],
) -> Result<ExitCode> {
    use imuprep::analysis::detector_compare as dc;
    let scn = read_scenario(scenario, sets)?;
    let seed = imuprep::sim::log::effective_seed(&scn, seed);
    let cfg = load_config(config)?;
    let (settings, model) = cfg
        .stages
        .gross_error
        .map(|g| (g.settings, g.model))
        .unwrap_or_default();
    let (samples, truth) = dc::simulate_decoded(&scn, seed)?;
    // Without a fitted model the online stage spends its first `warmup_samples` identifying
    // one (passing samples through); every detector is scored on the samples after that.
    let from = if model.is_some() {
        0
    } else {
        settings.warmup_samples.min(samples.len())
    };
    let rows = dc::compare_detectors(&samples, &truth, &settings, model.as_ref(), from)
        .map_err(|e| anyhow::anyhow!(e))?;
    let report = dc::DetectorReport {
        scenario: scenario.display().to_string(),
        seed,
        samples: samples.len(),
        scored_from: from,
        gross_samples: truth[from..]
            .iter()
            .map(|t| t.gross_mask.iter().filter(|m| **m).count() as u64)
            .sum(),
        rows,
    };
    print!("{}", report.text());
    if let Some(p) = json {
        std::fs::write(&p, serde_json::to_string_pretty(&report)?)?;
    }
    Ok(ExitCode::SUCCESS)
}

fn compare_bias(
    log: &std::path::Path,
    channels: &[String],
    skip_s: f64,
    temp_exo: bool,
    json: Option<PathBuf>,
) -> Result<ExitCode> {
    use imuprep::analysis::bias_compare::{CompareSettings, SensorKind, compare_channel};
    use imuprep::sample::CHANNEL_NAMES;
    let (rate, samples) = load_span(log, skip_s)?;
    let chans = parse_channels(channels)?;
    let temp: Vec<f64> = samples.iter().filter_map(|s| s.temp_c).collect();
    let have_temp = temp_exo && temp.len() == samples.len();
    anyhow::ensure!(
        !temp_exo || have_temp,
        "--temp-exo: the log has no complete temperature channel"
    );
    let settings = CompareSettings::paper(rate);
    let mut reports = Vec::new();
    for c in chans {
        let y: Vec<f64> = samples.iter().map(|s| s.channel(c)).collect();
        let exo: Vec<&[f64]> = if have_temp {
            vec![&temp[..]]
        } else {
            Vec::new()
        };
        let kind = if c < 3 {
            SensorKind::Gyro
        } else {
            SensorKind::Accel
        };
        let rep = compare_channel(&y, &exo, CHANNEL_NAMES[c], kind, &settings)?;
        println!("{}", rep.to_text_table());
        reports.push(rep);
    }
    if let Some(p) = json {
        let mut csv = String::new();
        for r in &reports {
            csv.push_str(&r.to_csv());
        }
        std::fs::write(p.with_extension("csv"), csv)?;
        let all: Vec<serde_json::Value> = reports
            .iter()
            .map(|r| serde_json::from_str(&r.to_json()).unwrap_or(serde_json::Value::Null))
            .collect();
        std::fs::write(&p, serde_json::to_string_pretty(&all)?)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Samples of a log after `skip_s`, with the log's sample rate.
fn load_span(log: &std::path::Path, skip_s: f64) -> Result<(f64, Vec<imuprep::Sample>)> {
    let (desc, samples, _) = csvio::read_log(log)?;
    let rate = desc.map(|d| d.sample_rate_hz).unwrap_or(0.0);
    anyhow::ensure!(
        rate > 0.0,
        "{}: the log does not declare its sample rate",
        log.display()
    );
    let skip = (skip_s * rate).round() as usize;
    anyhow::ensure!(skip < samples.len(), "--skip-s removes the whole log");
    Ok((rate, samples[skip..].to_vec()))
}

fn fit(
    log: &std::path::Path,
    out_dir: &std::path::Path,
    train_s: f64,
    skip_s: f64,
    bias_method: BiasMethod,
    bias_order: usize,
) -> Result<ExitCode> {
    use imuprep::model::arima::{ArimaModelFile, IdentifySettings, identify};
    use imuprep::model::bias_model::{BiasModelFile, ChannelBiasModel, MAX_FILE_AR_ORDER};
    use imuprep::sample::CHANNEL_NAMES;
    anyhow::ensure!(
        (1..=MAX_FILE_AR_ORDER).contains(&bias_order),
        "--bias-order must be in 1..={MAX_FILE_AR_ORDER} (got {bias_order})"
    );
    let (rate, samples) = load_span(log, skip_s)?;
    let n = ((train_s * rate).round() as usize).min(samples.len());
    std::fs::create_dir_all(out_dir)?;
    let mut file = ArimaModelFile::default();
    println!(
        "ARIMA identification on {n} samples ({:.0} s at {rate} Hz):",
        n as f64 / rate
    );
    println!(
        "{:<4} {:>9} {:>10} {:>8} {:>12} {:>12} {:>10}",
        "ch", "(p,d,q)", "ADF stat", "ADF p", "sigma", "Ljung-Box Q", "LB p"
    );
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let x: Vec<f64> = samples[..n].iter().map(|s| s.channel(c)).collect();
        let id = identify(&x, &IdentifySettings::default())
            .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let m = id.to_channel_model(name);
        println!(
            "{:<4} {:>9} {:>10.3} {:>8.4} {:>12.4e} {:>12.2} {:>10.4}",
            name,
            format!("({},{},{})", m.p, m.d, m.q),
            id.adf.stat,
            id.adf.p_value,
            m.sigma,
            id.ljung_box.q,
            id.ljung_box.p_value
        );
        file.channels.push(m);
    }
    let path = out_dir.join("arima.toml");
    std::fs::write(
        &path,
        file.to_toml_string().map_err(|e| anyhow::anyhow!("{e}"))?,
    )?;
    println!(
        "wrote {} (use it as [gross_error] model = \"{}\")",
        path.display(),
        path.display()
    );

    let mut bias = BiasModelFile::default();
    match bias_method {
        BiasMethod::Fos => println!(
            "bias model: FOS CP=1 L={bias_order} (constant + lags, as AR) per channel on the same span:"
        ),
        m => println!(
            "bias model: {} AR({bias_order}) per channel on the same span:",
            m.file_name()
        ),
    }
    for (c, name) in CHANNEL_NAMES.iter().enumerate() {
        let x: Vec<f64> = samples[..n].iter().map(|s| s.channel(c)).collect();
        let err = |e: imuprep::model::ModelError| anyhow::anyhow!("{name}: {e}");
        let from_ar = |f: imuprep::model::ArFit| ChannelBiasModel {
            channel: name.to_string(),
            method: bias_method.file_name().into(),
            sample_rate_hz: rate,
            mean: f.mean,
            ar: f.coeffs,
            innovation_var: f.noise_var,
            white_noise_var: 0.0,
            ..Default::default()
        };
        let (m, detail) = match bias_method {
            BiasMethod::Burg => (
                from_ar(imuprep::model::burg(&x, bias_order).map_err(err)?),
                String::new(),
            ),
            BiasMethod::YuleWalker => (
                from_ar(imuprep::model::yule_walker(&x, bias_order).map_err(err)?),
                String::new(),
            ),
            BiasMethod::Covariance => (
                from_ar(imuprep::model::covariance(&x, bias_order).map_err(err)?),
                String::new(),
            ),
            BiasMethod::Fos => {
                use imuprep::model::fos::FosSettings;
                use imuprep::model::fos_model::{FosModel, FosModelSpec};
                let (f, _) = FosModel::fit(
                    &x,
                    &[],
                    &FosModelSpec::paper(bias_order, 1),
                    &FosSettings::default(),
                )
                .map_err(err)?;
                // One-step residuals on the fit rows (those with a full L-sample past), y units.
                let r = f.residuals(&x, &[], bias_order..x.len());
                anyhow::ensure!(
                    !r.is_empty(),
                    "{name}: no fit rows for FOS with L = {bias_order}"
                );
                let mse = r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64;
                let m = ChannelBiasModel::from_linear_fos(name, rate, &f, mse)
                    .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
                let terms: Vec<String> = f.terms.iter().map(|t| t.name()).collect();
                let terms = if terms.is_empty() {
                    "none (white)".to_string()
                } else {
                    terms.join(" ")
                };
                (m, format!("  terms {terms}"))
            }
        };
        println!(
            "{name:<4} {:<11} mean {:>12.4e}  one-step innovation sd {:>10.4e}{detail}",
            m.method,
            m.mean,
            m.innovation_var.sqrt()
        );
        bias.channels.push(m);
    }
    bias.validate()
        .map_err(|e| anyhow::anyhow!("bias model: {}", e.join("; ")))?;
    let bpath = out_dir.join("bias.toml");
    std::fs::write(
        &bpath,
        bias.to_toml_string()
            .map_err(|e| anyhow::anyhow!(e.to_string()))?,
    )?;
    println!(
        "wrote {} (use it as [bias] model = \"{}\")",
        bpath.display(),
        bpath.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn evaluate(
    scenario: &std::path::Path,
    seed: Option<u64>,
    config: &Option<PathBuf>,
    json: Option<PathBuf>,
    sets: &[String],
) -> Result<ExitCode> {
    use imuprep::analysis::pipeline_eval as pe;
    let scn = read_scenario(scenario, sets)?;
    let seed = imuprep::sim::log::effective_seed(&scn, seed);
    let mut cfg = load_config(config)?;
    let rate = scn.sample_rate_hz();
    cfg.stages.set_sample_rate(rate);
    let pipeline = cfg.stages.build().map_err(|e| anyhow::anyhow!(e))?;
    let (samples, truth) = pe::simulate(&scn, seed)?;
    let cal = cfg
        .stages
        .bias
        .as_ref()
        .map(|b| b.settings.clone())
        .unwrap_or_default();
    let gyro_cal = cal
        .gyro
        .build()
        .context("gyro calibration matrix is singular")?;
    let accel_cal = cal
        .accel
        .build()
        .context("accel calibration matrix is singular")?;
    let calibrate = move |mut s: imuprep::Sample| {
        s.gyro = gyro_cal.apply(&s.gyro);
        s.accel = accel_cal.apply(&s.accel);
        s
    };
    let res = pe::evaluate(&samples, &truth, rate, pipeline, calibrate);
    let second = cfg.stages.build().map_err(|e| anyhow::anyhow!(e))?;
    let static_drift = pe::static_position_drift(&samples, &truth, rate, second, calibrate);
    println!(
        "pipeline vs calibration-only baseline on {} (seed {seed}), gyro channels:",
        scenario.display()
    );
    println!(
        "{:<3} {:>14} {:>14} {:>8} {:>14} {:>14} {:>9}  manoeuvres: worst attenuation, worst |change|, worst removed by the stage",
        "ch", "1s-mean RMS", "baseline", "ratio", "60s drift rad", "baseline", "reduced",
    );
    for r in &res {
        println!(
            "{:<3} {:>14.3e} {:>14.3e} {:>8.2} {:>14.3e} {:>14.3e} {:>8.1}%  {:.2}%, {:.2}%, {:.2}% of {}",
            r.channel,
            r.pipeline.rms_1s_mean_error,
            r.baseline.rms_1s_mean_error,
            r.improvement_1s,
            r.pipeline.rms_60s_drift_rad,
            r.baseline.rms_60s_drift_rad,
            100.0 * r.drift_reduction,
            100.0 * r.worst_attenuation,
            100.0 * r.worst_abs_change,
            100.0 * r.worst_stage_removed,
            r.manoeuvres
        );
    }
    if let Some(d) = &static_drift {
        println!(
            "static 60-s position drift (plain strapdown of the errors, {} windows): RMS {:.3e} m, baseline {:.3e} m, reduced {:.1}%",
            d.windows,
            d.pipeline_rms_m,
            d.baseline_rms_m,
            100.0 * d.reduction
        );
    }
    for r in res.iter().filter(|r| !r.manoeuvre_list.is_empty()) {
        println!(
            "{} manoeuvres: start s, duration s, true angle rad, change (+ = attenuated), removed by the stage, mean error rad/s (in the 1 s before)",
            r.channel
        );
        for m in &r.manoeuvre_list {
            println!(
                "  {:>7.1} {:>6.1} {:>9.4} {:>+8.2}% {:>+8.3}% {:>+11.3e} ({:>+10.3e})",
                m.start_s,
                m.duration_s,
                m.true_angle_rad,
                100.0 * m.change,
                100.0 * m.stage_removed,
                m.mean_error,
                m.mean_error_before
            );
        }
    }
    if let Some(p) = json {
        std::fs::write(&p, serde_json::to_string_pretty(&res)?)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// What one `diagnose` run added, per channel: (channel, effects chosen by the loop, with times
/// from the start of the analysed stretch).
type Added = Vec<(String, Vec<imuprep::model::bias_model::Effect>)>;

/// `diagnose --window-s W`: the loop on overlapping windows of a long log, and a summary.
fn diagnose_windows(
    log: &std::path::Path,
    channels: &[String],
    from_s: f64,
    to_s: Option<f64>,
    window_s: f64,
    hop_s: f64,
    out_dir: &std::path::Path,
) -> Result<ExitCode> {
    use imuprep::analysis::diagnose_report::effect_text;
    use imuprep::model::bias_model::Effect;
    anyhow::ensure!(
        window_s > 0.0 && hop_s > 0.0 && hop_s <= window_s,
        "--window-s and --hop-s must be > 0, with the hop no longer than the window"
    );
    let (rate, samples) = load_span(log, from_s)?;
    let total_s = samples.len() as f64 / rate;
    let end_s = to_s.map_or(from_s + total_s, |t| t.min(from_s + total_s));
    // Windows start every hop; a window shorter than half its length (the log's tail) is
    // dropped, since its split would leave too little to fit and test on.
    let mut starts = Vec::new();
    let mut t = from_s;
    while t < end_s && (end_s - t >= 0.5 * window_s || starts.is_empty()) {
        starts.push(t);
        t += hop_s;
    }
    let mut summary = Vec::new();
    for &a in &starts {
        let b = (a + window_s).min(end_s);
        println!("== window {a:.0}–{b:.0} s");
        let dir = out_dir.join(format!("window_{a:.0}s"));
        let i0 = (((a - from_s) * rate).round() as usize).min(samples.len());
        let i1 = (((b - from_s) * rate).round() as usize).clamp(i0, samples.len());
        let added = diagnose_samples(log, &samples[i0..i1], rate, a, channels, &dir)?;
        summary.push((a, b, added));
    }
    // Each window is tested at the loop's own significance level, so a scan of many windows
    // adds more false findings than one run (slow wander read as a step, say): a finding is
    // a place to look, to be confirmed with --from-s/--to-s around it.
    println!(
        "\nsummary: what each window's loop added (step times from the log's start; each window is tested on its own, so expect some findings from slow wander)"
    );
    for (a, b, added) in &summary {
        for (ch, effects) in added {
            let text: Vec<String> = effects
                .iter()
                .map(|e| match *e {
                    Effect::Step { t_s, size } => effect_text(&Effect::Step { t_s: t_s + a, size }),
                    ref other => effect_text(other),
                })
                .collect();
            println!("  {a:>7.0}–{b:<7.0} {ch}: {}", effects_text(&text));
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Effect texts joined with "; ", or "nothing".
fn effects_text(v: &[String]) -> String {
    if v.is_empty() {
        "nothing".to_string()
    } else {
        v.join("; ")
    }
}

/// `diagnose` on one stretch of a log.
fn diagnose(
    log: &std::path::Path,
    channels: &[String],
    from_s: f64,
    to_s: Option<f64>,
    out_dir: &std::path::Path,
) -> Result<Added> {
    let (rate, samples) = load_span(log, from_s)?;
    let end = match to_s {
        Some(t) => (((t - from_s) * rate).round() as usize).min(samples.len()),
        None => samples.len(),
    };
    diagnose_samples(log, &samples[..end], rate, from_s, channels, out_dir)
}

/// The loop on `samples` (already cut to the stretch that starts `from_s` into `log`).
fn diagnose_samples(
    log: &std::path::Path,
    samples: &[imuprep::Sample],
    rate: f64,
    from_s: f64,
    channels: &[String],
    out_dir: &std::path::Path,
) -> Result<Added> {
    use imuprep::analysis::diagnose::{ChannelInput, DiagnoseSettings, diagnose_channel};
    use imuprep::analysis::diagnose_report::{DiagnoseReport, channel_plots, effect_text};
    use imuprep::analysis::exogenous::Exogenous;
    use imuprep::model::bias_model::{BiasModelFile, ChannelBiasModel};
    use imuprep::sample::CHANNEL_NAMES;
    let end = samples.len();
    anyhow::ensure!(end > 0, "the chosen stretch is empty");
    let chans = parse_channels(channels)?;
    let series: Vec<Vec<f64>> = (0..6)
        .map(|c| samples.iter().map(|s| s.channel(c)).collect())
        .collect();
    let temp: Option<Vec<f64>> = samples.iter().map(|s| s.temp_c).collect();
    std::fs::create_dir_all(out_dir.join("plots"))?;
    let settings = DiagnoseSettings::default();
    let mut report = DiagnoseReport {
        source: format!(
            "{} [{from_s} s .. +{:.1} s at {rate} Hz]",
            log.display(),
            end as f64 / rate
        ),
        channels: vec![],
    };
    let mut model = BiasModelFile::default();
    let mut added_all: Added = Vec::new();
    for c in chans {
        let name = CHANNEL_NAMES[c];
        let others: Vec<(String, &[f64])> = (0..6)
            .filter(|j| *j != c)
            .map(|j| (CHANNEL_NAMES[j].to_string(), series[j].as_slice()))
            .collect();
        let exo = Exogenous {
            temperature_c: temp.as_deref(),
            specific_force_m_s2: (c < 3).then(|| {
                [
                    series[3].as_slice(),
                    series[4].as_slice(),
                    series[5].as_slice(),
                ]
            }),
            other_axes: &others,
        };
        let input = ChannelInput {
            name,
            values: &series[c],
            rate_hz: rate,
            exogenous: exo,
        };
        match diagnose_channel(&input, &settings) {
            Ok(d) => {
                let added: Vec<String> = d
                    .iterations
                    .iter()
                    .map(|it| effect_text(&it.effect))
                    .collect();
                let added = effects_text(&added);
                // What the model file carries: the effects refitted on the whole log for
                // deployment; one the loop added may have been superseded by a later one (a step
                // re-found nearby), so this list can be shorter than the loop's.
                let written: Vec<String> = d.effects.iter().map(effect_text).collect();
                let written = effects_text(&written);
                println!(
                    "{name}: first model AR({}) test MSE {:.4e}; added: {added}; final test MSE {:.4e} ({:.1} % lower)",
                    d.baseline.ar_order,
                    d.baseline.mse_one_step,
                    d.final_metrics.mse_one_step,
                    100.0 * (1.0 - d.final_metrics.mse_one_step / d.baseline.mse_one_step)
                );
                println!("{name}: effects in the model file (refit on the whole log): {written}");
                for (stem, svg) in channel_plots(&d) {
                    std::fs::write(out_dir.join("plots").join(format!("{stem}.svg")), svg)?;
                }
                model.channels.push(ChannelBiasModel {
                    channel: name.to_string(),
                    method: "burg".into(),
                    sample_rate_hz: rate,
                    mean: d.intercept,
                    ar: d.ar.clone(),
                    innovation_var: d.innovation_var,
                    white_noise_var: 0.0,
                    effects: d.effects.clone(),
                    ..Default::default()
                });
                added_all.push((
                    name.to_string(),
                    d.iterations.iter().map(|it| it.effect.clone()).collect(),
                ));
                report.channels.push(d);
            }
            Err(e) => println!("{name}: cannot diagnose: {e}"),
        }
    }
    std::fs::write(out_dir.join("report.txt"), report.to_text())?;
    std::fs::write(
        out_dir.join("report.json"),
        report
            .to_json()
            .map_err(|e| anyhow::anyhow!(e.to_string()))?,
    )?;
    std::fs::write(
        out_dir.join("bias.toml"),
        model
            .to_toml_string()
            .map_err(|e| anyhow::anyhow!(e.to_string()))?,
    )?;
    println!(
        "wrote {0}/report.txt, {0}/report.json, {0}/bias.toml and {0}/plots/",
        out_dir.display()
    );
    Ok(added_all)
}

/// `allan`: the report on stdout, its files in `out_dir`.
fn allan(
    log: &std::path::Path,
    channels: &[String],
    skip_s: f64,
    out_dir: &std::path::Path,
    json: Option<PathBuf>,
) -> Result<ExitCode> {
    use imuprep::analysis::{allan_export, allan_report, allan_terms::FitSettings};
    let (rate, samples) = load_span(log, skip_s)?;
    let chans = parse_channels(channels)?;
    let source = log.display().to_string();
    let report =
        allan_report::allan_report(&source, &samples, rate, &chans, &FitSettings::default())?;
    print!("{report}");
    let written = allan_export::write_outputs(&report, out_dir).map_err(anyhow::Error::msg)?;
    if let Some(p) = json {
        std::fs::write(&p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    let names: Vec<_> = written
        .iter()
        .filter_map(|p| p.file_name()?.to_str())
        .collect();
    println!("wrote {} in {}", names.join(", "), out_dir.display());
    if !names.contains(&"imu.yaml") {
        println!("(imu.yaml and gnss_imu_config.txt need gyro and accelerometer channels)");
    }
    Ok(ExitCode::SUCCESS)
}

/// Channel names (gx gy gz ax ay az) → indices; none given = all six.
fn parse_channels(channels: &[String]) -> Result<Vec<usize>> {
    if channels.is_empty() {
        return Ok((0..6).collect());
    }
    channels
        .iter()
        .map(|c| {
            imuprep::sample::channel_index(c)
                .with_context(|| format!("unknown channel {c:?} (gx gy gz ax ay az)"))
        })
        .collect()
}
