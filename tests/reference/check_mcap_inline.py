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
import sys

from rosbags.rosbag2 import Reader

from rosbags_common import HERE, IMU_COLUMNS, imu_row, write_csv

rows, counts = [], {}
bag, out = (sys.argv[1], sys.argv[2]) if len(sys.argv) > 2 else ("mcap_inline_bag.mcap", "mcap_inline_rosbags.csv")
with Reader(HERE / bag) as r:
    for conn, t, raw in r.messages():
        counts[conn.topic] = counts.get(conn.topic, 0) + 1
        if conn.msgtype != "sensor_msgs/msg/Imu":
            continue
        rows.append(imu_row(conn, t, raw))
assert counts == {"/imu/data": 60, "/imu/second": 20, "/chatter": 12}, counts
write_csv(HERE / out, IMU_COLUMNS, rows)
print(f"rosbags read {sum(counts.values())} messages through the index: {counts}")
