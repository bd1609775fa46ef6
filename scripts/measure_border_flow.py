"""How the flow of a window cut by the image border follows its person.

    python -m scripts.measure_border_flow DIR [DIR ...]     # occlusion_lab recordings with truth labels
    python -m scripts.measure_border_flow --projection DIR [DIR ...]   # either mode: the truth's cylinders

For each oblique window that overlaps one labelled person only (``truth_labels``, at least
``MIN_PIXELS`` visible pixels), the window's horizontal flow against the person's image motion
from the labels between consecutive frames: for a person cut by the left (right) image border,
the motion of the label's inner, right (left), edge, the only edge the image shows; for a person
clear of both borders, the motion of the label's centre. Windows of cut people are split by
whether they reach the border (an edge within ``BORDER_PX`` of it, as ``target_planes``'
``cut_edges`` requires) or stop short of it. Printed per kind: windows, the error's median and
robust sigma (px/s), the gain (least-squares slope of the flow on the labels' motion) and, for a
cut person, the window's inner edge against the label's (px, window minus label, positive into
the image): its median, robust sigma, and the share more than ``INNER_FAR_PX`` off (the edge
``target_planes`` updates a track by, ``border_edges``). With
``--projection`` the labels are the truth's people projected as the tracker's cylinders
(``height``, ``radius``), clipped to the image, in the frames where the truth says each is visible
(``truth_visibility``): analytic recordings have no segmentation labels. The truth is read here,
by the experimenter.
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
from trackroom.estimators.tp_joint import BORDER_PX
from trackroom.metrics.aggregate import robust_sigma

HEIGHT, RADIUS = TargetPlanes.Config.height, TargetPlanes.Config.radius  # the tracker's person model, m
MIN_PIXELS = 200  # a label this small is a sliver whose box moves with the occluder, not the person
CLEAR_PX = 3.0  # a label this far inside both borders is of a person seen whole across
INNER_FAR_PX = 10.0  # an inner edge this far from the label's is counted as gross (``summary``)


def label_motion(labels: pd.DataFrame, fps: dict[str, float]) -> pd.DataFrame:
    """``labels`` with ``v_left``, ``v_right``, ``v_centre``: each label box's edge and centre
    image velocities (px/s) since the same person's label in the camera's previous frame; rows
    without a label one frame before are left out."""
    L = labels[labels["pixels"] >= MIN_PIXELS].sort_values(["camera", "person_id", "t"]).copy()
    g = L.groupby(["camera", "person_id"], sort=False)
    dt = g["t"].diff()
    L["v_left"] = g["x0"].diff() / dt
    L["v_right"] = g["x1"].diff() / dt
    L["v_centre"] = 0.5 * (L["v_left"] + L["v_right"])
    frame = 1.0 / L["camera"].map(fps).astype(float)
    return L[dt.notna() & (dt <= 1.5 * frame)]


def border_windows(boxes: pd.DataFrame, motion: pd.DataFrame, widths: dict[str, float]) -> pd.DataFrame:
    """One row per window over one labelled person only: ``kind`` (left-cut, right-cut, whole),
    ``reach`` (reaches, short; "-" for whole), the window's ``flow`` and the label's ``motion``
    (px/s; ``label_motion``), ``gap``, the window's distance from the cutting border (px), and
    ``inner``, the window's inner edge minus the label's, positive into the image (px; NaN for
    whole)."""
    by_frame = {k: g for k, g in motion.groupby([motion["t"].round(6), "camera"])}
    rows = []
    for (t, c), g in boxes.groupby([boxes["t"].round(6), "camera"]):
        lab = by_frame.get((t, c))
        if lab is None:
            continue
        W = float(widths[c])
        x0, x1 = lab["x0"].to_numpy(float), lab["x1"].to_numpy(float)
        for ul, ur, fu in g[["u_left", "u_right", "flow_u"]].to_numpy(float):
            over = np.minimum(ur, x1) - np.maximum(ul, x0) > 0
            if over.sum() != 1:
                continue
            k = int(np.flatnonzero(over)[0])
            p = lab.iloc[k]
            if x0[k] <= BORDER_PX and x1[k] < W - BORDER_PX:
                kind, v, gap, inner = "left-cut", float(p["v_right"]), float(ul), float(ur - x1[k])
            elif x1[k] >= W - BORDER_PX and x0[k] > BORDER_PX:
                kind, v, gap, inner = "right-cut", float(p["v_left"]), float(W - ur), float(x0[k] - ul)
            elif x0[k] > CLEAR_PX and x1[k] < W - CLEAR_PX:
                kind, v, gap, inner = "whole", float(p["v_centre"]), np.nan, np.nan
            else:
                continue
            reach = "-" if kind == "whole" else ("reaches" if gap <= BORDER_PX else "short")
            rows.append((float(t), c, kind, reach, float(fu), v, gap, inner))
    return pd.DataFrame(rows, columns=["t", "camera", "kind", "reach", "flow", "motion", "gap", "inner"])


def summary(windows: pd.DataFrame) -> pd.DataFrame:
    """Per kind and reach: windows, the error (flow - motion) median and robust sigma, the gain,
    and for cut people the inner edge's error (``inner``): median, robust sigma (px) and the
    share beyond ``INNER_FAR_PX``."""
    rows = []
    for (kind, reach), g in windows.groupby(["kind", "reach"]):
        err = g["flow"] - g["motion"]
        gain = float(np.polyfit(g["motion"], g["flow"], 1)[0]) if len(g) >= 3 and g["motion"].std() > 0 else np.nan
        inner = g["inner"].dropna()
        rows.append({"kind": kind, "reach": reach, "windows": len(g), "error median px/s": float(err.median()),
                     "error robust sigma px/s": robust_sigma(err), "gain": gain,
                     "inner median px": float(inner.median()), "inner robust sigma px": robust_sigma(inner),
                     f"inner beyond {INNER_FAR_PX:g} px": float((inner.abs() > INNER_FAR_PX).mean())})
    return pd.DataFrame(rows)


def projected_labels(rec) -> pd.DataFrame:
    """Label boxes (t, camera, person_id, pixels, x0, x1) from the truth: each person's cylinder
    (the tracker's ``height``, ``radius``) projected into each oblique camera at its window times,
    clipped to the image, where ``truth_visibility`` says the person is visible (``pixels`` then
    ``MIN_PIXELS``)."""
    from scripts.experiment_tsutsui import people_at

    cams = rec.calibration.cameras
    boxes = rec.observations["boxes"]
    vis = rec.truth.visibility
    if vis is None or not len(vis):
        raise SystemExit("measure_border_flow: --projection needs the truth's visibility (truth_visibility)")
    seen = {(round(float(t), 6), str(c), str(p)) for t, c, p in vis.loc[vis["visible"].astype(bool), ["t", "camera", "person_id"]].to_numpy()}
    rows = []
    for c, g in boxes.groupby("camera"):
        times = np.unique(np.round(g["t"].to_numpy(float), 6))
        at = people_at(rec.truth.people, times, ("x", "y"))
        P, W = np.asarray(cams[c].P, float), float(cams[c].width)
        win = geo.cylinder_window(P, at[["x", "y"]].to_numpy(float), HEIGHT, RADIUS)
        for (t, pid), (ul, ur) in zip(at[["t", "person_id"]].to_numpy(), win[:, :2]):
            if (round(float(t), 6), str(c), str(pid)) in seen and np.isfinite(ul) and ur > 0.0 and ul < W:
                rows.append((float(t), str(c), str(pid), MIN_PIXELS, max(float(ul), 0.0), min(float(ur), W)))
    return pd.DataFrame(rows, columns=["t", "camera", "person_id", "pixels", "x0", "x1"])


def recording_windows(folder: str, projection: bool = False) -> pd.DataFrame:
    """``border_windows`` of one recording: against its truth labels (rendered recordings have
    them), or with ``projection`` against ``projected_labels``."""
    rec = read_recording(folder)
    labels = projected_labels(rec) if projection else rec.truth.tables.get("labels")
    if labels is None or not len(labels):
        raise SystemExit(f"measure_border_flow: {folder} has no segmentation labels (truth_labels): a rendered recording "
                         "is needed, or --projection")
    cams = rec.calibration.cameras
    motion = label_motion(labels, {c: float(cams[c].fps) for c in cams})
    return border_windows(rec.observations["boxes"], motion, {c: float(cams[c].width) for c in cams})


def main(argv: list[str]) -> int:
    projection = "--projection" in argv
    dirs = [a for a in argv if a != "--projection"]
    return run_pooled(dirs, "measure_border_flow", lambda f: recording_windows(f, projection), summary,
                      "no window over one labelled person in these recordings")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
