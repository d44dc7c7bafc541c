#!/usr/bin/python3
"""Runs pgo_benchmark on every pose graph in CCIR_DATA_DIR/posegraphs with injected outliers and
prints a Markdown table (and the raw JSON lines to --json-out). Slow: Sphere2500 with 1000
outliers takes about a minute per run.

  scripts/benchmarks/pgo_table.py [--quick] [--json-out FILE]
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.environ.get("CCIR_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
TOOL = os.path.join(ROOT, ".ws", "devel", "lib", "ccir_mapping", "pgo_benchmark")

# graph, ground truth (or None: against the outlier-free optimum), outliers
GRAPHS = [
    ("manhattanOlson3500.g2o", "manhattanOlson3500_gt_poses.txt", 1000),
    ("sphere2500.g2o", "sphere2500_gt_poses.txt", 1000),
    ("kitti_00.g2o", "kitti_00_gt_poses_2d.txt", 500),
    ("ring.g2o", "ring_gt_poses.txt", 100),
    ("intel.g2o", None, 500),
    ("smallGrid3D.g2o", None, 20),
    ("tinyGrid3D.g2o", None, 0),
]


def run(graph, gt, outliers, mode, robust):
    command = [TOOL, "--g2o", os.path.join(DATA, "posegraphs", graph), "--outliers", str(outliers),
               "--outlier-mode", mode, "--robust", robust, "--seed", "1"]
    if gt:
        command += ["--gt", os.path.join(DATA, "posegraphs", gt)]
    return json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="switchable, random outliers only")
    parser.add_argument("--json-out", help="append every result as a JSON line")
    args = parser.parse_args()
    print("| graph | outliers | mode | robust | ATE m | outlier-free ATE m | ratio | precision | "
          "recall | iterations | solve s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for graph, gt, outliers in GRAPHS:
        configs = [("random", "switchable")]
        if not args.quick and outliers > 0:
            configs += [("local", "switchable"), ("grouped", "switchable"), ("random", "dcs"),
                        ("random", "none")]
        if outliers == 0:
            configs = [("random", "switchable")]
        for mode, robust in configs:
            if graph.startswith("sphere") and robust == "none":
                continue  # least squares on it with 1000 outliers takes minutes and fails anyway
            r = run(graph, gt, outliers, mode, robust)
            c = r["loop_classification"]
            # Without ground truth the reference is the outlier-free optimum itself: no ratio.
            ratio = "%.2f" % r["ate_ratio"] if gt else "-"
            print("| %s | %d | %s | %s | %.3f | %.3f | %s | %.3f | %.3f | %d | %.1f |" % (
                graph, r["outliers"], mode, robust, r["ate_rmse"], r["outlier_free_ate_rmse"],
                ratio, c["precision"], c["recall"], r["iterations"], r["solve_s"]),
                flush=True)
            if args.json_out:
                with open(args.json_out, "a") as f:
                    f.write(json.dumps(r) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
