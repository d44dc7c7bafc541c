"""The demo's report for a person: <out>/report.html and the same as <out>/report.md, with the
summary (summary.txt) and plots in <out>/plots: bytes sent per link over mission time, known
volume per robot, the error of each team transform against the truth over time, and a top-down
picture of the team map as the first robot's team transforms place its teammates' maps, coloured
by robot. Reads what demo_summary.py and demo_report.py wrote; prints the page's path."""
import argparse
import html
import json
import os

import matplotlib

matplotlib.use("Agg")  # no display on a robot or in CI
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402

from .demo_summary import matrix, start_pose  # noqa: E402


def line_plot(path, title, ylabel, series, duration_s):
    """series: [(label, xs, ys)] over the mission; returns whether anything was drawn."""
    series = [s for s in series if len(s[1])]
    if not series:
        return False
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for label, xs, ys in series:
        ax.plot(xs, ys, label=label)
    ax.set_title(title)
    ax.set_xlim(0, duration_s)
    ax.set_xlabel("mission time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def team_map_plot(path, out, report, plans):
    """Each robot's own map (its keyframes' walls at its optimised poses) in the first robot's
    map frame: its own directly, a teammate's through the first robot's last valid transform
    to it (teammates it has none for are left out and named in the legend). Returns the caption
    or None when there is nothing to draw."""
    first = report["robots"][0]
    transforms = {t["peer"]: t for t in first["team_frames"] if t["valid"]}
    fig, ax = plt.subplots(figsize=(7, 7))
    drawn = False
    for r in report["robots"]:
        file = os.path.join(out, r["name"], "topdown_xy.npy")
        if not os.path.exists(file):
            continue
        xy = np.load(file)
        if r["name"] == first["name"]:
            label = r["name"]
        elif r["name"] in transforms:
            t = transforms[r["name"]]
            m = matrix(t["translation"], t["rotation_xyzw"])
            xy = xy @ m[:2, :2].T + m[:2, 3]
            label = "%s (via %s's transform)" % (r["name"], first["name"])
        else:
            ax.plot([], [], " ", label="%s: no transform known" % r["name"])
            continue
        # The truth frame of the first robot is its start: walls land where the world has them.
        world = start_pose(plans[first["name"]])
        xy = xy @ world[:2, :2].T + world[:2, 3]
        ax.scatter(xy[:, 0], xy[:, 1], s=0.3, alpha=0.5, label=label)
        drawn = True
    if not drawn:
        plt.close(fig)
        return None
    ax.set_aspect("equal")
    ax.set_xlabel("world x (m)")
    ax.set_ylabel("world y (m)")
    ax.set_title("team map as %s places it (walls 0.2-1.5 m above ground)" % first["name"])
    ax.legend(markerscale=20, fontsize=8, loc="upper left", bbox_to_anchor=(0, -0.08), ncol=3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return ("Each robot's walls at its own optimised poses; teammates placed by %s's last team "
            "transform, the whole shown in the world by %s's true start. Where they are "
            "consistent, colours overlap on the same walls." % (first["name"], first["name"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True, help="demo output folder")
    args = parser.parse_args()
    out = args.out
    report = json.load(open(os.path.join(out, "report.json")))
    plans = {p["name"]: p for p in yaml.safe_load(open(out + "/mission/mission.yaml"))["robots"]}
    os.makedirs(os.path.join(out, "plots"), exist_ok=True)
    figures = []  # (file, title, caption)

    def add(name, title, caption, drawn):
        if drawn:
            figures.append(("plots/" + name, title, caption))

    links = [("%s → %s" % (r["name"], peer), [t for t, _ in s["cumulative_bytes"]],
              [b / 1e3 for _, b in s["cumulative_bytes"]])
             for r in report["robots"] for peer, s in sorted(r["link_series"].items())]
    add("bytes_per_link.png", "Bytes sent per link",
        "Cumulative wire bytes each robot's bridge sent to each teammate (budget %s)."
        % ", ".join(sorted({"%.0f KB/s" % (link["budget_bytes_per_s"] / 1e3)
                            for r in report["robots"] for link in r["links"].values()
                            if link.get("budget_bytes_per_s")})),
        line_plot(os.path.join(out, "plots/bytes_per_link.png"), "bytes sent per link",
                  "KB", links, report["duration_s"]))
    volume = [(r["name"], [row[0] for row in r["map_series"]],
               [row[1] for row in r["map_series"]]) for r in report["robots"]]
    add("known_volume.png", "Known volume per robot",
        "Known (free or occupied) volume of each robot's map, own and teammates' scans.",
        line_plot(os.path.join(out, "plots/known_volume.png"), "known volume of each robot's map",
                  "m³", volume, report["duration_s"]))
    errors = [("%s → %s" % (r["name"], t["peer"]), [row[0] for row in t.get("error_series", [])],
               [row[1] for row in t.get("error_series", [])])
              for r in report["robots"] for t in r["team_frames"]]
    add("team_transform_error.png", "Team-transform error",
        "Distance between each valid team transform a robot published and the truth.",
        line_plot(os.path.join(out, "plots/team_transform_error.png"),
                  "team-transform error against the truth", "m", errors, report["duration_s"]))
    caption = team_map_plot(os.path.join(out, "plots/team_map.png"), out, report, plans)
    add("team_map.png", "Team map, top-down", caption, caption is not None)

    summary = open(os.path.join(out, "summary.txt")).read()
    title = "ccir_mapping demo: %s, %d robots, %.0f s, seed %d" % (
        report["world"]["kind"], len(report["robots"]), report["duration_s"], report["seed"])
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("# %s\n\n```\n%s```\n\n" % (title, summary))
        for file, name, text in figures:
            f.write("## %s\n\n![%s](%s)\n\n%s\n\n" % (name, name, file, text))
        f.write("Data: report.json (all robots), <robot>/report.json, summary.txt.\n")
    with open(os.path.join(out, "report.html"), "w") as f:
        f.write("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>%s</title></head>"
                "<body style=\"font-family: sans-serif; max-width: 60em\">\n<h1>%s</h1>\n"
                "<pre>%s</pre>\n" % (html.escape(title), html.escape(title), html.escape(summary)))
        for file, name, text in figures:
            f.write("<h2>%s</h2>\n<img src=\"%s\" alt=\"%s\" style=\"max-width: 100%%\">\n"
                    "<p>%s</p>\n" % (html.escape(name), file, html.escape(name), html.escape(text)))
        f.write("<p>Data: report.json (all robots), &lt;robot&gt;/report.json, summary.txt.</p>\n"
                "</body></html>\n")
    print("report: %s" % os.path.join(out, "report.html"))


if __name__ == "__main__":
    main()
