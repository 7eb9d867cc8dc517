#!/usr/bin/env python3
"""A large ROS 1 bag for the import timings in docs/protocols.md ("ROS 1 bags", "ROS 2 bags in
SQLite"): N sensor_msgs/Imu messages at 200 Hz on /imu/data (seeded white noise, gravity on z),
LZ4 chunks, written with rosbags' ROS 1 writer to big.bag in the current directory.

    python3 tests/reference/gen_big_ros1_bag.py 200000
    imuprep import big.bag -o big.log                          # a ros1 build
    rosbags-convert --src big.bag --dst bigdb --dst-storage sqlite3
    imuprep import bigdb -o bigdb.log                          # a ros2-sqlite build
    imuprep export big.log -o a.csv && imuprep export bigdb.log -o b.csv && cmp a.csv b.csv
"""
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS1_NOETIC)
Imu = ts.types["sensor_msgs/msg/Imu"]
Header = ts.types["std_msgs/msg/Header"]
Time = ts.types["builtin_interfaces/msg/Time"]
Quat = ts.types["geometry_msgs/msg/Quaternion"]
Vec3 = ts.types["geometry_msgs/msg/Vector3"]

n = int(sys.argv[1])
rng = np.random.default_rng(5)
path = Path("big.bag")
path.unlink(missing_ok=True)
w = Writer(path)
w.set_compression(Writer.CompressionFormat.LZ4)
z = np.zeros(9)
with w:
    c = w.add_connection("/imu/data", Imu.__msgtype__, typestore=ts)
    t0 = 1_600_000_000 * 10**9
    for k in range(n):
        t = t0 + k * 5_000_000
        g = rng.normal(0, 0.01, 3)
        a = rng.normal(0, 0.05, 3)
        a[2] += 9.8
        m = Imu(header=Header(seq=k, stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id="imu"),
                orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=z,
                angular_velocity=Vec3(x=g[0], y=g[1], z=g[2]), angular_velocity_covariance=z,
                linear_acceleration=Vec3(x=a[0], y=a[1], z=a[2]), linear_acceleration_covariance=z)
        w.write(c, t + 100_000, ts.serialize_ros1(m, Imu.__msgtype__))
print(f"{path}: {path.stat().st_size} bytes")
