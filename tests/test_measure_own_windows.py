"""scripts/measure_own_windows.py: windows holding one mover alone, on synthetic windows and labels."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from scripts.measure_own_windows import holders, own_window_counts, summarise


def test_a_window_holds_the_people_whose_visible_columns_it_covers_by_a_third():
    cols = {"target": (100.0, 120.0), "distractor": (115.0, 135.0)}
    # a window over the target alone; over both (a merge); covering 5 of the distractor's 20 columns
    # (25 %, under COVER): the target's alone; over nobody
    held = holders(np.array([[98.0, 114.0], [100.0, 136.0], [106.0, 120.0], [200.0, 220.0]]), cols)
    assert held == [{"target"}, {"target", "distractor"}, {"target"}, set()]


def _frames():
    boxes, labels = [], []
    for t in (0.1, 0.2, 0.3, 0.4):
        for c, (tx, dx) in {"a": ((100, 120), (200, 220)), "b": ((100, 120), (110, 130))}.items():
            labels += [(t, c, "target", *tx), (t, c, "distractor", *dx), (t, c, "standing1", tx[0], tx[1])]
        # camera a: one window each (0.1, 0.2), then one window over both (0.3, 0.4)
        if t < 0.25:
            boxes += [(t, "a", 98.0, 122.0), (t, "a", 198.0, 222.0)]
        else:
            boxes += [(t, "a", 98.0, 222.0)]
        # camera b: the two overlap in the image: one window over both, every frame
        boxes += [(t, "b", 100.0, 130.0)]
    return (pd.DataFrame(boxes, columns=["t", "camera", "u_left", "u_right"]),
            pd.DataFrame(labels, columns=["t", "camera", "person_id", "x0", "x1"]))


def test_own_windows_are_counted_per_camera_and_a_merge_or_a_standing_person_is_no_ones():
    boxes, labels = _frames()
    c = own_window_counts(boxes, labels)
    got = c.pivot(index="t", columns="person_id", values="own_cameras")
    # a standing person in the target's columns does not make its window a merge: movers only
    assert got["target"].tolist() == [1, 1, 0, 0]
    assert got["distractor"].tolist() == [1, 1, 0, 0]
    people = pd.DataFrame([(t, p, t < 0.35) for t in (0.1, 0.2, 0.3, 0.4) for p in ("target", "distractor")],
                          columns=["t", "person_id", "walking"])
    s = {x["person"]: x for x in summarise(c, people)}
    assert (s["target"]["walking"], s["target"]["one"], s["target"]["none"]) == (3, 2, 1)
    assert s["target"]["runs"] == [(pytest.approx(0.3), pytest.approx(0.4))]  # walking without: 0.3 s, one frame long
    assert (s["target"]["frames"], s["target"]["all_none"]) == (4, 2)
    late = {x["person"]: x for x in summarise(c, people, between=(0.3, 0.4))}
    assert (late["distractor"]["frames"], late["distractor"]["all_none"], late["distractor"]["walking"]) == (2, 2, 1)
