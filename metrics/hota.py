"""HOTA on floor positions (Luiten et al. 2020, IJCV), as TrackEval's ``metrics/hota.py`` computes it.

Input is the ``EvalFrames`` CLEAR MOT uses (``metrics/mot.py``): per evaluation frame k the truth
people present and the tracks reported, each with a floor position. The similarity of truth o and
track h in frame k is

    S(o, h) = max(0, 1 - d / gate),   d = |p_o - p_h| in metres, gate 1 m by default,

so S is 1 at the same spot and 0 from ``gate`` metres on (the same gate as CLEAR MOT and IDF1).

1. **Association potential.** Over all frames, for every truth id o and track id h,

       P(o, h) = sum_k S_k(o, h) / (sum_h' S_k(o, h') + sum_o' S_k(o', h) - S_k(o, h))

   (each frame's similarities normalised like a soft Jaccard index; a zero denominator gives 0),
   and the global alignment A(o, h) = P / (n_o + n_h - P), n_o and n_h the frames in which o and h
   are present.
2. **Matching.** Per frame, ``linear_sum_assignment`` maximises sum A(o, h) S(o, h) over one-to-one
   pairs. This is TrackEval's score, not the paper's (which ranks pairs first by S >= alpha, then
   by A, then by S, and matches once per alpha): TrackEval matches once for every alpha, and the
   figures here equal TrackEval's (``tests/test_hota_trackeval.py``). A frame whose positive scores
   already form a one-to-one matching needs no Hungarian step: every optimal assignment holds all
   of them, and zero-score pairs never count below.
3. **Per alpha** in 0.05, 0.10, ..., 0.95 (19 values; TrackEval's ``np.arange(0.05, 0.99, 0.05)``),
   a matched pair with S >= alpha (less machine epsilon) is a true positive. With TP_a of them, G
   truth and H track appearances, and c_a(o, h) the frames in which o and h form such a pair:

       DetRe = TP / G,  DetPr = TP / H,  DetA = TP / (G + H - TP)
       AssA  = (1 / TP) sum_(o,h) c (c / (n_o + n_h - c))       (sum over the TP pairs of their
       AssRe = (1 / TP) sum_(o,h) c (c / n_o),  AssPr = (1 / TP) sum c (c / n_h)   id's alignment)
       LocA  = mean S over the TP pairs,   HOTA_a = sqrt(DetA_a AssA_a)

   with every denominator floored at 1 (LocA: both sides at 1e-10), as TrackEval does.

The reported ``hota``, ``deta``, ``assa``, ``loca`` (and ``detre``, ``detpr``, ``assre``,
``asspr``) are the means over the 19 alphas (so ``hota`` is not sqrt(deta * assa) in general).
Empty inputs score as in TrackEval: no tracks or no truth give HOTA = DetA = AssA = 0 and LocA = 1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from .mot import DEFAULT_GATE, EvalFrames

# The alpha thresholds built exactly as TrackEval builds them (0.15 is 0.15000000000000002 there too).
ALPHAS = np.arange(0.05, 0.99, 0.05)
_EPS = np.finfo(float).eps
HOTA_COLUMNS = ["hota", "deta", "assa", "loca", "detre", "detpr", "assre", "asspr"]


@dataclass
class HotaResult:
    """HOTA counts and scores per alpha (arrays over ``alphas``); the properties are their means."""

    gate: float
    alphas: np.ndarray
    tp: np.ndarray  # true positives per alpha
    num_objects: int  # truth appearances G
    num_predictions: int  # track appearances H
    assa_alpha: np.ndarray
    assre_alpha: np.ndarray
    asspr_alpha: np.ndarray
    loca_alpha: np.ndarray

    @property
    def fn(self) -> np.ndarray:
        return self.num_objects - self.tp

    @property
    def fp(self) -> np.ndarray:
        return self.num_predictions - self.tp

    @property
    def deta_alpha(self) -> np.ndarray:
        return self.tp / np.maximum(1, self.num_objects + self.num_predictions - self.tp)

    @property
    def detre_alpha(self) -> np.ndarray:
        return self.tp / max(1, self.num_objects)

    @property
    def detpr_alpha(self) -> np.ndarray:
        return self.tp / max(1, self.num_predictions)

    @property
    def hota_alpha(self) -> np.ndarray:
        return np.sqrt(self.deta_alpha * self.assa_alpha)

    @property
    def hota(self) -> float:
        return float(self.hota_alpha.mean())

    @property
    def deta(self) -> float:
        return float(self.deta_alpha.mean())

    @property
    def assa(self) -> float:
        return float(self.assa_alpha.mean())

    @property
    def loca(self) -> float:
        return float(self.loca_alpha.mean())

    def metrics(self) -> dict[str, float]:
        """The means over alpha, keyed by ``HOTA_COLUMNS``."""
        return {name: float(getattr(self, f"{name}_alpha").mean()) for name in HOTA_COLUMNS}


def similarity(d: np.ndarray, gate: float = DEFAULT_GATE) -> np.ndarray:
    """S = max(0, 1 - d / gate) for distances ``d`` in metres."""
    return np.maximum(0.0, 1.0 - np.asarray(d, float) / gate)


def _frame_pairs(f_truth: np.ndarray, f_track: np.ndarray, n_frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every (truth row, track row) in the same frame, frame by frame, each frame's pairs in
    row-major order (truth row, then track row): row indices ``pi``, ``pj`` and the first pair
    of each frame (``start``, length n_frames + 1)."""
    tb = np.searchsorted(f_truth, np.arange(n_frames + 1))
    hb = np.searchsorted(f_track, np.arange(n_frames + 1))
    nh = np.diff(hb)
    per_row = nh[f_truth]  # pairs each truth row takes part in
    pi = np.repeat(np.arange(len(f_truth)), per_row)
    first = np.cumsum(per_row) - per_row  # index of each truth row's first pair
    pj = hb[f_truth][pi] + np.arange(len(pi)) - first[pi]
    start = np.concatenate([[0], np.cumsum(np.diff(tb) * nh)])
    return pi, pj, start


