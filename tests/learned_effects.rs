//! Issue 6, closing the loop end to end: `diagnose` learns effect terms from a static bench
//! recording, and replaying a *different* recording (the drive) through the daemon's pipeline
//! with those terms lowers the online error against truth.
//!
//! 1. `simulate` the static bench → `diagnose` it → `bias.toml` with learned effects.
//! 2. The control: the same file with every channel's `effects` cleared (same AR models).
//! 3. `evaluate` the drive scenario (truth known) with each model, plus a third model that keeps
//!    only the temperature terms (attribution: is it the temperature term that helps?).
//! 4. Compare the pipeline's RMS of the 1-s mean error and its 60-s drift per gyro channel.
//!
//! # Why the scenarios are changed with `--set`
//!
//! Only the *environment* is changed, never the sensor: bench and drive keep the identical
//! `[errors.temperature]` coefficients of the committed scenarios, so they describe the same
//! part. Both warm up by 15 °C instead of 6 °C (bench) and 9 °C (drive): the bench goes
//! 22.5 → 36.3 °C over its 10 min, the drive 18 → 25.9 °C over its 5 min. Measured reasons:
//!
//! * With the committed scenarios the effect is small and not attributable to temperature.
//!   Only gy learns a temperature term (gx and gz end with a rate random walk); gy's 1-s error
//!   drops 1.744e-3 → 1.608e-3 and its 60-s drift 3.68e-2 → 1.76e-2 rad, but the temperature
//!   term alone *raises* that drift (to 4.13e-2 rad): the drift gain comes from a learned bias
//!   step (spurious: the bench has no steps) that retunes the online step detector. With
//!   bench/drive seeds 1..=3 the learned temperature terms left the 60-s drift worse on some
//!   channel in two of the three (gy by 12.6 % and 11.4 %, gz by 8.7 %).
//! * With the larger warm-up, the temperature part of the drive's error outweighs the error
//!   both runs share (the bias estimate carried from the first 12-s stop). With the scenarios'
//!   seeds and with bench/drive seeds 1..=3, every gyro channel whose learned model kept a
//!   temperature term improved its 1-s error (by 6.3–24.5 %) and its 60-s drift (10.5–50.9 %);
//!   channels left with only a rate random walk lost at most 1.0 % and 4.1 %. (That seed sweep
//!   predates the bias stage's floor on a learned step's detector size, which removed gy's
//!   spurious-step drift gain at the scenarios' seeds — see the margins below; not re-run.)
//!
//! What `diagnose` selects is fragile (measured): recorded instead at ambient 15 °C (bench
//! 15 → 28.8 °C, same drive), gy's first candidate, a spurious step with p = 4.6e-3, misses the
//! Bonferroni threshold, the rate random walk (the last resort) goes in first, the temperature
//! term never passes after it, and gy's learned model (random walk + step) makes its 1-s error
//! 4.5 % and its drift 22.6 % *worse*. The check on channels without a bias term catches that.
//!
//! The simulations are seeded (the scenarios' own seeds), so every number is deterministic and
//! the margins below guard against regressions, not noise.
mod common;

use imuprep::model::bias_model::{BiasModelFile, Effect};
use std::path::Path;

/// Environment of the bench recording (see the module docs).
const BENCH_SETS: [&str; 1] = ["temperature.profile.rise_c=15.0"];
/// Environment of the drive (see the module docs).
const DRIVE_SETS: [&str; 1] = ["temperature.profile.rise_c=15.0"];
const GYROS: [&str; 3] = ["gx", "gy", "gz"];

