"""Round-1 held-out z of every calibration group on clean simulated tumbles (no scale factor or
misalignment on either triad, so every scale/misalignment group is superfluous and its z should
be ≈ N(0, 1), centred a little below 0). Cross-check for tests/calibrate_sim.rs's ignored test.

    cargo build --release
    python3 tests/reference/calibrate_clean_z.py 1 21 101 121   # seeds 1..20 and 101..120, ≈ 90 s

Prints per triad and group: mean / sd / largest round-1 z and how many seeds kept the triad's
scale or misalignment group; for the gyro, the whitened held-out residuals' mean RMS and mean
square at the truth K = I (no refit), and their mean square with both groups refitted without
each motion (round 1: what the test compares). The binary is `target/release/imuprep`, or
`$IMUPREP`.
"""

import json
import pathlib
import subprocess
import sys
import tempfile

import statistics

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = pathlib.Path(__import__("os").environ.get("IMUPREP", ROOT / "target" / "release" / "imuprep"))
SCENARIO = ROOT / "replay" / "tumble.toml"
OFF = ["errors.scale_factor.enabled=false", "errors.misalignment.enabled=false"]


def run(seed, tmp):
    log = tmp / f"{seed}.log"
    args = [EXE, "simulate", SCENARIO, "--seed", str(seed), "-o", log]
    for s in OFF:
        args += ["--set", s]
    subprocess.run(args, check=True, capture_output=True)
    out = tmp / f"cal{seed}"
    subprocess.run([EXE, "calibrate", log, "--out-dir", out], check=True, capture_output=True)
    return json.loads((out / "report.json").read_text())


def main():
    a = [int(x) for x in sys.argv[1:]] or [1, 21]
    seeds = [s for lo, hi in zip(a[::2], a[1::2]) for s in range(lo, hi)]
    z = {}
    kept = {"accel": 0, "gyro": 0}
    white, white_fit = [], []
    with tempfile.TemporaryDirectory() as d:
        for seed in seeds:
            rep = run(seed, pathlib.Path(d))
            for triad in ("accel", "gyro"):
                t = rep[triad]
                fit = t.get("fitted")
                if fit and {"scale", "misalignment"} & set(fit["groups"]):
                    kept[triad] += 1
                for c in t["candidates"]:
                    if c["round"] == 1:
                        z.setdefault((triad, c["group"]), []).append(c["test"]["z"])
            white.append(rep["gyro"]["held_out_white_rms_before"])
            r1 = [c for c in rep["gyro"]["candidates"] if c["round"] == 1]
            if r1:
                white_fit.append(r1[0]["test"]["mse_after"])
            print(seed, {f"{k[0]} {k[1]}": round(v[-1], 2) for k, v in z.items()}, flush=True)
    for (triad, g), v in sorted(z.items()):
        m, sd = statistics.mean(v), statistics.stdev(v)
        print(f"{triad} {g}: mean {m:.2f} sd {sd:.2f} largest {max(v):.2f} over {len(v)}")
    print(f"kept scale/misalignment: accel {kept['accel']}/{len(seeds)}, gyro {kept['gyro']}/{len(seeds)}")
    print(
        f"gyro whitened held-out RMS at K = I: mean {statistics.mean(white):.3f}"
        f" (mean square {statistics.mean(w * w for w in white):.3f});"
        f" with both groups refitted (round 1): mean square {statistics.mean(white_fit):.3f}"
    )


if __name__ == "__main__":
    main()
