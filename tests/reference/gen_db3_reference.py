#!/usr/bin/env python3
"""ROS 2 bags in SQLite (.db3, rosbags' writer), for tests/ros2_db3.rs: the messages of the two
MCAP reference bags (gen_mcap_reference.py, gen_mcap_temperature.py) written again with the
SQLite storage plugin, so rosbags' reading of the MCAP bags (mcap_expected.csv) is what the
.db3 bags must import to, plus the temperature the whole-file join should give.

Writes
  - db3_bag/db3_bag_0.db3: every message of mcap_bag.mcap (two Imu topics, a String topic);
  - db3_temp.db3: every message of mcap_temp_bag.mcap (an Imu topic and a Temperature topic),
  - db3_split/split_0.db3, split_1.db3: the messages of mcap_bag.mcap split in two at its
    middle message, as rosbag2 splits a long recording; the second file declares its topics in
    the reverse order (topic ids are per file);
  - db3_not_a_bag.db3: an SQLite database with one unrelated table (no rosbag2 schema);
  - db3_temp_expected.csv: per Imu message of db3_temp.db3 in the order rosbag2 plays them
    (by log time) the stamp and the temperature of the latest reading stamped at or before it
    among all readings of the bag (blank when none), computed on rosbags' deserialised values.

    python3 tests/reference/gen_db3_reference.py
"""
import shutil
import sqlite3
import tempfile
from pathlib import Path

from rosbags.rosbag2 import Reader, StoragePlugin, Writer

from rosbags_common import HERE, ts, write_csv


def rewrite(src, dst, part=None, reverse=False):
    """The messages of `src` (all, or those with index in `part`) into the .db3 file `dst`."""
    tmp = Path(tempfile.mkdtemp())
    bag = tmp / "bag"
    with Reader(src) as r, Writer(bag, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        conns = {}
        for c in (reversed(r.connections) if reverse else r.connections):
            conns[c.id] = w.add_connection(c.topic, c.msgtype, typestore=ts)
        for k, (c, t, raw) in enumerate(r.messages()):
            if part is None or k in part:
                w.write(conns[c.id], t, raw)
    db3 = next(bag.glob("*.db3"))
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(db3, dst)
    shutil.rmtree(tmp)
    print(f"{dst.relative_to(HERE)}: {dst.stat().st_size} bytes")


rewrite(HERE / "mcap_bag.mcap", HERE / "db3_bag" / "db3_bag_0.db3")
rewrite(HERE / "mcap_temp_bag.mcap", HERE / "db3_temp.db3")
with Reader(HERE / "mcap_bag.mcap") as r:
    n = r.message_count
rewrite(HERE / "mcap_bag.mcap", HERE / "db3_split" / "split_0.db3", range(0, n // 2))
rewrite(HERE / "mcap_bag.mcap", HERE / "db3_split" / "split_1.db3", range(n // 2, n), reverse=True)

nb = HERE / "db3_not_a_bag.db3"
nb.unlink(missing_ok=True)
with sqlite3.connect(nb) as c:
    c.execute("CREATE TABLE readings (t REAL, value REAL)")
    c.execute("INSERT INTO readings VALUES (0.0, 1.0)")
c.close()

temps, imus = [], []
with Reader(HERE / "mcap_temp_bag.mcap") as r:
    for c, t, raw in sorted(r.messages(), key=lambda m: m[1]):
        m = ts.deserialize_cdr(raw, c.msgtype)
        st = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        if c.msgtype == "sensor_msgs/msg/Temperature":
            temps.append((st, m.temperature))
        else:
            imus.append(st)
rows = []
for st in imus:
    before = [tc for tc in temps if tc[0] <= st]
    rows.append([st, repr(max(before)[1]) if before else ""])
write_csv(HERE / "db3_temp_expected.csv", ["stamp_ns", "temp_c"], rows)
print(f"{len(rows)} Imu messages, {len(temps)} temperature readings")
