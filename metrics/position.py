"""Position error over matched frames, overall and split by how many cameras saw the person.

For the CLEAR MOT correspondences (``metrics/mot.py``; matches and ID switches alike) with floor
distances d_i = |p_truth - p_track| (metres):

    RMSE = sqrt(mean_i d_i^2),   p50, p90, p95 = percentiles of d_i (linear interpolation).

The split uses the ``cameras`` column of the truth frames (how many cameras had the person
``visible`` at that time; see ``metrics/score.py``): groups 0, 1 and >= 2 (suffixes ``_cam0``,
``_cam1``, ``_cam2plus``). A group with no matched frames gives NaN.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .mot import EvalFrames, MotResult

CAMERA_GROUPS = (("cam0", 0, 0), ("cam1", 1, 1), ("cam2plus", 2, np.inf))
PERCENTILES = (50, 90, 95)


def error_stats(d: np.ndarray) -> dict[str, float]:
    """RMSE and percentiles (metres) of distances d; NaN when d is empty."""
    d = np.asarray(d, float)
    out = {"rmse": float(np.sqrt(np.mean(d**2))) if d.size else float("nan")}
    for p in PERCENTILES:
        out[f"p{p}"] = float(np.percentile(d, p)) if d.size else float("nan")
    return out


def matched_errors(frames: EvalFrames, mot: MotResult) -> pd.DataFrame:
    """The matches with the number of cameras that saw the person (``cameras``; -1 unknown)."""
    m = mot.matches[["frame", "t", "person_id", "track_id", "distance"]]
    if "cameras" in frames.truth.columns:
        m = m.merge(frames.truth[["frame", "person_id", "cameras"]], on=["frame", "person_id"], how="left")
        m["cameras"] = m["cameras"].fillna(-1).astype(int)
    else:
        m = m.assign(cameras=-1)
    return m


def position_errors(frames: EvalFrames, mot: MotResult) -> dict[str, float]:
    """``rmse, p50, p90, p95`` over all matches, then ``rmse_cam0, n_cam0, ...`` per camera group."""
    m = matched_errors(frames, mot)
    d = m["distance"].to_numpy(float)
    out = error_stats(d)
    cams = m["cameras"].to_numpy(int)
    for name, lo, hi in CAMERA_GROUPS:
        sel = (cams >= lo) & (cams <= hi)
        out[f"rmse_{name}"] = error_stats(d[sel])["rmse"]
        out[f"n_{name}"] = int(sel.sum())
    return out
