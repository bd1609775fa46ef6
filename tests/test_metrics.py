"""Hand-computed cases for CLEAR MOT, IDF1, identification accuracy and position error."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trackroom.metrics.identity import co_occurrence, idf1, identification_accuracy
from trackroom.metrics.mot import EvalFrames, clear_mot, gated_assignment
from trackroom.metrics.position import error_stats, position_errors


def frames_from(truth_rows, track_rows, n_frames):
    truth = pd.DataFrame(truth_rows, columns=["frame", "person_id", "x", "y"][: len(truth_rows[0])] if truth_rows else
                         ["frame", "person_id", "x", "y"])
    tracks = pd.DataFrame(track_rows, columns=["frame", "track_id", "x", "y"])
    return EvalFrames(np.arange(n_frames, dtype=float), truth, tracks)


@pytest.fixture
def two_people():
    """A at (0, 0), B at (5, 0) for three frames.

    frame 0: track 1 near A (0.3 m), track 2 near B (0.4 m), track 9 between them (2.5 m: FP)
    frame 1: track 2 near A (0.2 m): switch for A (its last match was 1); B missed
    frame 2: track 2 on B (kept: B's last match), track 1 near A (0.1 m): switch back for A
    """
    truth = [(k, p, x, 0.0) for k in range(3) for p, x in (("A", 0.0), ("B", 5.0))]
    tracks = [
        (0, 1, 0.3, 0.0), (0, 2, 5.0, 0.4), (0, 9, 2.5, 0.0),
        (1, 2, 0.0, 0.2),
        (2, 1, 0.0, 0.1), (2, 2, 5.0, 0.0),
    ]
    return frames_from(truth, tracks, 3)


def test_clear_mot_by_hand(two_people):
    r = clear_mot(two_people, gate=1.0)
    assert (r.num_objects, r.num_predictions) == (6, 6)
    assert (r.fn, r.fp, r.num_switches, r.num_detections) == (1, 1, 2, 5)
    assert r.mota == pytest.approx(1 - (1 + 1 + 2) / 6)
    assert r.motp == pytest.approx((0.3 + 0.4 + 0.2 + 0.0 + 0.1) / 5)
    assert r.recall == pytest.approx(5 / 6) and r.precision == pytest.approx(5 / 6)
    assert r.matches["switch"].tolist() == [False, False, True, False, True]
    assert r.per_frame["fn"].tolist() == [0, 1, 0] and r.per_frame["fp"].tolist() == [1, 0, 0]


def test_gate_is_inclusive_and_configurable(two_people):
    # track 2 is 0.4 m from B in frame 0: within a 0.4 m gate, outside 0.39 m
    assert clear_mot(two_people, gate=0.4).fn == 1
    assert clear_mot(two_people, gate=0.39).fn == 2
    with pytest.raises(ValueError, match="gate"):
        clear_mot(two_people, gate=0.0)


def test_idf1_by_hand(two_people):
    n = co_occurrence(two_people, 1.0)
    assert n.loc["A", 1] == 2 and n.loc["A", 2] == 1 and n.loc["B", 2] == 2 and n.loc["B", 1] == 0
    r = idf1(two_people, 1.0)
    assert r.idtp == 4  # A-1 (frames 0, 2) and B-2 (frames 0, 2)
    assert r.idf1 == pytest.approx(2 * 4 / (6 + 6))
    assert r.idp == pytest.approx(4 / 6) and r.idr == pytest.approx(4 / 6)


def test_position_error_by_hand(two_people):
    r = clear_mot(two_people, 1.0)
    pe = position_errors(two_people, r)
    assert pe["rmse"] == pytest.approx(np.sqrt((0.09 + 0.16 + 0.04 + 0.0 + 0.01) / 5))
    assert pe["p50"] == pytest.approx(0.2)
    assert np.isnan(pe["rmse_cam0"]) and pe["n_cam0"] == 0  # no camera counts known


def test_position_error_split_by_cameras():
    # one person, three frames seen by 0, 1 and 3 cameras; errors 0.1, 0.2, 0.3 m
    truth = pd.DataFrame({"frame": [0, 1, 2], "person_id": "A", "x": 0.0, "y": 0.0, "cameras": [0, 1, 3]})
    tracks = pd.DataFrame({"frame": [0, 1, 2], "track_id": 1, "x": [0.1, 0.2, 0.3], "y": 0.0})
    f = EvalFrames(np.arange(3.0), truth, tracks)
    pe = position_errors(f, clear_mot(f))
    assert pe["rmse_cam0"] == pytest.approx(0.1)
    assert pe["rmse_cam1"] == pytest.approx(0.2)
    assert pe["rmse_cam2plus"] == pytest.approx(0.3)
    assert (pe["n_cam0"], pe["n_cam1"], pe["n_cam2plus"]) == (1, 1, 1)


def test_error_stats():
    s = error_stats(np.array([3.0, 4.0]))
    assert s["rmse"] == pytest.approx(np.sqrt(12.5))
    assert s["p50"] == pytest.approx(3.5)
    assert np.isnan(error_stats(np.array([]))["rmse"])


def test_hungarian_prefers_more_matches_then_less_distance():
    # A-h1 0.1 alone would be cheapest, but A-h2 + B-h1 matches two pairs
    cost = np.array([[0.1, 0.9], [0.95, np.nan]])
    rows, cols = gated_assignment(cost)
    assert sorted(zip(rows.tolist(), cols.tolist())) == [(0, 1), (1, 0)]
    # among two-pair solutions the smaller total wins
    rows, cols = gated_assignment(np.array([[0.1, 0.5], [0.4, 0.2]]))
    assert sorted(zip(rows.tolist(), cols.tolist())) == [(0, 0), (1, 1)]
    assert gated_assignment(np.full((2, 2), np.nan))[0].size == 0


def test_mota_counts_the_hungarian_choice_not_greedy():
    # A (0,0), B (1,0); h1 (0.3,0), h2 (-0.8,0). Nearest-first would pair A-h1 (0.3) and leave B
    # (1.8 m from h2) missed and h2 false; the assignment pairs A-h2 (0.8) and B-h1 (0.7).
    f = frames_from([(0, "A", 0.0, 0.0), (0, "B", 1.0, 0.0)], [(0, 1, 0.3, 0.0), (0, 2, -0.8, 0.0)], 1)
    r = clear_mot(f, 1.0)
    assert r.fn == 0 and r.fp == 0 and r.motp == pytest.approx(0.75)


def test_empty_frames_count_all_misses_or_false_positives():
    f = frames_from([(0, "A", 0.0, 0.0), (1, "A", 0.0, 0.0)], [(1, 5, 3.0, 3.0)], 3)
    r = clear_mot(f)
    assert (r.fn, r.fp, r.num_detections, r.num_frames) == (2, 1, 0, 3)
    assert r.mota == pytest.approx(1 - 3 / 2)
    assert np.isnan(r.motp)


def test_identification_accuracy_by_hand():
    """A carries phone pa, B carries pb, C carries none.

    frame 0: t1 on A claims pa (correct); t2 on B claims pa (wrong); t3 far from everyone claims pb
             (wrong: matched to nobody); t4 on C claims nothing.
    frame 1: t1 on A claims pa (correct); B undetected; t2 on C claims pb (wrong).
    identifications 5, correct 2; people-with-phone appearances 4 (A, B in both frames).
    """
    truth = pd.DataFrame({
        "frame": [0, 0, 0, 1, 1, 1], "person_id": ["A", "B", "C"] * 2,
        "x": [0.0, 3.0, 6.0] * 2, "y": 0.0, "phone_id": ["pa", "pb", ""] * 2,
    })
    tracks = pd.DataFrame({
        "frame": [0, 0, 0, 0, 1, 1], "track_id": [1, 2, 3, 4, 1, 2],
        "x": [0.1, 3.1, 20.0, 6.0, 0.0, 6.1], "y": 0.0,
        "phone_id": ["pa", "pa", "pb", "", "pa", "pb"],
    })
    f = EvalFrames(np.arange(2.0), truth, tracks)
    r = identification_accuracy(f, clear_mot(f))
    assert (r.correct, r.identifications, r.people_with_phone) == (2, 5, 4)
    assert r.id_accuracy == pytest.approx(0.4)
    assert r.id_accuracy_all == pytest.approx(0.5)


def test_eval_frames_rejects_bad_input():
    with pytest.raises(ValueError, match="missing columns"):
        EvalFrames(np.arange(2.0), pd.DataFrame({"frame": [0], "x": [0.0], "y": [0.0]}),
                   pd.DataFrame(columns=["frame", "track_id", "x", "y"]))
    with pytest.raises(ValueError, match="twice"):
        frames_from([(0, "A", 0.0, 0.0)], [(0, 1, 0.0, 0.0), (0, 1, 1.0, 0.0)], 1)
