#!/usr/bin/env python3
"""MAVLink reference stream made with pymavlink (an encoder nobody here wrote), and the values
pymavlink reads back, for tests/protocols_reference.rs.

mavlink_stream.bin: v2 HEARTBEAT and ATTITUDE from system 1, HIGHRES_IMU instances 0 and 1 from
(1, 1), SCALED_IMU2 from (2, 1), SCALED_IMU as MAVLink v1 from (3, 1), RAW_IMU from (4, 1), a
few frames signed (v2 signing, the signature tolerated), all interleaved.
mavlink_expected.csv: one row per IMU message as pymavlink parses it, in imuprep units
(HIGHRES as sent in f32; SCALED mG → m/s² with 9.80665e-3, mrad/s → rad/s, c°C → °C;
RAW_IMU counts × 1e-3 rad/s and × 1e-2 m/s², the scales the test configures).

    python3 tests/reference/gen_mavlink_reference.py
"""
import io, random
from pymavlink.dialects.v20 import ardupilotmega as v2
from pymavlink.dialects.v10 import ardupilotmega as v1

random.seed(14)

class Buf(io.BytesIO):
    pass

b = Buf()
m2 = {s: v2.MAVLink(b, srcSystem=s, srcComponent=1) for s in (1, 2, 4)}
m1 = v1.MAVLink(b, srcSystem=3, srcComponent=1)
m2[1].signing.secret_key = bytes(range(32))
m2[1].signing.link_id = 0
m2[1].signing.timestamp = 1
G = 9.80665e-3
for i in range(40):
    t_us = 1_000_000 + i * 5000
    m2[1].signing.sign_outgoing = (i % 10 == 5)
    if i % 8 == 0:
        m2[1].heartbeat_send(2, 12, 0, 0, 4)
    for inst in (0, 1):
        g = [random.gauss(0, 0.05) for _ in range(3)]
        a = [random.gauss(0, 0.2), random.gauss(0, 0.2), -9.81 + random.gauss(0, 0.05)]
        m2[1].highres_imu_send(t_us, *a, *g, 0.2, 0.0, 0.4, 1013.0, 0.0, 100.0, 35.5 + inst, 0x3F | 0x1000, inst)
    m2[1].signing.sign_outgoing = False
    m2[1].attitude_send(t_us // 1000, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0)
    if i % 2 == 0:
        m2[2].scaled_imu2_send(t_us // 1000, random.randint(-200, 200), random.randint(-200, 200), -1000 + random.randint(-20, 20),
                               random.randint(-300, 300), random.randint(-300, 300), random.randint(-300, 300), 0, 0, 0, 3650)
        m1.scaled_imu_send(t_us // 1000, 5, -3, -1002, 10, -20, 30, 0, 0, 0)
        m2[4].raw_imu_send(t_us, 12, -7, -981, 3, -2, 1, 0, 0, 0, 0, 2900)
data = b.getvalue()
open("mavlink_stream.bin", "wb").write(data)

# Read back with pymavlink (v2 parser reads v1 frames too).
rd = v2.MAVLink(None)
rd.robust_parsing = True
rows = []
for msg in rd.parse_buffer(data) or []:
    t = msg.get_type()
    h = msg.get_header()
    if t == "HIGHRES_IMU":
        rows.append((h.srcSystem, h.srcComponent, 105, msg.id, msg.time_usec * 1000,
                     msg.xgyro, msg.ygyro, msg.zgyro, msg.xacc, msg.yacc, msg.zacc, msg.temperature))
    elif t in ("SCALED_IMU", "SCALED_IMU2"):
        mid, inst = (26, 0) if t == "SCALED_IMU" else (116, 1)
        temp = getattr(msg, "temperature", 0)
        rows.append((h.srcSystem, h.srcComponent, mid, inst, msg.time_boot_ms * 1_000_000,
                     msg.xgyro * 1e-3, msg.ygyro * 1e-3, msg.zgyro * 1e-3, msg.xacc * G, msg.yacc * G, msg.zacc * G,
                     temp * 0.01 if temp else ""))
    elif t == "RAW_IMU":
        rows.append((h.srcSystem, h.srcComponent, 27, msg.id, msg.time_usec * 1000,
                     msg.xgyro * 1e-3, msg.ygyro * 1e-3, msg.zgyro * 1e-3, msg.xacc * 1e-2, msg.yacc * 1e-2, msg.zacc * 1e-2,
                     msg.temperature * 0.01 if msg.temperature else ""))
total = len(rd.parse_buffer(data) or [])
with open("mavlink_expected.csv", "w") as f:
    f.write(f"# pymavlink read {total} messages, {len(rows)} IMU\n")
    f.write("sysid,compid,msgid,instance,t_ns,gx,gy,gz,ax,ay,az,temp\n")
    for r in rows:
        f.write(",".join(repr(x) if isinstance(x, float) else str(x) for x in r) + "\n")
print(total, "messages;", len(rows), "IMU;", len(data), "bytes")
