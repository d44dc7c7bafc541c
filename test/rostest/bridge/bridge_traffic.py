#!/usr/bin/env python3
"""One robot's traffic for the multi-master bridge test, in that robot's own master.

From a given wall time it publishes, for a given time, PointCloud2 "scans" on outbox/cloud
(incompressible bytes) and small control messages (std_msgs/Header) on outbox/ping, numbered in
frame_id and stamped with the wall time of sending. It records what arrives on
inbox/<peer>/cloud and inbox/<peer>/ping from each teammate until everything each teammate sent
has arrived from its latest process (or a time limit passes). It also latches one message on
outbox/state before the traffic; at the end a new subscriber to each teammate's
inbox/<peer>/state must still get it.
Writes what it saw as JSON."""
import argparse
import json
import os
import threading
import time

import rospy
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--robot", required=True)
    parser.add_argument("--peers", required=True, help="comma-separated robot names")
    parser.add_argument("--start-at", type=float, required=True, help="wall time to start")
    parser.add_argument("--duration-s", type=float, default=12.0)
    parser.add_argument("--ping-hz", type=float, default=20.0)
    parser.add_argument("--cloud-every", type=int, default=4, help="a cloud every n pings")
    parser.add_argument("--cloud-bytes", type=int, default=30000)
    parser.add_argument("--settle-s", type=float, default=40.0)
    parser.add_argument("--out", required=True)
    args, _ = parser.parse_known_args(rospy.myargv()[1:])
    peers = args.peers.split(",")
    pings = int(round(args.duration_s * args.ping_hz))
    clouds = (pings + args.cloud_every - 1) // args.cloud_every

    rospy.init_node("bridge_traffic_" + args.robot)
    lock = threading.Lock()
    received = {peer: {"ping": [], "cloud": []} for peer in peers}

    def record(peer, kind):
        def callback(msg):
            header = msg if kind == "ping" else msg.header
            n = int(header.frame_id.rsplit("/", 1)[1])
            with lock:
                received[peer][kind].append([n, header.stamp.to_sec(), time.time()])
        return callback

    subscribers = []
    for peer in peers:
        subscribers.append(rospy.Subscriber("inbox/%s/ping" % peer, Header, record(peer, "ping")))
        subscribers.append(
            rospy.Subscriber("inbox/%s/cloud" % peer, PointCloud2, record(peer, "cloud"),
                             queue_size=1000))
    ping_pub = rospy.Publisher("outbox/ping", Header, queue_size=1000)
    state_pub = rospy.Publisher("outbox/state", Header, queue_size=1, latch=True)
    cloud_pub = rospy.Publisher("outbox/cloud", PointCloud2, queue_size=100)

    # The bridge must be subscribed before anything is sent (it cannot forward what it missed).
    deadline = time.time() + 30.0
    while (ping_pub.get_num_connections() == 0 or cloud_pub.get_num_connections() == 0) and \
            time.time() < deadline and not rospy.is_shutdown():
        time.sleep(0.05)
    if ping_pub.get_num_connections() == 0:
        raise SystemExit("the bridge never subscribed to outbox/ping")

    state_pub.publish(Header(frame_id="%s/state/0" % args.robot))
    time.sleep(max(0.0, args.start_at - time.time()))  # the team's common schedule
    points = args.cloud_bytes // 16
    for k in range(pings):
        time.sleep(max(0.0, args.start_at + k / args.ping_hz - time.time()))
        now = rospy.Time.from_sec(time.time())
        ping_pub.publish(Header(stamp=now, frame_id="%s/ping/%d" % (args.robot, k)))
        if k % args.cloud_every == 0:
            cloud = PointCloud2()
            cloud.header = Header(stamp=now,
                                  frame_id="%s/cloud/%d" % (args.robot, k // args.cloud_every))
            cloud.height, cloud.width = 1, points
            cloud.fields = [PointField(name, 4 * i, PointField.FLOAT32, 1)
                            for i, name in enumerate("xyzi")]
            cloud.point_step, cloud.row_step = 16, 16 * points
            cloud.data = os.urandom(16 * points)
            cloud.is_dense = True
            cloud_pub.publish(cloud)

    def latest_process(got):
        """What arrived from the teammate's latest process: since its numbers last started over
        (a teammate that restarted counts from 0 again)."""
        starts = [i for i in range(1, len(got)) if got[i][0] <= got[i - 1][0]]
        return got[starts[-1] if starts else 0:]

    def complete():
        with lock:
            return all(len(latest_process(received[p]["ping"])) >= pings and
                       len(latest_process(received[p]["cloud"])) >= clouds for p in peers)

    deadline = time.time() + args.settle_s
    while not complete() and time.time() < deadline and not rospy.is_shutdown():
        time.sleep(0.1)
    time.sleep(1.0)  # anything arriving twice would arrive now
    # Subscribed only now: the teammates' state reaches us only if their inbox topic is latched.
    latched = {}
    for peer in peers:
        try:
            msg = rospy.wait_for_message("inbox/%s/state" % peer, Header, timeout=10.0)
            latched[peer] = msg.frame_id
        except rospy.ROSException:
            latched[peer] = None
    with lock:
        result = {"robot": args.robot, "sent": {"ping": pings, "cloud": clouds},
                  "received": received, "latched": latched}
    with open(args.out, "w") as f:
        json.dump(result, f)


if __name__ == "__main__":
    main()
