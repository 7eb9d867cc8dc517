"""Errors of a filter run against the RTK solution (.pos), per outage.

Reference: the RTK epochs of the tool's own GNSS file (4 Hz), fixed epochs (Q = 1) only, in a local
north-east-down frame at the first epoch. The filter's output (`outp`, one row per IMU epoch, GNSS
antenna position in ECEF, time already shifted by the config's `imu_t_off`) is compared at the
same times.

Scheme (i) — as issue 12 quotes it: the largest horizontal error over the IMU epochs of each
outage, the RTK position linearly interpolated to each epoch between two consecutive fixed epochs.
Scheme (ii): the error at the end of the outage — at the last RTK epoch whose measurement the
filter did not get (t <= outage end - 20 ms, so the IMU epoch that would have consumed it, at most
one 10 ms IMU step later, still lies inside the outage), which must be fixed; horizontal, vertical
heading and tilt (against a reference run's attitude at the same IMU epoch).
"""

import numpy as np

A_WGS84 = 6378137.0
E2_WGS84 = 6.69437999014e-3
FIX = 1
GNSS_DT = 0.25  # s, the RTK solution rate
END_MARGIN = 0.02  # s, see the module docstring


def llh_to_ecef(lat, lon, h):
    n = A_WGS84 / np.sqrt(1.0 - E2_WGS84 * np.sin(lat) ** 2)
    return np.column_stack([(n + h) * np.cos(lat) * np.cos(lon),
                            (n + h) * np.cos(lat) * np.sin(lon),
                            (n * (1.0 - E2_WGS84) + h) * np.sin(lat)])


def ecef_to_ned_rotation(lat, lon):
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    return np.array([[-sl * co, -sl * so, cl], [-so, co, 0.0], [-cl * co, -cl * so, -sl]])


class Rtk:
    """The RTK reference from the tool's GNSS array (columns: t, lat, lon, h, Q, ...)."""

    def __init__(self, in_gnss):
        self.t = in_gnss[:, 0]
        self.fixed = in_gnss[:, 4] == FIX
        lat, lon, h = in_gnss[:, 1], in_gnss[:, 2], in_gnss[:, 3]
        ecef = llh_to_ecef(lat, lon, h)
        self.origin = ecef[0]
        self.rot = ecef_to_ned_rotation(lat[0], lon[0])
        self.ned = self.to_ned(ecef)
        self.speed = np.hypot(in_gnss[:, 14], in_gnss[:, 15])  # horizontal, m/s

    def to_ned(self, ecef):
        return (ecef - self.origin) @ self.rot.T

    def at(self, t):
        """RTK NED interpolated at times t; NaN where the bracketing epochs are not both fixed."""
        j = np.clip(np.searchsorted(self.t, t), 1, len(self.t) - 1)
        i = j - 1
        ok = (self.fixed[i] & self.fixed[j] & (self.t[j] - self.t[i] < 1.5 * GNSS_DT)
              & (t >= self.t[i]) & (t <= self.t[j]))
        w = ((t - self.t[i]) / (self.t[j] - self.t[i]))[:, None]
        ned = self.ned[i] * (1.0 - w) + self.ned[j] * w
        ned[~ok] = np.nan
        return ned

    def end_epoch(self, window, t_off):
        """Index of the RTK epoch scored at the end of `window` (raw IMU time), or None."""
        t_end = window.end + t_off - END_MARGIN
        k = np.searchsorted(self.t, t_end, side="right") - 1
        if k < 0 or self.t[k] <= window.start + t_off or not self.fixed[k]:
            return None
        return int(k)


def wrap_deg(a):
    return (a + 180.0) % 360.0 - 180.0


def max_horizontal_error(run, rtk, window, matched):
    """Scheme (i): largest horizontal error over the outage's IMU epochs (NaN: no fixed RTK)."""
    outp = run["outp"] if matched else run["outp_unmatched"]
    t_raw = run["t_imu_raw"]
    idx = np.flatnonzero((t_raw > window.start) & (t_raw < window.end))
    check_marked(run, idx, window)
    ref = rtk.at(outp[idx, 0])
    err = np.hypot(*(rtk.to_ned(outp[idx, 1:4]) - ref)[:, :2].T)
    err = err[np.isfinite(err)]
    return float(err.max()) if len(err) else float("nan")


def check_marked(run, idx, window):
    """The filter must have marked every epoch of the outage but possibly its first as coasting."""
    flags = run["outp"][idx, 10]
    if len(idx) == 0 or not (flags[1:] == 1).all():
        raise RuntimeError("outage %.2f-%.2f: the filter's coast flags do not cover it"
                           % (window.start, window.end))


def end_errors(run, rtk, window, ref_outp):
    """Scheme (ii) at the outage's end: (horizontal m, vertical m, heading deg, tilt deg, mean RTK
    speed over the outage m/s), or None. Heading and tilt (roll and pitch combined) are differences
    to `ref_outp`, a run's output on the same IMU epochs (the harness: raw IMU, no outage)."""
    k = rtk.end_epoch(window, float(run["imu_t_off"]))
    if k is None:
        return None
    outp = run["outp_unmatched"]
    t_raw = run["t_imu_raw"]
    check_marked(run, np.flatnonzero((t_raw > window.start) & (t_raw < window.end)), window)
    tg = rtk.t[k]
    i = np.searchsorted(outp[:, 0], tg, side="right") - 1  # last IMU epoch at or before tg
    w = (tg - outp[i, 0]) / (outp[i + 1, 0] - outp[i, 0])
    pos = rtk.to_ned(outp[i:i + 1, 1:4] * (1.0 - w) + outp[i + 1:i + 2, 1:4] * w)[0]
    d = pos - rtk.ned[k]
    d_att = wrap_deg(np.rad2deg(outp[i, 7:10] - ref_outp[i, 7:10]))  # roll, pitch, yaw
    heading = abs(d_att[2])
    tilt = np.hypot(d_att[0], d_att[1])
    t_off = float(run["imu_t_off"])
    inside = (rtk.t > window.start + t_off) & (rtk.t <= tg)
    speed = float(rtk.speed[inside].mean())
    return float(np.hypot(d[0], d[1])), float(abs(d[2])), float(heading), float(tilt), speed
