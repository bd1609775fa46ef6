"""Property-based tests of the metrics: CLEAR MOT, IDF1, HOTA, scoring a tracks table, intervals, tracks CSVs.

Hypothesis builds truth and tracks (empty, disjoint or shared ids, tracks at times with no truth,
huge and tiny coordinates, single rows, duplicated or empty ids, text where numbers belong).
Every case must end in a result that keeps the invariants below or in one ``EstimatorError`` /
``RecordingError`` / ``CommandError`` of one line; any other exception is a defect.

Invariants: G truth and H track appearances give matches + FN = G and matches + FP = H;
MOTA <= 1 (NaN exactly when G = 0); 0 <= MOTP <= gate; 0 <= IDF1 <= 1 (NaN exactly when
G + H = 0), IDTP <= min(G, H); renaming the tracks (any bijection) changes neither MOTA nor
IDF1 when no two distances tie; HOTA, DetA, AssA, LocA and their recall and precision parts lie
in [0, 1], HOTA true positives <= min(G, H) at every alpha and fall as alpha rises, HOTA = DetA =
AssA = 0 when G or H is 0; renaming the tracks changes no HOTA figure (no ties); tracks equal to
the truth, under any names, score HOTA = DetA = AssA = LocA = 1; an interval lies in its
metric's range.

Case counts: ``examples(n)`` (tests/conftest.py), n in CI, >= 1000 with TRACKROOM_HYPOTHESIS=slow.
"""
from __future__ import annotations

import io
import math

import numpy as np
import pandas as pd
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tests.props import examples
from tests.test_metrics_score import tiny_recording
from trackroom.errors import CommandError
from trackroom.estimators.base import EstimatorError
from trackroom.metrics.aggregate import METRIC_RANGES, mean_interval
from trackroom.metrics.hota import HOTA_COLUMNS, hota
from trackroom.metrics.identity import idf1
from trackroom.metrics.mot import EvalFrames, clear_mot
from trackroom.metrics.score import evaluate, evaluation_frames
from trackroom.recording import RecordingError

GATE = 1.0
PEOPLE = ["p0", "p1", "p2"]
TRACK_IDS = [0, 1, 2, 3]
EXTREME = [0.0, 5e-324, 1e-300, -1e-300, 1e15, -1e15, 1e150]

moderate = st.floats(-6.0, 6.0, allow_nan=False, allow_infinity=False)
coordinate = st.one_of(moderate, moderate, st.sampled_from(EXTREME))


@st.composite
def eval_frames(draw, coords=coordinate, jitter=False):
    """EvalFrames of 1-6 frames: any subset of PEOPLE and of TRACK_IDS per frame, at ``coords``.

    ``jitter`` adds a distinct irrational offset to every row, so that no two distances tie.
    """
    n = draw(st.integers(1, 6))
    truth, tracks = [], []
    for k in range(n):
        for pid in draw(st.lists(st.sampled_from(PEOPLE), unique=True, max_size=3)):
            truth.append((k, pid, draw(coords), draw(coords)))
        for tid in draw(st.lists(st.sampled_from(TRACK_IDS), unique=True, max_size=4)):
            tracks.append((k, tid, draw(coords), draw(coords)))
    t = pd.DataFrame(truth, columns=["frame", "person_id", "x", "y"]).astype({"frame": int, "x": float, "y": float})
    h = pd.DataFrame(tracks, columns=["frame", "track_id", "x", "y"]).astype({"frame": int, "x": float, "y": float})
    if jitter:
        t["x"] += np.sqrt(2 + np.arange(len(t))) * 1e-3
        h["y"] += np.sqrt(3 + 2 * np.arange(len(h))) * 1e-3
    return EvalFrames(np.arange(n) * 0.25, t, h)


def check_invariants(frames: EvalFrames, gate: float = GATE):
    mot = clear_mot(frames, gate)
    ids = idf1(frames, gate)
    G, H = len(frames.truth), len(frames.tracks)
    assert (mot.num_objects, mot.num_predictions) == (G, H)
    assert mot.num_detections + mot.fn == G and mot.num_detections + mot.fp == H
    assert mot.num_switches <= mot.num_detections <= min(G, H)
    assert (mot.per_frame[["truth", "tracks"]].sum().to_list()) == [G, H]
    if G == 0:
        assert math.isnan(mot.mota)
    else:
        assert mot.mota <= 1.0
    if mot.num_detections:
        assert 0.0 <= mot.motp <= gate
    else:
        assert math.isnan(mot.motp)
    assert 0 <= ids.idtp <= min(G, H)
    if G + H == 0:
        assert math.isnan(ids.idf1)
    else:
        assert 0.0 <= ids.idf1 <= 1.0
    check_hota(frames, gate)
    return mot, ids


