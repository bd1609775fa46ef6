"""The matched-prior study of the QP smoother (issue 5), with the CRB as yardstick.

For each seed: a ``gauss_markov`` walker on ``bearing_hall`` (process noise ``--q`` large enough
that the path turns inside the room), simulated for 60 s with analytic 4 Hz bearings; the
estimator is handed the walker's own Gauss-Markov parameters from ``recording.meta["walkers"]``.
Variants: the paper's method (field-of-view constraints), without constraints, with walls, the
paper's method given only the bearings of ONE camera (the one that saw the person most: one
camera cannot fix depth, the observability limit the README must show), and the EKF baseline
(plain and RTS-smoothed). Per run: RMSE on the camera frame grid, the trajectory CRB
(``metrics.crb``) for the observation pattern the variant was given, RMSE split by how many
cameras saw the person at each time (truth ``visibility``: 0, 1, >= 2; for the one-camera
variant only that camera counts), the depth bias at the times a single camera saw the person
(mean of estimated minus true distance from that camera: negative = collapsed towards it),
convergence and osqp statuses, points outside the room. ``oracle`` (not an estimator: it
linearises at the truth, ``oracle_linearised``) splits RMSE / sqrt(CRB) into the MAP's
non-linearity and the rest. ``--set`` adds scene overrides (e.g. the walls moved far out),
``--variants`` picks a subset.

    python -m scripts.experiment_qp --seeds 24 --out docs/qp_experiment.csv
"""
from __future__ import annotations

import argparse
import os
import warnings

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd
from tqdm import tqdm

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.estimators import get
from trackroom.metrics.crb import trajectory_crb
from trackroom.scenes.loader import load_scene
from trackroom.recording import Observations

FIRST = (100.0, 10.0, 100.0, 10.0)  # the estimator's default weak first-state prior


def truth_on_grid(rec, person: str, dt: float, T: int, cols=("x", "y")) -> np.ndarray:
    p = rec.truth.people
    p = p[p.person_id == person]
    k = np.rint(p.t.to_numpy() / dt)
    on = np.abs(p.t.to_numpy() - k * dt) < 1e-6
    xy = np.full((T, 2), np.nan)
    kk = k[on].astype(int)
    ok = kk < T
    xy[kk[ok]] = p[list(cols)].to_numpy()[on][ok]
    return xy


def cameras_seeing(rec, person: str, dt: float, T: int, cameras=None) -> np.ndarray:
    """(T,) how many cameras (of ``cameras``; all when None) had the person visible at each step."""
    v = rec.truth.visibility
    v = v[(v.person_id == person) & v.visible.astype(bool)]
    if cameras is not None:
        v = v[v.camera.isin(list(cameras))]
    k = np.rint(v.t.to_numpy(float) / dt).astype(int)
    cam = pd.factorize(v.camera.to_numpy(object))[0]
    on = (k >= 0) & (k < T)
    if not on.any():
        return np.zeros(T, int)
    pairs = np.unique(np.c_[k[on], cam[on]], axis=0)  # one count per (step, camera)
    return np.bincount(pairs[:, 0], minlength=T)


GROUPS = (("cam0", 0, 0), ("cam1", 1, 1), ("cam2plus", 2, 10**9))


def split_errors(e2: np.ndarray, seen: np.ndarray) -> dict:
    """Sum of squared errors and step count per camera-count group (pooled RMSE = sqrt(sse / n))."""
    out = {}
    ok = np.isfinite(e2)
    for name, lo, hi in GROUPS:
        m = ok & (seen >= lo) & (seen <= hi)
        out[f"sse_{name}"] = float(e2[m].sum())
        out[f"n_{name}"] = int(m.sum())
        out[f"rmse_{name}"] = float(np.sqrt(e2[m].mean())) if m.any() else float("nan")
    return out


