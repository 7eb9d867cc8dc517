//! Allan-deviation check of a residual against what the model predicts for it.
//!
//! If the model is right, its one-step residual is white with variance σ², and the overlapping
//! Allan deviation at τ = m/f_s is σ_A(τ) = σ/√m (slope −½ on log-log axes). The estimate's
//! uncertainty: ν σ̂²_A/σ²_A ~ χ²(ν), with the equivalent degrees of freedom for white noise and
//! overlapping estimates (Howe, Allan & Barnes 1981, "Properties of signal sources and measurement
//! methods", Table 1, white FM):  ν = (3(N−1)/(2m) − 2(N−2)/N) · 4m²/(4m² + 5).
//! An averaging time whose one-sided p-value P(χ²(ν) > ν σ̂²_A/σ²_pred) is below α/M (Bonferroni
//! over the M averaging times) shows power the model cannot produce. The *excess* variance
//! σ̂²_A − σ²_pred over those τ is classified by its log-log slope s_ex (of the deviation):
//!   s_ex ≥ +¼  → rate random walk (σ_A = K √(τ/3), slope +½; IEEE Std 952-1997 Annex C),
//!   |s_ex| < ¼ → flicker / bias instability (flat),
//!   s_ex ≤ −¼ → other short-term colour (e.g. a line or an under-fitted correlation).
//! For a rate random walk, K² = 3 σ²_ex(τ)/τ is averaged over the excess region.

use super::oadev_octaves;
use crate::analysis::AnalysisError;
use crate::stats::allan_edf::edf_white;
use crate::stats::check_series;
use crate::stats::special::chi2_sf;
use serde::Serialize;

/// What the Allan deviation of the residual shows.
#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum AllanKind {
    /// No averaging time beyond the white-residual prediction.
    ConsistentWithModel,
    /// Excess rising as +½: a rate random walk the model lacks.
    RateRandomWalk,
    /// Flat excess: flicker (bias instability) the model lacks.
    Flicker,
    /// Excess with a falling slope or too few points to classify.
    OtherExcess,
}

/// One averaging time.
#[derive(Clone, Debug, Serialize)]
pub struct AllanPoint {
    /// Averaging time, s.
    pub tau_s: f64,
    /// Measured overlapping Allan deviation.
    pub adev: f64,
    /// Predicted for a white residual, σ/√m.
    pub predicted: f64,
    /// Equivalent degrees of freedom ν.
    pub edf: f64,
    /// One-sided p-value of the excess.
    pub p_value: f64,
}

/// The finding.
#[derive(Clone, Debug, Serialize)]
pub struct AllanFinding {
    /// Every octave τ.
    pub points: Vec<AllanPoint>,
    /// Classification of the excess.
    pub kind: AllanKind,
    /// Shortest τ with significant excess, s.
    pub excess_from_tau_s: Option<f64>,
    /// Log-log slope of the excess deviation.
    pub excess_slope: Option<f64>,
    /// K² (units²/s) if classified as rate random walk.
    pub rrw_q_per_s: Option<f64>,
}

