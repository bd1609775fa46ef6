"""The person detections' rates, for ``target_planes``' ``person_detections`` parameters.

    python scripts/measure_person_detections.py DIR [DIR ...]     # occlusion_lab recordings, either mode

    python scripts/measure_person_detections.py DIR [DIR ...] --views  # also the rates by how much is seen

The tracker reads the ``bearings`` table's u (a person detector's column of each body centre;
the colour labels unused) as evidence that someone stands where a still track is
(``tp_joint.JointTracker.detection_evidence``). Measured here, over the camera frames of each
recording (the truth read by the experimenter):

- people: every person wholly in a camera's image, all three rays of ``Occluders`` clear of the
  floor plan's boxes (``whole``): whether a detection lies within the gate (half the projected
  width + 3 px) of the projected axis; the rate (``p_person_detect``) and the rate after a
  frame with one and after a frame without (a miss run's mean, ``person_miss_run``, is one
  over the latter); and the column error of those detections about the projected axis (its
  core spread is the noise a detection's target plane would have: docs/target_planes.md,
  "person detections as target planes"); the same rates for the people standing (truth speed
  below ``STILL``, where the tracker uses the detections) and walking, with the longest run of
  misses and the number of runs of ``LONG_RUN`` frames or more (a two-state chain with a mean
  run of 3-4 frames makes these next to impossible: a detector that misses someone standing
  for seconds on end is outside the tracker's model);
- ``--views``: the same rates for people and ghost points seen partly (``VIEWS``: cut by the
  image border with a quarter or more of the width inside, or two of the three rays clear - what
  ``partial_detections`` adds to the test, ``tp_joint.detector_sees`` - and, for reference, seen
  less than that: cut by the border with under a quarter inside, or less still);
- ghosts: ``GHOSTS`` random floor points per recording, standing (seed 0), at frames when
  they are 1 m or more from everyone, tested the same way with the gate of a track of position
  sd 0.1 m: how often a detection falls within it, against the chance the tracker computes
  from the frame's number of detections, and its lag-1 persistence P(c | c) - P(c | no c)
  (``coincidence_persistence``).
"""
from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_joint import (VIS_FRACTIONS, Occluders, coincidence_chance, detection_gate, detector_sees,
                                          partly_in_image, wholly_in_image)
from trackroom.metrics.aggregate import robust_sigma

HEIGHT, RADIUS, CENTRE = TargetPlanes.Config.height, TargetPlanes.Config.radius, 0.9  # the tracker's person model (m) and the axis point it projects
GHOSTS = 60
GHOST_SD = 0.1  # m
STILL = 0.05  # m/s: a person standing (the truth's speed below this), where ``person_detections`` is used
LONG_RUN = 30  # frames (3 s at 10 fps): a miss run this long is outside the two-state chain's reach


VIEWS = {"whole": "seen whole", "border": "cut by the image border, a quarter or more inside, every ray clear",
         "hidden": "inside the image, two of three rays clear", "sliver": "cut by the border, under a quarter inside",
         "little": "seen less (one ray clear, or cut and partly hidden)"}


def view(win: np.ndarray, width: float, n_clear: int) -> str | None:
    """How a camera sees a person whose projected cylinder is ``win`` with ``n_clear`` rays
    clear of the floor plan's boxes (``VIEWS``; the tracker's rule, ``tp_joint.detector_sees``),
    or None: not at all (outside the image, or every ray hidden)."""
    n = len(VIS_FRACTIONS)
    if detector_sees(win, width, n_clear, n):
        return "whole"
    if detector_sees(win, width, n_clear, n, partial=True):
        return "hidden" if wholly_in_image(win, width) else "border"
    if n_clear == 0 or not bool(partly_in_image(win, width)):
        return None
    return "sliver" if n_clear == n and not wholly_in_image(win, width) else "little"


