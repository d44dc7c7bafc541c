"""Combines the demo's simulated mission (mission.yaml) and each robot's pipeline report into
<out>/report.json and <out>/summary.txt; prints the summary. Exits 1 when a robot made no
keyframe."""
import argparse
import json
import math
import os
import sys

import numpy as np
import yaml

from .clouds import quaternion_matrix


def matrix(translation, xyzw):
    """4 x 4 rigid transform from a translation and a unit quaternion (x, y, z, w)."""
    m = np.identity(4)
    m[:3, :3] = quaternion_matrix(xyzw)
    m[:3, 3] = translation
    return m


def start_pose(plan):
    """Where a robot's odom (and map) frame sits in the world."""
    p = plan["initial_pose_in_world"]
    return matrix([p["x"], p["y"], p["z"]], [p["qx"], p["qy"], p["qz"], p["qw"]])


# A team transform this close to the truth counts as correct (the target).
CORRECT_M, CORRECT_DEG = 0.3, 2.0


def transform_error(robot, peer, plans, translation, xyzw):
    """(metres, degrees) between an estimate of the peer's map frame and the truth."""
    truth = np.linalg.inv(start_pose(plans[robot])) @ start_pose(plans[peer])
    error = np.linalg.inv(truth) @ matrix(translation, xyzw)
    cos = max(-1.0, min(1.0, (np.trace(error[:3, :3]) - 1) / 2))
    return float(np.linalg.norm(error[:3, 3])), math.degrees(math.acos(cos))


def team_frames(robot, report, plans, start_s):
    """What a robot knows of each teammate's map frame: the Backend's last TeamTransform, for a
    valid one its error against the truth (metres, degrees), and from the time series the
    mission seconds to the first valid transform (with its error) and to the first within
    CORRECT_M / CORRECT_DEG, and the error of every valid one over mission time."""
    known = []
    series = report.get("series", {}).get("team_transforms", {})
    for peer, t in report.get("team_transforms", {}).items():
        entry = {"peer": peer, "valid": t["valid"], "inliers": t["inliers"],
                 "candidates": t["candidates"]}
        if peer not in plans:
            known.append(entry)
            continue
        if t["valid"]:
            entry["translation"], entry["rotation_xyzw"] = t["translation"], t["rotation_xyzw"]
            entry["error_m"], entry["error_deg"] = transform_error(
                robot, peer, plans, t["translation"], t["rotation_xyzw"])
        entry["error_series"] = []
        for stamp, valid, _, translation, xyzw in series.get(peer, []):
            if not valid:
                continue
            error_m, error_deg = transform_error(robot, peer, plans, translation, xyzw)
            entry["error_series"].append(
                [round(stamp - start_s, 2), round(error_m, 3), round(error_deg, 2)])
            if "first_valid_s" not in entry:
                entry["first_valid_s"] = round(stamp - start_s, 2)
                entry["first_valid_error"] = [round(error_m, 3), round(error_deg, 2)]
            if (error_m <= CORRECT_M and error_deg <= CORRECT_DEG
                    and "first_correct_s" not in entry):
                entry["first_correct_s"] = round(stamp - start_s, 2)
        known.append(entry)
    return known


def truth_at(truth, stamps):
    """Rows of the ground truth nearest to each stamp."""
    return truth[np.clip(np.searchsorted(truth[:, 0], stamps), 0, len(truth) - 1)]


def ate_m(out, name, report):
    """Absolute trajectory error (RMS planar distance to the truth, m, no alignment: the map
    frame is the odometry frame, which starts at the true start pose) of the Backend's optimised
    keyframe poses, and of the same keyframes' odometry poses."""
    truth = np.loadtxt("%s/mission/%s_gt.txt" % (out, name))
    result = {}
    for kind, rows in (("optimised", report.get("trajectory", [])),
                       ("odometry", [[k["stamp"], k["x"], k["y"]]
                                     for k in report.get("keyframe_list", [])])):
        if rows:
            rows = np.array([r[:3] for r in rows])
            d = rows[:, 1:3] - truth_at(truth, rows[:, 0])[:, 1:3]
            result[kind] = round(float(np.sqrt(np.mean(np.sum(d * d, axis=1)))), 3)
    return result


