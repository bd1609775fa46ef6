"""The flow windows' detection of walkers as ``target_planes``' existence test sees it (``p_detect``, ``miss_run``).

    python scripts/measure_tp_detection.py DIR [DIR ...]      # rendered occlusion_lab recordings

For each walking mover (the scene's target and distractor), oblique camera and frame where the
person is in the camera's field of view and image, moves at least 8 px/s in it (the estimator's
``mover_flow_px``), is not hidden by the floor plan's boxes (``tp_joint.Occluders``, as the
estimator decides it) and whose axis is not inside the other mover's nearer projected cylinder:
whether a window of the ``boxes`` table holds the person's axis column (+-3 px). Prints the rate
(``p_detect``), by image speed, and the mean run of misses in one camera (``miss_run``); and, by
the share of the person's image span covered by a standing person nearer the camera (whom the
tracker does not know), the rate of a window on the axis and of any window overlapping the
person's span (run it on rendered recordings and on their analytic twins to compare the two). The truth
is read here, by the experimenter; the estimator only gets the two numbers as Config defaults.
Measured on the rendered development recordings 100-105 (the standing people who hide movers are
not known to the tracker, so their occlusions are part of the rate).

    python scripts/measure_tp_detection.py DIR [DIR ...] --slowing

also prints the rate of a window on the axis by the mover's ground speed, for frames where it is
slowing, speeding up or steady (its ground speed changed by more than 0.02 m/s over the last
tenth of a second), every frame of a mover counted whether walking or not, movers not hidden and
apart from the other mover: how a flow tracker's windows fade as a person comes to a stop (issue
12's forty-second session, ``target_planes``' scratch trial ``stop_mode``). Rendered development
100-105: slowing, 0.46 under 0.1 m/s, 0.81 at 0.1-0.2, 0.88 at 0.2-0.4, 0.93 above 0.8 m/s;
speeding up, 0.21 and 0.57 in the two slowest bands (a region needs motion to build up); standing
(steady under 0.1 m/s) 0.035.

    python scripts/measure_tp_detection.py DIR [DIR ...] --border

prints instead, for a walker cut by the image border, the rate of a window overlapping the part
of its cylinder inside the image, by that part's columns (``border_rows``: every frame the
cylinder is at least partly inside, in the truth's field of view or not; issue 12's ninetieth
session). Rendered development 100-109: 0 at up to 1 px, 0.09 at 1-2, 0.13 at 2-3, 0.40 at 3-4,
0.75 at 4-6, 0.92 at 6-8, 0.99 from 8 px on (as for a walker seen whole); their analytic twins
0.42, 0.68, 0.87, 0.84, 0.89, 0.89 and 0.93-0.96: analytic sensing gives a window to a walker with
a few columns inside the image far more often than the rendered flow tracker.
"""
import argparse

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_joint import Occluders

HEIGHT, RADIUS = TargetPlanes.Config.height, TargetPlanes.Config.radius  # the tracker's person model, m
COLUMNS = ["rec", "t", "cam", "pid", "speed", "hid", "near", "det", "overlap", "cover", "walking", "gs", "dgs"]
BACK_STEPS = 10  # simulation steps (0.01 s) back for the ground speed's change
SPEED_BANDS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 2.0)  # m/s


def slowing_table(df: pd.DataFrame, change: float = 0.02) -> pd.DataFrame:
    """P(a window on the axis) by ground speed band, for frames where the mover is slowing
    (ground speed down by more than ``change`` m/s over the last tenth of a second), speeding
    up, or steady; movers not hidden and apart from the other mover (``--slowing``: the
    flow windows of a person coming to a stop)."""
    m = df[~df.hid & ~df.near]
    m = m.assign(band=pd.cut(m.gs, SPEED_BANDS), motion=np.where(m.dgs < -change, "slowing", np.where(m.dgs > change, "speeding up", "steady")))
    return m.groupby(["motion", "band"], observed=True).agg(n=("det", "size"), p_window=("det", "mean"), image_speed=("speed", "median"))


def _load(d):
    """A recording's visibility table, oblique cameras and projection matrices, the floor plan's
    ``Occluders``, each person's truth sorted by time, and its windows by (time, camera)."""
    rec = read_recording(d)
    vis = rec.truth.tables["visibility"]
    boxes = rec.observations["boxes"]
    bx = {k: g for k, g in boxes.groupby([boxes.t.round(6), "camera"])}
    cams = rec.calibration.cameras_of_kind("oblique")
    Ps = {c: np.asarray(cam.P, float) for c, cam in cams.items()}
    occ = Occluders(rec.calibration.floorplan, Ps, HEIGHT)
    pp = {pid: g.sort_values("t").reset_index(drop=True) for pid, g in rec.truth.people.groupby("person_id")}
    return vis, cams, Ps, occ, pp, bx


