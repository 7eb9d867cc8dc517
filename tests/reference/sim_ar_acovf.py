"""Reference autocovariances for the simulator's AR bias (tests/sim_realism.rs).

Prints the theoretical autocovariance gamma_0..gamma_3 of the AR(2) used in
replay/static_bench.toml (phi = 1.9795, -0.97951, unit innovation variance) and of an AR(3),
as computed by statsmodels.tsa.arima_process.arma_acovf.
Run: python3 tests/reference/sim_ar_acovf.py
"""
import numpy as np
from statsmodels.tsa.arima_process import arma_acovf

for phi in ([1.9795, -0.97951], [0.5, 0.2, -0.3]):
    g = arma_acovf(np.r_[1.0, -np.asarray(phi)], np.r_[1.0], nobs=4, sigma2=1.0)
    print("phi", phi, "gamma", ", ".join(repr(float(x)) for x in g))
