#!/usr/bin/env python3
"""ROS 2 bag (MCAP, rosbags' writer) with an Imu topic and a Temperature topic, and the
temperature each Imu message should get, for tests/ros2_mcap.rs.

Writes mcap_temp_bag.mcap:
  - /imu/data         sensor_msgs/msg/Imu, 40 messages at 200 Hz, logged 0.3 ms after their stamp;
  - /imu/temperature  sensor_msgs/msg/Temperature, 20 Hz, the first one stamped 12 ms after the
                      first Imu message, each logged 7 ms after its stamp (a slow driver: the Imu
                      messages stamped in those 7 ms are in the file before the reading that
                      precedes them);
and mcap_temp_expected.csv: per Imu message (file order, as rosbags reads them) the stamp and the
temperature of the nearest preceding (or equal) stamp among the readings read so far, blank
when there is none. The rule is computed here on rosbags' deserialised values.

    python3 tests/reference/gen_mcap_temperature.py
"""
import numpy as np
from rosbags.rosbag2 import Reader

from rosbags_common import HERE, Imu, Quat, Temperature, Vec3, header, ts, write_bag, write_csv


t0 = 1_700_000_100 * 10**9 + 1_000_000
msgs = []  # (topic, log time, message)
for k in range(40):
    t = t0 + k * 5_000_000
    m = Imu(header=header(t, "imu_link"), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.array([-1.0] + [0.0] * 8),
            angular_velocity=Vec3(x=0.001 * k, y=0.0, z=0.0), angular_velocity_covariance=np.zeros(9),
            linear_acceleration=Vec3(x=0.0, y=0.0, z=9.8), linear_acceleration_covariance=np.zeros(9))
    msgs.append(("/imu/data", t + 300_000, m))
for k in range(4):
    t = t0 + 12_000_000 + k * 50_000_000
    m = Temperature(header=header(t, "imu_link"), temperature=31.5 + 0.25 * k, variance=0.01)
    msgs.append(("/imu/temperature", t + 7_000_000, m))
msgs.sort(key=lambda m: m[1])

write_bag(HERE / "mcap_temp_bag.mcap", (("/imu/data", Imu), ("/imu/temperature", Temperature)), msgs)

rows, readings = [], []
with Reader(HERE / "mcap_temp_bag.mcap") as r:
    for conn, t, raw in r.messages():
        m = ts.deserialize_cdr(raw, conn.msgtype)
        st = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        if conn.msgtype == "sensor_msgs/msg/Temperature":
            readings.append((st, m.temperature))
            continue
        before = [x for x in readings if x[0] <= st]
        temp = repr(max(before)[1]) if before else ""
        rows.append([st, temp])
write_csv(HERE / "mcap_temp_expected.csv", ["stamp_ns", "temp_c"], rows)
print(f"{len(rows)} Imu rows, {sum(1 for r in rows if r[1])} with a temperature")
