"""Reference values for tests/reference_checks.rs (statsmodels, PyWavelets, allantools).

Writes tests/fixtures/ar_wavelet_allan.csv (one column `x`, 3000 rows, deterministic: numpy
PCG64 seed 20130523) and prints the values pasted into the Rust test.
Run from the crate root: python3 tests/reference/make_fixture_and_reference.py
Versions used: statsmodels 0.15.0, PyWavelets 1.8.0, allantools 2024.06, numpy 2.4.6.
"""
import os
import warnings

import numpy as np
import pywt
import allantools
from statsmodels.regression.linear_model import burg, yule_walker

here = os.path.dirname(os.path.abspath(__file__))
path = os.path.join(here, "..", "fixtures", "ar_wavelet_allan.csv")

rng = np.random.default_rng(20130523)
n = 3000
e = rng.standard_normal(n + 200)
# AR(3) bias (phi = 1.2, -0.5, 0.1) plus white measurement noise and an offset, like a gyro
v = np.zeros(n + 200)
for t in range(3, n + 200):
    v[t] = 1.2 * v[t - 1] - 0.5 * v[t - 2] + 0.1 * v[t - 3] + 0.01 * e[t]
x = 0.05 + v[200:] + 0.004 * rng.standard_normal(n)
if not os.path.exists(path):
    with open(path, "w") as f:
        f.write("x\n")
        for val in x:
            f.write(repr(float(val)) + "\n")
# always read back the stored fixture, so the printed values describe exactly the file
x = np.loadtxt(path, skiprows=1)

np.set_printoptions(precision=17)
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    for p in (1, 3, 10):
        rho, sigma = yule_walker(x, order=p, method="mle")
        print(f"yule_walker p={p} coeffs={list(map(float, rho))} noise_var={float(sigma**2)!r}")
for p in (1, 3, 10):
    rho, s2 = burg(x, order=p, demean=True)
    print(f"burg p={p} coeffs={list(map(float, rho))} noise_var={float(s2)!r}")

# wavelet denoise on an odd length (2999), periodization, 4 levels, universal soft threshold
xw = x[:2999]
coeffs = pywt.wavedec(xw, "db4", mode="periodization", level=4)
sigma = np.median(np.abs(coeffs[-1])) / 0.6745
thr = sigma * np.sqrt(2 * np.log(len(xw)))
den = [coeffs[0]] + [pywt.threshold(c, thr, mode="soft") for c in coeffs[1:]]
y = pywt.waverec(den, "db4", mode="periodization")[: len(xw)]
print(f"wavelet sigma={float(sigma)!r} threshold={float(thr)!r}")
for i in (0, 1, 2, 500, 1499, 2500, 2997, 2998):
    print(f"wavelet y[{i}]={float(y[i])!r}")
print(f"wavelet sum_sq={float(np.sum(y * y))!r}")
yr = pywt.waverec(coeffs, "db4", mode="periodization")[: len(xw)]
print(f"wavelet zero-threshold max|x - rec|={float(np.max(np.abs(yr - xw)))!r}")

# overlapping Allan deviation, rate 100 Hz, octave taus
taus, ad, ade, ns = allantools.oadev(x, rate=100.0, data_type="freq", taus="octave")
for t, a, k in zip(taus, ad, ns):
    print(f"oadev tau={float(t)!r} adev={float(a)!r} n={int(k)}")