def _consecutive(df: pd.DataFrame, keys: list[str]) -> tuple[pd.DataFrame, pd.Series]:
    """``df`` sorted by ``keys`` and time, and whether each row is the frame right after its
    group's previous row (the median frame step; a group's first row and a row after a gap are
    not)."""
    df = df.sort_values([*keys, "t"])
    step = df.groupby(keys).t.diff().round(3)
    dt = float(np.median(step.dropna())) if step.notna().any() else np.nan
    return df, step == round(dt, 3)


def _chain(df: pd.DataFrame, keys: list[str]) -> tuple[float, float]:
    """P(hit | hit the frame before), P(hit | miss the frame before) over consecutive frames."""
    df, ok = _consecutive(df, keys)
    prev = df.groupby(keys).hit.shift(1)
    return float(df[ok & (prev == True)].hit.mean()), float(df[ok & (prev == False)].hit.mean())  # noqa: E712


def miss_runs(df: pd.DataFrame, keys: list[str]) -> np.ndarray:
    """The lengths (frames) of every run of misses over consecutive frames, per ``keys`` group
    (a gap in a group's frames ends a run)."""
    df, ok = _consecutive(df, keys)
    miss = ~df["hit"].to_numpy(bool)
    follows = ok.to_numpy(bool)
    start = miss & ~(follows & np.r_[False, miss[:-1]])  # a miss not continuing one the frame before
    run = np.cumsum(start)[miss]
    return np.bincount(run)[1:].astype(int) if len(run) else np.zeros(0, int)


def measure(d: str, rng: np.random.Generator) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(people rows, ghost rows) of one recording: t, camera, who, hit (and chance for ghosts)."""
    rec = read_recording(d)
    cams = rec.calibration.cameras_of_kind("oblique")
    Ps = {c: np.asarray(cam.P, float) for c, cam in cams.items()}
    occ = Occluders(rec.calibration.floorplan, Ps, HEIGHT)
    b = rec.observations["bearings"]
    times = np.round(np.sort(b["t"].unique()), 6)
    dets = {k: g["u"].to_numpy(float) for k, g in b.groupby([np.round(b["t"].to_numpy(float), 6), "camera"])}
    people = rec.truth.people.assign(tk=lambda p: np.round(p["t"].to_numpy(float), 6))
    people = people[np.isin(people["tk"], times)]
    at = {t: g[["x", "y"]].to_numpy(float) for t, g in people.groupby("tk")}
    ghosts = rng.uniform([0.0, 0.0], [1.0, 1.0], (GHOSTS, 2))
    outline = np.asarray(rec.calibration.floorplan.outline, float)
    lo, hi = outline.min(0), outline.max(0)
    ghosts = lo + ghosts * (hi - lo)
    ghosts = ghosts[np.asarray(rec.calibration.floorplan.inside(ghosts), bool)]
    rows, grows = [], []
    for c, P in Ps.items():
        W = float(cams[c].width)
        n_clear = occ.clear_rays(c, people[["x", "y"]].to_numpy(float))
        for r, nc in zip(people.itertuples(), n_clear):
            win = geo.cylinder_window(P, (r.x, r.y), HEIGHT, RADIUS)
            seen = view(win, W, int(nc))
            if seen is None:
                continue
            (u, _), _ = geo.project(P, np.array([r.x, r.y, r.z]))
            us = dets.get((r.tk, c), np.zeros(0))
            res = float((us - u)[np.argmin(np.abs(us - u))]) if len(us) else np.nan
            rows.append((r.tk, c, r.person_id, bool(len(us)) and abs(res) <= detection_gate(win), res,
                         bool(np.hypot(r.vx, r.vy) < STILL), seen))
        for k, (q, nc) in enumerate(zip(ghosts, occ.clear_rays(c, ghosts))):
            win = geo.cylinder_window(P, q, HEIGHT, RADIUS)
            seen = view(win, W, int(nc))
            if seen not in ("whole", "border", "hidden"):
                continue
            X = np.r_[q, CENTRE]
            (u, _), _ = geo.project(P, X)
            gate = detection_gate(win, (GHOST_SD * float(np.linalg.norm(geo.flow_jacobian(P, X)[0, :2]))) ** 2)
            for t in times:
                if np.hypot(*(at[t] - q).T).min() < 1.0:
                    continue
                us = dets.get((t, c), np.zeros(0))
                chance = coincidence_chance(gate, W, len(us), u)  # over the gate's span inside the image, as the tracker
                grows.append((t, c, k, bool(len(us)) and float(np.abs(us - u).min()) <= gate, chance, seen))
    return (pd.DataFrame(rows, columns=["t", "camera", "who", "hit", "resid", "still", "view"]),
            pd.DataFrame(grows, columns=["t", "camera", "who", "hit", "chance", "view"]))


def views_table(p: pd.DataFrame, g: pd.DataFrame) -> pd.DataFrame:
    """``--views``: per view (``VIEWS``) and people standing or walking: camera frames, the
    detection rate, the rates after a detection and after a miss and the mean miss run (frames);
    and the ghost points' rate in the gate against the computed chance, with its persistence."""
    out = []
    for v in VIEWS:
        for name, q in (("standing", p[(p.view == v) & p.still]), ("walking", p[(p.view == v) & ~p.still]),
                        ("ghosts", g[g.view == v])):
            if not len(q):
                continue
            h, m = _chain(q, ["rec", "camera", "who"])
            out.append({"view": v, "who": name, "frames": len(q), "detected": float(q.hit.mean()), "after_detection": h,
                        "after_miss": m, "miss_run": 1.0 / m if m > 0 else np.inf,
                        "chance": float(q.chance.mean()) if name == "ghosts" else np.nan})
    return pd.DataFrame(out)


