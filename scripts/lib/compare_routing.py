#!/usr/bin/python3
"""Scores the runs of scripts/benchmarks/ccir_vs_fixed_rate (one demo report each) against the
simulator's truth and prints the comparison as JSON."""
import json
import os
import sys


def score(run_dir):
    report = json.load(open(os.path.join(run_dir, "report.json")))
    duration = report["duration_s"]
    robots = report["robots"]
    sent = sum(link["bytes_sent"] for r in robots for link in r["links"].values())
    transforms = {(r["name"], t["peer"]): t for r in robots for t in r["team_frames"]
                  if t.get("valid")}
    return {
        "bytes_sent": sent,
        "mean_kb_per_s_per_robot": sent / 1e3 / duration / len(robots),
        "transforms_found": len(transforms),
        "transforms": {"%s->%s" % k: {"error_m": round(t["error_m"], 3),
                                      "error_deg": round(t["error_deg"], 2),
                                      "inliers": t["inliers"]}
                       for k, t in sorted(transforms.items())},
        "known_volume_m3": {r["name"]: (r["map"] or {}).get("known_volume_m3", 0) for r in robots},
        "scans_lost": sum(r["scans_missed"] + r["scans_dropped"] for r in robots),
        "playback_rate": report["playback_rate"],
    }


def main():
    out = sys.argv[1]
    runs = {name: score(os.path.join(out, name)) for name in sorted(os.listdir(out))
            if os.path.exists(os.path.join(out, name, "report.json"))}
    ccir = runs.get("ccir")
    fixed = sorted(((int(name.rsplit("_", 1)[1]), s) for name, s in runs.items()
                    if name.startswith("fixed_rate_")), key=lambda x: x[0])
    match = None
    if ccir:
        for n, s in sorted(fixed, key=lambda x: -x[0]):  # sparsest first
            enough = all(s["known_volume_m3"][r] >= 0.9 * v for r, v in ccir["known_volume_m3"].items())
            if set(ccir["transforms"]) <= set(s["transforms"]) and enough:
                match = (n, s)
                break
    result = {"benchmark": "ccir_vs_fixed_rate", "runs": runs,
              "matching_fixed_rate_every_n": match[0] if match else None,
              "bytes_ratio_ccir_over_fixed_rate":
                  round(ccir["bytes_sent"] / match[1]["bytes_sent"], 3) if ccir and match else None,
              "target_ratio": 0.20,
              "ccir_known_volume_over_all": None if not ccir or "all" not in runs else {
                  r: round(v / max(1e-9, runs["all"]["known_volume_m3"][r]), 3)
                  for r, v in ccir["known_volume_m3"].items()}}
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
