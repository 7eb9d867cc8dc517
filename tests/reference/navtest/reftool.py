"""The reference filter (rtklibexplorer's GNSS_IMU, BSD-3) run from a temporary copy.

Nothing of the tool's code lives in this project. `ToolCopy` copies the tool's folder to a
temporary directory; a run then
  * rewrites, in that copy only, the three header lines of GNSS_IMU.py that pick the data set
    (config module, data folder, file stem) and the one line of convert_imu_file.py that names
    its input file — each replacement must match exactly once, so an upstream change fails loudly;
  * sets run options (plot switches, outage schedule, velocity matching, epoch count) as
    attributes of the tool's own config module before the script imports it;
  * runs the script in a fresh interpreter (`python3 reftool.py filter SPEC.json`): the tool
    converts config values in place (degrees to radians), so two runs must never share one.

Instrumentation, not maths: the run wraps the tool's `Velocity_Match` to keep a copy of the rows
it is about to overwrite (so one run with velocity matching on also yields the output with it
off: matching edits only the stored output, never the filter state — checked in full mode), wraps
`LC_KF_ZUPT_Update` to count zero-velocity updates, and replaces `Write_GNSS_data` (the RTKLIB
.pos writer, a few seconds per run) with a no-op, since the harness reads the filter's output
array directly.
"""

import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

# The header lines of GNSS_IMU.py (snapshot 8235ee6) that select the drive data set.
FILTER_SELECTION = (
    "import drive_config as cfg\n"
    "dataDir = r'..\\data\\drive_0708'\n"
    "fileIn = '1934_sf'\n"
)
# The line of convert_imu_file.py that names its input.
CONVERTER_INPUT = "filepath = r'..\\data\\drive_0708\\imu_1934.csv'\n"

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class LogSpec:
    """One recording as the tool holds it, and as ../shared/data/real holds it converted."""

    name: str  # short name used in the tables
    tool_folder: str  # folder under the tool's data/
    stem: str  # e.g. "1934": imu_<stem>.csv, imu_<stem>.csv.tag, gnss_<stem>_sf.pos
    config_module: str  # the tool's config module for this data set
    shared_csv: str  # file in ../shared/data/real/rtklibexplorer_drive_walk
    fit_skip_s: float  # variant (c): `imuprep fit --skip-s`
    fit_train_s: float  # variant (c): `imuprep fit --train-s`

    @property
    def raw_name(self):
        return "imu_%s.csv" % self.stem

    @property
    def file_in(self):
        return "%s_sf" % self.stem


LOGS = {
    # Drive: fit on the first 180 s (imuprep's default training span), evaluate outages after it.
    "drive": LogSpec("drive", "drive_0708", "1934", "drive_config", "drive_0708_imu.csv", 0.0, 180.0),
    # Walk (134 s): fit from 88 s to the end (the RTK is float there anyway; it holds the static
    # 106-122 s), evaluate outages that end before it.
    "walk": LogSpec("walk", "walk_0827", "1730", "walk_config", "walk_0827_imu.csv", 88.0, 50.0),
}


def replace_once(text, old, new, what):
    n = text.count(old)
    if n != 1:
        raise RuntimeError("%s: expected the text %r exactly once, found it %d times "
                           "(has the tool changed?)" % (what, old, n))
    return text.replace(old, new)


class ToolCopy:
    """A writable copy of the tool in a temporary directory."""

    def __init__(self, tool_dir, work_dir):
        self.root = Path(work_dir) / "gnss_imu"
        shutil.copytree(tool_dir, self.root)
        for p in [self.root, *self.root.rglob("*")]:
            p.chmod(p.stat().st_mode | 0o200)  # the shared copy is read-only
        self.src = self.root / "src"
        self.filter_text = (self.src / "GNSS_IMU.py").read_text()
        self.converter_text = (self.src / "convert_imu_file.py").read_text()
        # Fail now, not in a worker, if the lines to rewrite are not there.
        replace_once(self.filter_text, FILTER_SELECTION, "", "GNSS_IMU.py")
        replace_once(self.converter_text, CONVERTER_INPUT, "", "convert_imu_file.py")

    def data_dir(self, log):
        return self.root / "data" / log.tool_folder

    def filter_script(self, log, data_dir):
        """GNSS_IMU.py with its data-set selection pointing at `data_dir`."""
        sel = "import %s as cfg\ndataDir = %r\nfileIn = %r\n" % (
            log.config_module, str(data_dir), log.file_in)
        return replace_once(self.filter_text, FILTER_SELECTION, sel, "GNSS_IMU.py")

    def converter_script(self, raw_csv):
        return replace_once(self.converter_text, CONVERTER_INPUT,
                            "filepath = %r\n" % str(raw_csv), "convert_imu_file.py")

    def _import(self, module):
        """A module of the tool, imported into this process (reading only: no filter runs here)."""
        import importlib
        if str(self.src) not in sys.path:
            sys.path.insert(0, str(self.src))
        return importlib.import_module(module)

    def read_gnss(self, pos_path):
        """The RTK solution as the filter reads it (the tool's own reader)."""
        return self._import("imu_files").Read_GNSS_data(str(pos_path))[0]

    def config_values(self, log, keys):
        cfg = self._import(log.config_module)
        return {k: float(getattr(cfg, k)) for k in keys}

    def convert(self, raw_csv):
        """Run the tool's converter on `raw_csv` (beside it: the .tag); returns the _sf.csv path."""
        raw_csv = Path(raw_csv)
        script = raw_csv.parent / "convert_imu_file_run.py"
        script.write_text(self.converter_script(raw_csv))
        run_python([str(script)], cwd=self.src, log=raw_csv.parent / "convert.log",
                   pythonpath=self.src)
        out = raw_csv.with_name(raw_csv.stem + "_sf.csv")
        if not out.exists():
            raise RuntimeError("the converter did not write %s" % out)
        return out