def hota(frames: EvalFrames, gate: float = DEFAULT_GATE) -> HotaResult:
    """HOTA and its parts over all frames (see the module docstring for the procedure)."""
    if not gate > 0:
        raise ValueError(f"gate must be a positive distance in metres, got {gate}")
    truth, tracks = frames.truth, frames.tracks  # sorted by frame, then id (EvalFrames)
    f_truth = truth["frame"].to_numpy(int)
    f_track = tracks["frame"].to_numpy(int)
    o_idx, o_ids = pd.factorize(truth["person_id"])
    h_idx, h_ids = pd.factorize(tracks["track_id"])
    n_o = np.bincount(o_idx, minlength=len(o_ids)).astype(float)  # frames per truth id
    n_h = np.bincount(h_idx, minlength=len(h_ids)).astype(float)  # frames per track id
    n_frames = len(frames.times)

    pi, pj, start = _frame_pairs(f_truth, f_track, n_frames)
    t_xy = truth[["x", "y"]].to_numpy(float)
    h_xy = tracks[["x", "y"]].to_numpy(float)
    s = similarity(np.sqrt(((t_xy[pi] - h_xy[pj]) ** 2).sum(axis=-1)), gate)

    # 1. association potential: each frame's similarities normalised as a soft Jaccard index
    row_sum = np.bincount(pi, weights=s, minlength=len(truth))
    col_sum = np.bincount(pj, weights=s, minlength=len(tracks))
    denom = row_sum[pi] + col_sum[pj] - s
    ok = denom > _EPS
    s_iou = np.zeros_like(s)
    s_iou[ok] = s[ok] / denom[ok]
    # one entry per (truth id, track id) pair that ever shares a frame
    width = max(len(h_ids), 1)
    keys, key_of_pair = np.unique(o_idx[pi].astype(np.int64) * width + h_idx[pj], return_inverse=True)
    key_o, key_h = keys // width, keys % width
    potential = np.bincount(key_of_pair, weights=s_iou, minlength=len(keys))
    alignment = potential / (n_o[key_o] + n_h[key_h] - potential)
    score = alignment[key_of_pair] * s

    # 2. matching per frame; frames whose positive scores are already one-to-one need no Hungarian
    positive = score > 0
    busy_rows = np.bincount(pi[positive], minlength=len(truth)) > 1
    busy_cols = np.bincount(pj[positive], minlength=len(tracks)) > 1
    ambiguous = np.zeros(n_frames, bool)
    ambiguous[f_truth[busy_rows]] = True
    ambiguous[f_track[busy_cols]] = True
    pair_frame = f_truth[pi]
    matched = [np.flatnonzero(positive & ~ambiguous[pair_frame])]
    nh = np.bincount(f_track, minlength=n_frames)
    for k in np.flatnonzero(ambiguous):
        block = score[start[k]:start[k + 1]].reshape(-1, nh[k])
        rows, cols = linear_sum_assignment(-block)
        matched.append(start[k] + rows * nh[k] + cols)
    m = np.concatenate(matched)
    m = m[s[m] > 0]  # zero-similarity pairs never reach an alpha

    # 3. true positives per alpha, and the id pairs they form
    tp_mask = s[m][None, :] >= ALPHAS[:, None] - _EPS  # (alphas, matches)
    tp = tp_mask.sum(axis=1)
    loc_sum = (tp_mask * s[m][None, :]).sum(axis=1)
    a_idx, j = np.nonzero(tp_mask)
    c = np.bincount(a_idx * len(keys) + key_of_pair[m][j], minlength=len(ALPHAS) * len(keys))
    c = c.reshape(len(ALPHAS), len(keys)).astype(float)
    per_tp = np.maximum(1, tp)
    no, nh_ = n_o[key_o][None, :], n_h[key_h][None, :]
    return HotaResult(
        gate=float(gate),
        alphas=ALPHAS.copy(),
        tp=tp,
        num_objects=len(truth),
        num_predictions=len(tracks),
        assa_alpha=(c * c / np.maximum(1, no + nh_ - c)).sum(axis=1) / per_tp,
        assre_alpha=(c * c / np.maximum(1, no)).sum(axis=1) / per_tp,
        asspr_alpha=(c * c / np.maximum(1, nh_)).sum(axis=1) / per_tp,
        loca_alpha=np.maximum(1e-10, loc_sum) / np.maximum(1e-10, tp),
    )
