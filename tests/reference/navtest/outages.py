"""Simulated GNSS outages, expressed in the reference filter's own schedule.

The tool marks outages from three config values (drive_config.py / walk_config.py, "Testing/Debug"):
from `start_coast` seconds after the first GNSS epoch, an outage of `coast_len` seconds, then
2 x `coast_len` seconds of GNSS, and again, up to `end_coast` seconds before the last GNSS epoch.
It compares the IMU time stamps *before* its `imu_t_off` shift with that schedule, and skips every
GNSS measurement it meets during a marked IMU epoch.

Scheme (i) is the tool's default schedule (drive: 15 s outages from 40 s, every 45 s, 11 outages;
walk: from 25 s, 2 outages). Scheme (ii) places outages of 10, 30 and 60 s at >= 20 start times
spread evenly over the recording, several per filter run where they fit: a run is one "comb" of
the tool's own schedule (outage L, then 2L of GNSS to recover — the tool's own spacing), and the
combs of successive runs are shifted so that together their start times form an even grid.
"""

from dataclasses import dataclass, field

import numpy as np

MIN_STARTS = 20


@dataclass(frozen=True)
class Window:
    """One outage in raw IMU time (GPST s): the filter skips GNSS while start < t_imu < end."""

    start: float
    end: float


@dataclass
class Run:
    """One filter run: the tool's schedule values, and the outages of that schedule to evaluate."""

    start_coast: float  # s after the first GNSS epoch
    coast_len: float  # s
    end_coast: float  # s before the last GNSS epoch
    windows: list = field(default_factory=list)  # Window, each evaluated
    stop_t: float = None  # raw IMU time after which the run may stop (None = whole log)
    num_epochs: int = 0  # the tool's `num_epochs`: IMU epochs to run (0 = all)

    def overrides(self):
        return {"start_coast": self.start_coast, "coast_len": self.coast_len,
                "end_coast": self.end_coast, "num_epochs": self.num_epochs}


def comb_windows(g0, g1, start_coast, coast_len, end_coast):
    """The outages the tool's schedule marks (g0, g1: first and last GNSS epoch, GPST s)."""
    e = g1 - end_coast
    out, a = [], g0 + start_coast
    while a < e:
        out.append(Window(a, min(a + coast_len, e)))
        a += 3 * coast_len
    return out


def default_run(g0, g1, cfg_values):
    """Scheme (i): the config's own schedule, the whole log."""
    r = Run(cfg_values["start_coast"], cfg_values["coast_len"], cfg_values["end_coast"])
    r.windows = comb_windows(g0, g1, r.start_coast, r.coast_len, r.end_coast)
    return r


def no_outage_run(g0, g1):
    """A run without simulated outages (the heading reference of scheme (ii))."""
    return Run(start_coast=g1 - g0 + 1000.0, coast_len=15.0, end_coast=0.0)


def grid_runs(g0, g1, length, t_min, end_ok, min_starts=MIN_STARTS, isolated=False):
    """Scheme (ii) for one outage length: combs whose start times form an even grid.

    t_min: earliest start (s after g0). end_ok(t_end) says whether an outage ending at raw IMU
    time t_end can be scored (the RTK epoch there is fixed). Start times are t_min + i * 3L/K for
    the smallest K that gives >= min_starts scorable outages; comb j holds the starts i = j mod K
    (isolated: every scorable start is a run of its own instead). Returns the runs and the number
    of scorable starts.
    """
    last = g1 - g0 - length - 1.0  # the outage must end at least 1 s before the GNSS ends
    if last < t_min:
        return [], 0
    for k in range(1, 100_000):
        step = 3.0 * length / k
        starts = t_min + step * np.arange(int(np.floor((last - t_min) / step + 1e-9)) + 1)
        ok = [s for s in starts if end_ok(g0 + s + length)]
        if len(ok) >= min_starts:
            break
    if isolated:
        groups = [(s, [s]) for s in ok]
    else:
        groups = [(starts[j], [s for s in starts[j::k] if end_ok(g0 + s + length)])
                  for j in range(min(k, len(starts)))]
    runs = []
    for first, teeth in groups:
        if not teeth:
            continue
        end = g0 + teeth[-1] + length + 0.5  # the comb stops after its last scored outage
        r = Run(start_coast=float(first), coast_len=float(length), end_coast=float(g1 - end))
        r.windows = [w for w in comb_windows(g0, g1, r.start_coast, length, r.end_coast)
                     if w.end - w.start >= length - 1e-9 and end_ok(w.end)]
        r.stop_t = end + 1.0
        runs.append(r)
    return runs, len(ok)
