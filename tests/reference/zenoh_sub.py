#!/usr/bin/env python3
"""Cross-check of imuprep's Zenoh sink with a consumer nobody here wrote: eclipse-zenoh (Python).

A peer session listens on a free localhost port (multicast scouting off); `imuprep replay
replay/drive.log` (a build with --features zenoh) connects to it and publishes with
`--out 'zenoh:imuprep/xcheck/imu?wait=10&congestion=block'` beside a `csv:` sink (block: the
offline replay goes at this subscriber's pace; with the default, drop, a full-speed replay can
outrun a Python subscriber, and what Zenoh drops is counted in the sink's summary instead). This script decodes the native
frames it receives with its own reading of docs/frame-format.md (sync, version, type, length,
CRC-16 header check, CRC-32C trailer, payload fields) and checks every sample against the csv:
sink's export, and reads the health JSON on imuprep/xcheck/imu/health. It prints its result;
that output is committed as tests/reference/zenoh_sub_result.txt, and tests/zenoh.rs computes
the same lines (after the first) from its own Rust subscriber and compares.

    cargo build --release --features zenoh
    pip install eclipse-zenoh==1.10.2
    python3 tests/reference/zenoh_sub.py > tests/reference/zenoh_sub_result.txt
"""
import json, math, socket, struct, subprocess, sys, tempfile, time
from pathlib import Path

import zenoh

ROOT = Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release" / "imuprep"
KEY = "imuprep/xcheck/imu"


def crc_table(poly):
    t = []
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ poly if c & 1 else c >> 1
        t.append(c)
    return t


CRC32C = crc_table(0x82F63B78)


def crc32c(b):
    c = 0xFFFFFFFF
    for x in b:
        c = CRC32C[(c ^ x) & 0xFF] ^ (c >> 8)
    return c ^ 0xFFFFFFFF


def crc16_ccitt_false(b):
    c = 0xFFFF
    for x in b:
        c ^= x << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) & 0xFFFF if c & 0x8000 else (c << 1) & 0xFFFF
    return c


def frame(p):
    """One native frame: (type, seq, payload); asserts it is whole and its checks hold."""
    assert p[:2] == b"\xa5\x5a" and p[2] == 1, p[:4]
    typ, n, seq, hc = p[3], *struct.unpack_from("<HIH", p, 4)
    assert len(p) == 12 + n + 4, (len(p), n)
    assert crc16_ccitt_false(p[:10]) == hc
    assert crc32c(p[: 12 + n]) == struct.unpack_from("<I", p, 12 + n)[0]
    return typ, seq, p[12 : 12 + n]


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def main():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    conf.insert_json5("connect/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    # FIFO handlers (zenoh's default kind) large enough for the whole replay, drained after it:
    # a FIFO that is full holds up the session instead of losing samples, so what is counted
    # here is what the publisher sent.
    sub = session.declare_subscriber(KEY, zenoh.handlers.FifoChannel(100_000))
    hsub = session.declare_subscriber(KEY + "/health", zenoh.handlers.FifoChannel(1_000))
    with tempfile.TemporaryDirectory() as d:
        cfg, csv = Path(d) / "z.toml", Path(d) / "clean.csv"
        cfg.write_text(
            "[zenoh]\nmode = \"peer\"\n"
            f"connect = [\"tcp/127.0.0.1:{port}\"]\nlisten = [\"tcp/127.0.0.1:0\"]\n"
            "multicast_scouting = false\n"
        )
        subprocess.run(
            [str(BIN), "replay", "replay/drive.log", "--config", str(cfg),
             "--out", f"zenoh:{KEY}?wait=10&congestion=block", "--out", f"csv:{csv}"],
            cwd=ROOT, check=True, stderr=subprocess.DEVNULL)
        rows = csv.read_text().splitlines()[1:]
    # Take what arrived until nothing more comes for a second.
    payloads, health = [], []
    idle = time.time()
    while time.time() - idle < 1.0:
        got = False
        for h, out, f in ((sub, payloads, lambda p: bytes(p.to_bytes())),
                          (hsub, health, lambda p: json.loads(p.to_string()))):
            smp = h.try_recv()
            if smp is not None:
                out.append(f(smp.payload))
                got = True
        if got:
            idle = time.time()
        else:
            time.sleep(0.01)
    sub.undeclare()
    hsub.undeclare()
    session.close()

    descriptors, samples = [], []
    for p in payloads:
        typ, seq, pl = frame(p)
        if typ == 1:
            rate, gr, ar, axes, absent, dev = struct.unpack("<dffBB2xI", pl)
            descriptors.append((rate, gr, ar, dev, absent))
        else:
            assert typ in (2, 3), typ
            t, *vals = struct.unpack_from("<Q6ffI", pl)
            samples.append((seq, t, vals[:6], vals[6], vals[7]))
    from importlib.metadata import version
    print(f"consumer: eclipse-zenoh {version('eclipse-zenoh')} (Python), this script's own frame decoder")
    print(f"payloads: {len(payloads)} ({len(descriptors)} descriptor, {len(samples)} samples), "
          "each one whole frame with a good CRC-32C")
    rate, gr, ar, dev, absent = descriptors[0]

    def num(x):  # as Rust prints an f64 / f32 (shortest form that reads back)
        return repr(x) if x != int(x) else str(int(x))

    def num32(x):  # the shortest decimal that reads back as the same f32
        if x == int(x):
            return str(int(x))
        for p in range(1, 10):
            t = f"{x:.{p}g}"
            if f32(float(t)) == x:
                return t
        return repr(x)

    print(f"descriptor: rate {num(rate)} Hz, gyro range {num32(gr)} rad/s, accel range {num32(ar)} m/s2, "
          f"device {dev}, absent mask {absent}")
    same = [s[0] for s in samples] == [int(r.split(",")[8]) for r in rows]
    print(f"sequence: {samples[0][0]}..{samples[-1][0]}, "
          f"{'as in' if same else 'NOT as in'} the csv: sink's seq column")
    equal = 0
    for (seq, t, ch, temp, flags), row in zip(samples, rows):
        c = row.split(",")
        sec, ns = c[0].split(".")
        ok = int(sec) * 10**9 + int(ns) == t
        ok &= all(f32(float(c[1 + i])) == ch[i] for i in range(6))
        ok &= (c[7] == "" and math.isnan(temp)) or (c[7] != "" and f32(float(c[7])) == temp)
        ok &= int(c[8]) == seq and int(c[9]) == flags
        equal += ok
    print(f"values: {equal} of {len(rows)} csv: rows equal (t, gx..az, temp, seq, flags)")
    total = math.fsum(v for s in samples for v in s[2])
    # Rust sums in order, not exactly: agree to the printed 6 decimals.
    acc = 0.0
    for s in samples:
        for v in s[2]:
            acc += v
    print(f"sum of gx..az over every sample: {acc:.6f}")
    assert abs(acc - total) < 1e-6
    h = health[-1]
    print(f"health: last report samples_out={h['samples_out']} sink_dropped={h['sink_dropped']}")


if __name__ == "__main__":
    sys.exit(main())
