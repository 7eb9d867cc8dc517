#!/usr/bin/env python3
"""ROS 1 bags made with `rosbags` (a writer nobody here wrote), and the values rosbags reads back
from them, for tests/ros1_bag.rs.

Writes ros1_bag_none.bag, ros1_bag_bz2.bag, ros1_bag_lz4.bag: the same messages in a ROS 1 bag
(format 2.0, rosbags' writer: chunked, indexed) with chunks uncompressed, bzip2 and LZ4:
  - /imu/data    sensor_msgs/Imu, 80 messages at 100 Hz, frame_id "imu_link"; message 40 is
                 time-stamped 10 ms late (a gap of one period); message 50 has the linear
                 acceleration covariance[0] = -1 ("not available": its accel is absent);
  - /imu/second  sensor_msgs/Imu, 10 messages at 20 Hz, frame_id "";
  - /imu/temperature  sensor_msgs/Temperature, 5 Hz from 55 ms after the first Imu stamp;
  - /chatter     std_msgs/String, 12 messages (not IMU).
and ros1_expected.csv: one row per Imu message as rosbags deserialises it (topic, header stamp,
record time, angular velocity, linear acceleration, linear acceleration covariance[0]) and the
temperature the import should join to it: the latest reading stamped at or before it (empty
before the first).

    python3 tests/reference/gen_ros1_reference.py
"""
import csv
import random
import tempfile
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_typestore

HERE = Path(__file__).resolve().parent
ts = get_typestore(Stores.ROS1_NOETIC)
Imu = ts.types["sensor_msgs/msg/Imu"]
String = ts.types["std_msgs/msg/String"]
Temperature = ts.types["sensor_msgs/msg/Temperature"]
Header = ts.types["std_msgs/msg/Header"]
Time = ts.types["builtin_interfaces/msg/Time"]
Quat = ts.types["geometry_msgs/msg/Quaternion"]
Vec3 = ts.types["geometry_msgs/msg/Vector3"]

random.seed(41)


def imu(seq, t_ns, frame, g, a, acc0=4e-4):
    return Imu(
        header=Header(seq=seq, stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id=frame),
        orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.array([-1.0] + [0.0] * 8),
        angular_velocity=Vec3(x=g[0], y=g[1], z=g[2]),
        angular_velocity_covariance=np.array([1e-6, 0, 0, 0, 2e-6, 0, 0, 0, 3e-6]),
        linear_acceleration=Vec3(x=a[0], y=a[1], z=a[2]),
        linear_acceleration_covariance=np.array([acc0, 0, 0, 0, 5e-4, 0, 0, 0, 6e-4]),
    )


msgs = []  # (topic, record time ns, message)
t0 = 1_600_000_000 * 10**9 + 987_654_321
for k in range(80):
    t = t0 + k * 10_000_000 + (10_000_000 if k >= 40 else 0)  # message 40 comes 20 ms after 39
    g = [random.gauss(0, 0.01), random.gauss(0, 0.01), random.gauss(0.002, 0.01)]
    a = [random.gauss(0, 0.05), random.gauss(0, 0.05), 9.80665 + random.gauss(0, 0.05)]
    msgs.append(("/imu/data", t + 400_000, imu(k, t, "imu_link", g, a, -1.0 if k == 50 else 4e-4)))
for k in range(10):
    t = t0 + 2_000_000 + k * 50_000_000
    msgs.append(("/imu/second", t + 100_000, imu(k, t, "", [0.1 * k, -0.2, 0.3], [1.0, -2.0, -9.7])))
temps = []  # (stamp ns, °C)
for k in range(5):
    t = t0 + 55_000_000 + k * 200_000_000
    c = 25.0 + 0.125 * k
    temps.append((t, c))
    msgs.append(("/imu/temperature", t + 50_000, Temperature(
        header=Header(seq=k, stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id="imu_link"),
        temperature=c, variance=0.01)))
for k in range(12):
    msgs.append(("/chatter", t0 + k * 60_000_000 + 7, String(data=f"hello {k} " + "x" * k)))
msgs.sort(key=lambda m: m[1])

for name, fmt in (("none", None), ("bz2", Writer.CompressionFormat.BZ2), ("lz4", Writer.CompressionFormat.LZ4)):
    path = HERE / f"ros1_bag_{name}.bag"
    path.unlink(missing_ok=True)
    w = Writer(path)
    if fmt is not None:
        w.set_compression(fmt)
    # Chunks of about 8 KiB (rosbags' default is 1 MiB): several chunks per bag.
    w.chunk_threshold = 8 * 1024
    with w:
        conns = {}
        for topic, ty in (("/imu/data", Imu), ("/imu/second", Imu), ("/imu/temperature", Temperature),
                          ("/chatter", String)):
            conns[topic] = w.add_connection(topic, ty.__msgtype__, typestore=ts)
        for topic, t, m in msgs:
            w.write(conns[topic], t, ts.serialize_ros1(m, type(m).__msgtype__))
    print(f"{path.name}: {path.stat().st_size} bytes")

rows = []
with Reader(HERE / "ros1_bag_none.bag") as r:
    for conn, t, raw in r.messages():
        if conn.msgtype != "sensor_msgs/msg/Imu":
            continue
        m = ts.deserialize_ros1(raw, conn.msgtype)
        st = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        g, a = m.angular_velocity, m.linear_acceleration
        before = [c for (tt, c) in temps if tt <= st]
        rows.append([conn.topic, st, t, *(repr(v) for v in (g.x, g.y, g.z, a.x, a.y, a.z)),
                     repr(float(m.linear_acceleration_covariance[0])),
                     repr(before[-1]) if before else ""])
with open(HERE / "ros1_expected.csv", "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["topic", "stamp_ns", "record_time_ns", "gx", "gy", "gz", "ax", "ay", "az", "acov_0", "temp_c"])
    w.writerows(rows)
print(f"{len(rows)} Imu messages")
