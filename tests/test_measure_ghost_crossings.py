"""scripts/measure_ghost_crossings.py: crossings labelled against the truth and counted."""
from __future__ import annotations

import pandas as pd

from scripts.measure_ghost_crossings import PERSON_M, label_crossings, summary


def test_a_crossing_is_a_person_only_within_reach_of_someone_at_its_frame():
    people = pd.DataFrame({"t": [0.1, 0.1, 0.2], "person_id": ["a", "b", "a"], "x": [1.0, 5.0, 9.0], "y": [1.0, 5.0, 9.0]})
    crossings = pd.DataFrame({"t": [0.1, 0.1, 0.2, 0.3], "x": [1.0 + 0.9 * PERSON_M, 3.0, 1.0, 1.0], "y": [1.0, 3.0, 1.0, 1.0],
                              "no_one": [0, 2, 1, 3]})
    lab = label_crossings(crossings, people)
    # near a at 0.1; between a and b at 0.1; where a was at 0.1 but not at 0.2; a frame without truth
    assert lab["person"].tolist() == [True, False, False, False]


def test_the_summary_counts_each_class_of_cameras_seeing_no_one():
    lab = pd.DataFrame({"no_one": [0, 0, 1, 2, 3, 4], "person": [True, False, True, False, False, True]})
    tab = summary(lab)
    assert tab.loc["0", "person"] == 1 and tab.loc["0", "ghost"] == 1
    assert tab.loc["1", "person"] == 1 and tab.loc["1", "ghost"] == 0
    assert tab.loc["2+", "person"] == 1 and tab.loc["2+", "ghost"] == 2
    assert tab.loc["2+", "ghost share"] == round(2 / 3, 3)
