"""long_mission's per-minute rows from a run_team report: deltas per minute, not totals."""
from ccir_mapping.experiments import per_minute


def report():
    work, cpu, memory, known = [], [], [], []
    for k in range(1, 14):  # every 10 s to 130 s, the last sample a step past 120
        t = 10.0 * k + (0.1 if k == 12 else 0.0)
        work.append({"t": t, "keyframes": 10 * k, "places": 10 * k, "verifications": 30 * k,
                     "stage_cpu_s": {"match": 0.5 * k}})
        cpu.append([t, 2.0 * k])
        memory.append([t, 2e8 * k])
        known.append([t, 100.0 * k, 0.0])
    robot = {"work_series": work, "cpu_series": cpu, "map_series": known,
             "closure_waits": [[30.0, 0.0], [61.0, 4.0], [62.0, 1.0]]}
    return {"robots": [robot, robot], "memory_series": memory}


def test_each_minute_holds_what_happened_in_it():
    r = report()
    minutes = per_minute(r, r["robots"][0])
    assert [m["t"] for m in minutes] == [60.0, 120.1, 130.0]
    first, second, last = minutes
    assert first["cpu_s_per_keyframe"] == 12.0 / 60
    assert second["verifications"] == 180
    assert abs(second["stage_cpu_s_per_keyframe"]["match"] - 3.0 / 60) < 1e-12
    assert second["rss_mb"] == 2e8 * 12 / 1e6 / 2  # the process's, shared by two robots
    assert first["closure_latency_p99_s"] == 0.0
    assert second["closure_latency_p99_s"] == 4.0
    assert last["closure_latency_p99_s"] is None
    assert last["places"] == 130 and last["known_m3"] == 1300.0
