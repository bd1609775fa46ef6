"""Measure the target-plane tracker (Tsutsui et al.) on ``occlusion_lab``.

    python scripts/experiment_tsutsui.py [--sensing analytic|rendered|both] [--duration 60] [--seeds 0,1,2,3,4]
    python scripts/experiment_tsutsui.py --recording DIR[,DIR...]      # saved recordings (e.g. rendered ones)
    python scripts/experiment_tsutsui.py --recording DIR --window-errors    # the flow windows against the truth
    python scripts/experiment_tsutsui.py --recording "DIR/seed_4[0-9][0-9]" --table   # a glob; one line per run
    python scripts/experiment_tsutsui.py --sensing analytic --seeds 400,401 --duration 35 --table \
        --set "walkers.people.1.waypoints=[[1.0, 1.2], [5.0, 1.2]]" --param hold_s=4   # scene overrides, Config values
    python scripts/experiment_tsutsui.py --sensing analytic --seeds 100,101 --duration 35 --json --draw 2   # another perception draw
    python scripts/experiment_tsutsui.py --recording "DIR/seed_1[0-5][0-9]" --json --jobs 2   # two worker processes, same output

Rendered recordings declare the flow detector's measured window noise in their calibration
(``sim.perception_flow.RENDERED_WINDOW_NOISE``); recordings saved before that are given it here.
The eq. 8 threshold is the estimator's own parameter (``width_ratio_threshold``).

For each sensing mode it simulates the scene (occlusion_lab varies with the seed: pace, waypoints,
start phase, standing spots), runs ``target_planes`` on the target and in multi-person mode, and
prints the figures below. The target is initialised by hand, as in the paper, from a noisy click
(``click``): its true floor position at the first frame plus an error N(0, CLICK_SIGMA^2) per
axis, drawn from a stream of its own seeded by the recording's seed. Figures:

- identity held: share of output frames whose nearest true person is the target, within 1 m;
- position RMSE over frames with >= 2 reliable tracking cameras and with exactly 1 (the
  estimator's own count, the paper's "tracking cameras");
- multi-person mode: CLEAR MOT against every mover (people who walk), gate 1 m.

With several seeds it prints each run, then the mean and the worst value of each figure.
``--jobs N`` runs them in N worker processes (each reads its own recording, so a long list of
recordings is never held in memory at once); the runs are printed in the order given, with the
same figures as in one process but the timings (``sim_s``, ``estimate_s``).

Targets (issue 12): identity >= 99 % on every seed, RMSE <= 0.15 m (>= 2 cameras), <= 0.5 m (1
camera), multi-person MOTA >= 0.9 on the movers, rendered and analytic.
"""
from __future__ import annotations

import argparse
import dataclasses
import functools
import itertools
import json
import os
import sys
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import recording_folders
from trackroom.estimators.target_planes import TargetPlanes, TargetPlanesResult
from trackroom.metrics.aggregate import robust_sigma
from trackroom.metrics.score import evaluate
from trackroom.scenes.loader import load_scene
from trackroom.sim.perception_flow import RENDERED_WINDOW_NOISE
from trackroom.recording import Recording, Truth
from trackroom.sim.simulate import simulate

TARGET = "target"
# A user clicking the target's feet in the first frame: per-axis error, m. At 320x240 and 3-9 m a
# pixel is 2-5 cm on the floor, but where the feet meet the floor is ambiguous by a few pixels,
# more when the person is cut by an obstacle; 0.2 m is a careful but not exact click.
CLICK_SIGMA = 0.2
CLICK_STREAM = 7  # the click's random stream: numpy.random.default_rng([seed, CLICK_STREAM])


def click(rec: Recording) -> list[float]:
    """The hand initialisation: the target's true floor position at t = 0 (the first frame) plus a
    click error N(0, CLICK_SIGMA^2) per axis, seeded by the recording's seed (same recording,
    same click). The truth is read here, by the experimenter, never by the estimator."""
    first = rec.truth.people[rec.truth.people["person_id"] == TARGET].sort_values("t").iloc[0]
    err = np.random.default_rng([rec.seed, CLICK_STREAM]).normal(0.0, CLICK_SIGMA, 2)
    return [float(first["x"] + err[0]), float(first["y"] + err[1])]


