"""The camera + phone fusion study (issue 13): bearing_hall, qp_smoother / EKF+RTS / fusion_smoother.

For each seed and walker model (the scene's default random walk, ``default``, and the
Gauss-Markov walker, ``gauss_markov``): bearing_hall simulated for ``--duration`` s with its
default (fitted) analytic sensing and every walker carrying a phone; then, side by side,

- ``qp``: ``qp_smoother`` with its defaults (the paper's prior); for the Gauss-Markov walker also
  ``qp_matched``, given the walker's own prior;
- ``ekf_rts``: the EKF baseline with the RTS pass (its track nearest the truth at each step:
  optimistic for the baseline);
- ``fusion``: ``fusion_smoother`` with its defaults (``--param key=value`` overrides);
- ``qp_one_camera`` and ``fusion_one_camera``: the same given only the bearings of the camera
  that saw the walker most (the others removed): Rahimi Fig. 1a.

Per run: RMSE over every camera frame of the recording, the claimed phone, the estimated step
length and heading offset, the solve's convergence and time, and the trajectory CRB without and
with the phone (``metrics.crb``, at the estimator's prior; the walker's own prior is not known to
it), each for the observation pattern the variant was given. Development seeds (tuning) and
evaluation seeds (reported) are kept apart: docs/fusion_smoother.md.

    python -m scripts.experiment_fusion --first-seed 0 --seeds 20 --jobs 2 --out docs/fusion_experiment.csv
    python -m scripts.experiment_fusion --people 3,4,5 --first-seed 0 --seeds 4 --jobs 2 --out docs/fusion_people.csv
    python -m scripts.experiment_fusion --office --first-seed 0 --seeds 10 --jobs 2 --out docs/fusion_office.csv
"""
from __future__ import annotations

import argparse
import os
import time
import warnings

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd
from tqdm import tqdm

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.estimators import get
from trackroom.recording import Observations
from trackroom.scenes.loader import load_scene
from scripts.experiment_qp import truth_on_grid

WALKERS = {"default": [], "gauss_markov": ['walkers.motion="gauss_markov"']}
VARIANTS = ("qp", "qp_matched", "ekf_rts", "fusion", "qp_one_camera", "fusion_one_camera")


def parse_params(items) -> dict:
    out = {}
    for item in items or ():
        k, v = item.split("=", 1)
        try:
            out[k] = float(v) if any(ch in v for ch in ".e") else int(v)
        except ValueError:
            out[k] = {"true": True, "false": False}.get(v, v)
    return out


def rmse_on_grid(tracks: pd.DataFrame, xy: np.ndarray, dt: float) -> float:
    k = np.rint(tracks.t.to_numpy() / dt).astype(int)
    ok = (k >= 0) & (k < len(xy))
    e2 = np.sum((np.c_[tracks.x, tracks.y][ok] - xy[k[ok]]) ** 2, axis=1)
    return float(np.sqrt(np.nanmean(e2)))


