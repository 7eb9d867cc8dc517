//! Scenario parsing and validation (every problem of a scenario file, each at its key path), and
//! the per-channel white-noise σ a valid scenario implies.

use super::*;

impl Scenario {
    /// Parse and validate a scenario.
    pub fn from_toml_str(text: &str) -> Result<Scenario, SimError> {
        let scn: Scenario = toml::from_str(text).map_err(|e| SimError::Parse(e.to_string()))?;
        scn.validate()?;
        Ok(scn)
    }

    /// Parse a scenario with overrides applied first: each `(key.path, value)` sets one key,
    /// `value` in TOML syntax (`2e-3`, `"drive"`, `[6.0, 30.0]`); intermediate tables are created
    /// as needed. Used by `--set` on the command line (e.g. a denser gross-error rate for a
    /// detector comparison without a second copy of the scenario).
    pub fn from_toml_str_with(
        text: &str,
        overrides: &[(String, String)],
    ) -> Result<Scenario, SimError> {
        if overrides.is_empty() {
            return Self::from_toml_str(text);
        }
        let mut root: toml::Table =
            toml::from_str(text).map_err(|e| SimError::Parse(e.to_string()))?;
        for (key, value) in overrides {
            let parsed: toml::Table = toml::from_str(&format!("v = {value}"))
                .map_err(|e| SimError::Parse(format!("--set {key}={value}: {e}")))?;
            let v = parsed["v"].clone();
            let parts: Vec<&str> = key.split('.').collect();
            if parts.iter().any(|p| p.is_empty()) {
                return Err(SimError::Parse(format!("--set {key}: empty key segment")));
            }
            let mut t = &mut root;
            for p in &parts[..parts.len() - 1] {
                let e = t
                    .entry(p.to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()));
                t = e
                    .as_table_mut()
                    .ok_or_else(|| SimError::Parse(format!("--set {key}: `{p}` is not a table")))?;
            }
            t.insert(parts[parts.len() - 1].to_string(), v);
        }
        let scn: Scenario = root
            .try_into()
            .map_err(|e: toml::de::Error| SimError::Parse(e.to_string()))?;
        scn.validate()?;
        Ok(scn)
    }

    /// Check every value; all problems are reported together, each with its key path.
    pub fn validate(&self) -> Result<(), SimError> {
        let issues = self.issues();
        if issues.is_empty() {
            Ok(())
        } else {
            Err(SimError::Invalid(issues))
        }
    }

    /// All validation problems (empty when valid).
    pub fn issues(&self) -> Vec<Issue> {
        let mut ck = Checker::default();
        let s = &self.sensor;
        ck.positive("sensor.sample_rate_hz", s.sample_rate_hz);
        ck.positive("sensor.gyro_range_deg_s", s.gyro_range_deg_s);
        ck.positive("sensor.accel_range_g", s.accel_range_g);
        let rate = if s.sample_rate_hz.is_finite() && s.sample_rate_hz > 0.0 {
            s.sample_rate_hz
        } else {
            f64::NAN
        };
        let nyquist = 0.5 * rate;

        let traj = Trajectory::build(&self.motion, &mut ck);
        if let Some(tr) = &traj {
            let n = tr.duration_s() * rate;
            if n.is_finite() && !(1.0..=4.0e9).contains(&n.round()) {
                ck.push(
                    "motion",
                    format!("record must hold 1 to 4e9 samples, has {:.0}", n.round()),
                );
            }
        }
        let (vib, is_static) = self.motion.vibration();
        for (i, m) in vib.iter().enumerate() {
            check_vibration_mode(
                &mut ck,
                &format!("motion.vibration[{i}]"),
                m,
                nyquist,
                is_static,
            );
        }

        if let Some(t) = &self.temperature {
            ck.non_negative("temperature.resolution_c", t.resolution_c);
            ck.non_negative("temperature.noise_sd_c", t.noise_sd_c);
            let p = "temperature.profile";
            match &t.profile {
                TemperatureProfile::Constant { temp_c } => {
                    ck.finite(&format!("{p}.temp_c"), *temp_c);
                }
                TemperatureProfile::Ramp {
                    start_c,
                    end_c,
                    start_s,
                    duration_s,
                } => {
                    ck.finite(&format!("{p}.start_c"), *start_c);
                    ck.finite(&format!("{p}.end_c"), *end_c);
                    ck.finite(&format!("{p}.start_s"), *start_s);
                    ck.positive(&format!("{p}.duration_s"), *duration_s);
                }
                TemperatureProfile::WarmUp {
                    ambient_c,
                    rise_c,
                    tau_s,
                } => {
                    ck.finite(&format!("{p}.ambient_c"), *ambient_c);
                    ck.finite(&format!("{p}.rise_c"), *rise_c);
                    ck.positive(&format!("{p}.tau_s"), *tau_s);
                }
                TemperatureProfile::Steps {
                    initial_c,
                    steps,
                    tau_s,
                } => {
                    ck.finite(&format!("{p}.initial_c"), *initial_c);
                    ck.non_negative(&format!("{p}.tau_s"), *tau_s);
                    let mut last = f64::NEG_INFINITY;
                    for (i, st) in steps.iter().enumerate() {
                        ck.finite(&format!("{p}.steps[{i}].to_c"), st.to_c);
                        if ck.finite(&format!("{p}.steps[{i}].t_s"), st.t_s) {
                            if st.t_s < last {
                                ck.push(
                                    format!("{p}.steps[{i}].t_s"),
                                    "steps must be in time order",
                                );
                            }
                            last = st.t_s;
                        }
                    }
                }
            }
        }

        self.check_errors(&mut ck, nyquist, traj.as_ref().map(|t| t.duration_s()));

        if let Some(tp) = &self.transport {
            ck.probability("transport.drop_prob", tp.drop_prob);
            ck.probability("transport.duplicate_prob", tp.duplicate_prob);
            if tp.drop_prob + tp.duplicate_prob > 1.0 {
                ck.push("transport", "drop_prob + duplicate_prob must not exceed 1");
            }
            ck.non_negative("transport.jitter_sd_us", tp.jitter_sd_us);
            // Beyond a quarter period, keeping timestamps increasing would distort the jitter.
            if tp.jitter_sd_us * 1e-6 > 0.25 / rate {
                ck.push(
                    "transport.jitter_sd_us",
                    format!(
                        "must be below a quarter sample period ({} µs)",
                        0.25e6 / rate
                    ),
                );
            }
        }
        ck.issues
    }

    /// `duration_s`: the record's length, where the motion is valid.
    fn check_errors(&self, ck: &mut Checker, nyquist: f64, duration_s: Option<f64>) {
        let e = &self.errors;
        if let Some(w) = e.white_noise.as_ref().filter(|w| w.enabled) {
            ck.non_negative3("errors.white_noise.arw_deg_sqrt_h", &w.arw_deg_sqrt_h);
            ck.non_negative3("errors.white_noise.vrw_m_s_sqrt_h", &w.vrw_m_s_sqrt_h);
        }
        if let Some(b) = e.turn_on_bias.as_ref().filter(|b| b.enabled) {
            ck.finite3("errors.turn_on_bias.gyro_deg_s", &b.gyro_deg_s);
            ck.finite3("errors.turn_on_bias.accel_mg", &b.accel_mg);
            ck.non_negative3("errors.turn_on_bias.gyro_sd_deg_s", &b.gyro_sd_deg_s);
            ck.non_negative3("errors.turn_on_bias.accel_sd_mg", &b.accel_sd_mg);
        }
        if let Some(s) = e.scale_factor.as_ref().filter(|s| s.enabled) {
            ck.finite3("errors.scale_factor.gyro_ppm", &s.gyro_ppm);
            ck.finite3("errors.scale_factor.accel_ppm", &s.accel_ppm);
        }
        if let Some(m) = e.misalignment.as_ref().filter(|m| m.enabled) {
            for (name, mat) in [("gyro_mrad", &m.gyro_mrad), ("accel_mrad", &m.accel_mrad)] {
                let p = format!("errors.misalignment.{name}");
                ck.finite33(&p, mat);
                for (i, row) in mat.iter().enumerate() {
                    if row[i] != 0.0 {
                        ck.push(
                            format!("{p}[{i}][{i}]"),
                            "diagonal must be 0 (an axis' own sensitivity is the scale factor)",
                        );
                    }
                }
            }
        }
        if let Some(g) = e.g_sensitivity.as_ref().filter(|g| g.enabled) {
            ck.finite33("errors.g_sensitivity.deg_s_per_g", &g.deg_s_per_g);
        }
        for (i, g) in e.gauss_markov.iter().enumerate().filter(|(_, g)| g.enabled) {
            let p = format!("errors.gauss_markov[{i}]");
            ck.positive(&format!("{p}.tau_s"), g.tau_s);
            ck.non_negative3(&format!("{p}.gyro_sigma_deg_h"), &g.gyro_sigma_deg_h);
            ck.non_negative3(&format!("{p}.accel_sigma_mg"), &g.accel_sigma_mg);
        }
        if let Some(a) = e.ar_bias.as_ref().filter(|a| a.enabled) {
            for (name, co, sd) in [
                ("gyro", &a.gyro_coeffs, &a.gyro_innovation_sd_deg_h),
                ("accel", &a.accel_coeffs, &a.accel_innovation_sd_mg),
            ] {
                let p = format!("errors.ar_bias.{name}_coeffs");
                if co.len() > MAX_AR_ORDER {
                    ck.push(p.clone(), format!("at most {MAX_AR_ORDER} coefficients"));
                } else if !ar_is_stationary(co) {
                    ck.push(
                        p.clone(),
                        "not stationary (a root of 1 − Σ φᵢ zⁱ lies on or inside the unit circle)",
                    );
                }
                let sd_path = if name == "gyro" {
                    "errors.ar_bias.gyro_innovation_sd_deg_h"
                } else {
                    "errors.ar_bias.accel_innovation_sd_mg"
                };
                ck.non_negative3(sd_path, sd);
                if co.is_empty() && sd.iter().any(|v| *v != 0.0) {
                    ck.push(p, "innovation σ given without coefficients");
                }
            }
        }
        if let Some(r) = e.random_walk.as_ref().filter(|r| r.enabled) {
            ck.non_negative3("errors.random_walk.gyro_deg_h_sqrt_h", &r.gyro_deg_h_sqrt_h);
            ck.non_negative3(
                "errors.random_walk.accel_m_s_h_sqrt_h",
                &r.accel_m_s_h_sqrt_h,
            );
        }
        if let Some(t) = e.temperature.as_ref().filter(|t| t.enabled) {
            let p = "errors.temperature";
            if self.temperature.is_none() {
                ck.push(p, "needs a [temperature] profile to drive it");
            }
            ck.finite(&format!("{p}.t0_c"), t.t0_c);
            ck.non_negative(&format!("{p}.lag_tau_s"), t.lag_tau_s);
            ck.finite3(&format!("{p}.gyro_deg_s_per_c"), &t.gyro_deg_s_per_c);
            ck.finite3(&format!("{p}.gyro_deg_s_per_c2"), &t.gyro_deg_s_per_c2);
            ck.finite3(&format!("{p}.accel_mg_per_c"), &t.accel_mg_per_c);
            ck.finite3(&format!("{p}.accel_mg_per_c2"), &t.accel_mg_per_c2);
        }
        for (i, l) in e
            .vibration_lines
            .iter()
            .enumerate()
            .filter(|(_, l)| l.enabled)
        {
            let p = format!("errors.vibration_lines[{i}]");
            if !(l.freq_hz.is_finite() && l.freq_hz > 0.0 && l.freq_hz < nyquist) {
                ck.push(
                    format!("{p}.freq_hz"),
                    format!("must be in (0, Nyquist = {nyquist} Hz), got {}", l.freq_hz),
                );
            }
            ck.finite(&format!("{p}.phase_deg"), l.phase_deg);
            ck.non_negative(&format!("{p}.start_s"), l.start_s);
            ck.finite(&format!("{p}.drift_hz_per_s"), l.drift_hz_per_s);
            if let Some(end_s) = duration_s {
                let f_end = l.freq_hz + l.drift_hz_per_s * (end_s - l.start_s).max(0.0);
                if l.drift_hz_per_s != 0.0 && !(f_end > 0.0 && f_end < nyquist) {
                    ck.push(
                        format!("{p}.drift_hz_per_s"),
                        format!("takes the line to {f_end} Hz by the end ({end_s} s): it must stay in (0, Nyquist = {nyquist} Hz)"),
                    );
                }
            }
            ck.finite3(&format!("{p}.gyro_amp_deg_s"), &l.gyro_amp_deg_s);
            ck.finite3(&format!("{p}.accel_amp_mg"), &l.accel_amp_mg);
        }
        for (i, s) in e.steps.iter().enumerate().filter(|(_, s)| s.enabled) {
            let p = format!("errors.steps[{i}]");
            ck.non_negative(&format!("{p}.t_s"), s.t_s);
            ck.finite3(&format!("{p}.gyro_deg_s"), &s.gyro_deg_s);
            ck.finite3(&format!("{p}.accel_mg"), &s.accel_mg);
        }
        if let Some(g) = e.gross.as_ref().filter(|g| g.enabled) {
            let p = "errors.gross";
            ck.probability(&format!("{p}.rate_per_sample"), g.rate_per_sample);
            let [lo, hi] = g.amplitude_sigma;
            if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
                ck.push(
                    format!("{p}.amplitude_sigma"),
                    format!("must be [min, max] with 0 <= min <= max, got [{lo}, {hi}]"),
                );
            }
            ck.probability(&format!("{p}.run_fraction"), g.run_fraction);
            if !(1..=10).contains(&g.max_run_len) {
                ck.push(
                    format!("{p}.max_run_len"),
                    format!("must be 1..=10, got {}", g.max_run_len),
                );
            }
            if g.run_fraction > 0.0 && g.max_run_len < 2 {
                ck.push(format!("{p}.max_run_len"), "runs need max_run_len >= 2");
            }
            let active = gross_channels(g.channels.as_deref(), ck);
            let sigma = self.white_sigma();
            for c in 0..N_CHANNELS {
                let has_override = if c < 3 {
                    g.gyro_sigma_deg_s.is_some()
                } else {
                    g.accel_sigma_mg.is_some()
                };
                if active[c] && sigma[c] <= 0.0 && !has_override {
                    let key = if c < 3 {
                        "gyro_sigma_deg_s"
                    } else {
                        "accel_sigma_mg"
                    };
                    ck.push(
                        format!("{p}.{key}"),
                        format!(
                            "channel {} has no white noise to scale the amplitude: set {key}",
                            crate::sample::CHANNEL_NAMES[c]
                        ),
                    );
                }
            }
            if let Some(v) = g.gyro_sigma_deg_s {
                ck.positive(&format!("{p}.gyro_sigma_deg_s"), v);
            }
            if let Some(v) = g.accel_sigma_mg {
                ck.positive(&format!("{p}.accel_sigma_mg"), v);
            }
        }
        if let Some(q) = e.quantisation.as_ref().filter(|q| q.enabled) {
            ck.positive("errors.quantisation.gyro_lsb_deg_s", q.gyro_lsb_deg_s);
            ck.positive("errors.quantisation.accel_lsb_mg", q.accel_lsb_mg);
        }
    }

    /// White-noise σ per sample and channel (rad/s, m/s²); zero where off.
    pub fn white_sigma(&self) -> [f64; N_CHANNELS] {
        let mut s = [0.0; N_CHANNELS];
        if let Some(w) = self.errors.white_noise.as_ref().filter(|w| w.enabled) {
            let root_rate = self.sensor.sample_rate_hz.sqrt();
            for i in 0..3 {
                // ARW deg/√h → rad/√s (÷60), times √rate for the per-sample σ.
                s[i] = w.arw_deg_sqrt_h[i].to_radians() / 60.0 * root_rate;
                s[3 + i] = w.vrw_m_s_sqrt_h[i] / 60.0 * root_rate;
            }
        }
        s
    }

    /// Sample rate, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.sensor.sample_rate_hz
    }
}

