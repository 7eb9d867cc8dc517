//! Why the audit's 2 % static gyro outliers were caught less often on the MPU6050 bench
//! (recall 0.849) than on the ADIS16405 (0.924) while the shape tests judged them alone: the
//! audit sizes them in the channel's robust σ (spread of the values), the shape tests in σ̂
//! (white-noise-equivalent roughness from second differences, `confirm::roughness`). On white
//! noise the two agree; on noise correlated from sample to sample (ADIS16405, lag-1
//! autocorrelation 0.16–0.20) σ̂ is smaller, so the same "8–30 robust σ" outliers are larger in
//! those units. At rest the stage now also judges an event against the channel's resting level
//! in its spread (`rest_k`, `rest::at_rest`), the audit's own units: the MPU6050 0.935, the
//! ADIS16405 0.928. `docs/gross_error_results.md` quotes the printout:
//!
//! ```sh
//! cargo test --release --test static_outlier_recall -- --nocapture
//! ```
//!
//! `at_rest_white_noise_costs_no_recall` needs no data: the same injection on synthetic benches
//! of equal marginal σ, white and AR(1). The second test measures the real benches (skipped
//! visibly when `../shared/data/real` is absent).

mod common;

use imuprep::config::Config;
use imuprep::frame::Descriptor;
use imuprep::report::audit::{Seeds, audit_recording, inject_outliers, load_recording, run_config};
use imuprep::rng::{Rng, ar_series};
use imuprep::sample::{Sample, flags};
use imuprep::stage::gross_error::GrossErrorStage;
use imuprep::stage::gross_error::confirm::roughness;
use imuprep::stats::robust::robust_sigma;
use std::collections::BTreeMap;

/// The audit's seed and scoring start (`imuprep audit` defaults).
const SEED: u64 = 12;
const SCORE_FROM: usize = 2000;

/// Recall of the default pipeline on the gyro outliers `inject_outliers` puts into `raw`.
fn recall(raw: &[Sample], rate_hz: f64) -> f64 {
    let cfg = Config::default_embedded().unwrap();
    let desc = Descriptor {
        sample_rate_hz: rate_hz,
        ..Default::default()
    };
    let mut x = raw.to_vec();
    let labels = inject_outliers(&mut x, SEED);
    let out = run_config(&cfg, &desc, &x).unwrap();
    let (mut tp, mut all) = (0usize, 0usize);
    for (s, l) in out.iter().zip(&labels).skip(SCORE_FROM) {
        for (c, _) in l[..3].iter().enumerate().filter(|(_, l)| **l) {
            all += 1;
            tp += usize::from(s.flags & flags::replaced_ch(c) != 0);
        }
    }
    tp as f64 / all as f64
}

/// A static bench at 100 Hz: every channel AR(1) with coefficient `phi` and the marginal sd of
/// the MPU6050's channels (gyro 0.12/0.09/0.12 °/s, accel 3–5 mg), gravity on z.
fn bench(phi: f64, seed: u64) -> Vec<Sample> {
    let n = 65_000;
    let sd = [2.1e-3, 1.6e-3, 2.1e-3, 0.032, 0.031, 0.049];
    let mut rng = Rng::new(seed);
    let ch: Vec<Vec<f64>> = sd
        .iter()
        .map(|s| ar_series(&mut rng, n, &[phi], s * (1.0 - phi * phi).sqrt()))
        .collect();
    (0..n)
        .map(|k| {
            let mut s = Sample::nth(k, 10_000_000);
            for (c, x) in ch.iter().enumerate() {
                s.set_channel(c, x[k] + if c == 5 { 9.81 } else { 0.0 });
            }
            s
        })
        .collect()
}

#[test]
fn at_rest_white_noise_costs_no_recall() {
    let white = recall(&bench(0.0, 1), 100.0);
    let ar = recall(&bench(0.18, 1), 100.0);
    eprintln!(
        "synthetic bench, 2 % outliers of 8-30 robust σ: white recall {white:.4}, AR(1) 0.18 recall {ar:.4}"
    );
    // Measured 2026-12-02: white 0.9445, AR(1) 0.9416; before the rest test (this test, stop 24,
    // docs/gross_error_results.md) 0.8699 and 0.9124, a gap of 0.04, ten times the seed-to-seed
    // spread (≤ 0.01). At
    // rest the spike is judged in the spread about the level, which whiteness does not change:
    // both meet the issue's 0.9, and the gap is within that spread.
    assert!(white >= 0.9 && ar >= 0.9, "white {white}, AR {ar}");
    assert!((white - ar).abs() < 0.015, "white {white}, AR {ar}");
}

/// Lag-1 autocorrelation of `x` about its 201-sample running mean.
fn lag1(x: &[f64]) -> f64 {
    let h = 100;
    let y: Vec<f64> = (h..x.len() - h)
        .map(|i| x[i] - x[i - h..=i + h].iter().sum::<f64>() / (2 * h + 1) as f64)
        .collect();
    let m = y.iter().sum::<f64>() / y.len() as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for w in y.windows(2) {
        num += (w[0] - m) * (w[1] - m);
    }
    for v in &y {
        den += (v - m) * (v - m);
    }
    num / den
}

