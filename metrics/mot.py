"""CLEAR MOT on ground-plane positions (Bernardin & Stiefelhagen 2008), as py-motmetrics computes it.

Input is an ``EvalFrames``: for every evaluation frame k (time t_k) the truth people present
(id, floor position) and the tracks reported (id, floor position); ``metrics/score.py`` builds it
from a recording and a tracks table. Distances are Euclidean on the floor, d = |p_truth - p_track|
in metres; a pair may match only when d <= gate (default 1 m).

Per frame k, in this order (the procedure of py-motmetrics 1.4, ``MOTAccumulator.update``):

1. Keep correspondences: for each truth o (in id order) whose last match was track h, if h is
   reported in frame k, not yet taken, and d(o, h) <= gate, match them again. As in py-motmetrics
   and TrackEval this holds across frames in which o was missed (Bernardin keeps only the previous
   frame's pairs; the two differ only after a gap).
2. Hungarian on the rest: minimise the summed distance over the remaining pairs within the gate
   (``scipy.optimize.linear_sum_assignment``). Out-of-gate pairs get the cost l = 2 r c + 1
   (r = min(rows, cols), c = 1 + the largest in-gate cost), so a solution never trades a gated
   match for a lower total; they are then dropped. This is motmetrics' own construction, so ties
   break the same way.
   A match (o, h) where o's last match was a different track is an ID switch ("counted against a
   truth's last match across gaps").
3. Truth left unmatched are misses (FN); tracks left unmatched are false positives (FP).

Totals over all frames, with G = sum_k g_k truth appearances:

    MOTA = 1 - (FN + FP + IDSW) / G
    MOTP = sum of matched distances / number of matches      (metres; matches include switches)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

DEFAULT_GATE = 1.0  # metres


@dataclass
class EvalFrames:
    """Truth and tracks on a common grid of evaluation frames.

    times: (F,) frame times, s, increasing.
    truth: rows ``frame, person_id, x, y`` (+ optional ``phone_id``, ``cameras``: how many cameras
        saw the person then); frame indexes ``times``.
    tracks: rows ``frame, track_id, x, y`` (+ optional ``phone_id``: the identity claimed, "" none).
    """

    times: np.ndarray
    truth: pd.DataFrame
    tracks: pd.DataFrame

    def __post_init__(self) -> None:
        self.times = np.asarray(self.times, float)
        for name, df, idcol in (("truth", self.truth, "person_id"), ("tracks", self.tracks, "track_id")):
            missing = [c for c in ("frame", idcol, "x", "y") if c not in df.columns]
            if missing:
                raise ValueError(f"EvalFrames.{name}: missing columns {missing}")
            if len(df) and df.duplicated(["frame", idcol]).any():
                raise ValueError(f"EvalFrames.{name}: an id appears twice in one frame")
            if len(df) and ((df["frame"] < 0) | (df["frame"] >= len(self.times))).any():
                raise ValueError(f"EvalFrames.{name}: frame index outside the {len(self.times)} frames")
        self.truth = self.truth.sort_values(["frame", "person_id"], kind="stable").reset_index(drop=True)
        self.tracks = self.tracks.sort_values(["frame", "track_id"], kind="stable").reset_index(drop=True)

    def by_frame(self):
        """Yield ``(k, truth_rows, track_rows)`` for every frame (row index arrays into the tables)."""
        f_truth = self.truth["frame"].to_numpy(int)
        f_track = self.tracks["frame"].to_numpy(int)
        n = len(self.times)
        # Row ranges per frame (tables are sorted by frame).
        tb = np.searchsorted(f_truth, np.arange(n + 1))
        hb = np.searchsorted(f_track, np.arange(n + 1))
        for k in range(n):
            yield k, np.arange(tb[k], tb[k + 1]), np.arange(hb[k], hb[k + 1])


@dataclass
class MotResult:
    """CLEAR MOT totals and the per-frame correspondences they were computed from.

    matches: one row per matched pair: ``frame, t, person_id, track_id, distance, switch``.
    per_frame: one row per frame: ``frame, t, truth, tracks, matches, fn, fp, switches``.
    """

    gate: float
    num_frames: int
    num_objects: int  # truth appearances G
    num_predictions: int  # track appearances
    num_matches: int  # matches that are not switches
    num_switches: int
    fn: int
    fp: int
    matches: pd.DataFrame = field(repr=False)
    per_frame: pd.DataFrame = field(repr=False)

    @property
    def num_detections(self) -> int:
        return self.num_matches + self.num_switches

    @property
    def mota(self) -> float:
        return 1.0 - _ratio(self.fn + self.fp + self.num_switches, self.num_objects)

    @property
    def motp(self) -> float:
        return _ratio(float(self.matches["distance"].sum()), self.num_detections)

    @property
    def recall(self) -> float:
        return _ratio(self.num_detections, self.num_objects)

    @property
    def precision(self) -> float:
        return _ratio(self.num_detections, self.num_detections + self.fp)


def _ratio(a: float, b: float) -> float:
    return float(a) / b if b else float("nan")


def gated_assignment(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-cost assignment over the finite entries of ``cost`` (NaN/inf: may not pair).

    Non-edges get the cost l = 2 r c + 1 (r = min(cost.shape), c = 1 + max |finite cost|): using
    one costs more than any r real edges, so the most pairs are matched first, then the cheapest.
    Returns row and column indices of the finite pairs chosen.
    """
    cost = np.asarray(cost, float)
    if cost.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    valid = np.isfinite(cost)
    if not valid.any():
        return np.zeros(0, int), np.zeros(0, int)
    if valid.all():
        filled = cost
    else:
        c = np.abs(cost[valid]).max() + 1.0
        filled = np.where(valid, cost, 2 * min(cost.shape) * c + 1.0)
    rows, cols = linear_sum_assignment(filled)
    keep = valid[rows, cols]
    return rows[keep], cols[keep]


