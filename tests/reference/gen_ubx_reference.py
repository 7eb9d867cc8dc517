#!/usr/bin/env python3
"""UBX reference stream made with pyubx2 (an encoder nobody here wrote), and the values pyubx2
reads back from it, for tests/protocols_reference.rs.

Writes ubx_stream.bin: NMEA sentences, NAV-PVT and ESF-STATUS messages interleaved with
  - ESF-RAW messages carrying 4 sets each (gyro x/y/z, accel x/y/z, gyro temperature per
    24-bit sensor time tag, 256 counts apart; the tag wraps past 2^24 in the middle),
  - ESF-MEAS pairs as a ZED-F9R sends them: accel x/y/z in one message, gyro x/y/z + temperature
    in the next, same time tag (ms), with calibTtag.
and ubx_expected.csv: one row per IMU sample, values from pyubx2's parse of the stream
(24-bit fields sign-extended, gyro 2^-12 deg/s → rad/s, accel 2^-10 m/s², temp 1e-2 °C).

    python3 tests/reference/gen_ubx_reference.py
"""
import math, random, struct, io
from pyubx2 import UBXMessage, UBXReader, SET, GET
from pynmeagps import NMEAMessage
from ubx_rows import add_imu, csv_line

random.seed(14)
out = bytearray()

def word(ty, raw):
    return ((ty & 0xFF) << 24) | (raw & 0xFFFFFF)

def raw_msg(blocks):
    # pyubx2 builds the repeating group from payload bytes.
    payload = b"\x00\x00\x00\x00" + b"".join(struct.pack("<II", w, t) for w, t in blocks)
    return UBXMessage("ESF", "ESF-RAW", 0, payload=payload)

def meas_msg(tag, words, calib):
    flags = (len(words) << 11) | 0x08
    payload = struct.pack("<IHH", tag, flags, 0) + b"".join(struct.pack("<I", w) for w in words) + struct.pack("<I", calib)
    return UBXMessage("ESF", "ESF-MEAS", 0, payload=payload)

def nmea():
    return NMEAMessage("GN", "GGA", GET, lat=48.1 + random.random() * 1e-3, lon=11.5, quality=1, numSV=9).serialize()

def rnd(scale):
    return int(round(random.gauss(0, scale)))

tag = 0xFFFE00
for m in range(12):
    out += nmea()
    blocks = []
    for k in range(4):
        gx, gy, gz = rnd(400), rnd(400), rnd(400)
        ax, ay, az = rnd(100), rnd(100), 10042 + rnd(50)
        temp = 3125 + rnd(20)
        for ty, v in ((14, gx), (13, gy), (5, gz), (16, ax), (17, ay), (18, az), (12, temp)):
            blocks.append((word(ty, v), tag & 0xFFFFFF))
        tag += 256
    out += raw_msg(blocks).serialize()
    out += UBXMessage("NAV", "NAV-PVT", 0, iTOW=m * 1000, numSV=9, lat=48.1, lon=11.5).serialize()
t_ms = 130956
for m in range(10):
    ax, ay, az = rnd(100), rnd(100), 10091 + rnd(30)
    gx, gy, gz, temp = rnd(300), rnd(300), rnd(300), 3549 + rnd(10)
    out += meas_msg(t_ms, [word(16, ax), word(17, ay), word(18, az)], t_ms).serialize()
    if m % 3 == 0:
        out += nmea()
    out += meas_msg(t_ms, [word(14, gx), word(13, gy), word(5, gz), word(12, temp)], t_ms).serialize()
    t_ms += 10
out += UBXMessage("ESF", "ESF-STATUS", 0, iTOW=1, version=2, fusionMode=1, numSens=0).serialize()
open("ubx_stream.bin", "wb").write(bytes(out))

# Read back with pyubx2 and write the expected samples.
rows = []
nmea_n = other_n = 0
for raw, parsed in UBXReader(io.BytesIO(bytes(out)), protfilter=7):
    if add_imu(rows, raw, parsed):
        pass
    elif hasattr(parsed, "talker"):
        nmea_n += 1
    else:
        other_n += 1

with open("ubx_expected.csv", "w") as f:
    f.write(f"# pyubx2 read {len(rows)} IMU samples, {nmea_n} NMEA, {other_n} other UBX messages\n")
    f.write("kind,tag,gx,gy,gz,ax,ay,az,temp\n")
    f.writelines(csv_line(r) for r in rows)
print(len(rows), "samples;", nmea_n, "NMEA;", other_n, "other UBX;", len(out), "bytes")
