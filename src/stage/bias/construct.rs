//! Building the bias stage from validated settings and an optional model file: calibration,
//! per-channel effects, the gyro filters (or warm-up buffers), the delay line.

use super::*;
use crate::stage::bias::stillness::window_samples;

impl BiasStage {
    /// Build the stage with `model` (from the config's `[bias] model`, a file or inline), or
    /// without one (each gyro channel identifies its own during warm-up).
    pub fn new(
        settings: impl IntoValid<Valid = ValidBiasSettings>,
        model: Option<&BiasModelFile>,
    ) -> Result<Self, BiasStageError> {
        let settings = settings.into_valid()?;
        let model = match model {
            Some(m) => {
                let mut errs = m.validate().err().unwrap_or_default();
                for (i, ch) in m.channels.iter().enumerate() {
                    if (ch.sample_rate_hz / settings.sample_rate_hz - 1.0).abs() > 0.01 {
                        errs.push(format!(
                            "channels[{i}].sample_rate_hz: {} Hz differs from the stage's {} Hz by more than 1 %",
                            ch.sample_rate_hz, settings.sample_rate_hz
                        ));
                    }
                }
                if !errs.is_empty() {
                    return Err(BiasStageError::Model(errs));
                }
                Some(m)
            }
            None => None,
        };
        let fs = settings.sample_rate_hz;
        // Validation guarantees invertible calibrations.
        let cal_err =
            |k: &str| BiasStageError::Model(vec![format!("{k}: calibration matrix is singular")]);
        let gyro_cal = settings.gyro.build().ok_or_else(|| cal_err("gyro"))?;
        let accel_cal = settings.accel.build().ok_or_else(|| cal_err("accel"))?;
        let mut counters = BiasCounters::default();
        let empty = ChannelState {
            temp: None,
            gsens: None,
            lines: [None; MAX_LINES],
            est: None,
            warm: None,
            warm_sum: 0.0,
            warm_sumsq: 0.0,
            provisional: None,
            stationary_sd: 0.0,
            bias: 0.0,
            bias_sd: 0.0,
            engaged: false,
            diag: ChannelDiagnostics::default(),
            constant_stretches: 0,
            origin: BiasModelOrigin::None,
        };
        let mut ch: [ChannelState; N_CHANNELS] = std::array::from_fn(|_| empty.clone());
        let mut stage_proto = BiasStage {
            fs,
            gyro_cal,
            accel_cal,
            detector: StillnessDetector::new(&settings.stillness, fs),
            delay: (settings.update_delay_s * fs).round().clamp(
                0.0,
                window_samples(settings.stillness.window_s, fs).min(MAX_UPDATE_DELAY) as f64,
            ) as usize,
            ring: [DelayEntry {
                steps: 0,
                z: [0.0; 3],
                usable: [false; 3],
            }; MAX_UPDATE_DELAY + 1],
            ring_head: 0,
            ring_len: 0,
            lead_steps: 0,
            ch: std::array::from_fn(|_| empty.clone()),
            prev: None,
            warmup: settings.warmup,
            constant_prior_var: settings.turn_on_bias_sd_rad_s.powi(2),
            step_arl_samples: settings.step_false_alarm_interval_s * fs,
            step_inflation: settings.step_inflation_factor,
            default_step: settings.default_step_rad_s,
            default_rrw_q_per_s: settings.default_rate_random_walk_q_per_s,
            apply_k: settings.apply_k,
            counters,
            in_steady_turn: false,
            nis_weight: 1.0 / (super::NIS_WINDOW_S * fs).max(1.0),
            still_run: 0,
        };
        for (c, state) in ch.iter_mut().enumerate() {
            let name = CHANNEL_NAMES[c];
            let gyro = c < 3;
            let m = model.and_then(|m| m.channel(name));
            match m {
                Some(m) => {
                    state.origin = BiasModelOrigin::File;
                    let ss =
                        state_space_from_model(m).map_err(|source| BiasStageError::StateSpace {
                            channel: name.into(),
                            source,
                        })?;
                    if ss.white_noise_clamped {
                        counters.white_noise_clamped_channels += 1;
                    }
                    let mut n_lines = 0;
                    for e in &m.effects {
                        match *e {
                            Effect::Temperature(term) => {
                                state.temp = Some(TemperatureComp::new(&term, fs));
                            }
                            Effect::VibrationLine {
                                freq_hz,
                                amplitude,
                                phase_rad,
                            } => {
                                if n_lines < MAX_LINES {
                                    state.lines[n_lines] = Some(LineCanceller::new(
                                        freq_hz,
                                        fs,
                                        settings.vibration_bandwidth_hz,
                                        amplitude,
                                        phase_rad,
                                    ));
                                    n_lines += 1;
                                } else {
                                    counters.ignored_effects += 1;
                                }
                            }
                            Effect::GSensitivity { coeffs_per_m_s2 } => {
                                state.gsens = Some(coeffs_per_m_s2)
                            }
                            Effect::Step { .. } | Effect::RateRandomWalk { .. } if !gyro => {
                                counters.ignored_effects += 1;
                            }
                            Effect::Step { .. } | Effect::RateRandomWalk { .. } => {}
                        }
                    }
                    if gyro {
                        state.est = Some(stage_proto.channel_kf(ss, &m.effects));
                    } else {
                        state.stationary_sd = ss.gamma[0].max(0.0).sqrt();
                    }
                }
                None if gyro => {
                    state.warm = Some(Vec::with_capacity(settings.warmup.still_samples))
                }
                None => {}
            }
        }
        stage_proto.ch = ch;
        stage_proto.counters = counters;
        Ok(stage_proto)
    }