def main(argv: list[str]) -> int:
    views = "--views" in argv
    patterns = [p for p in argv if p != "--views"]
    if not patterns:
        sys.exit(__doc__)
    dirs = sorted(recording_folders(patterns, "measure_person_detections"))
    rng = np.random.default_rng(0)
    people, ghosts = [], []
    for d in dirs:
        p, g = measure(d, rng)
        people.append(p.assign(rec=d))
        ghosts.append(g.assign(rec=d))
    p_all, g_all = pd.concat(people), pd.concat(ghosts)
    p, g = p_all[p_all.view == "whole"], g_all[g_all.view == "whole"]
    after_hit, after_miss = _chain(p, ["rec", "camera", "who"])
    print(f"people wholly seen: {len(p)} camera frames, detected {p.hit.mean():.3f}; after a detection {after_hit:.3f}, "
          f"after a miss {after_miss:.3f} (mean miss run {1.0 / after_miss:.1f} frames)")
    for name, q in ((f"standing (slower than {STILL} m/s)", p[p.still]), ("walking", p[~p.still])):
        if len(q):
            h, m = _chain(q, ["rec", "camera", "who"])
            runs = miss_runs(q, ["rec", "camera", "who"])
            print(f"  {name}: {len(q)} camera frames, detected {q.hit.mean():.3f}; after a detection {h:.3f}, "
                  f"after a miss {m:.3f} (mean miss run {1.0 / m:.1f} frames); longest miss run "
                  f"{int(runs.max()) if len(runs) else 0} frames, {int((runs >= LONG_RUN).sum())} runs of "
                  f"{LONG_RUN} or more")
    r = p.resid[p.hit]
    mad = robust_sigma(r)
    print(f"their detections' columns against the projected axis: mean {r.mean():+.2f} px, sd {r.std():.2f} px "
          f"(tails: another person's detection in the gate), robust sd (1.4826 MAD) {mad:.2f} px, within 3 px "
          f"{float((r.abs() <= 3.0).mean()):.3f}")
    g_hit, g_miss = _chain(g, ["rec", "camera", "who"])
    print(f"ghosts (standing points 1 m or more from everyone): {len(g)} camera frames, a detection in the gate "
          f"{g.hit.mean():.3f} against the computed chance {g.chance.mean():.3f}; after one {g_hit:.3f}, after none "
          f"{g_miss:.3f} (persistence {g_hit - g_miss:.3f})")
    if views:
        print("by view (" + "; ".join(f"{k}: {v}" for k, v in VIEWS.items()) + "):")
        print(views_table(p_all, g_all).to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
