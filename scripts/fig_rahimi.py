"""Rahimi et al. Figs. 3, 4, 5 (bearing_hall) and 7 (office_floor) from simulated recordings.

    python -m scripts.fig_rahimi [--out docs/img]

Fig. 3: the Gauss-Newton iterates converging (paper's initial guess). Fig. 4: several runs.
Fig. 5: the same run without the field-of-view constraints. Fig. 7: the office floor loop, with
and without the walls as constraints. Walkers: gauss_markov with process noise (1e-4, 0.1) on
bearing_hall (the estimator gets the matched prior); the scripted loop on office_floor (prior
q = (1e-4, 0.1), not matched: the loop is not a Gauss-Markov path).
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

from estimators import get
from scenes.loader import load_scene
from scripts.experiment_qp import truth_on_grid

Q = (1e-4, 0.1)


def draw_room(ax, cal):
    fp = cal.floorplan
    o = np.vstack([fp.outline, fp.outline[:1]])
    ax.plot(o[:, 0], o[:, 1], "k-", lw=2)
    for w in fp.walls:
        ax.plot([w.start[0], w.end[0]], [w.start[1], w.end[1]], "k-", lw=2)
    for name, cam in cal.cameras.items():
        p = cam.position[:2]
        for s in (-1, 1):
            a = cam.yaw + s * cam.fovx / 2
            ax.plot([p[0], p[0] + 3 * np.cos(a)], [p[1], p[1] + 3 * np.sin(a)], color="0.6", lw=0.8)
        ax.plot(*p, "ks", ms=5)
        ax.annotate(name, p, fontsize=6)
    ax.set_aspect("equal")
    lo, hi = fp.outline.min(0) - 1, fp.outline.max(0) + 1
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])


def run(scene, seed, duration, **kw):
    from sim.simulate import simulate

    rec = simulate(scene, seed, duration)
    w = rec.meta["walkers"][0]
    cal, obs = rec.calibration, rec.observations
    b = obs["bearings"]
    b = b[b.label == w["color"]]
    dt = 1.0 / max(c.fps for c in cal.cameras.values())
    T = int(round(duration / dt))
    est = get("qp_smoother")(**kw)
    k = np.rint(b.t.to_numpy() / dt).astype(int)
    sigma = float(cal.noise.get("bearing_sigma_px", 1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = est.solve(k, b.camera.to_numpy(object), b.u.to_numpy(), T, dt, {n: cal.cameras[n] for n in set(b.camera)}, sigma, cal, keep_iterates=True)
    return rec, cal, truth_on_grid(rec, w["name"], dt, T), res


def xy_of(X):
    return X[0::4], X[2::4]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/img")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    hall = load_scene("bearing_hall", ['walkers.motion="gauss_markov"', f"walkers.process_noise=[{Q[0]}, {Q[1]}]"])
    # Fig. 3: iterates
    rec, cal, xy, res = run(hall, 0, 60.0, q_pos=Q[0], q_vel=Q[1])
    its = [i for i in (0, 1, 3, 9, 11, 17) if i < len(res.iterates)] + [len(res.iterates) - 1]
    fig, axs = plt.subplots(1, len(its), figsize=(3 * len(its), 3.2))
    for ax, i in zip(axs, its):
        draw_room(ax, cal)
        ax.plot(xy[:, 0], xy[:, 1], "g-", lw=1, label="truth")
        ax.plot(*xy_of(res.iterates[i]), "r.-", ms=2, lw=0.5, label="estimate")
        ax.set_title(f"iteration {i}", fontsize=8)
    axs[0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(f"{args.out}/rahimi_fig3_iterations.png", dpi=110)
    # Fig. 5: the same run without constraints
    _, _, _, res_u = run(hall, 0, 60.0, q_pos=Q[0], q_vel=Q[1], constraints=False)
    fig, axs = plt.subplots(1, 2, figsize=(7, 3.5))
    for ax, r, title in ((axs[0], res, "with FOV constraints"), (axs[1], res_u, "without constraints")):
        draw_room(ax, cal)
        ax.plot(xy[:, 0], xy[:, 1], "g-", lw=1)
        ax.plot(*xy_of(r.X), "r.-", ms=2, lw=0.5)
        e = np.sqrt(np.nanmean((r.X[0::4] - xy[:, 0]) ** 2 + (r.X[2::4] - xy[:, 1]) ** 2))
        ax.set_title(f"{title}: RMSE {e:.2f} m", fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{args.out}/rahimi_fig5_unconstrained.png", dpi=110)
    # Fig. 4: several runs
    fig, axs = plt.subplots(1, 4, figsize=(12, 3.2))
    for ax, seed in zip(axs, (2, 4, 5, 6)):
        try:
            _, cal_s, xy_s, r = run(hall, seed, 60.0, q_pos=Q[0], q_vel=Q[1])
        except ValueError:
            continue
        draw_room(ax, cal_s)
        ax.plot(xy_s[:, 0], xy_s[:, 1], "g-", lw=1)
        ax.plot(*xy_of(r.X), "r.-", ms=2, lw=0.5)
        e = np.sqrt(np.nanmean((r.X[0::4] - xy_s[:, 0]) ** 2 + (r.X[2::4] - xy_s[:, 1]) ** 2))
        ax.set_title(f"seed {seed}: RMSE {e:.2f} m", fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{args.out}/rahimi_fig4_runs.png", dpi=110)
    # Fig. 7: office floor
    office = load_scene("office_floor")
    fig, axs = plt.subplots(1, 2, figsize=(11, 3.4))
    for ax, walls in zip(axs, (False, True)):
        _, cal_o, xy_o, r = run(office, 0, 60.0, q_pos=Q[0], q_vel=Q[1], walls=walls)
        draw_room(ax, cal_o)
        ax.plot(xy_o[:, 0], xy_o[:, 1], "g-", lw=1)
        ax.plot(*xy_of(r.X), "r.-", ms=2, lw=0.5)
        e = np.sqrt(np.nanmean((r.X[0::4] - xy_o[:, 0]) ** 2 + (r.X[2::4] - xy_o[:, 1]) ** 2))
        ax.set_title(f"office_floor, walls={walls}: RMSE {e:.2f} m", fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{args.out}/rahimi_fig7_office.png", dpi=110)
    print("wrote", sorted(os.listdir(args.out)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
