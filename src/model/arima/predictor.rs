//! The fixed-size one-step predictor the online gross-error stage runs.

use super::*;

/// Fixed-size one-step ARIMA predictor (p ≤ 3, d ≤ 1, q ≤ 2): no heap, `Copy`.
///
/// The ARMA part is the fitted model; what it is centred on can be the fitted constant or a
/// locally tracked one:
///
/// * d = 0: `x̂_t = m_t + Σφ_i u_{t−i} + Σθ_j e_{t−j}` with deviations `u_s = x_s − m_s` from a
///   centre `m_t`. With `level_alpha = 0`, `m_t = μ = c/(1−Σφ)` and this is exactly the model.
///   With `level_alpha = α > 0`, `m_t = ℓ_{t−1} + b_{t−1}` is Holt's local linear trend of the
///   values fed in: `ℓ_t = m_t + α (x_t − m_t)`, `b_t = b_{t−1} + β (ℓ_t − ℓ_{t−1} − b_{t−1})`
///   (`β = trend_beta`; β = 0 is a local level only).
/// * d = 1: `x̂_t = x_{t−1} + b_t + Σφ_i (w_{t−i} − b_t) + Σθ_j e_{t−j}`, `w = ∇x`, where `b_t` is the
///   fitted mean of w (`trend_beta = 0`: exactly the model, as `b(1−Σφ) = c`) or a local mean
///   `b_t = b_{t−1} + β (w_{t−1} − b_{t−1})`.
///
/// Why: a model identified on a stationary stretch (a vehicle at rest: white noise around a bias)
/// would pull every prediction back to the rest value during a manoeuvre it has never seen. A
/// vehicle's motion is smooth at the sample scale, i.e. locally linear, which a local trend
/// follows with no steady-state lag; the price on stationary data is a small inflation of the
/// prediction variance (measured by the k-sweep). `slope()` exposes `b` (units per sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArimaPredictor {
    p: usize,
    d: usize,
    q: usize,
    ar: [f64; MAX_P],
    ma: [f64; MAX_Q],
    /// Fitted mean of w, c/(1−Σφ).
    mean: f64,
    level_alpha: f64,
    trend_beta: f64,
    /// d = 0: Holt level ℓ_{t−1} (or μ).
    level: f64,
    /// d = 0: Holt trend b_{t−1}; d = 1: (local) mean of w.
    slope: f64,
    /// d = 0: u_{t−1..t−p}; d = 1: w_{t−1..t−p}.
    hist: [f64; MAX_P],
    /// e_{t−1}, e_{t−2}.
    e_hist: [f64; MAX_Q],
    /// x_{t−1}.
    last: f64,
}

