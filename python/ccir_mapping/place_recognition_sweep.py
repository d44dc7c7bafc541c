"""Place recognition on simulated two-robot mine missions, one per seed (simulate_team), judged by
eval_place_recognition against the truth: a Markdown table per seed and method (the layout of
docs/place_recognition.md, plus recall@1/@5 and average precision) and the precision-recall
curves as a PNG. Flags it does not know go to eval_place_recognition (e.g.
--min-place-probability 0.1). A mission or an evaluation already in OUT is not run again."""
import argparse
import json
import os
import subprocess
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# The methods and their colours.
METHODS = {"fabmap": "C0", "histogram": "C1", "scan_context": "C2", "hgmm": "C3"}
# docs/place_recognition.md's missions: 120 s, robots on each other's lanes, a 3 x 3-pillar mine.
MISSION_FLAGS = ["--world", "mine", "--mine-pillars-x", "3", "--mine-pillars-y", "3",
                 "--robots", "2", "--duration-s", "120", "--overlap", "1"]


def run(command, log):
    with open(log, "w") as out:
        if subprocess.run(command, stdout=out, stderr=subprocess.STDOUT).returncode != 0:
            sys.exit("failed: %s (see %s)" % (" ".join(command), log))


def evaluate(args, eval_flags, seed):
    mission = os.path.join(args.out, "missions", "seed_%d" % seed)
    if not os.path.exists(os.path.join(mission, "mission.yaml")):
        os.makedirs(mission, exist_ok=True)
        run([os.path.join(args.bin_dir, "simulate_team"), "--out", mission, "--seed", str(seed)]
            + MISSION_FLAGS, os.path.join(mission, "simulate_team.log"))
    result = os.path.join(args.out, "eval", "seed_%d.json" % seed)
    if not os.path.exists(result):
        os.makedirs(os.path.dirname(result), exist_ok=True)
        with open(result + ".tmp", "w") as out:
            done = subprocess.run([os.path.join(args.bin_dir, "eval_place_recognition"),
                                   "--mission", mission, "--model", args.model] + eval_flags,
                                  stdout=out, stderr=subprocess.DEVNULL)
        if done.returncode != 0:
            sys.exit("eval_place_recognition failed on seed %d" % seed)
        os.replace(result + ".tmp", result)
    print("[place_recognition] seed %d done" % seed, file=sys.stderr)
    return json.load(open(result))


def evaluated(results):
    """The methods every result has (eval_place_recognition's --methods may pick a few)."""
    return [m for m in METHODS if all(m in r["methods"] for _, r in results)]


def table(results):
    methods = evaluated(results)
    lines = ["| seed | overlapping | best-ranked TP/FP | verified TP/FP (precision, recall) "
             "| after the team-frame EM | recall@1 | recall@5 | AP best-ranked | AP verified |",
             "|---|---|---|---|---|---|---|---|---|"]
    for seed, r in results:
        cells = {k: [] for k in ["best", "verified", "em", "r1", "r5", "ap_b", "ap_v"]}
        for m in methods:
            x = r["methods"][m]
            v = x["verified"]
            cells["best"].append("%d/%d" % (x["best_ranked_tp"], x["best_ranked_fp"]))
            cells["verified"].append("%d/%d (%.2f, %.2f)" % (v["tp"], v["fp"], v["precision"],
                                                             v["recall"]))
            e = x["team_frame"]
            cells["em"].append(
                "%d/%d (%.2f, %.2f)" % (e["tp"], e["fp"], e["precision"], e["recall"])
                if e["tp"] + e["fp"] else "none")
            cells["r1"].append("%.2f" % x["recall_at_1"])
            cells["r5"].append("%.2f" % x["recall_at_5"])
            cells["ap_b"].append("%.2f" % x["pr_best_ranked"]["average_precision"])
            cells["ap_v"].append("%.2f" % x["pr_verified"]["average_precision"])
        lines.append("| %d | %d | " % (seed, r["overlapping_queries"]) +
                     " | ".join(" · ".join(c) for c in cells.values()) + " |")
    return "\n".join(lines) + "\n\nEach cell: %s.\n" % " · ".join(methods)


def plot(results, path):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for seed, r in results:
        for m in evaluated(results):
            color = METHODS[m]
            for ax, key in zip(axes, ["pr_best_ranked", "pr_verified"]):
                points = r["methods"][m][key]["recall_precision"]
                ax.plot([p[0] for p in points], [p[1] for p in points], color=color, alpha=0.6,
                        label=m if seed == results[0][0] else None)
    for ax, title in zip(axes, ["best-ranked place, over its score",
                                "verified closure, over its score"]):
        ax.set_title(title)
        ax.set_xlabel("recall (of truly overlapping queries)")
        ax.set_ylabel("precision")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1.02)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("out")
    parser.add_argument("--bin-dir", required=True)
    parser.add_argument("--model", required=True)
    parser.add_argument("--seeds", default="61,62,63,64,65,66,67,68")
    args, eval_flags = parser.parse_known_args()
    args.out = os.path.abspath(args.out)
    results = [(int(s), evaluate(args, eval_flags, int(s))) for s in args.seeds.split(",")]
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write("eval_place_recognition %s\n\n" % " ".join(eval_flags) + table(results))
    plot(results, os.path.join(args.out, "pr_curves.png"))
    print(open(os.path.join(args.out, "results.md")).read())


if __name__ == "__main__":
    main()
