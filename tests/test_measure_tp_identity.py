"""scripts/measure_tp_identity.py: each scored identity decision labelled from the truth."""
import numpy as np
import pandas as pd

from scripts.measure_tp_identity import label, one_per_candidate, swap_time, thresholds

# two people at t = 0 and t = 2: A walks east from (1, 1) to (3, 1), B west from (3, 1.4) to (1, 1.4)
PEOPLE = pd.DataFrame({"t": [0.0, 0.0, 2.0, 2.0], "person_id": ["A", "B", "A", "B"],
                       "x": [1.0, 3.0, 3.0, 1.0], "y": [1.0, 1.4, 1.0, 1.4]})


def row(a_pre, b_pre, a_post, b_post):
    (apx, apy), (bpx, bpy), (ax, ay), (bx, by) = a_pre, b_pre, a_post, b_post
    return pd.Series({"t": 2.0, "t_pre": 0.0, "a_pre_x": apx, "a_pre_y": apy, "b_pre_x": bpx, "b_pre_y": bpy,
                      "a_post_x": ax, "a_post_y": ay, "b_post_x": bx, "b_post_y": by})


def test_labels():
    # track a started on A and ended on B, track b (or the new track) is on A: an exchange was due
    assert label(row((1, 1), (3, 1.4), (1, 1.4), (3, 1)), PEOPLE) == "exchanged"
    # a stayed on A
    assert label(row((1, 1), (3, 1.4), (3, 1), (1, 1.4)), PEOPLE) == "kept"
    # both started on A: one person seen twice
    assert label(row((1, 1), (1.1, 1), (3, 1), (1, 1.4)), PEOPLE) == "same"
    # a went to B, b is on B too: neither
    assert label(row((1, 1), (3, 1.4), (1, 1.4), (1.1, 1.4)), PEOPLE) == "other"


def test_thresholds_include_bayes_at_the_measured_prior():
    decided = pd.DataFrame({"label": ["exchanged"] + ["kept"] * 4})
    thr = thresholds(decided)
    assert sorted(round(v, 3) for v in thr.values()) == [0.0, 1.386, 4.595]


def test_swap_time_is_the_first_frame_the_track_stays_on_the_other_person():
    """A and B pass each other at t = 1 s. Track 0 starts on A, strays onto B at 0.5 s, is back
    on A at 1.0 s and on B from 1.5 s for good: its swap is at 1.5 s (the first frame of the last
    run on the other person). A track that ends on its own person has no swap."""
    people = pd.DataFrame({"t": np.repeat([0.0, 0.5, 1.0, 1.5, 2.0], 2), "person_id": ["A", "B"] * 5,
                           "x": [1.0, 3.0, 1.5, 2.5, 2.0, 2.0, 2.5, 1.5, 3.0, 1.0], "y": [1.0, 1.4] * 5})
    internal = pd.DataFrame({"t": [0.0, 0.5, 1.0, 1.5, 2.0], "track_id": 0,
                             "x": [1.0, 2.4, 2.0, 1.5, 1.0], "y": [1.0, 1.4, 1.0, 1.4, 1.4]})
    r = row((1, 1), (3, 1.4), (1, 1.4), (3, 1))
    r["a"] = 0
    assert swap_time(r, internal, people) == 1.5
    internal["x"] = [1.0, 1.5, 2.0, 2.5, 3.0]
    internal["y"] = 1.0
    assert np.isnan(swap_time(r, internal, people))


def successor_row(a_pre, b_pre, a_post, b_post, llr=1.0, a=0, b=5, kind="successor"):
    return pd.Series({**row(a_pre, b_pre, a_post, b_post).to_dict(), "kind": kind, "log_odds": llr, "a": a, "b": b})


def test_successor_labels():
    """A watched successor: the target track (a) was on A when the candidate (b) was born beside
    it; the identity should pass when b is on A at the decision and a is not."""
    # a lagged and is left where B now is, b follows A: pass the identity
    r = successor_row((1, 1), (1.1, 1), (1, 1.4), (3, 1))
    assert label(next(pd.DataFrame([r]).itertuples()), PEOPLE) == "exchanged"
    # b went to B: keep
    r = successor_row((1, 1), (1.1, 1), (1, 1.4), (1.1, 1.4))
    assert label(next(pd.DataFrame([r]).itertuples()), PEOPLE) == "kept"
    # a is still on A (and b too: a duplicate): keep
    r = successor_row((1, 1), (1.1, 1), (3, 1), (3.1, 1))
    assert label(next(pd.DataFrame([r]).itertuples()), PEOPLE) == "kept"
    # at b's birth a was between A (1, 1) and B (3, 1.4), nearly as near each: not told
    r = successor_row((2.0, 1.25), (2.1, 1.2), (1, 1.4), (3, 1))
    assert label(next(pd.DataFrame([r]).itertuples()), PEOPLE) == "ambiguous"
    r = successor_row((1.6, 1.1), (1.7, 1.1), (1, 1.4), (3, 1))  # 0.61 m from A, 1.43 m from B: told
    assert label(next(pd.DataFrame([r]).itertuples()), PEOPLE) == "exchanged"


def test_one_successor_decision_per_candidate_at_its_first_frame_of_largest_log_odds():
    """Candidate 5 scored four times (its largest log-odds 2.0 first at t = 1, again at t = 3, on
    another person by then), candidate 6 once; a pair decision is kept as it is."""
    rows = []
    for t, v, b, post in ((0.0, 0.5, 5, (3, 1)), (1.0, 2.0, 5, (3, 1)), (2.0, 1.0, 5, (3, 1)), (3.0, 2.0, 5, (1.1, 1.4)),
                          (0.0, -3.0, 6, (3, 1))):
        r = successor_row((1, 1), (1.1, 1), (1, 1.4), post, llr=v, b=b)
        r["t"] = t
        rows.append(r)
    pair = successor_row((1, 1), (3, 1.4), (1, 1.4), (3, 1), llr=7.0, b=1, kind="pair")
    out = one_per_candidate(pd.DataFrame(rows + [pair]))
    assert sorted(out["log_odds"]) == [-3.0, 2.0, 7.0]
    assert list(out["kind"]).count("pair") == 1
    assert float(out[(out["b"] == 5)]["t"].iloc[0]) == 1.0
