"""Reference values for src/analysis/detectors.rs: Grubbs' two-sided critical G (alpha = 0.05)
from scipy's t quantile, and Chauvenet's |z| threshold for n = 1000.
Run: python3 tests/reference/detectors.py"""
import math
from scipy import stats

for n in (10, 20, 100, 36000):
    t = stats.t.ppf(1 - 0.05 / (2 * n), n - 2)
    print(f"({n}, {(n - 1) / math.sqrt(n) * math.sqrt(t * t / (n - 2 + t * t))!r}),")
print("chauvenet_z_1000 =", repr(float(stats.norm.ppf(1 - 1 / 4000))))