#[test]
#[allow(clippy::needless_range_loop)] // c indexes the label rows' channel and the samples alike
fn the_static_benches_outliers_are_missed_near_the_bar_of_their_own_roughness() {
    let Some(dir) = common::real_data("") else {
        return;
    };
    let cfg = Config::default_embedded().unwrap();
    let ge = cfg.stages.gross_error.as_ref().expect("enabled by default");
    let th = ge.settings.thresholds();
    let mut scale = Vec::new();
    for rec in [
        "mpu6050_static_10min_temp/mpu6050_static.csv",
        "adis16405_static/adis_16405_imu1.csv.gz",
    ] {
        let (desc, raw) = load_recording(&dir.join(rec)).unwrap();
        let mut x = raw.clone();
        let labels = inject_outliers(&mut x, SEED);
        let mut stage = GrossErrorStage::new(&ge.settings, ge.model.as_ref()).unwrap();
        stage.record_verdicts();
        let out = imuprep::stage::run_through(&mut stage, &x);
        let verdicts = stage.take_verdicts();
        let n = raw.len();
        let mut why: BTreeMap<String, usize> = BTreeMap::new();
        // Per 2-robust-σ band of outlier size: (caught, missed).
        let mut band: BTreeMap<u32, (usize, usize)> = BTreeMap::new();
        // Missed outliers of 10-14 robust σ: the verdict's σ̂ over robust σ, and how many had
        // another outlier among the 32 samples before or the 4 after.
        let (mut inflation, mut crowded) = (Vec::new(), 0usize);
        for c in 0..3 {
            let xr: Vec<f64> = raw.iter().map(|s| s.channel(c)).collect();
            let rs = robust_sigma(&xr);
            let rough = roughness(&xr[..xr.len().min(100)]).unwrap();
            let mut levels: Vec<f64> = xr.clone();
            levels.sort_by(f64::total_cmp);
            levels.dedup();
            let lsb = levels
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min);
            // The scale ratio over the whole bench: robust σ over the roughness of 100-sample
            // stretches (median), as the confirmation measures it around each event.
            let mut r: Vec<f64> = xr
                .chunks(100)
                .filter_map(|w| roughness(w).filter(|v| *v > 0.0))
                .map(|v| rs / v)
                .collect();
            r.sort_by(f64::total_cmp);
            let ratio = r[r.len() / 2];
            scale.push(ratio);
            eprintln!(
                "{rec} g{}: robust σ {:.3e}, robust σ / σ̂ {ratio:.3}, lag-1 autocorrelation \
                 {:+.3}, σ̂ / LSB {:.1} (first 100 samples)",
                ["x", "y", "z"][c],
                rs,
                lag1(&xr),
                rough / lsb
            );
            for k in SCORE_FROM..n {
                if !labels[k][c] {
                    continue;
                }
                let hit = out[k].flags & flags::replaced_ch(c) != 0;
                let a = (x[k].channel(c) - xr[k]).abs() / rs;
                let e = band.entry((a / 2.0).floor() as u32 * 2).or_default();
                if hit {
                    e.0 += 1;
                    continue;
                }
                e.1 += 1;
                let v = verdicts.iter().find(|v| {
                    v.channel == c && (v.start..v.start + v.len as u64).contains(&(k as u64))
                });
                if let Some(e) = v
                    .and_then(|v| v.evidence)
                    .filter(|_| (10.0..14.0).contains(&a))
                {
                    inflation.push(e.sigma / rs);
                    crowded +=
                        usize::from((k - 32..(k + 5).min(n)).any(|j| j != k && labels[j][c]));
                }
                let r = match v {
                    None => "no event (the gate let it pass)".to_string(),
                    Some(v) if v.shock => "shock on other axes".into(),
                    Some(v) => match v.evidence {
                        None => "not judged".into(),
                        Some(e) => format!("{:?}", e.rejection(v.keep - v.lead, &th)),
                    },
                };
                *why.entry(r).or_default() += 1;
            }
        }
        let (tp, fn_) = band.values().fold((0, 0), |(a, b), (h, m)| (a + h, b + m));
        let r = tp as f64 / (tp + fn_) as f64;
        eprintln!("{rec}: recall {r:.4} ({tp} caught, {fn_} missed)");
        for (b, (h, m)) in &band {
            eprintln!(
                "  {b:2}-{:2} robust σ: missed {m:4} of {:4} ({:.0} %)",
                b + 2,
                h + m,
                100.0 * *m as f64 / (h + m) as f64
            );
        }
        inflation.sort_by(f64::total_cmp);
        eprintln!(
            "  missed 10-14 robust σ with a verdict: {}, σ̂ / robust σ median {:.2}, {crowded} \
             with another outlier within 32 before or 4 after",
            inflation.len(),
            inflation[inflation.len() / 2]
        );
        for (w, k) in &why {
            eprintln!("  {k:5}  {w}");
        }
        // The stage alone (stale repeats share an index here: neither bench has any) scores
        // what the audit's full pipeline scores.
        let audit =
            audit_recording(rec, &dir.join(rec), &desc, &raw, Seeds::one(SEED), &cfg).unwrap();
        let ar = audit.contamination_recall.unwrap();
        assert!((ar - r).abs() < 1e-9, "stage alone {r} vs audit {ar}");
    }
    // The cause: the MPU6050's outliers are smaller in the stage's units (ratio < 1, white
    // noise) than the ADIS16405's (> 1.1, correlated noise), on every axis.
    assert!(scale[..3].iter().all(|&v| v < 1.0), "{scale:?}");
    assert!(scale[3..].iter().all(|&v| v > 1.1), "{scale:?}");
}
