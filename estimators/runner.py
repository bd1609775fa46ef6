"""Run one estimator on one recording: applicability check (with the reason), timing, validation.

    result = run_estimator(recording, "ekf", {"smooth": True})
    result.status   # "ok", "skipped" (does not apply: ``reason`` says why) or "error"
    result.tracks   # the validated tracks table (``check_tracks``), None unless ok
    result.seconds  # wall-clock time of ``estimate`` alone, s
    result.camera_status  # the estimator's per-camera status table where it keeps one, else None

Estimators get ``recording.observations`` and ``recording.calibration`` only, never the truth. The
observations are checked first (``check_observations``: documented columns, finite numbers, times
inside the recording, calibrated cameras; rows sorted by time), so a bad table ends in one
``RecordingError`` naming the table, column and row, whichever estimator runs.
An ``EstimatorError`` raised while estimating becomes status "error" with its message when
``errors="record"`` (the comparison engine keeps going); with ``errors="raise"`` it propagates.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import pandas as pd

from trackroom.recording import Recording

from . import get
from .base import Estimator, EstimatorError, check_observations, check_tracks, coerce_param, coerce_value


@dataclass
class RunResult:
    estimator: str
    status: str  # "ok", "skipped", "error"
    reason: str = ""
    seconds: float = float("nan")
    tracks: pd.DataFrame | None = None
    camera_status: pd.DataFrame | None = None  # ``Estimator.estimate_with_status``


def parse_params(cls: type[Estimator], items: list[str] | dict[str, Any] | None) -> dict[str, Any]:
    """``["k=v", ...]`` (command line) or a dict, parsed strictly by the types of the estimator's
    Config fields (``coerce_param`` / ``coerce_value``); unknown names fail with the known ones."""
    if not items:
        return {}
    if isinstance(items, dict):
        pairs = [(k, coerce_value(cls, k, v)) for k, v in items.items()]
    else:
        pairs = []
        for item in items:
            if "=" not in item:
                raise EstimatorError(f"{cls.name}: parameter {item!r} is not of the form key=value")
            k, v = item.split("=", 1)
            pairs.append((k.strip(), coerce_param(cls, k.strip(), v.strip())))
    params = dict(pairs)
    cls(**params)  # unknown names fail here, with the list of known ones
    return params


def run_estimator(recording: Recording, name: str, params: dict[str, Any] | list[str] | None = None,
                  errors: str = "raise") -> RunResult:
    """Check that ``name`` applies to the recording, run it, time it and validate its tracks."""
    cls = get(name)
    est = cls(**parse_params(cls, params))
    cal = recording.calibration
    obs = check_observations(recording.observations, cal)
    reason = cls.applies_to(obs, cal)
    if reason:
        return RunResult(name, "skipped", reason)
    t0 = time.perf_counter()
    try:
        tracks, camera_status = est.estimate_with_status(obs, cal)
        seconds = time.perf_counter() - t0
        tracks = check_tracks(tracks, f"{name} tracks")
    except EstimatorError as e:
        if errors == "raise":
            raise
        return RunResult(name, "error", str(e), time.perf_counter() - t0)
    return RunResult(name, "ok", "", seconds, tracks, camera_status)