def pairwise_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distances (len(a), len(b)) between floor points a (n, 2) and b (m, 2), metres."""
    return np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=-1))


def clear_mot(frames: EvalFrames, gate: float = DEFAULT_GATE) -> MotResult:
    """CLEAR MOT counts over all frames (see the module docstring for the procedure)."""
    if not gate > 0:
        raise ValueError(f"gate must be a positive distance in metres, got {gate}")
    t_ids = frames.truth["person_id"].to_numpy(object)
    t_xy = frames.truth[["x", "y"]].to_numpy(float)
    h_ids = frames.tracks["track_id"].to_numpy(object)
    h_xy = frames.tracks[["x", "y"]].to_numpy(float)

    last_match: dict = {}  # truth id -> track id of its most recent match
    m_frame, m_o, m_h, m_d, m_sw = [], [], [], [], []
    pf = np.zeros((len(frames.times), 6), int)  # truth, tracks, matches, fn, fp, switches
    for k, ti, hi in frames.by_frame():
        oids, hids = t_ids[ti], h_ids[hi]
        d = pairwise_distances(t_xy[ti], h_xy[hi])
        d[d > gate] = np.nan
        o_done = np.zeros(len(ti), bool)
        h_done = np.zeros(len(hi), bool)
        n_match = n_sw = 0
        if len(ti) and len(hi):
            h_index = {h: j for j, h in enumerate(hids)}
            # 1. keep each truth's last correspondence while it stays within the gate
            for i, o in enumerate(oids):
                j = h_index.get(last_match.get(o, _NONE))
                if j is not None and not h_done[j] and np.isfinite(d[i, j]):
                    o_done[i] = h_done[j] = True
                    m_frame.append(k), m_o.append(o), m_h.append(hids[j]), m_d.append(d[i, j]), m_sw.append(False)
                    n_match += 1
            # 2. Hungarian on the remaining pairs
            cost = d.copy()
            cost[o_done, :] = np.nan
            cost[:, h_done] = np.nan
            for i, j in zip(*gated_assignment(cost)):
                o, h = oids[i], hids[j]
                switch = o in last_match and last_match[o] != h
                last_match[o] = h
                o_done[i] = h_done[j] = True
                m_frame.append(k), m_o.append(o), m_h.append(h), m_d.append(d[i, j]), m_sw.append(switch)
                n_sw += int(switch)
                n_match += int(not switch)
        pf[k] = (len(ti), len(hi), n_match, int((~o_done).sum()), int((~h_done).sum()), n_sw)

    matches = pd.DataFrame({
        "frame": np.asarray(m_frame, int),
        "t": frames.times[np.asarray(m_frame, int)],
        "person_id": pd.Series(m_o, dtype=object),
        "track_id": pd.Series(m_h, dtype=object),
        "distance": np.asarray(m_d, float),
        "switch": np.asarray(m_sw, bool),
    })
    per_frame = pd.DataFrame(pf, columns=["truth", "tracks", "matches", "fn", "fp", "switches"])
    per_frame.insert(0, "t", frames.times)
    per_frame.insert(0, "frame", np.arange(len(frames.times)))
    tot = pf.sum(axis=0)
    return MotResult(
        gate=float(gate),
        num_frames=len(frames.times),
        num_objects=int(tot[0]),
        num_predictions=int(tot[1]),
        num_matches=int(tot[2]),
        num_switches=int(tot[5]),
        fn=int(tot[3]),
        fp=int(tot[4]),
        matches=matches,
        per_frame=per_frame,
    )


class _Missing:
    """A key no truth id equals (ids may be any hashable, including None)."""


_NONE = _Missing()
