#!/usr/bin/env python3
"""Read the bag imuprep's MCAP sink wrote (mcap_sink_bag.mcap, made by tests/ros2_mcap.rs with
IMUPREP_BLESS=1) with `rosbags`, as a ROS 2 tool would, and write what it decodes to
mcap_sink_rosbags.csv: per /imu/clean message the stamp, angular velocity, linear acceleration
and the two covariance diagonals; per /imuprep/health message its JSON.

    IMUPREP_BLESS=1 cargo test --release --features ros2 --test ros2_mcap
    python3 tests/reference/check_mcap_sink.py
    python3 tests/reference/check_mcap_sink.py mcap_sink_lz4_bag.mcap mcap_sink_lz4_rosbags.csv
    python3 tests/reference/check_mcap_sink.py mcap_sink_zstd_bag.mcap mcap_sink_zstd_rosbags.csv

The second and third read the sink's LZ4- and zstd-chunked bags (`compression = "lz4"`,
`"zstd"`) the same way.
"""
import csv, json, sys
from pathlib import Path

from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

HERE = Path(__file__).resolve().parent
BAG, OUT = (sys.argv[1:3] if len(sys.argv) > 2 else ("mcap_sink_bag.mcap", "mcap_sink_rosbags.csv"))
ts = get_typestore(Stores.ROS2_HUMBLE)
rows = []
with Reader(HERE / BAG) as r:
    topics = {c.topic: c.msgtype for c in r.connections}
    assert topics == {"/imu/clean": "sensor_msgs/msg/Imu", "/imuprep/health": "std_msgs/msg/String"}, topics
    for conn, t, raw in r.messages():
        m = ts.deserialize_cdr(raw, conn.msgtype)
        if conn.topic == "/imu/clean":
            g, a = m.angular_velocity, m.linear_acceleration
            gc, ac = m.angular_velocity_covariance, m.linear_acceleration_covariance
            rows.append([conn.topic, m.header.stamp.sec, m.header.stamp.nanosec,
                         *(repr(float(v)) for v in (g.x, g.y, g.z, a.x, a.y, a.z,
                                                    gc[0], gc[4], gc[8], ac[0], ac[4], ac[8]))])
        else:
            rows.append([conn.topic, json.dumps(json.loads(m.data), sort_keys=True)])
with open(HERE / OUT, "w", newline="") as f:
    w = csv.writer(f, quoting=csv.QUOTE_MINIMAL)
    w.writerow(["topic", "sec", "nanosec", "gx", "gy", "gz", "ax", "ay", "az",
                "gcov_xx", "gcov_yy", "gcov_zz", "acov_xx", "acov_yy", "acov_zz"])
    w.writerows(rows)
print(f"rosbags read {len(rows)} messages")
