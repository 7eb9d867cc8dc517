//! The gross-error stage's recorded verdicts in a time window of a recording, with the raw
//! samples around them (gyro °/s, accel m/s²) and what the stage made of them, for explaining a
//! replacement or a miss (`docs/gross_error_results.md`):
//!
//! ```sh
//! cargo run --release --example verdict_trace -- \
//!     ../shared/data/real/rtklibexplorer_drive_walk/drive_0708_imu.csv 72.60 72.70
//! ```
//!
//! Times are seconds after the recording's first sample; the stage runs alone with the embedded
//! default config, as `tests/audit_misses.rs` runs it.

use imuprep::config::Config;
use imuprep::report::audit::load_recording;
use imuprep::sample::{CHANNEL_NAMES, flags};
use imuprep::stage::gross_error::{GrossErrorStage, confirm};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        return Err("usage: verdict_trace RECORDING FROM_S TO_S".into());
    }
    let (from, to): (f64, f64) = (args[2].parse()?, args[3].parse()?);
    let (_, raw) = load_recording(std::path::Path::new(&args[1]))?;
    let cfg = Config::default_embedded()?;
    let ge = cfg
        .stages
        .gross_error
        .as_ref()
        .ok_or("gross-error stage off")?;
    let mut stage = GrossErrorStage::new(&ge.settings, ge.model.as_ref())?;
    stage.record_verdicts();
    let out = imuprep::stage::run_through(&mut stage, &raw);
    let t0 = raw.first().map_or(0, |s| s.t_ns);
    let t = |k: usize| (raw[k].t_ns - t0) as f64 * 1e-9;
    // Stage index → sample index: a stale repeat shares its original's stage index.
    let first: Vec<usize> = (0..out.len())
        .filter(|&k| out[k].flags & flags::REPEATED == 0)
        .collect();
    println!("sample t s | gx gy gz °/s | ax ay az m/s² | replaced channels");
    for k in (0..raw.len()).filter(|&k| (from..=to).contains(&t(k))) {
        let (g, a) = (raw[k].gyro.map(f64::to_degrees), raw[k].accel);
        let rep: Vec<&str> = (0..CHANNEL_NAMES.len())
            .filter(|&c| out[k].flags & flags::replaced_ch(c) != 0)
            .map(|c| CHANNEL_NAMES[c])
            .collect();
        println!(
            "{k} {:.3} | {:7.2} {:7.2} {:7.2} | {:6.2} {:6.2} {:6.2} | {}",
            t(k),
            g.x,
            g.y,
            g.z,
            a.x,
            a.y,
            a.z,
            rep.join(" ")
        );
    }
    for v in stage.take_verdicts() {
        let k = first[v.start as usize];
        if (from..=to).contains(&t(k)) {
            println!("{} at {:.3} s: {v:?}", CHANNEL_NAMES[v.channel], t(k));
            // The several-axes test's view of the other channels (raw, repeats skipped): each
            // one's centred second difference on the samples start − 1, start, start + 1 over
            // its RMS on the `context_samples` before, as `shock` computes it.
            let s = v.start as usize;
            let ctx = ge.settings.context_samples;
            if s < ctx + 2 || s + 2 >= first.len() {
                continue;
            }
            // The same-triad test measured in `docs/gross_error_results.md` (not in the stage):
            // each other axis of the event's triad over the judged samples — its departure from
            // the interpolation across them (median |x − p| / √(1 + v), as `z_median · σ̂`), over
            // the event's own, and over its roughness σ̂ on the `context_samples` before.
            if let Some(e) = v.evidence {
                let (a, len) = (s + v.lead, v.keep - v.lead);
                let post = ge.settings.post_samples;
                if a >= ctx && a + len + post <= first.len() {
                    let dev = e.z_median * e.sigma;
                    for o in (0..CHANNEL_NAMES.len())
                        .filter(|&o| o != v.channel && o / 3 == v.channel / 3)
                    {
                        let x = |i: usize| raw[first[i]].channel(o);
                        let pre: Vec<f64> = (a - ctx..a).map(x).collect();
                        let ev: Vec<f64> = (a..a + len).map(x).collect();
                        let after: Vec<f64> = (a + len..a + len + post).map(x).collect();
                        let mut interp = vec![0.0; len];
                        let floor = if o < 3 {
                            ge.settings.min_sigma_gyro_rad_s
                        } else {
                            ge.settings.min_sigma_accel_m_s2
                        };
                        let (Some(p), Some(r)) = (
                            confirm::confirm_with(
                                &pre,
                                &ev,
                                &after,
                                floor,
                                ge.settings.run_fit_side,
                                &mut interp,
                            ),
                            confirm::roughness(&pre),
                        ) else {
                            continue;
                        };
                        let moved = p.z_median * p.sigma;
                        println!(
                            "  same triad {}: departure {moved:.3e} = {:.2} × the event's {dev:.3e}, {:.2} × its σ̂ before",
                            CHANNEL_NAMES[o],
                            moved / dev,
                            moved / r.max(floor)
                        );
                    }
                }
            }
            for c in (0..CHANNEL_NAMES.len()).filter(|&c| c != v.channel) {
                let x = |i: usize| raw[first[i]].channel(c);
                let d = |i: usize| x(i) - 0.5 * (x(i - 1) + x(i + 1));
                let ms = (s - ctx..s - 1).map(|i| d(i) * d(i)).sum::<f64>() / (ctx - 1) as f64;
                let r = |i: usize| d(i) / ms.sqrt();
                println!(
                    "  {}: {:+.2} {:+.2} {:+.2}",
                    CHANNEL_NAMES[c],
                    r(s - 1),
                    r(s),
                    r(s + 1)
                );
            }
        }
    }
    Ok(())
}
