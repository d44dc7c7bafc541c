#!/usr/bin/env python3
"""Starts Xvfb and rviz (config/rviz/robot.rviz, robot_a's namespace), publishes a small map,
trajectory and loop closures, and checks that a screenshot shows them: enough saturated pixels
(the map is coloured by height, the trajectory yellow, loops green), which the grey grid and
background alone never give. The screenshot is saved as ~out_dir/rviz_robot.png."""
import math
import os
import subprocess
import time
import unittest

import numpy as np
import rospkg
import rospy
import rostest
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Path
from sensor_msgs import point_cloud2
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

ROBOT = "robot_a"
FRAME = ROBOT + "/map"


def screenshot(display):
    """The root window as an H x W x 3 array, or None."""
    grab = subprocess.run(
        ["import", "-display", display, "-window", "root", "-depth", "8", "ppm:-"],
        capture_output=True, timeout=20)
    if grab.returncode != 0:
        return None
    data = grab.stdout
    # Binary PPM: "P6 <w> <h> <max>" then the pixels.
    fields = data.split(maxsplit=4)
    width, height = int(fields[1]), int(fields[2])
    pixels = np.frombuffer(fields[4], dtype=np.uint8)[: width * height * 3]
    return pixels.reshape(height, width, 3), data


def shares(image):
    """Shares of the pixels that are coloured at all, trajectory yellow and loop-closure green."""
    r, g, b = (image[:, :, k].astype(np.int16) for k in range(3))
    coloured = np.maximum(np.maximum(r, g), b) - np.minimum(np.minimum(r, g), b) > 80
    yellow = (r > 180) & (g > 150) & (b < 100)
    green = (g > 200) & (r < 90) & (b < 90)
    return float(np.mean(coloured)), float(np.mean(yellow)), float(np.mean(green))


class RvizScreenshot(unittest.TestCase):
    def setUp(self):
        self.processes = []

    def tearDown(self):
        for process in reversed(self.processes):
            process.terminate()
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()

    def start_xvfb(self):
        read_fd, write_fd = os.pipe()
        self.processes.append(subprocess.Popen(
            ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1200x800x24", "-nolisten",
             "tcp"], pass_fds=(write_fd,)))
        os.close(write_fd)
        with os.fdopen(read_fd) as reader:
            number = reader.readline().strip()
        self.assertTrue(number, "Xvfb did not start")
        return ":" + number

    def publish_map(self):
        header = Header(frame_id=FRAME, stamp=rospy.Time.now())
        # A 20 x 12 m room's walls, 0 to 3 m high, as 0.1 m voxel centres.
        points = []
        for i in range(200):
            for z in np.arange(0.0, 3.0, 0.2):
                points += [(-10 + 0.1 * i, -6, z), (-10 + 0.1 * i, 6, z)]
        for j in range(120):
            for z in np.arange(0.0, 3.0, 0.2):
                points += [(-10, -6 + 0.1 * j, z), (10, -6 + 0.1 * j, z)]
        cloud = point_cloud2.create_cloud_xyz32(header, points)
        path = Path(header=header)
        for k in range(30):
            pose = PoseStamped(header=header)
            pose.pose.position.x = 8 * math.cos(k * 0.2)
            pose.pose.position.y = 4 * math.sin(k * 0.2)
            pose.pose.orientation.w = 1.0
            path.poses.append(pose)
        loops = Marker(header=header, ns="loops kept", type=Marker.LINE_LIST, action=Marker.ADD)
        loops.pose.orientation.w = 1.0
        loops.scale.x = 0.2
        loops.color.g = loops.color.a = 1.0
        loops.points = [Point(-8, -4, 0), Point(8, 4, 0), Point(-8, 4, 0), Point(8, -4, 0)]
        self.publishers = [
            rospy.Publisher("/%s/map_cloud" % ROBOT, type(cloud), queue_size=1, latch=True),
            rospy.Publisher("/%s/trajectory" % ROBOT, Path, queue_size=1, latch=True),
            rospy.Publisher("/%s/loop_closure_markers" % ROBOT, MarkerArray, queue_size=1,
                            latch=True)]
        for publisher, message in zip(self.publishers,
                                      [cloud, path, MarkerArray(markers=[loops])]):
            publisher.publish(message)

    def test_map_trajectory_and_loop_closures_are_drawn(self):
        out_dir = rospy.get_param("~out_dir")
        os.makedirs(out_dir, exist_ok=True)
        display = self.start_xvfb()
        self.publish_map()
        config = os.path.join(rospkg.RosPack().get_path("ccir_mapping"), "config", "rviz",
                              "robot.rviz")
        env = dict(os.environ, DISPLAY=display, ROS_NAMESPACE=ROBOT)
        self.processes.append(subprocess.Popen(
            ["rosrun", "rviz", "rviz", "-d", config, "-f", FRAME], env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        # rviz takes a few seconds to come up and draw: poll the screen.
        found, shot = (0.0, 0.0, 0.0), None
        deadline = time.time() + 90
        while time.time() < deadline and not rospy.is_shutdown():
            grabbed = screenshot(display)
            if grabbed is not None:
                image, shot = grabbed
                found = shares(image)
                if min(found) > 0.0002 and found[0] > 0.005:
                    break
            time.sleep(1.0)
        self.assertIsNotNone(shot, "no screenshot could be taken of " + display)
        path = os.path.join(out_dir, "rviz_robot.png")
        subprocess.run(["convert", "ppm:-", path], input=shot, check=True, timeout=20)
        coloured, yellow, green = found
        self.assertGreater(coloured, 0.005, "%s shows no map (%.4f coloured)" % (path, coloured))
        self.assertGreater(yellow, 0.0002, "%s shows no trajectory (%.4f)" % (path, yellow))
        self.assertGreater(green, 0.0002, "%s shows no loop closures (%.4f)" % (path, green))


if __name__ == "__main__":
    rospy.init_node("rviz_screenshot")
    rostest.rosrun("ccir_mapping", "rviz", RvizScreenshot)
