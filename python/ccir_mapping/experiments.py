"""The experiments of docs/results.md, run with run_team (the team in simulated time) and
summarised as tables (Markdown) and plots (PNG, matplotlib). One subcommand per experiment; each
writes its runs under OUT/<config>/<run>/report.json (a run already there is not run again) and
its summary as OUT/results.md and OUT/*.png."""
import argparse
import glob
import json
import math
import os
import shutil
import subprocess
import sys
import time

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .compare_routing import compare  # noqa: E402

# Each world's mission: robots take lanes their teammates drove (overlap 1) so that they meet;
# the mine as the demo's (3 x 3 pillars).
WORLD_FLAGS = {
    "mine": ["--world", "mine", "--mine-pillars-x", "3", "--mine-pillars-y", "3"],
    "building": ["--world", "building"],
    "cave": ["--world", "cave"],
    "cluttered": ["--world", "cluttered"],
}
UNTHROTTLED = 1e8  # bytes/s: fixed rates and `all` are measured, not held (Table 3.1)


def snapshot(args):
    """Copies run_team and the package's libraries to OUT/bin (once), so that a rebuild while the
    experiment runs changes nothing in it; records the commit they were built from."""
    bin_dir = os.path.join(args.out, "bin")
    if not os.path.exists(os.path.join(bin_dir, "run_team")):
        os.makedirs(bin_dir, exist_ok=True)
        lib_dir = os.path.dirname(os.path.dirname(os.path.realpath(args.run_team)))
        for lib in glob.glob(os.path.join(lib_dir, "libccir_mapping_*.so")):
            shutil.copy2(lib, bin_dir)
        shutil.copy2(args.run_team, bin_dir)
        commit = subprocess.run(["git", "-C", os.path.dirname(os.path.realpath(__file__)),
                                 "describe", "--always", "--dirty"], capture_output=True,
                                text=True).stdout.strip()
        json.dump({"commit": commit}, open(os.path.join(bin_dir, "provenance.json"), "w"))
    args.run_team = os.path.join(bin_dir, "run_team")
    args.env = dict(os.environ, LD_LIBRARY_PATH=bin_dir)  # before the RUNPATH of the build


def run_team(args, run_dir, flags):
    """Runs run_team into run_dir unless its report is there; returns the report."""
    report = os.path.join(run_dir, "report.json")
    if not os.path.exists(report):
        os.makedirs(run_dir, exist_ok=True)
        started = time.monotonic()
        config = ["--config", args.config] if args.config else []
        with open(os.path.join(run_dir, "run_team.log"), "w") as log:
            done = subprocess.run([args.run_team, "--out", run_dir, "--threads", str(args.threads)]
                                  + config + flags, stdout=subprocess.DEVNULL, stderr=log,
                                  env=args.env)
        if done.returncode != 0:
            sys.exit("run_team failed: see %s/run_team.log" % run_dir)
        print("[experiments] %s: %.0f s"
              % (os.path.relpath(run_dir, args.out), time.monotonic() - started), file=sys.stderr)
    return json.load(open(report))


def mean_rate_per_robot(report):
    sent = sum(link["bytes_sent"] for r in report["robots"] for link in r["links"].values())
    return sent / report["duration_s"] / len(report["robots"])


def worst_window(report, window_s=1.0):
    """The most bytes any link carried in a window of window_s (from the series)."""
    worst = 0
    for r in report["robots"]:
        for series in r["link_series"].values():
            rows = series["cumulative_bytes"]
            for i, (t0, b0) in enumerate(rows):
                for t1, b1 in rows[i + 1:]:
                    if t1 - t0 > window_s + 1e-6:
                        break
                    worst = max(worst, b1 - b0)
    return worst


