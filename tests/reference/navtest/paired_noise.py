"""Is a do-no-harm cell above (a) more than the outage sample's own noise?

(b) and (a) run the same outages, so each outage gives a pair. Per recording and outage length
this prints the (b) − (a) difference of the median and of the 95th percentile (numpy's linear
interpolation, as the tables) of the horizontal error at the outage end, with a paired bootstrap
95 % interval (outages resampled with replacement, the same draw for both variants; 5 000
draws, seed 1), the number of outages where (b) > (a), and the Wilcoxon signed-rank p of the
per-outage differences.

    python3 tests/reference/navtest/paired_noise.py A.json [B.json ...]   # navtest.py --errors-json
    python3 tests/reference/navtest/paired_noise.py --rust rust.json       # imuprep navtest --json

Reference files may be staged runs (the same (a) outage in two files is kept once; later files'
(b) rows replace earlier ones, as compare_rust.py does).
"""
import json
import sys
from collections import defaultdict

import numpy as np
from scipy.stats import wilcoxon

DRAWS = 5000


def pairs_reference(paths):
    rows = {}
    for p in paths:
        for e in json.load(open(p)):
            rows[(e["log"], e["variant"], e["length_s"], round(e["start_rel_s"], 3))] = e["horiz_m"]
    out = defaultdict(dict)
    for (log, variant, length, start), h in rows.items():
        name = {"raw": "a", "default": "b"}.get(variant)
        if name:
            out[(log, length)].setdefault(start, {})[name] = h
    return out


def pairs_rust(path):
    out = defaultdict(dict)
    for rec in json.load(open(path))["records"]:
        for variant, e in rec["outages"]:
            name = {"(a) raw": "a", "(b) imuprep default": "b"}.get(variant)
            if name:
                out[(rec["name"], e["length_s"])].setdefault(round(e["start_rel_s"], 3), {})[name] = e["horiz_m"]
    return out


def main(argv):
    pairs = pairs_rust(argv[1]) if argv[0] == "--rust" else pairs_reference(argv)
    rng = np.random.default_rng(1)
    print("| record | outage s | n | (b) − (a) median m [95 % CI] | (b) − (a) p95 m [95 % CI] "
          "| outages (b) > (a) | Wilcoxon p |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for (log, length), by_start in sorted(pairs.items()):
        both = [v for _, v in sorted(by_start.items()) if "a" in v and "b" in v]
        if len(both) < 5:
            continue
        a = np.array([v["a"] for v in both])
        b = np.array([v["b"] for v in both])
        d_med = np.median(b) - np.median(a)
        d_p95 = np.percentile(b, 95) - np.percentile(a, 95)
        bm, bp = [], []
        for _ in range(DRAWS):
            i = rng.integers(0, len(a), len(a))
            bm.append(np.median(b[i]) - np.median(a[i]))
            bp.append(np.percentile(b[i], 95) - np.percentile(a[i], 95))
        diff = b - a
        p = wilcoxon(diff).pvalue if np.any(diff != 0) else 1.0
        print("| %s | %g | %d | %+.3f [%+.3f, %+.3f] | %+.3f [%+.3f, %+.3f] | %d of %d | %.2f |" % (
            log, length, len(a), d_med, *np.percentile(bm, [2.5, 97.5]),
            d_p95, *np.percentile(bp, [2.5, 97.5]), (diff > 0).sum(), len(diff), p))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    main(sys.argv[1:])