def truth_at(rec: Recording, times: np.ndarray) -> pd.DataFrame:
    """Truth positions of every person at the given times (nearest simulation step)."""
    return people_at(rec.truth.people, times)


def people_at(ppl: pd.DataFrame, times: np.ndarray, columns: tuple[str, ...] = ("x", "y")) -> pd.DataFrame:
    """``truth_at`` on a truth people table (t, person_id and ``columns``): ``t, person_id`` and
    ``columns`` at each of ``times``."""
    times = np.asarray(times, float)
    out = []
    for pid, g in ppl.groupby("person_id"):
        t = g["t"].to_numpy(float)
        k = np.clip(np.searchsorted(t, times - 1e-9), 0, len(t) - 1)
        out.append(pd.DataFrame({"t": times, "person_id": pid, **{c: g[c].to_numpy()[k] for c in columns}}))
    return pd.concat(out, ignore_index=True)


def distances_at(ppl: pd.DataFrame, times, xys) -> tuple[list[str], np.ndarray]:
    """Each floor point ``xys`` (n, 2)'s distance to every true person at its time ``times``
    (n,) (``people_at``, looked up once for all of them): (person ids, sorted; D (n, people), m)."""
    times = np.asarray(times, float).reshape(-1)
    xys = np.asarray(xys, float).reshape(-1, 2)
    d = {pid: np.hypot(xys[:, 0] - g["x"].to_numpy(float), xys[:, 1] - g["y"].to_numpy(float))
         for pid, g in people_at(ppl, times).groupby("person_id")}
    names = sorted(d)
    return names, np.stack([d[n] for n in names], 1) if names else np.zeros((len(times), 0))


def person_distances(rec: Recording, tracks: pd.DataFrame) -> tuple[list[str], np.ndarray]:
    """Each output row's distance to every true person at its time: (person ids, sorted;
    D (rows, people), m)."""
    return distances_at(rec.truth.people, tracks["t"], tracks[["x", "y"]])


def target_held(names: list[str], D: np.ndarray) -> np.ndarray:
    """The issue's identity held, per row: the nearest true person is the target, within 1 m."""
    return (np.array(names)[D.argmin(1)] == TARGET) & (D[:, names.index(TARGET)] < 1.0)


def run_target(rec: Recording, params: dict | None = None) -> TargetPlanesResult:
    """The experiment's single-target run on a recording: the seeded click, the calibration's
    noise, ``params`` (Config values) on top."""
    return TargetPlanes(initial_xy=click(rec), **{**estimator_config(rec), **(params or {})}).run(rec.observations, rec.calibration)


def refuse_lookahead(script: str, params: dict | None, what: str) -> None:
    """Scripts that hook ``JointTracker.step`` see every frame stepped twice with the look-ahead
    (once per hypothesis): they stop with a clear message when ``lookahead`` is asked for."""
    if (params or {}).get("lookahead"):
        raise SystemExit(f"{script}: the look-ahead (lookahead=true) steps frames twice, once per hypothesis; {what} without it")


def multi_estimator(rec: Recording, params: dict | None = None) -> TargetPlanes:
    """The experiment's multi-person estimator for a recording: every mover tracked, the
    calibration's noise, ``params`` (Config values) on top."""
    return TargetPlanes(multi_person=True, **{**estimator_config(rec), **(params or {})})


