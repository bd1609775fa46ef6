"""Benchmark: analytic ``overhead_lab`` with 10 walkers, speed as a multiple of real time and
memory per simulated minute.

    python scripts/bench_analytic.py [--duration 60] [--repeats 3] [--walkers 10] [--perception fitted|ideal] [--profile]

Speed = simulated seconds / CPU seconds of this process (``time.process_time``, all its threads:
the camera side of an analytic simulation runs in a second thread beside the IMU side, so this is
the work done, not inflated by other jobs on a shared machine); wall-clock speed is printed too. Memory: the peak of Python allocations
(``tracemalloc``) during one run, divided by the simulated minutes, plus the size of the
returned recording's tables. The 1-minute load average is printed: on a shared machine under
heavy load the CPU time of the same work still rises (caches, hyper-threads), so compare runs at
similar load. ``--profile`` adds a cProfile of one run, timed by CPU time (cProfile's default
wall-clock timer charges other processes' time slices to whatever function was running).
"""
from __future__ import annotations

import argparse
import os
import time
import tracemalloc

os.environ.setdefault("MUJOCO_GL", "egl")
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")  # no BLAS threads

import numpy as np

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.scenes.loader import load_scene
from trackroom.sim.simulate import simulate
from trackroom.sim.walkers import plan_trajectories


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds per run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--walkers", type=int, default=10)
    ap.add_argument("--profile", action="store_true", help="print the top functions of one run by CPU time")
    ap.add_argument("--perception", default="fitted", help='analytic perception: "fitted" (default), "ideal" or a model file')
    args = ap.parse_args(argv)
    scene = load_scene("overhead_lab", [f"walkers.count={args.walkers}", f"sensors.perception={args.perception}"])
    simulate(scene, 0, 2.0)  # warm up imports and caches
    load_before = os.getloadavg()[0]
    cpu, wall, plan = [], [], []
    for r in range(args.repeats):
        t0, w0 = time.process_time(), time.perf_counter()
        rec = simulate(scene, r, args.duration)
        cpu.append(time.process_time() - t0)
        wall.append(time.perf_counter() - w0)
        t1 = time.process_time()
        plan_trajectories(scene, args.duration, np.random.default_rng(r).spawn(4)[0])
        plan.append(time.process_time() - t1)
    tracemalloc.start()
    rec = simulate(scene, 99, args.duration)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    table_bytes = sum(int(df.memory_usage(deep=True).sum()) for df in [*rec.observations.tables.values(), *rec.truth.tables.values()])
    minutes = args.duration / 60.0
    best = min(cpu)
    print(f"overhead_lab analytic, {args.walkers} walkers, {args.duration:.0f} s simulated, {args.repeats} runs "
          f"(load average {load_before:.1f} before, {os.getloadavg()[0]:.1f} after, {os.cpu_count()} cores)")
    print(f"  CPU time per run: {', '.join(f'{c:.3f}' for c in cpu)} s  (trajectory planning alone: {min(plan):.3f} s)")
    print(f"  speed: {args.duration / best:.0f}x real time per CPU second (best run; median {args.duration / float(np.median(cpu)):.0f}x); "
          f"wall clock {args.duration / min(wall):.0f}x")
    print(f"  memory: peak Python allocations {peak / 2**20 / minutes:.1f} MiB per simulated minute; "
          f"recording tables {table_bytes / 2**20 / minutes:.1f} MiB per simulated minute")
    print(f"  rows: " + ", ".join(f"{k} {len(v)}" for k, v in rec.observations.tables.items()))
    if args.profile:
        import cProfile
        import pstats

        prof = cProfile.Profile(time.process_time)
        prof.runcall(simulate, scene, 0, args.duration)
        pstats.Stats(prof).sort_stats("tottime").print_stats(15)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
