//! What the gross-error stage flags on a recording without labels (issue 4's real drives):
//! every flagged event classified by tests independent of the stage's forecast
//! (`analysis::flag_review`: impulse, level change, burst, excursion, other), with counts, rates and the
//! largest events of each class.
//!
//! Run: cargo run --release --example flag_review -- LOG [K]
//! (LOG from `imuprep import`; K = the gate, default 4.5; the stage's other settings are the
//! defaults, with its model identified at warm-up as the embedded config does.)

use imuprep::analysis::flag_review::{EventClass, review};
use imuprep::io::csv::read_log;
use imuprep::sample::{CHANNEL_NAMES, flags};
use imuprep::stage::Stage;
use imuprep::stage::gross_error::{GrossErrorSettings, GrossErrorStage};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let Some(log) = args.get(1) else {
        eprintln!("usage: flag_review LOG [K]");
        std::process::exit(2);
    };
    let k: f64 = args.get(2).map(|a| a.parse()).transpose()?.unwrap_or(4.5);
    let (desc, raw, _) = read_log(std::path::Path::new(log))?;
    let rate = desc.map(|d| d.sample_rate_hz).unwrap_or(100.0);
    let settings = GrossErrorSettings {
        k,
        ..Default::default()
    };
    let mut stage = GrossErrorStage::new(settings.clone(), None)?;
    let out: Vec<_> = raw.iter().map(|s| stage.process(*s)).collect();
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
    Ok(())
}