def every_frame(res: TargetPlanesResult) -> pd.DataFrame:
    """The single-target output on every frame the tracker ran (``res.times``): a frame where no
    track carried the target's identity gets a row with x, y NaN and ``n_cameras`` -1."""
    tr = res.tracks
    times = np.round(np.asarray(res.times, float), 6)
    missing = np.setdiff1d(times, np.round(tr["t"].to_numpy(float), 6))
    if not len(missing):
        return tr.reset_index(drop=True)
    gap = pd.DataFrame({"t": missing, "track_id": 0, "x": np.nan, "y": np.nan, "vx": np.nan, "vy": np.nan,
                        "n_cameras": -1, "mode": "unreported"})
    return pd.concat([tr, gap[[c for c in tr.columns if c in gap.columns]]], ignore_index=True).sort_values("t", kind="stable").reset_index(drop=True)


def single_target_metrics(rec: Recording, res: TargetPlanesResult) -> dict:
    """The issue's figures of one single-target run, over every frame the tracker ran: a frame the
    target was not reported in counts as not held (``every_frame``); the RMSEs are over the
    reported frames."""
    tr = every_frame(res)
    names, D = person_distances(rec, tr)
    err = D[:, names.index(TARGET)]
    held = target_held(names, D)
    n = tr["n_cameras"].to_numpy()

    def rmse(mask):
        return float(np.sqrt(np.mean(err[mask] ** 2))) if mask.any() else float("nan")

    st = res.status
    return {
        "frames": int((n >= 0).sum()),
        "frames_unreported": int((n < 0).sum()),
        "identity_held": float(held.mean()),
        "rmse_2plus": rmse(n >= 2),
        "rmse_1": rmse(n == 1),
        "rmse_0": rmse(n == 0),
        "frames_2plus": int((n >= 2).sum()),
        "frames_1": int((n == 1).sum()),
        "frames_0": int((n == 0).sum()),
        "p95_2plus": float(np.percentile(err[n >= 2], 95)) if (n >= 2).any() else float("nan"),
        "max_err": float(np.nanmax(err)) if (n >= 0).any() else float("nan"),
        "camera_frames_unreliable": int((st["status"] == "unreliable").sum()),
        "camera_frames_lost": int((st["status"] == "lost").sum()),
    }


def estimator_config(rec: Recording) -> dict:
    """Allowances for the estimator: none, it reads the noise levels from the calibration.
    Rendered recordings written before their calibration declared the flow detector's noise
    (``sim.simulate`` now merges ``sim.perception_flow.RENDERED_WINDOW_NOISE`` into it) get it
    here, in the calibration, as a new recording would."""
    if rec.sensing == "rendered" and "box_u_sigma_px" not in rec.calibration.noise:
        rec.calibration.noise = {**rec.calibration.noise, **RENDERED_WINDOW_NOISE}
    return {}


def window_errors(rec: Recording, min_speed: float = 0.3) -> pd.DataFrame:
    """Each window of ``boxes`` against the truth (measurement only, never given to estimators).

    A window belongs to the person whose segmentation box (``labels``) it overlaps most; its
    errors are against that person's body centre X (truth ``people``) projected by the camera:
    ``e_u`` = u - u(X) (centroid against the body axis), ``e_flow_u/v`` = mean flow - dx(X)/dt
    (px/s), ``e_top``/``e_bottom``/``e_left``/``e_right`` = window edges - segmentation box edges.
    Windows overlapping no person have ``person`` = None.
    """
    lab = rec.truth.tables.get("labels")
    if lab is None or not len(lab):
        raise SystemExit("window errors need the segmentation labels of a rendered recording")
    boxes = rec.observations["boxes"]
    ppl = rec.truth.people
    tracks = {pid: g.sort_values("t") for pid, g in ppl.groupby("person_id")}
    labels = {(round(float(t), 6), c): g for (t, c), g in lab.groupby(["t", "camera"])}
    rows = []
    for (t, c), g in boxes.groupby(["t", "camera"]):
        cam = rec.calibration.cameras[c]
        L = labels.get((round(float(t), 6), c))
        for r in g.itertuples():
            best, area = None, 0.0
            if L is not None:
                iw = np.clip(np.minimum(r.u_right, L.x1) - np.maximum(r.u_left, L.x0), 0, None)
                ih = np.clip(np.minimum(r.v_bottom, L.y1) - np.maximum(r.v_top, L.y0), 0, None)
                k = int(np.argmax(iw * ih))
                if (iw * ih).iloc[k] > 0:
                    best, area = L.iloc[k], float((iw * ih).iloc[k])
            if best is None:
                rows.append({"t": t, "camera": c, "track": r.track, "person": None})
                continue
            tr = tracks[best.person_id]
            k = min(int(np.searchsorted(tr["t"].to_numpy(), t - 1e-9)), len(tr) - 1)
            x, y, z, vx, vy = tr[["x", "y", "z", "vx", "vy"]].to_numpy()[k]
            uv, _ = cam.project(np.array([[x, y, z], [x + 0.01 * vx, y + 0.01 * vy, z]]))
            vel = (uv[1] - uv[0]) / 0.01
            rows.append({"t": t, "camera": c, "track": r.track, "person": best.person_id, "speed": float(np.hypot(vx, vy)),
                         "visible_fraction": float(best.visible_fraction),
                         "e_u": r.u - uv[0, 0], "e_flow_u": r.flow_u - vel[0], "e_flow_v": r.flow_v - vel[1],
                         "e_top": r.v_top - best.y0, "e_bottom": r.v_bottom - best.y1,
                         "e_left": r.u_left - best.x0, "e_right": r.u_right - best.x1})
    return pd.DataFrame(rows)


