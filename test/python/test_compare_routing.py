"""The match rule of the routing comparison (ccir_mapping.compare_routing): the sparsest fixed
rate that finds every team transform CCIR finds and reaches 90 % of CCIR's known volume on every
robot is the match, `all` stands for every keyframe, and the byte ratio is CCIR's over the
match's."""
import json

from ccir_mapping.compare_routing import compare, sampled


def write_run(out, name, bytes_sent, transforms, volumes):
    """A run's report.json as the demo writes it: two robots, one link each."""
    robots = []
    for robot, peer in (("robot_a", "robot_b"), ("robot_b", "robot_a")):
        robots.append({
            "name": robot,
            "links": {peer: {"bytes_sent": bytes_sent // 2}},
            "link_series": {peer: {"cumulative_bytes": [[0, 0], [60, bytes_sent // 2]],
                                   "peak_kb_per_s": 10.0}},
            "team_frames": [{"peer": peer, "valid": (robot, peer) in transforms,
                             "error_m": 0.2, "error_deg": 1.0, "inliers": 12}],
            "map": {"known_volume_m3": volumes[robot]},
            "map_series": [],
            "ate_m": 0.3, "scans_missed": 0, "scans_dropped": 0})
    run = out / name
    run.mkdir()
    (run / "report.json").write_text(json.dumps(
        {"duration_s": 60, "playback_rate": 1.0, "robots": robots}))


BOTH = {("robot_a", "robot_b"), ("robot_b", "robot_a")}
FULL = {"robot_a": 1000.0, "robot_b": 900.0}


def test_the_sparsest_fixed_rate_with_every_transform_and_enough_volume_matches(tmp_path):
    write_run(tmp_path, "ccir", 2_000_000, BOTH, FULL)
    write_run(tmp_path, "all", 20_000_000, BOTH, FULL)
    write_run(tmp_path, "fixed_rate_2", 8_000_000, BOTH, FULL)
    write_run(tmp_path, "fixed_rate_5", 4_000_000, BOTH, {"robot_a": 950.0, "robot_b": 850.0})
    # The sparsest: one transform missing.
    write_run(tmp_path, "fixed_rate_13", 1_000_000, {("robot_a", "robot_b")}, FULL)
    result = compare(str(tmp_path))
    assert result["fixed_rate_every_n"] == [1, 2, 5, 13]
    assert result["matching_fixed_rate_every_n"] == 5
    assert result["bytes_ratio_ccir_over_fixed_rate"] == 0.5
    assert result["ccir_known_volume_over_all"] == {"robot_a": 1.0, "robot_b": 1.0}


def test_too_little_volume_is_no_match_and_all_stands_for_every_keyframe(tmp_path):
    write_run(tmp_path, "ccir", 2_000_000, BOTH, FULL)
    write_run(tmp_path, "all", 20_000_000, BOTH, FULL)
    # 89 % of robot_b's volume: below the 90 % the match needs.
    write_run(tmp_path, "fixed_rate_3", 6_000_000, BOTH, {"robot_a": 1000.0, "robot_b": 801.0})
    result = compare(str(tmp_path))
    assert result["matching_fixed_rate_every_n"] == 1
    assert result["bytes_ratio_ccir_over_fixed_rate"] == 0.1


def test_no_match_without_the_transforms_ccir_found(tmp_path):
    write_run(tmp_path, "ccir", 2_000_000, BOTH, FULL)
    write_run(tmp_path, "fixed_rate_2", 8_000_000, set(), FULL)
    result = compare(str(tmp_path))
    assert result["matching_fixed_rate_every_n"] is None
    assert result["bytes_ratio_ccir_over_fixed_rate"] is None
    assert result["ccir_known_volume_over_all"] is None


def test_series_are_sampled_every_5_s_and_keep_their_last_row():
    rows = [[t, t * 10] for t in range(0, 13)]
    assert sampled(rows) == [[0, 0], [5, 50], [10, 100], [12, 120]]
    assert sampled([]) == []
