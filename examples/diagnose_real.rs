//! Run the close-the-loop diagnosis on the real recordings in `../shared/data/real/`.
//!
//! `cargo run --release --example diagnose_real [OUT_DIR]` (default `results/real`): per
//! recording a text and a JSON report and SVG plots, plus a summary on stdout. Static recordings
//! are used whole; moving ones only on still stretches (the NOTES' stops for the rtklibexplorer
//! drive and walk; the longest automatically detected still stretch otherwise). comma2k19 is a
//! highway segment with no still stretch at all: it is left out, since the loop would read true
//! motion as bias (tried: its "still" stretch was driving, and g-sensitivity "explained" turns). Units are
//! converted to rad/s and m/s² (g = 9.80665). The ADIS16405 file is decompressed into /tmp only.
//! Time is sample index / mean rate (the MPU6050's host timestamps are bursty).

use imuprep::analysis::diagnose::paper_split::{ChannelInput, DiagnoseSettings, diagnose_channel};
use imuprep::analysis::diagnose::report::{DiagnoseReport, channel_plots, effect_text};
use imuprep::analysis::exogenous::Exogenous;
use std::path::{Path, PathBuf};

const G: f64 = 9.806_65;
const DEG: f64 = std::f64::consts::PI / 180.0;

#[derive(Clone, Copy)]
enum Stretch {
    Whole,
    /// Seconds from the first timestamp.
    Window(f64, f64),
    /// The longest still stretch (1-s windows).
    AutoStill,
}

struct Rec {
    name: &'static str,
    file: &'static str,
    time_col: usize,
    gyro: [usize; 3],
    gyro_scale: f64,
    acc: [usize; 3],
    acc_scale: f64,
    temp: Option<usize>,
    stretch: Stretch,
}

fn read_csv(path: &Path) -> Result<Vec<Vec<f64>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut rows = Vec::new();
    for line in text.lines().skip(1) {
        let r: Result<Vec<f64>, _> = line.split(',').map(|v| v.trim().parse::<f64>()).collect();
        match r {
            Ok(v) => rows.push(v),
            Err(_) => continue, // a truncated line: skip, as the NOTES say
        }
    }
    Ok(rows)
}

fn still_stretch(gyro: &[Vec<f64>; 3], rate: f64) -> (usize, usize) {
    let w = rate.round().max(2.0) as usize;
    let nw = gyro[0].len() / w;
    let sd: Vec<f64> = (0..nw)
        .map(|k| {
            let norm: Vec<f64> = (k * w..(k + 1) * w)
                .map(|i| (0..3).map(|a| gyro[a][i].powi(2)).sum::<f64>().sqrt())
                .collect();
            let m = norm.iter().sum::<f64>() / w as f64;
            (norm.iter().map(|v| (v - m).powi(2)).sum::<f64>() / w as f64).sqrt()
        })
        .collect();
    let mut sorted = sd.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let thr = 3.0 * sorted[sorted.len() / 20];
    let (mut best, mut cur) = ((0, 0), 0usize);
    for (k, v) in sd.iter().enumerate() {
        cur = if *v < thr { cur + 1 } else { 0 };
        if cur > best.1 - best.0 {
            best = (k + 1 - cur, k + 1);
        }
    }
    (best.0 * w, best.1 * w)
}

