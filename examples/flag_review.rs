//! What the gross-error stage flags on a recording without labels (issue 4's real drives):
//! every flagged event classified by tests independent of the stage's forecast
//! (`report::flag_review`: impulse, level change, burst, excursion, other), with counts, rates and the
//! largest events of each class.
//!
//! Run: cargo run --release --example flag_review -- LOG [K [KEY=VALUE ...]] [--list]
//! (LOG from `imuprep import`; K = the gate, default 4.5; the stage's other settings are the
//! defaults, with its model identified at warm-up as the embedded config does.)

use imuprep::io::csv::read_log;
use imuprep::report::flag_review::{EventClass, review};
use imuprep::sample::{CHANNEL_NAMES, flags};
use imuprep::stage::gross_error::{GrossErrorSettings, GrossErrorStage};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `--list` (anywhere) prints every event, not only the largest of each class.
    let all: Vec<String> = std::env::args().collect();
    let list_all = all.iter().any(|a| a == "--list");
    let args: Vec<&String> = all.iter().filter(|a| *a != "--list").collect();
    let Some(log) = args.get(1) else {
        eprintln!("usage: flag_review LOG [K [KEY=VALUE ...]] [--list]");
        std::process::exit(2);
    };
    let k: f64 = args.get(2).map(|a| a.parse()).transpose()?.unwrap_or(4.5);
    // Further arguments: KEY=VALUE overrides of the stage's settings (as in the config's
    // [gross_error.settings] table), e.g. tail_gain=1.0.
    let mut table = toml::Table::new();
    table.insert("k".into(), toml::Value::Float(k));
    for kv in args.iter().skip(3) {
        let (key, val) = kv.split_once('=').ok_or("override must be KEY=VALUE")?;
        let v: toml::Value = toml::from_str::<toml::Table>(&format!("v = {val}"))?["v"].clone();
        table.insert(key.into(), v);
    }
    let (desc, raw, _) = read_log(std::path::Path::new(log))?;
    let rate = desc.map(|d| d.sample_rate_hz).unwrap_or(100.0);
    let settings: GrossErrorSettings = table.try_into()?;
    let mut stage = GrossErrorStage::new(settings.clone(), None)?;
    // With `lookahead_samples=L`, the stage's look-ahead revises events that prove to be motion.
    let out = imuprep::stage::run_through(&mut stage, &raw);
    let scored = raw.len().saturating_sub(settings.warmup_samples) * CHANNEL_NAMES.len();
    let events = review(&raw, &out);
    let replaced: usize = events.iter().map(|e| e.len).sum();
    println!(
        "{log}: {} samples at {rate:.2} Hz, k = {k}: {} events, {replaced} channel-samples replaced ({:.2e} of {scored} after warm-up)",
        raw.len(),
        events.len(),
        replaced as f64 / scored.max(1) as f64
    );
    let samples_with_flag = out.iter().filter(|s| s.has(flags::REPLACED)).count();
    println!("samples with any channel replaced: {samples_with_flag}");
    let (ev, n): (u64, u64) = (0..CHANNEL_NAMES.len())
        .map(|c| stage.channel_counters(c))
        .fold((0, 0), |a, k| (a.0 + k.suspect_events, a.1 + k.suspect));
    println!("{ev} events ({n} channel-samples) not confirmed: passed, flagged suspect");
    println!(
        "{:<13} {:>7} {:>9} {:>10}  largest (channel, t s, length, size in local σ)",
        "class", "events", "samples", "rate"
    );
    for class in [
        EventClass::Impulse,
        EventClass::LevelChange,
        EventClass::Burst,
        EventClass::Excursion,
        EventClass::Other,
    ] {
        let mut ev: Vec<_> = events.iter().filter(|e| e.class == class).collect();
        let n: usize = ev.iter().map(|e| e.len).sum();
        ev.sort_by(|a, b| b.size_sigma.total_cmp(&a.size_sigma));
        let top: Vec<String> = ev
            .iter()
            .take(3)
            .map(|e| {
                format!(
                    "({}, {:.2}, {}, {:.1})",
                    CHANNEL_NAMES[e.channel],
                    e.start as f64 / rate,
                    e.len,
                    e.size_sigma
                )
            })
            .collect();
        println!(
            "{:<13} {:>7} {:>9} {:>10.2e}  {}",
            format!("{class:?}"),
            ev.len(),
            n,
            n as f64 / scored.max(1) as f64,
            top.join(" ")
        );
    }
    // Coherence: events whose start lies within ±1 sample of events on at least two other
    // channels — a shock seen by several axes at once (a sensor glitch hits one channel).
    let coherent: Vec<_> = events
        .iter()
        .filter(|e| {
            let mut other = [false; CHANNEL_NAMES.len()];
            for f in &events {
                if f.channel != e.channel && f.start.abs_diff(e.start) <= 1 {
                    other[f.channel] = true;
                }
            }
            other.iter().filter(|&&o| o).count() >= 2
        })
        .collect();
    println!(
        "events starting within 1 sample of events on >= 2 other channels: {} ({} channel-samples)",
        coherent.len(),
        coherent.iter().map(|e| e.len).sum::<usize>()
    );
    // Where in the recording the replaced channel-samples fall (a warm-up model meeting the first
    // motion shows as a cluster at the start), in at most 20 bins of whole minutes.
    let minutes = ((raw.len() as f64 / rate / 60.0).ceil() as usize).max(1);
    let bin_min = minutes.div_ceil(20);
    let n_bins = minutes.div_ceil(bin_min);
    let mut per_bin = vec![0usize; n_bins];
    for e in &events {
        let b = (e.start as f64 / rate / 60.0) as usize / bin_min;
        per_bin[b.min(n_bins - 1)] += e.len;
    }
    println!("replaced channel-samples per {bin_min} min: {per_bin:?}");
    if list_all {
        println!("every event: channel, start s, replaced samples, class, size in local σ");
        for e in &events {
            println!(
                "  {:<2} {:>9.2} {:>3} {:<12} {:>5.1}",
                CHANNEL_NAMES[e.channel],
                e.start as f64 / rate,
                e.len,
                format!("{:?}", e.class),
                e.size_sigma
            );
        }
    }
    Ok(())
}
