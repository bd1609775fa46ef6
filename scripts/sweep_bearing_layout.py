"""Where bearings alone work (issue 13): the QP smoother over camera layouts, walker speeds and priors.

    python -m scripts.sweep_bearing_layout --quick          # 3 x 2 cells x 2 layouts, 2 seeds: 17 s on 2 busy cores
    python -m scripts.sweep_bearing_layout --jobs 2         # the full grid (docs/bearing_layout_sweep.csv, .png)

Two layouts, each with one walker and N horizontal bearing cameras (apart at narrow fields of view;
many wide ones overlap, and the overlap is reported):

- ``hall``: Rahimi sec. 6 (``bearing_hall``'s 10 m x 10 m room): the N cameras stand on the walls
  at equal steps along the outline (moved 1 m off a corner), each looking along the wall into the
  room (the outline's inward normal turned by 90 deg - FOV/2 - 5 deg, as bearing_hall's four are),
  and the walker is bearing_hall's reflected random walk, at one constant speed (heading diffusing).
- ``corridor``: Rahimi Fig. 1(b) (``bearing_corridor``'s 30 m x 5 m corridor): the N cameras on
  alternating side walls look straight across it, spread evenly over x = 2 ... 20 m (N = 3 at
  58 deg: bearing_corridor's), and the walker walks the corridor's length once at one speed x the
  seeded pace (bearing_corridor's walker); each run lasts 24 m / speed (the walker passes every
  camera and never reaches the far end).

Per cell (layout, cameras N = 2 ... 8, horizontal field of view 40 ... 120 deg, walker speed) and
seed: one analytic recording (the bundled, fitted perception model), and ``qp_smoother`` with two
priors: ``paper`` (its defaults, Rahimi's stiff Sigma_nu: nearly constant velocity) and
``identified`` (q_pos, q_vel fitted to the true paths of that layout's walker at that speed on
separate identification seeds, as Rahimi sec. 7 identified its model from stereo tracks:
``identify_prior``). Reported: the walker's position RMSE over every frame of the recording (m)
and sqrt(CRB) (m; ``metrics.crb``, the bound for a Gauss-Markov walker of the estimator's own prior
with this observation pattern and the calibrated bearing noise), per prior; how many cameras saw
the walker; and per layout the share of the floor seen by >= 2 cameras (many wide cameras overlap:
such a layout is no longer the paper's non-overlapping case). Development seeds only (200 + i;
identification 900 + i); the evaluation seeds of ``scripts.experiment_corridor`` are not used.
"""
from __future__ import annotations

import argparse
import itertools
import math
import os
import tomllib
import warnings
from importlib import resources

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pandas as pd
from tqdm import tqdm

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.experiment_qp import truth_on_grid
from trackroom.estimators import get
from trackroom.metrics.crb import trajectory_crb
from trackroom.scenes.loader import parse_scene

LAYOUTS = ("hall", "corridor")
PRIORS = ("paper", "identified")
CAMERAS = (2, 3, 4, 6, 8)
FOVS = (40, 60, 90, 120)
SPEEDS = (0.6, 1.2, 1.8)
QUICK = {"cameras": (2, 4, 8), "fovs": (40, 120), "speeds": (1.2,), "seeds": 2}
SEED0, ID_SEED0, ID_SEEDS = 200, 900, 4
HALL_DURATION = 60.0  # s, as the bearing_hall study (scripts.experiment_qp)
CORRIDOR_LENGTH = 24.0  # m walked in a corridor run: duration = CORRIDOR_LENGTH / speed
RESOLUTION = (320, 240)
Q_POS_FLOOR = 1e-6  # m^2/s: the identified q_pos is at least this (the walkers' paths are smooth)


def _bundled(name: str) -> dict:
    return tomllib.loads(resources.files("trackroom.scenes").joinpath(f"{name}.toml").read_text())


def fovy_deg(fovx_deg: float, resolution=RESOLUTION) -> float:
    """The vertical field of view (deg) that gives horizontal field of view ``fovx_deg`` on square pixels."""
    w, h = resolution
    return math.degrees(2 * math.atan(math.tan(math.radians(fovx_deg) / 2) * h / w))


def _camera(name, xy, yaw_deg, fov):
    return {"name": name, "kind": "horizontal", "position": [round(float(xy[0]), 4), round(float(xy[1]), 4), 1.5],
            "yaw_deg": round(float(yaw_deg), 4), "fovy_deg": round(fovy_deg(fov), 4), "resolution": list(RESOLUTION), "fps": 4}


