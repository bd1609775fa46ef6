"""Frame-wise access to the ``boxes`` table for the target-plane tracker.

The oblique cameras' tracking windows (``trackroom/recording.py``: ``t, camera, track, u, u_left,
u_right, v_top, v_bottom, flow_u, flow_v``) are split once into one ``CameraBoxes`` per camera
and frame, so the tracker's loop over frames does no pandas work.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from trackroom.recording import Calibration, RecordingError

BOX_COLUMNS = ["t", "camera", "track", "u", "u_left", "u_right", "v_top", "v_bottom", "flow_u", "flow_v"]


@dataclass(frozen=True)
class CameraBoxes:
    """The windows one camera reports in one frame (k boxes).

    ``track`` (k,): the camera's own tracker ids; ``win`` (k, 4): u_left, u_right, v_top,
    v_bottom (px); ``u`` (k,): horizontal centroid of the region (px); ``flow`` (k, 2): mean image
    flow (px/s).
    """

    track: np.ndarray
    u: np.ndarray
    win: np.ndarray
    flow: np.ndarray

    def __len__(self) -> int:
        return len(self.u)

    @property
    def width(self) -> np.ndarray:
        return self.win[:, 1] - self.win[:, 0]

    def box(self, j: int) -> tuple[float, float, float, float, float]:
        """(u, u_left, u_right, v_top, v_bottom) of box j."""
        return (float(self.u[j]), *map(float, self.win[j]))

    def with_box(self, track, win, flow) -> tuple["CameraBoxes", int]:
        """These windows plus one more (its centroid u the window's centre); returns the new
        frame and the index of the added window."""
        win = np.asarray(win, float).reshape(1, 4)
        tr = np.empty(len(self) + 1, object)
        tr[:-1], tr[-1] = self.track, track
        out = CameraBoxes(tr, np.append(self.u, 0.5 * (win[0, 0] + win[0, 1])), np.vstack([self.win, win]),
                          np.vstack([self.flow, np.asarray(flow, float).reshape(1, 2)]))
        return out, len(self)

    @staticmethod
    def empty() -> "CameraBoxes":
        return CameraBoxes(np.array([], object), np.zeros(0), np.zeros((0, 4)), np.zeros((0, 2)))


def frame_times(calibration: Calibration, cameras: list[str], duration: float, boxes: pd.DataFrame) -> np.ndarray:
    """Sorted frame times (s) of the oblique cameras: every camera's capture times over the
    recording (so a frame where no one is seen still counts), plus any time in the table."""
    ts = [calibration.cameras[c].frame_times(duration) for c in cameras]
    ts.append(boxes["t"].to_numpy(float))
    return np.unique(np.round(np.concatenate(ts), 6))


def mean_flows(boxes: pd.DataFrame, flow_window: int) -> pd.DataFrame:
    """``boxes`` with each window's flow replaced by the causal mean over the last ``flow_window``
    frames of the same camera track (rows in time order within each track)."""
    if flow_window <= 1 or not len(boxes):
        return boxes
    df = boxes.copy()
    g = df.groupby(["camera", "track"], sort=False)[["flow_u", "flow_v"]]
    df[["flow_u", "flow_v"]] = g.transform(lambda s: s.rolling(flow_window, min_periods=1).mean())
    return df


def mean_lag_s(n: int, dt: float) -> float:
    """How far the causal mean of a velocity over its last ``n`` samples, ``dt`` apart, strays
    from the present velocity: Var(v(t) - mean_i v(t - i dt)) per unit of white-acceleration
    intensity (m^2/s^3), in s: dt / n^2 sum_{i,j<n} min(i, j) (n = 5: 1.2 dt; n = 1: 0)."""
    i = np.arange(max(int(n), 1))
    return float(dt * np.minimum.outer(i, i).sum() / len(i) ** 2)


def split_boxes(boxes: pd.DataFrame, cameras: list[str], flow_window: int = 1) -> dict[float, dict[str, CameraBoxes]]:
    """``{t: {camera: CameraBoxes}}`` for the given cameras (time rounded to 1 us).

    ``flow_window``: each window's flow is the causal mean over the last ``flow_window`` frames
    of the same camera track (the camera's own tracker history), which divides the flow noise
    by sqrt(flow_window).
    """
    missing = [c for c in BOX_COLUMNS if c not in boxes.columns]
    if missing:
        raise RecordingError(f"boxes: missing columns {missing}")
    df = mean_flows(boxes[boxes["camera"].isin(cameras)], flow_window)
    num = df[["u", "u_left", "u_right", "v_top", "v_bottom", "flow_u", "flow_v"]].to_numpy(float)
    if len(df) and not np.isfinite(num).all():
        raise RecordingError("boxes: non-finite window or flow values")
    if len(df) and (num[:, 2] < num[:, 1]).any():
        raise RecordingError("boxes: a window has u_right < u_left")
    out: dict[float, dict[str, CameraBoxes]] = {}
    t = np.round(df["t"].to_numpy(float), 6)
    cam = df["camera"].to_numpy(object)
    track = df["track"].to_numpy(object)
    order = np.lexsort((cam.astype(str), t))
    t, cam, track, num = t[order], cam[order], track[order], num[order]
    keys = np.stack([t.astype(str), cam.astype(str)], 1) if len(t) else np.zeros((0, 2), str)
    if len(t):
        breaks = np.flatnonzero((keys[1:] != keys[:-1]).any(1)) + 1
        for s, e in zip(np.r_[0, breaks], np.r_[breaks, len(t)]):
            out.setdefault(float(t[s]), {})[str(cam[s])] = CameraBoxes(
                track=track[s:e], u=num[s:e, 0], win=num[s:e, 1:5], flow=num[s:e, 5:7]
            )
    return out


def person_detections(observations, cameras: list[str]) -> tuple[dict[float, dict[str, np.ndarray]] | None, list[str]]:
    """``({t: {camera: u (n,)}}, the cameras with any)``: the oblique cameras' person
    detections, the ``bearings`` table's columns t, camera and u (time rounded to 1 us; its
    colour labels are not read). A camera with detections in the table has none at a frame
    time that is not in the first. ``(None, [])`` for a recording without the table (flow
    windows alone)."""
    if not observations.has("bearings"):
        return None, []
    b = observations["bearings"]
    missing = [c for c in ("t", "camera", "u") if c not in b.columns]
    if missing:
        raise RecordingError(f"bearings: missing columns {missing}")
    b = b[b["camera"].isin(cameras)]
    u = b["u"].to_numpy(float)
    if len(u) and not np.isfinite(u).all():
        raise RecordingError("bearings: non-finite u")
    out: dict[float, dict[str, np.ndarray]] = {}
    for (t, c), g in b.groupby([np.round(b["t"].to_numpy(float), 6), b["camera"].to_numpy(str)]):
        out.setdefault(float(t), {})[str(c)] = g["u"].to_numpy(float)
    return out, sorted(set(b["camera"].astype(str)))
