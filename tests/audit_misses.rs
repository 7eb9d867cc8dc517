//! What the audit's injected spikes and runs lose on the real moving recordings, and why local σ
//! is not the reason: per recording, the labelled samples missed in single spikes and in runs,
//! and the ratio of the injection's scale (local σ: robust spread of the raw channel within ±100
//! samples, the audit's definition) to the confirmation's own scale σ̂ (roughness of the 32 raw
//! samples before the event and 4 after, `confirm::roughness`) over the missed events.
//! `docs/real-data.md` quotes the printout:
//!
//! ```sh
//! cargo test --release --test audit_misses -- --nocapture
//! ```
//!
//! The assertion: the breakdown's own count of hits, misses and false replacements gives the
//! audit's F1 for the same recording and seed (so the breakdown describes what the audit scores).
//! Skipped (visibly, on stderr) when `../shared/data/real` is absent.
//!
//! A second test, `missed_injections_are_explained_by_the_verdict_that_let_them_pass`, runs the
//! gross-error stage alone with its verdicts recorded (`GrossErrorStage::record_verdicts`) and
//! files every missed labelled sample under the verdict of the event that held it: no event
//! (the gate let it pass), handed back by the trim of a confirmed event, or the first test that
//! rejected its event (`confirm::Rejection`, shock, motion, not judged), marked "after a trim"
//! when the event's judged part was shorter than the event.

mod common;

use imuprep::config::Config;
use imuprep::report::audit::{Seeds, audit_recording, inject_spikes, load_recording, run_config};
use imuprep::sample::{N_CHANNELS, flags};
use imuprep::stage::gross_error::confirm::{Thresholds, roughness};
use imuprep::stage::gross_error::{EventVerdict, GrossErrorStage};
use imuprep::stats::robust::robust_sigma;
use std::collections::BTreeMap;

const RECORDINGS: &[&str] = &[
    "rtklibexplorer_drive_walk/drive_0708_imu.csv",
    "rtklibexplorer_drive_walk/walk_0827_imu.csv",
    "comma2k19_car_segment/imu.csv",
];
/// The audit's seed and scoring start (`imuprep audit` defaults).
const SEED: u64 = 12;
const SCORE_FROM: usize = 2000;

#[test]
#[allow(clippy::needless_range_loop)] // c indexes the label rows' channel and the samples alike
fn missed_injections_are_broken_down_and_agree_with_the_audit() {
    let Some(dir) = common::real_data("") else {
        return;
    };
    let cfg = Config::default_embedded().unwrap();
    let mut ratios = Vec::new();
    let mut spike_sizes = Vec::new();
    let (mut spike_missed, mut run_missed, mut runs) = (0usize, 0usize, 0usize);
    for rec in RECORDINGS {
        let path = dir.join(rec);
        let (desc, raw) = load_recording(&path).unwrap();
        let mut x = raw.clone();
        let labels = inject_spikes(&mut x, SEED);
        let out = run_config(&cfg, &desc, &x).unwrap();
        let n = raw.len();
        let (mut tp, mut fn_, mut fp) = (0usize, 0usize, 0usize);
        for c in 0..N_CHANNELS {
            let replaced = |k: usize| out[k].flags & flags::replaced_ch(c) != 0;
            fp += (SCORE_FROM..n)
                .filter(|&k| replaced(k) && !labels[k][c])
                .count();
            let mut i = SCORE_FROM;
            while i < n {
                if !labels[i][c] {
                    i += 1;
                    continue;
                }
                let j = (i..n).find(|&k| !labels[k][c]).unwrap_or(n);
                let hit = (i..j).filter(|&k| replaced(k)).count();
                tp += hit;
                fn_ += j - i - hit;
                if hit < j - i {
                    let near: Vec<f64> = raw[i.saturating_sub(100)..(i + 101).min(n)]
                        .iter()
                        .map(|s| s.channel(c))
                        .collect();
                    let ctx: Vec<f64> = raw[i.saturating_sub(32)..(j + 4).min(n)]
                        .iter()
                        .map(|s| s.channel(c))
                        .collect();
                    if let Some(r) = roughness(&ctx).filter(|r| *r > 0.0) {
                        ratios.push(robust_sigma(&near) / r);
                    }
                    if j - i == 1 {
                        spike_missed += 1;
                        let local = robust_sigma(&near);
                        spike_sizes.push((x[i].channel(c) - raw[i].channel(c)).abs() / local);
                    } else {
                        run_missed += j - i - hit;
                        runs += 1;
                    }
                }
                i = j;
            }
        }
        let p = tp as f64 / (tp + fp).max(1) as f64;
        let r = tp as f64 / (tp + fn_).max(1) as f64;
        let f1 = 2.0 * p * r / (p + r);
        let audit = audit_recording(rec, &path, &desc, &raw, Seeds::one(SEED), &cfg).unwrap();
        eprintln!("{rec}: {tp} labelled samples replaced, {fn_} missed, {fp} false; F1 {f1:.4}");
        // The same samples, stage and score: equal up to rounding.
        assert!(
            (audit.injected_f1.unwrap() - f1).abs() < 1e-9,
            "{f1} vs {audit:?}"
        );
    }
    ratios.sort_by(f64::total_cmp);
    spike_sizes.sort_by(f64::total_cmp);
    let q = |p: f64| ratios[((ratios.len() - 1) as f64 * p).round() as usize];
    let qs = |p: f64| spike_sizes[((spike_sizes.len() - 1) as f64 * p).round() as usize];
    eprintln!(
        "missed: {spike_missed} single spikes; {run_missed} samples in {runs} runs of 2-10 \
         samples; local σ / σ̂ over the {} missed events: median {:.2}, 10-90 % {:.2}-{:.2}",
        ratios.len(),
        q(0.5),
        q(0.1),
        q(0.9)
    );
    eprintln!(
        "missed single spikes, size in local σ: min {:.1}, median {:.1}, max {:.1}",
        qs(0.0),
        qs(0.5),
        qs(1.0)
    );
}