def crb_pair(rec, xy: np.ndarray, vxy: np.ndarray, b: pd.DataFrame, dt: float, params: dict, phone_id: str | None):
    """sqrt(CRB) (m) of the fusion smoother's model without and with the phone (``metrics.crb``),
    for the bearings ``b`` and the phone's own walking / cadence pattern, at the estimator's prior."""
    from trackroom.metrics.crb import PhoneRows, trajectory_crb_phone

    est = get("fusion_smoother")(**params)
    c = est.config
    cal = rec.calibration
    T = len(xy)
    k = np.rint(b.t.to_numpy() / dt).astype(int)
    sigma = c.sigma_px if c.sigma_px is not None else float(cal.noise.get("bearing_sigma_px", 1.0))
    args = (xy, vxy, k, b.camera.to_numpy(object), cal.cameras, sigma, dt, c.q_pos, c.q_vel)
    kw = dict(first_sigma=(c.first_pos_sigma, c.first_vel_sigma, c.first_pos_sigma, c.first_vel_sigma),
              discretisation=c.discretisation)
    without = trajectory_crb_phone(*args, None, **kw).sqrt_crb
    if not phone_id:
        return without, float("nan")
    m = est.phone_motions(rec.observations, cal, (np.arange(T) + 0.5) * dt)[phone_id]
    fac = est.factors(m, T)
    walking = np.zeros(T, bool)
    walking[fac.kw] = True
    cadence = np.full(T, np.nan)
    cadence[fac.kw] = fac.f
    dsdl = np.zeros(T)
    dsdl[fac.kw[fac.ia]] = fac.g
    sa, sc = np.ones(T), np.ones(T)
    sa[fac.kw], sc[fac.kw] = fac.sig_a, fac.sig_c
    measured = np.isfinite(cadence)
    rows = PhoneRows(walking=walking, cadence=cadence, sigma_a=sa, sigma_c=sc, sigma_stop=c.stop_sigma,
                     sigma_l=c.step_length_sigma, sigma_delta=np.radians(c.offset_sigma_deg),
                     loose=measured[1:] & measured[:-1], q_vel_phone=c.q_vel_phone, dspeed_dl=dsdl)
    return without, trajectory_crb_phone(*args, rows, **kw).sqrt_crb


def run_seed(seed: int, walker: str, duration: float, params: dict, which=VARIANTS, overrides=()) -> list[dict]:
    from trackroom.sim.simulate import simulate

    scene = load_scene("bearing_hall", [*WALKERS[walker], *overrides])
    try:
        rec = simulate(scene, seed, duration)
    except ValueError as e:
        return [{"seed": seed, "walker": walker, "variant": "simulation_failed", "note": str(e)}]
    w = rec.meta["walkers"][0]
    label, person = w["color"], w["name"]
    cal, obs = rec.calibration, rec.observations
    b = obs["bearings"]
    b = b[b.label == label]
    if b.empty:
        return [{"seed": seed, "walker": walker, "variant": "unobserved"}]
    dt = 1.0 / max(c.fps for c in cal.cameras.values())
    T = int(round(duration / dt))
    xy = truth_on_grid(rec, person, dt, T)
    vxy = truth_on_grid(rec, person, dt, T, ("vx", "vy"))
    one = str(b.camera.value_counts().idxmax())
    bv = obs["bearings"]
    obs_one = Observations({**obs.tables, "bearings": bv[bv.camera == one].reset_index(drop=True)}, obs.duration)
    base = {"seed": seed, "walker": walker, "n_cameras": int(b.camera.nunique()), "n_obs": len(b), "phone_true": w["phone_id"]}
    gm = w.get("gauss_markov") or {}
    runs = {
        "qp": ("qp_smoother", {}, obs),
        "qp_matched": ("qp_smoother", {"q_pos": gm.get("q_pos"), "q_vel": gm.get("q_vel")}, obs) if gm else None,
        "ekf_rts": ("ekf", {"smooth": True}, obs),
        "fusion": ("fusion_smoother", params, obs),
        "qp_one_camera": ("qp_smoother", {}, obs_one),
        "fusion_one_camera": ("fusion_smoother", params, obs_one),
    }
    rows = []
    for name in which:
        spec = runs.get(name)
        if spec is None:
            continue
        est_name, kw, o = spec
        est = get(est_name)(**kw)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tr = est.estimate(o, cal)
        secs = time.perf_counter() - t0
        row = dict(base, variant=name, seconds=secs)
        if name.endswith("one_camera"):
            row.update(n_cameras=1, one_camera=one, n_obs=int((b.camera == one).sum()))
        if est_name == "ekf":
            k = np.rint(tr.t.to_numpy() / dt).astype(int)
            ok = k < T
            d2 = np.sum((np.c_[tr.x, tr.y][ok] - xy[k[ok]]) ** 2, axis=1)
            best = pd.Series(d2).groupby(k[ok]).min()
            row.update(rmse=float(np.sqrt(best.mean())) if len(best) else float("nan"), coverage=len(best) / T)
        else:
            tr = tr[tr.track_id == label]
            row["rmse"] = rmse_on_grid(tr, xy, dt)
            d = est.diagnostics_.get(label, {})
            row.update(converged=d.get("converged"), iterations=d.get("iterations"))
            if est_name == "fusion_smoother":
                mism = d.get("mismatch", {})
                row.update(phone=d.get("phone_id", ""), step_length=d.get("step_length"),
                           heading_offset_deg=d.get("heading_offset_deg"),
                           mismatch_per_bearing=mism.get(w["phone_id"], float("nan")) / max(1, row["n_obs"]))
                bb = b if name == "fusion" else b[b.camera == one]
                c0, c1 = crb_pair(rec, xy, vxy, bb, dt, params, w["phone_id"] or None)
                row.update(sqrt_crb_no_phone=c0, sqrt_crb_phone=c1)
        rows.append(row)
    return rows


