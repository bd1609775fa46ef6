"""scripts/measure_tp_duplicates.py: labelling a dropped track by the person it followed, on synthetic tables."""
from __future__ import annotations

import numpy as np
import pandas as pd

from scripts.measure_tp_duplicates import apart_frames, follows, of_another


def _people(t):
    return pd.concat([pd.DataFrame({"t": t, "person_id": "target", "x": 1.0 + t, "y": 1.0}),
                      pd.DataFrame({"t": t, "person_id": "distractor", "x": 1.0 + t, "y": 1.6})], ignore_index=True)


def test_a_track_is_labelled_with_the_person_it_was_nearest_most_of_the_time():
    t = np.round(np.arange(0.0, 1.0, 0.1), 2)
    people = _people(t)
    y = np.where(t < 0.7, 1.55, 1.1)  # on the look-alike, then onto the target for 3 frames
    assert follows(pd.DataFrame({"t": t, "x": 1.0 + t, "y": y}), people) == "distractor"
    assert follows(pd.DataFrame({"t": t, "x": 5.0 + t, "y": y}), people) == "none"  # nobody within 0.7 m
    assert follows(pd.DataFrame({"t": [], "x": [], "y": []}), people) is None
    df = pd.DataFrame({"dropped_follows": ["distractor", "target", "none"], "kept_follows": ["target", "target", "target"]})
    assert of_another(df).tolist() == [True, False, False]


def test_apart_frames_count_one_camera_holding_both_tracks_in_different_windows():
    s = pd.DataFrame({"t": [1.0, 1.0, 1.1, 1.1, 1.2, 1.2, 0.5, 0.5],
                      "camera": ["a", "a", "a", "a", "a", "b", "a", "a"],
                      "track_id": [1, 2, 1, 2, 1, 2, 1, 2],
                      "status": ["tracking"] * 8,
                      "window": [3, 4, 3, 3, 5, 6, 7, 8]})
    # 1.0: two windows in camera a (counted); 1.1: one window for both; 1.2: different cameras;
    # 0.5: older than 2 s before t = 2.6
    assert apart_frames(s, 1, 2, 2.6) == 1
