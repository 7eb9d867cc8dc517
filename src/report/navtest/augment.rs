//! Variant (d)'s bias process: Gauss–Markov parts from imuprep's Allan terms of the record's
//! longest still stretch, each checked ([`GaussMarkov::check`]) — an implausible part (T_c ≈ 0
//! from a bad fit, σ not finite) falls back to the random walk and the report says so.

use serde::Serialize;

use super::setup::{RecordSpec, mount};
use crate::analysis::allan::export::BiasModelNote;
use crate::analysis::allan::{self, terms::FitSettings};
use crate::nav::eskf::*;
use crate::nav::pos::PosEpoch;
use crate::sample::Sample;

/// The Gauss–Markov part of variant (d), per body axis, with where it came from.
#[derive(Clone, Debug, Serialize)]
pub struct AugmentationSource {
    /// Still stretch the Allan terms were fitted on, s from the IMU start.
    pub still_from_s: f64,
    pub still_to_s: f64,
    /// What the filter runs with (refused parts removed); `None` when every part was refused:
    /// (d) is then the 15-state filter, i.e. (a).
    pub augmentation: Option<BiasAugmentation>,
    /// Per IMU channel (gx gy gz ax ay az): correlation time s, σ (rad/s or m/s²), B resolved.
    pub channels: Vec<(String, f64, f64, bool)>,
    /// IMU channels whose part was refused, and why (they keep the random walk only).
    pub refused: Refused,
    /// Variant (e)'s process noise from the same Allan report: N and K of the gyros and of
    /// the accelerometers, the largest over each sensor's axes (`allan::export::sensor_noise`,
    /// the values `imuprep allan` exports for Kalibr and for GNSS_IMU's config), with the
    /// channels whose N or K is only an upper bound (not resolved by the stretch).
    pub noise: Option<(ImuNoise, Vec<String>)>,
}

/// The process noise a filter gets from `allan` (see [`AugmentationSource::noise`]).
fn noise_from_allan(
    rep: &crate::analysis::allan::report::AllanReport,
) -> Option<(ImuNoise, Vec<String>)> {
    let g = allan::export::sensor_noise(rep, true)?;
    let a = allan::export::sensor_noise(rep, false)?;
    let mut bounds: Vec<String> = vec![];
    for (what, b) in [
        ("N", &g.noise_density_bounds),
        ("K", &g.random_walk_bounds),
        ("N", &a.noise_density_bounds),
        ("K", &a.random_walk_bounds),
    ] {
        bounds.extend(b.iter().map(|c| format!("{what} {c}")));
    }
    Some((
        ImuNoise {
            gyro_psd: g.noise_density,
            accel_psd: a.noise_density,
            gyro_bias_rw: g.random_walk,
            accel_bias_rw: a.random_walk,
        },
        bounds,
    ))
}

/// Channels whose Gauss–Markov part was refused: (channel, why).
pub type Refused = Vec<(String, String)>;

/// The filter's Gauss–Markov parts from per-IMU-channel notes (gx gy gz ax ay az) of
/// `allan::export::bias_model`: each channel's part checked ([`GaussMarkov::check`]; refused
/// ones listed, their axis keeps the random walk), then mapped to the body axis it is closest
/// to under `mount` (IMU → body; an axis permutation with signs plus a few degrees).
pub fn augmentation_from_notes(
    notes: &[BiasModelNote],
    mount: &nalgebra::Matrix3<f64>,
) -> Result<(Option<BiasAugmentation>, Refused), String> {
    if notes.len() != 6 {
        return Err(format!("Allan terms for {} of 6 channels", notes.len()));
    }
    let mut refused = vec![];
    let parts: Vec<Option<GaussMarkov>> = notes
        .iter()
        .map(|n| {
            let gm = GaussMarkov {
                sigma: n.sigma_gm,
                tc_s: n.tc_s,
            };
            match gm.check() {
                Ok(()) => Some(gm),
                Err(why) => {
                    refused.push((n.channel.clone(), why));
                    None
                }
            }
        })
        .collect();
    let pick = |body: usize, off: usize| {
        let a = (0..3)
            .max_by(|&x, &y| mount[(body, x)].abs().total_cmp(&mount[(body, y)].abs()))
            .unwrap_or(body);
        parts[off + a]
    };
    let aug = BiasAugmentation {
        gyro: [0, 1, 2].map(|b| pick(b, 0)),
        accel: [0, 1, 2].map(|b| pick(b, 3)),
    };
    Ok(((!aug.is_empty()).then_some(aug), refused))
}

