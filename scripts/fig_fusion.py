"""Figures of the fusion smoother (issue 13).

- ``fusion_sweep.png``: fusion_smoother's RMSE on bearing_hall (default walker, four cameras)
  against the indoor magnetic disturbance (``sensors.mag_disturbance_deg``, with every other
  phone error at its sweep setting: ``--pocket-yaw`` deg offsets, ``--accel-bias``) and against
  the step-length prior's error (the estimator's ``step_length`` minus the walkers' true step
  length at the reference cadence, 0.74 m: the simulator's gait law f = 1 + 0.6 s), median and
  quartiles over seeds; the numbers go to ``fusion_sweep.csv``.
- ``fusion_one_camera.png``: Rahimi Fig. 1a reproduced: one camera's bearings only; the truth,
  qp_smoother (collapsed onto the camera) and fusion_smoother, top-down.

    python -m scripts.fig_fusion --seeds 8 --first-seed 200 --jobs 2 --out docs/img
"""
from __future__ import annotations

import argparse
import os
import warnings

os.environ.setdefault("MUJOCO_GL", "egl")

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from tqdm import tqdm

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.estimators import get
from trackroom.recording import Observations
from trackroom.scenes.loader import load_scene
from scripts.experiment_fusion import rmse_on_grid
from scripts.experiment_qp import truth_on_grid

TRUE_STEP = 0.74  # m at 1.8 Hz: (f - 1) / (0.6 f), the simulator's gait law (sim/walkers.py)
DISTURBANCE = (0.0, 10.0, 20.0, 40.0)
STEP_PRIOR = (0.54, 0.64, 0.74, 0.84, 0.94)


def one_run(seed: int, kind: str, value: float, pocket_yaw: float, accel_bias: float, duration: float) -> dict:
    from trackroom.sim.simulate import simulate

    sets = [f"sensors.pocket_yaw_deg={pocket_yaw}", f"sensors.accel_bias={accel_bias}"]
    params = {}
    if kind == "disturbance":
        sets.append(f"sensors.mag_disturbance_deg={value}")
    else:
        params["step_length"] = value
    rec = simulate(load_scene("bearing_hall", sets), seed, duration)
    w = rec.meta["walkers"][0]
    dt = 0.25
    T = int(round(duration / dt))
    xy = truth_on_grid(rec, w["name"], dt, T)
    est = get("fusion_smoother")(**params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = est.estimate(rec.observations, rec.calibration)
    tr = tr[tr.track_id == w["color"]]
    d = est.diagnostics_.get(w["color"], {})
    return {"seed": seed, "kind": kind, "value": value, "rmse": rmse_on_grid(tr, xy, dt) if len(tr) else np.nan,
            "phone": d.get("phone_id", ""), "step_length": d.get("step_length")}


def sweep(args) -> pd.DataFrame:
    tasks = [(s, "disturbance", v) for v in DISTURBANCE for s in range(args.first_seed, args.first_seed + args.seeds)]
    tasks += [(s, "step_length", v) for v in STEP_PRIOR for s in range(args.first_seed, args.first_seed + args.seeds)]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max(1, args.jobs)) as ex:
        futs = [ex.submit(one_run, s, k, v, args.pocket_yaw, args.accel_bias, args.duration) for s, k, v in tasks]
        rows = [f.result() for f in tqdm(futs)]
    return pd.DataFrame(rows)


def plot_sweep(df: pd.DataFrame, path: str) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, kind, xlabel, shift in ((axes[0], "disturbance", "magnetic disturbance at a wall (deg)", 0.0),
                                    (axes[1], "step_length", "step-length prior error (m)", TRUE_STEP)):
        g = df[df.kind == kind].groupby("value").rmse
        x = np.array(sorted(df[df.kind == kind].value.unique())) - shift
        ax.plot(x, g.median().to_numpy(), "o-", label="median")
        ax.fill_between(x, g.quantile(0.25).to_numpy(), g.quantile(0.75).to_numpy(), alpha=0.3, label="quartiles")
        ax.axhline(0.5, color="grey", ls="--", lw=1, label="0.5 m target")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("RMSE (m)")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend()
    axes[0].set_title("fusion_smoother vs magnetic disturbance")
    axes[1].set_title("fusion_smoother vs step-length prior")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_one_camera(seed: int, path: str, duration: float) -> None:
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("bearing_hall"), seed, duration)
    w = rec.meta["walkers"][0]
    b = rec.observations["bearings"]
    one = str(b[b.label == w["color"]].camera.value_counts().idxmax())
    obs = Observations({**rec.observations.tables, "bearings": b[b.camera == one].reset_index(drop=True)}, rec.observations.duration)
    dt = 0.25
    T = int(round(duration / dt))
    xy = truth_on_grid(rec, w["name"], dt, T)
    fig, ax = plt.subplots(figsize=(6, 6))
    out = np.asarray(rec.calibration.floorplan.outline, float)
    ax.plot(*np.vstack([out, out[:1]]).T, "k-", lw=2)
    cam = rec.calibration.cameras[one]
    ax.plot(cam.position[0], cam.position[1], "ks", ms=9)
    ax.annotate(one, cam.position[:2], textcoords="offset points", xytext=(5, 5))
    ax.plot(xy[:, 0], xy[:, 1], "-", color="grey", lw=3, alpha=0.6, label="truth")
    for name, color in (("qp_smoother", "tab:red"), ("fusion_smoother", "tab:blue")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tr = get(name)().estimate(obs, rec.calibration)
        tr = tr[tr.track_id == w["color"]]
        ax.plot(tr.x, tr.y, "-", color=color, lw=1.5, label=f"{name} (RMSE {rmse_on_grid(tr, xy, dt):.2f} m)")
    seen = np.rint(b[(b.camera == one) & (b.label == w["color"])].t.to_numpy() / dt).astype(int)
    ax.plot(xy[seen, 0], xy[seen, 1], "k.", ms=4, label="seen by the camera")
    ax.set_aspect("equal")
    ax.set_xlim(-0.5, 10.5)
    ax.set_ylim(-0.5, 10.5)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"one camera only (bearing_hall seed {seed}, {duration:g} s)")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=200)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--pocket-yaw", type=float, default=30.0)
    ap.add_argument("--accel-bias", type=float, default=0.05)
    ap.add_argument("--one-camera-seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default="docs/img")
    ap.add_argument("--skip-sweep", action="store_true")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    plot_one_camera(args.one_camera_seed, os.path.join(args.out, "fusion_one_camera.png"), args.duration)
    if not args.skip_sweep:
        df = sweep(args)
        df.to_csv(os.path.join(os.path.dirname(args.out.rstrip("/")) or ".", "fusion_sweep.csv"), index=False)
        plot_sweep(df, os.path.join(args.out, "fusion_sweep.png"))
        for kind, g in df.groupby("kind"):
            print(kind, g.groupby("value").rmse.median().round(3).to_dict())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
