"""Score a tracks table against a recording's truth: one tidy row per (recording, estimator).

Evaluation frames. Truth ``people`` comes at the simulation rate (100 Hz); tracks come at times
an estimator chooses (usually camera frame times). Everything is compared on one grid:

- **Frames**: the union of every calibrated camera's frame times in [0, duration)
  (``Camera.frame_times``), rounded to the microsecond. A frame where no track reports is all
  misses; a frame where nobody is present is all false positives.
- **Truth at a frame**: each person's x, y linearly interpolated in time from the ``people``
  table (exact on the grid, since camera rates divide the simulation rate); the phone carried is
  taken from the nearest row. A person counts at frames within their first and last truth row.
- **Tracks at a frame**: a track row within ``tol`` (1 ms) of the frame gives the track's
  position there; otherwise, when the frame lies between two rows of that track at most
  ``max_gap`` seconds apart (default 1.5 frame periods of the slowest camera), x, y are
  linearly interpolated and the claimed ``phone_id`` is the earlier row's. So an estimator that
  reports on the camera grid is taken as is (a missing row stays missing) and one that reports
  at a finer or shifted grid is resampled; one reporting more sparsely than the cameras loses
  the frames in between (they count as misses).
- **Cameras that saw a person** (for the position-error split): from truth ``visibility``,
  the number of cameras with ``visible == True`` at their frame nearest the evaluation frame.

Then CLEAR MOT (``mot.py``), HOTA (``hota.py``: similarity max(0, 1 - d / gate)), IDF1 and
identification accuracy (``identity.py``) and position error (``position.py``) are computed on
those frames with the same gate (default 1 m).

**One person** (``person=ID``): the truth is that person's alone, so a single-target tracker is
scored against the person it follows: every track row is matched to that person or counts as
a false positive, and the frames where the person is absent count nothing for the truth.

Tracks are validated first (``estimators.base.check_tracks``): a missing column, a ``t, x, y``
that is not a finite number, an empty ``track_id``, or one track at one time twice ends in one
``EstimatorError`` naming the column and row; a person id the truth lacks ends in a
``RecordingError`` listing the ids it holds.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from trackroom.estimators.base import check_tracks
from trackroom.recording import Recording, RecordingError

from .hota import HotaResult, hota
from .identity import IdentificationResult, IdResult, claims_phones, idf1, identification_accuracy
from .mot import DEFAULT_GATE, EvalFrames, MotResult, clear_mot
from .position import position_errors

TIME_TOL = 1e-3  # s: a track row this close to a frame is taken as that frame's
# Bump when ``evaluate`` gains or changes a metric: a comparison's stored runs scored by another
# revision are run again (``trackroom.compare.run_key``). 2: HOTA and its parts (issue 15).
SCORE_REVISION = 2


def evaluation_frames(recording: Recording) -> np.ndarray:
    """Frame times (s): the union of all cameras' frame times over [0, duration)."""
    cams = recording.calibration.cameras
    if not cams:
        raise ValueError("cannot choose evaluation frames: the recording has no cameras")
    times = np.concatenate([c.frame_times(recording.duration) for c in cams.values()])
    return np.unique(np.round(times, 6))


def default_max_gap(recording: Recording) -> float:
    """1.5 frame periods of the slowest camera (s)."""
    return 1.5 / min(c.fps for c in recording.calibration.cameras.values())


def person_ids(recording: Recording) -> list:
    """The person ids of the recording's truth, sorted."""
    return sorted(pd.unique(recording.truth.people["person_id"]), key=str)


def find_person(recording: Recording, person) -> Any:
    """The truth's id equal to ``person`` (compared as text, so "3" finds 3), else RecordingError."""
    ids = person_ids(recording)
    for pid in ids:
        if str(pid) == str(person):
            return pid
    raise RecordingError(f"no person {str(person)!r} in the recording's truth; person ids: {', '.join(map(str, ids)) or 'none'}")