/// Compare the Allan deviation of `residual` with the white prediction at family-wise level `alpha`.
pub fn allan_check(
    residual: &[f64],
    rate_hz: f64,
    alpha: f64,
) -> Result<AllanFinding, AnalysisError> {
    check_series(residual, 64)?;
    if !crate::analysis::is_pos(rate_hz) || !crate::analysis::in_open_unit(alpha) {
        return Err(AnalysisError::bad("allan_check: rate or alpha"));
    }
    let n = residual.len();
    let mean = residual.iter().sum::<f64>() / n as f64;
    let var = residual
        .iter()
        .map(|v| (v - mean) * (v - mean))
        .sum::<f64>()
        / (n as f64 - 1.0);
    let curve = oadev_octaves(residual, rate_hz);
    // m = 1 is where σ² itself is measured: test from m = 2 on.
    let tested: Vec<(f64, f64)> = curve
        .into_iter()
        .filter(|(tau, _)| (tau * rate_hz).round() >= 2.0)
        .collect();
    let big_m = tested.len().max(1) as f64;
    let points: Vec<AllanPoint> = tested
        .iter()
        .map(|&(tau_s, adev)| {
            let m = (tau_s * rate_hz).round() as usize;
            let predicted = (var / m as f64).sqrt();
            let edf = edf_white(n, m);
            let p_value = chi2_sf(edf * (adev / predicted).powi(2), edf);
            AllanPoint {
                tau_s,
                adev,
                predicted,
                edf,
                p_value,
            }
        })
        .collect();
    let excess: Vec<&AllanPoint> = points
        .iter()
        .filter(|p| p.p_value < alpha / big_m)
        .collect();
    let mut f = AllanFinding {
        points: points.clone(),
        kind: AllanKind::ConsistentWithModel,
        excess_from_tau_s: None,
        excess_slope: None,
        rrw_q_per_s: None,
    };
    if excess.is_empty() {
        return Ok(f);
    }
    f.excess_from_tau_s = Some(excess[0].tau_s);
    f.kind = AllanKind::OtherExcess;
    let pts: Vec<(f64, f64)> = excess
        .iter()
        .filter_map(|p| {
            let ex = p.adev * p.adev - p.predicted * p.predicted;
            (ex > 0.0).then(|| (p.tau_s.ln(), 0.5 * ex.ln()))
        })
        .collect();
    if pts.len() >= 2 {
        let k = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / k;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / k;
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let slope = sxy / sxx;
        f.excess_slope = Some(slope);
        f.kind = if slope >= 0.25 {
            AllanKind::RateRandomWalk
        } else if slope > -0.25 {
            AllanKind::Flicker
        } else {
            AllanKind::OtherExcess
        };
        if f.kind == AllanKind::RateRandomWalk {
            let qs: Vec<f64> = excess
                .iter()
                .map(|p| 3.0 * (p.adev * p.adev - p.predicted * p.predicted).max(0.0) / p.tau_s)
                .collect();
            f.rrw_q_per_s = Some(qs.iter().sum::<f64>() / qs.len() as f64);
        }
    }
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn white_residual_is_consistent() {
        // White noise matches the prediction by construction; at alpha = 0.01 family-wise this
        // seed must not flag (a flag would be a 1 % event).
        let mut rng = Rng::new(4);
        let x: Vec<f64> = (0..30_000).map(|_| rng.normal()).collect();
        let f = allan_check(&x, 100.0, 0.01).unwrap();
        assert_eq!(f.kind, AllanKind::ConsistentWithModel, "{f:?}");
        // And the slope of the measured curve is −½ within the scatter of its long-τ points.
        let (a, b) = (&f.points[0], &f.points[6]);
        let slope = (b.adev / a.adev).ln() / (b.tau_s / a.tau_s).ln();
        assert!((slope + 0.5).abs() < 0.05, "{slope}");
    }

    #[test]
    fn rate_random_walk_is_named_and_its_k_recovered() {
        // Unit white noise + a random walk with increments sd 0.01 per sample at 100 Hz:
        // K² = 0.01² · 100 = 0.01 units²/s. The two Allan curves cross at τ = √(3/(100 K²)) ≈ 1.7 s,
        // so the excess is clear over the long octaves; K² is required within a factor 2 because
        // those octaves have few degrees of freedom (ν ≈ 3–10).
        let mut rng = Rng::new(8);
        let mut rw = 0.0;
        let x: Vec<f64> = (0..60_000)
            .map(|_| {
                rw += 0.01 * rng.normal();
                rw + rng.normal()
            })
            .collect();
        let f = allan_check(&x, 100.0, 0.01).unwrap();
        assert_eq!(f.kind, AllanKind::RateRandomWalk, "{f:?}");
        let q = f.rrw_q_per_s.unwrap();
        assert!(q > 0.005 && q < 0.02, "{q}");
    }

    #[test]
    fn flicker_like_excess_is_named_flicker() {
        // A sum of Gauss–Markov processes with time constants spread one per octave and equal
        // Allan peaks approximates flicker (flat σ_A over the covered range).
        let mut rng = Rng::new(12);
        let n = 200_000;
        let taus: [f64; 8] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0];
        let mut st = [0.0; 8];
        let x: Vec<f64> = (0..n)
            .map(|_| {
                let mut s = 0.0;
                for (j, tau) in taus.iter().enumerate() {
                    let phi = (-0.01f64 / tau).exp();
                    st[j] = phi * st[j] + 0.2 * (1.0 - phi * phi).sqrt() * rng.normal();
                    s += st[j];
                }
                s + rng.normal()
            })
            .collect();
        let f = allan_check(&x, 100.0, 0.01).unwrap();
        assert_eq!(
            f.kind,
            AllanKind::Flicker,
            "{:?} {:?}",
            f.kind,
            f.excess_slope
        );
    }
}
