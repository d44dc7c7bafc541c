#!/usr/bin/env python3
"""The bridge between separate ROS masters: N robots, each with its own rosmaster (its own port,
its own processes), a Bridge in its own manager, and a traffic node. Every link goes through a
link_proxy (the emulated radio) that records the bytes each way and cuts the robot_a-robot_b
connection once, mid-run.

With ~netns, the two robots live in network namespaces the test makes, joined by a veth pair
shaped with tbf (the kernel's rate limiter; 250 KB/s, above the budget) and addressed from
10.200.0.0/24; it is skipped with a message where namespaces cannot be made.

With ~restart, robot_b crashes instead of the cut: its bridge (manager, nodelet loader,
roslaunch) and traffic node are killed with SIGKILL, as a manager dies with the nodelets in it,
and started again. The teammates must keep running, take robot_b back as a new incarnation, and
deliver every message of each robot_b process once and in order (the first process's up to its
crash), and robot_b's new process everything sent after its first message, latched state
included.

With ~outage_s, the robot_a-robot_b radio carries nothing for that long instead of the cut
(its connections stay open, as a radio out of range: the bridges close them as silent and
redial into the outage) while the traffic goes on; afterwards the backlog must arrive exactly
once and in order within the budget.

Checks: every control message and scan from each teammate arrives exactly once and in order
across the cut; each robot's bytes on the wire stay within its total budget in every 1 s (and
5 s) window while scans saturate it, and fill most of it; control messages stay fast (those sent
around the cut or the restart excepted)."""
import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest
import xml.etree.ElementTree as ET

import roslib.packages
import rospy

from ccir_mapping.rostest_processes import Processes, descendants, free_port

BUDGET = 150000.0
BURST = 131072
TEAM_KEY = "bridge-test-team-key"
CUT_AFTER_S = 8.0  # into the traffic; robot_b's crash with ~restart too
RESTART_TRAFFIC_AFTER_S = 4.0  # after the crash: robot_b's new process sends from then
# Queues that hold every message of a run (30 s at most: 600 pings, 200 clouds), so that an
# outage's backlog waits whole however late the link is seen down: the default 100 pings fill
# in 5 s, and a busy machine once dropped one (queue_full) in the 60 s outage.
QUEUED = 1000


def executable(name):
    found = roslib.packages.find_node("ccir_mapping", name)
    if not found:
        raise RuntimeError("%s is not built" % name)
    return found[0]