MOVERS = ("target", "distractor")


def _truth_row(pp: dict, pid: str, t: float) -> tuple[pd.DataFrame, int]:
    """Person ``pid``'s truth (``pp``, sorted by time) and the index of its row at time t (the
    first at or after it, the last one beyond the end)."""
    p = pp[pid]
    return p, min(int(np.searchsorted(p.t.to_numpy(), t - 1e-9)), len(p) - 1)


def _mover_view(cam, P: np.ndarray, pp: dict, pid: str, k: int) -> tuple:
    """Mover ``pid`` at its truth row k in camera ``cam`` (projection matrix P): its floor
    position and velocity, its image speed (px/s), its projected cylinder (the tracker's person
    model), and the other mover's floor position and projected cylinder."""
    x, y, z, vx, vy = pp[pid][["x", "y", "z", "vx", "vy"]].to_numpy()[k]
    uv, _ = cam.project(np.array([[x, y, z], [x + 0.01 * vx, y + 0.01 * vy, z]]))
    win = geo.cylinder_window(P, np.array([x, y]), HEIGHT, RADIUS)
    o = pp[next(m for m in MOVERS if m != pid)]
    ox, oy = o.x.iloc[k], o.y.iloc[k]
    wo = geo.cylinder_window(P, np.array([ox, oy]), HEIGHT, RADIUS)
    return x, y, vx, vy, float(np.hypot(*(uv[1] - uv[0]) / 0.01)), win, ox, oy, wo


def recording_rows(d, slowing: bool = False) -> list[tuple]:
    """One row per mover, oblique camera and frame as above (walking movers only, or with
    ``slowing`` every frame of a mover, walking or not, with its ground speed and its change over
    the last tenth of a second)."""
    rows = []
    vis, cams, Ps, occ, pp, bx = _load(d)
    standing = [q for q in pp if q not in MOVERS]
    for r in vis[vis.in_fov & vis.person_id.isin(MOVERS)].itertuples():
        if r.camera not in Ps: continue
        p, k = _truth_row(pp, r.person_id, r.t)
        walking = bool(p.walking.iloc[k])
        if not (walking or slowing): continue
        P = Ps[r.camera]; cam = cams[r.camera]
        x, y, vx, vy, sp, win, ox, oy, wo = _mover_view(cam, P, pp, r.person_id, k)
        if win[1] < 0 or win[0] > cam.width: continue
        if not occ.visible(r.camera, np.array([x, y])): continue
        C = occ.centres[r.camera]
        u = 0.5 * (win[0] + win[1])
        hid = np.hypot(ox - C[0], oy - C[1]) < np.hypot(x - C[0], y - C[1]) and wo[0] <= u <= wo[1]
        near_other = wo[0] <= win[1] and win[0] <= wo[1]
        dist = np.hypot(x - C[0], y - C[1])
        cover = 0.0  # share of the person's span behind a nearer standing person's span
        for q in standing:
            sq = pp[q].iloc[min(k, len(pp[q]) - 1)]
            if np.hypot(sq.x - C[0], sq.y - C[1]) < dist:
                ws = geo.cylinder_window(P, np.array([sq.x, sq.y]), HEIGHT, RADIUS)
                cover = max(cover, max(0.0, min(ws[1], win[1]) - max(ws[0], win[0])) / max(win[1] - win[0], 1e-9))
        g = bx.get((round(float(r.t), 6), r.camera))
        det = overlap = False
        if g is not None:
            det = bool(((g.u_left.to_numpy() - 3 <= u) & (u <= g.u_right.to_numpy() + 3)).any())
            overlap = bool(((g.u_left.to_numpy() <= win[1]) & (g.u_right.to_numpy() >= win[0])).any())
        kb = max(k - BACK_STEPS, 0)  # the ground speed a tenth of a second before: slowing or speeding up
        gs, gs0 = float(np.hypot(vx, vy)), float(np.hypot(p.vx.iloc[kb], p.vy.iloc[kb]))
        rows.append((d, r.t, r.camera, r.person_id, sp, hid, near_other, det, overlap, cover, walking, gs, gs - gs0))
    return rows


BORDER_COLUMNS = ["rec", "cam", "pid", "t", "inside_px", "det"]
BORDER_BANDS = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, np.inf)  # px of the projected cylinder inside the image


