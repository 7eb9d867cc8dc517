#!/usr/bin/env python3
"""ROS 2 bag (MCAP storage) made with `rosbags` (a writer nobody here wrote), and the values
rosbags reads back from it, for tests/ros2_mcap.rs.

Writes mcap_bag.mcap: a rosbag2 MCAP file (rosbags' writer: chunked, uncompressed, indexed) with
  - /imu/data   sensor_msgs/msg/Imu, 60 messages at 200 Hz, covariances filled, frame_id
                "imu_link"; one message time-stamped 10 ms late (a gap of one period);
  - /imu/second sensor_msgs/msg/Imu, 20 messages at 50 Hz, frame_id "" (an empty string shifts
                the CDR alignment of everything after it);
  - /chatter    std_msgs/msg/String, 12 messages (not IMU: passed through).
and mcap_expected.csv: one row per Imu message as rosbags deserialises it (topic, header stamp,
log time, angular velocity, linear acceleration, the three covariance diagonals).

    python3 tests/reference/gen_mcap_reference.py
"""
import random

import numpy as np
from rosbags.rosbag2 import Reader

from rosbags_common import HERE, IMU_COLUMNS, Imu, Quat, String, Vec3, header, imu_row, write_bag, write_csv

random.seed(14)


def cov(d):
    c = np.zeros(9)
    c[0], c[4], c[8] = d
    c[1] = c[3] = d[0] * 0.1  # one off-diagonal pair, to show only the diagonal is published
    return c


def imu(t_ns, frame, g, a):
    return Imu(
        header=header(t_ns, frame),
        orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.array([-1.0] + [0.0] * 8),
        angular_velocity=Vec3(x=g[0], y=g[1], z=g[2]),
        angular_velocity_covariance=cov([1e-6, 2e-6, 3e-6]),
        linear_acceleration=Vec3(x=a[0], y=a[1], z=a[2]),
        linear_acceleration_covariance=cov([4e-4, 5e-4, 6e-4]),
    )


msgs = []  # (topic, log_time_ns, message)
t0 = 1_700_000_000 * 10**9 + 123_456_789
for k in range(60):
    t = t0 + k * 5_000_000 + (5_000_000 if k >= 30 else 0)  # message 30 comes 10 ms after 29
    g = [random.gauss(0, 0.01), random.gauss(0, 0.01), random.gauss(0.002, 0.01)]
    a = [random.gauss(0, 0.05), random.gauss(0, 0.05), 9.80665 + random.gauss(0, 0.05)]
    msgs.append(("/imu/data", t + 300_000, imu(t, "imu_link", g, a)))
for k in range(20):
    t = t0 + 1_000_000 + k * 20_000_000
    msgs.append(("/imu/second", t + 200_000, imu(t, "", [0.1 * k, -0.2, 0.3], [1.0, -2.0, -9.7])))
for k in range(12):
    msgs.append(("/chatter", t0 + k * 25_000_000 + 7, String(data=f"hello {k} " + "x" * k)))
msgs.sort(key=lambda m: m[1])

write_bag(HERE / "mcap_bag.mcap", (("/imu/data", Imu), ("/imu/second", Imu), ("/chatter", String)), msgs)

# Read back with rosbags (from the copied file) and write what it decodes.
rows = []
with Reader(HERE / "mcap_bag.mcap") as r:
    for conn, t, raw in r.messages():
        if conn.msgtype != "sensor_msgs/msg/Imu":
            continue
        rows.append(imu_row(conn, t, raw))
write_csv(HERE / "mcap_expected.csv", IMU_COLUMNS, rows)
print(f"{len(rows)} Imu messages, {(HERE / 'mcap_bag.mcap').stat().st_size} bytes")
