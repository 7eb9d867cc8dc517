"""Reference overlapping Allan deviations for the test-only ADEV helper in tests/sim_realism.rs.

Writes tests/fixtures/sim_adev_fixture.csv (3000 rate samples at 1 Hz: white noise sd 1 plus a
random walk with step sd 0.02, numpy default_rng(12345), %.17g so the Rust test reads the exact
f64 values) and prints allantools.oadev at m = 1, 4, 16, 64, 256.
Run: python3 tests/reference/sim_allan_oadev.py
"""
import os
import numpy as np
import allantools

rng = np.random.default_rng(12345)
n = 3000
y = rng.standard_normal(n) + np.cumsum(0.02 * rng.standard_normal(n))
here = os.path.dirname(os.path.abspath(__file__))
path = os.path.join(here, "..", "fixtures", "sim_adev_fixture.csv")
with open(path, "w") as f:
    for v in y:
        f.write("%.17g\n" % v)
taus = [1, 4, 16, 64, 256]
t, ad, ade, ns = allantools.oadev(y, rate=1.0, data_type="freq", taus=taus)
for ti, a in zip(t, ad):
    print("m", int(ti), "oadev", repr(float(a)))
