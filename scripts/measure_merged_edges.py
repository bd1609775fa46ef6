"""How far a merged window's outer edges lie from the outermost person's, against one person's own.

    python -m scripts.measure_merged_edges DIR [DIR ...]     # occlusion_lab recordings, either mode

``target_planes`` updates a track by a window's edge in two ways: a window of the track alone
gives both edges with the noise ``edge_sigma`` (``JointTracker.edge_sigma``: the box noise and
``edge_sigma_frac`` of the projected width), and a merged window gives each outer edge to its
outermost member with ``outer_edge_sigma``, twice that. This script measures both against the
truth: for every oblique camera's window, the walking people whose projected cylinders
(``tp_geometry.cylinder_window``, the tracker's height and radius) lie at least half inside it
are its members. A window is used when it touches no other walking person's projection, every
member is wholly visible (``tp_joint.Occluders``) and wholly in the image, and the window does not
reach the image border. Its left edge's error is its ``u_left`` minus the leftmost member's
projected left edge, the right edge likewise. Each error is also given in units of the outermost
member's ``edge_sigma``.

Printed, for windows of one member and of two or more: the number of edges, the median, the
robust sigma (1.4826 MAD) and the standard deviation of the errors in ``edge_sigma`` units, and
the median and robust sigma in px; and how the errors persist from frame to frame: the number of
edges also measured in the next frame (the same camera track's same side, of the same kind),
the rank correlation of the two errors and the sd of their change (errors independent from frame
to frame: 0 and sqrt(2) sd; a Kalman filter takes an edge's change between frames as motion).
The truth is read here, by the experimenter (issue 12's eighty-fourth session: is the merged
edges' doubled noise what the windows show? eighty-eighth: do their errors persist?).
"""
from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.measure_pooled import run_pooled
from trackroom.dataset import read_recording
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_joint import BORDER_PX, Occluders, edge_noise
from trackroom.metrics.aggregate import robust_sigma


def edge_errors(people: np.ndarray, visible: np.ndarray, windows: np.ndarray, width: float) -> list:
    """The outer-edge errors of one camera's windows in one frame.

    ``people`` (k, 2): each walking person's projected [left, right] columns (NaN: behind the
    camera); ``visible`` (k,): wholly visible; ``windows`` (m, 2): the windows' [u_left, u_right];
    ``width``: the image width, px. Returns (members, side, error px, the outermost member's
    projected width) for each edge of each usable window (module docstring)."""
    out = []
    ok = np.isfinite(people).all(1)
    in_image = ok & (people[:, 0] > 0.0) & (people[:, 1] < width)
    for ul, ur in np.asarray(windows, float).reshape(-1, 2):
        if ul <= BORDER_PX or ur >= width - BORDER_PX:
            continue
        overlap = np.where(ok, np.minimum(people[:, 1], ur) - np.maximum(people[:, 0], ul), 0.0)
        inside = ok & (overlap >= 0.5 * (people[:, 1] - people[:, 0]))
        touching = ok & (overlap > 0.0) & ~inside
        if not inside.any() or touching.any() or not (visible[inside] & in_image[inside]).all():
            continue
        idx = np.flatnonzero(inside)
        kl, kr = idx[np.argmin(people[idx, 0])], idx[np.argmax(people[idx, 1])]
        n = len(idx)
        out.append((n, "left", float(ul - people[kl, 0]), float(people[kl, 1] - people[kl, 0])))
        out.append((n, "right", float(ur - people[kr, 1]), float(people[kr, 1] - people[kr, 0])))
    return out