def run_people(seed: int, people: int, duration: float, params: dict, overrides=()) -> list[dict]:
    """Several people with phones and appearance labels in bearing_hall: one row per label with
    the phone it claimed, the phone its person carries, and its RMSE."""
    from trackroom.sim.simulate import simulate

    scene = load_scene("bearing_hall", [f"walkers.count={people}", *overrides])
    rec = simulate(scene, seed, duration)
    cal, obs = rec.calibration, rec.observations
    dt = 1.0 / max(c.fps for c in cal.cameras.values())
    T = int(round(duration / dt))
    est = get("fusion_smoother")(**params)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        tr = est.estimate(obs, cal)
    secs = time.perf_counter() - t0
    rows = []
    for w in rec.meta["walkers"]:
        label = w["color"]
        t = tr[tr.track_id == label]
        if t.empty:
            continue
        d = est.diagnostics_.get(label, {})
        xy = truth_on_grid(rec, w["name"], dt, T)
        rows.append({"seed": seed, "people": people, "label": label, "phone_true": w["phone_id"],
                     "phone": d.get("phone_id", ""), "frames": len(t), "rmse": rmse_on_grid(t, xy, dt),
                     "n_obs": int((obs["bearings"].label == label).sum()), "seconds": secs})
    return rows


def run_office(seed: int, duration: float, params: dict) -> list[dict]:
    """office_floor (corridor and rooms, its scripted loop varied by the seed): qp_smoother with
    walls against fusion_smoother with walls."""
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("office_floor"), seed, duration)
    w = rec.meta["walkers"][0]
    dt = 1.0 / max(c.fps for c in rec.calibration.cameras.values())
    xy = truth_on_grid(rec, w["name"], dt, int(round(duration / dt)))
    rows = []
    for name, est_name, kw in (("qp_walls", "qp_smoother", {"walls": True}),
                               ("fusion_walls", "fusion_smoother", {**params, "walls": True})):
        est = get(est_name)(**kw)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tr = est.estimate(rec.observations, rec.calibration)
        tr = tr[tr.track_id == w["color"]]
        d = est.diagnostics_.get(w["color"], {})
        rows.append({"seed": seed, "variant": name, "rmse": rmse_on_grid(tr, xy, dt), "phone": d.get("phone_id", ""),
                     "outside": int((~rec.calibration.floorplan.inside(np.c_[tr.x, tr.y])).sum()),
                     "seconds": time.perf_counter() - t0})
    return rows