/// Variant (e)'s filter noise from `src`'s Allan terms, two ways: (e) every term as `allan`
/// gives it, an upper bound taken as the value (the exported Kalibr / GNSS_IMU values);
/// (e') only the resolved terms, `base` (the reference filter's) where a sensor's term is an
/// upper bound on any axis.
pub fn noise_variants(src: &AugmentationSource, base: &ImuNoise) -> Vec<(&'static str, ImuNoise)> {
    let Some((n, bounds)) = &src.noise else {
        return vec![];
    };
    let pick = |term: &str, sensor: char, allan: f64, own: f64| {
        let bounded = bounds.iter().any(|b| {
            let mut w = b.split(' ');
            w.next() == Some(term) && w.next().is_some_and(|c| c.starts_with(sensor))
        });
        if bounded { own } else { allan }
    };
    let resolved = ImuNoise {
        gyro_psd: pick("N", 'g', n.gyro_psd, base.gyro_psd),
        accel_psd: pick("N", 'a', n.accel_psd, base.accel_psd),
        gyro_bias_rw: pick("K", 'g', n.gyro_bias_rw, base.gyro_bias_rw),
        accel_bias_rw: pick("K", 'a', n.accel_bias_rw, base.accel_bias_rw),
    };
    vec![
        ("(e) raw, filter noise from allan", *n),
        (
            "(e') raw, filter noise from allan, resolved terms only",
            resolved,
        ),
    ]
}

