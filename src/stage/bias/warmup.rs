//! The bias stage's warm-up model: a gyro channel's first still stretch, turned into the
//! random-walk bias filter the stage runs until a model says otherwise (module docs of
//! [`super`], "Warm-up").

use super::health::BiasModelOrigin;
use super::kf::{BiasKf, ConstantState};
use super::{BiasStage, ChannelKf};
use crate::model::bias_state_space::BiasStateSpace;
use crate::sample::CHANNEL_NAMES;

impl BiasStage {
    /// The warm-up model of gyro channel `c` from its still stretch (module docs): R measured
    /// about a fitted line, a random-walk bias with time constant `warmup.time_constant_s`.
    pub(super) fn finish_warmup(&mut self, c: usize) {
        let Some(buf) = self.ch[c].warm.as_ref() else {
            return;
        };
        let n = buf.len() as f64;
        // Least-squares line through (i, z_i); R = residual variance.
        let tm = (n - 1.0) / 2.0;
        let zm = buf.iter().sum::<f64>() / n;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (i, z) in buf.iter().enumerate() {
            let t = i as f64 - tm;
            sxy += t * (z - zm);
            sxx += t * t;
        }
        let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        let r = buf
            .iter()
            .enumerate()
            .map(|(i, z)| (z - zm - slope * (i as f64 - tm)).powi(2))
            .sum::<f64>()
            / (n - 2.0).max(1.0);
        if !(r.is_finite() && r > 0.0) {
            // A constant stretch (a stuck or coarsely quantised channel): nothing to learn yet.
            // Said once a channel, so a user whose samples stay `WARMING_UP` learns why.
            self.counters.warmup_fit_failures += 1;
            let st = &mut self.ch[c];
            st.constant_stretches += 1;
            if st.constant_stretches == 1 {
                tracing::warn!(
                    "bias: {} read one value ({:.6} rad/s, {:.4} °/s) over a whole still stretch of {:.0} samples ({:.1} s): a stuck axis, or noise below one LSB. Its bias is not identified and samples stay flagged WARMING_UP until it varies at rest (health: `constant_stretches`)",
                    CHANNEL_NAMES[c],
                    zm,
                    zm.to_degrees(),
                    n,
                    n / self.fs
                );
            }
            if let Some(b) = st.warm.as_mut() {
                b.clear();
            }
            return;
        }
        let ss = BiasStateSpace {
            mean: zm + slope * tm, // the line's value at the stretch's end
            order: 0,
            phi: [0.0; crate::model::bias_state_space::MAX_AR_ORDER],
            q: 0.0,
            r,
            gamma: [0.0; crate::model::bias_state_space::MAX_AR_ORDER + 1],
            white_noise_clamped: false,
            sample_rate_hz: self.fs,
        };
        let steps = self.warmup.time_constant_s * self.fs;
        let constant = ConstantState {
            prior_var: r / n,
            q_per_step: r / (steps * steps),
        };
        let kf = BiasKf::new(&ss, Some(constant));
        self.ch[c].est = Some(ChannelKf {
            lead_nominal: kf.lead(self.delay as u32),
            kf,
            ss,
            cusum: None,
            step_size: 0.0,
            rejected_run: 0,
            anchored: true,
            nis: 1.0,
        });
        self.ch[c].warm = None;
        self.ch[c].origin = BiasModelOrigin::WarmUp;
        self.counters.warmup_fits += 1;
    }
}
