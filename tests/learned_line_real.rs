//! The daemon applies a learned vibration line on a real sensor whose line drifts (issue 6: "a
//! vibration line cancelled with its phase tracked online — its phase will not stay fixed on a
//! live sensor").
//!
//! `imuprep diagnose` on the ADIS16405 static recording (evaluation data beside the project;
//! skipped with a message when absent) finds a line at 0.5667 Hz on all three accelerometers in
//! the first minutes (docs/results-diagnose-real.md); later in the 2.78 h recording it sits at
//! 0.563–0.565 Hz, so a fixed sinusoid would drift out of phase within minutes. Here the bias stage
//! gets a model file carrying only that learned line (frequency from the early fit, a small seed
//! amplitude, phase 0: the canceller must find amplitude and phase itself) and the whole recording
//! is replayed through it. Scored per 20-min block on the Hann periodogram: the power in a ±6 mHz
//! band around the block's peak near 0.566 Hz against the mean of the neighbouring 0.50–0.55 and
//! 0.58–0.63 Hz bands (same number of bins).

mod common;

use imuprep::analysis::spectrum::{Psd, periodogram};
use imuprep::io::csv::{ImportOptions, read_csv};
use imuprep::model::bias_model::BiasModelFile;
use imuprep::stage::bias::BiasStage;
use imuprep::stage::bias::settings::BiasSettings;

const LINE_HZ: f64 = 0.5667;

fn model() -> BiasModelFile {
    let ch = |name: &str| {
        format!(
            r#"
[[channels]]
channel = "{name}"
method = "burg"
sample_rate_hz = 100.0
mean = 0.0
ar = [0.2]
innovation_var = 1.5e-3
white_noise_var = 0.0
ar_of = "signal"

[[channels.effects]]
kind = "vibration_line"
freq_hz = {LINE_HZ}
amplitude = 5.0e-4
phase_rad = 0.0
"#
        )
    };
    let text = ["ax", "ay", "az"].map(ch).concat();
    BiasModelFile::from_toml_str(&text).unwrap()
}

/// (line-band power / neighbouring background, peak frequency) of one block.
fn line_to_background(p: &Psd) -> (f64, f64) {
    let in_band = |lo: f64, hi: f64| {
        p.freq_hz
            .iter()
            .zip(&p.density)
            .filter(move |(f, _)| **f > lo && **f < hi)
            .map(|(_, d)| *d)
    };
    let (f_pk, _) = p
        .freq_hz
        .iter()
        .zip(&p.density)
        .filter(|(f, _)| **f > 0.555 && **f < 0.575)
        .fold((0.0, 0.0), |b, (f, d)| if *d > b.1 { (*f, *d) } else { b });
    let line: Vec<f64> = in_band(f_pk - 0.006, f_pk + 0.006).collect();
    let bg: Vec<f64> = in_band(0.50, 0.55).chain(in_band(0.58, 0.63)).collect();
    let bg_mean = bg.iter().sum::<f64>() / bg.len() as f64;
    (
        line.iter().sum::<f64>() / (bg_mean * line.len() as f64),
        f_pk,
    )
}

fn band_power(p: &Psd, lo: f64, hi: f64) -> f64 {
    p.freq_hz
        .iter()
        .zip(&p.density)
        .filter(|(f, _)| **f > lo && **f < hi)
        .map(|(_, d)| d)
        .sum()
}

#[test]
fn adis16405_accelerometer_line_is_tracked_through_its_drift() {
    let Some(path) = common::real_data("adis16405_static/adis_16405_imu1.csv.gz") else {
        return;
    };
    let (_, raw) = read_csv(&path, &ImportOptions::default()).unwrap();
    let settings = BiasSettings {
        sample_rate_hz: 100.0,
        ..BiasSettings::default()
    };
    let mut stage = BiasStage::new(&settings, Some(&model())).unwrap();
    let out: Vec<_> = raw.iter().map(|s| stage.process(*s)).collect();
    let block = 20 * 60 * 100;
    let mut peaks = Vec::new();
    for c in 3..6 {
        for b in 0..raw.len() / block {
            let s = b * block..(b + 1) * block;
            let x: Vec<f64> = raw[s.clone()].iter().map(|v| v.channel(c)).collect();
            let y: Vec<f64> = out[s].iter().map(|v| v.channel(c)).collect();
            let (pr, py) = (
                periodogram(&x, 100.0).unwrap(),
                periodogram(&y, 100.0).unwrap(),
            );
            let ((r_raw, f_pk), (r_out, _)) = (line_to_background(&pr), line_to_background(&py));
            // Away from the line the output is the input up to the notch's skirt: the canceller
            // subtracts only its line estimate, and the accelerometers get no stochastic bias
            // estimate. Its transfer function (src/stage/line_canceller.rs, 0.2 Hz bandwidth)
            // has |H|² = 0.92 at 1 Hz, 0.988 at 2 Hz, 0.998 at 5 Hz; over 1–10 Hz of this
            // recording's noise that is −0.5 % (measured 0.9941–0.9953).
            let broad = band_power(&py, 1.0, 10.0) / band_power(&pr, 1.0, 10.0);
            eprintln!(
                "ch {c} block {b}: peak {f_pk:.4} Hz, line/background raw {r_raw:.1}, output {r_out:.2}; 1-10 Hz power out/raw {broad:.5}"
            );
            peaks.push(f_pk);
            // Measured: raw 29–101 (the line stands far out of the noise in every block), output
            // 0.09–0.60 (the notch's ±0.1 Hz band takes the local noise too). A line left at a
            // quarter of its power would still read ≥ 7 here; 2 fails anything visible.
            assert!(
                r_raw > 20.0,
                "ch {c} block {b}: no line in the input ({r_raw})"
            );
            assert!(
                r_out < 2.0,
                "ch {c} block {b}: line left in the output ({r_out})"
            );
            // 1 %: twice the skirt's measured effect; a doubled bandwidth or any gain error fails.
            assert!((broad - 1.0).abs() < 0.01, "ch {c} block {b}: {broad}");
        }
    }
    // The line did drift: the canceller was not handed its later frequency.
    let spread = peaks.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - peaks.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(spread >= 0.001, "peak frequencies spread only {spread} Hz");
}