pub(super) fn check_vibration_mode(
    ck: &mut Checker,
    p: &str,
    m: &VibrationMode,
    nyquist: f64,
    is_static: bool,
) {
    if !m.enabled {
        return;
    }
    if !(m.freq_hz.is_finite() && m.freq_hz > 0.0 && m.freq_hz < nyquist) {
        ck.push(
            format!("{p}.freq_hz"),
            format!("must be in (0, Nyquist = {nyquist} Hz), got {}", m.freq_hz),
        );
    }
    if !(m.damping_ratio.is_finite() && m.damping_ratio > 0.0 && m.damping_ratio < 1.0) {
        ck.push(
            format!("{p}.damping_ratio"),
            format!("must be in (0, 1), got {}", m.damping_ratio),
        );
    }
    ck.non_negative3(&format!("{p}.accel_rms_m_s2"), &m.accel_rms_m_s2);
    ck.non_negative3(&format!("{p}.gyro_rms_deg_s"), &m.gyro_rms_deg_s);
    if let Some(v) = m.speed_ref_m_s {
        if is_static {
            ck.push(
                format!("{p}.speed_ref_m_s"),
                "a static scenario has no speed",
            );
        } else {
            ck.positive(&format!("{p}.speed_ref_m_s"), v);
        }
    }
    if !(m.idle_fraction.is_finite() && (0.0..=1.0).contains(&m.idle_fraction)) {
        ck.push(
            format!("{p}.idle_fraction"),
            format!("must be in [0, 1], got {}", m.idle_fraction),
        );
    }
}

pub(super) fn gross_channels(names: Option<&[String]>, ck: &mut Checker) -> [bool; N_CHANNELS] {
    match names {
        None => [true; N_CHANNELS],
        Some(list) => {
            let mut a = [false; N_CHANNELS];
            for (i, n) in list.iter().enumerate() {
                match channel_index(n) {
                    Some(c) => a[c] = true,
                    None => ck.push(
                        format!("errors.gross.channels[{i}]"),
                        format!("unknown channel {n:?} (gx gy gz ax ay az)"),
                    ),
                }
            }
            a
        }
    }
}