def ccir_vs_fixed_rate(args):
    configs = []
    for world in args.worlds.split(","):
        for robots in [int(n) for n in args.robots.split(",")]:
            for seed in [int(s) for s in args.seeds.split(",")]:
                name = "%s-%dr-s%d" % (world, robots, seed)
                base = WORLD_FLAGS[world] + ["--robots", str(robots), "--seed", str(seed),
                                             "--duration-s", str(args.duration_s), "--overlap", "1"]
                out = os.path.join(args.out, name)
                budget = ["--budget-bytes-per-s", str(args.budget_bytes_per_s)]
                free = ["--budget-bytes-per-s", str(UNTHROTTLED)]
                run_team(args, os.path.join(out, "ccir"), base + ["--mode", "ccir"] + budget)
                every = run_team(args, os.path.join(out, "all"), base + ["--mode", "all"] + free)
                for n in sorted((int(n) for n in args.every_n.split(",")), reverse=True):
                    run_team(args, os.path.join(out, "fixed_rate_%d" % n),
                             base + ["--mode", "fixed_rate", "--every-n", str(n)] + free)
                    result = compare(out)
                    if result["matching_fixed_rate_every_n"] == n:
                        break  # the sparsest that matches: denser ones send more
                # The densest fixed rate whose average fits the budget, held to it.
                naive = max(1, math.ceil(mean_rate_per_robot(every) / args.budget_bytes_per_s))
                run_team(args, os.path.join(out, "naive_%d" % naive),
                         base + (["--mode", "all"] if naive == 1 else
                                 ["--mode", "fixed_rate", "--every-n", str(naive)]) + budget)
                configs.append(name)
    summarize(args.out, configs, args.budget_bytes_per_s)


def load(path):
    return json.load(open(os.path.join(path, "report.json")))


def summarize(out, configs, budget):
    rows, ratios, by_world, naive_shares = [], [], {}, []
    for name in configs:
        result = compare(os.path.join(out, name))
        json.dump(result, open(os.path.join(out, name, "ccir_vs_fixed_rate.json"), "w"), indent=2)
        runs = result["runs"]
        ccir, n = runs["ccir"], result["matching_fixed_rate_every_n"]
        match = None if n is None else runs["all" if n == 1 and "fixed_rate_1" not in runs
                                            else "fixed_rate_%d" % n]
        naive_dir = next(d for d in os.listdir(os.path.join(out, name)) if d.startswith("naive_"))
        naive = load(os.path.join(out, name, naive_dir))
        naive_share = min(
            (r["map"]["known_volume_m3"] / max(1e-9, ccir["known_volume_m3"][r["name"]])
             for r in naive["robots"]), default=0.0)
        naive_shares.append((name, naive_share, naive_dir.split("_")[1]))
        ccir_report = load(os.path.join(out, name, "ccir"))
        ratio = result["bytes_ratio_ccir_over_fixed_rate"]
        if ratio is not None:
            ratios.append(ratio)
            by_world.setdefault(name.split("-")[0], []).append(ratio)
        rows.append("| %s | %.2f | %.1f / %.1f | %d | %s | %s | %s | %s | %.2f | %s | %.1f |" % (
            name, ccir["bytes_sent"] / 1e6, ccir["mean_kb_per_s_per_robot"],
            ccir["peak_kb_per_s_per_link"] or 0, ccir["transforms_found"],
            "n = %d" % n if n else "none",
            "%.2f" % (match["bytes_sent"] / 1e6) if match else "-",
            "%.1f / %.1f" % (match["mean_kb_per_s_per_robot"], match["peak_kb_per_s_per_link"] or 0)
            if match else "-",
            "%.2f" % ratio if ratio is not None else "-", naive_share,
            naive_dir.split("_")[1], worst_window(ccir_report) / 1e3))
        plot_config(out, name, result)
    lines = [
        "| mission | CCIR MB | CCIR KB/s per robot mean / peak per link | transforms | match |"
        " match MB | match KB/s mean / peak | CCIR / match | naive volume share | naive n |"
        " CCIR worst 1 s on a link, KB |",
        "|---|---|---|---|---|---|---|---|---|---|---|"] + rows
    summary = {"ratio_mean": round(sum(ratios) / len(ratios), 3) if ratios else None,
               "ratio_by_world": {w: round(sum(v) / len(v), 3) for w, v in by_world.items()},
               "configs": len(configs), "configs_with_a_match": len(ratios)}
    plot_naive(out, naive_shares)
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write("\n".join(lines) + "\n\n```\n" + json.dumps(summary, indent=2) + "\n```\n")
    print("\n".join(lines))
    print(json.dumps(summary, indent=2))