def depth_bias(tr_xy: np.ndarray, xy: np.ndarray, cam, steps: np.ndarray) -> float:
    """Mean (estimated - true) floor distance from camera ``cam`` over ``steps`` (m)."""
    if not len(steps):
        return float("nan")
    p = np.asarray(cam.position, float)[:2]
    return float(np.nanmean(np.linalg.norm(tr_xy[steps] - p, axis=1) - np.linalg.norm(xy[steps] - p, axis=1)))


def behind_cameras(txy: np.ndarray, bearings: pd.DataFrame, cameras, dt: float, z_h: float = 0.9) -> int:
    """Observed (step, camera) pairs whose estimate lies behind the camera that saw it (n^T (x - p) < 0)."""
    n = 0
    for name, g in bearings.groupby("camera"):
        P = np.asarray(cameras[name].P, float)
        k = np.unique(np.rint(g.t.to_numpy(float) / dt).astype(int))
        depth = txy[k] @ P[2, :2] + P[2, 2] * z_h + P[2, 3]
        n += int((depth < 0).sum())
    return n


def oracle_linearised(xy: np.ndarray, vxy: np.ndarray, b: pd.DataFrame, k: np.ndarray, cameras, sigma: float,
                      dt: float, q: tuple[float, float], centre) -> np.ndarray:
    """NOT an estimator (it uses the truth): the linear-Gaussian smoother with every bearing
    linearised at the TRUE state, X^ = J_X^{-1} (G^T g + sum_j H_j^T (y_j - u_j(s*) + H_j s*) / sigma^2),
    J_X the information of ``metrics.crb`` (same prior, first-state prior and H_j). Were the paths
    drawn from the prior independently of the observation pattern and u linear near the truth, its
    mean squared error averaged over paths would be exactly the CRB. So RMSE(MAP) / RMSE(oracle)
    measures what the bearing model's non-linearity costs the MAP, and RMSE(oracle) / sqrt(CRB)
    everything else: the walker's room conditioning and the selection of paths by their
    observation pattern (``scripts.crb_montecarlo``). Returns (T, 2) positions."""
    from trackroom.estimators.qp_model import IX, IY, NS, Bearings, Prior
    from trackroom.scenes.spec import GaussMarkovParams
    from scripts.crb_montecarlo import oracle

    T = len(xy)
    prior = Prior.build(T, dt, GaussMarkovParams(*q), first_mean=(centre[0], 0.0, centre[1], 0.0), first_sigma=FIRST)
    S = np.zeros((T, NS))
    S[:, IX], S[:, 1], S[:, IY], S[:, 3] = xy[:, 0], vxy[:, 0], xy[:, 1], vxy[:, 1]
    obs = Bearings.from_arrays(k, b.camera.to_numpy(object), b.u.to_numpy(float), cameras, sigma)
    X = oracle(prior, obs, obs.u, S)
    return np.c_[X[IX::NS], X[IY::NS]]


QP_VARIANTS = ("qp", "qp_unconstrained", "qp_walls", "qp_one_camera")
ALL_VARIANTS = QP_VARIANTS + ("oracle", "ekf", "ekf_rts")