def truth_at(recording: Recording, times: np.ndarray, person=None) -> pd.DataFrame:
    """Truth on the frame grid: ``frame, person_id, x, y, phone_id`` (+ ``cameras``); only
    ``person``'s rows when given (an id of the truth)."""
    people = recording.truth.people
    if person is not None:
        people = people[people["person_id"] == person]
    parts = []
    for pid, g in people.groupby("person_id", sort=True):
        g = g.sort_values("t", kind="stable")
        t = g["t"].to_numpy(float)
        k = np.flatnonzero((times >= t[0] - 1e-9) & (times <= t[-1] + 1e-9))
        if not len(k):
            continue
        near = np.clip(np.searchsorted(t, times[k]), 0, len(t) - 1)
        phone = g["phone_id"].to_numpy(object)[near] if "phone_id" in g.columns else np.full(len(k), "", object)
        parts.append(pd.DataFrame({
            "frame": k,
            "person_id": pid,
            "x": np.interp(times[k], t, g["x"].to_numpy(float)),
            "y": np.interp(times[k], t, g["y"].to_numpy(float)),
            "phone_id": pd.Series(phone, dtype=object).fillna(""),
        }))
    cols = ["frame", "person_id", "x", "y", "phone_id"]
    df = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)
    seen = cameras_seeing(recording, times)
    if seen is not None and len(df):
        # joined on the ids as text: a recording from elsewhere may write 3 in one table, "3" in another
        seen = seen.assign(key=seen["person_id"].astype(str)).drop(columns="person_id")
        df = df.assign(key=df["person_id"].astype(str)).merge(seen, on=["frame", "key"], how="left").drop(columns="key")
        df["cameras"] = df["cameras"].fillna(0).astype(int)
    return df


def cameras_seeing(recording: Recording, times: np.ndarray) -> pd.DataFrame | None:
    """``frame, person_id, cameras``: cameras with the person visible at their nearest frame.

    None when the recording has no visibility table.
    """
    vis = recording.truth.visibility
    if not len(vis):
        return None
    total = None
    for _, g in vis.groupby("camera", sort=True):
        table = g.pivot_table(index="t", columns="person_id", values="visible", aggfunc="max").fillna(False)
        ct = table.index.to_numpy(float)
        j = np.clip(np.searchsorted(ct, times), 1, len(ct) - 1) if len(ct) > 1 else np.zeros(len(times), int)
        if len(ct) > 1:
            j = np.where(np.abs(ct[j - 1] - times) <= np.abs(ct[j] - times), j - 1, j)
        counts = pd.DataFrame(table.to_numpy(bool)[j].astype(int), columns=table.columns)
        total = counts if total is None else total.add(counts, fill_value=0)
    long = total.stack().rename("cameras").reset_index()
    long.columns = ["frame", "person_id", "cameras"]
    long["cameras"] = long["cameras"].astype(int)
    return long


def tracks_at(tracks: pd.DataFrame, times: np.ndarray, max_gap: float, tol: float = TIME_TOL) -> pd.DataFrame:
    """Tracks on the frame grid: ``frame, track_id, x, y`` (+ ``phone_id``); see module docstring."""
    has_phone = "phone_id" in tracks.columns
    parts = []
    for tid, g in tracks.groupby("track_id", sort=True):
        g = g.sort_values("t", kind="stable")
        t = g["t"].to_numpy(float)
        if (np.diff(t) <= 0).any():
            raise ValueError(f"track {tid!r} has two rows at the same time t")
        k = np.flatnonzero((times >= t[0] - tol) & (times <= t[-1] + tol))
        if not len(k):
            continue
        tk = times[k]
        j = np.clip(np.searchsorted(t, tk), 1, max(len(t) - 1, 1))  # t[j-1] < tk <= t[j] inside
        if len(t) == 1:
            lo = hi = np.zeros(len(k), int)
        else:
            lo, hi = j - 1, j
        near = np.where(np.abs(t[lo] - tk) <= np.abs(t[hi] - tk), lo, hi)
        snap = np.abs(t[near] - tk) <= tol
        bridge = ~snap & (t[lo] <= tk) & (tk <= t[hi]) & (t[hi] - t[lo] <= max_gap)
        ok = snap | bridge
        x, y = g["x"].to_numpy(float), g["y"].to_numpy(float)
        part = pd.DataFrame({
            "frame": k[ok],
            "track_id": tid,
            "x": np.where(snap, x[near], np.interp(tk, t, x))[ok],
            "y": np.where(snap, y[near], np.interp(tk, t, y))[ok],
        })
        if has_phone:
            phone = g["phone_id"].fillna("").astype(str).to_numpy(object)
            part["phone_id"] = np.where(snap, phone[near], phone[lo])[ok]
        parts.append(part)
    cols = ["frame", "track_id", "x", "y"] + (["phone_id"] if has_phone else [])
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=cols)


