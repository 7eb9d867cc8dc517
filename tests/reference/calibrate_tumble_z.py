"""How honest are `imuprep calibrate`'s σ on the simulated tumble? (cross-check for
tests/calibrate_sim.rs, which asserts |z| < 4.5 on five seeds).

For each seed: `imuprep simulate replay/tumble.toml --seed S`, `imuprep calibrate`, then
z = (fitted − true) / σ for the nine accelerometer parameters (scale, bias, misalignment of
L = chol(A Aᵀ)) and the nine gyro entries (M = G Qᵀ, Q = L⁻¹A), the truth taken from the TOML.
Prints the RMS and the largest |z| per triad; with honest σ the RMS is ≈ 1.

    cargo build --release
    python3 tests/reference/calibrate_tumble_z.py 1 41        # seeds 1..40, about 80 s
"""

import json
import pathlib
import subprocess
import sys
import tempfile
import tomllib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = ROOT / "target" / "release" / "imuprep"
SCENARIO = ROOT / "replay" / "tumble.toml"


def triad(ppm, mrad):
    return np.eye(3) + np.diag(np.array(ppm) * 1e-6) + np.array(mrad) * 1e-3


def truth():
    e = tomllib.loads(SCENARIO.read_text())["errors"]
    a = triad(e["scale_factor"]["accel_ppm"], e["misalignment"]["accel_mrad"])
    g = triad(e["scale_factor"]["gyro_ppm"], e["misalignment"]["gyro_mrad"])
    l = np.linalg.cholesky(a @ a.T)
    q = np.linalg.inv(l) @ a
    bias = np.array(e["turn_on_bias"]["accel_mg"]) * 9.80665e-3
    return l, g @ q.T, bias


def z_scores(rep, l, mg, bias):
    fa = rep["accel"]["fitted"]
    sa = fa["settings"]
    za = [(sa["scale"][i] - l[i, i]) / fa["scale_sd"][i] for i in range(3)]
    za += [(sa["bias"][i] - bias[i]) / fa["bias_sd_m_s2"][i] for i in range(3)]
    for k, (i, j) in enumerate([(1, 0), (2, 0), (2, 1)]):
        za.append((sa["misalignment"][i][j] - l[i, j] / l[i, i]) / fa["misalignment_sd_rad"][k])
    fg = rep["gyro"]["fitted"]
    sg = fg["settings"]
    zg = []
    for i in range(3):
        for j in range(3):
            if i == j:
                got, want = sg["scale"][i], mg[i, i]
            else:
                got, want = sg["misalignment"][i][j], mg[i, j] / mg[i, i]
            zg.append((got - want) / fg["k_sd"][3 * i + j])
    return za, zg


def main():
    lo, hi = int(sys.argv[1]), int(sys.argv[2])
    l, mg, bias = truth()
    all_a, all_g = [], []
    with tempfile.TemporaryDirectory() as d:
        log, out = f"{d}/t.log", f"{d}/cal"
        for seed in range(lo, hi):
            subprocess.run([EXE, "simulate", SCENARIO, "-o", log, "--seed", str(seed)],
                           check=True, capture_output=True)
            subprocess.run([EXE, "calibrate", log, "--out-dir", out],
                           check=True, capture_output=True)
            za, zg = z_scores(json.loads(pathlib.Path(out, "report.json").read_text()),
                              l, mg, bias)
            all_a += za
            all_g += zg
    for name, z in (("accel", all_a), ("gyro", all_g)):
        z = np.array(z)
        print(f"{name}: {len(z)} z over seeds {lo}..{hi - 1}: RMS {np.sqrt(np.mean(z * z)):.3f}, "
              f"max |z| {np.max(np.abs(z)):.2f}")


if __name__ == "__main__":
    main()
