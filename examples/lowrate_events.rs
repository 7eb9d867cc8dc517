//! The gross-error stage's confirmed events on a lower-rate copy of a recording (non-overlapping
//! groups of K samples averaged, as `tests/sensor_classes.rs` makes its `rate/K` copies; K = 1:
//! the recording itself), each with its evidence, the level test's distances over the past
//! 0.5, 1 and 2 s, the several-axes view of the other channels and the raw samples around it
//! (gyro °/s, accel m/s²); for `docs/real-data.md`, "Sensor classes we do not have":
//!
//! ```sh
//! cargo run --release --example lowrate_events -- \
//!     ../shared/data/real/rtklibexplorer_drive_walk/drive_0708_imu.csv 4 [AROUND] [all|gross] [CONFIG]
//! ```
//!
//! AROUND: raw samples shown on each side (default 6); `all`: every event, `gross` (default): only the
//! confirmed ones; CONFIG: a TOML file laid over the embedded default config.
use imuprep::config::Config;
use imuprep::report::audit::load_recording;
use imuprep::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use imuprep::stage::gross_error::GrossErrorStage;

fn decimate(raw: &[Sample], k: usize) -> Vec<Sample> {
    raw.chunks_exact(k)
        .enumerate()
        .map(|(i, g)| {
            let mut s = g[0];
            s.seq = i as u32;
            s.t_ns = g.iter().map(|x| u128::from(x.t_ns)).sum::<u128>() as u64 / k as u64;
            let mut v = [0.0; N_CHANNELS];
            for x in g {
                for (c, vc) in v.iter_mut().enumerate() {
                    *vc += x.channel(c) / k as f64;
                }
            }
            s.set_channels(&v);
            let temps: Vec<f64> = g.iter().filter_map(|x| x.temp_c).collect();
            s.temp_c = (!temps.is_empty()).then(|| temps.iter().sum::<f64>() / temps.len() as f64);
            s.flags = g.iter().fold(0, |a, x| a | x.flags);
            s.absent = g.iter().fold(0, |a, x| a | x.absent);
            s
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: lowrate_events RECORDING K [AROUND] [all|gross] [CONFIG]".into());
    }
    let k: usize = args[2].parse()?;
    let around: usize = args.get(3).map_or(Ok(6), |a| a.parse())?;
    let all = args.get(4).is_some_and(|a| a == "all");
    let (_, raw0) = load_recording(std::path::Path::new(&args[1]))?;
    let raw = if k > 1 { decimate(&raw0, k) } else { raw0 };
    let mut cfg = Config::default_embedded()?;
    if let Some(extra) = args.get(5) {
        let text = format!(
            "[source]\nkind = \"replay\"\npath = \"replay/drive.log\"\n{}",
            std::fs::read_to_string(extra)?
        );
        cfg = Config::from_toml_str(&text, std::path::Path::new("."))?;
    }
    let ge = cfg.stages.gross_error.as_ref().ok_or("off")?;
    let mut stage = GrossErrorStage::new(&ge.settings, ge.model.as_ref())?;
    stage.record_verdicts();
    let out = imuprep::stage::run_through(&mut stage, &raw);
    let t0 = raw[0].t_ns;
    let t = |i: usize| (raw[i].t_ns - t0) as f64 * 1e-9;
    let first: Vec<usize> = (0..out.len())
        .filter(|&i| out[i].flags & flags::REPEATED == 0)
        .collect();
    let th = ge.settings.thresholds();
    let mut nrep = [0usize; 6];
    for s in &out {
        for (c, n) in nrep.iter_mut().enumerate() {
            if s.flags & flags::replaced_ch(c) != 0 {
                *n += 1;
            }
        }
    }
    println!(
        "n {} replaced {:?} per-ch-sample {:?}",
        out.len(),
        nrep,
        nrep.map(|r| r as f64 / out.len() as f64)
    );
    for v in stage.take_verdicts() {
        if !v.gross && !all {
            continue;
        }
        let s = first[v.start as usize];
        let e = v.evidence;
        println!(
            "\n{} {} at {:.3} s (idx {}): len {} judged {}..{} gross {} shock {} motion_break {}",
            CHANNEL_NAMES[v.channel],
            if v.gross { "GROSS" } else { "pass" },
            t(s),
            s,
            v.len,
            v.lead,
            v.keep,
            v.gross,
            v.shock,
            v.motion_break
        );
        if let Some(e) = e {
            let edge = e.z_in.min(e.z_out);
            println!(
                "  z_med {:.2} (conf {:.2}, standout bar {:.2}) z_in {:.2} z_out {:.2} (edge bar {:.2}) z_ctx {:.2} jag {:.2} sigma {:.3e} rej {:?}",
                e.z_median,
                th.confirm_k,
                th.stand_out * e.z_context,
                e.z_in,
                e.z_out,
                (0.5 * th.edge_stand_out * e.z_context).max(th.edge_k),
                e.z_context,
                e.jaggedness,
                e.sigma,
                e.rejection(v.keep - v.lead, &th)
            );
            let _ = edge;
        }
        let c = v.channel;
        {
            let st = v.start as usize;
            let rate =
                (raw.len() - 1) as f64 / ((raw[raw.len() - 1].t_ns - raw[0].t_ns) as f64 * 1e-9);
            let mut parts = Vec::new();
            for tw in [0.5f64, 1.0, 2.0] {
                let w = (tw * rate).round() as usize;
                if st + v.lead < w {
                    continue;
                }
                let a = first[st + v.lead];
                let hist: Vec<f64> = (a - w..a).map(|i| out[i].channel(c)).collect();
                let med = imuprep::stats::robust::median(&mut hist.clone());
                let sd = imuprep::stats::robust::robust_sigma(&hist);
                let mut dev: Vec<f64> = (v.lead..v.keep)
                    .map(|j| ((raw[first[st + j]].channel(c) - med) / sd).abs())
                    .collect();
                let dm = imuprep::stats::robust::median(&mut dev);
                parts.push(format!("{tw}s: {dm:.2}"));
            }
            println!("  level dist (robust σ of the past): {}", parts.join(" "));
        }
        {
            let ctx = ge.settings.context_samples;
            let st = v.start as usize;
            if st >= ctx + 2 && st + 2 < first.len() {
                let mut parts = Vec::new();
                for o in (0..6).filter(|&o| o != c) {
                    let x = |i: usize| raw[first[i]].channel(o);
                    let d = |i: usize| x(i) - 0.5 * (x(i - 1) + x(i + 1));
                    let ms =
                        (st - ctx..st - 1).map(|i| d(i) * d(i)).sum::<f64>() / (ctx - 1) as f64;
                    let r = |i: usize| d(i) / ms.sqrt();
                    parts.push(format!(
                        "{} {:+.1} {:+.1} {:+.1}",
                        CHANNEL_NAMES[o],
                        r(st - 1),
                        r(st),
                        r(st + 1)
                    ));
                }
                println!("  partners: {}", parts.join(" | "));
            }
        }
        let scale = if c < 3 {
            180.0 / std::f64::consts::PI
        } else {
            1.0
        };
        for i in s.saturating_sub(around)..(s + v.len + around).min(raw.len()) {
            let mark = if i >= s + v.lead && i < s + v.keep {
                "*"
            } else if i >= s && i < s + v.len {
                "+"
            } else {
                " "
            };
            let vals: Vec<String> = (0..6)
                .map(|cc| {
                    let sc = if cc < 3 {
                        180.0 / std::f64::consts::PI
                    } else {
                        1.0
                    };
                    format!("{:8.3}", raw[i].channel(cc) * sc)
                })
                .collect();
            println!(
                "  {mark} {i} {:.3} | {} | out {:8.3}",
                t(i),
                vals.join(" "),
                out[i].channel(c) * scale
            );
        }
    }
    Ok(())
}