def plot_config(out, name, result):
    """Known volume and entropy over time, cumulative bytes per link, team-transform error."""
    runs = {"CCIR": "ccir", "all": "all"}
    n = result["matching_fixed_rate_every_n"]
    if n and n > 1:
        runs["fixed rate 1/%d (match)" % n] = "fixed_rate_%d" % n
    reports = {label: load(os.path.join(out, name, d)) for label, d in runs.items()}
    fig, axes = plt.subplots(1, 4, figsize=(20, 4))
    for label, report in reports.items():
        for r in report["robots"]:
            t = [row[0] for row in r["map_series"]]
            axes[0].plot(t, [row[1] for row in r["map_series"]], label="%s %s" % (label, r["name"]))
            axes[1].plot(t, [row[2] / 1e6 for row in r["map_series"]])
        if label != "all":
            for r in report["robots"]:
                for peer, s in sorted(r["link_series"].items()):
                    rows = s["cumulative_bytes"]
                    axes[2].plot([x[0] for x in rows], [x[1] / 1e6 for x in rows],
                                 linestyle="-" if label == "CCIR" else ":")
    for r in reports["CCIR"]["robots"]:
        for t in r["team_frames"]:
            rows = t.get("error_series", [])
            axes[3].plot([x[0] for x in rows], [x[1] for x in rows],
                         label="%s → %s" % (r["name"], t["peer"]))
    for ax, title, unit in zip(axes, ["known volume", "entropy", "bytes per link (CCIR —, match ⋯)",
                                      "CCIR team-transform error"], ["m³", "Mbit", "MB", "m"]):
        ax.set_title(title)
        ax.set_xlabel("mission s")
        ax.set_ylabel(unit)
    axes[0].legend(fontsize=6)
    axes[3].legend(fontsize=6)
    fig.suptitle(name)
    fig.tight_layout()
    fig.savefig(os.path.join(out, name + ".png"), dpi=80)
    plt.close(fig)


def plot_naive(out, shares):
    """Fig. 3.3: the naive fixed rate's known volume (worst robot) as a share of CCIR's."""
    fig, ax = plt.subplots(figsize=(max(4, 0.6 * len(shares)), 3.5))
    ax.bar(range(len(shares)), [s for _, s, _ in shares])
    ax.set_xticks(range(len(shares)))
    ax.set_xticklabels(["%s\n(1/%s)" % (name, n) for name, _, n in shares], fontsize=7,
                       rotation=30)
    ax.axhline(1.0, color="k", linewidth=0.5)
    ax.set_ylabel("volume / CCIR's (worst robot)")
    ax.set_title("naive fixed rate within the budget")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "naive_fixed_rate.png"), dpi=80)
    plt.close(fig)