// Margins, as relative improvements `1 - with/without`. Measured at the scenarios' seeds
// (full learned model vs the same AR models without effects):
//   gx (rate random walk + temperature): 1-s 3.554e-3 vs 3.793e-3 (6.3 %),
//                                        60-s drift 4.973e-2 vs 5.831e-2 rad (14.7 %)
//   gy (step + temperature):             1-s 1.624e-3 vs 1.804e-3 (10.0 %),
//                                        60-s drift 3.062e-2 vs 2.981e-2 rad (-2.7 %)
//   gz (rate random walk only):          1-s 8.807e-4 vs 8.781e-4 (-0.3 %),
//                                        60-s drift 2.412e-2 vs 2.384e-2 rad (-1.1 %)
//   mean 1-s over gx gy gz:              2.019e-3 vs 2.158e-3 (6.4 %)
//   temperature terms only:              gx 1-s 6.3 %, drift 14.8 %; gy 1-s 10.0 %, drift -2.7 %
// (Before the bias stage floored a learned step's size at `default_step_rad_s` for its step
// detector, gy's learned spurious step of 1.6e-5 rad/s made that detector hypersensitive and gy's
// drift moved by 40.9 %; now the step term only re-enables the default detector.)
// Each margin is about half the smallest improvement it covers: a harmless change (a refit that
// moves a coefficient a little) keeps it, losing the learned temperature term does not.

/// Least 1-s improvement on every gyro channel with a learned bias term (half of gx's 6.3 %).
const MIN_1S_GAIN: f64 = 0.03;
/// Least 60-s drift improvement of the channels with a learned bias term taken together (sum
/// of their drifts; half of the 8.8 % measured: gx 14.7 %, gy −2.7 %).
const MIN_POOLED_DRIFT_GAIN: f64 = 0.04;
/// Largest 60-s drift loss of any one channel with a learned bias term (gy: 2.7 %, see
/// `MIN_TEMP_ONLY_1S_GAIN` for why).
const MAX_BIAS_DRIFT_LOSS: f64 = 0.05;
/// Least improvement of the mean 1-s error over the three gyros (half of 6.4 %).
const MIN_MEAN_1S_GAIN: f64 = 0.03;
/// Least 1-s improvement from the temperature terms alone (half of gx's 6.3 %). The drift is
/// not asserted for them: on gy the temperature term alone leaves the drift 2.7 % worse. (Traced
/// on the committed drive: gy carries a +6e-4..8e-4 rad/s error from the end of the first stop
/// to the next, with and without effects, and the uncompensated temperature drift happens to
/// cancel part of it; even the true coefficients raise gy's drift there.)
const MIN_TEMP_ONLY_1S_GAIN: f64 = 0.03;
/// Channels whose learned effects only tune the filter (a rate random walk, a step size for the
/// step detector) subtract no bias term; they must not get materially worse. Measured here: gz
/// (rate random walk only) -0.3 % and -1.1 %; over other seeds and environments a learned rate
/// random walk alone cost up to 1.0 % (1-s) and 5.3 % (60-s drift), while a learned step with a
/// random walk has cost 4.5 % and 22.6 % (see the module docs; the bounds are meant to catch it).
const MAX_TUNING_1S_LOSS: f64 = 0.02;
const MAX_TUNING_DRIFT_LOSS: f64 = 0.10;

fn run(args: &[&str]) -> String {
    common::run_cli(args)
}

/// The pipeline's scores of one gyro channel on the drive.
#[derive(Clone, Copy, Debug)]
struct Scores {
    rms_1s: f64,
    drift_60s: f64,
}

/// Bias terms the online stage subtracts from a gyro channel (as opposed to filter tuning:
/// rate random walk, step size).
fn is_bias_term(e: &Effect) -> bool {
    matches!(
        e,
        Effect::Temperature(_) | Effect::GSensitivity { .. } | Effect::VibrationLine { .. }
    )
}

/// `model` with only the effects `keep` accepts, on every channel.
fn filtered(model: &BiasModelFile, keep: impl Fn(&Effect) -> bool) -> BiasModelFile {
    let mut m = model.clone();
    for c in &mut m.channels {
        c.effects.retain(&keep);
    }
    m
}

