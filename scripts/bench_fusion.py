"""Runtime of ``fusion_smoother`` on one person with a phone (issue 13 targets: T = 240 frames
in <= 1 s, T = 3840 in <= 15 s).

bearing_hall (4 Hz cameras, the default random walker with its phone at 100 Hz) simulated for
T / 4 seconds; ``estimate`` timed end to end (phone features, the robust no-phone solve and the
phone-only solve that the matching needs, the fused solve), best and median of ``--repeat``, in
wall time and in the process's CPU time (on a busy machine the wall time counts other processes'
turns; the load average is printed beside it).

    python -m scripts.bench_fusion --frames 240 3840 --repeat 3
    python -m scripts.bench_fusion --frames 240 3840 --repeat 1 --param offset_knot_s=5
"""
from __future__ import annotations

import argparse
import os
import time
import warnings

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.estimators import get
from trackroom.scenes.loader import load_scene
from trackroom.sim.simulate import simulate

TARGETS = {240: 1.0, 3840: 15.0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, nargs="+", default=[240, 3840])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="fusion_smoother parameter")
    args = ap.parse_args(argv)
    from scripts.experiment_fusion import parse_params

    params = parse_params(args.param)
    print(f"load average {os.getloadavg()[0]:.1f}; parameters {params or 'the defaults'}")
    for T in args.frames:
        rec = simulate(load_scene("bearing_hall"), args.seed, T / 4.0)
        times, cpu, parts = [], [], None
        for _ in range(args.repeat):
            est = get("fusion_smoother")(**params)
            t0, c0 = time.perf_counter(), time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                est.estimate(rec.observations, rec.calibration)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            d = next(iter(est.diagnostics_.values()))
            parts = (d["seconds"], d["iterations"], d["phone_id"])
        target = TARGETS.get(T)
        verdict = "" if target is None else f" (target {target:g} s: {'met' if min(times) <= target else 'NOT met'})"
        print(f"T = {T}: best {min(times):.2f} s, median {np.median(times):.2f} s{verdict}; "
              f"process CPU time best {min(cpu):.2f} s (less sensitive to a shared machine's load); "
              f"fused solve {parts[0]:.2f} s in {parts[1]} Gauss-Newton iterations, phone {parts[2] or 'none'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
