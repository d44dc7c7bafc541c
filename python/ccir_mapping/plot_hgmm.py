"""A scan next to the points sampled from its HGMM levels, seen from above: reads what
`bench_hgmm --samples-out DIR` wrote for one scan (DIR/<scan>_points.xyz, DIR/<scan>_level<L>.xyz)
and writes a PNG.
    python3 -m ccir_mapping.plot_hgmm DIR SCAN OUT.png [--range-m 30]"""
import argparse
import glob
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir")
    parser.add_argument("scan", help="file stem, e.g. 16line_1")
    parser.add_argument("out")
    parser.add_argument("--range-m", type=float, default=30.0)
    args = parser.parse_args()
    levels = sorted(glob.glob(os.path.join(args.dir, args.scan + "_level*.xyz")))
    files = [os.path.join(args.dir, args.scan + "_points.xyz")] + levels
    titles = ["the scan"] + ["sampled from level %s" % f.rsplit("_level", 1)[1][:-4]
                             for f in levels]
    fig, axes = plt.subplots(1, len(files), figsize=(4.2 * len(files), 4.4), squeeze=False)
    for ax, name, title in zip(axes[0], files, titles):
        points = np.loadtxt(name, ndmin=2)
        ax.scatter(points[:, 0], points[:, 1], s=0.3, c=points[:, 2], cmap="viridis")
        ax.set_title("%s (%d points)" % (title, len(points)))
        ax.set_xlim(-args.range_m, args.range_m)
        ax.set_ylim(-args.range_m, args.range_m)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
    axes[0][0].set_ylabel("y [m]")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)


if __name__ == "__main__":
    main()