def build_frames(recording: Recording, tracks: pd.DataFrame, max_gap: float | None = None, person=None) -> EvalFrames:
    """Truth (``person``'s only, when given) and tracks on the evaluation grid (module docstring)."""
    times = evaluation_frames(recording)
    gap = default_max_gap(recording) if max_gap is None else max_gap
    return EvalFrames(times, truth_at(recording, times, person), tracks_at(tracks, times, gap))


@dataclass
class Evaluation:
    """Everything computed when scoring one tracks table on one recording."""

    frames: EvalFrames
    mot: MotResult
    ids: IdResult
    hota: HotaResult
    identification: IdentificationResult | None
    position: dict[str, float]

    def metrics(self) -> dict[str, Any]:
        """The flat dictionary of scores: CLEAR MOT, IDF1, HOTA, phone identification (when tracks claim
        phones) and position errors; ``docs/format.md`` describes each column of ``results.csv``."""
        m, i = self.mot, self.ids
        out: dict[str, Any] = {
            "gate": m.gate,
            "frames": m.num_frames,
            "objects": m.num_objects,
            "predictions": m.num_predictions,
            "mota": m.mota,
            "motp": m.motp,
            "id_switches": m.num_switches,
            "fp": m.fp,
            "fn": m.fn,
            "matches": m.num_detections,
            "recall": m.recall,
            "precision": m.precision,
            "idf1": i.idf1,
            "idp": i.idp,
            "idr": i.idr,
            **self.hota.metrics(),
            "tracks": int(self.frames.tracks["track_id"].nunique()),
            "people": int(self.frames.truth["person_id"].nunique()),
        }
        out.update(self.position)
        ident = self.identification
        out["id_accuracy"] = ident.id_accuracy if ident else float("nan")
        out["id_accuracy_all"] = ident.id_accuracy_all if ident else float("nan")
        return out

    def error_over_time(self) -> pd.DataFrame:
        """Per frame: ``t``, RMSE of the matched distances (NaN with no match), fn, fp, switches."""
        pf = self.mot.per_frame[["frame", "t", "fn", "fp", "switches"]].copy()
        sq = self.mot.matches.assign(d2=self.mot.matches["distance"] ** 2).groupby("frame")["d2"].mean()
        pf["rmse"] = np.sqrt(pf["frame"].map(sq).to_numpy(float))
        return pf


def evaluate(recording: Recording, tracks: pd.DataFrame, gate: float = DEFAULT_GATE,
             max_gap: float | None = None, person=None) -> Evaluation:
    """Score ``tracks`` (``t, track_id, x, y`` [+ ``phone_id``]) against ``recording``'s truth:
    every person's, or ``person``'s alone (an id of the truth, e.g. "p1"; module docstring)."""
    if not (isinstance(gate, (int, float)) and gate > 0 and np.isfinite(gate)):
        raise ValueError(f"gate must be a positive distance in metres, got {gate!r}")
    tracks = check_tracks(tracks)
    if "phone_id" in tracks.columns:
        tracks = tracks.assign(phone_id=tracks["phone_id"].fillna("").astype(str))
    if person is not None:
        person = find_person(recording, person)
    frames = build_frames(recording, tracks, max_gap, person)
    mot = clear_mot(frames, gate)
    ident = identification_accuracy(frames, mot) if claims_phones(tracks) else None
    return Evaluation(frames, mot, idf1(frames, gate), hota(frames, gate), ident, position_errors(frames, mot))


KEY_COLUMNS = ["scene", "seed", "sensing", "estimator"]


def score(recording: Recording, tracks: pd.DataFrame, estimator: str = "", gate: float = DEFAULT_GATE,
          person=None, **extra: Any) -> pd.DataFrame:
    """One tidy row: ``scene, seed, sensing, estimator`` + ``extra`` columns + the metrics
    (against ``person`` alone when given, with a ``person`` column)."""
    row = {"scene": recording.scene, "seed": recording.seed, "sensing": recording.sensing, "estimator": estimator}
    if person is not None:
        row["person"] = str(person)
    row.update(extra)
    row.update(evaluate(recording, tracks, gate, person=person).metrics())
    return pd.DataFrame([row])
