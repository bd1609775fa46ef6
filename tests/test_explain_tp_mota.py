"""scripts/explain_tp_mota.py: the classes of a movers' score's unmatched frames, on hand-made tables."""
from __future__ import annotations

import numpy as np
import pandas as pd

from scripts.explain_tp_mota import classify, counts, episodes


def _rows(frame, items):
    return [{"frame": frame, "person_id": p, "x": x, "y": y} for p, x, y in items]


def test_every_unmatched_frame_gets_its_class():
    # frame 0: mover a at (0, 0), mover b at (5, 0), standing s at (2, 4)
    people = pd.DataFrame(_rows(0, [("a", 0.0, 0.0), ("b", 5.0, 0.0), ("s", 2.0, 4.0)]))
    movers = people[people.person_id.isin(["a", "b"])]
    tracks = pd.DataFrame([
        {"frame": 0, "track_id": 1, "x": 0.1, "y": 0.0},   # on a, matched
        {"frame": 0, "track_id": 2, "x": 0.0, "y": 0.6},   # a second track on a: duplicate
        {"frame": 0, "track_id": 3, "x": 2.0, "y": 4.3},   # on the standing person
        {"frame": 0, "track_id": 4, "x": 6.5, "y": 0.0},   # 1.5 m off b (b is unmatched)
        {"frame": 0, "track_id": 5, "x": 2.5, "y": -3.0},  # far from everyone
    ])
    matches = pd.DataFrame([{"frame": 0, "person_id": "a", "track_id": 1}])
    C = classify(tracks, movers, people, matches)
    fp = dict(zip(C[C.kind == "fp"]["id"], C[C.kind == "fp"]["cls"]))
    assert fp == {2: "duplicate", 3: "standing", 4: "off", 5: "far"}
    fn = dict(zip(C[C.kind == "fn"]["id"], C[C.kind == "fn"]["cls"]))
    assert fn == {"b": "track 1-2 m"}
    c = counts(C)
    assert c["fp duplicate"] == 1 and c["fp far"] == 1 and c["fn track 1-2 m"] == 1 and c["fn taken"] == 0


def test_a_mover_beside_a_track_matched_elsewhere_is_taken_and_one_with_none_near_has_no_track():
    people = pd.DataFrame(_rows(0, [("a", 0.0, 0.0), ("b", 0.5, 0.0), ("c", 9.0, 9.0)]))
    tracks = pd.DataFrame([{"frame": 0, "track_id": 1, "x": 0.2, "y": 0.0}])
    matches = pd.DataFrame([{"frame": 0, "person_id": "a", "track_id": 1}])
    C = classify(tracks, people, people, matches)
    assert dict(zip(C["id"], C["cls"])) == {"b": "taken", "c": "no track"}


def test_episodes_are_a_tracks_runs_of_one_class():
    people = pd.concat([pd.DataFrame(_rows(f, [("a", 0.1 * f, 0.0)])) for f in range(10)], ignore_index=True)
    tracks = pd.DataFrame([{"frame": f, "track_id": 7, "x": 0.1 * f, "y": 3.0} for f in range(10)])
    C = classify(tracks, people, people, pd.DataFrame(columns=["frame", "person_id", "track_id"]))
    E = episodes(C, np.arange(10) * 0.1, min_frames=5)
    assert len(E) == 1
    e = E.iloc[0]
    assert (e["id"], e["cls"], e["frames"], e["near"]) == (7, "far", 10, "a")
    assert np.isclose(e["t1"], 0.9) and np.isclose(e["moved"], 0.9) and np.isclose(e["d"], 3.0)
    assert episodes(C, np.arange(10) * 0.1, min_frames=11).empty
