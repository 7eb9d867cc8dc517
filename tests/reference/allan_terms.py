#!/usr/bin/env python3
"""Reference values for tests/allan_reference.rs: allantools' overlapping Allan deviation of every
channel of a log, and the IEEE-952 terms derived from it by the method `imuprep allan` documents in
src/analysis/allan/terms.rs -- written here independently on top of allantools (oadev,
edf_greenhall, confidence_interval) and scipy (nnls, brentq):

  sigma^2(tau) = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2,
  non-negative weighted least squares, sd(sigma^2_i) = model_i * sqrt(2/nu_i + eps^2),
  nu_i = Greenhall-Riley EDF (d=2, unmodified, overlapping) of the model's largest term at tau_i
  (Q -> alpha 2, N -> 0, B -> -1, K and R -> -2; for alpha <= 0 with the filter factor F = inf,
  see edf()), eps = model-error floor with the log-domain chi^2 = dof
  (sum_i (ln(s2_i/model_i) - psi(nu_i/2) + ln(nu_i/2))^2 / (psi'(nu_i/2) + eps^2) = dof);
  pass 0 with the measured sigma^2, white-FM EDFs and eps = 0; passes until every sqrt(c) and eps
  change by < 1e-6 (relative), at most 50.
  Backward elimination: while a positive term has c < 2 standard errors (covariance of the
  weighted fit on the active columns), the one with the fewest is dropped and the fit redone.
  A term is resolved when it survives, c > 0, and it is the largest contribution at one measured
  tau at least; upper bound =
  min_i hi_i / sqrt(f_j(tau_i)) with hi the upper end of the 68.27 % chi-squared interval.

The taus are the octaves m = 1, 2, 4, ... with at least two second differences (N_phase - 2m >= 2),
the same as allantools' "octave" list without its last one or two entries.

Make the fixtures (the series is the replay log's, read back as float32 exactly as the log holds it):

  cargo run --release -- import ../shared/data/real/adis16405_static/adis_16405_imu1.csv.gz -o /tmp/adis.log
  cargo run --release -- export /tmp/adis.log -o /tmp/adis.csv
  python3 tests/reference/allan_terms.py /tmp/adis.csv --rate 100 -o tests/fixtures/allan_terms_adis16405.json
  cargo run --release -- import ../shared/data/real/mpu6050_static_10min_temp/mpu6050_static.csv -o /tmp/mpu.log
  cargo run --release -- export /tmp/mpu.log -o /tmp/mpu.csv
  python3 tests/reference/allan_terms.py /tmp/mpu.csv --rate 99.31713766727061 -o tests/fixtures/allan_terms_mpu6050.json

--rate is the rate the log declares (`imuprep allan LOG` prints it; its report.json has every digit).
"""
import argparse
import json
import math

import numpy as np
import allantools
from allantools import ci as atci
from scipy.optimize import nnls, brentq
from scipy.special import digamma, polygamma

CHANNELS = ["gx", "gy", "gz", "ax", "ay", "az"]
LETTERS = ["Q", "N", "B", "K", "R"]
ALPHA = [2, 0, -1, -2, -2]
STOCK_EDF = False  # --allantools-edf: edf_greenhall as it is (F = m for 3m <= 100)


def basis(tau):
    tau = np.asarray(tau, dtype=float)
    return np.stack([3.0 / tau**2, 1.0 / tau, np.full_like(tau, 2.0 * math.log(2.0) / math.pi),
                     tau / 3.0, tau**2 / 2.0], axis=1)


