"""How well can any test flag a Gauss-Markov wander within 2 min? (docs/model-health.md)

120 one-second means of the output, white with unit variance under H0; under H1 a first-order
Gauss-Markov wander of correlation time tau and standard deviation k (in units of the 1-s mean's
white sd) is added. Two numbers per (tau, k), at false-alarm probability p per test:

* the Neyman-Pearson bound: the power of the most powerful test of that exact alternative (the
  likelihood-ratio quadratic form x'(I - S1^-1)x, its null and alternative laws weighted chi-square
  sums evaluated by Imhof's integral), with the white variance known. No test that flags within
  120 s of the onset at the same p per test can do better;
* the monitor's Allan-ratio statistic R = m A(m)/A(1), m = 8, against its bar once the learned
  no-effect ratio is exact (F(12.44, 1000) quantile; 12.44 = Greenhall-Riley EDF of A(8) over 121
  phase points for random-walk FM, the monitor's choice), by Monte Carlo (20 000 windows, seeded);
* a candidate statistic: the variance of the window's fifteen 8-s means about their mean, over
  its no-effect value (white: chi2(14)/14), on the same windows.

Cross-check only; the product is Rust. Run: python3 tests/reference/wander_power_bound.py
"""

import numpy as np
from scipy import integrate, optimize, stats

N = 120


def imhof_tail(lams, x):
    """P(sum lam_i z_i^2 > x), z_i iid N(0, 1)."""

    def f(u):
        th = 0.5 * np.sum(np.arctan(lams * u)) - 0.5 * x * u
        rho = np.prod((1 + (lams * u) ** 2) ** 0.25)
        return np.sin(th) / (u * rho)

    v, _ = integrate.quad(f, 0, np.inf, limit=2000)
    return 0.5 + v / np.pi


def np_power(tau, k, p):
    lag = np.abs(np.subtract.outer(np.arange(N), np.arange(N)))
    s1 = np.eye(N) + k * k * np.exp(-lag / tau)
    a = np.eye(N) - np.linalg.inv(s1)
    l0 = np.linalg.eigvalsh(a)
    c = np.linalg.cholesky(s1)
    l1 = np.linalg.eigvalsh(c.T @ a @ c)
    x = optimize.brentq(lambda x: imhof_tail(l0, x) - p, 0, 1000)
    return imhof_tail(l1, x)


def allan_ratio(x, m):
    ph = np.concatenate([np.zeros((len(x), 1)), np.cumsum(x, 1)], 1)

    def avar(m):
        t = ph[:, 2 * m :] - 2 * ph[:, m:-m] + ph[:, : -2 * m]
        return (t**2).mean(1) / (2 * m * m)

    return m * avar(m) / avar(1)


def ratio_power(tau, k, p, rng, windows=20000):
    phi = np.exp(-1 / tau)
    g = np.zeros((windows, N))
    g[:, 0] = k * rng.standard_normal(windows)
    e = k * np.sqrt(1 - phi**2) * rng.standard_normal((windows, N))
    for i in range(1, N):
        g[:, i] = phi * g[:, i - 1] + e[:, i]
    x = rng.standard_normal((windows, N)) + g
    bar = stats.f.ppf(1 - p, 12.44, 1000)
    v = 8 * x.reshape(windows, N // 8, 8).mean(2).var(1, ddof=1)
    v_bar = stats.chi2.ppf(1 - p, N // 8 - 1) / (N // 8 - 1)
    return (allan_ratio(x, 8) >= bar).mean(), bar, (v >= v_bar).mean(), v_bar


rng = np.random.default_rng(17)
p = 1e-5
for tau in [20.0, 60.0]:
    for k in [0.5, 1.0, 2.0, 4.0]:
        pr, bar, pv, v_bar = ratio_power(tau, k, p, rng)
        print(
            f"tau {tau:.0f} s, k {k}: P(flag by 120 s) Neyman-Pearson bound {np_power(tau, k, p):.3f}, "
            f"Allan ratio (m = 8, bar {bar:.2f}) {pr:.3f}, 8-s means' variance (bar {v_bar:.2f}) {pv:.3f}"
        )
