#!/usr/bin/env python3
"""A robot that crashes mid-mission and resumes: two robots of the fixture mission, each its whole
pipeline (launch/robot.launch, broker mode ccir) on a ROS master of its own, bridged over
loopback, saving every 2 s of mission time (save_period_s). robot_b replays the first half of
its bag, and once its map is saved its manager dies with SIGKILL (manager, nodelet loaders
and roslaunch at once: nothing is written at shutdown). Started again with resume:=true it must
come back with its team graph (every keyframe it had, from team_graph_inputs) and its saved map
before any new scan, then replay the second half numbering its keyframes after the old ones.
robot_a runs throughout: it takes robot_b back as a new incarnation, and nothing robot_b sends
after the restart is refused as a duplicate."""
import os
import shutil
import signal
import tempfile
import unittest

import rospy
import rosunit

from ccir_mapping.rostest_processes import Processes, descendants

ROBOTS = ["robot_a", "robot_b"]
HALF_S = 10  # of the fixture's 20 s: robot_b's crash
RATE = "0.3"  # so that two pipelines keep up on a slow two-core machine
KEYFRAME_ID_BLOCK = 1000  # core/preprocess/keyframe_id_journal.h


class RobotRestart(Processes, unittest.TestCase):
    def setUp(self):
        self.mission = rospy.get_param("~mission")
        self.dir = tempfile.mkdtemp(prefix="robot_restart_")
        self.processes = []

    def tearDown(self):
        self.stop_all()
        shutil.rmtree(self.dir, ignore_errors=True)

    def play(self, robot, port, *window):
        player = self.spawn("play_%s_%s" % (robot, "_".join(window) or "all"),
                            ["rosbag", "play", "--clock", "--quiet", "--wait-for-subscribers",
                             "-r", RATE, os.path.join(self.mission, robot + ".bag"),
                             "--topics", "/velodyne_points", "/odom", "/tf", "/tf_static"]
                            + list(window), port)
        return player

    def trajectory_length(self, port):
        path = self.latest("/trajectory", port)
        return len(path["poses"]) if path else 0

    def test_a_killed_robot_resumes_its_mission(self):
        saved = {r: os.path.join(self.dir, r + "_saved") for r in ROBOTS}
        master = self.start_team(self.dir, ROBOTS, lambda robot, bridge: (
            "broker: {mode: ccir, stats_period_s: 0.5}\n"
            "bridge: {%s, stats_period_s: 0.2}\n" % bridge),
            lambda robot: ["save_dir:=" + saved[robot], "save_period_s:=2"])
        a, b = master["robot_a"], master["robot_b"]
        ids_log = os.path.join(self.dir, "robot_b_keyframe_ids.csv")
        self.spawn("ids_b", ["rostopic", "echo", "-p", "/keyframes/id"], b, out=ids_log)

        def linked():
            return all((self.latest("/link_stats", master[r]) or {}).get("connected")
                       for r in ROBOTS)
        self.wait_for(linked, 300, "both robots' links came up")
        player_a = self.play("robot_a", a)
        first_half = self.play("robot_b", b, "-u", str(HALF_S))
        first_half.wait(timeout=300)
        self.assertEqual(first_half.returncode, 0, "rosbag play failed")

        # Its graph has optimised every keyframe it made; the map is saved; then the crash.
        def keyframe_ids():
            with open(ids_log) as f:
                return [int(line.split(",")[1]) for line in f if line[:1].isdigit()]
        self.wait_for(lambda: len(keyframe_ids()) >= 5 and
                      self.trajectory_length(b) == len(keyframe_ids()), 120,
                      "robot_b's keyframes all in its trajectory")
        keyframes_before = len(keyframe_ids())
        map_file = os.path.join(saved["robot_b"], "map.bt")
        self.wait_for(lambda: os.path.exists(map_file), 60, "robot_b's periodic save")
        pipeline_b = [p for p in self.processes if "robot:=robot_b" in p.args][0]
        for pid in descendants(pipeline_b.pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        pipeline_b.wait(timeout=10)

        self.start_pipeline("robot_b", os.path.join(self.dir, "robot_b.yaml"), b,
                            ["save_dir:=" + saved["robot_b"], "save_period_s:=2", "resume:=true"],
                            "_resumed")
        # Before any new scan: its keyframes and its map are back.
        self.wait_for(lambda: self.trajectory_length(b) >= keyframes_before, 120,
                      "robot_b's resumed trajectory (%d keyframes before the crash)"
                      % keyframes_before)
        self.wait_for(lambda: ((self.latest("/map_stats", b) or {}).get("known_volume_m3") or 0)
                      > 1.0, 120, "robot_b's resumed map")
        second_half = self.play("robot_b", b, "-s", str(HALF_S))
        second_half.wait(timeout=300)
        self.assertEqual(second_half.returncode, 0, "rosbag play failed")
        player_a.wait(timeout=300)
        self.wait_for(lambda: self.trajectory_length(b) >= keyframes_before + 5, 120,
                      "robot_b's new keyframes after the old ones")

        # Keyframe ids: the first run's from 0, the resumed run's after a reserved block.
        ids = keyframe_ids()
        old = [i for i in ids if i < KEYFRAME_ID_BLOCK]
        new = [i for i in ids if i >= KEYFRAME_ID_BLOCK]
        print("robot_b keyframes: %d before the crash, %d after, from id %s"
              % (len(old), len(new), new[:1]))
        self.assertEqual(old, list(range(keyframes_before)))
        self.assertEqual(new, list(range(KEYFRAME_ID_BLOCK, KEYFRAME_ID_BLOCK + len(new))))
        self.assertGreaterEqual(len(new), 5)

        # robot_a: robot_b came back as a new incarnation; nothing of it refused as a duplicate.
        def routing():
            stats = self.latest("/broker_stats", a) or {}
            return {p["peer"]: p for p in stats.get("peers", [])}.get("robot_b")
        self.wait_for(lambda: (routing() or {}).get("offers_received"), 120,
                      "robot_a hearing robot_b's offers")
        peer = routing()
        refused = dict(zip(peer["refused_reasons"] or [], peer["refused_counts"] or []))
        print("robot_a <- robot_b: offers %d, scans %d, refused %s"
              % (peer["offers_received"], peer["scans_received"], refused))
        for reason in ("duplicate_scan", "undecodable_scan", "malformed_offer", "not_offered"):
            self.assertNotIn(reason, refused)
        link = self.latest("/link_stats", a)
        self.assertGreaterEqual(link["peer_restarts"], 1, "robot_a saw no new incarnation")

        # The resumed run keeps journaling: stopped, robot_b's files hold both runs.
        self.stop_all()
        with open(os.path.join(saved["robot_b"], "team_graph_inputs")) as f:
            own = [int(line.split()[2]) for line in f if line.startswith("K ")]
        self.assertEqual(own, sorted(own))
        self.assertTrue(any(i < KEYFRAME_ID_BLOCK for i in own) and own[-1] >= KEYFRAME_ID_BLOCK)
        with open(os.path.join(saved["robot_b"], "trajectory.tum")) as f:
            rows = [line for line in f if line[:1].isdigit()]
        self.assertEqual(len(rows), len(own), "one trajectory row per keyframe of both runs")


if __name__ == "__main__":
    rospy.init_node("robot_restart_check", anonymous=True)
    rosunit.unitrun("ccir_mapping", "robot_restart", RobotRestart)
