"""imuprep as a black box (import, replay, fit), and its output mapped back onto the filter's input.

The reference filter reads the tool's raw IMU file (`imu_<stem>.csv`: ax, ay, az in g; gx, gy, gz in
deg/s; IMU tick in ms; printed with 3 decimals) through the tool's own converter (time tags, a
zero-phase low-pass, deg to rad). imuprep reads the converted recording in ../shared/data/real
(same samples, a GPST column, SI units after import). To feed the filter imuprep's output, each
sample of `imuprep replay --out csv:` is matched by time to the shared CSV's row (its `gpst_s`),
that row's IMU tick to the tool's raw line, and the line's six values are replaced by imuprep's
values converted back to g and deg/s. The converter then runs unchanged on the rewritten file.

Values are written with 4 decimals: one more than the recording (3 decimals), i.e. 1e-4 g and
1e-4 deg/s, 10x below the sensor's own steps (1 mg; about 0.0076 deg/s). That recovers the
recording's values exactly from imuprep's f32 output when imuprep changes nothing, so the
pass-through variant must reproduce the raw converter output byte for byte (checked), and it
adds a rounding error (< 5e-5 of a unit) far below anything a stage changes.
"""

import re
import subprocess
import tomllib
from decimal import Decimal
from pathlib import Path

import numpy as np
import tomli_w

G0 = 9.80665  # m/s² per g, as imuprep's importer uses (src/io/csv.rs G0)
RAD_TO_DEG = 180.0 / np.pi
MATCH_TOL_NS = 2_000  # imuprep stores t as f64 seconds -> ns (±0.2 µs here); rows are ≥ 6 ms apart


class Imuprep:
    def __init__(self, binary):
        self.binary = Path(binary).resolve()
        if not self.binary.is_file():
            raise SystemExit("imuprep binary not found: %s (build it: cargo build --release)"
                             % self.binary)
        self.version = self._run(["--version"]).strip()

    def _run(self, args, log=None):
        r = subprocess.run([str(self.binary), *map(str, args)], capture_output=True, text=True)
        if log is not None:
            Path(log).write_text(r.stdout + r.stderr)
        if r.returncode != 0:
            raise RuntimeError("imuprep %s failed:\n%s%s" % (" ".join(map(str, args)), r.stdout,
                                                         r.stderr[-3000:]))
        return r.stdout + r.stderr

    def import_csv(self, csv_path, log_path):
        self._run(["import", csv_path, "-o", log_path])

    def replay(self, log_path, config, out_csv, summary_log):
        """Replay `log_path` (config None = the embedded default); returns the summary counts."""
        args = ["replay", log_path, "--out", "csv:%s" % out_csv]
        if config is not None:
            args += ["--config", config]
        return parse_summary(self._run(args, log=summary_log))

    def fit(self, log_path, out_dir, skip_s, train_s, summary_log):
        self._run(["fit", log_path, "--out-dir", out_dir, "--skip-s", skip_s,
                   "--train-s", train_s], log=summary_log)
        return Path(out_dir) / "arima.toml", Path(out_dir) / "bias.toml"


def parse_summary(text):
    """The counts of the summary's `samples :` line, e.g. {'replaced': 160, 'bias removed': 34777}."""
    m = re.search(r"samples\s*:\s*(\d+) in, (\d+) out; flagged: (.*)", text)
    if not m:
        return {}
    out = {"in": int(m.group(1)), "out": int(m.group(2))}
    for part in m.group(3).split(","):
        n, _, name = part.strip().partition(" ")
        if n.isdigit():
            out[name] = int(n)
    return out


def fitted_config(base_config, arima, bias, out_path):
    """`base_config` (a TOML file) with the fitted models as [gross_error] / [bias] `model`."""
    with open(base_config, "rb") as f:
        cfg = tomllib.load(f)
    cfg["source"] = {"kind": "stdin"}  # `replay LOG` replaces it; no path to resolve
    cfg.pop("sinks", None)  # write nothing but the harness's own --out
    cfg.setdefault("gross_error", {})["model"] = str(Path(arima).resolve())
    cfg.setdefault("bias", {})["model"] = str(Path(bias).resolve())
    with open(out_path, "wb") as f:
        tomli_w.dump(cfg, f)
    return out_path


