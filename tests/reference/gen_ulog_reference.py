#!/usr/bin/env python3
"""Reference values of the real PX4 logs in ../shared/data/real/px4_ulog, read with pyulog (a
reader nobody here wrote), for tests/protocols_reference.rs: per file and topic instance the
number of sensor_combined samples and three rows (first, middle, last) of time and values. The logs themselves
are not copied into the repository.

    python3 tests/reference/gen_ulog_reference.py
"""
import os
from pyulog import ULog

D = os.path.join(os.path.dirname(__file__), "../../../shared/data/real/px4_ulog")
rows = []
for name in sorted(os.listdir(D)):
    if not name.endswith(".ulg"):
        continue
    u = ULog(os.path.join(D, name), ["sensor_combined"])
    for d in u.data_list:
        if d.name == "sensor_combined":
            n = len(d.data["timestamp"])
            for i in (0, n // 2, n - 1):
                v = [d.data[f"gyro_rad[{k}]"][i] for k in range(3)] + [d.data[f"accelerometer_m_s2[{k}]"][i] for k in range(3)]
                rows.append((name, "sensor_combined", d.multi_id, n, i, int(d.data["timestamp"][i]), *[repr(float(x)) for x in v]))
with open("ulog_expected.csv", "w") as f:
    f.write("file,topic,instance,n,row,t_us,gx,gy,gz,ax,ay,az\n")
    for r in rows:
        f.write(",".join(str(x) for x in r) + "\n")
print(len(rows), "rows")
