#!/usr/bin/env python3
"""Writes the x y z of the next PointCloud2 on a topic of the master in ROS_MASTER_URI to a .npy
file, then exits: how a rostest that runs robots on masters of their own reads a cloud.
  latest_cloud.py TOPIC OUT.npy [TIMEOUT_S]      exit 0 written, 1 none within the timeout"""
import sys

import numpy as np
import rospy
from sensor_msgs.msg import PointCloud2

from ccir_mapping.clouds import xyz


def main():
    topic, out = sys.argv[1], sys.argv[2]
    timeout_s = float(sys.argv[3]) if len(sys.argv) > 3 else 60.0
    rospy.init_node("latest_cloud", anonymous=True)
    try:
        msg = rospy.wait_for_message(topic, PointCloud2, timeout=timeout_s)
    except rospy.ROSException:
        sys.stderr.write("latest_cloud: no %s within %.0f s\n" % (topic, timeout_s))
        return 1
    np.save(out, xyz(msg))
    return 0


if __name__ == "__main__":
    sys.exit(main())
