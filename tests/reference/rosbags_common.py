"""What the rosbags scripts here share (gen_mcap_reference.py, gen_mcap_temperature.py,
check_mcap_inline.py): the ROS 2 Humble type store and its message types, a message header,
writing messages into an MCAP bag with rosbags' writer, and the Imu rows of mcap_expected.csv."""
import csv, shutil, tempfile
from pathlib import Path

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

HERE = Path(__file__).resolve().parent
ts = get_typestore(Stores.ROS2_HUMBLE)
Imu = ts.types["sensor_msgs/msg/Imu"]
Temperature = ts.types["sensor_msgs/msg/Temperature"]
String = ts.types["std_msgs/msg/String"]
Header = ts.types["std_msgs/msg/Header"]
Time = ts.types["builtin_interfaces/msg/Time"]
Quat = ts.types["geometry_msgs/msg/Quaternion"]
Vec3 = ts.types["geometry_msgs/msg/Vector3"]


def header(t_ns, frame):
    return Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id=frame)


def write_bag(path, topics, msgs):
    """A rosbag2 MCAP file (rosbags' writer: chunked, uncompressed, indexed) at `path`: one
    connection per (topic, type) of `topics`, in that order, then `msgs`, (topic, log time ns,
    message) each, in the order given."""
    tmp = Path(tempfile.mkdtemp())
    bag = tmp / "bag"
    with Writer(bag, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {topic: w.add_connection(topic, ty.__msgtype__, typestore=ts) for topic, ty in topics}
        for topic, t, m in msgs:
            w.write(conns[topic], t, ts.serialize_cdr(m, type(m).__msgtype__))
    shutil.copy(next(bag.glob("*.mcap")), path)
    shutil.rmtree(tmp)


IMU_COLUMNS = ["topic", "stamp_ns", "log_time_ns", "gx", "gy", "gz", "ax", "ay", "az",
               "gcov_xx", "gcov_yy", "gcov_zz", "acov_xx", "acov_yy", "acov_zz", "ocov_0"]


def imu_row(conn, t, raw):
    """The row of mcap_expected.csv (columns IMU_COLUMNS) of one Imu message as rosbags
    deserialises it."""
    m = ts.deserialize_cdr(raw, conn.msgtype)
    st = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
    g, a = m.angular_velocity, m.linear_acceleration
    gc, ac, oc = m.angular_velocity_covariance, m.linear_acceleration_covariance, m.orientation_covariance
    return [conn.topic, st, t, repr(g.x), repr(g.y), repr(g.z), repr(a.x), repr(a.y), repr(a.z),
            *(repr(float(v)) for v in (gc[0], gc[4], gc[8], ac[0], ac[4], ac[8], oc[0]))]


def write_csv(path, columns, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        w.writerows(rows)
