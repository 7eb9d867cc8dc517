"""Reference values for tests/arima_reference.rs.

Writes tests/fixtures/arma11.csv (deterministic: numpy PCG64 seed 20130211) and prints the values
pasted into the Rust test. Run from the crate root: python3 tests/reference/arima_statsmodels.py

* ADF, ACF, PACF (ldb), Ljung-Box, MacKinnon p/crit: statsmodels itself.
* CSS estimates: statsmodels has had no CSS estimator since `tsa.arima_model` was removed (0.13),
  so the CSS optimum is computed here directly: the same conditional residual recursion (condition on
  the first p differenced values, pre-sample innovations 0) minimised by scipy.optimize.least_squares
  to 1e-15 tolerances. statsmodels' exact Gaussian MLE (tsa.arima.model.ARIMA, state space) is
  printed beside it: it maximises a different objective (the exact likelihood, including the first
  observations' unconditional distribution), so it agrees with CSS only to O(1/N).
"""
import os
import numpy as np
import scipy
import statsmodels
from scipy.optimize import least_squares
from statsmodels.tsa.stattools import adfuller, acf, pacf
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa.adfvalues import mackinnonp, mackinnoncrit
from statsmodels.tsa.arima.model import ARIMA

here = os.path.dirname(os.path.abspath(__file__))
fixtures = os.path.join(here, "..", "fixtures")
os.makedirs(fixtures, exist_ok=True)

print(f"# numpy {np.__version__} scipy {scipy.__version__} statsmodels {statsmodels.__version__}")

# ARMA(1,1) with intercept: x_t = c + phi x_{t-1} + e_t + theta e_{t-1}
N, c, phi, theta, sigma = 2000, 0.05, 0.6, 0.3, 0.02
rng = np.random.Generator(np.random.PCG64(20130211))
burn = 500
e = sigma * rng.standard_normal(N + burn)
x = np.zeros(N + burn)
for t in range(1, N + burn):
    x[t] = c + phi * x[t - 1] + e[t] + theta * e[t - 1]
x = x[burn:]
np.savetxt(os.path.join(fixtures, "arma11.csv"), x, fmt="%.17g", header="x", comments="")
y = np.cumsum(x)  # an I(1) series for the d = 1 path (the Rust test forms it the same way)


def css_resid(beta, w, p, q):
    cc, ar, ma = beta[0], beta[1:1 + p], beta[1 + p:]
    n = len(w)
    ee = np.zeros(n)
    for t in range(p, n):
        v = w[t] - cc
        for i in range(p):
            v -= ar[i] * w[t - 1 - i]
        for j in range(q):
            if t - 1 - j >= p:
                v -= ma[j] * ee[t - 1 - j]
        ee[t] = v
    return ee[p:]


def css_fit(w, p, q):
    b0 = np.concatenate([[np.mean(w) * 0.5], np.full(p, 0.3), np.full(q, 0.1)])
    r = least_squares(css_resid, b0, args=(w, p, q), xtol=1e-15, ftol=1e-15, gtol=1e-15,
                      method="lm", max_nfev=100000)
    res = css_resid(r.x, w, p, q)
    return r.x, float(np.sum(res ** 2) / len(res))


def show(name, v):
    if np.ndim(v) == 0:
        print(f"{name} = {float(v)!r}")
    else:
        print(f"{name} = [{', '.join(repr(float(a)) for a in v)}]")


print("## ADF on x (regression='c', autolag='AIC')")
r = adfuller(x, regression="c", autolag="AIC", result_object=False)
show("adf_x_stat", r[0]); show("adf_x_p", r[1]); print(f"adf_x_lag = {r[2]}"); print(f"adf_x_nobs = {r[3]}")
show("adf_x_crit", [r[4]["1%"], r[4]["5%"], r[4]["10%"]]); show("adf_x_icbest", r[5])
print("## ADF on y = cumsum(x)")
r = adfuller(y, regression="c", autolag="AIC", result_object=False)
show("adf_y_stat", r[0]); show("adf_y_p", r[1]); print(f"adf_y_lag = {r[2]}"); print(f"adf_y_nobs = {r[3]}")
show("adf_y_crit", [r[4]["1%"], r[4]["5%"], r[4]["10%"]])
print("## ADF on x with fixed lag 4 (autolag=None, maxlag=4)")
r = adfuller(x, maxlag=4, regression="c", autolag=None, result_object=False)
show("adf_x4_stat", r[0]); print(f"adf_x4_nobs = {r[3]}")
print("## MacKinnon")
show("mackinnonp", [mackinnonp(s, regression="c", N=1) for s in (-5.0, -3.0, -2.0, -1.0, 0.5)])
show("mackinnoncrit_100", mackinnoncrit(N=1, regression="c", nobs=100))
print("## ACF / PACF(ldb) / Ljung-Box on x")
show("acf10", acf(x, nlags=10, fft=False))
show("pacf10", pacf(x, nlags=10, method="ldb"))
lb = acorr_ljungbox(x, lags=[10], model_df=2)
show("lb10_q", lb["lb_stat"].iloc[0]); show("lb10_p", lb["lb_pvalue"].iloc[0])
print("## CSS (scipy least_squares on the conditional residuals)")
b, s2 = css_fit(x, 1, 1)
show("css_x_101", b); show("css_x_101_sigma2", s2)
b, s2 = css_fit(x, 2, 1)
show("css_x_201", b); show("css_x_201_sigma2", s2)
b, s2 = css_fit(np.diff(y), 1, 1)
show("css_y_111", b); show("css_y_111_sigma2", s2)
print("## statsmodels exact MLE ARIMA(1,0,1) trend='c' (const is the MEAN)")
m = ARIMA(x, order=(1, 0, 1), trend="c").fit()
show("mle_x_101 [mean, ar, ma, sigma2]", m.params)
show("mle_x_101_bse", m.bse)
