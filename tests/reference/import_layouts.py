#!/usr/bin/env python3
"""Write the rtklibexplorer walk recording (g, deg/s, gpst_s) in the CSV layouts a new user brings,
and the other real recordings under canonical names (t,gx..az) in their own units.

    python3 tests/reference/import_layouts.py [REAL_DIR] [OUT_DIR]

defaults: ../shared/data/real, /tmp/layouts. The files are written outside the project (they are
the real recordings, reshaped); `imuprep import` each, as docs/protocols.md ("CSV layouts and
their units") shows. Standard library only.

  euroc.csv      EuRoC / TUM-VI imu0/data.csv: ns, rad/s, m/s² named in brackets
  ros.csv        `rostopic echo -p` of sensor_msgs/Imu: %time in ns (no unit in the name), SI,
                 orientation and covariance columns beside the sensor's
  camel.csv      timestamp (s), accX..gyroZ in g and deg/s, no unit in the names
  short.csv      SparkFun OpenLog style: time_ms (ms), aX..gZ in g and deg/s, magnetometer mX..mZ
  wx.csv         t (s), ax,ay,az + wx,wy,wz in g and rad/s (WitMotion-style short names)
  ios.csv        time (s), accelerationX..Z (g), rotationRateX..Z (rad/s), beside CoreMotion's
                 userAccelerationX..Z and gravityX..Z (which must never be taken for the sensor)
  canon_gdps.csv canonical names t,gx..az holding g and deg/s (names say SI, data do not)
  lying_walk.csv the walk's own names with _mps2/_rps put for _g/_dps (stated units, contradicted)
  canon_<rec>.csv drive, mpu6050, comma2k19, px4, ximu3 under canonical names, values as published
                 (g + deg/s for drive, mpu6050, ximu3; m/s² + rad/s for comma2k19, px4)
"""
import csv
import math
import os
import sys

G0 = 9.80665
D2R = math.pi / 180.0

real = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/real"
out = sys.argv[2] if len(sys.argv) > 2 else "/tmp/layouts"
src = os.path.join(real, "rtklibexplorer_drive_walk/walk_0827_imu.csv")

os.makedirs(out, exist_ok=True)
rows = []
with open(src) as f:
    r = csv.reader(f)
    h = next(r)
    i = {n: h.index(n) for n in h}
    for row in r:
        t = float(row[i["gpst_s"]])
        a = [float(row[i[f"acc_{c}_g"]]) for c in "xyz"]
        g = [float(row[i[f"gyro_{c}_dps"]]) for c in "xyz"]
        rows.append((row[i["gpst_s"]], t, a, g))


def ns(ts):
    """gpst_s text → integer ns, exactly (no float rounding)."""
    s, _, frac = ts.partition(".")
    return int(s) * 10**9 + int((frac + "000000000")[:9])


def write(name, header, fn):
    with open(os.path.join(out, name), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        for k, row in enumerate(rows):
            w.writerow(fn(k, *row))
    print(os.path.join(out, name))


write(
    "euroc.csv",
    ["#timestamp [ns]"]
    + [f"w_RS_S_{c} [rad s^-1]" for c in "xyz"]
    + [f"a_RS_S_{c} [m s^-2]" for c in "xyz"],
    lambda k, ts, t, a, g: [ns(ts)] + [repr(x * D2R) for x in g] + [repr(x * G0) for x in a],
)
ros_h = ["%time", "field.header.seq", "field.header.stamp", "field.header.frame_id"]
ros_h += [f"field.orientation.{c}" for c in "xyzw"] + [f"field.orientation_covariance{j}" for j in range(9)]
ros_h += [f"field.angular_velocity.{c}" for c in "xyz"] + [f"field.angular_velocity_covariance{j}" for j in range(9)]
ros_h += [f"field.linear_acceleration.{c}" for c in "xyz"]
ros_h += [f"field.linear_acceleration_covariance{j}" for j in range(9)]
write(
    "ros.csv",
    ros_h,
    lambda k, ts, t, a, g: [ns(ts), k, ns(ts), "imu_link", 0, 0, 0, 1]
    + [0] * 9
    + [repr(x * D2R) for x in g]
    + [0] * 9
    + [repr(x * G0) for x in a]
    + [0] * 9,
)
write(
    "camel.csv",
    ["timestamp", "accX", "accY", "accZ", "gyroX", "gyroY", "gyroZ"],
    lambda k, ts, t, a, g: [ts] + a + g,
)
write(
    "short.csv",
    ["time_ms", "aX", "aY", "aZ", "gX", "gY", "gZ", "mX", "mY", "mZ"],
    lambda k, ts, t, a, g: [f"{(t - rows[0][1]) * 1e3:.1f}"] + a + g + [20.0, -3.0, 41.0],
)
write(
    "wx.csv",
    ["t", "ax", "ay", "az", "wx", "wy", "wz"],
    lambda k, ts, t, a, g: [ts] + a + [repr(x * D2R) for x in g],
)
write(
    "ios.csv",
    ["time"]
    + [f"userAcceleration{c}" for c in "XYZ"]
    + [f"gravity{c}" for c in "XYZ"]
    + [f"acceleration{c}" for c in "XYZ"]
    + [f"rotationRate{c}" for c in "XYZ"],
    lambda k, ts, t, a, g: [ts, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0] + a + [repr(x * D2R) for x in g],
)
write(
    "canon_gdps.csv",
    ["t", "gx", "gy", "gz", "ax", "ay", "az"],
    lambda k, ts, t, a, g: [ts] + g + a,
)

with open(src) as f, open(os.path.join(out, "lying_walk.csv"), "w") as o:
    head, _, body = f.read().partition("\n")
    o.write(head.replace("_g", "_mps2").replace("_dps", "_rps") + "\n" + body)
print(os.path.join(out, "lying_walk.csv"))


def canon(name, rel, t, g, a):
    with open(os.path.join(real, rel)) as f, open(os.path.join(out, name), "w") as o:
        r = csv.reader(f)
        h = next(r)
        cols = [h.index(c) for c in [t] + g + a]
        o.write("t,gx,gy,gz,ax,ay,az\n")
        for row in r:
            o.write(",".join(row[i] for i in cols) + "\n")
    print(os.path.join(out, name))


dps = ["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"]
acc_g = ["acc_x_g", "acc_y_g", "acc_z_g"]
rps = ["gyro_x_rps", "gyro_y_rps", "gyro_z_rps"]
mps2 = ["acc_x_mps2", "acc_y_mps2", "acc_z_mps2"]
canon("canon_drive.csv", "rtklibexplorer_drive_walk/drive_0708_imu.csv", "gpst_s", dps, acc_g)
canon("canon_mpu6050.csv", "mpu6050_static_10min_temp/mpu6050_static.csv", "t_s", dps, acc_g)
canon("canon_comma2k19.csv", "comma2k19_car_segment/imu.csv", "t_boot_s", rps, mps2)
canon("canon_px4.csv", "px4_sensor_combined_sample/sensor_combined.csv", "t_boot_s", rps, mps2)
canon(
    "canon_ximu3.csv",
    "ximu3_fusion_example/sensor_data.csv",
    "Time (s)",
    [f"Gyroscope {c} (deg/s)" for c in "XYZ"],
    [f"Accelerometer {c} (g)" for c in "XYZ"],
)
