#!/usr/bin/env python3
"""Navigation test: the reference GNSS/IMU filter fed the raw IMU and imuprep's cleaned IMU.

Feeds rtklibexplorer's GNSS_IMU (../shared/tools/gnss_imu, run from a temporary copy) the same RTK
GNSS and the same simulated outages with
  (a) raw      the recording's IMU as the tool ships it;
  (b) default  the IMU cleaned by `imuprep replay` (embedded default config, or --config);
  (c) fitted   cleaned with the models `imuprep fit` made on another stretch of the same recording
               (drive: first 180 s; walk: 80 s to the end), scored only on outages outside it;
and checks that imuprep's pass-through config reproduces (a) exactly. Scheme (i): the tool's own
outages, largest horizontal error within each, velocity matching on and off. Scheme (ii): 10/30/60 s
outages at >= 20 start times, error at each outage's end. See README.md beside this file and
docs/navigation.md.

Run from the repository root:  python3 tests/reference/navtest/navtest.py [--quick] [--jobs 2]
"""

import argparse
import ast
import json
import filecmp
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import imuprep_io  # noqa: E402
import metrics  # noqa: E402
import outages  # noqa: E402
import report  # noqa: E402
import reftool  # noqa: E402

VARIANTS = ("raw", "default", "fitted")
LENGTHS_S = (10.0, 30.0, 60.0)
HELD_OUT_MARGIN_S = 1.0  # an outage this close to the fitting span still counts as inside it


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--imuprep", default="target/release/imuprep", help="imuprep binary to test")
    p.add_argument("--config", help="imuprep config for variant (b) (default: the embedded one)")
    p.add_argument("--default-config", default="config/default.toml",
                   help="TOML equal to the binary's embedded config; base of variant (c) when "
                        "--config is absent (checked: must give the embedded config's output)")
    p.add_argument("--passthrough-config", default="config/passthrough.toml")
    p.add_argument("--tool", default="../shared/tools/gnss_imu", help="GNSS_IMU folder")
    p.add_argument("--data", default="../shared/data/real/rtklibexplorer_drive_walk",
                   help="the converted recordings imuprep imports")
    p.add_argument("--logs", default="drive,walk", help="comma list of: drive, walk")
    p.add_argument("--variants", default=",".join(VARIANTS),
                   help="comma list of: raw, default, fitted (raw is always run)")
    p.add_argument("--lengths", default=",".join("%g" % x for x in LENGTHS_S),
                   help="scheme (ii): comma list of outage lengths, s (a subset of the default "
                        "saves time on a busy machine)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="set an attribute of the tool's config module in every run (VALUE a "
                        "Python literal), e.g. gyro_noise_PSD=0.00029; repeatable; shown in "
                        "the report's command line")
    p.add_argument("--one-outage-per-run", action="store_true",
                   help="scheme (ii): every outage in a filter run of its own (slower) instead "
                        "of the tool's comb of outages spaced 2 x their length")
    p.add_argument("--quick", action="store_true",
                   help="scheme (i) only (the tool's own outages), no extra consistency runs")
    p.add_argument("--jobs", type=int, default=1, help="filter runs in parallel processes")
    p.add_argument("--out-md", help="write the markdown tables to this file")
    p.add_argument("--errors-json",
                   help="write scheme (ii)'s per-outage end errors here (for the comparison with "
                        "imuprep's own filter, `imuprep navtest`)")
    p.add_argument("--work-dir", help="keep the temporary files here (default: a temp dir, "
                                      "removed at the end)")
    return p.parse_args(argv)


@dataclass
class Task:
    """One filter run."""

    log: str
    variant: str
    purpose: str  # "scheme_i", "vm_off_check", "no_outage", "scheme_ii"
    run: outages.Run
    vel_match: bool
    length: float = 0.0
    result: dict = None


def skip_if_absent(args):
    for p in (args.tool, args.data):
        if not Path(p).is_dir():
            print("SKIPPED: %s is absent; the navigation test needs ../shared" % p,
                  file=sys.stderr)
            sys.exit(0)