def edf(alpha, m, n_phase):
    big_m = n_phase - 2 * m
    r = big_m / m
    if alpha == 2 and math.ceil(r) <= 2:
        # allantools leaves white PM with r <= 2 unimplemented; the exact three-term sum there
        pos = lambda v: max(v, 0.0)
        return 1.0 / ((1.0 + 8.0 / 9.0 * pos(1.0 - 1.0 / r) + 1.0 / 18.0 * pos(1.0 - 2.0 / r)) / big_m)
    j = min(big_m, 3 * m)
    if alpha <= 0 and j <= 100 and not STOCK_EDF:
        # edf_greenhall takes F = m here when 3m <= 100; for rate samples (phase = their running
        # sum) F = inf is right (src/stats/allan_edf.rs: Monte Carlo, white FM at m = 1:
        # F = m is 18 % high). allantools' own sum and sz with F = inf:
        inf = float("inf")
        return 1.0 / (atci.greenhall_BasicSum(j, big_m, m, inf, alpha, 2)
                      / (big_m * atci.greenhall_sz(0, inf, alpha, 2) ** 2))
    return float(atci.edf_greenhall(alpha, 2, m, n_phase, overlapping=True, modified=False))


def dominant(c, tau):
    return int(np.argmax(c * basis([tau])[0]))


def edfs(c, taus, ms, n_phase):
    out = []
    for t, m in zip(taus, ms):
        j = 1 if c is None else dominant(c, t)
        out.append((ALPHA[j], edf(ALPHA[j], m, n_phase)))
    return out


def model(c, taus):
    return basis(taus) @ c


def sds(c, taus, avar, nus, eps):
    mv = model(c, taus)
    base = np.where(mv > 0, mv, avar)
    nu = np.array([n for _, n in nus])
    return base * np.sqrt(2.0 / nu + eps * eps)


def solve(taus, avar, sd, allowed):
    a = basis(taus) / sd[:, None]
    b = avar / sd
    norms = np.maximum(np.linalg.norm(a, axis=0), np.finfo(float).tiny)
    cols = np.flatnonzero(allowed)
    x, _ = nnls((a / norms)[:, cols], b)
    c = np.zeros(5)
    c[cols] = x / norms[cols]
    cov = np.zeros((5, 5))
    act = np.flatnonzero(c > 0)
    if act.size:
        s = (a / norms)[:, act]
        inv = np.linalg.inv(s.T @ s)
        cov[np.ix_(act, act)] = inv / np.outer(norms[act], norms[act])
    return c, cov


def chi2(c, taus, avar, sd):
    return float(np.sum(((avar - model(c, taus)) / sd) ** 2))


def floor_eps(c, taus, avar, nus, dof):
    # log-domain: ln(s2/sigma2) has mean psi(nu/2) - ln(nu/2) and variance psi'(nu/2)
    if dof == 0:
        return 0.0
    h = np.array([n for _, n in nus]) / 2.0
    r2 = (np.log(avar / model(c, taus)) - (digamma(h) - np.log(h))) ** 2
    v = polygamma(1, h)
    f = lambda le2: float(np.sum(r2 / (v + math.exp(le2)))) - dof
    if not np.sum(r2 / v) > dof:
        return 0.0
    return math.sqrt(math.exp(brentq(f, math.log(1e-12), math.log(1e4), xtol=1e-14, rtol=1e-14)))


def passes_with(taus, ms, avar, n_phase, allowed):
    dof = lambda c: len(taus) - int(np.sum(c > 0))
    c, cov = solve(taus, avar, sds(np.zeros(5), taus, avar, edfs(None, taus, ms, n_phase), 0.0), allowed)
    eps = floor_eps(c, taus, avar, edfs(c, taus, ms, n_phase), dof(c))
    rel = lambda a, b: abs(a - b) / max(abs(a), abs(b)) if max(abs(a), abs(b)) > 0 else 0.0
    passes, converged = 0, False
    while passes < 50:
        passes += 1
        c_new, cov_new = solve(taus, avar, sds(c, taus, avar, edfs(c, taus, ms, n_phase), eps), allowed)
        eps_new = floor_eps(c_new, taus, avar, edfs(c_new, taus, ms, n_phase), dof(c_new))
        change = max([rel(eps, eps_new)] + [rel(math.sqrt(a), math.sqrt(b)) for a, b in zip(c, c_new)])
        c, cov, eps = c_new, cov_new, eps_new
        if change < 1e-6:
            converged = True
            break
    return c, cov, eps, passes, converged


