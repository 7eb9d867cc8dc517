"""The ADIS16405 bench's raw data around the monitor's wander alarms (docs/model-health.md).

Raw 1-s means of every axis (no imuprep stage in between); for 120-s windows every 8 s the
monitor's statistic R = 8 A(8 s)/A(1 s), and the largest distance of a 10-s mean of the window
from the window's median, in units of the white part of the 10-s means' sd (1.4826 MAD of
successive 10-s means / sqrt 2). Prints R over each channel's median R and the excursions at the
start times of the monitor's alarms (tests/model_health.rs prints them), the correlation of ln R
between axes, and how many windows hold an excursion of >= 4 sd on at least two accelerometer axes.

Cross-check only; reads ../shared/data/real (skips visibly when absent).
Run: python3 tests/reference/adis_wander_episodes.py
"""

import os
import sys

import numpy as np
import pandas as pd

PATH = "../shared/data/real/adis16405_static/adis_16405_imu1.csv.gz"
ALARMS_S = [1310.9, 2047.2, 6720.8, 6936.8, 8705.2, 8752.8, 9496.8]
NAMES = ["gx", "gy", "gz", "ax", "ay", "az"]

if not os.path.exists(PATH):
    print(f"SKIPPED: {PATH} is absent", file=sys.stderr)
    sys.exit(0)

x = pd.read_csv(PATH).iloc[:, 1:7].to_numpy()
n = len(x) // 100
m1 = x[: n * 100].reshape(n, 100, 6).mean(1)  # 1-s means (100 Hz)
k10 = n // 10
m10 = m1[: k10 * 10].reshape(k10, 10, 6).mean(1)
sd10 = 1.4826 * np.median(np.abs(np.diff(m10, axis=0)), 0) / np.sqrt(2)


def ratio(b, m=8):
    ph = np.concatenate([[0.0], np.cumsum(b)])

    def avar(m):
        t = ph[2 * m :] - 2 * ph[m:-m] + ph[: -2 * m]
        return (t**2).mean() / (2 * m * m)

    return m * avar(m) / avar(1)


def excursion(t0):
    w = m10[int(t0) // 10 : int(t0) // 10 + 12]
    return np.abs(w - np.median(w, 0)).max(0) / sd10


starts = np.arange(0, n - 120 + 1, 8)
r = np.array([[ratio(m1[s : s + 120, c]) for c in range(6)] for s in starts])
med = np.median(r, 0)
print("median R per channel:", " ".join(f"{c} {v:.2f}" for c, v in zip(NAMES, med)))
print("alarm window start | R / median R (gx gy gz ax ay az) | 10-s excursion / 10-s white sd")
for t in ALARMS_S:
    i = int(np.argmin(np.abs(starts - t)))
    z = r[i] / med
    e = excursion(t)
    print(f"{t:8.1f} s | " + " ".join(f"{v:4.1f}" for v in z) + " | " + " ".join(f"{v:4.1f}" for v in e))
c = np.corrcoef(np.log(r).T)
print("corr of ln R: gyro pairs", " ".join(f"{c[i, j]:.2f}" for i, j in [(0, 1), (0, 2), (1, 2)]),
      "| accelerometer pairs", " ".join(f"{c[i, j]:.2f}" for i, j in [(3, 4), (3, 5), (4, 5)]))
exc = np.array([excursion(s)[3:] for s in starts])
hit = (exc >= 4.0).sum(1) >= 2
episodes = int(np.sum(np.diff(np.concatenate([[0], hit.astype(int)])) == 1))
print(f"windows with >= 4 sd on >= 2 accelerometer axes: {hit.sum()} of {len(starts)}, "
      f"{episodes} separate episodes in {n / 3600:.2f} h")