class BridgeMasters(Processes, unittest.TestCase):
    def setUp(self):
        self.netns = rospy.get_param("~netns", False)
        self.restart = rospy.get_param("~restart", False)
        self.outage_s = rospy.get_param("~outage_s", 0.0)
        count = 2 if self.netns else rospy.get_param("~robots", 2)
        self.robots = ["robot_%s" % c for c in "abcdefgh"[:count]]
        self.duration_s = rospy.get_param("~duration_s", 12.0)
        # A cloud every 3 control messages (6.7 Hz): a third more than the budget takes.
        self.cloud_bytes = rospy.get_param("~cloud_bytes", 30000)
        self.dir = tempfile.mkdtemp(prefix="bridge_masters_")
        self.processes = []

    def tearDown(self):
        self.stop_all()
        shutil.rmtree(self.dir, ignore_errors=True)

    def check_call(self, command):
        subprocess.run(command, check=True, capture_output=True, timeout=20)

    def make_namespaces(self):
        """Two network namespaces (held by sleeping processes) joined by a tbf-shaped veth pair;
        returns each one's command prefix and address."""
        for tool in ("unshare", "nsenter", "ip", "tc"):
            if not shutil.which(tool):
                self.skipTest("network namespace test skipped: %s is not installed" % tool)
        holders = []
        for robot in self.robots:
            holder = self.spawn("netns_" + robot, ["unshare", "--net", "sleep", "3600"])
            holders.append(holder)
        prefixes, hosts = {}, {}
        try:
            own = os.readlink("/proc/self/ns/net")
            for holder in holders:
                deadline = time.time() + 10
                while True:  # until unshare has moved into its new namespace
                    if holder.poll() is not None:
                        raise RuntimeError("unshare --net failed")
                    try:
                        if os.readlink("/proc/%d/ns/net" % holder.pid) != own:
                            break
                    except OSError:
                        pass
                    if time.time() > deadline:
                        raise RuntimeError("unshare --net made no namespace")
                    time.sleep(0.01)
            a, b = (["nsenter", "-t", str(h.pid), "-n"] for h in holders)
            self.check_call(a + ["ip", "link", "add", "v1", "type", "veth", "peer", "name", "v2"])
            self.check_call(a + ["ip", "link", "set", "v2", "netns", str(holders[1].pid)])
            for prefix, dev, address in ((a, "v1", "10.200.0.1"), (b, "v2", "10.200.0.2")):
                self.check_call(prefix + ["ip", "addr", "add", address + "/24", "dev", dev])
                self.check_call(prefix + ["ip", "link", "set", "lo", "up"])
                self.check_call(prefix + ["ip", "link", "set", dev, "up"])
                # burst must be at least the MTU (1500), or TCP stalls.
                self.check_call(prefix + ["tc", "qdisc", "add", "dev", dev, "root", "tbf", "rate",
                                          "2mbit", "burst", "32kb", "latency", "200ms"])
            for robot, prefix, address in zip(self.robots, (a, b), ("10.200.0.1", "10.200.0.2")):
                prefixes[robot], hosts[robot] = prefix, address
        except (RuntimeError, subprocess.SubprocessError, OSError) as e:
            detail = getattr(e, "stderr", b"") or b""
            self.skipTest("network namespace test skipped: cannot make namespaces here (%s %s)"
                          % (e, detail.decode(errors="replace").strip()))
        return prefixes, hosts

    def spawn(self, name, command, master_port=None):
        env = dict(os.environ, ROS_IP="127.0.0.1", ROS_LOG_DIR=os.path.join(self.dir, "log"))
        env.pop("ROS_HOSTNAME", None)
        if master_port:
            env["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % master_port
        log = open(os.path.join(self.dir, name + ".log"), "w")
        process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True)
        self.processes.append(process)
        return process

    def log_tail(self, name, lines=30):
        with open(os.path.join(self.dir, name + ".log")) as f:
            return "".join(f.readlines()[-lines:])

    def link_stats(self, robot, master_port, peer):
        """The robot's next link_stats for the peer, as rostopic -p prints it (field.*)."""
        env = dict(os.environ, ROS_IP="127.0.0.1",
                   ROS_MASTER_URI="http://127.0.0.1:%d" % master_port)
        rows = subprocess.run(["rostopic", "echo", "-n", "10", "-p", "/link_stats"], env=env,
                              capture_output=True, text=True, timeout=60).stdout
        for row in csv.DictReader(rows.splitlines()):
            if row["field.peer"] == peer:
                return row
        self.fail("no link_stats of %s for %s" % (robot, peer))

    def test_team_over_separate_masters(self):
        n = len(self.robots)
        masters = {r: free_port() for r in self.robots}
        listen = {r: free_port() for r in self.robots}
        # Where each robot runs (a command prefix) and the address teammates reach it at.
        prefix = {r: [] for r in self.robots}
        host = {r: "127.0.0.1" for r in self.robots}
        if self.netns:
            prefix, host = self.make_namespaces()
        for robot, port in masters.items():
            self.spawn("master_" + robot, prefix[robot] + ["rosmaster", "--core", "-p", str(port)])
        # The robot whose name sorts first dials, through a proxy of its own per link (in its
        # own namespace, relaying to the teammate's address).
        proxies = {}
        proxy_started = time.time()
        start_at = proxy_started + 10.0 + 2.0 * n
        for i, a in enumerate(self.robots):
            for b in self.robots[i + 1:]:
                port = free_port()
                command = [executable("link_proxy"), "--listen-port", str(port), "--target-host",
                           host[b], "--target-port", str(listen[b]), "--rate-bytes-per-s", "1e6",
                           "--seed", str(i + 1),
                           "--log", os.path.join(self.dir, "wire_%s_%s.csv" % (a, b))]
                if (a, b) == ("robot_a", "robot_b") and self.outage_s:
                    begin = start_at - proxy_started + CUT_AFTER_S
                    command += ["--outage-s", str(begin), str(begin + self.outage_s)]
                elif (a, b) == ("robot_a", "robot_b") and not self.restart:
                    command += ["--cut-at-s", str(start_at - proxy_started + CUT_AFTER_S)]
                proxies[(a, b)] = (port, self.spawn("proxy_%s_%s" % (a, b), prefix[a] + command))
        for robot in self.robots:
            # Asked from the robot's own namespace (roslaunch --wait hangs in one).
            waited = subprocess.run(prefix[robot] + [
                "python3", "-c", "import rosgraph, sys, time\n"
                "m = rosgraph.Master('/wait', 'http://127.0.0.1:%d')\n"
                "deadline = time.time() + 20\n"
                "while not m.is_online() and time.time() < deadline: time.sleep(0.1)\n"
                "sys.exit(0 if m.is_online() else 1)" % masters[robot]], timeout=30)
            self.assertEqual(waited.returncode, 0, "rosmaster of %s did not come up" % robot)

        def start_robot(robot, config, at, settle_s=40.0 + self.outage_s):
            """The robot's bridge and traffic node; returns the traffic node's process."""
            self.spawn("bridge_" + robot,
                       prefix[robot] + ["roslaunch", "ccir_mapping", "bridge.launch",
                                        "robot:=" + robot, "config:=" + config],
                       masters[robot])
            self.spawn("traffic_" + robot,
                       prefix[robot] + [
                           executable("bridge_traffic.py"), "--robot", robot, "--peers",
                           ",".join(r for r in self.robots if r != robot), "--start-at",
                           str(at), "--duration-s", str(self.duration_s), "--cloud-every", "3",
                           "--cloud-bytes", str(self.cloud_bytes), "--settle-s", str(settle_s),
                           "--out", os.path.join(self.dir, "traffic_%s.json" % robot)],
                       masters[robot])
            return self.processes[-1]

        traffic = {}
        for robot in self.robots:
            peers = []
            for other in self.robots:
                if other == robot:
                    continue
                dials = robot < other
                address, port = (("127.0.0.1", proxies[(robot, other)][0]) if dials
                                 else (host[other], listen[other]))
                peers.append("{name: %s, host: %s, port: %d}" % (other, address, port))
            config = os.path.join(self.dir, robot + ".yaml")
            with open(config, "w") as f:
                f.write("bridge:\n  listen_port: %d\n  listen_address: 0.0.0.0\n"
                        "  team_key: %s\n  budget_bytes_per_s: %f\n"
                        "  total_budget_bytes_per_s: %f\n  burst_bytes: %d\n"
                        "  reconnect_min_s: 0.2\n  reconnect_max_s: 1.0\n  peer_timeout_s: 5.0\n"
                        "  peers: [%s]\n"
                        "  topics: [{topic: outbox/ping, priority: control, max_queued: %d},\n"
                        "           {topic: outbox/state, priority: control},\n"
                        "           {topic: outbox/cloud, priority: bulk, max_queued: %d}]\n"
                        % (listen[robot], TEAM_KEY, BUDGET, BUDGET, BURST, ", ".join(peers),
                           QUEUED, QUEUED))
            traffic[robot] = start_robot(robot, config, start_at)

        restarted_at = None
        if self.restart:
            # robot_b crashes mid-traffic: its manager, loader, roslaunch and traffic node at once.
            time.sleep(max(0.0, start_at + CUT_AFTER_S - time.time()))
            bridge_b = [p for p in self.processes if "robot:=robot_b" in p.args][0]
            for pid in descendants(bridge_b.pid) + [traffic["robot_b"].pid]:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            bridge_b.wait(timeout=10)
            traffic["robot_b"].wait(timeout=10)
            restarted_at = time.time() + RESTART_TRAFFIC_AFTER_S
            os.rename(os.path.join(self.dir, "bridge_robot_b.log"),
                      os.path.join(self.dir, "bridge_robot_b_crashed.log"))
            traffic["robot_b"] = start_robot("robot_b", os.path.join(self.dir, "robot_b.yaml"),
                                             restarted_at, settle_s=10.0)

        for robot, process in traffic.items():
            try:
                last_start = max(start_at, restarted_at or 0)
                process.wait(
                    timeout=last_start - time.time() + self.duration_s + 60 + self.outage_s)
            except subprocess.TimeoutExpired:
                self.fail("traffic of %s did not finish:\n%s"
                          % (robot, self.log_tail("traffic_" + robot)))
            self.assertEqual(process.returncode, 0, "traffic of %s failed:\n%s\nbridge:\n%s" % (
                robot, self.log_tail("traffic_" + robot), self.log_tail("bridge_" + robot)))
        for _, process in proxies.values():
            process.send_signal(signal.SIGINT)
            process.wait(timeout=10)

        if self.netns:
            # The traffic crossed the shaped veth link, not some other path.
            stats = subprocess.run(prefix["robot_a"] + ["tc", "-s", "qdisc", "show", "dev", "v1"],
                                   capture_output=True, text=True, timeout=10).stdout
            sent = int(re.search(r"Sent (\d+) bytes", stats).group(1))
            print("tbf on robot_a's veth sent %d bytes" % sent)
            self.assertGreater(sent, 0.5 * BUDGET * self.duration_s, stats)
        if self.restart:
            for robot in self.robots:
                if robot != "robot_b":
                    row = self.link_stats(robot, masters[robot], "robot_b")
                    self.assertEqual(int(row["field.peer_restarts"]), 1,
                                     "%s took robot_b back as a new incarnation" % robot)
        elif self.outage_s:
            self.assertIn("closed", self.log_tail("bridge_robot_a", 200),
                          "robot_a closed the silent link")
            for robot, peer in (("robot_a", "robot_b"), ("robot_b", "robot_a")):
                row = self.link_stats(robot, masters[robot], peer)
                # rostopic -p numbers array elements: field.drop_reasons0, field.drop_counts0, ...
                drops = {row[k]: int(row[k.replace("reasons", "counts")]) for k in row
                         if k.startswith("field.drop_reasons")}
                print("%s's link to %s after the outage: drops %s" % (robot, peer, drops))
                # (A "duplicate" is a message resent after the outage and dropped: as it should.)
                for reason in ("missing", "given_up", "queue_full"):
                    self.assertNotIn(reason, drops, "%s at %s" % (reason, robot))
        else:
            self.assertIn("cut every connection", self.log_tail("proxy_robot_a_robot_b"))
            self.assertIn("closed", self.log_tail("bridge_robot_a", 200), "robot_a saw the cut")
        results = {}
        for robot in self.robots:
            with open(os.path.join(self.dir, "traffic_%s.json" % robot)) as f:
                results[robot] = json.load(f)
        cut_at = start_at + CUT_AFTER_S
        all_latencies = []
        for robot, result in results.items():
            for peer, got in result["received"].items():
                self.assertEqual(result["latched"][peer], peer + "/state/0",
                                 "%s's latched state at %s" % (peer, robot))
                sent = results[peer]["sent"]
                for kind in ("ping", "cloud"):
                    numbers = [m[0] for m in got[kind]]
                    what = "%s from %s at %s (%d of %d)" % (kind, peer, robot, len(numbers),
                                                            sent[kind])
                    if self.restart and robot == "robot_b":
                        # The new process: from its first message on, each once, in order, to
                        # the last sent.
                        self.assertTrue(numbers, what)
                        self.assertEqual(numbers, list(range(numbers[0], sent[kind])), what)
                        continue
                    if self.restart and peer == "robot_b":
                        # The crashed process's up to the crash, then all the new one's.
                        resets = [i for i in range(1, len(numbers)) if numbers[i] <= numbers[i - 1]]
                        self.assertEqual(len(resets), 1, what + ": %s" % numbers)
                        first, second = numbers[:resets[0]], numbers[resets[0]:]
                        self.assertEqual(first, list(range(len(first))), what)
                        self.assertEqual(second, list(range(sent[kind])), what)
                        continue
                    self.assertEqual(numbers, list(range(sent[kind])),
                                     "%s: not exactly once in order\n%s"
                                     % (what, self.log_tail("bridge_" + robot)))
                # Control latency, except for pings sent around the cut of a-b or robot_b's
                # crash and restart.
                since = cut_at - 1.0
                if self.restart:
                    around, until = "robot_b" in (peer, robot), restarted_at + 3.0
                else:
                    around = {peer, robot} == {"robot_a", "robot_b"}
                    until = cut_at + self.outage_s + 3.0
                all_latencies += [arrived - stamp for _, stamp, arrived in got["ping"]
                                  if not (around and since <= stamp <= until)]
        all_latencies.sort()
        p50 = all_latencies[len(all_latencies) // 2]
        p99 = all_latencies[int(0.99 * (len(all_latencies) - 1))]
        print("control latency p50 %.3f s, p99 %.3f s, max %.3f s over %d messages"
              % (p50, p99, all_latencies[-1], len(all_latencies)))
        self.assertLess(p50, 0.3)
        self.assertLess(p99, 0.8)

        # Each robot's bytes on the wire: what it sent through the proxies it dialed ("up") and
        # back through those that dialed it ("down").
        for robot in self.robots:
            chunks = []
            for (a, b) in proxies:
                if robot not in (a, b):
                    continue
                with open(os.path.join(self.dir, "wire_%s_%s.csv" % (a, b))) as f:
                    for row in csv.DictReader(f):
                        if row["direction"] == ("up" if robot == a else "down"):
                            chunks.append((float(row["time_s"]), int(row["bytes"])))
            chunks.sort()
            for window in (1.0, 5.0):
                j = 0
                in_window = 0
                for i in range(len(chunks)):
                    while j < len(chunks) and chunks[j][0] < chunks[i][0] + window:
                        in_window += chunks[j][1]
                        j += 1
                    self.assertLessEqual(in_window, BURST + BUDGET * window,
                                         "%s sent %d bytes in %.0f s from %.2f s" % (
                                             robot, in_window, window, chunks[i][0]))
                    in_window -= chunks[i][1]
            # While saturated (after the first burst, before the cut): most of the budget.
            t0 = start_at - proxy_started + 4.0
            t1 = start_at - proxy_started + CUT_AFTER_S - 0.5
            used = sum(b for t, b in chunks if t0 <= t < t1) / (t1 - t0)
            print("%s: %.0f bytes/s on the wire while saturated (budget %.0f)"
                  % (robot, used, BUDGET))
            self.assertGreater(used, 0.85 * BUDGET, robot)


def main():
    """Runs the test and writes its JUnit XML itself: rosunit's writer has no "skipped"."""
    rospy.init_node("bridge_masters", anonymous=True)
    suite = unittest.defaultTestLoader.loadTestsFromTestCase(BridgeMasters)
    ids = [test.id() for test in suite]  # (running empties the suite)
    result = unittest.TextTestRunner(verbosity=2).run(suite)
    output = [a.split("xml:", 1)[1] for a in sys.argv if a.startswith("--gtest_output=xml:")]
    if output:
        suite_xml = ET.Element("testsuite", name="bridge_masters", tests=str(result.testsRun),
                               failures=str(len(result.failures)),
                               errors=str(len(result.errors)))
        outcomes = {}
        for kind, entries in (("failure", result.failures), ("error", result.errors),
                              ("skipped", result.skipped)):
            for test, text in entries:
                outcomes[test.id()] = (kind, text)
        for test_id in ids:
            case = ET.SubElement(suite_xml, "testcase", classname="BridgeMasters",
                                 name=test_id.rsplit(".", 1)[1])
            if test_id in outcomes:
                kind, text = outcomes[test_id]
                ET.SubElement(case, kind, message=text.strip().splitlines()[-1]).text = text
        os.makedirs(os.path.dirname(output[0]), exist_ok=True)
        ET.ElementTree(suite_xml).write(output[0])
    sys.exit(0 if result.wasSuccessful() else 1)


if __name__ == "__main__":
    main()
