"""Our HOTA equals TrackEval's (``trackeval.metrics.HOTA``, PyPI trackeval 1.3) on the same inputs.

TrackEval is given, per frame, the truth and track ids present and max(0, 1 - d / gate) from the
same distances, and its per-alpha arrays are averaged over alpha as its summary does
(``scripts/record_hota_trackeval.py``, which also describes the 24 random scenarios: misses,
false tracks, fresh ids, swaps, empty and one-sided frames, crowding, lattice ties).

Two comparisons: with TrackEval live when it is installed (``pip install --no-deps
"trackeval>=1.3"``: its dependencies would add opencv-python beside opencv-python-headless), and
always with its figures recorded in ``tests/data/hota_trackeval.json`` by that script.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from scripts.record_hota_trackeval import FIELDS, FIXTURE, SEEDS, checksum, scenario, trackeval_hota
from trackroom.metrics.hota import hota
from trackroom.metrics.mot import EvalFrames, pairwise_distances

RECORDED = {r["seed"]: r for r in json.loads(FIXTURE.read_text())["scenarios"]}


@pytest.fixture(scope="module")
def live():
    pytest.importorskip("trackeval")
    return trackeval_hota


def assert_equal(ours: dict, ref: dict) -> None:
    for k in FIELDS:
        assert ours[k] == pytest.approx(ref[k], abs=1e-9), k


@pytest.mark.parametrize("seed", SEEDS)
def test_equal_to_recorded_trackeval(seed):
    frames, gate = scenario(seed)
    rec = RECORDED[seed]
    assert checksum(frames) == rec["checksum"], "the scenario generator changed: python -m scripts.record_hota_trackeval"
    assert gate == rec["gate"]
    assert_equal(hota(frames, gate).metrics(), rec["trackeval"])


@pytest.mark.parametrize("seed", SEEDS)
def test_equal_to_trackeval_live(seed, live):
    frames, gate = scenario(seed)
    assert_equal(hota(frames, gate).metrics(), live(frames, gate))


def _frames(truth, tracks, n=3):
    return EvalFrames(np.arange(n) * 0.1, pd.DataFrame(truth, columns=["frame", "person_id", "x", "y"]),
                      pd.DataFrame(tracks, columns=["frame", "track_id", "x", "y"]))


EMPTY_CASES = [
    ([], []),  # nothing at all
    ([(0, "a", 0.0, 0.0), (1, "a", 0.1, 0.0)], []),  # no tracks
    ([], [(0, 1, 0.0, 0.0), (2, 1, 0.0, 0.0)]),  # no truth
    ([(0, "a", 0.0, 0.0)], [(1, 1, 0.0, 0.0)]),  # never in the same frame
    ([(0, "a", 0.0, 0.0)], [(0, 1, 5.0, 0.0)]),  # together but beyond the gate
]


@pytest.mark.parametrize("truth,tracks", EMPTY_CASES)
def test_nothing_matched_scores_as_trackeval_defines(truth, tracks):
    # TrackEval: HOTA = DetA = AssA = 0 and LocA = 1 when nothing is matched (no tracks, no truth)
    m = hota(_frames(truth, tracks), 1.0).metrics()
    assert m["hota"] == m["deta"] == m["assa"] == 0.0 and m["loca"] == 1.0


@pytest.mark.parametrize("truth,tracks", EMPTY_CASES)
def test_nothing_matched_equal_to_trackeval_live(truth, tracks, live):
    f = _frames(truth, tracks)
    assert_equal(hota(f, 1.0).metrics(), live(f, 1.0))


def test_scenarios_exercise_what_the_test_claims():
    """The scenarios hold empty and one-sided frames, crowded frames (Hungarian) and similarities on an alpha."""
    empty = no_truth = no_tracks = crowded = on_alpha = 0
    for seed in SEEDS:
        frames, _ = scenario(seed)
        t_xy = frames.truth[["x", "y"]].to_numpy(float)
        h_xy = frames.tracks[["x", "y"]].to_numpy(float)
        for _, ti, hi in frames.by_frame():
            empty += not len(ti) and not len(hi)
            no_truth += not len(ti) and bool(len(hi))
            no_tracks += bool(len(ti)) and not len(hi)
            s = np.maximum(0.0, 1.0 - pairwise_distances(t_xy[ti], h_xy[hi]))
            crowded += bool(((s > 0).sum(axis=0) > 1).any() or ((s > 0).sum(axis=1) > 1).any())
            on_alpha += int(np.isin(np.round(s, 12), [0.25, 0.5, 0.75]).sum())
    assert min(empty, no_truth, no_tracks) > 20 and crowded > 100 and on_alpha > 50
