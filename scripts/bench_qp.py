"""Speed benchmark of the QP smoother: wall time and time per Gauss-Newton iteration vs T.

A person walks a smooth closed path through all four views of ``bearing_hall`` (bearings from
the calibrated cameras with 1 px noise, 4 Hz) for T steps; the estimator runs with the
field-of-view constraints. Targets (issue 5): T = 240 in <= 0.5 s, T = 3840 in <= 10 s, and the
time per iteration growing at most linearly in T (the fitted exponent of t_iter ~ T^p).

    python -m scripts.bench_qp [--sizes 240 480 960 1920 3840] [--repeats 3]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.estimators.qp_smoother import QPSmoother
from trackroom.scenes.loader import load_scene
from trackroom.recording import Calibration, Observations


def loop_path(T: int, dt: float) -> np.ndarray:
    """A smooth rounded-square loop (period 40 s, 1.5-8.5 m) through the four corner views."""
    t = np.arange(T) * dt
    w = 2 * np.pi / 40.0
    c, s = np.cos(w * t), np.sin(w * t)
    return np.c_[5.0 + 3.5 * np.sign(c) * np.abs(c) ** 0.5, 5.0 + 3.5 * np.sign(s) * np.abs(s) ** 0.5]


def synthetic(T: int, seed: int = 0):
    sc = load_scene("bearing_hall")
    cal = Calibration({c.name: c for c in sc.cameras}, sc.floorplan, {"bearing_sigma_px": 1.0})
    dt = 1.0 / sc.cameras[0].fps
    xy = loop_path(T, dt)
    rng = np.random.default_rng(seed)
    rows = []
    for name, cam in cal.cameras.items():
        m = cam.in_horizontal_fov(xy)
        rows.append(pd.DataFrame({"t": np.arange(T)[m] * dt, "camera": name, "u": cam.bearing_u(xy[m]) + rng.normal(size=m.sum()), "label": "red"}))
    df = pd.concat(rows).sort_values(["t", "camera"], kind="stable").reset_index(drop=True)
    return Observations({"bearings": df}, T * dt), cal, xy


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[240, 480, 960, 1920, 3840])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--q-vel", type=float, default=0.05, help="prior q_vel (m^2/s^3); the path turns, so a loose prior")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    rows = []
    for T in args.sizes:
        obs, cal, xy = synthetic(T)
        best = None
        for _ in range(args.repeats):
            est = QPSmoother(q_vel=args.q_vel, q_pos=1e-4)
            t0 = time.perf_counter()
            tr = est.estimate(obs, cal)
            wall = time.perf_counter() - t0
            d = est.diagnostics_["red"]
            if best is None or wall < best[0]:
                best = (wall, d, tr)
        wall, d, tr = best
        rmse = float(np.sqrt(np.mean((tr.x - xy[:, 0]) ** 2 + (tr.y - xy[:, 1]) ** 2)))
        rows.append({"T": T, "seconds": wall, "iterations": d["iterations"], "s_per_iter": wall / d["iterations"],
                     "converged": d["converged"], "qp_not_solved": d["qp_not_solved"], "observations": len(obs["bearings"]), "rmse_m": rmse})
        print(f"T={T:5d}  {wall:7.3f} s  {d['iterations']:3d} GN iterations  {wall / d['iterations'] * 1e3:7.1f} ms/iter  "
              f"converged={d['converged']}  qp_not_solved={d['qp_not_solved']}  rmse={rmse:.3f} m", flush=True)
    df = pd.DataFrame(rows)
    if len(df) > 1:
        p = np.polyfit(np.log(df["T"]), np.log(df["s_per_iter"]), 1)[0]
        print(f"time per GN iteration ~ T^{p:.2f}")
    else:
        p = float("nan")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "exponent": float(p)}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
