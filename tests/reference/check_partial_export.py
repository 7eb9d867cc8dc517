#!/usr/bin/env python3
"""What the reference libraries read from imuprep's export of partial sensors, for
tests/partial_protocols.rs.

Reads the fixtures `partial_{gyro,accel}.{ubx,mavlink}` and `partial_gyro.ulg` (written by that
test with IMUPREP_BLESS=1: 20 samples of a gyro-only and an accel-only log exported with
`encode_stream`) with pyubx2, pymavlink and pyulog, and writes partial_export_reference.csv: one
row per IMU message, channels in imuprep units, an empty cell where the library's reading says
there is no data for that channel:
  - UBX ESF-RAW: no data word of the channel's data type (gyro x/y/z = 14/13/5 in 2^-12 deg/s,
    accel x/y/z = 16/17/18 in 2^-10 m/s^2; 24-bit fields sign-extended),
  - MAVLink HIGHRES_IMU: the channel's fields_updated bit clear (accel 0..2, gyro 3..5),
  - ULog sensor_combined: accelerometer_timestamp_relative == RELATIVE_TIMESTAMP_INVALID
    (0x7fffffff) for the three accel channels.

    cd tests/reference && python3 check_partial_export.py
"""
import math
from pyubx2 import UBXReader
from pymavlink.dialects.v20 import ardupilotmega as v2
from pyulog import ULog

rows = []


def fmt(v):
    return "" if v is None else repr(float(v))


def ubx(name):
    gyro_types = {14: 0, 13: 1, 5: 2}
    accel_types = {16: 3, 17: 4, 18: 5}
    with open(name, "rb") as f:
        for _, msg in UBXReader(f, protfilter=2):
            if msg.identity != "ESF-RAW":
                continue
            n = len([a for a in vars(msg) if a.startswith("data_")])
            vals = [None] * 6
            tag = None
            for i in range(1, n + 1):
                # X4 fields come as little-endian bytes.
                word = int.from_bytes(getattr(msg, f"data_{i:02d}"), "little")
                tag = int.from_bytes(getattr(msg, f"sTag_{i:02d}"), "little")
                ty = (word >> 24) & 0xFF
                raw = word & 0xFFFFFF
                raw = raw - (1 << 24) if raw & 0x800000 else raw
                if ty in gyro_types:
                    vals[gyro_types[ty]] = math.radians(raw / 4096.0)
                elif ty in accel_types:
                    vals[accel_types[ty]] = raw / 1024.0
            # Time: the sensor time tag, 39.0625 us per count (the decoder's default).
            rows.append((name, len([r for r in rows if r[0] == name]), round(tag * 39.0625), vals))


def mavlink(name):
    rd = v2.MAVLink(None)
    data = open(name, "rb").read()
    for msg in rd.parse_buffer(data) or []:
        if msg.get_type() != "HIGHRES_IMU":
            continue
        fu = msg.fields_updated
        src = [msg.xgyro, msg.ygyro, msg.zgyro, msg.xacc, msg.yacc, msg.zacc]
        bits = [3, 4, 5, 0, 1, 2]
        vals = [float(v) if fu & (1 << b) else None for v, b in zip(src, bits)]
        rows.append((name, len([r for r in rows if r[0] == name]), msg.time_usec, vals))


def ulog(name):
    u = ULog(name, ["sensor_combined"])
    d = u.get_dataset("sensor_combined").data
    for i in range(len(d["timestamp"])):
        g = [float(d[f"gyro_rad[{k}]"][i]) for k in range(3)]
        invalid = int(d["accelerometer_timestamp_relative"][i]) == 0x7FFFFFFF
        a = [None] * 3 if invalid else [float(d[f"accelerometer_m_s2[{k}]"][i]) for k in range(3)]
        rows.append((name, i, int(d["timestamp"][i]), g + a))


ubx("partial_gyro.ubx")
mavlink("partial_gyro.mavlink")
ulog("partial_gyro.ulg")
ubx("partial_accel.ubx")
mavlink("partial_accel.mavlink")

with open("partial_export_reference.csv", "w") as f:
    f.write("file,i,t_us,gx,gy,gz,ax,ay,az\n")
    for name, i, t, vals in rows:
        f.write(f"{name},{i},{t}," + ",".join(fmt(v) for v in vals) + "\n")
print(len(rows), "rows")