/// `evaluate` on the drive with `model` as the bias stage's model; scores of gx, gy, gz.
fn evaluate_drive(dir: &Path, tag: &str, model: &BiasModelFile) -> [Scores; 3] {
    let model_path = dir.join(format!("{tag}.bias.toml"));
    std::fs::write(&model_path, model.to_toml_string().unwrap()).unwrap();
    let cfg = dir.join(format!("{tag}.config.toml"));
    std::fs::write(
        &cfg,
        format!(
            "[source]\nkind = \"stdin\"\n[gross_error]\nenabled = true\n[bias]\nenabled = true\nmodel = \"{}\"\n",
            model_path.display()
        ),
    )
    .unwrap();
    let json = dir.join(format!("{tag}.eval.json"));
    let mut args = vec![
        "evaluate",
        "--scenario",
        "replay/drive.toml",
        "--config",
        cfg.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ];
    for s in DRIVE_SETS {
        args.extend(["--set", s]);
    }
    run(&args);
    let v: serde_json::Value = common::read_json(&json);
    GYROS.map(|name| {
        let ch = v
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["channel"] == name)
            .unwrap_or_else(|| panic!("{name} missing from {v}"));
        Scores {
            rms_1s: ch["pipeline"]["rms_1s_mean_error"].as_f64().unwrap(),
            drift_60s: ch["pipeline"]["rms_60s_drift_rad"].as_f64().unwrap(),
        }
    })
}

/// `1 - with/without`: the share of the error the effects removed (negative: they added).
fn gain(with: f64, without: f64) -> f64 {
    1.0 - with / without
}