/// Allan terms of the record's longest still stretch (consecutive GNSS epochs slower than
/// 0.3 m/s, less 1 s at either end; at least 10 s) → a Gauss–Markov bias per body axis.
pub fn augmentation_from_allan(
    spec: &RecordSpec,
    samples: &[Sample],
    rate: f64,
    gnss: &[PosEpoch],
) -> Result<AugmentationSource, String> {
    let t_imu0 = samples[0].t_s() + spec.t_off;
    let t_imu1 = samples[samples.len() - 1].t_s() + spec.t_off;
    let mut best = (0.0, 0.0);
    let mut run_start: Option<f64> = None;
    for (k, e) in gnss.iter().enumerate() {
        let still = e.v_neu[0].hypot(e.v_neu[1]) < 0.3;
        let last = k + 1 == gnss.len();
        match (still, run_start) {
            (true, None) => run_start = Some(e.t),
            (false, Some(a)) | (true, Some(a)) if !still || last => {
                let (a, b) = (a.max(t_imu0) + 1.0, e.t.min(t_imu1) - 1.0);
                if b - a > best.1 - best.0 {
                    best = (a, b);
                }
                run_start = None;
            }
            _ => {}
        }
    }
    let (from_s, to_s) = (best.0 - t_imu0, best.1 - t_imu0);
    if to_s - from_s < 10.0 {
        return Err(format!(
            "no still stretch of 10 s or more for Allan terms (longest {:.1} s)",
            to_s - from_s
        ));
    }
    let (i0, i1) = (
        (from_s * rate) as usize,
        ((to_s * rate) as usize).min(samples.len()),
    );
    let rep = allan::report::allan_report(
        &spec.name,
        &samples[i0..i1],
        rate,
        &[0, 1, 2, 3, 4, 5],
        &FitSettings::default(),
    )
    .map_err(|e| e.to_string())?;
    let (_, notes) = allan::export::bias_model(&rep);
    let (augmentation, refused) = augmentation_from_notes(&notes, &mount(spec))?;
    Ok(AugmentationSource {
        still_from_s: from_s,
        still_to_s: to_s,
        augmentation,
        channels: notes
            .iter()
            .map(|n| (n.channel.clone(), n.tc_s, n.sigma_gm, !n.b_is_bound))
            .collect(),
        refused,
        noise: noise_from_allan(&rep),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::earth::euler_to_ctm;

    fn note(ch: &str, tc_s: f64, sigma: f64) -> BiasModelNote {
        BiasModelNote {
            channel: ch.into(),
            tc_s,
            sigma_gm: sigma,
            b_is_bound: false,
            n_is_bound: false,
            rrw_q_per_s: None,
            ramp_dropped: false,
        }
    }

    #[test]
    fn a_near_zero_correlation_time_falls_back_to_the_random_walk() {
        // The walk's mounting (roll 180°, yaw −90°): body x ← IMU y, body y ← IMU x,
        // body z ← IMU z. gx's T_c of 2 ms (an Allan curve whose minimum is its first τ) and
        // az's NaN σ are refused; the others map to their body axes unchanged.
        let m = euler_to_ctm(180f64.to_radians(), 0.0, (-90f64).to_radians());
        let notes = [
            note("gx", 0.002, 1e-4),
            note("gy", 300.0, 2e-4),
            note("gz", 50.0, 3e-4),
            note("ax", 200.0, 1e-3),
            note("ay", 100.0, 2e-3),
            note("az", 100.0, f64::NAN),
        ];
        let (aug, refused) = augmentation_from_notes(&notes, &m).unwrap();
        let aug = aug.unwrap();
        let names: Vec<&str> = refused.iter().map(|r| r.0.as_str()).collect();
        assert_eq!(names, ["gx", "az"]);
        assert!(refused[0].1.contains("T_c"), "{}", refused[0].1);
        assert_eq!(aug.gyro[0].map(|g| g.tc_s), Some(300.0));
        assert_eq!(aug.gyro[1], None);
        assert_eq!(aug.gyro[2].map(|g| g.tc_s), Some(50.0));
        assert_eq!(aug.accel[0].map(|g| g.tc_s), Some(100.0));
        assert_eq!(aug.accel[1].map(|g| g.tc_s), Some(200.0));
        assert_eq!(aug.accel[2], None);
        // Every part implausible: no augmentation at all — (d) runs as the 15-state filter.
        let bad: Vec<BiasModelNote> = ["gx", "gy", "gz", "ax", "ay", "az"]
            .iter()
            .map(|c| note(c, 0.0, 1e-3))
            .collect();
        let (aug, refused) = augmentation_from_notes(&bad, &m).unwrap();
        assert!(aug.is_none());
        assert_eq!(refused.len(), 6);
        assert!(augmentation_from_notes(&bad[..5], &m).is_err());
    }

    /// (e) takes every `allan` term, bounds included; (e') keeps the filter's own value for a
    /// sensor's term that is an upper bound on any of its axes.
    #[test]
    fn resolved_terms_only_keeps_the_filters_own_noise_where_allan_gives_a_bound() {
        let allan = ImuNoise {
            gyro_psd: 1.0,
            accel_psd: 2.0,
            gyro_bias_rw: 3.0,
            accel_bias_rw: 4.0,
        };
        let base = ImuNoise {
            gyro_psd: 10.0,
            accel_psd: 20.0,
            gyro_bias_rw: 30.0,
            accel_bias_rw: 40.0,
        };
        let src = AugmentationSource {
            still_from_s: 0.0,
            still_to_s: 20.0,
            augmentation: None,
            channels: vec![],
            refused: vec![],
            noise: Some((allan, vec!["K gx".into(), "N az".into()])),
        };
        let v = noise_variants(&src, &base);
        assert_eq!(v.len(), 2);
        assert_eq!(v[0].1.gyro_bias_rw, 3.0);
        let r = v[1].1;
        assert_eq!(
            [r.gyro_psd, r.accel_psd, r.gyro_bias_rw, r.accel_bias_rw],
            [1.0, 20.0, 30.0, 4.0]
        );
        let none = AugmentationSource { noise: None, ..src };
        assert!(noise_variants(&none, &base).is_empty());
    }
}
