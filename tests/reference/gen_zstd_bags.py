#!/usr/bin/env python3
"""ROS 2 bags compressed as rosbag2 compresses them, made with `rosbags` (a writer nobody here
wrote; its zstd is the zstd library's, through `backports.zstd`), for tests/ros2_zstd.rs. Each
holds the messages of an uncompressed reference bag, byte for byte, so the compressed bag must
import to exactly what the uncompressed one does (and what rosbags reads from it:
mcap_expected.csv, mcap_temp_expected.csv):

  - zstd_chunks.mcap: mcap_bag.mcap's messages, MCAP chunks zstd-compressed (rosbags'
    `CompressionMode.STORAGE`; the chunk compression `ros2 bag record -s mcap` writes by
    default);
  - zstd_message.mcap: mcap_temp_bag.mcap's messages (Imu and Temperature), each message's data
    one zstd frame (`compression_mode: message`);
  - zstd_file_bag/: mcap_bag.mcap's messages in a bag directory whose MCAP file is compressed
    whole (`compression_mode: file`: zstd_file_bag_0.mcap.zstd beside metadata.yaml);
  - db3_zstd_message.db3: mcap_temp_bag.mcap's messages in SQLite, each message compressed;
  - db3_zstd_file_bag/: mcap_bag.mcap's messages in SQLite, the .db3 file compressed whole.

    python3 tests/reference/gen_zstd_bags.py
"""
import shutil
import tempfile
from pathlib import Path

from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, StoragePlugin, Writer

from rosbags_common import HERE, ts

MODES = {"chunks": CompressionMode.STORAGE, "message": CompressionMode.MESSAGE, "file": CompressionMode.FILE}


def rewrite(src, mode, plugin):
    """A bag directory (in a temporary folder) holding every message of `src`."""
    bag = Path(tempfile.mkdtemp()) / "bag"
    with Reader(src) as r:
        w = Writer(bag, version=8, storage_plugin=plugin)
        w.set_compression(MODES[mode], CompressionFormat.ZSTD)
        with w:
            conns = {c.id: w.add_connection(c.topic, c.msgtype, typestore=ts) for c in r.connections}
            for c, t, raw in r.messages():
                w.write(conns[c.id], t, raw)
    # What rosbags reads back from the bag equals the source's messages, byte for byte.
    with Reader(src) as a, Reader(bag) as b:
        ma = [(c.topic, t, bytes(raw)) for c, t, raw in a.messages()]
        mb = [(c.topic, t, bytes(raw)) for c, t, raw in b.messages()]
    assert ma == mb, (src, mode, plugin)
    print(f"{src.name} as {plugin.name} with {mode} compression: {len(mb)} messages read back")
    return bag


def one_file(src, mode, plugin, dst):
    bag = rewrite(src, mode, plugin)
    (f,) = [p for p in bag.iterdir() if p.name != "metadata.yaml"]
    shutil.copy(f, dst)
    shutil.rmtree(bag.parent)
    print(f"{dst.relative_to(HERE)}: {dst.stat().st_size} bytes")


def bag_dir(src, mode, plugin, dst):
    bag = rewrite(src, mode, plugin)
    shutil.rmtree(dst, ignore_errors=True)
    dst.mkdir()
    (f,) = [p for p in bag.iterdir() if p.name != "metadata.yaml"]
    name = dst.name + f.name[len("bag"):]
    shutil.copy(f, dst / name)
    meta = (bag / "metadata.yaml").read_text().replace(f.name, name)
    (dst / "metadata.yaml").write_text(meta)
    shutil.rmtree(bag.parent)
    print(f"{dst.relative_to(HERE)}/: {sorted(p.name for p in dst.iterdir())}")


MCAP, SQLITE = StoragePlugin.MCAP, StoragePlugin.SQLITE3
one_file(HERE / "mcap_bag.mcap", "chunks", MCAP, HERE / "zstd_chunks.mcap")
one_file(HERE / "mcap_temp_bag.mcap", "message", MCAP, HERE / "zstd_message.mcap")
bag_dir(HERE / "mcap_bag.mcap", "file", MCAP, HERE / "zstd_file_bag")
one_file(HERE / "mcap_temp_bag.mcap", "message", SQLITE, HERE / "db3_zstd_message.db3")
bag_dir(HERE / "mcap_bag.mcap", "file", SQLITE, HERE / "db3_zstd_file_bag")