# ---------------------------------------------------------------------------------------------
# Inputs: one data folder per (log, variant), laid out as the tool's own data folder

def variant_folder(tool, log, work, name, raw_text_path):
    """A data folder with the tool's GNSS file, the tag, and the converted `raw_text_path`."""
    d = work / "data" / log.name / name
    d.mkdir(parents=True)
    src = tool.data_dir(log)
    shutil.copy(src / ("gnss_%s.pos" % log.file_in), d)
    shutil.copy(src / (log.raw_name + ".tag"), d)
    shutil.copy(raw_text_path, d / log.raw_name)
    tool.convert(d / log.raw_name)
    return d


def sf_path(folder, log):
    return folder / ("imu_%s.csv" % log.file_in)


class LogInputs:
    """One recording's inputs: imuprep's log of it, and one data folder per variant."""

    def __init__(self, args, tool, imp, log, work):
        self.args, self.tool, self.imp, self.log = args, tool, imp, log
        self.work = work
        self.w = work / "imuprep" / log.name
        self.w.mkdir(parents=True)
        self.shared = Path(args.data) / log.shared_csv
        self.imp_log = self.w / (log.name + ".log")
        imp.import_csv(self.shared, self.imp_log)
        self.folders, self.summaries = {}, {}
        imu_t0 = imuprep_io.read_shared_csv(self.shared)[0][0] / 1e9
        self.fit_span = (imu_t0 + log.fit_skip_s, imu_t0 + log.fit_skip_s + log.fit_train_s)

    def tool_raw(self):
        return self.tool.data_dir(self.log) / self.log.raw_name

    def make_raw(self):
        """(a): the tool's own raw file through its converter (== its shipped file, if any)."""
        self.folders["raw"] = variant_folder(self.tool, self.log, self.work, "raw", self.tool_raw())
        shipped = sf_path(self.tool.data_dir(self.log), self.log)
        if shipped.exists() and not filecmp.cmp(shipped, sf_path(self.folders["raw"], self.log),
                                                shallow=False):
            raise RuntimeError("the tool's converter does not reproduce its shipped %s" % shipped)

    def make_cleaned(self, name, config):
        """imuprep replay with `config` (None: embedded), mapped onto the tool's raw file."""
        out_csv = self.w / (name + ".csv")
        self.summaries[name] = self.imp.replay(self.imp_log, config, out_csv,
                                               self.w / (name + ".summary.txt"))
        mapped = self.w / (name + "_" + self.log.raw_name)
        imuprep_io.write_tool_raw(self.tool_raw(), self.shared, out_csv, mapped)
        self.folders[name] = variant_folder(self.tool, self.log, self.work, name, mapped)
        return out_csv

    def check_passthrough(self):
        if not filecmp.cmp(sf_path(self.folders["raw"], self.log),
                           sf_path(self.folders["passthrough"], self.log), shallow=False):
            raise RuntimeError("%s: imuprep pass-through does not reproduce the filter's raw "
                               "input" % self.log.name)

    def base_config(self, default_csv):
        """Variant (c)'s base config: --config, or --default-config checked against the embedded."""
        if self.args.config:
            return Path(self.args.config).resolve()
        base = Path(self.args.default_config).resolve()
        check_csv = self.w / "default_file.csv"
        self.imp.replay(self.imp_log, base, check_csv, self.w / "default_file.summary.txt")
        if not filecmp.cmp(default_csv, check_csv, shallow=False):
            raise RuntimeError("%s gives other output than the binary's embedded config; pass "
                               "--default-config with the binary's config/default.toml" % base)
        return base

    def make_fitted(self, base):
        """(c): `imuprep fit` on the log's fitting stretch, then replay with those models."""
        arima, bias = self.imp.fit(self.imp_log, self.w / "models", self.log.fit_skip_s,
                                   self.log.fit_train_s, self.w / "fit.txt")
        cfg = imuprep_io.fitted_config(base, arima, bias, self.w / "fitted.toml")
        self.make_cleaned("fitted", cfg)
        self.summaries["fitted"]["model_gyro_mean_dps"] = imuprep_io.bias_model_means_dps(bias)
        fit_out = (self.w / "fit.txt").read_text()
        if "NOT FITTED" in fit_out:
            why = fit_out.split("NOT FITTED", 1)[1].splitlines()[0].lstrip(" —-")
            self.summaries["fitted"]["bias_not_fitted"] = why

    def record_gyro_changes(self):
        """What imuprep took off the gyros, IMU axes: mean of (output - input), deg/s."""
        gyro = {v: imuprep_io.read_imuprep_csv(self.w / (v + ".csv"))[2] for v in self.summaries}
        for v in self.summaries:
            self.summaries[v]["gyro_change_dps"] = np.rad2deg(
                (gyro[v] - gyro["passthrough"]).mean(axis=0))