def window_error_summary(E: pd.DataFrame, min_speed: float = 0.3) -> pd.DataFrame:
    """Median, robust sigma (1.4826 MAD), standard deviation and 90th percentile of |e| of each
    error over the windows on walking people (speed > ``min_speed``), plus counts."""
    mv = E[E["person"].notna()]
    mv = mv[mv["speed"] > min_speed]
    out = {}
    for k in ("e_u", "e_top", "e_bottom", "e_left", "e_right", "e_flow_u", "e_flow_v"):
        x = mv[k].to_numpy(float)
        med = float(np.median(x))
        out[k] = {"median": med, "robust_sigma": robust_sigma(x), "sd": float(x.std()),
                  "p90_abs": float(np.percentile(np.abs(x), 90))}
    per = mv.groupby(["t", "camera", "person"]).size()
    print(f"windows {len(E)}, on no person {int(E['person'].isna().sum())}, on walking people {len(mv)}; "
          f"person-frames with more than one window {int((per > 1).sum())} of {len(per)}; "
          f"track ids per walking person and camera {mv.groupby(['camera', 'person'])['track'].nunique().mean():.1f}")
    return pd.DataFrame(out).T


def movers_only(rec: Recording, scene) -> Recording:
    """The recording with truth restricted to the people who walk (the movers)."""
    movers = {w.name for w in scene.walkers if w.motion != "standing"}
    tables = dict(rec.truth.tables)
    tables["people"] = tables["people"][tables["people"]["person_id"].isin(movers)].reset_index(drop=True)
    if "visibility" in tables:
        tables["visibility"] = tables["visibility"][tables["visibility"]["person_id"].isin(movers)].reset_index(drop=True)
    return dataclasses.replace(rec, truth=Truth(tables))


def parse_params(items: list[str]) -> dict:
    """``--param KEY=VALUE`` items as estimator Config values (VALUE read as JSON, else a string)."""
    out = {}
    for it in items or []:
        if "=" not in it:
            raise SystemExit(f"--param {it!r}: expected KEY=VALUE")
        k, v = it.split("=", 1)
        try:
            out[k] = json.loads(v)
        except json.JSONDecodeError:
            out[k] = v
    return out


