"""The estimator interface and the registry.

An estimator is configured in its constructor (a typed ``Config`` dataclass of parameters with
defaults; no work done there) and does its work in one method::

    tracks = Estimator(**params).estimate(observations, calibration)

It never sees ground truth. ``requires`` lists observation kinds that must all be present;
``requires_any`` lists kinds of which at least one must be present. ``applies_to`` tells the
runner why an estimator does not apply to a recording (or None when it does).

Tracks are a DataFrame with columns ``t, track_id, x, y`` and optionally ``vx, vy`` (m/s),
``pxx, pxy, pyy`` (position covariance, m^2) and ``phone_id`` (the identity claimed; "" for none).
"""
from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from trackroom.recording import Calibration, Observations, RecordingError

TRACK_COLUMNS = ["t", "track_id", "x", "y"]
OPTIONAL_TRACK_COLUMNS = ["vx", "vy", "pxx", "pxy", "pyy", "phone_id"]

REGISTRY: dict[str, type["Estimator"]] = {}


class EstimatorError(ValueError):
    """An estimator cannot run on its input; the message says why."""


def register(cls):
    """Class decorator: add an estimator to the registry under ``cls.name``."""
    if cls.name in REGISTRY and REGISTRY[cls.name] is not cls:
        raise ValueError(f"estimator name {cls.name!r} registered twice")
    REGISTRY[cls.name] = cls
    return cls


class Estimator:
    """Base class: subclasses set ``name``, ``Config``, ``requires``/``requires_any`` and
    implement ``estimate``."""

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()
    requires_any: ClassVar[tuple[str, ...]] = ()

    @dataclasses.dataclass
    class Config:
        pass

    def __init__(self, **params: Any):
        fields = {f.name: f for f in dataclasses.fields(self.Config)}
        unknown = sorted(set(params) - set(fields))
        if unknown:
            raise EstimatorError(
                f"{self.name}: unknown parameter(s) {unknown}; known: {sorted(fields)}"
            )
        self.config = self.Config(**params)

    @classmethod
    def applies_to(cls, observations: Observations, calibration: Calibration) -> str | None:
        """None if the estimator can run on this input, else the reason it cannot."""
        missing = [k for k in cls.requires if not observations.has(k)]
        if missing:
            return f"needs {' and '.join(missing)} observations"
        if cls.requires_any and not any(observations.has(k) for k in cls.requires_any):
            return f"needs {' or '.join(cls.requires_any)} observations"
        return None

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        raise NotImplementedError


def check_tracks(df: pd.DataFrame, name: str = "tracks") -> pd.DataFrame:
    """Validate an estimator's output table; returns it with columns in canonical order."""
    missing = [c for c in TRACK_COLUMNS if c not in df.columns]
    if missing:
        raise EstimatorError(f"{name}: missing columns {missing}")
    for c in ("t", "x", "y"):
        if len(df) and not np.isfinite(df[c].to_numpy(float)).all():
            raise EstimatorError(f"{name}: non-finite values in column {c!r}")
    cols = TRACK_COLUMNS + [c for c in OPTIONAL_TRACK_COLUMNS if c in df.columns]
    return df[cols].sort_values(["t", "track_id"], kind="stable").reset_index(drop=True)


def coerce_param(cls: type[Estimator], key: str, text: str) -> Any:
    """Parse a command-line ``k=v`` parameter into the type of the Config field."""
    import tomllib

    fields = {f.name: f for f in dataclasses.fields(cls.Config)}
    if key not in fields:
        raise EstimatorError(f"{cls.name}: unknown parameter {key!r}; known: {sorted(fields)}")
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


__all__ = [
    "REGISTRY", "Estimator", "EstimatorError", "RecordingError", "TRACK_COLUMNS", "check_tracks", "coerce_param", "register",
]
