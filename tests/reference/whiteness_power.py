"""Power of the monitor's whiteness test on one window (docs/model-health.md, src/stage/monitor/whiteness.rs).

An AR(1) component (pole phi per sample, sd k x the white noise, variance ratio a = k^2) adds
rho_j = phi^j a/(1+a) to the autocorrelations. Over a window of N samples the Ljung-Box change
statistic over lags 1..h is ~ noncentral chi2(h, lam), lam = N sum_{j<=h} rho_j^2; the bar is the
chi2(h) quantile at 1 - p (the F bar once the learned scale is well known). The Neyman-Pearson
bound for that exact alternative (locally: the score test sum_j rho_j r_j, one-sided) has power
Phi(sqrt(N sum_j rho_j^2) - z_{1-p}). The 1-s segment demeaning is ignored (it removes < 3 %
of an AR(1) of phi <= 0.8). Run: python3 tests/reference/whiteness_power.py
"""
import numpy as np
from scipy import stats

P, H, FS = 1e-5, 10, 100.0
bar = stats.chi2.ppf(1 - P, H)
z = stats.norm.ppf(1 - P)
print(f"bar chi2({H}) at 1-{P:g}: {bar:.1f}")
for window_s in (60.0, 90.0, 120.0):
    n = window_s * FS
    for phi, k in ((0.8, 0.15), (0.8, 0.2), (0.8, 0.3), (0.8, 0.4), (0.5, 0.3), (0.5, 0.5)):
        a = k * k
        rho = phi ** np.arange(1, 2000) * a / (1 + a)
        lam = n * np.sum(rho[:H] ** 2)
        power = stats.ncx2.sf(bar, H, lam)
        np_bound = stats.norm.cdf(np.sqrt(n * np.sum(rho**2)) - z)
        print(f"window {window_s:.0f} s, phi {phi}, sd {k}x: lam {lam:6.1f}, "
              f"P(flag) Ljung-Box {power:.3f}, Neyman-Pearson bound {np_bound:.3f}")
