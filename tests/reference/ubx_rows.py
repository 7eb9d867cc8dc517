"""pyubx2's reading of UBX IMU messages as rows, shared by gen_ubx_reference.py and
check_inline_reference.py: one row per sample (ESF-RAW: per sensor time tag; ESF-MEAS: per
time tag, the two halves of a ZED-F9R pair joined), and the CSV line of a row in imuprep
units (24-bit fields sign-extended, gyro 2^-12 deg/s → rad/s, accel 2^-10 m/s², temp 1e-2 °C).
"""
import math


def s24(v):
    return v - (1 << 24) if v & 0x800000 else v


def add_imu(rows, raw, parsed):
    """Append the samples of one parsed message to rows; False when it is no IMU message."""
    if parsed.identity == "ESF-RAW":
        n = (len(raw) - 8 - 4) // 8
        sets, order = {}, []
        for i in range(1, n + 1):
            d = getattr(parsed, f"data_{i:02d}")
            t = getattr(parsed, f"sTag_{i:02d}")
            # pyubx2 keeps X4 fields as little-endian bytes.
            d = int.from_bytes(d, "little") if isinstance(d, bytes) else d
            t = (int.from_bytes(t, "little") if isinstance(t, bytes) else t) & 0xFFFFFF
            if t not in sets:
                sets[t] = {}
                order.append(t)
            sets[t][d >> 24] = s24(d & 0xFFFFFF)
        rows += [("raw", t, sets[t]) for t in order]
        return True
    if parsed.identity == "ESF-MEAS":
        vals = {}
        for i in range(1, parsed.numMeas + 1):
            vals[getattr(parsed, f"dataType_{i:02d}")] = s24(getattr(parsed, f"dataField_{i:02d}"))
        if rows and rows[-1][0] == "meas" and rows[-1][1] == parsed.timeTag and len(rows[-1][2]) < 7:
            rows[-1][2].update(vals)
        else:
            rows.append(("meas", parsed.timeTag, vals))
        return True
    return False


def csv_line(row):
    kind, t, v = row
    g = [math.radians(v[ty] * 2.0**-12) for ty in (14, 13, 5)]
    a = [v[ty] * 2.0**-10 for ty in (16, 17, 18)]
    return f"{kind},{t}," + ",".join(repr(x) for x in g + a) + f",{v[12] * 0.01!r}\n"
