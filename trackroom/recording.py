"""The Recording contract: what a simulation run produces (see DESIGN.md).

A ``Recording`` = ``Calibration`` + ``Observations`` (what a real system would have) + ``Truth``
(kept apart: estimators never get it). This module imports no MuJoCo, so estimators may use it.

Observation tables (pandas DataFrames, one row per measurement, time ``t`` in seconds):

- ``bearings``: ``t, camera, u, label`` (+ ``width`` in rendered mode). ``u`` is the horizontal
  image coordinate in pixels of a person seen by a horizontal (or oblique) camera; ``label`` is an
  appearance class (the colour name), never a ground-truth id.
- ``boxes``: ``t, camera, track, u, u_left, u_right, v_top, v_bottom, flow_u, flow_v`` from oblique
  cameras: the tracking window (pixels), its horizontal centroid ``u``, and the mean image flow of
  the region in pixels per second. ``track`` is the camera's own tracker id (a new id after the
  person was lost), not a person id.
- ``floor_detections``: ``t, camera, x, y`` anonymous floor positions (m) from overhead cameras.
- ``imu``: ``t, phone_id, ax, ay, az, gx, gy, gz, mx, my, mz``: phone accelerometer (m/s^2,
  specific force in the phone frame), gyro (rad/s) and magnetometer (field units, phone frame).

Truth tables:

- ``people``: ``t, person_id, x, y, z, yaw, vx, vy, walking, phone_id`` at the simulation rate
  (``phone_id`` is "" for a person without a phone; ``z`` is the body centre height).
- ``visibility``: ``t, camera, person_id, in_fov, visible`` for every camera frame and person:
  ``visible`` = in the field of view and not occluded (what the camera could observe).
- ``labels`` (rendered mode): ``t, camera, person_id, pixels, visible_fraction, x0, y0, x1, y1``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from trackroom.scenes.camera import Camera
from trackroom.scenes.spec import Floorplan

OBSERVATION_COLUMNS: dict[str, list[str]] = {
    "bearings": ["t", "camera", "u", "label"],
    "boxes": ["t", "camera", "track", "u", "u_left", "u_right", "v_top", "v_bottom", "flow_u", "flow_v"],
    "floor_detections": ["t", "camera", "x", "y"],
    "imu": ["t", "phone_id", "ax", "ay", "az", "gx", "gy", "gz", "mx", "my", "mz"],
}
TRUTH_COLUMNS: dict[str, list[str]] = {
    "people": ["t", "person_id", "x", "y", "z", "yaw", "vx", "vy", "walking", "phone_id"],
    "visibility": ["t", "camera", "person_id", "in_fov", "visible"],
    "labels": ["t", "camera", "person_id", "pixels", "visible_fraction", "x0", "y0", "x1", "y1"],
}
SENSING_MODES = ("analytic", "rendered")


class RecordingError(ValueError):
    """A recording (or an observation table) that cannot be used, with the reason."""


def empty_table(kind: str) -> pd.DataFrame:
    cols = OBSERVATION_COLUMNS.get(kind) or TRUTH_COLUMNS[kind]
    return pd.DataFrame({c: pd.Series(dtype=object if c in ("camera", "label", "phone_id", "person_id") else float) for c in cols})


def check_table(kind: str, df: pd.DataFrame) -> pd.DataFrame:
    """Validate an observation or truth table: required columns, finite numbers, sorted by time."""
    cols = OBSERVATION_COLUMNS.get(kind) or TRUTH_COLUMNS.get(kind)
    if cols is None:
        raise RecordingError(f"unknown table kind {kind!r}")
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise RecordingError(f"{kind}: missing columns {missing}")
    num = df.select_dtypes(include=[np.number])
    if len(df) and not np.isfinite(num.to_numpy(float)).all():
        bad = [c for c in num.columns if not np.isfinite(num[c].to_numpy(float)).all()]
        raise RecordingError(f"{kind}: non-finite values (NaN or inf) in columns {bad}")
    if len(df) and (np.diff(df["t"].to_numpy(float)) < 0).any():
        raise RecordingError(f"{kind}: rows are not sorted by time")
    return df


@dataclass
class Calibration:
    """What a user of a real network would have measured: cameras, floor plan, sensor noise."""

    cameras: dict[str, Camera]
    floorplan: Floorplan
    noise: dict[str, float] = field(default_factory=dict)  # calibrated sensor noise (SensorSpec fields)

    def cameras_of_kind(self, *kinds: str) -> dict[str, Camera]:
        return {n: c for n, c in self.cameras.items() if c.kind in kinds}


@dataclass
class Observations:
    """The observation tables of one recording (kinds absent from the scene are empty)."""

    tables: dict[str, pd.DataFrame]
    duration: float

    def __getitem__(self, kind: str) -> pd.DataFrame:
        return self.tables.get(kind, empty_table(kind)) if kind in OBSERVATION_COLUMNS else self.tables[kind]

    def has(self, kind: str) -> bool:
        return kind in self.tables and len(self.tables[kind]) > 0

    def kinds(self) -> list[str]:
        return [k for k in OBSERVATION_COLUMNS if self.has(k)]


@dataclass
class Truth:
    """Ground truth, kept apart from observations."""

    tables: dict[str, pd.DataFrame]

    @property
    def people(self) -> pd.DataFrame:
        return self.tables["people"]

    @property
    def visibility(self) -> pd.DataFrame:
        return self.tables.get("visibility", empty_table("visibility"))


@dataclass
class Recording:
    """One simulation run. ``meta`` holds the scene, seed, sensing mode, versions and the
    walkers' motion-model parameters (e.g. the Gauss-Markov prior for matched-prior runs);
    ``scene_toml`` the resolved scene it was simulated from (TOML text), when known."""

    calibration: Calibration
    observations: Observations
    truth: Truth
    meta: dict[str, Any] = field(default_factory=dict)
    scene_toml: str | None = field(default=None, repr=False)

    @property
    def scene(self) -> str:
        return self.meta.get("scene", "")

    @property
    def seed(self) -> int:
        return int(self.meta.get("seed", 0))

    @property
    def sensing(self) -> str:
        return self.meta.get("sensing", "analytic")

    @property
    def duration(self) -> float:
        return self.observations.duration