/// Why one missed labelled sample (stage index `k`, channel `c`) was not replaced, from the
/// recorded verdicts of channel `c` (sorted by start).
fn why_missed(verdicts: &[&EventVerdict], k: u64, k_th: &Thresholds) -> String {
    let Some(v) = verdicts
        .iter()
        .find(|v| (v.start..v.start + v.len as u64).contains(&k))
    else {
        return "no event (the gate let it pass)".into();
    };
    let j = (k - v.start) as usize;
    let trimmed = v.lead > 0 || v.keep < v.len;
    if v.gross {
        return if (v.lead..v.keep).contains(&j) {
            "replaced, then overwritten (cannot happen)".into()
        } else if v.rest {
            "outside the break of an event confirmed at rest (within 4.5 spreads of the level)"
                .into()
        } else {
            "handed back by the trim of a confirmed event".into()
        };
    }
    let why = if v.shock {
        "shock on other axes".to_string()
    } else if v.motion_break {
        "break inside a gate-called motion".to_string()
    } else {
        match v.evidence {
            None => "not judged".to_string(),
            Some(e) => match e.rejection(v.keep - v.lead, k_th) {
                Some(r) => format!("{r:?}"),
                None => "confirmed but not replaced (cannot happen)".to_string(),
            },
        }
    };
    if trimmed {
        format!("{why} (after a trim)")
    } else {
        why
    }
}

#[test]
#[allow(clippy::needless_range_loop)] // c indexes the label rows' channel and the samples alike
fn missed_injections_are_explained_by_the_verdict_that_let_them_pass() {
    let Some(dir) = common::real_data("") else {
        return;
    };
    let cfg = Config::default_embedded().unwrap();
    let ge = cfg.stages.gross_error.as_ref().expect("enabled by default");
    let th = ge.settings.thresholds();
    let mut total: BTreeMap<String, usize> = BTreeMap::new();
    for rec in RECORDINGS
        .iter()
        .chain(&["ximu3_fusion_example/sensor_data.csv"])
    {
        let (desc, raw) = load_recording(&dir.join(rec)).unwrap();
        let mut x = raw.clone();
        let labels = inject_spikes(&mut x, SEED);
        let piped = run_config(&cfg, &desc, &x).unwrap();
        let mut stage = GrossErrorStage::new(&ge.settings, ge.model.as_ref()).unwrap();
        stage.record_verdicts();
        let out = imuprep::stage::run_through(&mut stage, &x);
        let verdicts = stage.take_verdicts();
        // The stage alone replaces exactly what the pipeline's output says was replaced, so the
        // verdicts explain the audit's score.
        assert_eq!(out.len(), piped.len());
        for (a, b) in out.iter().zip(&piped) {
            assert_eq!(a.flags & flags::REPLACED_ANY, b.flags & flags::REPLACED_ANY);
        }
        // Stage index of each sample: a stale repeat shares its original's.
        let mut idx = Vec::with_capacity(out.len());
        let mut next = 0u64;
        for s in &out {
            if s.flags & flags::REPEATED != 0 {
                idx.push(next.saturating_sub(1));
            } else {
                idx.push(next);
                next += 1;
            }
        }
        let mut mine: BTreeMap<String, usize> = BTreeMap::new();
        let mut missed = 0;
        for c in 0..N_CHANNELS {
            let of_c: Vec<&EventVerdict> = verdicts.iter().filter(|v| v.channel == c).collect();
            for k in SCORE_FROM..out.len() {
                if labels[k][c] && out[k].flags & flags::replaced_ch(c) == 0 {
                    missed += 1;
                    *mine.entry(why_missed(&of_c, idx[k], &th)).or_default() += 1;
                }
            }
        }
        // Every missed sample is filed once, and none under a case that cannot happen.
        assert_eq!(mine.values().sum::<usize>(), missed);
        assert!(
            mine.keys().all(|k| !k.contains("cannot happen")),
            "{mine:?}"
        );
        eprintln!("{rec}: {missed} labelled samples missed");
        for (why, n) in &mine {
            eprintln!("  {n:4}  {why}");
            *total.entry(why.clone()).or_default() += n;
        }
    }
    let mut rows: Vec<_> = total.into_iter().collect();
    rows.sort_by_key(|r| std::cmp::Reverse(r.1));
    eprintln!("all four:");
    for (why, n) in rows {
        eprintln!("  {n:4}  {why}");
    }
}