def summarise_people(df: pd.DataFrame) -> str:
    lines = ["| people | runs | labels | claimed labels | claims correct (of claimed frames) | median RMSE (m) | median s per run |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for n, g in df.groupby("people"):
        claimed = g[g.phone.fillna("") != ""]
        frames = claimed.frames.sum()
        correct = claimed[claimed.phone == claimed.phone_true].frames.sum()
        lines.append(f"| {n} | {g.seed.nunique()} | {len(g)} | {len(claimed)} | {correct / max(frames, 1):.3f} ({correct}/{frames}) | "
                     f"{g.rmse.median():.2f} | {g.groupby('seed').seconds.first().median():.1f} |")
    return "\n".join(lines)


def summarise(df: pd.DataFrame) -> str:
    ok = df[~df.variant.isin(("simulation_failed", "unobserved"))]
    lines = ["| walker | variant | runs | median RMSE (m) | mean RMSE (m) | 90th pct RMSE (m) | median sqrt(CRB) no phone / phone (m) | phone claimed | median s |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for (wk, v), g in ok.groupby(["walker", "variant"], sort=False):
        crb = ""
        if "sqrt_crb_phone" in g and g.sqrt_crb_phone.notna().any():
            crb = f"{g.sqrt_crb_no_phone.median():.2f} / {g.sqrt_crb_phone.median():.2f}"
        claimed = ""
        if "phone" in g and g.phone.notna().any():
            claimed = f"{int((g.phone.fillna('') == g.phone_true).sum())}/{len(g)}"
        lines.append(f"| {wk} | {v} | {len(g)} | {g.rmse.median():.2f} | {g.rmse.mean():.2f} | {g.rmse.quantile(0.9):.2f} | "
                     f"{crb} | {claimed} | {g.seconds.median():.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--walkers", default="default,gauss_markov")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="fusion_smoother parameter")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="scene override")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--office", action="store_true", help="office_floor instead: walls alone vs walls + phone")
    ap.add_argument("--people", default="", help="several people instead, e.g. 3,4,5 (phone matching)")
    ap.add_argument("--out", default="docs/fusion_experiment.csv")
    args = ap.parse_args(argv)
    params = parse_params(args.param)
    if args.office:
        from concurrent.futures import ProcessPoolExecutor

        seeds = range(args.first_seed, args.first_seed + args.seeds)
        with ProcessPoolExecutor(max(1, args.jobs)) as ex:
            rows = [r for f in tqdm([ex.submit(run_office, s, args.duration, params) for s in seeds]) for r in f.result()]
        df = pd.DataFrame(rows)
        df.to_csv(args.out, index=False)
        for v, g in df.groupby("variant", sort=False):
            print(f"office_floor {v}: median RMSE {g.rmse.median():.2f} m, mean {g.rmse.mean():.2f} m over {len(g)} seeds; "
                  f"points outside the floor plan {int(g.outside.sum())}; phone claimed {int((g.phone != '').sum())}/{len(g)}")
        return 0
    if args.people:
        counts = [int(n) for n in args.people.split(",")]
        tasks = [(s, n) for n in counts for s in range(args.first_seed, args.first_seed + args.seeds)]
        rows = []
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max(1, args.jobs)) as ex:
            futs = [ex.submit(run_people, s, n, args.duration, params, tuple(args.set)) for s, n in tasks]
            for f in tqdm(futs):
                rows += f.result()
        df = pd.DataFrame(rows)
        os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
        df.to_csv(args.out, index=False)
        print(summarise_people(df))
        return 0
    walkers = [w.strip() for w in args.walkers.split(",") if w.strip()]
    which = tuple(v.strip() for v in args.variants.split(",") if v.strip())
    bad = sorted(set(walkers) - set(WALKERS)) + sorted(set(which) - set(VARIANTS))
    if bad:
        ap.error(f"unknown walker or variant {bad}")
    params = parse_params(args.param)
    tasks = [(s, w) for w in walkers for s in range(args.first_seed, args.first_seed + args.seeds)]
    rows = []
    if args.jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs) as ex:
            futs = [ex.submit(run_seed, s, w, args.duration, params, which, tuple(args.set)) for s, w in tasks]
            for f in tqdm(futs):
                rows += f.result()
    else:
        for s, w in tqdm(tasks):
            rows += run_seed(s, w, args.duration, params, which, tuple(args.set))
    df = pd.DataFrame(rows)
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    df.to_csv(args.out, index=False)
    print(summarise(df))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
