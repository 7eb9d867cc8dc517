//! `imuprep compare --detectors`: the online gross-error stage against the paper's classical
//! detectors, on a simulated log whose truth is known.
//!
//! The scenario is simulated in-process, encoded to frames and decoded by the live decoder (so
//! every detector sees exactly the f32 values, gaps and duplicates a replay would). Duplicated
//! frames are dropped from the evaluation (they repeat an instant already scored). Per channel:
//! the gross-error mask of the truth sidecar is the label; the spike-free reference is the
//! measured value minus its gross-error component; "truth" is the true motion (including road
//! vibration) the sensor experienced.

use crate::analysis::detectors::{self, Detection, DetectorScore, score};
use crate::frame::{FrameDecoder, Message, encode_sample};
use crate::model::arima::ArimaModelFile;
use crate::sample::{CHANNEL_NAMES, N_CHANNELS, Sample, flags};
use crate::sim::truth::{Effect, TruthRow};
use crate::sim::{Emission, Scenario, SimError, Simulator};
use crate::stage::gross_error::{GrossErrorSettings, GrossErrorStage};
use bytes::BytesMut;
use serde::Serialize;
use tokio_util::codec::Decoder;

/// One detector's score, summed over channels (and per channel).
#[derive(Debug, Clone, Serialize)]
pub struct DetectorRow {
    pub detector: String,
    /// Channels pooled (TP/FP/FN summed).
    pub pooled: Pooled,
    pub per_channel: Vec<(String, DetectorScore)>,
}

/// Scores pooled over channels.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Pooled {
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
    pub false_alarm_rate: f64,
    pub false_positives: u64,
    pub clean_samples: u64,
    /// Mean over channels of RMSE(corrected − truth) / RMSE(spike-free − truth): 1.0 means the
    /// corrected series is as close to the truth as a series that never had spikes.
    pub rmse_ratio_vs_spike_free: f64,
}

/// The comparison report.
#[derive(Debug, Clone, Serialize)]
pub struct DetectorReport {
    pub scenario: String,
    pub seed: u64,
    pub samples: usize,
    /// First scored sample (the online stage's warm-up is excluded for every detector).
    pub scored_from: usize,
    /// Gross-error channel samples in the scored part.
    pub gross_samples: u64,
    pub rows: Vec<DetectorRow>,
}

/// Decoded samples (duplicates removed) with their truth rows.
pub fn simulate_decoded(
    scn: &Scenario,
    seed: u64,
) -> Result<(Vec<Sample>, Vec<TruthRow>), SimError> {
    let mut sim = Simulator::new(scn, seed)?;
    let mut bytes = BytesMut::new();
    let mut truth = Vec::with_capacity(sim.len());
    while let Some(r) = sim.next_record() {
        let n = match r.emission {
            Emission::Normal => 1,
            Emission::Dropped => 0,
            Emission::Duplicated => 2,
        };
        for _ in 0..n {
            encode_sample(&r.sample, &mut bytes);
        }
        truth.push(r.truth);
    }
    let mut dec = FrameDecoder::with_descriptor(crate::sim::log::descriptor(&sim));
    let mut out = Vec::with_capacity(truth.len());
    let mut rows = Vec::with_capacity(truth.len());
    while let Ok(Some(m)) = dec.decode_eof(&mut bytes) {
        if let Message::Sample(s) = m {
            if s.has(flags::DUPLICATE) {
                continue;
            }
            // Simulated seq = instant index (wrapping only after 2^32 samples).
            rows.push(truth[s.seq as usize]);
            out.push(s);
        }
    }
    Ok((out, rows))
}

fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().max(1) as f64;
    (a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>() / n).sqrt()
}

