#!/usr/bin/env python3
"""A ROS 2 bag (MCAP) split in two files as rosbag2 splits a long recording
(`--max-bag-size`, `--max-bag-duration`), made with `rosbags`, for tests/ros2_zstd.rs: the
messages of mcap_bag.mcap, the first half in mcap_split/mcap_split_0.mcap and the rest in
mcap_split/mcap_split_1.mcap. The second file declares its channels in the reverse order, so
its channel ids name other topics than the first file's (ids are per file): a reader that keeps
the first file's id for /imu/data would read /chatter or /imu/second from the second. The
split bag must import to exactly what mcap_bag.mcap imports to.

mcap_split_zstd/: the same two files, each compressed whole with the zstd library (rosbag2's
`--compression-mode file` on a split bag: mcap_split_zstd_0.mcap.zstd, …_1.mcap.zstd).

    python3 tests/reference/gen_mcap_split.py
"""
import shutil
import tempfile
from pathlib import Path

from backports import zstd
from rosbags.rosbag2 import Reader, StoragePlugin, Writer

from rosbags_common import HERE, ts


def part(src, dst, keep, reverse):
    """The messages of `src` with index in `keep` as the one MCAP file `dst`."""
    bag = Path(tempfile.mkdtemp()) / "bag"
    with Reader(src) as r, Writer(bag, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for c in (reversed(r.connections) if reverse else r.connections):
            conns[c.id] = w.add_connection(c.topic, c.msgtype, typestore=ts)
        for k, (c, t, raw) in enumerate(r.messages()):
            if k in keep:
                w.write(conns[c.id], t, raw)
    shutil.copy(next(bag.glob("*.mcap")), dst)
    shutil.rmtree(bag.parent)


src = HERE / "mcap_bag.mcap"
with Reader(src) as r:
    n = r.message_count
out, zout = HERE / "mcap_split", HERE / "mcap_split_zstd"
for d in (out, zout):
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir()
part(src, out / "mcap_split_0.mcap", range(0, n // 2), reverse=False)
part(src, out / "mcap_split_1.mcap", range(n // 2, n), reverse=True)
for i in (0, 1):
    data = (out / f"mcap_split_{i}.mcap").read_bytes()
    (zout / f"mcap_split_zstd_{i}.mcap.zstd").write_bytes(zstd.compress(data))
for d in (out, zout):
    print(f"{d.relative_to(HERE)}/: " + ", ".join(f"{p.name} {p.stat().st_size} bytes" for p in sorted(d.iterdir())))