def run_seed(seed: int, q: tuple[float, float], duration: float, overrides: tuple[str, ...] = (),
             which: tuple[str, ...] = ALL_VARIANTS) -> list[dict]:
    from trackroom.sim.simulate import simulate

    scene = load_scene("bearing_hall", ['walkers.motion="gauss_markov"', f"walkers.process_noise=[{q[0]}, {q[1]}]",
                                        *overrides])
    try:
        rec = simulate(scene, seed, duration)
    except ValueError as e:  # the walker planner found no in-room Gauss-Markov path for this seed
        return [{"seed": seed, "variant": "simulation_failed", "note": str(e)}]
    w = rec.meta["walkers"][0]
    gm = w["gauss_markov"]
    label, person = w["color"], w["name"]
    cal, obs = rec.calibration, rec.observations
    b = obs["bearings"]
    b = b[b.label == label]
    if b.empty:  # a short run can miss every view: nothing to estimate, no bound to compare with
        return [{"seed": seed, "variant": "unobserved", "note": "no bearings of the walker"}]
    dt = 1.0 / max(c.fps for c in cal.cameras.values())
    T = int(round(duration / dt))
    xy = truth_on_grid(rec, person, dt, T)
    k = np.rint(b.t.to_numpy() / dt).astype(int)
    sigma = float(cal.noise.get("bearing_sigma_px", 1.0))
    n_cams = int(b.camera.nunique())
    base = {"seed": seed, "n_cameras": n_cams, "n_obs": len(b), "q_pos": gm["q_pos"], "q_vel": gm["q_vel"]}
    crb = trajectory_crb(xy, k, b.camera.to_numpy(object), cal.cameras, sigma, dt, gm["q_pos"], gm["q_vel"], FIRST)
    base["sqrt_crb"] = crb.sqrt_crb
    seen_all = cameras_seeing(rec, person, dt, T)
    # the one-camera variant: only the bearings of the camera that saw the person most
    one = str(b.camera.value_counts().idxmax()) if len(b) else None
    rows = []
    QP = get("qp_smoother")
    variants = {
        "qp": (dict(constraints=True), None),
        "qp_unconstrained": (dict(constraints=False), None),
        "qp_walls": (dict(constraints=True, walls=True), None),
        "qp_one_camera": (dict(constraints=True), one),
    }
    for name, (kw, only) in variants.items():
        if name not in which or (name == "qp_one_camera" and one is None):
            continue
        row = dict(base)
        obs_v, seen = obs, seen_all
        if only is not None:
            bv = obs["bearings"]
            obs_v = Observations({**obs.tables, "bearings": bv[bv.camera == only].reset_index(drop=True)}, obs.duration)
            mo = (b.camera == only).to_numpy()
            row.update(n_cameras=1, n_obs=int(mo.sum()), one_camera=only)
            row["sqrt_crb"] = trajectory_crb(xy, k[mo], b.camera.to_numpy(object)[mo], cal.cameras, sigma, dt,
                                             gm["q_pos"], gm["q_vel"], FIRST).sqrt_crb
            seen = cameras_seeing(rec, person, dt, T, [only])
        est = QP(q_pos=gm["q_pos"], q_vel=gm["q_vel"], **kw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tr = est.estimate(obs_v, cal)
        tr = tr[tr.track_id == label]
        d = est.diagnostics_.get(label, {})
        txy = np.c_[tr.x, tr.y]
        e2 = np.sum((txy - xy) ** 2, axis=1)
        rmse = float(np.sqrt(np.nanmean(e2)))
        outside = int((~cal.floorplan.inside(txy)).sum())
        behind = behind_cameras(txy, b if only is None else b[b.camera == only], cal.cameras, dt)
        # depth bias where exactly one camera saw the person, from that camera
        kb = np.rint(b.t.to_numpy() / dt).astype(int)
        single = np.nonzero(seen == 1)[0]
        cam_of = pd.Series(b.camera.to_numpy(object), index=kb)
        if only is not None:
            cam_of = cam_of[cam_of == only]
        cam_of = cam_of[~cam_of.index.duplicated()]
        biases = [depth_bias(txy, xy, cal.cameras[c], np.intersect1d(single, cam_of.index[cam_of == c]))
                  for c in cam_of.unique()]
        ns = [len(np.intersect1d(single, cam_of.index[cam_of == c])) for c in cam_of.unique()]
        bias = float(np.average(biases, weights=ns)) if sum(ns) else float("nan")
        row.update({"variant": name, "rmse": rmse, "rmse_over_crb": rmse / row["sqrt_crb"],
                    **split_errors(e2, seen), "depth_bias_1cam": bias,
                    "converged": d.get("converged"), "iterations": d.get("iterations"),
                    "qp_not_solved": d.get("qp_not_solved"), "reason": d.get("reason"), "outside_room": outside,
                    "behind_camera": behind, "seconds": d.get("seconds")})
        rows.append(row)
    if "oracle" in which:
        vxy = truth_on_grid(rec, person, dt, T, ("vx", "vy"))
        centre = np.asarray(cal.floorplan.outline, float).mean(axis=0)
        oxy = oracle_linearised(xy, vxy, b, k, cal.cameras, sigma, dt, (gm["q_pos"], gm["q_vel"]), centre)
        e2 = np.sum((oxy - xy) ** 2, axis=1)
        rmse = float(np.sqrt(np.mean(e2)))
        kb = np.rint(b.t.to_numpy() / dt).astype(int)
        single = np.nonzero(seen_all == 1)[0]
        cam_of = pd.Series(b.camera.to_numpy(object), index=kb)
        cam_of = cam_of[~cam_of.index.duplicated()]
        steps = {c: np.intersect1d(single, cam_of.index[cam_of == c]) for c in cam_of.unique()}
        ns = [len(v) for v in steps.values()]
        bias = float(np.average([depth_bias(oxy, xy, cal.cameras[c], v) for c, v in steps.items()], weights=ns)) if sum(ns) else float("nan")
        rows.append({**base, "variant": "oracle", "rmse": rmse, "rmse_over_crb": rmse / crb.sqrt_crb,
                     **split_errors(e2, seen_all), "depth_bias_1cam": bias})
    for name, kw in {"ekf": dict(), "ekf_rts": dict(smooth=True)}.items():
        if name not in which:
            continue
        tr = get("ekf")(**kw).estimate(obs, cal)
        # nearest EKF track to the truth at each grid step (optimistic for the baseline)
        kk = np.rint(tr.t.to_numpy() / dt).astype(int)
        ok = kk < T
        d2 = np.sum((np.c_[tr.x, tr.y][ok] - xy[kk[ok]]) ** 2, axis=1)
        best = pd.Series(d2).groupby(kk[ok]).min()
        rmse = float(np.sqrt(best.mean())) if len(best) else float("nan")
        e2 = np.full(T, np.nan)
        e2[best.index.to_numpy()] = best.to_numpy()
        rows.append({**base, "variant": name, "rmse": rmse, "rmse_over_crb": rmse / crb.sqrt_crb,
                     **split_errors(e2, seen_all), "coverage": len(best) / T})
    return rows


def summarise(df: pd.DataFrame) -> str:
    """Markdown table per variant (runs split by how many cameras' bearings the variant had)."""
    ok = df[~df.variant.isin(("simulation_failed", "unobserved"))]
    lines = ["| variant | cameras | runs | median RMSE (m) | median sqrt(CRB) (m) | median RMSE/sqrt(CRB) | converged |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for (v, grp), g in ok.assign(grp=np.where(ok.n_cameras >= 2, ">=2", ok.n_cameras.astype(str))).groupby(["variant", "grp"], sort=False):
        conv = f"{int(g.converged.fillna(True).astype(bool).sum())}/{len(g)}" if "converged" in g else ""
        lines.append(f"| {v} | {grp} | {len(g)} | {g.rmse.median():.3f} | {g.sqrt_crb.median():.3f} | "
                     f"{g.rmse_over_crb.median():.2f} | {conv} |")
    return "\n".join(lines)


def summarise_split(df: pd.DataFrame) -> str:
    """Markdown table: pooled RMSE over all runs' steps seen by 0, 1, >= 2 cameras, per variant."""
    ok = df[~df.variant.isin(("simulation_failed", "unobserved"))]
    lines = ["| variant | RMSE, 0 cameras (steps) | RMSE, 1 camera (steps) | RMSE, >= 2 cameras (steps) | depth bias at 1-camera steps (m) |",
             "| --- | --- | --- | --- | --- |"]
    for v, g in ok.groupby("variant", sort=False):
        cells = []
        for name, _, _ in GROUPS:
            n = int(g[f"n_{name}"].sum())
            cells.append(f"{np.sqrt(g[f'sse_{name}'].sum() / n):.2f} ({n})" if n else "- (0)")
        bias = g["depth_bias_1cam"].median() if "depth_bias_1cam" in g and g["depth_bias_1cam"].notna().any() else float("nan")
        lines.append(f"| {v} | " + " | ".join(cells) + (f" | {bias:+.2f} |" if np.isfinite(bias) else " | - |"))
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--q", type=float, nargs=2, default=(1e-4, 0.1), metavar=("Q_POS", "Q_VEL"))
    ap.add_argument("--out", default="docs/qp_experiment.csv")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="extra scene override (repeatable), e.g. room.outline=[[-40,-40],[50,-40],[50,50],[-40,50]]")
    ap.add_argument("--variants", default=",".join(ALL_VARIANTS),
                    help=f"comma-separated subset of {','.join(ALL_VARIANTS)}")
    args = ap.parse_args(argv)
    which = tuple(v.strip() for v in args.variants.split(",") if v.strip())
    bad = sorted(set(which) - set(ALL_VARIANTS))
    if bad or "qp" not in which:
        ap.error(f"--variants must include qp and name only {ALL_VARIANTS}; got {bad or which}")
    extra = tuple(args.set)
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    rows = []
    if args.jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs) as ex:
            n = len(seeds)
            for r in tqdm(ex.map(run_seed, seeds, [tuple(args.q)] * n, [args.duration] * n, [extra] * n, [which] * n), total=n):
                rows += r
    else:
        for s in tqdm(seeds):
            rows += run_seed(s, tuple(args.q), args.duration, extra, which)
    df = pd.DataFrame(rows)
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    df.to_csv(args.out, index=False)
    print(summarise(df))
    print()
    print(summarise_split(df))
    failed = (df.variant == "simulation_failed").sum()
    if failed:
        print(f"{failed} seed(s) where the simulator found no in-room Gauss-Markov path (skipped)")
    ok_seeds = df[df.variant == "qp"].seed.nunique()
    print(f"{ok_seeds} of {len(seeds)} seeds simulated")
    qp = df[df.variant == "qp"]
    multi = qp[qp.n_cameras >= 2]
    if len(multi):
        print(f"matched prior, >= 2 cameras: median RMSE {multi.rmse.median():.3f} m vs 1.5 sqrt(CRB) "
              f"{1.5 * multi.sqrt_crb.median():.3f} m; median RMSE/sqrt(CRB) = {multi.rmse_over_crb.median():.2f} (target <= 1.5)")
    ora = df[(df.variant == "oracle") & (df.n_cameras >= 2)]
    if len(ora) and len(multi):
        r = multi.set_index("seed").rmse / ora.set_index("seed").rmse.reindex(multi.seed).to_numpy()
        print(f"oracle (linearised at the truth, uses the truth): median RMSE/sqrt(CRB) = {ora.rmse_over_crb.median():.2f}; "
              f"median RMSE(qp) / RMSE(oracle) = {r.median():.2f}")
    if "qp_unconstrained" in which:
        un = df[df.variant == "qp_unconstrained"].set_index("seed").rmse
        worse = (un.reindex(qp.seed).to_numpy() >= qp.rmse.to_numpy() - 1e-6)
        print(f"without constraints worse or equal in {int(worse.sum())}/{len(qp)} runs")
    for v in ("qp", "qp_unconstrained", "qp_one_camera"):
        g = df[df.variant == v]
        if not len(g):
            continue
        print(f"{v}: observed points estimated behind the camera that saw them: {int(g.behind_camera.sum())} "
              f"in {int((g.behind_camera > 0).sum())}/{len(g)} runs")
    wl = df[df.variant == "qp_walls"]
    if len(wl):
        print(f"with walls: {int(wl.outside_room.sum())} estimated points outside the room over {len(wl)} runs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
