"""ccir_mapping.demo_page on demo outputs made up here: a two-robot one with every series and
a third robot no team transform reaches, and one where nothing was measured yet. The page names
every plot it drew, each plot exists, and the summary is on it, escaped."""
import json
import os
import subprocess
import sys

import numpy as np
import yaml

PYTHON_DIR = os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "..", "python")
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


def page(out, robots, measured):
    """The page made of a made-up demo output: (html, markdown)."""
    write_demo(str(out), robots, measured)
    done = subprocess.run([sys.executable, "-m", "ccir_mapping.demo_page", "--out", str(out)],
                          capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=PYTHON_DIR))
    assert done.returncode == 0, done.stderr
    assert str(out / "report.html") in done.stdout
    html = (out / "report.html").read_text()
    markdown = (out / "report.md").read_text()
    assert "robot_a &lt;knows&gt; robot_b &amp; more" in html
    assert "robot_a <knows> robot_b & more" in markdown
    return html, markdown


def test_every_plot_of_a_measured_mission(tmp_path):
    html, markdown = page(tmp_path, ["robot_a", "robot_b", "robot_c"], measured=True)
    for plot in PLOTS:
        assert "plots/" + plot in html
        assert "plots/" + plot in markdown
        assert (tmp_path / "plots" / plot).stat().st_size > 1000


def test_no_plot_before_anything_was_measured(tmp_path):
    html, _ = page(tmp_path, ["robot_a", "robot_b"], measured=False)
    assert "<img" not in html
    assert os.listdir(tmp_path / "plots") == []
