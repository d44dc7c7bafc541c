#!/usr/bin/env python3
"""run_team (the team in simulated time, without ROS) against the bridged ROS path: the fixture
mission's three robots each run their whole pipeline (launch/robot.launch) on a ROS master of
their own, bridged over loopback, fed their bags at 0.3 x, sharing every 2nd keyframe
(fixed_rate: which scans go does not depend on timing); then run_team runs the same mission with
the same settings. Each robot must make the same keyframes, send the same number of scans on
each link, carry the same bytes within 10 % and end knowing the same teammates' transforms. The
stages are the same objects on both paths; what this checks is their wiring (RobotPipeline
against the topics of robot.launch) and the runner's emulated link against the Bridge."""
import csv
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import rospkg
import rospy
import rosunit
import yaml

from ccir_mapping.rostest_processes import Processes

ROBOTS = ["robot_a", "robot_b", "robot_c"]
EVERY_N = 2
RATE = "0.3"  # three pipelines on a slow two-core machine lose no scan
BYTES_WITHIN = 0.10
CONFIG = os.path.join(rospkg.RosPack().get_path("ccir_mapping"), "config",
                      "robot.yaml")  # what launch/robot.launch loads


def last_rows(path, key):
    """The last row of a `rostopic echo -p` CSV for each value of `key`."""
    with open(path) as f:
        lines = f.readlines()
    header = next((i for i, line in enumerate(lines) if line.startswith("%time")), len(lines))
    rows = {}
    for r in csv.DictReader(lines[header:]):
        if None not in r and None not in r.values():
            rows[r[key]] = r
    return rows


class RunnerEquivalence(Processes, unittest.TestCase):
    def setUp(self):
        self.mission = rospy.get_param("~mission")
        self.dir = tempfile.mkdtemp(prefix="runner_equivalence_")
        self.processes = []

    def tearDown(self):
        self.stop_all()
        shutil.rmtree(self.dir, ignore_errors=True)

    def broker_stats(self, port):
        try:
            out = subprocess.run(["rostopic", "echo", "-n", "1", "/broker_stats"],
                                 env=self.env(port), capture_output=True, text=True, timeout=30)
        except subprocess.TimeoutExpired:
            return None
        text = out.stdout.split("\n---")[0]
        return yaml.safe_load(text) if text.strip() else None

    def run_ros(self):
        master = self.start_team(self.dir, ROBOTS, lambda robot, bridge: (
            "broker: {mode: fixed_rate, fixed_rate_every_n: %d}\nbridge: {%s}\n"
            % (EVERY_N, bridge)))
        for robot in ROBOTS:
            self.spawn("links_" + robot, ["rostopic", "echo", "-p", "/link_stats"],
                       master[robot], out=os.path.join(self.dir, robot + "_links.csv"))
            self.spawn("team_" + robot, ["rostopic", "echo", "-p", "/team_transforms"],
                       master[robot], out=os.path.join(self.dir, robot + "_team.csv"))

        def linked():
            return all(len(last_rows(os.path.join(self.dir, r + "_links.csv"), "field.peer")) ==
                       len(ROBOTS) - 1 for r in ROBOTS)
        self.wait_for(linked, 300, "every robot's links reported", poll_s=1)
        players = [self.spawn("play_" + robot,
                              ["rosbag", "play", "--clock", "--quiet", "--wait-for-subscribers",
                               "-r", RATE, os.path.join(self.mission, robot + ".bag"),
                               "--topics", "/velodyne_points", "/odom", "/tf", "/tf_static"],
                              master[robot]) for robot in ROBOTS]
        for player in players:
            player.wait(timeout=1200)
            self.assertEqual(player.returncode, 0, "rosbag play failed")
        stats = {}

        def drained():  # every scan sent has been received
            for robot in ROBOTS:
                stats[robot] = self.broker_stats(master[robot])
                if not stats[robot]:
                    return False
            sent = {(r, p["peer"]): p["scans_sent"] for r in ROBOTS for p in stats[r]["peers"]}
            received = {(p["peer"], r): p["scans_received"] for r in ROBOTS
                        for p in stats[r]["peers"]}
            return sent == received
        self.wait_for(drained, 300, "the links drained", poll_s=2)
        self.stop_all()
        ros = {}
        for robot in ROBOTS:
            links = last_rows(os.path.join(self.dir, robot + "_links.csv"), "field.peer")
            team = last_rows(os.path.join(self.dir, robot + "_team.csv"), "field.peer")
            ros[robot] = {
                "keyframes": stats[robot]["keyframes"],
                "scans_sent": {p["peer"]: p["scans_sent"] for p in stats[robot]["peers"]},
                "bytes_sent": {p: int(r["field.bytes_sent"]) for p, r in links.items()},
                "transforms": sorted(p for p, r in team.items()
                                     if r["field.valid"] in ("1", "True"))}
        return ros

    def run_runner(self):
        out = os.path.join(self.dir, "run_team")
        # The stages' parameters from the file the robots' launch loads.
        done = subprocess.run(["rosrun", "ccir_mapping", "run_team", "--mission", self.mission,
                               "--config", CONFIG, "--mode", "fixed_rate", "--every-n",
                               str(EVERY_N), "--threads", "2", "--out", out],
                              capture_output=True, text=True, timeout=1200)
        self.assertEqual(done.returncode, 0, done.stderr[-2000:])
        report = json.load(open(os.path.join(out, "report.json")))
        return {r["name"]: {
            "keyframes": r["keyframes"],
            "scans_sent": {p: c["scans_sent"] for p, c in r["routing"].items()},
            "bytes_sent": {p: l["bytes_sent"] for p, l in r["links"].items()},
            "transforms": sorted(t["peer"] for t in r["team_frames"] if t["valid"])}
            for r in report["robots"]}

    def test_runner_matches_the_bridged_ros_path(self):
        ros = self.run_ros()
        runner = self.run_runner()
        print("ROS:    " + json.dumps(ros, sort_keys=True))
        print("runner: " + json.dumps(runner, sort_keys=True))
        for robot in ROBOTS:
            r, s = ros[robot], runner[robot]
            self.assertEqual(r["keyframes"], s["keyframes"], robot + ": keyframes")
            self.assertEqual(r["transforms"], s["transforms"], robot + ": transforms known")
            for peer in ROBOTS:
                if peer == robot:
                    continue
                link = "%s -> %s" % (robot, peer)
                self.assertEqual(r["scans_sent"][peer], s["scans_sent"][peer], link + ": scans")
                ratio = s["bytes_sent"][peer] / r["bytes_sent"][peer]
                self.assertLess(abs(ratio - 1.0), BYTES_WITHIN,
                                "%s: run_team %d B, ROS %d B" % (link, s["bytes_sent"][peer],
                                                                 r["bytes_sent"][peer]))

    def test_a_bad_configuration_file_is_refused_naming_the_key(self):
        config = os.path.join(self.dir, "bad.yaml")
        with open(config, "w") as f:
            f.write("matcher: {complete_placez: 10}\nmapper: {resolution_m: -1}\n")
        done = subprocess.run(["rosrun", "ccir_mapping", "run_team", "--config", config],
                              capture_output=True, text=True, timeout=120)
        self.assertEqual(done.returncode, 2, done.stderr)
        self.assertIn("matcher/complete_placez", done.stderr)
        self.assertIn("resolution_m", done.stderr)


if __name__ == "__main__":
    rospy.init_node("runner_equivalence_check", anonymous=True)
    rosunit.unitrun("ccir_mapping", "runner_equivalence", RunnerEquivalence)
