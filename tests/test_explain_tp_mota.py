"""scripts/explain_tp_mota.py: the classes of a movers' score's unmatched frames, on hand-made tables."""
from __future__ import annotations

import numpy as np
import pandas as pd

from scripts.explain_tp_mota import classify, counts, episodes, fn_episodes, mover_states


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


def test_a_movers_state_is_walking_standing_after_walking_or_not_yet_walked():
    t = np.arange(6) * 0.1
    people = pd.DataFrame({"t": t, "person_id": "a", "walking": [False, False, True, True, False, False]})
    S = mover_states(people, t)
    assert list(S["state"]) == ["not yet walked"] * 2 + ["walking"] * 2 + ["standing"] * 2
    # without the simulator's flag, from the speed
    people = pd.DataFrame({"t": t, "person_id": "a", "vx": [0, 0, 1.0, 1.0, 0.0, 0.0], "vy": 0.0})
    assert list(mover_states(people, t)["state"]) == list(S["state"])


def test_false_negative_runs_carry_the_movers_state_and_the_other_movers_distance():
    # b stands 0.6 m from a for 8 frames; the only track follows a, so b is missed (taken)
    frames = range(8)
    people = pd.concat([pd.DataFrame(_rows(f, [("a", 0.1 * f, 0.0), ("b", 0.5, 0.6)])) for f in frames], ignore_index=True)
    tracks = pd.DataFrame([{"frame": f, "track_id": 1, "x": 0.1 * f, "y": 0.0} for f in frames])
    matches = pd.DataFrame([{"frame": f, "person_id": "a", "track_id": 1} for f in frames])
    states = pd.DataFrame([{"frame": f, "person_id": p, "state": s} for f in frames for p, s in (("a", "walking"), ("b", "standing"))])
    C = classify(tracks, people, people, matches, states=states)
    assert set(C["id"]) == {"b"} and set(C["state"]) == {"standing"}
    assert np.isclose(C["other"].min(), 0.6)
    c = counts(C)
    assert c["fn standing"] == 8 and c["fn walking"] == 0 and c["fn taken"] + c["fn track 1-2 m"] == 8
    E = fn_episodes(C, np.arange(8) * 0.1, min_frames=5)
    assert len(E) == 1 and (E.iloc[0]["id"], E.iloc[0]["frames"], E.iloc[0]["state"]) == ("b", 8, "standing")
    assert np.isclose(E.iloc[0]["other"], 0.6) and fn_episodes(C, np.arange(8) * 0.1, min_frames=9).empty