def scale(args):
    """Team sizes with radio-range links: growth per robot of bytes, messages, CPU and memory."""
    rows, points = [], []
    for robots in [int(n) for n in args.robots.split(",")]:
        name = "mine-%dr-radio" % robots
        report = run_team(args, os.path.join(args.out, name), WORLD_FLAGS["mine"][:2] + [
            "--mine-pillars-x", str(args.pillars), "--mine-pillars-y", str(args.pillars),
            "--robots", str(robots), "--seed", args.seeds.split(",")[0],
            "--duration-s", str(args.duration_s), "--overlap", "1",
            "--start-interval-s", str(args.start_window_s / robots),
            "--topology", "radio_range", "--radio-range-m", str(args.radio_range_m),
            "--max-peers", str(args.max_peers), "--line-of-sight",
            "--budget-bytes-per-s", str(args.budget_bytes_per_s), "--mode", "ccir"])
        d, n = report["duration_s"], len(report["robots"])
        links = [link for r in report["robots"] for link in r["links"].values()]
        sent = sum(link["bytes_sent"] for link in links)
        messages = sum(link["messages_sent"] for link in links)
        cpu = sum(r["cpu_s"]["pipeline"] + r["cpu_s"]["recording_and_preprocessing"]
                  for r in report["robots"])
        peers = sum(report.get("link_up_s", {}).values()) / d / n
        transforms = sum(1 for r in report["robots"] for t in r["team_frames"] if t["valid"])
        point = {"robots": n, "kb_per_s_per_robot": sent / 1e3 / d / n,
                 "messages_per_s_per_robot": messages / d / n,
                 "cpu_core_share_per_robot": cpu / d / n,
                 "resident_mb_per_robot": report["peak_resident_mb"] / n,
                 "linked_peers_per_robot": peers, "transforms_per_robot": transforms / n,
                 "worst_1s_on_a_link_kb": worst_window(report) / 1e3,
                 "robot_s_per_cpu_s": report["robot_s_per_cpu_s"], "wall_s": report["wall_s"]}
        points.append(point)
        rows.append("| %d | %.1f | %.1f | %.2f | %.0f | %.1f | %.1f | %.0f |" % (
            n, point["kb_per_s_per_robot"], point["messages_per_s_per_robot"],
            point["cpu_core_share_per_robot"], point["resident_mb_per_robot"],
            point["linked_peers_per_robot"], point["transforms_per_robot"],
            point["worst_1s_on_a_link_kb"]))
    fig, axes = plt.subplots(1, 4, figsize=(16, 3.5))
    for ax, key, title in zip(axes, ["kb_per_s_per_robot", "messages_per_s_per_robot",
                                     "cpu_core_share_per_robot", "resident_mb_per_robot"],
                              ["KB/s sent per robot", "messages/s per robot",
                               "CPU per robot (cores)", "resident MB per robot"]):
        ax.plot([p["robots"] for p in points], [p[key] for p in points], "o-")
        ax.set_xlabel("robots")
        ax.set_title(title)
        ax.set_ylim(bottom=0)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "scale.png"), dpi=80)
    plt.close(fig)
    lines = ["| robots | KB/s sent per robot | messages/s per robot | CPU per robot, cores |"
             " resident MB per robot | linked teammates (mean) | transforms known per robot |"
             " worst 1 s on a link, KB |", "|---|---|---|---|---|---|---|---|"] + rows
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write("\n".join(lines) + "\n\n```\n" + json.dumps(points, indent=2) + "\n```\n")
    print("\n".join(lines))


