"""How far `target_planes`' tracks are off the movers they follow, by how the cameras held them.

    python -m scripts.explain_tp_errors DIR [DIR ...] [--single] [--param KEY=VALUE ...] [--csv FILE]

Runs the multi-person tracker on each occlusion_lab recording as ``scripts/experiment_tsutsui.py``
does (the run its movers' MOTA scores), or with ``--single`` the single-target run from the
experiment's click (``experiment_tsutsui.run_target``: the run the identity and RMSE targets
score, whose track ids ``trace_tp_track`` uses without ``--multi``), and reads its internal tracks
(every frame of every confirmed track, before the output's lag and selection) against the movers'
truth, by the experimenter. Each frame, tracks and movers are matched one to one (least total
distance, a pair only within 1 m); for each matched pair with the mover walking (the truth's
``walking``, true speed at least 0.3 m/s):

- ``err``: the track's distance from the mover, m;
- ``along``: its offset along the mover's true heading, m (negative: the track lags behind);
- ``speed``: the track's speed over the mover's true speed;
- ``mode``: how the cameras held the track that frame (``planes``: windows of its own in two or
  more cameras; ``area``: in one; ``merged``: only shares of merged windows; ``predicted``: no
  window);
- ``pair``: whether another mover was within 1 m (``beside``) or not (``apart``);
- ``below``: whether an oblique camera sees the mover with the feet below its image (its
  projected cylinder, height 1.8 m and radius 0.2 m as the tracker's person, reaches past the
  image's bottom row while lying at least in part between its left and right borders: a person
  1-3 m from a corner camera, whose windows hold the upper body; the fifty-fifth session's
  failures at the west wall near the south-west corner; False where no camera is given);
- ``d2``: the error's squared Mahalanobis distance under the track's own position covariance
  (the internal rows' ``cxx, cxy, cyy``; NaN without them): for a consistent tracker it is
  chi^2_2, median 1.39, beyond 9.21 one frame in a hundred (fewer here: errors beyond the 1 m
  match are not measured).

Unlike ``measure_tp_lag`` (the reported target's lag, along its reported velocity, where two or
more cameras update it), this reads every mover's track, internal, by the true heading, in every
mode. It prints, per mode and pair, the frames, the median and 90th percentile of ``err``, the median
``along``, the median ``speed``, the median ``d2`` and the share of frames with ``d2`` beyond
chi^2_2(0.99), then the same by mode and ``below`` (frames with and without a camera that sees
the mover's feet below its image); ``--csv`` writes every matched frame.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file

GATE_M = 1.0  # a track and a mover this near may be matched (the movers' MOTA gate)
BESIDE_M = 1.0  # another mover this near: the pair is "beside"
WALK_MPS = 0.3  # a mover at least this fast is walking
MODES = ("planes", "area", "merged", "predicted")
CHI2_2_99 = float(chi2.ppf(0.99, 2))  # chi^2_2's 99th percentile, 9.21


def feet_below(cameras: dict, xy: np.ndarray) -> bool:
    """Whether some camera of ``cameras`` (name -> (P, width, height), px) sees a person standing
    at floor point xy with the feet below its image (module docstring, ``below``)."""
    from trackroom.estimators import tp_geometry as geo
    from trackroom.estimators.target_planes import TargetPlanes

    person = TargetPlanes.Config  # the tracker's person model: its height and radius defaults
    for P, width, height in cameras.values():
        win = geo.cylinder_window(P, np.asarray(xy, float), person.height, person.radius)
        if np.isfinite(win).all() and win[1] >= 0.0 and win[0] <= width and win[3] > height:
            return True
    return False


def track_errors(internal: pd.DataFrame, movers: pd.DataFrame, cameras: dict | None = None) -> pd.DataFrame:
    """Each frame's confirmed tracks matched to the walking movers (module docstring).

    ``internal``: ``t, track_id, x, y, vx, vy, mode, confirmed``; ``movers``: the movers' truth,
    ``t, person_id, x, y, vx, vy, walking`` (looked up at the nearest earlier or equal simulation
    step); with ``cxx, cxy, cyy`` (the position's covariance) ``d2`` is measured, else NaN;
    ``cameras`` (name -> (P, width, height)) the oblique cameras for ``below`` (None: all False).
    Returns rows ``t, track_id, person_id, mode, pair, err, along, speed, d2, below``."""
    cols = ["t", "track_id", "person_id", "mode", "pair", "err", "along", "speed", "d2", "below"]
    has_cov = {"cxx", "cxy", "cyy"} <= set(internal.columns)
    tracks = internal[internal["confirmed"].astype(bool)]
    if tracks.empty or movers.empty:
        return pd.DataFrame(columns=cols)
    from scripts.experiment_tsutsui import people_at

    truth = people_at(movers.sort_values("t", kind="stable"), np.unique(tracks["t"].to_numpy(float)),
                      ("x", "y", "vx", "vy", "walking"))
    truth_by_t = dict(iter(truth.groupby("t", sort=False)))
    rows = []
    for t, g in tracks.groupby("t", sort=True):
        h = truth_by_t[t]
        P, V, walking = h[["x", "y"]].to_numpy(float), h[["vx", "vy"]].to_numpy(float), h["walking"].to_numpy(bool)
        X = g[["x", "y"]].to_numpy(float)
        D = np.linalg.norm(X[:, None, :] - P[None, :, :], axis=2)
        a, b = linear_sum_assignment(np.where(D <= GATE_M, D, 1e6))
        for i, j in zip(a, b):
            speed = float(np.linalg.norm(V[j]))
            if D[i, j] > GATE_M or not walking[j] or speed < WALK_MPS:
                continue
            others = np.delete(P, j, axis=0)
            near = bool(len(others)) and float(np.min(np.linalg.norm(others - P[j], axis=1))) <= BESIDE_M
            tr = g.iloc[i]
            e = X[i] - P[j]
            d2 = float(e @ np.linalg.solve(np.array([[tr["cxx"], tr["cxy"]], [tr["cxy"], tr["cyy"]]]), e)) if has_cov else np.nan
            rows.append((float(t), int(tr["track_id"]), h["person_id"].iloc[j], str(tr["mode"]), "beside" if near else "apart",
                         float(D[i, j]), float(e @ (V[j] / speed)), float(np.hypot(tr["vx"], tr["vy"])) / speed, d2,
                         feet_below(cameras or {}, P[j])))
    return pd.DataFrame(rows, columns=cols)


def summary(E: pd.DataFrame, by: tuple[str, ...] = ("mode", "pair")) -> pd.DataFrame:
    """Per mode and pair (or the columns ``by``): frames, median and 90th percentile error (m),
    median along-heading offset (m), median speed ratio, median ``d2`` and its share beyond
    chi^2_2(0.99)."""
    out = []
    for key, g in E.groupby(list(by), sort=False):  # key: a tuple, one value per column of ``by``
        out.append({**dict(zip(by, key)), "frames": len(g), "err_median": g["err"].median(),
                    "err_p90": g["err"].quantile(0.9), "along_median": g["along"].median(), "speed_median": g["speed"].median(),
                    "d2_median": g["d2"].median(), "beyond99": (g["d2"] > CHI2_2_99).mean() if g["d2"].notna().any() else np.nan})
    S = pd.DataFrame(out, columns=[*by, "frames", "err_median", "err_p90", "along_median", "speed_median", "d2_median", "beyond99"])
    order = {m: k for k, m in enumerate(MODES)}
    return S.sort_values(list(by), key=lambda s: s.map(order) if s.name == "mode" else s).reset_index(drop=True)


def errors(d: str, params: dict, single: bool = False) -> pd.DataFrame:
    """One recording's matched frames (``track_errors``), with its folder; ``single``: of the
    single-target run (``experiment_tsutsui.run_target``), else of the multi-person one."""
    from scripts.experiment_tsutsui import movers_only, multi_estimator, run_target
    from trackroom.dataset import read_recording
    from trackroom.scenes.loader import load_scene

    rec = read_recording(d)
    scene = load_scene(Path(d) / "scene.toml")
    res = run_target(rec, params) if single else multi_estimator(rec, params).run(rec.observations, rec.calibration)
    cams = {c: (np.asarray(cam.P, float), float(cam.width), float(cam.height))
            for c, cam in rec.calibration.cameras_of_kind("oblique").items()}
    E = track_errors(res.internal, movers_only(rec, scene).truth.people, cams)
    E.insert(0, "recording", d)
    return E


def main(argv=None) -> int:
    from scripts.experiment_tsutsui import measurement_args, measurement_parser

    ap = measurement_parser(__doc__, csv_help="write every matched frame to this CSV file")
    ap.add_argument("--single", action="store_true",
                    help="the single-target run from the experiment's click (the identity and RMSE targets' run) "
                         "instead of the multi-person one (the movers' MOTA's)")
    dirs, params, a = measurement_args(ap, argv)
    E = pd.concat([errors(d, params, a.single) for d in dirs], ignore_index=True)
    run = "single-target run" if a.single else "multi-person run"
    print(f"{len(dirs)} recordings ({run}), {len(E)} matched frames of walking movers")
    with pd.option_context("display.width", 200, "display.float_format", "{:.3f}".format):
        print(summary(E).to_string(index=False))
        print("by mode and whether a camera sees the mover's feet below its image:")
        print(summary(E, ("mode", "below")).to_string(index=False))
    if a.csv:
        E.to_csv(a.csv, index=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