def measurement_parser(doc: str, csv_help: str | None = None) -> argparse.ArgumentParser:
    """The command line of the measurement scripts that run target_planes on recordings:
    ``DIR [DIR ...] [--param KEY=VALUE ...]``, and ``[--csv FILE]`` with ``csv_help`` (``doc``:
    the script's docstring); a script adds its own options to it."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR", help="recording folders (globs allowed)")
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="a target_planes Config value (JSON)")
    if csv_help:
        ap.add_argument("--csv", help=csv_help)
    return ap


def measurement_args(ap: argparse.ArgumentParser, argv=None) -> tuple[list[str], dict, argparse.Namespace]:
    """A ``measurement_parser`` command line (with whatever options the script added) read: the
    folders (quoted globs expanded, each checked), the Config values and every parsed option."""
    a = ap.parse_args(argv)
    return recording_folders(a.recordings, ap.prog), parse_params(a.param), a


def recordings_and_params(doc: str, argv=None, csv_help: str | None = None) -> tuple[list[str], dict, str | None]:
    """``measurement_parser``'s command line read: the folders, the Config values and the CSV path
    (None: not asked for)."""
    dirs, params, a = measurement_args(measurement_parser(doc, csv_help), argv)
    return dirs, params, getattr(a, "csv", None)


def run(sensing: str, duration: float, seed: int, progress: bool = False, recording: Recording | None = None,
        params: dict | None = None, overrides: list[str] | None = None, draw: int = 0) -> tuple[Recording, TargetPlanesResult, dict]:
    """One run (``draw`` > 0: an analytic recording's camera tables redrawn through the perception
    model, ``simulate(..., perception_draw=draw)``: the same walkers, click and phones)."""
    scene = load_scene("occlusion_lab", overrides or None)
    t0 = time.time()
    rec = recording if recording is not None else simulate(scene, seed=seed, duration=duration, sensing=sensing, progress=progress,
                                                           perception_draw=draw)
    t_sim = time.time() - t0
    if recording is not None:
        sensing, seed, duration = rec.meta.get("sensing", "?"), rec.meta.get("seed", "?"), rec.observations.duration
    t0 = time.time()
    res = run_target(rec, params)
    t_est = time.time() - t0
    m = {"sensing": sensing, "seed": seed, "duration": duration, "sim_s": round(t_sim, 1), "estimate_s": round(t_est, 2)}
    if draw:
        m["perception_draw"] = draw
    m.update(single_target_metrics(rec, res))
    multi = multi_estimator(rec, params).estimate(rec.observations, rec.calibration)
    ev = evaluate(movers_only(rec, scene), multi, gate=1.0)
    mm = ev.metrics()
    m.update({f"multi_{k}": mm[k] for k in ("mota", "motp", "id_switches", "fp", "fn", "idf1", "tracks")})
    return rec, res, m


def run_task(mode: str | None, seed: int | None, folder: str | None, duration: float, params: dict, overrides: list[str],
             draw: int, progress: bool) -> dict:
    """One run of the command line's list (``main``) -> its figures: a simulated (``mode``,
    ``seed``) or a recording ``folder``. At module level so that worker processes (``--jobs``)
    can run it; a recording is read in the process that runs it."""
    rec = None
    if folder is not None:
        from trackroom.dataset import read_recording

        rec = read_recording(folder)
    return run(mode, duration, seed, progress=progress, recording=rec, params=params, overrides=overrides, draw=draw)[2]


def run_all(tasks: list[tuple], jobs: int = 1, **common):
    """``run_task`` over ``tasks`` ((mode, seed, folder) each, the other arguments ``common`` to
    all), in this process (``jobs`` 1) or in ``jobs`` worker processes; yields the figures in the
    order of ``tasks`` either way."""
    one = functools.partial(run_task, **common)
    if jobs == 1:
        yield from itertools.starmap(one, tasks)
        return
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max(1, min(jobs, len(tasks)))) as pool:
        yield from pool.map(one, *zip(*tasks))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sensing", default="both", choices=["analytic", "rendered", "both"])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--seeds", default="0", help="comma-separated seeds")
    ap.add_argument("--recording", help="evaluate saved recording folders (comma-separated) instead of simulating")
    ap.add_argument("--window-errors", action="store_true", help="with --recording: the flow windows' errors against the truth")
    ap.add_argument("--json", action="store_true", help="print one JSON object per run")
    ap.add_argument("--param", action="append", default=[], help="estimator Config KEY=VALUE (repeatable), e.g. hold_s=4")
    ap.add_argument("--set", dest="overrides", action="append", default=[], help="scene override KEY=VALUE for simulated runs (repeatable)")
    ap.add_argument("--table", action="store_true", help="print one line per run with the issue's figures")
    ap.add_argument("--draw", type=int, default=0, help="analytic runs: the perception model's draw K of each seed's camera "
                    "tables (0: the seed's own recording; K > 0 redraws them, same walkers and click), to judge a change "
                    "over several draws")
    ap.add_argument("--jobs", type=int, default=1, help="run the list in N worker processes (output in the order given)")
    a = ap.parse_args(argv)
    if a.draw < 0 or (a.draw and (a.recording or a.sensing != "analytic")):
        ap.error("--draw K needs K >= 0, and K > 0 only with --sensing analytic (it redraws simulated camera tables)")
    if a.jobs < 1:
        ap.error(f"--jobs N needs N >= 1, got {a.jobs}")
    if a.recording:
        from trackroom.dataset import read_recording

        folders = recording_folders(a.recording.split(","), "experiment_tsutsui")
        if a.window_errors:
            for d in folders:
                rec = read_recording(d)
                print(f"{rec.scene} seed {rec.seed} ({rec.sensing})")
                print(window_error_summary(window_errors(rec)).round(2).to_string())
            return 0
        tasks = [(None, None, d) for d in folders]
    else:
        modes = ["analytic", "rendered"] if a.sensing == "both" else [a.sensing]
        tasks = [(mode, int(s), None) for mode in modes for s in a.seeds.split(",")]
    rows = []
    common = dict(duration=a.duration, params=parse_params(a.param), overrides=a.overrides, draw=a.draw,
                  progress=not (a.json or a.table) and a.jobs == 1)
    for m in run_all(tasks, a.jobs, **common):
        rows.append(m)
        if a.json:
            print(json.dumps(m), flush=True)
        if a.table:
            print(table_line(m), flush=True)
    df = pd.DataFrame(rows)
    if not (a.json or a.table):
        print(df.set_index(["sensing", "seed"]).T.to_string())
    if len(df) > 1:  # with --json, stdout holds the runs alone (a file for compare_tp_runs)
        print(summary(df).to_string(), file=sys.stderr if a.json else sys.stdout)
    return 0


def table_line(m: dict) -> str:
    """One run's issue-12 figures: identity held, RMSE with >= 2 and 1 tracking cameras (frames),
    frames with no camera and frames the target was not reported, multi-person MOTA and ID switches on the movers, estimate time (s)."""
    return (f"{m['sensing']:9s} seed {m['seed']!s:>4}  identity {100 * m['identity_held']:6.2f} %  "
            f"RMSE>=2 {m['rmse_2plus']:.3f} m ({m['frames_2plus']})  RMSE1 {m['rmse_1']:.3f} m ({m['frames_1']})  "
            f"0 cams {m['frames_0']}  unreported {m['frames_unreported']}  MOTA {m['multi_mota']:.3f}  IDsw {m['multi_id_switches']}  IDF1 {m['multi_idf1']:.3f}  est {m['estimate_s']} s")


HIGHER_IS_BETTER = ("identity_held", "multi_mota", "multi_idf1")


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Mean and worst over runs of each figure, per sensing mode."""
    cols = ["identity_held", "rmse_2plus", "p95_2plus", "rmse_1", "multi_mota", "multi_id_switches", "multi_idf1"]
    out = {}
    for mode, g in df.groupby("sensing"):
        for c in cols:
            worst = g[c].min() if c in HIGHER_IS_BETTER else g[c].max()
            out[(mode, c)] = {"mean": g[c].mean(), "worst": worst, "runs": len(g)}
    return pd.DataFrame(out).T


if __name__ == "__main__":
    sys.exit(main())
