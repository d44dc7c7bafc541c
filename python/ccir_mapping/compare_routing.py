"""Scores the runs of scripts/benchmarks/ccir_vs_fixed_rate_demo (one demo report each, with its
time series) or of scripts/experiments/ccir_vs_fixed_rate_run_team against the simulator's truth
and prints the comparison as JSON."""
import json
import os
import sys

# Time series in the JSON are sampled this often (mission seconds); each run's report.json
# holds them at every report.
SAMPLE_S = 5.0


def sampled(rows):
    """Every row at least SAMPLE_S after the last one kept, and the last row."""
    kept = []
    for row in rows:
        if not kept or row[0] >= kept[-1][0] + SAMPLE_S:
            kept.append(row)
    if rows and kept[-1] is not rows[-1]:
        kept.append(rows[-1])
    return kept


def score(run_dir):
    report = json.load(open(os.path.join(run_dir, "report.json")))
    duration = report["duration_s"]
    robots = report["robots"]
    sent = sum(link["bytes_sent"] for r in robots for link in r["links"].values())
    frames = {(r["name"], t["peer"]): t for r in robots for t in r["team_frames"]}
    transforms = {k: t for k, t in frames.items() if t.get("valid")}
    return {
        "bytes_sent": sent,
        "mean_kb_per_s_per_robot": round(sent / 1e3 / duration / len(robots), 1),
        "peak_kb_per_s_per_link": max((link["peak_kb_per_s"] for r in robots
                                       for link in r.get("link_series", {}).values()),
                                      default=None),
        "transforms_found": len(transforms),
        "transforms": {"%s->%s" % k: {"error_m": round(t["error_m"], 3),
                                      "error_deg": round(t["error_deg"], 2),
                                      "inliers": t["inliers"],
                                      "first_valid_s": t.get("first_valid_s"),
                                      "first_valid_error": t.get("first_valid_error"),
                                      "first_correct_s": t.get("first_correct_s")}
                       for k, t in sorted(transforms.items())},
        "known_volume_m3": {r["name"]: (r["map"] or {}).get("known_volume_m3", 0) for r in robots},
        "ate_m": {r["name"]: r.get("ate_m") for r in robots},
        "scans_lost": sum(r["scans_missed"] + r["scans_dropped"] for r in robots),
        "playback_rate": report["playback_rate"],
        "series": {
            "cumulative_bytes_sent": {"%s->%s" % (r["name"], peer): sampled(l["cumulative_bytes"])
                                      for r in robots
                                      for peer, l in sorted(r.get("link_series", {}).items())},
            "known_volume_m3_and_entropy_bits": {r["name"]: sampled(r.get("map_series", []))
                                                 for r in robots}},
    }


def compare(out):
    """The runs under `out` (ccir, all, fixed_rate_<n>) scored, and the match."""
    runs = {name: score(os.path.join(out, name)) for name in sorted(os.listdir(out))
            if os.path.exists(os.path.join(out, name, "report.json"))}
    ccir = runs.get("ccir")
    fixed = {int(name.rsplit("_", 1)[1]): s for name, s in runs.items()
             if name.startswith("fixed_rate_")}
    if "all" in runs and 1 not in fixed:
        fixed[1] = runs["all"]  # every keyframe to every teammate, unthrottled: the same run
    match = None
    if ccir:
        for n, s in sorted(fixed.items(), key=lambda x: -x[0]):  # sparsest first
            enough = all(s["known_volume_m3"][r] >= 0.9 * v
                         for r, v in ccir["known_volume_m3"].items())
            if set(ccir["transforms"]) <= set(s["transforms"]) and enough:
                match = (n, s)
                break
    result = {"benchmark": "ccir_vs_fixed_rate", "runs": runs,
              "fixed_rate_every_n": sorted(fixed),
              "matching_fixed_rate_every_n": match[0] if match else None,
              "bytes_ratio_ccir_over_fixed_rate":
                  round(ccir["bytes_sent"] / match[1]["bytes_sent"], 3) if ccir and match else None,
              "target_ratio": 0.20,
              "ccir_known_volume_over_all": None if not ccir or "all" not in runs else {
                  r: round(v / max(1e-9, runs["all"]["known_volume_m3"][r]), 3)
                  for r, v in ccir["known_volume_m3"].items()}}
    return result


def main():
    print(json.dumps(compare(sys.argv[1]), indent=2))


if __name__ == "__main__":
    main()