def bias_model_means_dps(bias_toml):
    """The `mean` of each gyro channel of a fitted bias model (rad/s in the file), deg/s; None
    when `imuprep fit` wrote no channel models (no still stretch of --min-still-s: NOT FITTED)."""
    with open(bias_toml, "rb") as f:
        chans = {c["channel"]: c for c in tomllib.load(f).get("channels", [])}
    if not all(c in chans for c in ("gx", "gy", "gz")):
        return None
    return np.rad2deg([chans[c]["mean"] for c in ("gx", "gy", "gz")])


def seconds_to_ns(text):
    return int(Decimal(text) * 1_000_000_000)


def read_shared_csv(path):
    """The shared recording's time (ns) and IMU tick per row (columns gpst_s, imu_tick_ms)."""
    t_ns, ticks = [], []
    with open(path) as f:
        header = f.readline().strip().split(",")
        it, ik = header.index("gpst_s"), header.index("imu_tick_ms")
        for line in f:
            cells = line.split(",")
            t_ns.append(seconds_to_ns(cells[it]))
            ticks.append(int(cells[ik]))
    return np.array(t_ns, dtype=np.int64), np.array(ticks, dtype=np.int64)


def read_imuprep_csv(path):
    """imuprep's canonical CSV: t (ns), seq, gyro (rad/s), accel (m/s²)."""
    t_ns, seq, vals = [], [], []
    with open(path) as f:
        header = f.readline().strip().split(",")
        cols = [header.index(c) for c in ("gx", "gy", "gz", "ax", "ay", "az")]
        it, iseq = header.index("t"), header.index("seq")
        for line in f:
            cells = line.rstrip("\n").split(",")
            t_ns.append(seconds_to_ns(cells[it]))
            seq.append(int(cells[iseq]))
            vals.append([float(cells[c]) for c in cols])
    v = np.array(vals, dtype=float)
    return np.array(t_ns, dtype=np.int64), np.array(seq, dtype=np.int64), v[:, :3], v[:, 3:]


def match_rows(out_t_ns, out_seq, shared_t_ns):
    """Index of the shared row each output sample belongs to, matched by time."""
    j = np.clip(np.searchsorted(shared_t_ns, out_t_ns), 1, len(shared_t_ns) - 1)
    j -= (out_t_ns - shared_t_ns[j - 1]) < (shared_t_ns[j] - out_t_ns)
    bad = np.abs(shared_t_ns[j] - out_t_ns) > MATCH_TOL_NS
    if bad.any():
        raise RuntimeError("%d imuprep samples match no recording row in time (first at t=%d ns)"
                           % (bad.sum(), out_t_ns[bad][0]))
    if len(np.unique(j)) != len(j):
        raise RuntimeError("two imuprep samples matched the same recording row")
    if not np.array_equal(j, out_seq):
        raise RuntimeError("time match and imuprep's seq disagree: the import reordered rows?")
    return j


def write_tool_raw(tool_raw, shared_csv, imuprep_csv, out_path):
    """The tool's raw IMU file with every matched line's values replaced by imuprep's output."""
    shared_t, shared_tick = read_shared_csv(shared_csv)
    t_ns, seq, gyro, accel = read_imuprep_csv(imuprep_csv)
    rows = match_rows(t_ns, seq, shared_t)
    by_tick = {int(shared_tick[r]): k for k, r in enumerate(rows)}

    lines = Path(tool_raw).read_text().split("\n")
    replaced = np.zeros(len(lines), dtype=bool)
    for i, line in enumerate(lines):
        cells = line.split(",")
        if len(cells) != 7:
            continue  # the truncated first/last lines of the walk; the converter skips them
        k = by_tick.get(int(cells[6]))
        if k is None:
            continue
        acc_g = accel[k] / G0
        gyr_dps = gyro[k] * RAD_TO_DEG
        lines[i] = ",".join(["%.4f" % x for x in (*acc_g, *gyr_dps)] + [cells[6]])
        replaced[i] = True
    # The converter reads every line but the first and the last (skip_header=1, skip_footer=1).
    body = np.arange(1, len([ln for ln in lines if ln]) - 1)
    if not replaced[body].all():
        raise RuntimeError("%d lines the converter reads have no imuprep sample (first: line %d)"
                           % ((~replaced[body]).sum(), body[~replaced[body]][0] + 1))
    Path(out_path).write_text("\n".join(lines))
    return int(replaced.sum())