def check_hota(frames: EvalFrames, gate: float = GATE) -> dict:
    h = hota(frames, gate)
    G, H = len(frames.truth), len(frames.tracks)
    m = h.metrics()
    for k in HOTA_COLUMNS:
        assert 0.0 <= m[k] <= 1.0, k
    assert ((0 <= h.tp) & (h.tp <= min(G, H))).all() and (np.diff(h.tp) <= 0).all()
    if G == 0 or H == 0:
        assert m["hota"] == m["deta"] == m["assa"] == 0.0 and m["loca"] == 1.0
    return m


@settings(max_examples=examples(150))
@given(eval_frames())
def test_clear_mot_and_idf1_invariants(frames):
    check_invariants(frames)


@settings(max_examples=examples(100))
@given(eval_frames(coords=moderate, jitter=True), st.permutations(TRACK_IDS), st.sampled_from(["", "h", 100]))
def test_renaming_tracks_changes_neither_mota_nor_idf1(frames, perm, prefix):
    mot, ids = check_invariants(frames)
    rename = {old: (f"{prefix}{new}" if isinstance(prefix, str) else prefix + new) for old, new in zip(TRACK_IDS, perm)}
    renamed = EvalFrames(frames.times, frames.truth, frames.tracks.assign(track_id=frames.tracks["track_id"].map(rename)))
    mot2, ids2 = check_invariants(renamed)
    assert (mot2.fn, mot2.fp, mot2.num_switches) == (mot.fn, mot.fp, mot.num_switches)
    assert mot2.mota == mot.mota or (math.isnan(mot.mota) and math.isnan(mot2.mota))
    assert ids2.idtp == ids.idtp
    h, h2 = check_hota(frames), check_hota(renamed)
    assert all(math.isclose(h[k], h2[k], abs_tol=1e-12) for k in HOTA_COLUMNS)


@settings(max_examples=examples(100))
@given(eval_frames(coords=moderate), st.permutations(PEOPLE), st.sampled_from(["", "h", 100]),
       st.floats(0.05, 3.0))
def test_tracks_equal_to_the_truth_score_hota_one(frames, perm, prefix, gate):
    # every person in a lane of their own, farther than the gate from the others, tracked exactly
    lane = {p: 20.0 * i for i, p in enumerate(PEOPLE)}  # |y| <= 6: lanes >= 8 m apart
    truth = frames.truth.assign(y=frames.truth["y"] + frames.truth["person_id"].map(lane))
    name = {old: (f"{prefix}{new}" if isinstance(prefix, str) else prefix + i) for i, (old, new) in enumerate(zip(PEOPLE, perm))}
    exact = EvalFrames(frames.times, truth, truth.rename(columns={"person_id": "track_id"}).assign(
        track_id=truth["person_id"].map(name)))
    m = check_hota(exact, gate)
    if len(truth):
        assert m["hota"] == m["deta"] == m["assa"] == m["loca"] == 1.0


@settings(max_examples=examples(40))
@given(eval_frames(coords=moderate))
def test_disjoint_frames_score_nothing_matched(frames):
    # tracks moved 100 m away from every truth: all misses and false positives, IDF1 0
    far = EvalFrames(frames.times, frames.truth, frames.tracks.assign(x=frames.tracks["x"] + 100.0))
    mot, ids = check_invariants(far)
    assert (mot.num_detections, mot.fn, mot.fp, ids.idtp) == (0, len(far.truth), len(far.tracks), 0)
    assert check_hota(far)["hota"] == 0.0


# --------------------------------------------------------------------- scoring a tracks table
track_time = st.one_of(st.sampled_from([0.0, 0.25, 0.5, 0.75, 1.25, 1.5]), st.floats(-2.0, 4.0, allow_nan=False))
track_id = st.one_of(st.sampled_from([1, 2, 3]), st.sampled_from(["a", "b"]), st.sampled_from([None, np.nan, "", " "]))
cell = st.one_of(coordinate, coordinate, coordinate, st.sampled_from([np.nan, np.inf, "abc", None]))


