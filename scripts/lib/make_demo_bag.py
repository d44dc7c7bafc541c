#!/usr/bin/python3
"""Writes the demo's short input bag: one robot driving down a mine drift lined with pillars.

A stand-in until the team mission simulator exists. VLP-16 layout (16 rings at -15..+15 deg,
x y z intensity ring time, organised ring-major), odometry with drift on `odom` and the tf
odom -> base_link, the sensor mount on /tf_static. Deterministic from --seed.
"""
import argparse
import math

import numpy as np
import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2, PointField
from tf2_msgs.msg import TFMessage

RINGS = np.radians(np.arange(-15.0, 16.0, 2.0))  # ring r at -15 + 2r degrees
SENSOR_HEIGHT_M = 0.5
DRIFT_HALF_WIDTH_M = 2.5
CEILING_M = 4.0
PILLAR_PERIOD_M = 15.0  # 10 m pillar + 5 m cross-cut, as in a room-and-pillar mine


def cast(origin, yaw, columns, rng, noise_m):
    """Ranges of all beams from `origin` (world) with heading `yaw`: walls with cross-cuts,
    floor and ceiling, solved per plane in closed form."""
    azimuth = np.linspace(0.0, 2.0 * np.pi, columns, endpoint=False)
    elev, az = np.meshgrid(RINGS, azimuth, indexing="ij")
    d = np.stack([np.cos(elev) * np.cos(az + yaw), np.cos(elev) * np.sin(az + yaw), np.sin(elev)], -1)
    t = np.full(elev.shape, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis, plane in ((2, 0.0), (2, CEILING_M)):
            s = (plane - origin[axis]) / d[..., axis]
            t = np.where((s > 0) & (s < t), s, t)
        for wall in (-DRIFT_HALF_WIDTH_M, DRIFT_HALF_WIDTH_M):
            s = (wall - origin[1]) / d[..., 1]
            x = origin[0] + s * d[..., 0]
            in_crosscut = np.mod(x, PILLAR_PERIOD_M) > 10.0  # open cross-cut: no wall here
            t = np.where((s > 0) & (s < t) & ~in_crosscut, s, t)
    t = np.where(t > 100.0, np.inf, t)
    t = t + rng.normal(0.0, noise_m, t.shape)
    return elev, az, t


def cloud_msg(stamp, frame, elev, az, ranges):
    rows, cols = ranges.shape
    hit = np.isfinite(ranges)
    r = np.where(hit, ranges, 0.0)  # no return: zeros, as the Velodyne driver's organised cloud
    points = np.zeros((rows, cols), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                          ("intensity", "<f4"), ("ring", "<u2"), ("time", "<f4")])
    points["x"] = r * np.cos(elev) * np.cos(az)
    points["y"] = r * np.cos(elev) * np.sin(az)
    points["z"] = r * np.sin(elev)
    points["intensity"] = np.where(hit, 40.0, 0.0)
    points["ring"] = np.arange(rows)[:, None]
    points["time"] = (az / (2 * np.pi) * 0.1).astype(np.float32)
    msg = PointCloud2()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.height, msg.width = rows, cols
    msg.fields = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
                  PointField("z", 8, PointField.FLOAT32, 1),
                  PointField("intensity", 12, PointField.FLOAT32, 1),
                  PointField("ring", 16, PointField.UINT16, 1), PointField("time", 18, PointField.FLOAT32, 1)]
    msg.is_bigendian, msg.point_step, msg.row_step = False, 22, 22 * cols
    msg.is_dense = False
    msg.data = points.tobytes()
    return msg


def pose_fields(target, x, y, yaw):
    target.position.x, target.position.y = x, y
    target.orientation.z, target.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True, help="bag file to write")
    parser.add_argument("--robot", default="robot_a")
    parser.add_argument("--duration-s", type=float, default=15.0)
    parser.add_argument("--speed-mps", type=float, default=1.0)
    parser.add_argument("--columns", type=int, default=900, help="azimuth steps per revolution")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    if args.duration_s <= 0 or args.speed_mps < 0 or args.columns < 16:
        parser.error("need --duration-s > 0, --speed-mps >= 0, --columns >= 16")

    rng = np.random.default_rng(args.seed)
    odom_frame, base_frame = args.robot + "/odom", args.robot + "/base_link"
    sensor_frame = args.robot + "/velodyne"
    t0 = 100.0
    with rosbag.Bag(args.out, "w") as bag:
        mount = TransformStamped()
        mount.header.stamp, mount.header.frame_id = rospy.Time(t0), base_frame
        mount.child_frame_id = sensor_frame
        mount.transform.translation.z = SENSOR_HEIGHT_M
        mount.transform.rotation.w = 1.0
        bag.write("/tf_static", TFMessage([mount]), rospy.Time(t0))

        odom_x = odom_y = odom_yaw = 0.0
        steps = int(args.duration_s * 10)
        for k in range(steps + 1):
            stamp = rospy.Time(t0 + 0.1 * k)
            # Truth: along the drift centre with a gentle weave.
            x = args.speed_mps * 0.1 * k
            y = 0.3 * math.sin(x / 5.0)
            yaw = math.atan2(0.3 / 5.0 * math.cos(x / 5.0), 1.0)
            if k:  # odometry integrates noisy increments: it drifts
                odom_x += args.speed_mps * 0.1 * (1 + rng.normal(0, 0.02)) * math.cos(odom_yaw)
                odom_y += args.speed_mps * 0.1 * (1 + rng.normal(0, 0.02)) * math.sin(odom_yaw)
                odom_yaw = yaw + rng.normal(0, 0.005)
            elev, az, ranges = cast(np.array([x, y, SENSOR_HEIGHT_M]), yaw, args.columns, rng, 0.03)
            bag.write("/velodyne_points", cloud_msg(stamp, sensor_frame, elev, az, ranges), stamp)

            odom = Odometry()
            odom.header.stamp, odom.header.frame_id, odom.child_frame_id = stamp, odom_frame, base_frame
            pose_fields(odom.pose.pose, odom_x, odom_y, odom_yaw)
            bag.write("/odom", odom, stamp)
            tf = TransformStamped()
            tf.header = odom.header
            tf.child_frame_id = base_frame
            tf.transform.translation.x, tf.transform.translation.y = odom_x, odom_y
            tf.transform.rotation = odom.pose.pose.orientation
            bag.write("/tf", TFMessage([tf]), stamp)
    print("wrote %s: %d scans, %.0f m" % (args.out, steps + 1, args.speed_mps * args.duration_s))


if __name__ == "__main__":
    main()