def per_minute(report, robot):
    """One robot's mission minutes: CPU per keyframe (and by stage), resident memory (the
    process's, shared evenly: run_team runs every robot in one), known volume, places,
    verifications and the 99th percentile of what its loop closures waited for the budget."""
    n = len(report["robots"])
    work = robot["work_series"]

    def at(series, t):  # the row of a [t, value, ...] series sampled with the work series
        return min(series, key=lambda row: abs(row[0] - t))[1] if t > 0 else 0.0
    # The samples closest to each whole minute (a sample lands within a simulation step of it).
    rows = []
    for minute in range(1, int(work[-1]["t"] // 60 + 1e-6) + 1):
        rows.append(next(w for w in work if w["t"] >= 60.0 * minute - 0.05))
    if not rows or rows[-1]["t"] < work[-1]["t"] - 1.0:
        rows.append(work[-1])  # a last part-minute
    minutes = []
    before = {"t": 0.0, "keyframes": 0, "verifications": 0, "stage_cpu_s": {}}
    for row in rows:
        keyframes = row["keyframes"] - before["keyframes"]
        cpu_s = at(robot["cpu_series"], row["t"]) - at(robot["cpu_series"], before["t"])
        waits = sorted(w for t, w in robot["closure_waits"] if before["t"] < t <= row["t"])
        minutes.append({
            "minute": len(minutes) + 1,
            "t": row["t"],
            "cpu_cores": cpu_s / (row["t"] - before["t"]),
            "cpu_s_per_keyframe": cpu_s / keyframes if keyframes else None,
            "stage_cpu_s_per_keyframe": {
                k: (v - before["stage_cpu_s"].get(k, 0.0)) / keyframes
                for k, v in row["stage_cpu_s"].items()} if keyframes else {},
            "rss_mb": at(report["memory_series"], row["t"]) / 1e6 / n,
            "known_m3": at(robot["map_series"], row["t"]),
            "places": row["places"],
            "verifications": row["verifications"] - before["verifications"],
            "closure_latency_p99_s": waits[min(len(waits) - 1, int(0.99 * len(waits)))]
            if waits else None,
        })
        before = row
    return minutes


def long_mission(args):
    """Long missions (run_team, CCIR): per robot and mission minute, CPU per keyframe and by
    stage, resident memory, known volume, places, verifications and closure latency; OUT/
    summary.json and a plot."""
    robots = int(args.robots.split(",")[0])
    summary = {"robots": []}
    fig, axes = plt.subplots(1, 3, figsize=(15, 3.5))
    for seed in args.seeds.split(","):
        report = run_team(args, os.path.join(args.out, "seed_%s" % seed), [
            "--world", "mine", "--mine-pillars-x", str(args.pillars),
            "--mine-pillars-y", str(args.pillars), "--robots", str(robots), "--seed", seed,
            "--duration-s", str(args.duration_s), "--overlap", str(args.overlap),
            "--budget-bytes-per-s", str(args.budget_bytes_per_s), "--mode", "ccir",
            "--series-period-s", "10"])
        for r in report["robots"]:
            minutes = per_minute(report, r)
            name = r["name"] if len(args.seeds.split(",")) == 1 else "%s/%s" % (seed, r["name"])
            summary["robots"].append({
                "name": name, "seed": int(seed), "keyframes": r["keyframes"],
                "cpu_cores_mean": r["cpu_series"][-1][1] / report["duration_s"],
                "stage_cpu_s": r["stage_cpu_s"], "ate_m": r["ate_m"], "minutes": minutes})
            t = [m["t"] for m in minutes]
            axes[0].plot(t, [m["cpu_s_per_keyframe"] for m in minutes], label=name)
            axes[1].plot(t, [m["rss_mb"] for m in minutes], label=name)
            axes[2].plot(t, [m["known_m3"] for m in minutes], label=name)
    for ax, title in zip(axes, ["CPU s per keyframe", "resident MB per robot", "known volume, m³"]):
        ax.set_title(title)
        ax.set_xlabel("mission s")
        ax.set_ylim(bottom=0)
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "long_mission.png"), dpi=80)
    plt.close(fig)
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
    for r in summary["robots"]:
        print("%s: %.2f cores, CPU s per keyframe by minute %s" % (
            r["name"], r["cpu_cores_mean"],
            " ".join("%.2f" % m["cpu_s_per_keyframe"] if m["cpu_s_per_keyframe"] else "-"
                     for m in r["minutes"])))


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("experiment", choices=["ccir_vs_fixed_rate", "scale", "long_mission"])
    parser.add_argument("out")
    parser.add_argument("--run-team", required=True)
    parser.add_argument("--worlds", default="mine,building,cave,cluttered")
    parser.add_argument("--robots", default="3,6,9")
    parser.add_argument("--seeds", default="7,11,13")
    parser.add_argument("--duration-s", type=float, default=60.0)
    parser.add_argument("--budget-bytes-per-s", type=float, default=150000.0)
    parser.add_argument("--every-n", default="13,8,5,3,2")
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--config", help="a robot YAML for run_team --config (stage parameters)")
    # scale
    parser.add_argument("--pillars", type=int, default=6, help="scale, long_mission: mine pillars")
    parser.add_argument("--start-window-s", type=float, default=20.0)
    parser.add_argument("--radio-range-m", type=float, default=30.0)
    parser.add_argument("--max-peers", type=int, default=8)
    # long_mission
    parser.add_argument("--overlap", type=float, default=0.5)
    args = parser.parse_args()
    args.out = os.path.abspath(args.out)
    if args.config:
        args.config = os.path.abspath(args.config)
    os.makedirs(args.out, exist_ok=True)
    snapshot(args)
    {"ccir_vs_fixed_rate": ccir_vs_fixed_rate, "scale": scale,
     "long_mission": long_mission}[args.experiment](args)


if __name__ == "__main__":
    main()