impl ArimaPredictor {
    /// Predictor for `model` (validated against the online limits). `level_alpha` (d = 0) and
    /// `trend_beta` are the local-trend weights per sample (0 = the fitted constant). Starts at
    /// the model mean; call [`ArimaPredictor::reseed`] before use.
    pub fn new(
        model: &ArimaChannelModel,
        level_alpha: f64,
        trend_beta: f64,
    ) -> Result<Self, ArimaError> {
        model.validate(true)?;
        for (name, v) in [("level_alpha", level_alpha), ("trend_beta", trend_beta)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(ArimaError::InvalidModel(format!(
                    "{name} = {v} must be in [0, 1]"
                )));
            }
        }
        let mut ar = [0.0; MAX_P];
        ar[..model.p].copy_from_slice(&model.ar);
        let mut ma = [0.0; MAX_Q];
        ma[..model.q].copy_from_slice(&model.ma);
        let mean = model.mean();
        let level_alpha = if model.d == 0 { level_alpha } else { 0.0 };
        // For d = 0 a trend needs a level to ride on.
        let trend_beta = if model.d == 0 && level_alpha == 0.0 {
            0.0
        } else {
            trend_beta
        };
        Ok(ArimaPredictor {
            p: model.p,
            d: model.d,
            q: model.q,
            ar,
            ma,
            mean,
            level_alpha,
            trend_beta,
            level: if model.d == 0 { mean } else { 0.0 },
            slope: if model.d == 1 { mean } else { 0.0 },
            hist: [0.0; MAX_P],
            e_hist: [0.0; MAX_Q],
            last: if model.d == 0 { mean } else { 0.0 },
        })
    }

    /// Restart from recent values (newest first), zero past innovations. With a local trend,
    /// level and slope restart from the least-squares line through the values (slope 0 for fewer
    /// than 3); otherwise from the model.
    pub fn reseed(&mut self, recent_newest_first: &[f64]) {
        let Some(&newest) = recent_newest_first.first() else {
            return;
        };
        let v = &recent_newest_first[..recent_newest_first.len().min(MAX_P + MAX_D)];
        let n = v.len();
        self.e_hist = [0.0; MAX_Q];
        self.last = newest;
        // Least-squares line through (−i, v_i): value at i = 0 and slope per sample.
        let (line0, line_slope) = if n >= 3 {
            let nf = n as f64;
            let tm = -(nf - 1.0) / 2.0;
            let vm = v.iter().sum::<f64>() / nf;
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for (i, x) in v.iter().enumerate() {
                let t = -(i as f64) - tm;
                sxy += t * (x - vm);
                sxx += t * t;
            }
            let b = sxy / sxx;
            (vm - b * tm, b)
        } else {
            (v.iter().sum::<f64>() / n as f64, 0.0)
        };
        if self.d == 0 {
            if self.level_alpha > 0.0 {
                let b = if self.trend_beta > 0.0 {
                    line_slope
                } else {
                    0.0
                };
                self.level = line0;
                self.slope = b;
                for i in 0..MAX_P {
                    let x = v.get(i).copied().unwrap_or(v[n - 1]);
                    self.hist[i] = x - (self.level - b * i as f64);
                }
            } else {
                for i in 0..MAX_P {
                    self.hist[i] = v.get(i).copied().unwrap_or(v[n - 1]) - self.mean;
                }
            }
        } else {
            // w_{t−i} = v_{i} − v_{i+1} where available, else the current mean of w.
            if self.trend_beta > 0.0 {
                self.slope = if n >= 3 {
                    line_slope
                } else if n == 2 {
                    v[0] - v[1]
                } else {
                    0.0
                };
            }
            for i in 0..MAX_P {
                self.hist[i] = if i + 1 < n {
                    v[i] - v[i + 1]
                } else {
                    self.slope
                };
            }
        }
    }

    /// Centre of the d = 0 prediction, m_t.
    #[inline]
    fn centre(&self) -> f64 {
        if self.level_alpha > 0.0 {
            self.level + self.slope
        } else {
            self.mean
        }
    }

    /// One-step prediction of the next value.
    #[inline]
    pub fn predict(&self) -> f64 {
        let mut y = 0.0;
        for j in 0..self.q {
            y += self.ma[j] * self.e_hist[j];
        }
        if self.d == 1 {
            let b = self.slope;
            y += self.last + b;
            for i in 0..self.p {
                y += self.ar[i] * (self.hist[i] - b);
            }
        } else {
            y += self.centre();
            for i in 0..self.p {
                y += self.ar[i] * self.hist[i];
            }
        }
        y
    }

    /// Feed the value accepted for this step and its innovation (value − prediction).
    #[inline]
    pub fn update(&mut self, x: f64, e: f64) {
        let h = if self.d == 1 {
            let w = x - self.last;
            if self.trend_beta > 0.0 {
                self.slope += self.trend_beta * (w - self.slope);
            }
            w
        } else {
            let m = self.centre();
            if self.level_alpha > 0.0 {
                let new_level = m + self.level_alpha * (x - m);
                self.slope += self.trend_beta * (new_level - self.level - self.slope);
                self.level = new_level;
            }
            x - m
        };
        for i in (1..MAX_P).rev() {
            self.hist[i] = self.hist[i - 1];
        }
        self.hist[0] = h;
        for j in (1..MAX_Q).rev() {
            self.e_hist[j] = self.e_hist[j - 1];
        }
        self.e_hist[0] = e;
        self.last = x;
    }

    /// Restart at value `x` moving with `slope` (units per sample): past innovations and
    /// deviations zero, the local trend (if enabled) set to `slope`.
    pub fn restart(&mut self, x: f64, slope: f64) {
        self.e_hist = [0.0; MAX_Q];
        self.last = x;
        if self.d == 0 {
            if self.level_alpha > 0.0 {
                self.level = x;
                self.slope = if self.trend_beta > 0.0 { slope } else { 0.0 };
            }
            self.hist = [if self.level_alpha > 0.0 {
                0.0
            } else {
                x - self.mean
            }; MAX_P];
        } else {
            if self.trend_beta > 0.0 {
                self.slope = slope;
            }
            self.hist = [self.slope; MAX_P];
        }
    }

    /// Model orders (p, d, q).
    pub fn order(&self) -> (usize, usize, usize) {
        (self.p, self.d, self.q)
    }

    /// The last value fed (x_{t−1}).
    #[inline]
    pub fn last(&self) -> f64 {
        self.last
    }

    /// Local slope b (units per sample): Holt's trend (d = 0) or the mean of ∇x (d = 1); 0 for a
    /// d = 0 model without a local trend.
    #[inline]
    pub fn slope(&self) -> f64 {
        self.slope
    }
}