def prepare_log(args, tool, imp, log, work):
    """Every variant's input folder for one log, with the pass-through check."""
    li = LogInputs(args, tool, imp, log, work)
    li.make_raw()
    li.make_cleaned("passthrough", Path(args.passthrough_config).resolve())
    li.check_passthrough()
    default_csv = li.make_cleaned("default", args.config and Path(args.config).resolve())
    li.make_fitted(li.base_config(default_csv))
    li.record_gyro_changes()
    return li.folders, li.summaries, li.fit_span


# ---------------------------------------------------------------------------------------------
# Planning

def plan(args, tool, log, rtk, fit_span, t_imu_raw):
    g0, g1 = rtk.t[0], rtk.t[-1]
    cv = tool.config_values(log, ("start_coast", "end_coast", "coast_len", "imu_t_off"))
    tasks = []
    chosen = [v for v in VARIANTS if v == "raw" or v in args.variants.split(",")]
    for v in chosen if args.quick else chosen + ["passthrough"]:
        tasks.append(Task(log.name, v, "scheme_i", outages.default_run(g0, g1, cv), True))
    if args.quick:
        return tasks
    tasks.append(Task(log.name, "raw", "vm_off_check", outages.default_run(g0, g1, cv), False))
    tasks.append(Task(log.name, "raw", "no_outage", outages.no_outage_run(g0, g1), False))

    def end_ok(t_end):
        return rtk.end_epoch(outages.Window(t_end - 1.0, t_end), cv["imu_t_off"]) is not None

    for length in [float(x) for x in args.lengths.split(",")]:
        runs, _ = outages.grid_runs(g0, g1, length, cv["start_coast"], end_ok,
                                    isolated=args.one_outage_per_run)
        for r in runs:
            # Stop the run after its last outage; at most the tool's own count (all but 100).
            r.num_epochs = min(int(np.searchsorted(t_imu_raw, r.stop_t)) + 1,
                               len(t_imu_raw) - 100)
            for v in chosen:
                if v == "fitted" and not any(held_out(w, fit_span) for w in r.windows):
                    continue
                tasks.append(Task(log.name, v, "scheme_ii", r, False, length))
    return tasks


def held_out(window, fit_span):
    return (window.end < fit_span[0] - HELD_OUT_MARGIN_S
            or window.start > fit_span[1] + HELD_OUT_MARGIN_S)


# ---------------------------------------------------------------------------------------------
# Running