def hall_cameras(n: int, fov: float, side: float = 10.0, inset: float = 0.06) -> list[dict]:
    """N cameras at equal steps along the square outline (starting at the south wall's middle,
    counter-clockwise), each looking into the room along the wall ahead of it (N = 4, 39 deg:
    bearing_hall's cameras, to half a degree)."""
    per = 4 * side
    cams = []
    for i in range(n):
        s = (side / 2 + i * per / n) % per
        wall, a = int(s // side), s % side
        a = min(max(a, 1.0), side - 1.0)  # not in a corner
        # wall 0 south (x = a), 1 east (y = a), 2 north (x = side - a), 3 west (y = side - a)
        xy = [(a, inset), (side - inset, a), (side - a, side - inset), (inset, side - a)][wall]
        normal = (90.0, 180.0, 270.0, 0.0)[wall]  # inward normal of the wall, deg
        cams.append(_camera(f"cam{i}", xy, normal + 90.0 - fov / 2 - 5.0, fov))
    return cams


def corridor_cameras(n: int, fov: float, x0: float = 2.0, x1: float = 20.0, width: float = 5.0, inset: float = 0.06):
    """N cameras spread evenly over x0 ... x1 (at x0 + (i + 1/2) (x1 - x0) / N), alternately on the
    south and north wall, looking across (N = 3, 58 deg: bearing_corridor's cameras)."""
    cams = []
    for i in range(n):
        x = x0 + (i + 0.5) * (x1 - x0) / n
        south = i % 2 == 0
        cams.append(_camera(f"cam{i}", (x, inset if south else width - inset), 90.0 if south else 270.0, fov))
    return cams


def layout_scene(layout: str, n: int, fov: float, speed: float):
    """The scene of one cell: the bundled scene with N cameras of field of view ``fov`` (deg) and
    the walker at ``speed`` (m/s)."""
    if layout == "hall":
        raw = _bundled("bearing_hall")
        raw["cameras"] = hall_cameras(n, fov)
        raw["walkers"]["speed"] = [speed, speed]
    elif layout == "corridor":
        raw = _bundled("bearing_corridor")
        raw["cameras"] = corridor_cameras(n, fov)
        raw["walkers"]["people"][0]["speed"] = [speed, speed]
    else:
        raise ValueError(f"layout must be one of {LAYOUTS}, got {layout!r}")
    raw["scene"]["name"] = f"{layout}_n{n}_fov{fov:g}_v{speed:g}"
    return parse_scene(raw, f"sweep:{raw['scene']['name']}")


def duration_of(layout: str, speed: float) -> float:
    return HALL_DURATION if layout == "hall" else float(np.ceil(4 * CORRIDOR_LENGTH / speed) / 4)


def overlap_share(scene, step: float = 0.1) -> tuple[float, float]:
    """(share of the free floor seen by >= 2 cameras, share seen by >= 1): horizontal fields of view
    on a grid of the floor at least 0.2 m from walls (the layouts have no interior walls)."""
    fp = scene.floorplan
    x0, y0, x1, y1 = fp.bounds()
    g = np.stack(np.meshgrid(np.arange(x0 + 0.1, x1, step), np.arange(y0 + 0.1, y1, step)), -1).reshape(-1, 2)
    g = g[fp.clearance(g) > 0.2]
    seen = np.stack([c.in_horizontal_fov(g) for c in scene.cameras]).sum(axis=0)
    return float((seen >= 2).mean()), float((seen >= 1).mean())


def identify_prior(layout: str, speed: float, dt: float = 0.25, seeds=range(ID_SEED0, ID_SEED0 + ID_SEEDS)) -> tuple[float, float]:
    """Gauss-Markov (q_pos, q_vel) of the layout's walker at ``speed``, by moments of its true paths
    on the camera grid (step dt) over ``seeds``: per axis, v_{k+1} - v_k ~ N(0, q_vel dt) and
    x_{k+1} - x_k - dt v_k ~ N(0, q_pos dt + q_vel dt^3 / 3) (the exact discretisation the
    estimator uses, ``qp_model.process_covariance``)."""
    from trackroom.sim.walkers import plan_trajectories

    scene = layout_scene(layout, 2, 40.0, speed)  # the walker does not depend on the cameras
    dv2, dx2, n = 0.0, 0.0, 0
    for s in seeds:
        tr = plan_trajectories(scene, duration_of(layout, speed), np.random.default_rng(s))
        stride = int(round(dt * tr.rate))
        x, v = tr.pos[0, ::stride, :2], tr.vel[0, ::stride, :2]
        dv2 += float(np.sum(np.diff(v, axis=0) ** 2))
        dx2 += float(np.sum((x[1:] - x[:-1] - dt * v[:-1]) ** 2))
        n += 2 * (len(x) - 1)
    q_vel = dv2 / n / dt
    q_pos = max(dx2 / n / dt - q_vel * dt**2 / 3, Q_POS_FLOOR)
    return q_pos, q_vel


def walker_errors(rec, params: dict[str, dict]) -> dict:
    """Per parameter set of ``params`` (name -> ``qp_smoother`` parameters): ``rmse_<name>``, the
    position RMSE (m, every frame of the recording) on the recording's first walker, and
    ``sqrt_crb_<name>``, sqrt(CRB) (m) of that walker's observation pattern under the same prior."""
    w = rec.meta["walkers"][0]
    cal, obs = rec.calibration, rec.observations
    b = obs["bearings"]
    b = b[b.label == w["color"]]
    dt = 1.0 / max(c.fps for c in cal.cameras.values())
    T = int(round(obs.duration / dt))
    xy = truth_on_grid(rec, w["name"], dt, T)
    out = {"n_obs": len(b), "cameras_seen": int(b.camera.nunique())}
    k = np.rint(b.t.to_numpy() / dt).astype(int)
    for name, p in params.items():
        if b.empty:
            out[f"rmse_{name}"] = out[f"sqrt_crb_{name}"] = float("nan")
            continue
        est = get("qp_smoother")(**p)
        c = est.config
        sigma = c.sigma_px if c.sigma_px is not None else float(cal.noise.get("bearing_sigma_px", 1.0))
        out[f"sqrt_crb_{name}"] = trajectory_crb(xy, k, b.camera.to_numpy(object), cal.cameras, sigma, dt, c.q_pos, c.q_vel,
                                                 (c.first_pos_sigma, c.first_vel_sigma) * 2).sqrt_crb
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tr = est.estimate(obs, cal)
        tr = tr[tr.track_id == w["color"]]
        e2 = np.sum((np.c_[tr.x, tr.y] - xy) ** 2, axis=1)
        out[f"rmse_{name}"] = float(np.sqrt(np.nanmean(e2)))
        out[f"converged_{name}"] = bool(est.diagnostics_[w["color"]]["converged"])
    return out


def run_cell(layout: str, n: int, fov: float, speed: float, seed: int, q_id: tuple[float, float]) -> dict:
    from trackroom.sim.simulate import simulate

    scene = layout_scene(layout, n, fov, speed)
    row = {"layout": layout, "cameras": n, "fov_deg": fov, "speed": speed, "seed": seed, "q_pos_id": q_id[0], "q_vel_id": q_id[1]}
    try:
        rec = simulate(scene, seed, duration_of(layout, speed))
    except ValueError as e:  # no plan for the walker: reported, not hidden
        return {**row, "note": f"simulation failed: {e}"}
    params = {"paper": {}, "identified": {"q_pos": q_id[0], "q_vel": q_id[1]}}
    return {**row, **walker_errors(rec, params)}


def _run(args):
    return run_cell(*args)


def summary_table(df: pd.DataFrame) -> pd.DataFrame:
    """Median over seeds per cell (layout, cameras, fov_deg, speed)."""
    cols = [f"{m}_{p}" for p in PRIORS for m in ("rmse", "sqrt_crb")] + ["cameras_seen"]
    g = df.groupby(["layout", "cameras", "fov_deg", "speed"])
    out = g[cols].median()
    out["runs"] = g.size()
    out["overlap"] = g["overlap"].first()
    return out.reset_index()


def plot(summary: pd.DataFrame, path: str, target: float = 0.3) -> None:
    """Heat maps of median RMSE, cameras (rows of a map) x field of view (columns), one map per
    layout, prior and walker speed; each cell reads RMSE / sqrt(CRB) (m), the bound under the
    identified prior (the walker's own Gauss-Markov model, whichever prior the estimator used); a
    cell whose views overlap (some floor seen by >= 2 cameras) is hatched, and one within ``target``
    (m) without overlap, where the paper's claim holds, is outlined in red."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    layouts = [l for l in LAYOUTS if l in set(summary.layout)]
    speeds = sorted(set(summary.speed))
    cams, fovs = sorted(set(summary.cameras)), sorted(set(summary.fov_deg))
    rows = [(l, p) for l in layouts for p in PRIORS]
    fig, axs = plt.subplots(len(rows), len(speeds), figsize=(3.6 * len(speeds) + 1.4, 3.2 * len(rows)), squeeze=False,
                            constrained_layout=True)
    norm = LogNorm(vmin=0.05, vmax=10.0)
    im = None
    for (r, (layout, prior)), (c, speed) in itertools.product(enumerate(rows), enumerate(speeds)):
        ax = axs[r, c]
        s = summary[(summary.layout == layout) & (summary.speed == speed)]
        M = np.full((len(cams), len(fovs)), np.nan)
        for _, x in s.iterrows():
            M[cams.index(x.cameras), fovs.index(x.fov_deg)] = x[f"rmse_{prior}"]
        im = ax.imshow(M, origin="lower", cmap="viridis_r", norm=norm, aspect="auto")
        for _, x in s.iterrows():
            i, j = cams.index(x.cameras), fovs.index(x.fov_deg)
            v = x[f"rmse_{prior}"]
            ax.text(j, i, f"{v:.2f}\n/{x.sqrt_crb_identified:.2f}", ha="center", va="center", fontsize=6.5,
                    color="white" if np.isfinite(v) and v > 1.0 else "black")
            if x.overlap > 0:
                ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch="///", edgecolor="0.55", lw=0))
            elif v <= target:
                ax.add_patch(plt.Rectangle((j - 0.46, i - 0.46), 0.92, 0.92, fill=False, edgecolor="red", lw=1.6))
        ax.set_xticks(range(len(fovs)), [f"{f:g}" for f in fovs], fontsize=7)
        ax.set_yticks(range(len(cams)), [str(n) for n in cams], fontsize=7)
        ax.set_xlabel("horizontal field of view (deg)", fontsize=7)
        ax.set_ylabel("cameras", fontsize=7)
        ax.set_title(f"{layout}, {prior} prior, walker {speed:g} m/s", fontsize=8)
    fig.colorbar(im, ax=axs, shrink=0.5, label="median RMSE (m)")
    fig.suptitle("qp_smoother alone: median position RMSE over seeds / median sqrt(CRB) under the identified prior (m)\n"
                 f"hatched: views overlap (some floor seen by >= 2 cameras); red: <= {target:g} m with no overlap",
                 fontsize=9)
    from trackroom.dataset import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"a small grid: cameras {QUICK['cameras']}, fields of view "
                                                         f"{QUICK['fovs']}, speed {QUICK['speeds']}, {QUICK['seeds']} seeds")
    ap.add_argument("--seeds", type=int, default=6, help="seeds per cell (200, 201, ...)")
    ap.add_argument("--layouts", default=",".join(LAYOUTS))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=None, help="CSV of every run (default docs/bearing_layout_sweep[_quick].csv)")
    ap.add_argument("--plot", default=None, help="PNG (default docs/img/bearing_layout_sweep[_quick].png)")
    ap.add_argument("--from-csv", metavar="CSV", help="redraw the plot and table from an earlier run's CSV (runs nothing)")
    args = ap.parse_args(argv)
    if args.from_csv:
        summ = summary_table(pd.read_csv(args.from_csv))
        plot(summ, args.plot or "docs/img/bearing_layout_sweep.png")
        print(summ.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
        return 0
    layouts = [l.strip() for l in args.layouts.split(",") if l.strip()]
    bad = sorted(set(layouts) - set(LAYOUTS))
    if bad:
        ap.error(f"--layouts: unknown {bad}; choose from {LAYOUTS}")
    if args.seeds < 1 or args.jobs < 1:
        ap.error("--seeds and --jobs must be at least 1")
    cams, fovs, speeds, n_seeds = (QUICK["cameras"], QUICK["fovs"], QUICK["speeds"], QUICK["seeds"]) if args.quick \
        else (CAMERAS, FOVS, SPEEDS, args.seeds)
    tag = "_quick" if args.quick else ""
    out = args.out or f"docs/bearing_layout_sweep{tag}.csv"
    png = args.plot or f"docs/img/bearing_layout_sweep{tag}.png"
    q_id = {(l, v): identify_prior(l, v) for l in layouts for v in speeds}
    for (l, v), q in q_id.items():
        print(f"identified prior, {l} walker at {v:g} m/s: q_pos = {q[0]:.2e} m^2/s, q_vel = {q[1]:.2e} m^2/s^3")
    tasks = [(l, n, f, v, SEED0 + s, q_id[(l, v)]) for l in layouts for n in cams for f in fovs for v in speeds
             for s in range(n_seeds)]
    if args.jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs) as ex:
            rows = list(tqdm(ex.map(_run, tasks, chunksize=2), total=len(tasks), desc="runs"))
    else:
        rows = [_run(t) for t in tqdm(tasks, desc="runs")]
    df = pd.DataFrame(rows)
    overlap = {(l, n, f): overlap_share(layout_scene(l, n, f, speeds[0]))[0] for l in layouts for n in cams for f in fovs}
    df["overlap"] = [overlap[(r.layout, r.cameras, r.fov_deg)] for r in df.itertuples()]
    from trackroom.dataset import atomic_write

    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    atomic_write(out, lambda tmp: df.to_csv(tmp, index=False))
    summ = summary_table(df)
    os.makedirs(os.path.dirname(png) or ".", exist_ok=True)
    plot(summ, png)
    pd.set_option("display.width", 200)
    print(summ.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    failed = df["note"].notna().sum() if "note" in df else 0
    print(f"{len(df)} runs ({failed} failed to simulate) -> {out}, {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
