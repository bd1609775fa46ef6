"""Benchmark: ``target_planes`` on a 35 s, 4-camera occlusion_lab recording (target <= 5 s).

    python scripts/bench_target_planes.py [--recording DIR] [--repeat 3] [--param KEY=VALUE ...]

Without ``--recording`` it simulates occlusion_lab (analytic sensing, seed 100, 35 s) first (not
timed). It times ``TargetPlanes.run`` in single-target mode (the target from a noisy click,
``experiment_tsutsui.click``) and in multi-person mode, ``--repeat`` times each, and prints the
median and the spread beside the load average (the machine is shared: compare ratios measured in
one run, not absolute times across runs).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts import experiment_tsutsui as ts  # noqa: E402

from trackroom.estimators.target_planes import TargetPlanes  # noqa: E402

TARGET_S = 5.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recording", help="a saved occlusion_lab recording (default: simulate analytic seed 100, 35 s)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--param", action="append", default=[], help="estimator Config KEY=VALUE")
    a = ap.parse_args(argv)
    if a.recording:
        from trackroom.dataset import read_recording, recording_folders

        rec = read_recording(recording_folders([a.recording], ap.prog)[0])  # a missing folder named, no traceback
    else:
        from trackroom.scenes.loader import load_scene
        from trackroom.sim.simulate import simulate

        rec = simulate(load_scene("occlusion_lab"), seed=100, duration=35.0, sensing="analytic")
    kw = {**ts.estimator_config(rec), **ts.parse_params(a.param)}
    cams = rec.calibration.cameras_of_kind("oblique")
    print(f"{rec.scene} seed {rec.seed} ({rec.sensing}), {rec.observations.duration:.0f} s, {len(cams)} cameras, "
          f"{len(rec.observations['boxes'])} windows")
    for label, est in (("single target", TargetPlanes(initial_xy=ts.click(rec), **kw)), ("multi-person", TargetPlanes(multi_person=True, **kw))):
        times = []
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            est.run(rec.observations, rec.calibration)
            times.append(time.perf_counter() - t0)
        load = os.getloadavg()[0]
        med = float(np.median(times))
        print(f"{label:14s} median {med:.2f} s (min {min(times):.2f}, max {max(times):.2f}) over {a.repeat} runs; "
              f"load average {load:.2f}; target <= {TARGET_S:.0f} s: {'met' if med <= TARGET_S else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
