#!/usr/bin/env python3
"""Read imuprep's inline MCAP output of mcap_bag.mcap (identity re-encoding; written by
tests/ros2_mcap.rs with IMUPREP_BLESS=1 to mcap_inline_bag.mcap) with `rosbags`, which reads
messages through the summary's chunk indexes, and write the Imu rows in the layout of
mcap_expected.csv (what rosbags read from the original bag) to mcap_inline_rosbags.csv; the
test asserts the two are equal.

    IMUPREP_BLESS=1 cargo test --release --features ros2 --test ros2_mcap
    python3 tests/reference/check_mcap_inline.py

The same check for the LZ4-chunked inline output (tests/protocols_mcap_index.rs):

    IMUPREP_BLESS=1 cargo test --release --features ros2 --test protocols_mcap_index
    python3 tests/reference/check_mcap_inline.py mcap_inline_lz4.mcap mcap_inline_lz4_rosbags.csv
"""
import csv
import sys
from pathlib import Path

from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

HERE = Path(__file__).resolve().parent
ts = get_typestore(Stores.ROS2_HUMBLE)
rows, counts = [], {}
bag, out = (sys.argv[1], sys.argv[2]) if len(sys.argv) > 2 else ("mcap_inline_bag.mcap", "mcap_inline_rosbags.csv")
with Reader(HERE / bag) as r:
    for conn, t, raw in r.messages():
        counts[conn.topic] = counts.get(conn.topic, 0) + 1
        if conn.msgtype != "sensor_msgs/msg/Imu":
            continue
        m = ts.deserialize_cdr(raw, conn.msgtype)
        st = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        g, a = m.angular_velocity, m.linear_acceleration
        gc, ac, oc = m.angular_velocity_covariance, m.linear_acceleration_covariance, m.orientation_covariance
        rows.append([conn.topic, st, t, repr(g.x), repr(g.y), repr(g.z), repr(a.x), repr(a.y), repr(a.z),
                     *(repr(float(v)) for v in (gc[0], gc[4], gc[8], ac[0], ac[4], ac[8], oc[0]))])
assert counts == {"/imu/data": 60, "/imu/second": 20, "/chatter": 12}, counts
with open(HERE / out, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["topic", "stamp_ns", "log_time_ns", "gx", "gy", "gz", "ax", "ay", "az",
                "gcov_xx", "gcov_yy", "gcov_zz", "acov_xx", "acov_yy", "acov_zz", "ocov_0"])
    w.writerows(rows)
print(f"rosbags read {sum(counts.values())} messages through the index: {counts}")
