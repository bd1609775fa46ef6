"""HOTA on hand-computed cases (metrics/hota.py); equality with TrackEval is in test_hota_trackeval.py."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trackroom.metrics.hota import ALPHAS, hota, similarity
from trackroom.metrics.mot import EvalFrames


def frames(truth, tracks, n=4):
    return EvalFrames(np.arange(n) * 0.1, pd.DataFrame(truth, columns=["frame", "person_id", "x", "y"]),
                      pd.DataFrame(tracks, columns=["frame", "track_id", "x", "y"]))


def test_alphas_and_similarity():
    assert len(ALPHAS) == 19 and ALPHAS[0] == pytest.approx(0.05) and ALPHAS[-1] == pytest.approx(0.95)
    assert similarity(np.array([0.0, 0.25, 1.0, 3.0]), gate=1.0).tolist() == [1.0, 0.75, 0.0, 0.0]
    assert similarity(np.array([1.0]), gate=2.0).tolist() == [0.5]


def test_one_person_with_a_loose_frame_and_a_miss():
    # track 1 exact in frames 0 and 1, 0.5 m off in frame 2 (S = 0.5), absent in frame 3: G = 4, H = 3.
    # alphas 0.05..0.50 (10): TP 3, DetA = 3 / (4 + 3 - 3) = 3/4, AssA = 3 (3/4) / 3 = 3/4, LocA = 2.5 / 3
    # alphas 0.55..0.95 (9):  TP 2, DetA = 2 / 5, AssA = 2 (2/5) / 2 = 2/5, LocA = 1
    f = frames([(k, "a", 0.0, 0.0) for k in range(4)], [(0, 1, 0.0, 0.0), (1, 1, 0.0, 0.0), (2, 1, 0.5, 0.0)])
    h = hota(f, gate=1.0)
    assert h.tp.tolist() == [3] * 10 + [2] * 9
    assert h.hota == pytest.approx((10 * 0.75 + 9 * 0.4) / 19)
    assert h.deta == pytest.approx((10 * 0.75 + 9 * 0.4) / 19)
    assert h.assa == pytest.approx((10 * 0.75 + 9 * 0.4) / 19)
    assert h.loca == pytest.approx((10 * 2.5 / 3 + 9) / 19)
    m = h.metrics()
    assert m["detre"] == pytest.approx((10 * 3 + 9 * 2) / 4 / 19) and m["detpr"] == pytest.approx((10 + 9 * 2 / 3) / 19)


def test_one_person_two_tracks_halves_association_only():
    # tracks 1 and 2 each follow person a exactly for two of four frames: DetA = 1,
    # AssA = (2 * 2/(4 + 2 - 2) + 2 * 2/4) / 4 = 1/2, AssRe = (2 * 2/4) * 2 / 4 = 1/2, AssPr = (2 * 2/2) * 2 / 4 = 1
    f = frames([(k, "a", 1.0, 2.0) for k in range(4)], [(k, 1 if k < 2 else 2, 1.0, 2.0) for k in range(4)])
    m = hota(f).metrics()
    assert (m["deta"], m["assa"], m["assre"], m["asspr"], m["loca"]) == (1.0, 0.5, 0.5, 1.0, 1.0)
    assert m["hota"] == pytest.approx(np.sqrt(0.5))


def test_matching_prefers_the_consistent_track():
    # a and b are tracked by 1 and 2 in frames 0-2; in frame 3 both tracks sit between them. The
    # track closer to a is 2, but a's alignment with 1 makes 1-a, 2-b the better pair (by score).
    truth = [(k, "a", 0.0, 0.0) for k in range(4)] + [(k, "b", 0.0, 1.0) for k in range(4)]
    tracks = [(k, 1, 0.0, 0.0) for k in range(3)] + [(k, 2, 0.0, 1.0) for k in range(3)]
    tracks += [(3, 1, 0.0, 0.45), (3, 2, 0.0, 0.40)]
    f = frames(truth, tracks)
    h = hota(f, gate=1.0)
    # every alpha up to S = 0.55 (1 - 0.45) and 0.4 counts both frame-3 pairs for the consistent ids
    assert h.assa_alpha[0] == pytest.approx(1.0) and h.deta_alpha[0] == 1.0


def test_gate_must_be_positive():
    with pytest.raises(ValueError, match="gate"):
        hota(frames([], []), gate=0.0)