def config_sets(items):
    """`--set NAME=VALUE` options as a dict of config attributes."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.isidentifier():
            sys.exit("--set %r: expected NAME=VALUE" % item)
        try:
            out[name] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            sys.exit("--set %r: VALUE is not a Python literal" % item)
    return out


def execute(tasks, tool, folders, work, jobs, sets=None):
    def one(i_task):
        i, t = i_task
        log = reftool.LOGS[t.log]
        overrides = dict(t.run.overrides(), **(sets or {}), vel_match=t.vel_match,
                         plot_results=False,
                         plot_bias_data=False, plot_imu_data=False, plot_unc_data=False)
        run_dir = work / "runs" / ("%04d_%s_%s_%s" % (i, t.log, t.variant, t.purpose))
        spec = reftool.filter_run_spec(tool, log, folders[t.log][t.variant], overrides,
                                       run_dir / "out.npz")
        path = reftool.run_filter(spec, run_dir)
        with np.load(path) as z:
            t.result = {k: z[k] for k in z.files}
        if t.purpose == "scheme_ii":
            keep_needed_columns(t.result)
        return t

    # Longest first (drive before walk, whole-log runs before short ones) to keep both cores busy.
    order = sorted(enumerate(tasks), key=lambda it: (it[1].log != "drive",
                                                     it[1].run.num_epochs != 0))
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        list(pool.map(one, order))


def keep_needed_columns(result):
    """Keep time, position, attitude and coast flag of the output (columns 0..10): the scheme
    (ii) runs are many, and their whole outputs would hold about a gigabyte."""
    result["outp"] = result["outp"][:, :11].copy()
    if len(result["vel_match_calls"]) == 0:
        if not np.array_equal(result["outp"], result["outp_unmatched"][:, :11]):
            raise RuntimeError("output changed without a velocity-matching call")
        result["outp_unmatched"] = result["outp"]
    else:
        result["outp_unmatched"] = result["outp_unmatched"][:, :11].copy()


# ---------------------------------------------------------------------------------------------
# Scoring

def score_scheme_i(tasks, rtk, fit_span):
    """{variant: {"on": [...], "off": [...], "held_out": [bool]}} per outage."""
    out = {}
    for t in tasks:
        if t.purpose != "scheme_i":
            continue
        r = t.result
        out[t.variant] = {
            "on": [metrics.max_horizontal_error(r, rtk, w, True) for w in t.run.windows],
            "off": [metrics.max_horizontal_error(r, rtk, w, False) for w in t.run.windows],
            "held_out": [held_out(w, fit_span) for w in t.run.windows],
            "windows": t.run.windows,
        }
    return out


def score_scheme_ii(tasks, rtk, fit_span, ref):
    """{(variant, length): list of (start, h, v, heading, tilt, speed, held_out)}."""
    out = {}
    for t in tasks:
        if t.purpose != "scheme_ii":
            continue
        n = len(t.result["outp"])
        if not np.array_equal(t.result["outp"][:, 0], ref.result["outp"][:n, 0]):
            raise RuntimeError("IMU time grids differ between runs")
        for w in t.run.windows:
            ho = held_out(w, fit_span)
            if t.variant == "fitted" and not ho:
                continue
            e = metrics.end_errors(t.result, rtk, w, ref.result["outp"])
            if e is None:
                raise RuntimeError("planned outage %.2f s has no fixed end epoch" % w.start)
            out.setdefault((t.variant, t.length), []).append((w.start - rtk.t[0], *e, ho))
    return out


def consistency_checks(tasks, scheme_i):
    """Full mode: pass-through == raw exactly; a velocity-matching-off run == the unmatched rows."""
    lines = []
    by = {(t.variant, t.purpose): t for t in tasks}
    pt, raw = scheme_i.get("passthrough"), scheme_i["raw"]
    lines.append("pass-through through imuprep: filter input byte-identical to raw")
    if pt is not None:
        same = pt["on"] == raw["on"] and pt["off"] == raw["off"]
        if not same:
            raise RuntimeError("pass-through errors differ from raw: %s vs %s" % (pt, raw))
        lines.append("pass-through run: outage errors identical to raw (%d outages, velocity "
                     "matching on and off)" % len(raw["on"]))
    chk = by.get(("raw", "vm_off_check"))
    if chk is not None:
        a = by[("raw", "scheme_i")].result["outp_unmatched"]
        b = chk.result["outp"]
        if not np.array_equal(a, b):
            raise RuntimeError("velocity matching changed more than the stored output")
        lines.append("a run with vel_match = False equals the velocity-matched run's output with "
                     "the matched rows restored, bit for bit (%d epochs x %d columns)" % b.shape)
    return lines


BIAS_TIMELINE_STEP_S = 25.0


def filter_diagnostics(tasks):
    """Per variant (scheme (i) run): ZUPT count, the filter's gyro-bias estimate (deg/s), and its
    z (yaw) component every BIAS_TIMELINE_STEP_S seconds after the first GNSS epoch."""
    out = {}
    for t in tasks:
        if t.purpose != "scheme_i":
            continue
        b = t.result["bias_est"]
        b = b[b[:, 0] > 0]
        gyro = np.rad2deg(b[:, 4:7])
        t_rel = b[:, 0] - t.result["in_gnss"][0, 0]
        grid = np.arange(BIAS_TIMELINE_STEP_S, t_rel[-1], BIAS_TIMELINE_STEP_S)
        out[t.variant] = {
            "zupts": len(t.result["zupt_gyro_bias_change"]),
            "gyro_bias_median_dps": np.median(gyro, axis=0),
            "timeline": (grid, gyro[np.searchsorted(t_rel, grid, side="right") - 1, 2]),
        }
    return out


# ---------------------------------------------------------------------------------------------

def git_context():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return rev + (" (uncommitted changes)" if dirty else "")
    except (subprocess.CalledProcessError, FileNotFoundError):
        return "not a git checkout"


def main(argv=None):
    args = parse_args(argv)
    skip_if_absent(args)
    t_start = time.time()
    imp = imuprep_io.Imuprep(args.imuprep)
    work = Path(args.work_dir or tempfile.mkdtemp(prefix="navtest-")).resolve()
    work.mkdir(parents=True, exist_ok=True)
    if any(work.iterdir()):
        sys.exit("--work-dir %s is not empty" % work)
    try:
        tool = reftool.ToolCopy(args.tool, work)
        logs = [reftool.LOGS[n] for n in args.logs.split(",")]
        folders, summaries, spans, rtks, all_tasks = {}, {}, {}, {}, {}
        for log in logs:
            folders[log.name], summaries[log.name], spans[log.name] = prepare_log(
                args, tool, imp, log, work)
            raw = folders[log.name]["raw"]
            rtks[log.name] = metrics.Rtk(tool.read_gnss(raw / ("gnss_%s.pos" % log.file_in)))
            t_imu_raw = np.loadtxt(sf_path(raw, log), delimiter=",", usecols=0)
            all_tasks[log.name] = plan(args, tool, log, rtks[log.name], spans[log.name],
                                       t_imu_raw)
        t_prep = time.time() - t_start
        execute([t for ts in all_tasks.values() for t in ts], tool, folders, work, args.jobs,
                config_sets(args.set))

        sections = []
        per_outage = []
        for log in logs:
            tasks, rtk = all_tasks[log.name], rtks[log.name]
            s1 = score_scheme_i(tasks, rtk, spans[log.name])
            checks = consistency_checks(tasks, s1)
            s2 = None
            if not args.quick:
                ref = next(t for t in tasks if t.purpose == "no_outage")
                s2 = score_scheme_ii(tasks, rtk, spans[log.name], ref)
                for (variant, length), rows in s2.items():
                    for r in rows:
                        per_outage.append({"log": log.name, "variant": variant, "length_s": length,
                                           "start_rel_s": r[0], "horiz_m": r[1], "vert_m": r[2],
                                           "heading_deg": r[3], "tilt_deg": r[4]})
            sections.append(report.log_section(log, rtk, spans[log.name], s1, s2,
                                               summaries[log.name], filter_diagnostics(tasks),
                                               checks))
        elapsed = time.time() - t_start
        n_runs = sum(len(ts) for ts in all_tasks.values())
        if args.errors_json:
            Path(args.errors_json).write_text(json.dumps(per_outage, indent=1))
        md = report.document(args, imp.version, git_context(), sections, n_runs, t_prep, elapsed)
        print(md)
        if args.out_md:
            Path(args.out_md).write_text(md)
    finally:
        if not args.work_dir:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
