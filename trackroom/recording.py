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
# Column types: ids are strings, flags are true/false, every other column is a number.
STRING_COLUMNS = frozenset({"camera", "label", "phone_id", "person_id"})
FLAG_COLUMNS = frozenset({"walking", "in_fov", "visible"})


class RecordingError(ValueError):
    """A recording (or an observation table) that cannot be used, with the reason."""


def empty_table(kind: str) -> pd.DataFrame:
    cols = OBSERVATION_COLUMNS.get(kind) or TRUTH_COLUMNS[kind]
    return pd.DataFrame({c: pd.Series(dtype=object if c in STRING_COLUMNS else float) for c in cols})


def check_table(kind: str, df: pd.DataFrame) -> pd.DataFrame:
    """Validate an observation or truth table: required columns of the right types (ids strings,
    flags true/false, the rest numbers), finite numbers, sorted by time."""
    cols = OBSERVATION_COLUMNS.get(kind) or TRUTH_COLUMNS.get(kind)
    if cols is None:
        raise RecordingError(f"unknown table kind {kind!r}")
    if not isinstance(df, pd.DataFrame):
        raise RecordingError(f"{kind}: expected a table, got {type(df).__name__}")
    if not df.columns.is_unique:
        raise RecordingError(f"{kind}: repeated column names {sorted(set(df.columns[df.columns.duplicated()]))}")
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise RecordingError(f"{kind}: missing columns {missing}")
    if not len(df):
        return df
    for c in cols:
        problem = _column_problem(c, df[c])
        if problem:
            raise RecordingError(f"{kind}: column {c!r} {problem}")
    numeric = [c for c in df.columns if _is_number_column(df[c])]
    bad = [c for c in numeric if not np.isfinite(df[c].to_numpy(float, na_value=np.nan)).all()]
    if bad:
        raise RecordingError(f"{kind}: non-finite values (NaN or inf) in columns {bad}")
    if (np.diff(df["t"].to_numpy(float)) < 0).any():
        raise RecordingError(f"{kind}: rows are not sorted by time")
    return df


def _is_number_column(s: pd.Series) -> bool:
    return (pd.api.types.is_integer_dtype(s) or pd.api.types.is_float_dtype(s)) and not pd.api.types.is_bool_dtype(s)


def _column_problem(name: str, s: pd.Series) -> str | None:
    """Why column ``name`` does not hold what the contract says, or None."""
    if name in STRING_COLUMNS:
        if s.isna().any():
            return "has missing values (ids are strings; a phone-less person has \"\")"
        values = s.cat.categories if isinstance(s.dtype, pd.CategoricalDtype) else s
        if pd.api.types.infer_dtype(values, skipna=False) not in ("string", "empty"):
            return f"must hold strings (ids), found {s.dtype} values such as {repr(s.iloc[0])[:40]}"
    elif name in FLAG_COLUMNS:
        if s.isna().any():
            return "has missing values (flags are true or false)"
        if not (pd.api.types.is_bool_dtype(s) or (_is_number_column(s) and s.isin([0, 1]).all())):
            return f"must hold true/false, found {s.dtype}"
    elif not _is_number_column(s):
        return f"must be numeric, found {s.dtype} values such as {repr(s.iloc[0])[:40]}"
    return None


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
