"""Compare `imuprep navtest --json` (imuprep's own filter) with the reference filter's per-outage
errors (`navtest.py --errors-json`), raw IMU, same outage schedule.

    python3 tests/reference/navtest/navtest.py --variants raw --jobs 2 --errors-json ref.json
    target/release/imuprep navtest --no-static --json rust.json
    python3 tests/reference/navtest/compare_rust.py ref.json rust.json
    python3 tests/reference/navtest/compare_rust.py A.json B.json C.json rust.json   # staged runs

Prints, per recording and outage length: medians and 95th percentiles (numpy's linear
interpolation) of the horizontal and vertical error at the outage end, their ratio Rust /
reference, and the rank correlation of the per-outage horizontal errors. Recordings and lengths
the reference files do not hold are skipped. Then, from the reference files alone, every
variant's median and p95 against (a)'s on the same outages ((c): its held-out outages), to
3 decimals — the do-no-harm check of the reference filter.
"""
import json
import sys

import numpy as np
from scipy.stats import spearmanr


def main(ref_paths, rust_path):
    # Staged runs may hold the same (a) outage twice: keep one per (log, variant, length, start).
    ref = list({(e["log"], e["variant"], e["length_s"], round(e["start_rel_s"], 3)): e
                for p in ref_paths for e in json.load(open(p))}.values())
    rust = json.load(open(rust_path))
    print("| record | outage s | n | ref. horiz. median / p95 m | Rust median / p95 m | ratio median / p95 "
          "| ref. vert. median m | Rust vert. median m | rank corr. (per outage) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for rec in rust["records"]:
        for length in (10.0, 30.0, 60.0):
            r = sorted((e["start_rel_s"], e["horiz_m"], e["vert_m"]) for e in ref
                       if e["log"] == rec["name"] and e["variant"] == "raw" and e["length_s"] == length)
            o = sorted((e["start_rel_s"], e["horiz_m"], e["vert_m"]) for v, e in rec["outages"]
                       if v == "(a) raw" and e["length_s"] == length)
            if not r:
                continue
            if len(r) != len(o) or any(abs(a[0] - b[0]) > 0.2 for a, b in zip(r, o)):
                raise SystemExit("%s %g s: the outage schedules differ" % (rec["name"], length))
            rh, oh = np.array([x[1] for x in r]), np.array([x[1] for x in o])
            rv, ov = np.array([x[2] for x in r]), np.array([x[2] for x in o])
            rm, rp, om, op = np.median(rh), np.percentile(rh, 95), np.median(oh), np.percentile(oh, 95)
            rho = spearmanr(rh, oh).correlation
            print("| %s | %.0f | %d | %.2f / %.2f | %.2f / %.2f | %.2f / %.2f | %.2f | %.2f | %.2f |"
                  % (rec["name"], length, len(r), rm, rp, om, op, om / rm, op / rp,
                     np.median(rv), np.median(ov), rho))
    print()
    print("Per outage, horizontal m (reference / Rust):")
    for rec in rust["records"]:
        for length in (10.0, 30.0, 60.0):
            r = sorted((e["start_rel_s"], e["horiz_m"]) for e in ref
                       if e["log"] == rec["name"] and e["variant"] == "raw" and e["length_s"] == length)
            o = sorted((e["start_rel_s"], e["horiz_m"]) for v, e in rec["outages"]
                       if v == "(a) raw" and e["length_s"] == length)
            if r:
                print("%s %.0f s: " % (rec["name"], length)
                      + ", ".join("%.1f: %.1f/%.1f" % (a[0], a[1], b[1]) for a, b in zip(r, o)))
    harm(ref)


def harm(ref):
    """Each variant against (a) on the same outages of the reference filter, 3 decimals."""
    print()
    print("| record | outage s | variant | n | (a) median / p95 m | variant median / p95 m "
          "| difference median / p95 m |")
    print("|---|---:|---|---:|---:|---:|---:|")
    rows = {(e["log"], e["length_s"], e["variant"], round(e["start_rel_s"], 3)): e for e in ref}
    keys = sorted({(k[0], k[1], k[2]) for k in rows})
    for log, length, variant in keys:
        if variant == "raw":
            continue
        starts = [k[3] for k in rows if k[:3] == (log, length, variant)]
        a = np.array([rows[(log, length, "raw", s)]["horiz_m"] for s in starts])
        v = np.array([rows[(log, length, variant, s)]["horiz_m"] for s in starts])
        am, ap, vm, vp = np.median(a), np.percentile(a, 95), np.median(v), np.percentile(v, 95)
        print("| %s | %.0f | %s | %d | %.3f / %.3f | %.3f / %.3f | %+.3f / %+.3f |"
              % (log, length, variant, len(starts), am, ap, vm, vp, vm - am, vp - ap))


if __name__ == "__main__":
    main(sys.argv[1:-1], sys.argv[-1])
