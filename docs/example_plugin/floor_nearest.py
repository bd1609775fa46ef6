"""``floor_nearest``: an example estimator plug-in for trackroom (docs/plugins.md).

Overhead cameras report anonymous floor positions (``floor_detections``: t, camera, x, y in
metres). Per frame, detections closer than ``duplicate_m`` are one person (neighbouring cameras
both see someone at a tile border; single-linkage clusters, averaged), and each person is joined
to the nearest track seen within the last ``max_missed_s`` seconds by minimising the summed
distance (``scipy.optimize.linear_sum_assignment``) with a ``gate_m`` gate; the others start new
tracks. No motion model: a deliberately plain baseline.

Installed (``pip install docs/example_plugin``), the entry point in its pyproject registers it;
without installing, ``--plugin docs/example_plugin/floor_nearest.py`` loads this file.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.optimize import linear_sum_assignment

from trackroom.estimators import Estimator, EstimatorError, param, register
from trackroom.recording import Calibration, Observations


@register
class FloorNearest(Estimator):
    """Nearest-neighbour tracking of overhead floor detections (module docstring)."""

    name = "floor_nearest"
    description = "example plug-in: overhead floor detections joined frame to frame by nearest neighbour"
    requires = ("floor_detections",)

    @dataclasses.dataclass
    class Config:
        gate_m: float = param(1.0, "a person farther than this from every live track starts a new track, m")
        duplicate_m: float = param(0.3, "detections of one frame closer than this are one person, m")
        max_missed_s: float = param(0.5, "a track not seen for longer than this is not continued, s")

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        c = self.config
        if not (c.gate_m > 0 and c.duplicate_m >= 0 and c.max_missed_s >= 0):
            raise EstimatorError(f"{self.name}: need gate_m > 0, duplicate_m >= 0 and max_missed_s >= 0")
        det = observations["floor_detections"]
        pos, ids, seen = np.empty((0, 2)), np.empty(0, int), np.empty(0)  # live tracks: last position, id, time
        rows, next_id = [], 0
        for t, frame in det.groupby("t", sort=True):
            xy = merge_duplicates(frame[["x", "y"]].to_numpy(float), c.duplicate_m)
            live = t - seen <= c.max_missed_s
            pos, ids, seen = pos[live], ids[live], seen[live]
            new_id = np.full(len(xy), -1)
            if len(pos) and len(xy):
                dist = np.linalg.norm(xy[:, None, :] - pos[None, :, :], axis=2)
                r, k = linear_sum_assignment(dist)
                ok = dist[r, k] <= c.gate_m
                new_id[r[ok]] = ids[k[ok]]
            fresh = new_id < 0
            new_id[fresh] = next_id + np.arange(fresh.sum())
            next_id += int(fresh.sum())
            rows += [(float(t), int(i), float(x), float(y)) for i, (x, y) in zip(new_id, xy)]
            kept = ~np.isin(ids, new_id)  # tracks not seen this frame stay live until max_missed_s
            pos = np.concatenate([pos[kept], xy])
            ids = np.concatenate([ids[kept], new_id])
            seen = np.concatenate([seen[kept], np.full(len(xy), float(t))])
        return pd.DataFrame(rows, columns=["t", "track_id", "x", "y"])


def merge_duplicates(xy: np.ndarray, within: float) -> np.ndarray:
    """Points closer than ``within`` (m, single linkage) replaced by their cluster's mean."""
    if len(xy) < 2 or within <= 0:
        return xy
    label = fcluster(linkage(xy, "single"), within, criterion="distance")
    return np.array([xy[label == k].mean(axis=0) for k in np.unique(label)])