fn main() -> Result<(), String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real");
    if !root.exists() {
        eprintln!(
            "SKIP: {} not found (real recordings live beside the project only)",
            root.display()
        );
        return Ok(());
    }
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "results/real".into()),
    );
    std::fs::create_dir_all(out.join("plots")).map_err(|e| e.to_string())?;
    let adis_tmp = PathBuf::from("/tmp/adis_16405_imu1.csv");
    if !adis_tmp.exists() {
        let st = std::process::Command::new("sh")
            .arg("-c")
            .arg(format!(
                "gzip -dc '{}' > '{}'",
                root.join("adis16405_static/adis_16405_imu1.csv.gz")
                    .display(),
                adis_tmp.display()
            ))
            .status()
            .map_err(|e| e.to_string())?;
        if !st.success() {
            return Err("gzip failed".into());
        }
    }
    let recs = [
        Rec {
            name: "adis16405_static",
            file: "/tmp/adis_16405_imu1.csv",
            time_col: 0,
            gyro: [1, 2, 3],
            gyro_scale: DEG,
            acc: [4, 5, 6],
            acc_scale: G,
            temp: None,
            stretch: Stretch::Whole,
        },
        Rec {
            name: "mpu6050_static_10min_temp",
            file: "mpu6050_static_10min_temp/mpu6050_static.csv",
            time_col: 0,
            gyro: [1, 2, 3],
            gyro_scale: DEG,
            acc: [4, 5, 6],
            acc_scale: G,
            temp: Some(7),
            stretch: Stretch::Whole,
        },
        Rec {
            name: "rtklibexplorer_drive_stop_528_548s",
            file: "rtklibexplorer_drive_walk/drive_0708_imu.csv",
            time_col: 0,
            gyro: [5, 6, 7],
            gyro_scale: DEG,
            acc: [2, 3, 4],
            acc_scale: G,
            temp: None,
            stretch: Stretch::Window(528.0, 548.0),
        },
        Rec {
            name: "rtklibexplorer_drive_stop_198_208s",
            file: "rtklibexplorer_drive_walk/drive_0708_imu.csv",
            time_col: 0,
            gyro: [5, 6, 7],
            gyro_scale: DEG,
            acc: [2, 3, 4],
            acc_scale: G,
            temp: None,
            stretch: Stretch::Window(198.0, 208.0),
        },
        Rec {
            name: "rtklibexplorer_walk_still_106_122s",
            file: "rtklibexplorer_drive_walk/walk_0827_imu.csv",
            time_col: 0,
            gyro: [5, 6, 7],
            gyro_scale: DEG,
            acc: [2, 3, 4],
            acc_scale: G,
            temp: None,
            stretch: Stretch::Window(106.0, 122.0),
        },
        Rec {
            name: "ximu3_fusion_example_still",
            file: "ximu3_fusion_example/sensor_data.csv",
            time_col: 0,
            gyro: [1, 2, 3],
            gyro_scale: DEG,
            acc: [4, 5, 6],
            acc_scale: G,
            temp: None,
            stretch: Stretch::AutoStill,
        },
        Rec {
            name: "px4_sensor_combined_still",
            file: "px4_sensor_combined_sample/sensor_combined.csv",
            time_col: 0,
            gyro: [1, 2, 3],
            gyro_scale: 1.0,
            acc: [4, 5, 6],
            acc_scale: 1.0,
            temp: None,
            stretch: Stretch::AutoStill,
        },
    ];
    println!(
        "| recording | ch | stretch | first model (AR p, 1-step MSE) | loop added | final 1-step MSE | removed |"
    );
    println!("|---|---|---|---|---|---|---|");
    for rec in &recs {
        let path = if rec.file.starts_with('/') {
            PathBuf::from(rec.file)
        } else {
            root.join(rec.file)
        };
        let rows = read_csv(&path)?;
        let t: Vec<f64> = rows.iter().map(|r| r[rec.time_col]).collect();
        let rate = (t.len() - 1) as f64 / (t[t.len() - 1] - t[0]);
        let col = |c: usize, s: f64| -> Vec<f64> { rows.iter().map(|r| r[c] * s).collect() };
        let gyro = [
            col(rec.gyro[0], rec.gyro_scale),
            col(rec.gyro[1], rec.gyro_scale),
            col(rec.gyro[2], rec.gyro_scale),
        ];
        let acc = [
            col(rec.acc[0], rec.acc_scale),
            col(rec.acc[1], rec.acc_scale),
            col(rec.acc[2], rec.acc_scale),
        ];
        let (a, b) = match rec.stretch {
            Stretch::Whole => (0, t.len()),
            Stretch::Window(t0, t1) => {
                let a = t.iter().position(|v| v - t[0] >= t0).unwrap_or(0);
                let b = t.iter().position(|v| v - t[0] >= t1).unwrap_or(t.len());
                (a, b)
            }
            Stretch::AutoStill => still_stretch(&gyro, rate),
        };
        let n = b - a;
        let stretch = format!(
            "{:.1}-{:.1} s ({n} samples, {rate:.1} Hz)",
            t[a] - t[0],
            t[b - 1] - t[0]
        );
        let mut settings = DiagnoseSettings::default();
        // Short stretches: the largest AR order the proportional split can hold (each part needs
        // 8 p + 200 samples).
        let max_p = ((n * 3 / 10).saturating_sub(200) / 8).min(20);
        if max_p < 2 {
            println!(
                "| {} | all | {stretch} | too short for a split | - | - | - |",
                rec.name
            );
            continue;
        }
        settings.max_ar_order = max_p;
        let temp: Option<Vec<f64>> = rec.temp.map(|c| col(c, 1.0)[a..b].to_vec());
        let accs: Vec<Vec<f64>> = acc.iter().map(|v| v[a..b].to_vec()).collect();
        let chans: Vec<(String, Vec<f64>)> = ["gx", "gy", "gz", "ax", "ay", "az"]
            .iter()
            .enumerate()
            .map(|(i, nm)| {
                (
                    nm.to_string(),
                    if i < 3 {
                        gyro[i][a..b].to_vec()
                    } else {
                        accs[i - 3].clone()
                    },
                )
            })
            .collect();
        let mut report = DiagnoseReport {
            source: format!("{} [{stretch}], rad/s and m/s²", rec.name),
            channels: vec![],
            warnings: vec![],
        };
        for (i, (nm, v)) in chans.iter().enumerate() {
            let others: Vec<(String, &[f64])> = chans
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, (m, w))| (m.clone(), w.as_slice()))
                .collect();
            let exo = Exogenous {
                temperature_c: temp.as_deref(),
                specific_force_m_s2: (i < 3)
                    .then(|| [accs[0].as_slice(), accs[1].as_slice(), accs[2].as_slice()]),
                other_axes: &others,
            };
            let input = ChannelInput {
                name: nm,
                values: v,
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
                    println!(
                        "| {} | {nm} | {stretch} | AR({}) {:.3e} | {} | {:.3e} | {:.1} % |",
                        rec.name,
                        d.baseline.ar_order,
                        d.baseline.mse_one_step,
                        if added.is_empty() {
                            "nothing".into()
                        } else {
                            added.join("; ")
                        },
                        d.final_metrics.mse_one_step,
                        100.0 * (1.0 - d.final_metrics.mse_one_step / d.baseline.mse_one_step)
                    );
                    for (stem, svg) in channel_plots(&d)? {
                        std::fs::write(
                            out.join("plots").join(format!("{}_{stem}.svg", rec.name)),
                            svg,
                        )
                        .map_err(|e| e.to_string())?;
                    }
                    report.channels.push(d);
                }
                Err(e) => println!(
                    "| {} | {nm} | {stretch} | error: {e} | - | - | - |",
                    rec.name
                ),
            }
        }
        std::fs::write(out.join(format!("{}.txt", rec.name)), report.to_text())
            .map_err(|e| e.to_string())?;
        std::fs::write(
            out.join(format!("{}.json", rec.name)),
            report.to_json().map_err(|e| e.to_string())?,
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}
