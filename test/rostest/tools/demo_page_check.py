#!/usr/bin/env python3
"""scripts/lib/demo_page.py on demo outputs made up here: a two-robot one with every series and
a third robot no team transform reaches, and one where nothing was measured yet. The page names
every plot it drew, each plot exists, and the summary is on it, escaped."""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy as np
import rosunit
import yaml

PAGE = os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "..", "scripts", "lib",
                    "demo_page.py")
PLOTS = ["bytes_per_link.png", "known_volume.png", "team_transform_error.png", "team_map.png"]


def write_demo(out, robots, measured):
    """A demo output folder as demo_summary.py and demo_report.py leave it."""
    os.makedirs(os.path.join(out, "mission"))
    starts = {name: {"x": 10.0 * i, "y": 0.0, "z": 0.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
                     "qw": 1.0} for i, name in enumerate(robots)}
    with open(os.path.join(out, "mission", "mission.yaml"), "w") as f:
        yaml.safe_dump({"robots": [{"name": n, "initial_pose_in_world": starts[n]}
                                   for n in robots]}, f)
    entries = []
    for i, name in enumerate(robots):
        os.makedirs(os.path.join(out, name))
        peers = [p for p in robots if p != name]
        entry = {"name": name, "link_series": {}, "links": {}, "map_series": [],
                 "team_frames": [{"peer": p, "valid": False} for p in peers]}
        if measured:
            entry["link_series"] = {p: {"cumulative_bytes": [[0, 0], [30, 4e5], [60, 9e5]]}
                                    for p in peers}
            entry["links"] = {p: {"budget_bytes_per_s": 150000.0} for p in peers}
            entry["map_series"] = [[0, 0, 1e6], [30, 800, 9e5], [60, 1500, 8e5]]
            # A wall 5 m ahead of each robot's start, in its own map frame.
            np.save(os.path.join(out, name, "topdown_xy.npy"),
                    np.column_stack([np.full(50, 5.0), np.linspace(-2, 2, 50)]))
        if measured and i == 0:  # the first robot knows the second's frame, not the third's
            entry["team_frames"][0] = {
                "peer": robots[1], "valid": True, "translation": [10.1, 0.0, 0.0],
                "rotation_xyzw": [0, 0, 0, 1], "error_series": [[40, 0.3, 1.0], [60, 0.1, 0.2]]}
        entries.append(entry)
    with open(os.path.join(out, "report.json"), "w") as f:
        json.dump({"world": {"kind": "mine"}, "duration_s": 60, "seed": 7, "robots": entries}, f)
    with open(os.path.join(out, "summary.txt"), "w") as f:
        f.write("robot_a <knows> robot_b & more\n")


class DemoPage(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="demo_page_")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def page(self, robots, measured):
        write_demo(self.dir, robots, measured)
        done = subprocess.run(["/usr/bin/python3", PAGE, "--out", self.dir], capture_output=True,
                              text=True)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn(os.path.join(self.dir, "report.html"), done.stdout)
        with open(os.path.join(self.dir, "report.html")) as f:
            html = f.read()
        with open(os.path.join(self.dir, "report.md")) as f:
            markdown = f.read()
        self.assertIn("robot_a &lt;knows&gt; robot_b &amp; more", html)
        self.assertIn("robot_a <knows> robot_b & more", markdown)
        return html, markdown

    def test_every_plot_of_a_measured_mission(self):
        html, markdown = self.page(["robot_a", "robot_b", "robot_c"], measured=True)
        for plot in PLOTS:
            self.assertIn("plots/" + plot, html)
            self.assertIn("plots/" + plot, markdown)
            self.assertGreater(os.path.getsize(os.path.join(self.dir, "plots", plot)), 1000)

    def test_no_plot_before_anything_was_measured(self):
        html, _ = self.page(["robot_a", "robot_b"], measured=False)
        self.assertNotIn("<img", html)
        self.assertEqual(os.listdir(os.path.join(self.dir, "plots")), [])


if __name__ == "__main__":
    rosunit.unitrun("ccir_mapping", "demo_page", DemoPage)