def recording_edges(folder: str) -> pd.DataFrame:
    """Every usable edge of one recording's oblique windows (``edge_errors``), with ``z``: the
    error over the outermost member's ``edge_sigma``."""
    from scripts.experiment_tsutsui import estimator_config, people_at

    rec = read_recording(folder)
    cfg = TargetPlanes(initial_xy=[0.0, 0.0], **estimator_config(rec)).resolved_config(rec.calibration)
    cams = rec.calibration.cameras_of_kind("oblique")
    Ps = {c: np.asarray(rec.calibration.cameras[c].P, float) for c in cams}
    fps = {c: float(rec.calibration.cameras[c].fps) for c in cams}
    occ = Occluders(rec.calibration.floorplan, Ps, cfg.height)
    boxes = rec.observations["boxes"]
    times = np.sort(boxes["t"].unique())
    walkers = people_at(rec.truth.people, times, ("x", "y", "walking"))
    walkers = walkers[walkers["walking"].astype(bool)]
    by_t = {t: g[["x", "y"]].to_numpy(float) for t, g in walkers.groupby("t")}
    rows = []
    for (t, c), g in boxes.groupby(["t", "camera"]):
        xy = by_t.get(t)
        if c not in Ps or xy is None:
            continue
        win = geo.cylinder_window(Ps[c], xy, cfg.height, cfg.radius)[:, :2]
        vis = np.asarray(occ.visible_many(c, xy, whole=True), bool)
        width = float(rec.calibration.cameras[c].width)
        for track, lr in zip(g["track"].to_numpy(), g[["u_left", "u_right"]].to_numpy(float)):
            for n, side, err, w in edge_errors(win, vis, lr[None], width):
                sigma = edge_noise(cfg.box_sigma_px, cfg.edge_sigma_frac, w)
                rows.append((folder, float(t), int(round(float(t) * fps[c])), c, int(track), n, side, err, err / sigma))
    return pd.DataFrame(rows, columns=["recording", "t", "frame", "camera", "track", "members", "side", "err_px", "z"])


def window_kind(members) -> np.ndarray:
    """Each edge's kind of window by its members' count: "one" or "two or more"."""
    return np.where(np.asarray(members) >= 2, "two or more", "one")


def lag_pairs(edges: pd.DataFrame) -> pd.DataFrame:
    """The same edge (recording, camera, camera track, side, one member or more) in two
    consecutive frames (``frame``: the camera's frame number): columns z0 (the earlier frame's
    error in ``edge_sigma`` units), z1 and kind."""
    e = edges.assign(kind=window_kind(edges["members"]), tk=edges["frame"].astype(int))
    keys = ["recording", "camera", "track", "side", "kind"]
    nxt = e.assign(tk=e["tk"] - 1)[keys + ["tk", "z"]]
    return e[keys + ["tk", "z"]].merge(nxt, on=keys + ["tk"], suffixes=("0", "1"))


def summarise(edges: pd.DataFrame) -> pd.DataFrame:
    """Per window kind (one member, two or more): edges, median / robust sigma / sd of ``z``, and
    median / robust sigma of the error in px."""
    kind = window_kind(edges["members"])
    pairs = lag_pairs(edges) if {"recording", "frame", "camera", "track", "side"} <= set(edges.columns) else None
    rows = []
    for k, g in edges.groupby(kind):
        row = {"members": k, "edges": len(g), "z_median": g["z"].median(), "z_robust_sigma": robust_sigma(g["z"]),
               "z_sd": g["z"].std(), "px_median": g["err_px"].median(), "px_robust_sigma": robust_sigma(g["err_px"])}
        if pairs is not None:
            pk = pairs[pairs["kind"] == k]
            row["next_frame_pairs"] = len(pk)
            # Spearman's rank correlation: the errors' tails are heavy
            row["next_frame_r"] = float(pk["z0"].corr(pk["z1"], method="spearman")) if len(pk) > 2 else float("nan")
            row["change_sd"] = float((pk["z1"] - pk["z0"]).std()) if len(pk) > 2 else float("nan")
        rows.append(row)
    return pd.DataFrame(rows)


def main(argv: list[str]) -> int:
    return run_pooled(argv, "measure_merged_edges", recording_edges, summarise, "no usable windows in these recordings", count=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