    /// The filter of a gyro channel for state-space model `ss` with the model's effects; a model
    /// without a rate random walk or a step gets the settings' defaults for them.
    fn channel_kf(&self, ss: BiasStateSpace, effects: &[Effect]) -> ChannelKf {
        let declared_rrw = effects
            .iter()
            .any(|e| matches!(e, Effect::RateRandomWalk { .. }));
        let rrw_q_per_s: f64 = if declared_rrw {
            effects
                .iter()
                .map(|e| {
                    if let Effect::RateRandomWalk { q_per_s } = e {
                        *q_per_s
                    } else {
                        0.0
                    }
                })
                .sum()
        } else {
            self.default_rrw_q_per_s
        };
        let declared_step = effects
            .iter()
            .filter_map(|e| {
                if let Effect::Step { size, .. } = e {
                    Some(size.abs())
                } else {
                    None
                }
            })
            .fold(f64::INFINITY, f64::min);
        // The CUSUM is tuned for the smallest step worth catching: a declared step smaller than
        // the default (diagnose can learn steps of 1e-5 rad/s) would make it fire on noise.
        let step_size = if declared_step.is_finite() {
            declared_step.max(self.default_step)
        } else if self.default_step > 0.0 {
            self.default_step
        } else {
            f64::INFINITY
        };
        let has_step = step_size.is_finite();
        let constant = (self.constant_prior_var > 0.0 || rrw_q_per_s > 0.0 || has_step).then_some(
            ConstantState {
                prior_var: self.constant_prior_var,
                q_per_step: rrw_q_per_s / self.fs,
            },
        );
        let kf = BiasKf::new(&ss, constant);
        // The CUSUM is tuned for the step in units of the steady innovation sd.
        let cusum = has_step.then(|| {
            Cusum::new(
                step_size / ss.optimal_innovation_var().sqrt(),
                self.step_arl_samples,
            )
        });
        ChannelKf {
            lead_nominal: kf.lead(self.delay as u32),
            kf,
            ss,
            cusum,
            step_size: if has_step { step_size } else { 0.0 },
            rejected_run: 0,
            anchored: false,
            nis: 1.0,
        }
    }
}