def link_series(report, start_s):
    """Cumulative bytes sent on each link over mission time, and the peak rate between two
    reports at least 0.9 s apart (KB/s)."""
    result = {}
    for peer, rows in report.get("series", {}).get("links", {}).items():
        rows = [r for r in rows if r[0] > 0]  # reports before mission time began
        peak, last = 0.0, None
        for stamp, sent, _ in rows:
            if last is not None and stamp - last[0] >= 0.9:
                peak = max(peak, (sent - last[1]) / 1e3 / (stamp - last[0]))
                last = (stamp, sent)
            elif last is None:
                last = (stamp, sent)
        result[peer] = {"peak_kb_per_s": round(peak, 1),
                        "cumulative_bytes": [[round(t - start_s, 2), sent] for t, sent, _ in rows]}
    return result


def odometry_drift_m(out, name, keyframes):
    """How far the robot's odometry had drifted from the truth at its last keyframe (m, in the
    plane): a transform found from loop closures inherits both robots' drift where they closed."""
    if not keyframes:
        return None
    truth = np.loadtxt("%s/mission/%s_gt.txt" % (out, name))
    last = keyframes[-1]
    row = truth[np.argmin(np.abs(truth[:, 0] - last["stamp"]))]
    return float(np.hypot(last["x"] - row[1], last["y"] - row[2]))


def world_path(out, plan):
    """The robot's true positions in the world (every 10th ground-truth pose)."""
    truth = np.loadtxt("%s/mission/%s_gt.txt" % (out, plan["name"]))[::10, 1:4]
    start = start_pose(plan)
    return truth @ start[:3, :3].T + start[:3, 3]


def paths_meet(a, b, within_m=3.0):
    """Whether two paths come within `within_m` of each other (the loop-closure truth radius)."""
    return any(np.min(np.linalg.norm(b - p, axis=1)) <= within_m for p in a)