def run_python(args, cwd, log, pythonpath=None):
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONHASHSEED="0")
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    with open(log, "w") as f:
        r = subprocess.run([sys.executable, *args], cwd=cwd, env=env, stdout=f,
                           stderr=subprocess.STDOUT)
    if r.returncode != 0:
        tail = Path(log).read_text()[-2000:]
        raise RuntimeError("%s failed (exit %d), log %s:\n%s" % (args[0], r.returncode, log, tail))


def filter_run_spec(tool, log, data_dir, overrides, out_npz):
    """Everything a worker needs for one filter run (JSON-serialisable)."""
    return {
        "src_dir": str(tool.src),
        "config_module": log.config_module,
        "script": tool.filter_script(log, data_dir),
        "overrides": overrides,
        "out": str(out_npz),
    }


def run_filter(spec, run_dir):
    """Run the filter once, in a fresh interpreter; returns the path of its .npz output."""
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    spec_path = run_dir / "spec.json"
    spec_path.write_text(json.dumps(spec, indent=1))
    run_python([str(HERE / "reftool.py"), "filter", str(spec_path)], cwd=run_dir,
               log=run_dir / "filter.log")
    return Path(spec["out"])


# ---------------------------------------------------------------------------------------------
# Worker side (runs in the fresh interpreter)

def _worker_filter(spec_path):
    import contextlib
    import importlib
    import runpy

    import numpy as np

    spec = json.loads(Path(spec_path).read_text())
    run_dir = Path(spec_path).parent
    sys.path.insert(0, spec["src_dir"])
    cfg = importlib.import_module(spec["config_module"])
    for k, v in spec["overrides"].items():
        if not hasattr(cfg, k):
            raise RuntimeError("config module %s has no setting %r" % (spec["config_module"], k))
        setattr(cfg, k, v)

    import imu_files
    import imu_math

    matched = []  # (start, end, rows before matching), one per Velocity_Match call
    velocity_match = imu_math.Velocity_Match

    def recording_velocity_match(outp, coast_start, coast_end):
        matched.append((coast_start, coast_end, outp[coast_start:coast_end, 1:7].copy()))
        return velocity_match(outp, coast_start, coast_end)

    zupts = []
    zupt_update = imu_math.LC_KF_ZUPT_Update

    def counting_zupt(*args):
        before = np.array(args[3][3:6], dtype=float)
        res = zupt_update(*args)
        zupts.append(np.array(res[2][3:6], dtype=float) - before)  # gyro bias change, rad/s
        return res

    imu_math.Velocity_Match = recording_velocity_match
    imu_math.LC_KF_ZUPT_Update = counting_zupt
    imu_files.Write_GNSS_data = lambda *a, **k: None

    script = run_dir / "GNSS_IMU_run.py"
    script.write_text(spec["script"])
    os.chdir(spec["src_dir"])
    with open(run_dir / "stdout.log", "w") as f, contextlib.redirect_stdout(f):
        g = runpy.run_path(str(script), run_name="__main__")

    outp = np.asarray(g["outp"])
    unmatched = outp.copy()
    for s, e, rows in reversed(matched):
        unmatched[s:e, 1:7] = rows
    n = int(g["num_epochs"])
    np.savez(
        spec["out"],
        outp=outp,
        outp_unmatched=unmatched,
        t_imu_raw=np.asarray(g["in_imu"])[:n, 0],
        in_gnss=np.asarray(g["in_gnss"]),
        bias_est=np.asarray(g["out_IMU_bias_est"])[:, :, 0],
        zupt_gyro_bias_change=np.array(zupts).reshape(-1, 3),
        vel_match_calls=np.array([(s, e) for s, e, _ in matched], dtype=int).reshape(-1, 2),
        imu_t_off=float(cfg.imu_t_off),
        start_coast=float(cfg.start_coast),
        end_coast=float(cfg.end_coast),
        coast_len=float(cfg.coast_len),
        vel_match=bool(cfg.vel_match),
    )


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "filter":
        _worker_filter(sys.argv[2])
    else:
        sys.exit("usage: reftool.py filter SPEC.json")
