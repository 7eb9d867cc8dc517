"""Reference values for src/stats/line.rs (the strongest line: its frequency and least-squares fit).

The series: tests/fixtures/ljung_box_ar1.csv (AR(1), phi = 0.3, 2000 values; written by
tests/reference/ljung_box.py) plus 0.8 sin(w n) - 0.6 cos(w n), w = 2 pi 0.2213 rad per sample.
Prints, for the unit test `the_line_agrees_with_numpy_and_scipy`:
- the frequency maximising |sum (x_n - mean) e^{-i w n}|^2 within one bin of the periodogram's peak
  (scipy.optimize.minimize_scalar, bounded, xatol 1e-12), and
- the least-squares a, b (with an intercept) of a sin(w n) + b cos(w n) at that frequency
  (numpy.linalg.lstsq).
Run from the crate root: python3 tests/reference/line_fit.py
"""
import numpy as np
from scipy.optimize import minimize_scalar

noise = np.loadtxt("tests/fixtures/ljung_box_ar1.csv")
n = len(noise)
i = np.arange(n)
w0 = 2 * np.pi * 0.2213
x = noise + 0.8 * np.sin(w0 * i) - 0.6 * np.cos(w0 * i)
d = x - x.mean()


def power(w):
    return abs(np.sum(d * np.exp(-1j * w * i))) ** 2


p = np.abs(np.fft.rfft(d * np.hanning(n + 1)[:-1])) ** 2
j = int(np.argmax(p[4:])) + 4
b = 2 * np.pi / n
r = minimize_scalar(lambda w: -power(w), bounds=(b * (j - 1), b * (j + 1)), method="bounded",
                    options={"xatol": 1e-12})
w = r.x
A = np.column_stack([np.sin(w * i), np.cos(w * i), np.ones(n)])
coef = np.linalg.lstsq(A, x, rcond=None)[0]
print("peak bin", j)
print("omega", repr(float(w)))
print("a", repr(float(coef[0])), "b", repr(float(coef[1])))