@st.composite
def tracks_table(draw):
    rows = draw(st.lists(st.tuples(track_time, track_id, cell, cell), max_size=12))
    df = pd.DataFrame(rows, columns=["t", "track_id", "x", "y"])
    if draw(st.booleans()):
        df["phone_id"] = draw(st.lists(st.sampled_from(["", "phone0", "phone9", None]), min_size=len(df), max_size=len(df)))
    return df


@st.composite
def truth_variant(draw):
    """tiny_recording (4 cameras at 4 fps, 1 s) with p0 and p1; the truth cut, emptied or renamed."""
    rec = tiny_recording(duration=2.0)
    p0 = rec.truth.people
    p1 = p0.assign(person_id="p1", x=draw(coordinate), y=draw(coordinate), phone_id="")
    people = pd.concat([p0, p1]).sort_values("t", kind="stable").reset_index(drop=True)
    how = draw(st.sampled_from(["both", "empty", "first_half", "single_row", "duplicated_t", "int_ids"]))
    if how == "empty":
        people = people.iloc[:0]
    elif how == "first_half":
        people = people[people["t"] < 1.0]
    elif how == "single_row":
        people = people.iloc[[draw(st.integers(0, len(people) - 1))]]
    elif how == "duplicated_t":
        people = pd.concat([people, people.iloc[:10]]).sort_values("t", kind="stable")
    elif how == "int_ids":
        people = people.assign(person_id=people["person_id"].map({"p0": 0, "p1": 1}))
    rec.truth.tables["people"] = people.reset_index(drop=True)
    return rec


@settings(max_examples=examples(150))
@given(truth_variant(), tracks_table(), st.sampled_from([None, "p0", "p1", "p7", 0]))
def test_evaluate_ends_in_scores_or_one_clear_error(rec, tracks, person):
    try:
        ev = evaluate(rec, tracks, GATE, person=person)
    except (EstimatorError, RecordingError) as e:
        assert str(e) and "\n" not in str(e)
        return
    check_invariants(ev.frames)
    m = ev.metrics()
    assert m["frames"] == len(evaluation_frames(rec))
    assert m["people"] <= (1 if person is not None else 2)
    if person is not None:
        assert set(ev.frames.truth["person_id"].astype(str)) <= {str(person)}
    for key, (lo, hi) in METRIC_RANGES.items():
        if key in m and not (isinstance(m[key], float) and math.isnan(m[key])):
            assert lo <= m[key] <= hi, key


@settings(max_examples=examples(100))
@given(tracks_table())
def test_tracks_csv_loads_or_one_clear_line(tracks):
    from trackroom.cli.commands.score import load_tracks

    buf = io.StringIO()
    tracks.to_csv(buf, index=False)
    buf.seek(0)
    try:
        loaded = load_tracks(buf)
    except (EstimatorError, CommandError) as e:
        assert str(e) and "\n" not in str(e)
        return
    assert np.isfinite(loaded[["t", "x", "y"]].to_numpy(float)).all()
    assert not loaded.duplicated(["t", "track_id"]).any() and loaded["track_id"].notna().all()


# --------------------------------------------------------------------- intervals
values = st.lists(st.one_of(st.floats(-1e300, 1e300), st.sampled_from([np.nan, np.inf, -np.inf, 0.0, 1.0, -1.0])),
                  max_size=12)


@settings(max_examples=examples(200))
@given(values, st.sampled_from([None, *sorted(METRIC_RANGES)]))
def test_interval_stays_in_the_metrics_range(v, metric):
    mean, lo, hi, n = mean_interval(v, metric)
    finite = [x for x in v if math.isfinite(x)]
    assert n == len(finite)
    if n < 2:
        assert math.isnan(lo) and math.isnan(hi)
        assert math.isnan(mean) == (n == 0)
        return
    low_ok, high_ok = METRIC_RANGES.get(metric, (-math.inf, math.inf))
    assert low_ok <= lo <= hi <= high_ok
    assert min(max(min(finite), low_ok), high_ok) <= lo and hi <= max(min(max(finite), high_ok), low_ok)
    assert mean_interval(v, metric) == (mean, lo, hi, n) or math.isnan(mean)  # seeded: the same interval
