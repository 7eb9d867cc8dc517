"""Reference values for src/analysis/spectrum.rs.

Writes tests/fixtures/spectrum_line.csv (1000 samples at 100 Hz: white noise, numpy seed 8, plus
0.8 sin(2 pi 12.34 t)) and prints scipy.signal.periodogram(window='hann') at a few bins.
Run from the crate root: python3 tests/reference/spectrum.py
"""
import numpy as np
from scipy import signal

rng = np.random.default_rng(8)
t = np.arange(1000) / 100.0
x = rng.standard_normal(1000) + 0.8 * np.sin(2 * np.pi * 12.34 * t)
with open("tests/fixtures/spectrum_line.csv", "w") as f:
    for v in x:
        f.write(f"{v:.17g}\n")
x = np.loadtxt("tests/fixtures/spectrum_line.csv")
fr, p = signal.periodogram(x, 100.0, window="hann", detrend="constant", scaling="density")
for k in [0, 50, 123, 500]:
    print(k, repr(float(fr[k])), repr(float(p[k])))