def stage_cpu(nodelets):
    """CPU seconds of each nodelet's stages, from the "cpu s <stage>" diagnostics."""
    return {"%s %s" % (name, key[len("cpu s "):]): float(value)
            for name, info in sorted(nodelets.items())
            for key, value in info["flow"].items() if key.startswith("cpu s ")}


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True, help="demo output folder")
    args = parser.parse_args()
    mission = yaml.safe_load(open(args.out + "/mission/mission.yaml"))
    robots = []
    plans = {plan["name"]: plan for plan in mission["robots"]}
    config = os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../config/robot.yaml")
    needed = yaml.safe_load(open(config))["backend"]["min_team_inliers"]
    for plan in mission["robots"]:
        report = json.load(open("%s/%s/report.json" % (args.out, plan["name"])))
        flow = report["nodelets"].get("preprocessor", {}).get("flow", {})
        matcher = report["nodelets"].get("matcher", {}).get("flow", {})
        robots.append({
            "name": plan["name"], "kind": plan["kind"], "distance_m": plan["distance_m"],
            "shared_fraction": plan["shared_fraction"],
            "initial_pose_in_world": plan["initial_pose_in_world"],
            "scans_recorded": plan["scans"],
            "scans_in": flow.get("in velodyne_points messages", 0),
            "scans_dropped": flow.get("dropped scans messages", 0),
            "keyframes": report["keyframes"], "keyframe_spacing_m": report["keyframe_spacing_m"],
            "features_to_outbox": report["features_to_outbox"],
            "word_sets": matcher.get("out features messages", 0),
            "own_loop_closures": matcher.get("out loop_closures (own) messages", 0),
            "broker": report.get("broker") or {}, "map": report.get("map"),
            "team_loop_closures": matcher.get("out loop_closures (teammates) messages", 0),
            "inbox_scans": report.get("inbox_scans", 0),
            "inbox_features": report.get("inbox_features", 0),
            "links": report.get("links", {}),
            "team_frames": team_frames(plan["name"], report, plans, mission["start_time_s"]),
            "ate_m": ate_m(args.out, plan["name"], report),
            "link_series": link_series(report, mission["start_time_s"]),
            "map_series": [[round(t - mission["start_time_s"], 2), volume, entropy]
                           for t, volume, entropy in report.get("series", {}).get("map", [])],
            "odometry_drift_m": odometry_drift_m(args.out, plan["name"],
                                                 report.get("keyframe_list", [])),
            "scans_missed": flow.get("missed scans (gaps in stamps)", 0),
            "manager_cpu_s": report.get("manager_cpu_s"),
            "stage_cpu_s": stage_cpu(report["nodelets"]),
            "latency_mission_s": report.get("latency_mission_s"),
            "pipeline": report["nodelets"]})
    world = mission["world"]
    duration_s = mission["end_time_s"] - mission["start_time_s"]
    rate_file = args.out + "/playback_rate"
    rate = float(open(rate_file).read()) if os.path.exists(rate_file) else 1.0
    result = {"world": world, "duration_s": duration_s, "playback_rate": rate,
              "seed": mission["parameters"]["seed"], "robots": robots}
    json.dump(result, open(args.out + "/report.json", "w"), indent=2)
    # The CPU budget's figures (scripts/bench_pipeline prints them).
    cpu = {"benchmark": "pipeline_cpu", "mission_s": duration_s, "playback_rate": rate,
           "robots": {r["name"]: {
               "keyframes": r["keyframes"],
               "manager_core_share": None if r["manager_cpu_s"] is None
               else round(r["manager_cpu_s"] / duration_s, 3),
               "stage_cpu_ms_per_keyframe": {stage: round(1e3 * v / max(1, r["keyframes"]), 1)
                                             for stage, v in r["stage_cpu_s"].items()},
               "scans_lost": r["scans_missed"] + r["scans_dropped"],
               "latency_mission_s": r["latency_mission_s"]} for r in robots},
           "target_core_share": 0.33}
    json.dump(cpu, open(args.out + "/cpu.json", "w"), indent=2)

    lines = ["%s %.0f x %.0f m, %d robots, %.0f s, seed %d" % (
        world["kind"], world["size_x_m"], world["size_y_m"], len(robots), result["duration_s"],
        result["seed"])]
    lines.append("  %-9s %7s %6s %6s %9s %12s %6s %6s %9s %7s %8s %9s" % (
        "robot", "path m", "shared", "scans", "keyframes", "spacing m", "word", "own", "features",
        "scans", "map", "entropy"))
    lines.append("  %-9s %7s %6s %6s %9s %12s %6s %6s %9s %7s %8s %9s" % (
        "", "", "", "in", "", "mean", "sets", "loops", "outbox", "sent", "known m3",
        "drop Mbit"))
    for r in robots:
        m = r["map"] or {}
        lines.append("  %-9s %7.1f %5.0f%% %6d %9d %12.2f %6d %6d %9d %7d %8.0f %9s" % (
            r["name"], r["distance_m"], 100 * r["shared_fraction"], r["scans_in"], r["keyframes"],
            r["keyframe_spacing_m"]["mean"], r["word_sets"], r["own_loop_closures"],
            r["features_to_outbox"], r["broker"].get("scans_sent", 0), m.get("known_volume_m3", 0),
            "-" if not m else "%.2f" % (m["entropy_drop_bits"] / 1e6)))
    budgets = {link.get("budget_bytes_per_s") for r in robots for link in r["links"].values()}
    lines.append("  bridges (budget %s KB/s per robot):" % "/".join(
        "%.0f" % (b / 1e3) for b in sorted(b for b in budgets if b) or [150000]))
    drift = {r["name"]: r["odometry_drift_m"] for r in robots}
    path = {name: world_path(args.out, plan) for name, plan in plans.items()}
    lines.append("  %-9s %-9s %9s %9s %9s %9s %7s %6s" % (
        "robot", "peer", "connected", "sent KB", "recv KB", "messages", "queued", "drops"))
    for r in robots:
        for peer, link in r["links"].items():
            lines.append("  %-9s %-9s %9s %9.0f %9.0f %9d %7d %6d" % (
                r["name"], peer, "yes" if link["connected"] else "no",
                link["bytes_sent"] / 1e3, link["bytes_received"] / 1e3,
                link["messages_received"], link["queued"],
                sum(n for reason, n in link["drops"].items() if reason != "duplicate")))
        lines.append("  %-9s received %d word sets and %d scans from teammates; %d inter-robot "
                     "loop closures" % (r["name"], r["inbox_features"], r["inbox_scans"],
                                        r["team_loop_closures"]))
        for peer, p in sorted(r["broker"].get("peers", {}).items()):
            if not peer:
                continue
            refused = ", ".join("%s %d" % kv for kv in sorted(p["refused"].items()))
            lines.append("  %-9s %s: offered %d scans in %d offers, %d requested, sent %d "
                         "(%.0f KB); was offered %d, requested %d, received %d (%.0f KB)%s" % (
                             r["name"], peer, p["scans_offered"], p["offers_sent"],
                             p["scans_requested_by_peer"], p["scans_sent"],
                             p["scan_bytes_sent"] / 1e3, p["scans_in_offers_received"],
                             p["scans_requested"], p["scans_received"],
                             p["scan_bytes_received"] / 1e3,
                             "; refused: " + refused if refused else ""))
        for t in r["team_frames"]:
            if "error_m" in t:
                lines.append("  %-9s knows %s's map frame (since %s s) from %d of %d loop "
                             "closures: %.2f m, %.1f deg from the truth (odometry drift at the "
                             "end: %s)" % (
                                 r["name"], t["peer"], t.get("first_valid_s", "?"), t["inliers"],
                                 t["candidates"], t["error_m"], t["error_deg"], ", ".join(
                                     "%s %.2f m" % (n, drift[n]) for n in (r["name"], t["peer"])
                                     if drift.get(n) is not None)))
            else:
                lines.append("  %-9s does not know %s's map frame yet: %d inter-robot loop "
                             "closures, %d agreeing ones needed%s" % (
                                 r["name"], t["peer"], t["candidates"], needed,
                                 "" if t["peer"] not in path or
                                 paths_meet(path[r["name"]], path[t["peer"]])
                                 else " (their paths never come within 3 m)"))
    lines.append("  trajectory error (RMS in the plane against the truth), optimised / odometry: " +
                 ", ".join("%s %s / %s m" % (r["name"], r["ate_m"].get("optimised", "-"),
                                             r["ate_m"].get("odometry", "-")) for r in robots))
    lines.append("  CPU (nodelet manager, per mission second: the share of a core at real time; "
                 "replayed at %.1f x):" % rate)
    for r in robots:
        if r["manager_cpu_s"] is None:
            continue
        stages = ", ".join("%s %.0f" % (stage, 1e3 * s / max(1, r["keyframes"]))
                           for stage, s in r["stage_cpu_s"].items()
                           if s >= 0.05 * r["keyframes"] / 1e3)
        lat = r["latency_mission_s"] or {}
        lines.append("  %-9s %.2f core; ms per keyframe: %s" % (
            r["name"], r["manager_cpu_s"] / duration_s, stages))
        lines.append("  %-9s lost scans: %d missed, %d dropped; latency (mission s) word set p50 "
                     "%s p99 %s, loop closure p50 %s p99 %s" % (
                         r["name"], r["scans_missed"], r["scans_dropped"],
                         *("%.2f" % v if v is not None else "-"
                           for v in (lat.get("word_sets", {}).get("p50"),
                                     lat.get("word_sets", {}).get("p99"),
                                     lat.get("loop_closures", {}).get("p50"),
                                     lat.get("loop_closures", {}).get("p99")))))
    total_scans = sum(r["scans_in"] for r in robots)
    total_keyframes = sum(r["keyframes"] for r in robots)
    with open(args.out + "/summary.txt", "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    if any(r["keyframes"] == 0 for r in robots):
        print("[demo] FAILED: a robot made no keyframe; see its pipeline.log", file=sys.stderr)
        return 1
    print("demo done: %d robots in a simulated mine turned %d scans into %d keyframes; report in "
          "%s/report.json" % (len(robots), total_scans, total_keyframes, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