/// Run every detector on every channel (the online stage with `model`, or identifying its own at
/// warm-up) and score each on samples `from..` (every detector sees the whole series).
pub fn compare_detectors(
    samples: &[Sample],
    truth: &[TruthRow],
    settings: &GrossErrorSettings,
    model: Option<&ArimaModelFile>,
    from: usize,
) -> Result<Vec<DetectorRow>, String> {
    let n = samples.len();
    if from >= n {
        return Err(format!(
            "nothing to score: {n} samples, scoring from {from}"
        ));
    }
    let mut stage = GrossErrorStage::new(settings.clone(), model).map_err(|e| e.to_string())?;
    let online: Vec<Sample> = crate::stage::run_through(&mut stage, samples);
    type Offline = fn(&[f64]) -> Result<Detection, crate::stats::NumError>;
    let offline: [(&str, Offline); 5] = [
        ("global 3-sigma", detectors::three_sigma),
        ("Grubbs (alpha 0.05)", |x| detectors::grubbs(x, 0.05)),
        ("Chauvenet", detectors::chauvenet),
        ("Dixon Q (windows of 10)", |x| detectors::dixon_q(x, 10)),
        ("Hampel (half-width 10, k 3)", |x| {
            detectors::hampel(x, 10, 3.0)
        }),
    ];
    let mut rows = Vec::new();
    for d in 0..=offline.len() {
        let name = if d == 0 {
            match settings.lookahead_samples {
                0 => format!("online ARIMA gate (k {})", settings.k),
                l => format!("online ARIMA gate (k {}, look-ahead {l})", settings.k),
            }
        } else {
            offline[d - 1].0.to_string()
        };
        let mut per = Vec::new();
        let mut ratio_sum = 0.0;
        for (c, ch_name) in CHANNEL_NAMES.iter().enumerate() {
            let x: Vec<f64> = samples.iter().map(|s| s.channel(c)).collect();
            let mask_true: Vec<bool> = truth.iter().map(|t| t.gross_mask[c]).collect();
            let clean: Vec<f64> = x
                .iter()
                .zip(truth)
                .map(|(v, t)| v - t.component(Effect::Gross, c))
                .collect();
            let true_sig: Vec<f64> = truth
                .iter()
                .map(|t| t.true_signal[c] + t.component(Effect::RoadVibration, c))
                .collect();
            let (mask, corrected) = if d == 0 {
                (
                    online
                        .iter()
                        .map(|s| s.flags & flags::replaced_ch(c) != 0)
                        .collect::<Vec<_>>(),
                    online.iter().map(|s| s.channel(c)).collect::<Vec<_>>(),
                )
            } else {
                let det = offline[d - 1].1(&x).map_err(|e| e.to_string())?;
                (det.mask, det.corrected)
            };
            let sc = score(
                &mask[from..],
                &mask_true[from..],
                &corrected[from..],
                &clean[from..],
            )
            .map_err(|e| e.to_string())?;
            let base = rmse(&clean[from..], &true_sig[from..]);
            ratio_sum += if base > 0.0 {
                rmse(&corrected[from..], &true_sig[from..]) / base
            } else {
                1.0
            };
            per.push((ch_name.to_string(), sc));
        }
        let (tp, fp, fne, clean_n) = per.iter().fold((0, 0, 0, 0), |a, (_, s)| {
            (
                a.0 + s.true_positives,
                a.1 + s.false_positives,
                a.2 + s.false_negatives,
                a.3 + s.clean_samples,
            )
        });
        let precision = if tp + fp > 0 {
            tp as f64 / (tp + fp) as f64
        } else {
            0.0
        };
        let recall = if tp + fne > 0 {
            tp as f64 / (tp + fne) as f64
        } else {
            0.0
        };
        let f1 = if precision + recall > 0.0 {
            2.0 * precision * recall / (precision + recall)
        } else {
            0.0
        };
        rows.push(DetectorRow {
            detector: name,
            pooled: Pooled {
                precision,
                recall,
                f1,
                false_alarm_rate: fp as f64 / clean_n.max(1) as f64,
                false_positives: fp,
                clean_samples: clean_n,
                rmse_ratio_vs_spike_free: ratio_sum / N_CHANNELS as f64,
            },
            per_channel: per,
        });
    }
    Ok(rows)
}

impl DetectorReport {
    pub fn text(&self) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let _ = writeln!(
            o,
            "gross-error detectors on scenario {} (seed {}): {} samples × 6 channels{}, {} gross-error channel samples",
            self.scenario,
            self.seed,
            self.samples,
            if self.scored_from > 0 {
                format!(
                    ", scored from sample {} (the online stage's warm-up excluded)",
                    self.scored_from
                )
            } else {
                String::new()
            },
            self.gross_samples
        );
        let w = self
            .rows
            .iter()
            .map(|r| r.detector.chars().count())
            .max()
            .unwrap_or(0)
            .max(30);
        let _ = writeln!(
            o,
            "{:<w$} {:>9} {:>9} {:>7} {:>12} {:>8} {:>10}",
            "detector", "precision", "recall", "F1", "false alarms", "(count)", "RMSE ratio"
        );
        for r in &self.rows {
            let p = &r.pooled;
            let _ = writeln!(
                o,
                "{:<w$} {:>9.4} {:>9.4} {:>7.4} {:>12.2e} {:>8} {:>10.3}",
                r.detector,
                p.precision,
                p.recall,
                p.f1,
                p.false_alarm_rate,
                p.false_positives,
                p.rmse_ratio_vs_spike_free
            );
        }
        let _ = writeln!(
            o,
            "false alarms per clean channel-sample; RMSE ratio = RMSE(corrected − truth) / RMSE(spike-free − truth), mean over channels"
        );
        o
    }
}
