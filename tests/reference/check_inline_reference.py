#!/usr/bin/env python3
"""Round trip through the reference decoders: imuprep's inline output of the pyubx2 and
pymavlink streams, with every IMU value of the selected stream shifted (gyro +0.01 rad/s,
accel -0.05 m/s², written by tests/protocols_inline_reference.rs with IMUPREP_BLESS=1 as
ubx_inline_shifted.bin and mavlink_inline_shifted.bin), read back by pyubx2 and pymavlink.

Checked here, against the same library's reading of the input (ubx_stream.bin,
mavlink_stream.bin): the same messages in the same order (identity, and for MAVLink system,
component and sequence), every message that carries no IMU sample of the selected stream
byte for byte the input's; the first CSV line says so. The rows (same format as
ubx_expected.csv / mavlink_expected.csv) are the values the library reads from the output; the
Rust test compares them with the input's values plus the shift, to the protocol's resolution.

    IMUPREP_BLESS=1 cargo test --release --test protocols_inline_reference
    python3 tests/reference/check_inline_reference.py
"""
import io
from pathlib import Path

from pyubx2 import UBXReader
from pymavlink.dialects.v20 import ardupilotmega as v2
from ubx_rows import add_imu, csv_line

HERE = Path(__file__).resolve().parent


def ubx_read(data):
    """(raw bytes, identity) of every message, and the IMU rows (ubx_rows.py)."""
    msgs, rows = [], []
    for raw, parsed in UBXReader(io.BytesIO(data), protfilter=7):
        msgs.append((raw, parsed.identity))
        add_imu(rows, raw, parsed)
    return msgs, rows


def ubx():
    src = (HERE / "ubx_stream.bin").read_bytes()
    out = (HERE / "ubx_inline_shifted.bin").read_bytes()
    (m_in, r_in), (m_out, r_out) = ubx_read(src), ubx_read(out)
    assert [i for _, i in m_out] == [i for _, i in m_in], "message identities differ"
    imu = ("ESF-RAW", "ESF-MEAS")
    assert all(a == b for (a, i), (b, _) in zip(m_in, m_out) if i not in imu), "a non-IMU message changed"
    assert len(r_out) == len(r_in) and [(k, t) for k, t, _ in r_out] == [(k, t) for k, t, _ in r_in]
    other = sum(1 for _, i in m_out if i not in imu)
    with open(HERE / "ubx_inline_shifted_pyubx2.csv", "w") as f:
        f.write(f"# pyubx2 read {len(r_out)} IMU samples; all {len(m_out)} messages in the input's order, "
                f"the {other} others byte for byte\n")
        f.write("kind,tag,gx,gy,gz,ax,ay,az,temp\n")
        f.writelines(csv_line(r) for r in r_out)
    return len(r_out), len(m_out)


def mav_read(data):
    rd = v2.MAVLink(None)
    rd.robust_parsing = True
    return rd.parse_buffer(data) or []


def mavlink():
    src = (HERE / "mavlink_stream.bin").read_bytes()
    out = (HERE / "mavlink_inline_shifted.bin").read_bytes()
    m_in, m_out = mav_read(src), mav_read(out)
    key = lambda m: (m.get_type(), m.get_srcSystem(), m.get_srcComponent(), m.get_seq())
    assert [key(m) for m in m_out] == [key(m) for m in m_in], "messages differ"
    sel = lambda m: m.get_type() == "HIGHRES_IMU" and m.get_srcSystem() == 1 and m.id == 0
    same = sum(1 for a, b in zip(m_in, m_out) if not sel(a) and a.get_msgbuf() == b.get_msgbuf())
    assert same == sum(1 for a in m_in if not sel(a)), "a message outside the selected stream changed"
    rows = [(m.get_srcSystem(), m.get_srcComponent(), 105, m.id, m.time_usec * 1000,
             m.xgyro, m.ygyro, m.zgyro, m.xacc, m.yacc, m.zacc, m.temperature)
            for m in m_out if sel(m)]
    with open(HERE / "mavlink_inline_shifted_pymavlink.csv", "w") as f:
        f.write(f"# pymavlink read all {len(m_out)} messages in the input's order (type, ids, sequence), "
                f"the {same} outside the selected stream byte for byte\n")
        f.write("sysid,compid,msgid,instance,t_ns,gx,gy,gz,ax,ay,az,temp\n")
        for r in rows:
            f.write(",".join(repr(x) if isinstance(x, float) else str(x) for x in r) + "\n")
    return len(rows), len(m_out)


print("pyubx2: %d samples, %d messages" % ubx())
print("pymavlink: %d selected samples, %d messages" % mavlink())
