#!/usr/bin/env python3
"""One mission replayed at full and at half speed through the bridge, each run on fresh ROS
masters: robot_a's pipeline (fixed rate, every keyframe: far more than the budget) on its own
master, fed the fixture bag at the given speed, and robot_b's bridge on another. Rates follow
mission time while replaying, so both runs send the same scans and, while the link is
saturated, the same bytes per mission second (within 5 %); with the bridge on the wall clock
the half-speed run would send twice as many."""
import csv
import os
import shutil
import tempfile
import time
import unittest

import rosbag
import rosgraph
import rospy
import rosunit

from ccir_mapping.rostest_processes import Processes, free_port

TEAM_KEY = "replay-rate-test-team-key"
# Below what every keyframe in wire form needs (~60 KB a second), so the link is saturated.
BUDGET = 20000.0
BURST = 16384


def rows(path):
    """The complete rows so far of a CSV another process is appending to."""
    if not os.path.exists(path):
        return []
    with open(path) as f:
        lines = [line for line in f if not line.startswith("WARNING")]  # rostopic's own
    return [r for r in csv.DictReader(lines) if None not in r.values() and None not in r]


class ReplayRate(Processes, unittest.TestCase):
    def setUp(self):
        self.bag = rospy.get_param("~bag")
        self.dir = tempfile.mkdtemp(prefix="replay_rate_")
        self.processes = []

    def tearDown(self):
        self.stop_all()
        shutil.rmtree(self.dir, ignore_errors=True)

    def replay(self, rate):
        """Bytes robot_a sent per mission second while saturated, and the scans it sent."""
        run = os.path.join(self.dir, "rate_%s" % rate)
        os.makedirs(run)
        master = {r: free_port() for r in ("robot_a", "robot_b")}
        listen = {r: free_port() for r in ("robot_a", "robot_b")}
        for robot, port in master.items():
            self.spawn("master_" + robot, ["rosmaster", "--core", "-p", str(port)], port)
        for robot, port in master.items():
            online = rosgraph.Master("/replay_rate", "http://127.0.0.1:%d" % port).is_online
            self.wait_for(online, 30, "the master of " + robot)
        configs = {}
        for robot, peer in (("robot_a", "robot_b"), ("robot_b", "robot_a")):
            configs[robot] = os.path.join(run, robot + ".yaml")
            with open(configs[robot], "w") as f:
                # Small fragments (a tenth of a second's budget), reports every mission
                # second: each report's rate is then the budget's to a few percent.
                f.write("broker: {mode: fixed_rate, fixed_rate_every_n: 1}\n"
                        "bridge:\n  listen_port: %d\n  team_key: %s\n  budget_bytes_per_s: %f\n"
                        "  total_budget_bytes_per_s: %f\n  reconnect_min_s: 0.2\n"
                        "  fragment_bytes: 2048\n  burst_bytes: %d\n  stats_period_s: 1.0\n"
                        "  peers: [{name: %s, host: 127.0.0.1, port: %d}]\n"
                        % (listen[robot], TEAM_KEY, BUDGET, BUDGET, BURST, peer, listen[peer]))
        a, b = master["robot_a"], master["robot_b"]
        self.spawn("pipeline_a", ["roslaunch", "ccir_mapping", "robot.launch", "robot:=robot_a",
                                  "use_sim_time:=true", "overrides:=" + configs["robot_a"]], a)
        self.spawn("bridge_b", ["roslaunch", "ccir_mapping", "bridge.launch", "robot:=robot_b",
                                "config:=" + configs["robot_b"]], b)
        link_csv = os.path.join(run, "link.csv")
        broker_csv = os.path.join(run, "broker.csv")
        self.spawn("echo_link", ["rostopic", "echo", "-p", "/link_stats"], a, out=link_csv)
        self.spawn("echo_broker", ["rostopic", "echo", "-p", "/broker_stats"], a, out=broker_csv)
        self.wait_for(
            lambda: any(r.get("field.connected") in ("1", "True") for r in rows(link_csv)), 90,
            "robot_a's link to robot_b came up")
        player = self.spawn("play", ["rosbag", "play", "--clock", "--quiet",
                                     "--wait-for-subscribers", "-r", str(rate), self.bag,
                                     "--topics", "/velodyne_points", "/odom", "/tf", "/tf_static"],
                            a)
        player.wait(timeout=300)
        self.assertEqual(player.returncode, 0, "rosbag play failed")
        # The Broker has seen every keyframe once its count stands still for 3 s (its stats go on
        # after the replay, on the wall clock).
        counts = []

        def settled():
            last = rows(broker_csv)[-1:] or [{"field.keyframes": "-1"}]
            counts.append((time.monotonic(), last[0]["field.keyframes"]))
            recent = [c for t, c in counts if t > counts[-1][0] - 3.0]
            return counts[-1][0] - counts[0][0] > 3.0 and len(set(recent)) == 1
        self.wait_for(settled, 60, "the Broker's keyframe count settled")
        scans_sent = int(rows(broker_csv)[-1]["field.scans_sent"])
        samples = [(int(r["field.header.stamp"]) * 1e-9, int(r["field.bytes_sent"]))
                   for r in rows(link_csv)]
        # Bytes sent by the same mission instants in both runs (interpolated between reports):
        # from 2 s into the replay, when the link is saturated, to 1 s before its end (then
        # mission time stands still and the queue drains on the wall clock).
        bag = rosbag.Bag(self.bag)
        t0, t1 = bag.get_start_time() + 2.0, bag.get_end_time() - 1.0
        bag.close()

        def sent_at(t):
            for (ta, sa), (tb, sb) in zip(samples, samples[1:]):
                if ta <= t <= tb and tb > ta:
                    return sa + (sb - sa) * (t - ta) / (tb - ta)
            self.fail("no link report around mission time %.1f s" % t)
        rate_bytes_per_s = (sent_at(t1) - sent_at(t0)) / (t1 - t0)
        # LinkStats' own rate is per second of the bridge's clock too.
        reported = sorted(float(r["field.send_rate_bytes_per_s"]) for r in rows(link_csv)
                          if t0 <= int(r["field.header.stamp"]) * 1e-9 <= t1)
        self.assertGreater(len(reported), 4)
        median = reported[len(reported) // 2]
        self.assertLess(abs(median - BUDGET), 0.2 * BUDGET,
                        "send_rate_bytes_per_s %.0f at %sx" % (median, rate))
        self.stop_all()
        return rate_bytes_per_s, scans_sent

    def test_same_bytes_per_mission_second_at_half_speed(self):
        full_rate, full_scans = self.replay(1.0)
        half_rate, half_scans = self.replay(0.5)
        print("bytes per mission second: %.0f at full speed, %.0f at half speed (budget %.0f); "
              "scans sent %d and %d" % (full_rate, half_rate, BUDGET, full_scans, half_scans))
        self.assertGreater(full_scans, 5)
        self.assertEqual(full_scans, half_scans)
        self.assertLess(full_rate, 1.1 * BUDGET)
        self.assertGreater(full_rate, 0.7 * BUDGET, "the link was not saturated")
        self.assertLess(abs(half_rate - full_rate), 0.05 * full_rate)


if __name__ == "__main__":
    rospy.init_node("replay_rate_check", anonymous=True)
    rosunit.unitrun("ccir_mapping", "replay_rate", ReplayRate)
