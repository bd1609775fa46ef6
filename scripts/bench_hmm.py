"""Runtime of the hmm_matcher as a multiple of real time (Teixeira: ~6x; target >= 100x).

Simulates analytic ``overhead_lab`` recordings (20 Hz cameras, 100 Hz phone IMUs) with 1 and 10
people, then times ``HMMMatcher.estimate`` (tracker + phone features + MAP recursion +
per-frame assignment, everything from the observation tables to the tracks table) over several
repetitions, and reports recording seconds per wall second (best and median), with the stages
timed separately and the machine's load average (the figure scales with free CPU).

    python scripts/bench_hmm.py [--duration 60] [--repeats 5] [--people 1,10] [--set K=V ...]

``--set``: a matcher parameter (e.g. ``share_offset=false`` to time the single pass).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
os.environ.setdefault("MUJOCO_GL", "egl")


def bench(n: int, duration: float, repeats: int, seed: int = 0, params: dict | None = None) -> dict:
    from trackroom.estimators.gait import load_default
    from trackroom.estimators.hmm_matcher import HMMMatcher, phone_features
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("overhead_lab", [f"walkers.count={n}"]), seed, duration)
    obs, cal = rec.observations, rec.calibration
    m = HMMMatcher(**(params or {}))
    totals, stages = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        m.estimate(obs, cal)
        totals.append(time.perf_counter() - t0)
        # the stages, timed on their own
        g = load_default()
        t0 = time.perf_counter(); segs = m.track(obs["floor_detections"], cal, duration); t1 = time.perf_counter()
        ph = phone_features(obs["imu"], segs.frame_times, g, cal.noise["magnetic_field"], m.config.velocity_window_s)
        t2 = time.perf_counter(); m.match(segs, ph, g); t3 = time.perf_counter()
        stages.append((t1 - t0, t2 - t1, t3 - t2))
    st = np.median(np.array(stages), axis=0)
    return {"people": n, "duration": duration, "detections": len(obs["floor_detections"]), "imu_rows": len(obs["imu"]),
            "best_s": min(totals), "median_s": float(np.median(totals)),
            "x_realtime_best": duration / min(totals), "x_realtime_median": duration / float(np.median(totals)),
            "tracker_s": st[0], "phone_features_s": st[1], "recursion_assignment_s": st[2]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--people", default="1,10")
    ap.add_argument("--set", dest="params", action="append", default=[], metavar="K=V", help="matcher parameter")
    args = ap.parse_args(argv)
    from trackroom.estimators.base import coerce_param
    from trackroom.estimators.hmm_matcher import HMMMatcher

    params = {k: coerce_param(HMMMatcher, k, v) for k, v in (p.split("=", 1) for p in args.params)}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {os.cpu_count()} CPUs, load average {load:.2f} (1 min)")
    print("| people | detections | IMU rows | best s | median s | x real time (best) | x real time (median) | tracker s | phone features s | recursion + assignment s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for n in [int(p) for p in args.people.split(",")]:
        r = bench(n, args.duration, args.repeats, params=params)
        print(f"| {n} | {r['detections']} | {r['imu_rows']} | {r['best_s']:.3f} | {r['median_s']:.3f} | {r['x_realtime_best']:.0f} | "
              f"{r['x_realtime_median']:.0f} | {r['tracker_s']:.3f} | {r['phone_features_s']:.3f} | {r['recursion_assignment_s']:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