def fit(taus, ms, adev, n_phase):
    avar = adev**2
    allowed = np.ones(5, dtype=bool)
    total = 0
    while True:
        # backward elimination of the least significant positive term (z < 2)
        c, cov, eps, passes, converged = passes_with(taus, ms, avar, n_phase, allowed)
        total += passes
        z = [(c[j] / math.sqrt(cov[j, j]) if cov[j, j] > 0 else 0.0, j) for j in range(5) if c[j] > 0]
        weak = [zj for zj in z if zj[0] < 2.0]
        if not weak:
            break
        allowed[min(weak)[1]] = False
    passes = total
    nus = edfs(c, taus, ms, n_phase)
    lo, hi = [], []
    for a, (_, nu) in zip(adev, nus):
        l, h = atci.confidence_interval(a, nu)
        lo.append(float(l))
        hi.append(float(h))
    hi = np.array(hi)
    terms = {}
    f = basis(taus)
    for j, letter in enumerate(LETTERS):
        dom = [t for t in taus if c[j] > 0 and dominant(c, t) == j]
        if not allowed[j]:
            res = "not_significant"
        elif not c[j] > 0:
            res = "fitted_zero"
        elif not dom:
            res = "never_dominant"
        else:
            res = "resolved"
        terms[letter] = {
            "coefficient": math.sqrt(c[j]),
            "resolution": res,
            "upper_bound": float(np.min(hi / np.sqrt(f[:, j]))),
        }
    return {
        "edf": [n for _, n in nus],
        "alpha": [a for a, _ in nus],
        "lo": lo,
        "hi": hi.tolist(),
        "model_error": eps,
        "passes": passes,
        "converged": converged,
        "terms": terms,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", help="canonical CSV from `imuprep export LOG -o CSV`")
    ap.add_argument("--rate", type=float, required=True, help="the log's declared rate, Hz")
    ap.add_argument("-o", "--out", required=True, help="fixture JSON")
    ap.add_argument("--allantools-edf", action="store_true",
                    help="use edf_greenhall unchanged (F = m at small m) to see what that choice moves")
    args = ap.parse_args()
    global STOCK_EDF
    STOCK_EDF = args.allantools_edf
    with open(args.csv) as f:
        header = f.readline().strip().split(",")
    assert header[1:7] == CHANNELS, header
    # the log stores float32 and the CSV prints each one's shortest decimal: parsing as float32
    # gives back exactly the values the log holds
    data = np.loadtxt(args.csv, delimiter=",", skiprows=1, usecols=range(1, 7), dtype=np.float32)
    out = {"rate_hz": args.rate, "channels": {}}
    for k, ch in enumerate(CHANNELS):
        y = data[:, k].astype(np.float64)
        n_phase = len(y) + 1
        ms = []
        m = 1
        while n_phase - 2 * m >= 2:
            ms.append(m)
            m *= 2
        taus_in = np.array(ms, dtype=float) / args.rate
        taus, adev, _, ns = allantools.oadev(y, rate=args.rate, data_type="freq", taus=taus_in)
        assert len(taus) == len(ms), (len(taus), len(ms))
        r = fit(np.asarray(taus), ms, np.asarray(adev), n_phase)
        r.update({"n_samples": len(y), "tau_s": list(map(float, taus)), "m": ms,
                  "adev": list(map(float, adev)), "n_terms": list(map(int, ns))})
        out["channels"][ch] = r
        print(ch, {k: (v["resolution"], "%.4e" % v["coefficient"]) for k, v in r["terms"].items()},
              "eps %.3f" % r["model_error"], "passes", r["passes"])
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
