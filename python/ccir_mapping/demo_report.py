"""Watches one robot's pipeline during the demo and writes what flowed through each nodelet.

Sets /demo/ready once it is connected to the pipeline; after /demo/playback_done it waits for
the last statistics, writes <out>/report.json and prints a summary.
"""
import argparse
import json
import math
import os
import time
import xmlrpc.client

import numpy as np
import rosgraph
import rospy
from ccir_mapping.msg import (BrokerStats, Keyframe, KeyframeFeatures, LinkStats, LoopClosure,
                              MapStats, TeamTransform)
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Clock
from nav_msgs.msg import Path

from .clouds import quaternion_matrix, xyz

# The top-down picture of the map: wall points 0.2-1.5 m above the ground (the sensor is 0.5 m
# up), one per TOPDOWN_CELL_M cube of a keyframe.
TOPDOWN_Z_M = (-0.3, 1.0)
TOPDOWN_CELL_M = 0.25


def process_cpu_s(pid):
    """CPU seconds (user + system) a process has used, from /proc."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def node_pid(name):
    """Process id of a node of this master."""
    uri = rosgraph.Master("/demo_report").lookupNode(name)
    return xmlrpc.client.ServerProxy(uri).getPid("/demo_report")[2]


def percentile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))] if values else None


class Report:
    def __init__(self):
        self.mission_time = None
        self.features_latency_s = []
        self.loop_latency_s = []
        self.keyframes = []
        self.walls = {}  # keyframe stamp -> its wall points in the sensor frame
        self.features = 0
        self.trajectory = None
        self.broker = None
        self.map = None
        self.links = {}
        self.team = {}
        self.inbox_scans = 0
        self.inbox_features = 0
        self.flows = {}
        self.levels = {}
        self.updated_at = {}
        # Time series (mission seconds): what the comparison of routing modes scores.
        self.series = {"links": {}, "map": [], "team_transforms": {}}
        self.subs = [
            rospy.Subscriber("keyframes", Keyframe, self.on_keyframe, queue_size=100),
            rospy.Subscriber("outbox/features", KeyframeFeatures, self.on_features, queue_size=100),
            rospy.Subscriber("trajectory", Path, self.on_trajectory, queue_size=1),
            rospy.Subscriber("broker_stats", BrokerStats, self.on_broker, queue_size=1),
            rospy.Subscriber("map_stats", MapStats, self.on_map, queue_size=1),
            rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=20),
            rospy.Subscriber("link_stats", LinkStats, self.on_link, queue_size=20),
            rospy.Subscriber("team_transforms", TeamTransform, self.on_team, queue_size=20),
            rospy.Subscriber("teammate_scans", Keyframe, self.on_inbox_scan, queue_size=100),
            rospy.Subscriber("inbox/features", KeyframeFeatures, self.on_inbox_features,
                             queue_size=100),
            rospy.Subscriber("features", KeyframeFeatures, self.on_own_features, queue_size=100),
            rospy.Subscriber("loop_closures", LoopClosure, self.on_loop, queue_size=1000),
            rospy.Subscriber("/clock", Clock, self.on_clock, queue_size=1),
        ]

    # Mission seconds from a keyframe's scan to what the Matcher made of it (this node may have
    # started before /use_sim_time was set: mission time from /clock itself).
    def on_clock(self, msg):
        self.mission_time = msg.clock

    def on_own_features(self, msg):
        if self.mission_time is not None:
            self.features_latency_s.append((self.mission_time - msg.header.stamp).to_sec())

    def on_loop(self, msg):
        # Only closures found for this robot's own keyframes: one found for a teammate's scan
        # carries that scan's stamp, and its age is the link's queue, not the pipeline's. The
        # own keyframe found for is "to" of an own loop and "from" of an inter-robot one (teammates'
        # scans share stamps with own keyframes, so the stamp alone does not tell).
        query = msg.keyframe_to if msg.robot_to == msg.robot_from else msg.keyframe_from
        own = any(k["id"] == query and k["stamp"] == msg.header.stamp.to_sec()
                  for k in self.keyframes)
        if self.mission_time is not None and own:
            self.loop_latency_s.append((self.mission_time - msg.header.stamp).to_sec())

    def on_keyframe(self, msg):
        p = msg.odom_pose.position
        self.keyframes.append({"id": msg.id, "stamp": msg.header.stamp.to_sec(), "x": p.x, "y": p.y,
                               "z": p.z, "points": msg.cloud.width * msg.cloud.height,
                               "travelled_m": msg.travelled_m})
        points = xyz(msg.cloud)
        points = points[(points[:, 2] > TOPDOWN_Z_M[0]) & (points[:, 2] < TOPDOWN_Z_M[1])]
        cells = np.unique(np.floor(points / TOPDOWN_CELL_M), axis=0)
        self.walls[msg.header.stamp.to_sec()] = (cells + 0.5) * TOPDOWN_CELL_M

    def on_features(self, msg):
        self.features += 1

    def on_trajectory(self, msg):
        self.trajectory = msg

    def on_broker(self, msg):
        self.broker = msg

    def on_map(self, msg):
        self.map = msg
        self.series["map"].append([msg.header.stamp.to_sec(), msg.known_volume_m3,
                                   msg.entropy_bits])

    def on_link(self, msg):
        if msg.peer:
            self.links[msg.peer] = msg
            self.series["links"].setdefault(msg.peer, []).append(
                [msg.header.stamp.to_sec(), msg.bytes_sent, msg.bytes_received])

    def on_team(self, msg):
        self.team[msg.peer] = msg
        t = msg.transform
        self.series["team_transforms"].setdefault(msg.peer, []).append(
            [msg.header.stamp.to_sec(), bool(msg.valid), msg.inliers,
             [t.translation.x, t.translation.y, t.translation.z],
             [t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w]])

    def on_inbox_scan(self, msg):
        self.inbox_scans += 1

    def on_inbox_features(self, msg):
        self.inbox_features += 1

    def links_idle(self):
        """Every link up and nothing waiting to be sent."""
        return self.links and all(link.connected and link.queued_control + link.queued_bulk == 0
                                  for link in self.links.values())

    def on_diagnostics(self, msg):
        for status in msg.status:
            nodelet = status.name.split(":")[0].split("/")[-1]
            self.updated_at[nodelet] = time.monotonic()
            self.levels[nodelet] = (ord(status.level) if isinstance(status.level, bytes)
                                    else status.level)
            self.flows[nodelet] = {kv.key: int(kv.value) if kv.value.isdigit() else kv.value
                                   for kv in status.values}

    def box_voxels(self):
        """Voxels of the map's entropy box: its entropy while nothing is known (1 bit each)."""
        lo, hi, res = self.map.box_min, self.map.box_max, self.map.resolution_m
        return math.prod(round((b - a) / res) + 1
                         for a, b in ((lo.x, hi.x), (lo.y, hi.y), (lo.z, hi.z)))

    def connected(self):
        return all(s.get_num_connections() > 0 for s in self.subs[:2])

    def topdown_xy(self):
        """Every keyframe's wall points at its optimised pose, in the robot's map frame (x y)."""
        placed = []
        for pose in self.trajectory.poses if self.trajectory else []:
            points = self.walls.get(pose.header.stamp.to_sec())
            if points is None:
                continue
            o, p = pose.pose.orientation, pose.pose.position
            placed.append(points @ quaternion_matrix([o.x, o.y, o.z, o.w])[:2].T + [p.x, p.y])
        return np.vstack(placed) if placed else np.zeros((0, 2))

    def as_dict(self):
        spacing = [math.dist((a["x"], a["y"]), (b["x"], b["y"]))
                   for a, b in zip(self.keyframes, self.keyframes[1:])]
        b = self.broker
        return {
            "keyframes": len(self.keyframes),
            "keyframe_spacing_m": {"mean": sum(spacing) / len(spacing) if spacing else 0.0,
                                   "min": min(spacing, default=0.0),
                                   "max": max(spacing, default=0.0)},
            "features_to_outbox": self.features,
            "trajectory_poses": len(self.trajectory.poses) if self.trajectory else 0,
            "broker": None if b is None else {
                "mode": b.mode, "keyframes": b.keyframes, "features_sent": b.features_sent,
                "kept_scans": b.kept_scans, "scans_sent": b.scans_sent,
                "scan_bytes_sent": b.scan_bytes_sent, "scans_received": b.scans_received,
                "scan_bytes_received": b.scan_bytes_received,
                "peers": {p.peer: {
                    "offers_sent": p.offers_sent, "scans_offered": p.scans_offered,
                    "offers_received": p.offers_received,
                    "scans_in_offers_received": p.scans_in_offers_received,
                    "scans_requested": p.scans_requested,
                    "scans_requested_by_peer": p.scans_requested_by_peer,
                    "scans_sent": p.scans_sent, "scan_bytes_sent": p.scan_bytes_sent,
                    "scans_received": p.scans_received,
                    "scan_bytes_received": p.scan_bytes_received,
                    "receipts_sent": p.receipts_sent, "receipts_received": p.receipts_received,
                    "control_bytes_sent": p.control_bytes_sent,
                    "refused": dict(zip(p.refused_reasons, p.refused_counts))}
                    for p in b.peers}},
            "map": None if self.map is None else {
                "keyframes": self.map.keyframes, "known_volume_m3": self.map.known_volume_m3,
                "entropy_bits": self.map.entropy_bits,
                "entropy_drop_bits": self.box_voxels() - self.map.entropy_bits,
                "resolution_m": self.map.resolution_m, "submap_moves": self.map.submap_moves,
                "reintegrations": self.map.reintegrations},
            "links": {peer: {"connected": l.connected, "bytes_sent": l.bytes_sent,
                             "budget_bytes_per_s": l.budget_bytes_per_s,
                             "bytes_received": l.bytes_received, "messages_sent": l.messages_sent,
                             "messages_received": l.messages_received,
                             "queued": l.queued_control + l.queued_bulk,
                             "drops": dict(zip(l.drop_reasons, l.drop_counts))}
                      for peer, l in sorted(self.links.items())},
            "team_transforms": {
                peer: {"valid": t.valid, "inliers": t.inliers, "candidates": t.candidates,
                       "translation": [t.transform.translation.x, t.transform.translation.y,
                                       t.transform.translation.z],
                       "rotation_xyzw": [t.transform.rotation.x, t.transform.rotation.y,
                                         t.transform.rotation.z, t.transform.rotation.w]}
                for peer, t in sorted(self.team.items())},
            "inbox_scans": self.inbox_scans,
            "inbox_features": self.inbox_features,
            "nodelets": {name: {"level": self.levels[name], "flow": flow}
                         for name, flow in sorted(self.flows.items())},
            "keyframe_list": self.keyframes,
            "trajectory": [] if self.trajectory is None else [
                [p.header.stamp.to_sec(), p.pose.position.x, p.pose.position.y, p.pose.position.z]
                for p in self.trajectory.poses],
            "series": self.series,
        }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--manager", required=True, help="the robot's nodelet manager node")
    parser.add_argument("--timeout-s", type=float, default=600.0)
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("demo_report")
    report = Report()
    deadline = time.monotonic() + args.timeout_s
    while not report.connected() and time.monotonic() < deadline and not rospy.is_shutdown():
        time.sleep(0.05)
    manager_pid = node_pid(args.manager)
    cpu_start_s = process_cpu_s(manager_pid)
    rospy.set_param("/demo/ready", True)
    while not rospy.get_param("/demo/playback_done", False) and time.monotonic() < deadline:
        time.sleep(0.1)
    # Diagnostics, broker and map statistics are periodic (1-2 s; the map inserts ~7 keyframes a
    # second): wait until they cover every keyframe.
    settle = time.monotonic() + 20.0
    while time.monotonic() < settle:
        flows = report.flows.get("broker", {})
        if (report.broker and report.broker.keyframes == len(report.keyframes)
                and flows.get("in keyframes messages") == len(report.keyframes)
                and report.map and report.map.keyframes == len(report.keyframes)):
            break
        time.sleep(0.1)
    # The links drain what the mission queued (scans at 150 KB/s per robot): this robot's have
    # nothing left to send and no byte has gone either way for 3 s.
    drain = time.monotonic() + 90.0
    received, quiet_since = None, time.monotonic()
    while time.monotonic() < drain:
        now_received = sum(link.bytes_received + link.bytes_sent
                           for link in report.links.values())
        if now_received != received:
            received, quiet_since = now_received, time.monotonic()
        if report.links_idle() and time.monotonic() - quiet_since > 3.0:
            break
        time.sleep(0.2)
    # One more diagnostics report from every nodelet, so each one's last counts are in.
    mark = time.monotonic()
    while time.monotonic() < mark + 5.0 and not all(t > mark for t in report.updated_at.values()):
        time.sleep(0.05)
    result = report.as_dict()
    result["manager_cpu_s"] = process_cpu_s(manager_pid) - cpu_start_s
    result["latency_mission_s"] = {
        name: {"p50": percentile(values, 0.5), "p99": percentile(values, 0.99), "n": len(values)}
        for name, values in (("word_sets", report.features_latency_s),
                             ("loop_closures", report.loop_latency_s))}
    with open(args.out + "/report.json", "w") as f:
        json.dump(result, f, indent=2)
    np.save(args.out + "/topdown_xy.npy", report.topdown_xy())

    lines = ["what flowed through each nodelet (from their diagnostics):"]
    for name, info in result["nodelets"].items():
        flow = ", ".join("%s %s" % (k.replace(" messages", ""), v) for k, v in info["flow"].items()
                         if k.endswith("messages"))
        lines.append("  %-13s %s" % (name, flow or "-"))
    sp = result["keyframe_spacing_m"]
    lines.append("keyframes: %d (spacing %.2f m mean, %.2f..%.2f m); features to outbox: %d; "
                 "scans sent: %d; trajectory poses: %d"
                 % (result["keyframes"], sp["mean"], sp["min"], sp["max"],
                    result["features_to_outbox"],
                    result["broker"]["scans_sent"] if result["broker"] else 0,
                    result["trajectory_poses"]))
    with open(args.out + "/summary.txt", "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
