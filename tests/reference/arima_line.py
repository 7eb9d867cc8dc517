#!/usr/bin/env python3
"""ARIMA identification on a channel carrying a vibration line: imuprep against statsmodels.

For each case (seed, line frequency Hz, amplitude in noise σ) a 200-s, 100-Hz log is written
whose gx is AR(1) noise (φ 0.3, σ 0.01) plus a sine; `imuprep import` and `imuprep fit
--train-s 20` identify gx's ARIMA on its first 2000 samples, and statsmodels' ARIMA picks the
lowest-AIC (p, 0, q), p ≤ 3, q ≤ 2, on the same 2000. Both are scored by their one-step MSE
on the held-out rest (conditional one-step errors of the fitted ARMA; the innovation variance
is 1e-4). Usage: python3 tests/reference/arima_line.py BIN [BIN_BEFORE]
"""
import subprocess, sys, tempfile, tomllib, warnings
from pathlib import Path

import numpy as np

warnings.filterwarnings("ignore")
CASES = [(2, 22.0, 10), (7, 11.2, 10), (1, 7.37, 3), (3, 0.566, 5), (4, 7.37, 30), (5, 31.3, 2), (6, 22.0, 3)]
N, FS, TRAIN = 20000, 100.0, 2000


def series(seed, f, a):
    rng = np.random.default_rng(seed)
    e = rng.normal(0, 0.01, N)
    x = np.zeros(N)
    for i in range(1, N):
        x[i] = 0.3 * x[i - 1] + e[i]
    t = np.arange(N) / FS
    gx = x + a * 0.01 * np.sin(2 * np.pi * f * t + 0.3)
    others = [rng.normal(0, 0.01, N), rng.normal(0, 0.01, N), rng.normal(0, 0.05, N),
              rng.normal(0, 0.05, N), 9.81 + rng.normal(0, 0.05, N)]
    return t, gx, others


def one_step_mse(x, const, ar, ma):
    p, q = len(ar), len(ma)
    e = np.zeros(len(x))
    for t in range(len(x)):
        v = const + sum(ar[i] * x[t - 1 - i] for i in range(p) if t - 1 - i >= 0)
        v += sum(ma[j] * e[t - 1 - j] for j in range(q) if t - 1 - j >= 0)
        e[t] = x[t] - v
    return float(np.mean(e[TRAIN + 50:] ** 2))


def imuprep(bin_, d, gx):
    out = d / ("fit_" + Path(bin_).name)
    subprocess.run([bin_, "fit", str(d / "line.log"), "--train-s", "20", "--out-dir", str(out)],
                   check=True, capture_output=True)
    c = [c for c in tomllib.load(open(out / "arima.toml", "rb"))["channels"] if c["channel"] == "gx"][0]
    return (c["p"], c["d"], c["q"]), one_step_mse(gx, c["constant"], c["ar"], c["ma"])


def statsmodels_best(gx):
    from statsmodels.tsa.arima.model import ARIMA
    best = None
    for p in range(4):
        for q in range(3):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    r = ARIMA(gx[:TRAIN], order=(p, 0, q)).fit()
            except Exception:
                continue
            if best is None or r.aic < best[0]:
                best = (r.aic, p, q, r)
    _, p, q, r = best
    res = gx - r.apply(gx).fittedvalues
    return (p, 0, q), float(np.mean(res[TRAIN + 50:] ** 2))


def main():
    bins = sys.argv[1:]
    for seed, f, a in CASES:
        t, gx, others = series(seed, f, a)
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            with open(d / "line.csv", "w") as o:
                o.write("t,gx,gy,gz,ax,ay,az\n")
                for i in range(N):
                    o.write("%.4f," % t[i] + ",".join("%.9f" % c[i] for c in [gx] + others) + "\n")
            subprocess.run([bins[0], "import", str(d / "line.csv"), "-o", str(d / "line.log")],
                           check=True, capture_output=True)
            row = [f"seed {seed}, {f} Hz, {a} σ"]
            for b in bins:
                order, mse = imuprep(b, d, gx)
                row.append(f"{Path(b).name} {order} {mse / 1e-4:.3f}")
            order, mse = statsmodels_best(gx)
            row.append(f"statsmodels {order} {mse / 1e-4:.3f}")
            print(" | ".join(row), flush=True)


if __name__ == "__main__":
    main()