#[test]
fn learned_effects_lower_the_online_error_on_a_different_recording() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    // 1. Bench recording → diagnose → bias model with learned effects.
    let bench = d.join("bench.log");
    let mut args = vec![
        "simulate",
        "replay/static_bench.toml",
        "-o",
        bench.to_str().unwrap(),
    ];
    for s in BENCH_SETS {
        args.extend(["--set", s]);
    }
    run(&args);
    let diag_dir = d.join("diagnose");
    let out = run(&[
        "diagnose",
        bench.to_str().unwrap(),
        "--out-dir",
        diag_dir.to_str().unwrap(),
    ]);
    eprintln!("diagnose:\n{out}");
    let learned = BiasModelFile::load(&diag_dir.join("bias.toml"))
        .expect("diagnose writes a valid bias model");
    let effects_of = |name: &str| -> &[Effect] {
        &learned
            .channel(name)
            .unwrap_or_else(|| panic!("{name} missing from the learned model"))
            .effects
    };
    let has_temp = GYROS.map(|n| {
        effects_of(n)
            .iter()
            .any(|e| matches!(e, Effect::Temperature(_)))
    });
    let has_bias_term = GYROS.map(|n| effects_of(n).iter().any(is_bias_term));
    for name in GYROS {
        eprintln!("{name} learned: {:?}", effects_of(name));
    }
    // Otherwise the comparison below would be vacuous.
    assert!(
        has_temp.iter().any(|t| *t),
        "diagnose learned no temperature effect on any gyro channel: {learned:?}"
    );

    // 2.–3. The drive, with the learned effects, without any, and with the temperature only.
    let with = evaluate_drive(d, "learned", &learned);
    let without = evaluate_drive(d, "no_effects", &filtered(&learned, |_| false));
    let temp_only = evaluate_drive(
        d,
        "temperature_only",
        &filtered(&learned, |e| matches!(e, Effect::Temperature(_))),
    );

    eprintln!(
        "drive (--set {}), pipeline error vs truth, learned effects vs none (gain = 1 - with/without):",
        DRIVE_SETS.join(" ")
    );
    eprintln!(
        "{:<3} {:>11} {:>11} {:>7} {:>11} {:>11} {:>7} {:>9} {:>9}",
        "ch",
        "1s with",
        "1s without",
        "gain",
        "60s with",
        "60s without",
        "gain",
        "T-only 1s",
        "T-only 60s"
    );
    for (i, name) in GYROS.iter().enumerate() {
        let (w, wo, t) = (with[i], without[i], temp_only[i]);
        eprintln!(
            "{:<3} {:>11.4e} {:>11.4e} {:>6.1}% {:>11.4e} {:>11.4e} {:>6.1}% {:>8.1}% {:>8.1}%",
            name,
            w.rms_1s,
            wo.rms_1s,
            100.0 * gain(w.rms_1s, wo.rms_1s),
            w.drift_60s,
            wo.drift_60s,
            100.0 * gain(w.drift_60s, wo.drift_60s),
            100.0 * gain(t.rms_1s, wo.rms_1s),
            100.0 * gain(t.drift_60s, wo.drift_60s),
        );
    }
    let mean = |s: &[Scores; 3]| s.iter().map(|x| x.rms_1s).sum::<f64>() / 3.0;
    let mean_gain = gain(mean(&with), mean(&without));
    eprintln!(
        "mean 1-s error over gx gy gz: {:.4e} with, {:.4e} without ({:.1}%)",
        mean(&with),
        mean(&without),
        100.0 * mean_gain
    );

    // 4. The assertions.
    let mut failures = Vec::new();
    let pooled = |sc: &[Scores; 3]| {
        (0..3)
            .filter(|&i| has_bias_term[i])
            .map(|i| sc[i].drift_60s)
            .sum::<f64>()
    };
    let pooled_gain = gain(pooled(&with), pooled(&without));
    eprintln!(
        "60-s drift summed over the channels with learned bias terms: {:.4e} with, {:.4e} without ({:.1}%)",
        pooled(&with),
        pooled(&without),
        100.0 * pooled_gain
    );
    if pooled_gain < MIN_POOLED_DRIFT_GAIN {
        failures.push(format!(
            "the 60-s drift of the channels with learned bias terms drops by {:.1}% < {:.1}%",
            100.0 * pooled_gain,
            100.0 * MIN_POOLED_DRIFT_GAIN
        ));
    }
    for (i, name) in GYROS.iter().enumerate() {
        let g1 = gain(with[i].rms_1s, without[i].rms_1s);
        let g60 = gain(with[i].drift_60s, without[i].drift_60s);
        if has_bias_term[i] {
            if g1 < MIN_1S_GAIN {
                failures.push(format!(
                    "{name}: learned bias terms lower the 1-s error by {:.1}% < {:.1}%",
                    100.0 * g1,
                    100.0 * MIN_1S_GAIN
                ));
            }
            if g60 < -MAX_BIAS_DRIFT_LOSS {
                failures.push(format!(
                    "{name}: learned bias terms raise the 60-s drift by {:.1}% > {:.1}%",
                    -100.0 * g60,
                    100.0 * MAX_BIAS_DRIFT_LOSS
                ));
            }
        } else {
            if g1 < -MAX_TUNING_1S_LOSS {
                failures.push(format!(
                    "{name} (no bias term learned): the 1-s error is {:.1}% worse with the learned model (allowed {:.1}%)",
                    -100.0 * g1,
                    100.0 * MAX_TUNING_1S_LOSS
                ));
            }
            if g60 < -MAX_TUNING_DRIFT_LOSS {
                failures.push(format!(
                    "{name} (no bias term learned): the 60-s drift is {:.1}% worse with the learned model (allowed {:.1}%)",
                    -100.0 * g60,
                    100.0 * MAX_TUNING_DRIFT_LOSS
                ));
            }
        }
        if has_temp[i] {
            let gt = gain(temp_only[i].rms_1s, without[i].rms_1s);
            if gt < MIN_TEMP_ONLY_1S_GAIN {
                failures.push(format!(
                    "{name}: the temperature term alone lowers the 1-s error by {:.1}% < {:.1}%",
                    100.0 * gt,
                    100.0 * MIN_TEMP_ONLY_1S_GAIN
                ));
            }
        }
    }
    if mean_gain < MIN_MEAN_1S_GAIN {
        failures.push(format!(
            "the mean 1-s error over gx gy gz drops by {:.1}% < {:.1}%",
            100.0 * mean_gain,
            100.0 * MIN_MEAN_1S_GAIN
        ));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
