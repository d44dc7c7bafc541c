"""Processes of a rostest that runs its own ROS masters (one per robot, as in the field):
spawned in their own process groups, logged to files, stopped in reverse order."""
import os
import random
import signal
import socket
import subprocess
import time

import rosgraph
import yaml

TEAM_KEY = "rostest-team-key"


def free_port():
    """A free TCP port below the ephemeral range: a port the kernel hands out (bind to 0) may be
    taken by one of the many outgoing connections made before the process it was chosen for
    binds it, and that process would then fail to listen."""
    with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
        ephemeral = int(f.read().split()[0])
    for _ in range(1000):
        port = random.randint(max(1024, ephemeral - 12000), ephemeral - 1)
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
                return port
            except OSError:
                continue
    raise RuntimeError("no free TCP port below %d" % ephemeral)


def descendants(pid):
    """pid and every process below it (from /proc)."""
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open("/proc/%s/stat" % entry) as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(entry))
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        found.append(p)
        todo += children.get(p, [])
    return found


class Processes:
    """Mixin for unittest.TestCase: self.dir must be set (logs go there)."""

    def env(self, master_port):
        env = dict(os.environ, ROS_IP="127.0.0.1",
                   ROS_MASTER_URI="http://127.0.0.1:%d" % master_port,
                   PYTHONUNBUFFERED="1",  # rostopic echo rows reach the file at once
                   ROS_LOG_DIR=os.path.join(self.dir, "log"))
        env.pop("ROS_HOSTNAME", None)
        return env

    def spawn(self, name, command, master_port, out=None):
        log = open(out or os.path.join(self.dir, name + ".log"), "w")
        process = subprocess.Popen(command, env=self.env(master_port), stdout=log,
                                   stderr=subprocess.STDOUT, start_new_session=True)
        self.processes.append(process)
        return process

    def stop_all(self):
        for process in reversed(self.processes):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGINT)
        for process in reversed(self.processes):
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
        self.processes = []

    def start_team(self, run, robots, overrides, launch_args=lambda robot: []):
        """Each robot on a rosmaster of its own and its pipeline (launch/robot.launch, simulated
        time), the robots bridged over loopback. overrides(robot, bridge) returns the YAML that
        robot's pipeline loads over config/robot.yaml; bridge is the flow-style body of its
        bridge's settings (listen port, team key, peers). Returns {robot: master port}."""
        master = {r: free_port() for r in robots}
        listen = {r: free_port() for r in robots}
        for robot, port in master.items():
            self.spawn("master_" + robot, ["rosmaster", "--core", "-p", str(port)], port)
        for robot, port in master.items():
            online = rosgraph.Master("/rostest", "http://127.0.0.1:%d" % port).is_online
            self.wait_for(online, 30, "the master of " + robot)
        for robot in robots:
            peers = ", ".join("{name: %s, host: 127.0.0.1, port: %d}" % (p, listen[p])
                              for p in robots if p != robot)
            bridge = ("listen_port: %d, team_key: %s, reconnect_min_s: 0.2, peers: [%s]"
                      % (listen[robot], TEAM_KEY, peers))
            config = os.path.join(run, robot + ".yaml")
            with open(config, "w") as f:
                f.write(overrides(robot, bridge))
            self.start_pipeline(robot, config, master[robot], launch_args(robot))
        return master

    def start_pipeline(self, robot, config, master_port, launch_args, log_suffix=""):
        """One robot's pipeline (launch/robot.launch in simulated time) with the overrides in
        `config`, on the master at master_port."""
        return self.spawn("pipeline_" + robot + log_suffix,
                          ["roslaunch", "ccir_mapping", "robot.launch", "robot:=" + robot,
                           "use_sim_time:=true", "overrides:=" + config] + launch_args,
                          master_port)

    def latest(self, topic, port):
        """The next message on a topic of one master, as a dict (None if none within 30 s)."""
        try:
            result = subprocess.run(["rostopic", "echo", "-n", "1", topic], env=self.env(port),
                                    capture_output=True, text=True, timeout=30)
        except subprocess.TimeoutExpired:  # a busy machine; the caller asks again
            return None
        text = result.stdout.split("\n---")[0]
        try:
            return yaml.safe_load(text) if text.strip() else None
        except yaml.YAMLError:
            return None

    def wait_for(self, condition, timeout_s, what, poll_s=0.2):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if condition():
                return
            time.sleep(poll_s)
        self.fail("%s within %.0f s" % (what, timeout_s))
