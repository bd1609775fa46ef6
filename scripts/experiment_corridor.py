"""bearing_corridor (Rahimi Fig. 1b): how close the QP smoother alone gets, on evaluation seeds.

    python -m scripts.experiment_corridor                      # evaluation seeds 1000-1023, docs/corridor_experiment.csv
    python -m scripts.experiment_corridor --seeds 100-111 --out /tmp/dev.csv --no-figure   # development seeds

Per seed: one analytic recording of ``bearing_corridor`` (20 s, the bundled fitted perception
model) and ``qp_smoother`` variants on the walker's bearings, RMSE over every frame (m) against
the truth and sqrt(CRB) (m) under the variant's own prior:

- ``qp``: the estimator's defaults (Rahimi's stiff prior, the calibrated bearing noise);
- ``qp_sigma3``: the same with sigma_px = 3 (chosen on development seeds: the calibrated
  0.23 px is the rendered detector's scatter on whole silhouettes; a silhouette cut by the image
  border is off by tens of pixels, ``docs/sensing.md``);
- ``qp_identified``: the prior identified from the walker's true paths on identification seeds
  (``scripts.sweep_bearing_layout.identify_prior``);
- ``qp_one_camera``: defaults, given only the bearings of the camera that saw the walker most
  (Fig. 1a: one camera cannot fix the depth).

Development seeds (used while designing the scene and choosing ``qp_sigma3``): 100-111.
Evaluation seeds: 1000-1023, run once the scene and the variants were fixed.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import warnings

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pandas as pd
from tqdm import tqdm

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.experiment_qp import truth_on_grid
from scripts.sweep_bearing_layout import identify_prior, walker_errors
from trackroom.recording import Observations
from trackroom.scenes.loader import load_scene

DURATION = 20.0
EVAL_SEEDS = range(1000, 1024)
DEV_SEEDS = range(100, 112)
TARGET = 0.3  # m: issue 13's "close to the true trajectory"


def parse_seeds(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def variants(q_id) -> dict[str, dict]:
    return {"qp": {}, "qp_sigma3": {"sigma_px": 3.0}, "qp_identified": {"q_pos": q_id[0], "q_vel": q_id[1]}}


def run_seed(seed: int, q_id, duration: float = DURATION) -> list[dict]:
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("bearing_corridor"), seed, duration)
    res = walker_errors(rec, variants(q_id))
    rows = [{"seed": seed, "variant": v, "rmse": res[f"rmse_{v}"], "sqrt_crb": res[f"sqrt_crb_{v}"],
             "cameras_seen": res["cameras_seen"], "n_obs": res["n_obs"], "converged": res.get(f"converged_{v}")}
            for v in variants(q_id)]
    b = rec.observations["bearings"]
    w = rec.meta["walkers"][0]
    mine = b[b.label == w["color"]]
    if len(mine):  # one camera only: the one that saw the walker most
        one = str(mine.camera.value_counts().idxmax())
        obs1 = Observations({**rec.observations.tables, "bearings": b[b.camera == one].reset_index(drop=True)},
                            rec.observations.duration)
        rec1 = dataclasses.replace(rec, observations=obs1)
        r1 = walker_errors(rec1, {"qp": {}})
        rows.append({"seed": seed, "variant": "qp_one_camera", "rmse": r1["rmse_qp"], "sqrt_crb": r1["sqrt_crb_qp"],
                     "cameras_seen": 1, "n_obs": r1["n_obs"], "converged": r1.get("converged_qp"), "one_camera": one})
    return rows


def _run(args):
    return run_seed(*args)


def summarise(df: pd.DataFrame) -> str:
    lines = ["| variant | runs | median RMSE (m) | quartiles (m) | worst (m) | runs <= 0.3 m | median sqrt(CRB) (m) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for v, g in df.groupby("variant", sort=False):
        q1, q3 = g.rmse.quantile([0.25, 0.75])
        lines.append(f"| {v} | {len(g)} | {g.rmse.median():.3f} | {q1:.3f}-{q3:.3f} | {g.rmse.max():.3f} | "
                     f"{int((g.rmse <= TARGET).sum())}/{len(g)} | {g.sqrt_crb.median():.3f} |")
    return "\n".join(lines)


def figure(seeds: list[int], path: str, duration: float = DURATION) -> None:
    """Top-down runs (truth green, qp_smoother red, one camera only orange), one corridor per seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from scripts.fig_rahimi import draw_room
    from trackroom.dataset import atomic_write
    from trackroom.estimators import get
    from trackroom.sim.simulate import simulate

    scene = load_scene("bearing_corridor")
    fig, axs = plt.subplots(len(seeds), 1, figsize=(12, 2.2 * len(seeds)), squeeze=False)
    for ax, seed in zip(axs[:, 0], seeds):
        rec = simulate(scene, seed, duration)
        w = rec.meta["walkers"][0]
        cal, obs = rec.calibration, rec.observations
        dt = 1.0 / max(c.fps for c in cal.cameras.values())
        xy = truth_on_grid(rec, w["name"], dt, int(round(duration / dt)))
        draw_room(ax, cal)
        ax.plot(xy[:, 0], xy[:, 1], "g-", lw=1.2, label="truth")
        b = obs["bearings"]
        mine = b[b.label == w["color"]]
        one = str(mine.camera.value_counts().idxmax())
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tr = get("qp_smoother")().estimate(obs, cal)
            obs1 = Observations({**obs.tables, "bearings": b[b.camera == one].reset_index(drop=True)}, obs.duration)
            tr1 = get("qp_smoother")().estimate(obs1, cal)
        tr, tr1 = tr[tr.track_id == w["color"]], tr1[tr1.track_id == w["color"]]
        e = float(np.sqrt(np.nanmean(np.sum((np.c_[tr.x, tr.y] - xy) ** 2, axis=1))))
        e1 = float(np.sqrt(np.nanmean(np.sum((np.c_[tr1.x, tr1.y] - xy) ** 2, axis=1))))
        ax.plot(tr1.x, tr1.y, ".", color="orange", ms=2.5, label=f"{one}'s bearings only: RMSE {e1:.2f} m")
        ax.plot(tr.x, tr.y, "r.", ms=3, label=f"qp_smoother, all cameras: RMSE {e:.2f} m")
        seen = np.zeros(len(xy), bool)
        seen[np.rint(mine.t.to_numpy() / dt).astype(int)] = True
        ax.plot(xy[seen, 0], xy[seen, 1], "o", mfc="none", mec="g", ms=4, lw=0.5, label="seen (truth)")
        ax.set_ylim(-0.8, 5.8)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("y (m)", fontsize=8)
        ax.set_title(f"bearing_corridor, seed {seed}, {duration:g} s (4 Hz)", fontsize=9)
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default=f"{EVAL_SEEDS.start}-{EVAL_SEEDS.stop - 1}", help="e.g. 1000-1023 or 100,101")
    ap.add_argument("--duration", type=float, default=DURATION)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default="docs/corridor_experiment.csv")
    ap.add_argument("--figure", default="docs/img/corridor_runs.png")
    ap.add_argument("--no-figure", action="store_true")
    args = ap.parse_args(argv)
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError:
        ap.error(f"--seeds: expected whole numbers and ranges like 1000-1023 or 100,101, got {args.seeds!r}")
    if not seeds or args.jobs < 1 or not args.duration > 0:
        ap.error("need at least one seed, --jobs >= 1 and --duration > 0")
    q_id = identify_prior("corridor", 1.2)
    print(f"identified prior: q_pos = {q_id[0]:.2e} m^2/s, q_vel = {q_id[1]:.2e} m^2/s^3")
    tasks = [(s, q_id, args.duration) for s in seeds]
    if args.jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs) as ex:
            rows = [r for rs in tqdm(ex.map(_run, tasks), total=len(tasks), desc="seeds") for r in rs]
    else:
        rows = [r for t in tqdm(tasks, desc="seeds") for r in _run(t)]
    df = pd.DataFrame(rows)
    from trackroom.dataset import atomic_write

    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    atomic_write(args.out, lambda tmp: df.to_csv(tmp, index=False))
    print(summarise(df))
    qp = df[df.variant == "qp"]
    verdict = "met" if qp.rmse.median() <= TARGET else "NOT met"
    print(f"qp_smoother alone (defaults), seeds {args.seeds}: median RMSE {qp.rmse.median():.3f} m; target <= {TARGET} m {verdict}")
    if not args.no_figure:
        os.makedirs(os.path.dirname(args.figure) or ".", exist_ok=True)
        figure(seeds[:3], args.figure, args.duration)
        print(f"figure: {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
