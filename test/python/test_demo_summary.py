"""The geometry of the demo's summary (ccir_mapping.demo_summary): start poses, the error of a
team transform against the truth, whether two paths meet, each stage's CPU."""
import math

import numpy as np
import pytest

from ccir_mapping.demo_summary import matrix, paths_meet, stage_cpu, start_pose, transform_error


def plan(x, y, yaw):
    return {"initial_pose_in_world": {"x": x, "y": y, "z": 0.0, "qx": 0.0, "qy": 0.0,
                                      "qz": math.sin(yaw / 2), "qw": math.cos(yaw / 2)}}


def test_a_team_transform_is_judged_against_the_start_poses():
    plans = {"robot_a": plan(0.0, 0.0, 0.0), "robot_b": plan(10.0, 5.0, math.pi / 2)}
    # robot_b's map frame in robot_a's: 10 m ahead, 5 m left, turned a quarter.
    quarter = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]
    assert transform_error("robot_a", "robot_b", plans, [10.0, 5.0, 0.0], quarter) == \
        pytest.approx((0.0, 0.0), abs=1e-6)
    metres, degrees = transform_error("robot_a", "robot_b", plans, [10.3, 5.4, 0.0],
                                      [0.0, 0.0, 0.0, 1.0])
    assert metres == pytest.approx(0.5)
    assert degrees == pytest.approx(90.0)
    # Seen from robot_b: the inverse.
    assert transform_error("robot_b", "robot_a", plans, [-5.0, 10.0, 0.0],
                           [0.0, 0.0, -math.sin(math.pi / 4), math.cos(math.pi / 4)]) == \
        pytest.approx((0.0, 0.0), abs=1e-6)


def test_start_pose_is_the_rigid_transform_of_the_plan():
    m = start_pose(plan(1.0, 2.0, math.pi))
    assert m[:3, 3] == pytest.approx([1.0, 2.0, 0.0])
    assert np.allclose(m[:2, :2], [[-1.0, 0.0], [0.0, -1.0]])
    assert np.allclose(matrix([0, 0, 0], [0, 0, 0, 1]), np.identity(4))


def test_paths_meet_within_three_metres():
    a = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    assert paths_meet(a, np.array([[5.0, 2.9, 0.0]]))
    assert not paths_meet(a, np.array([[5.0, 3.1, 0.0]]))


def test_stage_cpu_reads_the_nodelets_diagnostics():
    nodelets = {"matcher": {"flow": {"cpu s match": "2.5", "cpu runs match": "10",
                                     "in keyframes messages": "10"}},
                "backend": {"flow": {"cpu s optimise": "0.25"}}}
    assert stage_cpu(nodelets) == {"backend optimise": 0.25, "matcher match": 2.5}
