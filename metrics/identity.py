"""Identity metrics: IDF1 (Ristani et al. 2016) and Teixeira's identification accuracy (eq. 22).

IDF1. Count, for every truth id o and track id h, the frames in which both are present and
within the gate: n(o, h) (the identity true positives the pair would give). A global one-to-one
assignment of truth ids to track ids maximises IDTP = sum over assigned pairs of n(o, h)
(``linear_sum_assignment`` on -n). With G truth appearances and H track appearances,

    IDF1 = 2 IDTP / (G + H),   IDP = IDTP / H,   IDR = IDTP / G.

Identification accuracy (Teixeira, Jung & Savvides 2010, eq. 22, which the paper calls MOTA):

    accuracy = sum_k correct identifications in k / sum_k identifications in k

over evaluation frames k. An identification is a track row claiming a ``phone_id`` (non-empty);
it is correct when the CLEAR MOT matching of that frame (``metrics/mot.py``) paired the track
with a truth person who carries exactly that phone. Two ways of counting people nobody
identified, both reported:

- ``id_accuracy``: over the identifications made (the paper's ratio); a claim by a track matched
  to nobody, or to someone else, is wrong; people with no claiming track do not count.
- ``id_accuracy_all``: correct identifications over the truth appearances of people who carry a
  phone; a person with a phone who is undetected or whose track claims nothing (or the wrong
  phone) counts as a failure.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from .mot import DEFAULT_GATE, EvalFrames, MotResult, _ratio


@dataclass
class IdResult:
    idtp: int
    num_objects: int
    num_predictions: int

    @property
    def idfp(self) -> int:
        return self.num_predictions - self.idtp

    @property
    def idfn(self) -> int:
        return self.num_objects - self.idtp

    @property
    def idf1(self) -> float:
        return _ratio(2 * self.idtp, self.num_objects + self.num_predictions)

    @property
    def idp(self) -> float:
        return _ratio(self.idtp, self.num_predictions)

    @property
    def idr(self) -> float:
        return _ratio(self.idtp, self.num_objects)


def co_occurrence(frames: EvalFrames, gate: float = DEFAULT_GATE) -> pd.DataFrame:
    """n(o, h): frames in which truth o and track h are both present within ``gate`` metres.

    Returns a table (rows: person ids, columns: track ids), zeros where they never are.
    """
    pairs = frames.truth[["frame", "person_id", "x", "y"]].merge(
        frames.tracks[["frame", "track_id", "x", "y"]], on="frame", suffixes=("_o", "_h")
    )
    d = np.hypot(pairs["x_o"].to_numpy(float) - pairs["x_h"].to_numpy(float),
                 pairs["y_o"].to_numpy(float) - pairs["y_h"].to_numpy(float))
    near = pairs.loc[d <= gate, ["person_id", "track_id"]]
    counts = near.groupby(["person_id", "track_id"]).size()
    people = pd.unique(frames.truth["person_id"])
    tracks = pd.unique(frames.tracks["track_id"])
    table = counts.unstack(fill_value=0) if len(counts) else pd.DataFrame()
    return table.reindex(index=people, columns=tracks, fill_value=0).astype(int)


def idf1(frames: EvalFrames, gate: float = DEFAULT_GATE) -> IdResult:
    """IDF1 by the global maximum-overlap assignment of truth ids to track ids."""
    n = co_occurrence(frames, gate).to_numpy(float)
    idtp = 0
    if n.size:
        rows, cols = linear_sum_assignment(-n)
        idtp = int(n[rows, cols].sum())
    return IdResult(idtp=idtp, num_objects=len(frames.truth), num_predictions=len(frames.tracks))


@dataclass
class IdentificationResult:
    correct: int
    identifications: int  # track rows that claim a phone
    people_with_phone: int  # truth appearances of people who carry a phone

    @property
    def id_accuracy(self) -> float:
        return _ratio(self.correct, self.identifications)

    @property
    def id_accuracy_all(self) -> float:
        return _ratio(self.correct, self.people_with_phone)


def claims_phones(tracks: pd.DataFrame) -> bool:
    """True when a tracks table claims identities (a ``phone_id`` column with a non-empty value)."""
    return "phone_id" in tracks.columns and bool(_claimed(tracks["phone_id"]).any())


def _claimed(s: pd.Series) -> np.ndarray:
    return (s.notna() & (s.astype(str) != "")).to_numpy(bool)


def identification_accuracy(frames: EvalFrames, mot: MotResult) -> IdentificationResult:
    """Teixeira's eq. 22 from the per-frame CLEAR MOT matches (module docstring: both variants).

    Needs ``phone_id`` in both ``frames.truth`` (the phone each person carries) and
    ``frames.tracks`` (the phone each track claims).
    """
    for name, df in (("truth", frames.truth), ("tracks", frames.tracks)):
        if "phone_id" not in df.columns:
            raise ValueError(f"identification accuracy needs a phone_id column in the {name}")
    claims = frames.tracks.loc[_claimed(frames.tracks["phone_id"]), ["frame", "track_id", "phone_id"]]
    carried = frames.truth.loc[_claimed(frames.truth["phone_id"]), ["frame", "person_id", "phone_id"]]
    # Which person each claiming track was matched to in that frame, and that person's phone.
    m = mot.matches[["frame", "person_id", "track_id"]]
    judged = claims.merge(m, on=["frame", "track_id"], how="left").merge(
        frames.truth[["frame", "person_id", "phone_id"]].rename(columns={"phone_id": "true_phone"}),
        on=["frame", "person_id"], how="left",
    )
    correct = int((judged["phone_id"].astype(str) == judged["true_phone"].astype(str)).where(
        judged["true_phone"].notna(), False).sum())
    return IdentificationResult(correct=correct, identifications=len(claims), people_with_phone=len(carried))
