#!/usr/bin/env python3
"""A MAVLink telemetry log (.tlog) of the reference stream, for tests/protocols_reference.rs.

mavlink_stream.tlog: every message of mavlink_stream.bin (gen_mavlink_reference.py), in order,
each after an 8-byte big-endian time stamp in µs since 1970 (the .tlog layout QGroundControl,
Mission Planner and MAVProxy write), read back with pymavlink's own tlog reader
(mavutil.mavlink_connection on a .tlog), which must find the same 185 messages with the stamps
written. The values are those of mavlink_expected.csv.

    python3 tests/reference/gen_tlog_reference.py
"""
import struct
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as v2

data = open("mavlink_stream.bin", "rb").read()
rd = v2.MAVLink(None)
rd.robust_parsing = True
msgs = rd.parse_buffer(data) or []
t0_us = 1_714_564_800_000_000  # 2024-05-01T12:00:00Z
out = bytearray()
for i, m in enumerate(msgs):
    out += struct.pack(">Q", t0_us + i * 2500) + m.get_msgbuf()
open("mavlink_stream.tlog", "wb").write(out)

# pymavlink's tlog reader: every message, each with the stamp written before it.
log = mavutil.mavlink_connection("mavlink_stream.tlog", dialect="ardupilotmega")
n = 0
while True:
    m = log.recv_match()
    if m is None:
        break
    assert abs(m._timestamp - (t0_us + n * 2500) * 1e-6) < 1e-6, (n, m._timestamp)
    n += 1
assert n == len(msgs) == 185, (n, len(msgs))
print(n, "messages;", len(out), "bytes")
