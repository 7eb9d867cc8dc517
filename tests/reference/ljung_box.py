"""Reference values for src/analysis/ljung_box.rs.

Writes tests/fixtures/ljung_box_ar1.csv (AR(1), phi = 0.3, 2000 values, numpy seed 6) and prints
statsmodels' Ljung-Box Q and p at lag 10 and scipy's chi-square survival values used in the tests.
Run from the crate root: python3 tests/reference/ljung_box.py
"""
import numpy as np
from scipy import stats
from statsmodels.stats.diagnostic import acorr_ljungbox

rng = np.random.default_rng(6)
e = rng.standard_normal(2000)
x = np.zeros(2000)
for n in range(1, 2000):
    x[n] = 0.3 * x[n - 1] + e[n]
with open("tests/fixtures/ljung_box_ar1.csv", "w") as f:
    for v in x:
        f.write(f"{v:.17g}\n")
x = np.loadtxt("tests/fixtures/ljung_box_ar1.csv")
r = acorr_ljungbox(x, lags=[10], return_df=True)
print("LB Q", repr(float(r["lb_stat"].iloc[0])), "p", repr(float(r["lb_pvalue"].iloc[0])))
for xx, k in [(10.0, 5.0), (30.0, 20.0), (150.0, 100.0), (0.5, 3.0)]:
    print("chi2_sf", xx, k, repr(float(stats.chi2.sf(xx, k))))
