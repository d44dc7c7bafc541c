#!/usr/bin/env python3
"""The "your own bag" walk-through of docs/getting_started.md, end to end on the real VLP-16
capture (CCIR_DATA_DIR/lidar/velodyne_vlp16.pcap): pcap_to_bag makes a bag, `rosbag play --clock
--wait-for-subscribers` plays it into robot.launch (started by own_bag.test with
odom_source:=lidar sensor_frame:=velodyne, simulated time), and the robot must make a keyframe of
it, broadcast its lidar odometry on tf,
publish a map for rviz and save it as a readable .bt on mapper/save_map. The capture is a single
rotation; once the bag has ended the Mapper's periodic publishing follows the wall clock
(core/common/mission_clock.h)."""
import os
import subprocess
import sys
import tempfile
import time
import unittest

import rosgraph
import rospy
import rostest
from ccir_mapping.msg import Keyframe
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

ROBOT = "robot_a"
BOUND_S = 120.0  # generous: a busy two-core machine loads the manager slowly


def wait_for(condition, bound_s=BOUND_S):
    deadline = time.monotonic() + bound_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


class OwnBag(unittest.TestCase):
    def test_pcap_to_a_saved_map(self):
        pcap = os.path.join(os.environ.get("CCIR_DATA_DIR", ""), "lidar", "velodyne_vlp16.pcap")
        if not os.path.isfile(pcap):
            sys.stderr.write("SKIPPED own_bag: %s absent (set CCIR_DATA_DIR)\n" % pcap)
            self.skipTest("%s absent" % pcap)
        save_dir = rospy.get_param("~save_dir")
        bag = os.path.join(tempfile.mkdtemp(prefix="own_bag_"), "vlp16.bag")
        converted = subprocess.run(
            ["rosrun", "ccir_mapping", "pcap_to_bag", "--pcap", pcap, "--out", bag,
             "--model", "VLP16"], capture_output=True, text=True, timeout=120)
        self.assertEqual(converted.returncode, 0, converted.stderr)

        keyframes, odometry_tf, map_points = [], [], []
        rospy.Subscriber("keyframes", Keyframe, keyframes.append)
        rospy.Subscriber("/tf", TFMessage, lambda m: odometry_tf.extend(
            t for t in m.transforms
            if t.header.frame_id == ROBOT + "/odom" and t.child_frame_id == ROBOT + "/base_link"))
        rospy.Subscriber("map_cloud", PointCloud2, lambda m: map_points.append(m.width * m.height))
        master = rosgraph.Master(rospy.get_name())

        def preprocessor_listens():
            _, subscribers, _ = master.getSystemState()
            return any(topic == "/velodyne_points" and nodes for topic, nodes in subscribers)
        self.assertTrue(wait_for(preprocessor_listens), "the pipeline did not come up")

        # The capture is one rotation: published before the Preprocessor's subscription has
        # connected (a busy machine), it would be lost.
        played = subprocess.run(["rosbag", "play", "--clock", "--wait-for-subscribers", bag,
                                 "--topics", "/velodyne_points"], capture_output=True, text=True,
                                timeout=120)
        self.assertEqual(played.returncode, 0, played.stderr)
        self.assertTrue(wait_for(lambda: keyframes), "no keyframe from the capture")
        self.assertGreater(len(keyframes[0].cloud.data), 0)
        self.assertTrue(wait_for(lambda: odometry_tf), "no lidar odometry on tf")
        self.assertAlmostEqual(odometry_tf[0].transform.translation.x, 0.0, places=6,
                               msg="the first scan defines the odometry frame")

        self.assertTrue(wait_for(lambda: any(n > 500 for n in map_points)),
                        "no map on map_cloud: %s" % map_points)

        rospy.wait_for_service("mapper/save_map", timeout=BOUND_S)
        saved = rospy.ServiceProxy("mapper/save_map", Trigger)()
        self.assertTrue(saved.success, saved.message)
        map_file = os.path.join(save_dir, "map.bt")
        with open(map_file, "rb") as f:
            content = f.read()
        self.assertTrue(content.startswith(b"# Octomap OcTree binary file"), content[:80])
        self.assertIn(b"\nres 0.1\n", content[:400])
        self.assertGreater(len(content), 10000,
                           "a map of one VLP-16 scan holds thousands of voxels")


if __name__ == "__main__":
    rospy.init_node("own_bag_check")
    rostest.rosrun("ccir_mapping", "own_bag", OwnBag)