def border_rows(d) -> list[tuple]:
    """``--border``: one row per walking mover, oblique camera and frame where the mover's
    projected cylinder (the tracker's person model) lies at least in part inside the image,
    moving at least 8 px/s, not hidden by the floor plan's boxes and apart from the other mover
    (their cylinders' columns do not meet): the cylinder's columns inside the image (px) and
    whether a window overlaps that part (+-3 px). Every such frame, in the camera's field of view
    by the truth or not: the tracker knows only the cylinder."""
    rows = []
    vis, cams, Ps, occ, pp, bx = _load(d)
    for r in vis[vis.person_id.isin(MOVERS)].itertuples():
        if r.camera not in Ps: continue
        p, k = _truth_row(pp, r.person_id, r.t)
        if not bool(p.walking.iloc[k]): continue
        cam = cams[r.camera]
        x, y, _, _, sp, win, _, _, wo = _mover_view(cam, Ps[r.camera], pp, r.person_id, k)
        lo, hi = max(float(win[0]), 0.0), min(float(win[1]), float(cam.width))
        if not np.isfinite(win[:2]).all() or hi <= lo or sp < 8.0: continue
        if not occ.visible(r.camera, np.array([x, y])): continue
        if wo[0] <= win[1] and win[0] <= wo[1]: continue
        g = bx.get((round(float(r.t), 6), r.camera))
        det = g is not None and bool(((g.u_left.to_numpy() <= hi + 3) & (g.u_right.to_numpy() >= lo - 3)).any())
        rows.append((d, r.camera, r.person_id, r.t, hi - lo, det))
    return rows


def border_table(df: pd.DataFrame) -> pd.DataFrame:
    """P(a window) by the columns of the mover's cylinder inside the image (``BORDER_BANDS``)."""
    band = pd.cut(df.inside_px, BORDER_BANDS)
    return df.assign(band=band).groupby("band", observed=True).agg(n=("det", "size"), p_window=("det", "mean"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR")
    ap.add_argument("--slowing", action="store_true", help="also the rate of a window by ground speed, slowing, speeding up or steady")
    ap.add_argument("--border", action="store_true", help="only the rate of a window by the columns of the mover's "
                    "cylinder inside the image (a walker cut by the image border)")
    a = ap.parse_args(argv)
    if a.border:
        df = pd.DataFrame([r for d in recording_folders(a.recordings, ap.prog) for r in border_rows(d)], columns=BORDER_COLUMNS)
        print("walking movers partly or wholly inside the image, moving >= 8 px/s, not hidden, apart from the other mover:")
        print("P(a window overlapping the part inside) by its columns inside the image (px)")
        print(border_table(df).round(3).to_string())
        return 0
    rows = [r for d in recording_folders(a.recordings, ap.prog) for r in recording_rows(d, a.slowing)]
    every = pd.DataFrame(rows, columns=COLUMNS)
    df = every[every.walking]
    m = df[~df.hid & (df.speed >= 8)]
    print(f"in view, not hidden by boxes or the other mover, speed >= 8: n={len(m)} P(window on axis)={m.det.mean():.3f}; apart from the other mover: {m[~m.near].det.mean():.3f}")
    for lo, hi in ((8, 12), (12, 25), (25, 1e9)):
        g = m[(m.speed >= lo) & (m.speed < hi)]; print(f"  speed {lo}-{hi}: n={len(g)} {g.det.mean():.3f}")
    print(f"hidden by the other mover: n={df.hid.sum()} {df[df.hid].det.mean():.3f}")
    m = m.sort_values(["rec", "cam", "pid", "t"])
    runs = []
    for _, g in m.groupby(["rec", "cam", "pid"]):
        t = g.t.to_numpy(); det = g.det.to_numpy(); cur = 0
        for i in range(len(t)):
            if i and t[i] - t[i - 1] > 0.15:
                if cur: runs.append(cur)
                cur = 0
            if not det[i]: cur += 1
            elif cur: runs.append(cur); cur = 0
        if cur: runs.append(cur)
    runs = np.array(runs)
    print("miss runs:", len(runs), "mean", runs.mean().round(2), "median", np.median(runs), "p90", np.percentile(runs, 90), "max", runs.max())
    c = df[~df.hid & (df.speed >= 8)]
    c = c.assign(cover=pd.cut(c.cover, [-0.01, 0.0, 0.5, 0.9, 1.01], labels=["none", "< 0.5", "0.5-0.9", ">= 0.9"]))
    print("by the share covered by a nearer standing person: window on the axis, any window overlapping the person")
    print(c.groupby("cover", observed=True).agg(n=("det", "size"), on_axis=("det", "mean"), overlapping=("overlap", "mean")).round(3).to_string())
    if a.slowing:
        print("by ground speed (m/s), movers in view, not hidden and apart from the other mover: window on the axis")
        print(slowing_table(every).round(3).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
