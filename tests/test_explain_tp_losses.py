"""scripts/explain_tp_losses.py: loss episodes of target_planes' single-target output."""
import numpy as np
import pandas as pd

from scripts.explain_tp_losses import episodes, views_before, why_untracked


def test_loss_runs_less_than_a_second_apart_are_one_episode():
    t = np.round(np.arange(60) * 0.1, 1)
    held = np.ones(60, bool)
    held[[5, 6, 7]] = False  # 0.5-0.7 s
    held[[14, 15]] = False  # 0.7 s after: joined
    held[[40]] = False  # 2.5 s after: a new episode
    assert episodes(held, t) == [(5, 15), (40, 40)]
    assert episodes(np.ones(5, bool), t[:5]) == []


def test_the_last_track_on_the_other_person_and_how_it_ended():
    """The look-alike at x = 1 + 0.1 t; its track 3 followed it until 2 s and was dropped as a
    duplicate of the target's track 0; track 4 never came near it."""
    t = np.round(np.arange(50) * 0.1, 1)
    xy = np.c_[1.0 + 0.1 * t, np.zeros_like(t)]
    rows = [(tk, 3, 1.0 + 0.1 * tk, 0.05, True) for tk in t[:21]] + [(tk, 4, 5.0, 5.0, True) for tk in t]
    rows += [(tk, 0, 3.0, 3.0, True) for tk in t]
    internal = pd.DataFrame(rows, columns=["t", "track_id", "x", "y", "confirmed"])
    ends = pd.DataFrame([(2.0, 3, 1.2, 0.05, "duplicate", 0)], columns=["t", "track_id", "x", "y", "reason", "other"])
    assert why_untracked(ends, internal, t, xy, 4.0, own=0) == "duplicate of target"
    assert why_untracked(ends, internal, t, xy, 4.0, own=4) == "duplicate"
    assert why_untracked(ends.iloc[:0], internal, t, xy, 4.0, own=0) == "alive"
    far = np.c_[t * 0 + 9.0, t * 0 + 9.0]
    assert why_untracked(ends, internal, t, far, 4.0, own=0) == "never"


def test_views_before_counts_the_cameras_that_truly_see_the_person():
    # two frames in the second before t0 = 1.0: 2 cameras then 1 see the target; the distractor
    # and frames at or after t0 do not count
    vis = pd.DataFrame({
        "t": [0.5, 0.5, 0.5, 0.9, 0.9, 0.9, 1.0, 0.5],
        "camera": ["a", "b", "c", "a", "b", "c", "a", "a"],
        "person_id": ["target"] * 7 + ["distractor"],
        "visible": [True, True, False, True, False, False, True, True],
    })
    assert views_before(vis, "target", 1.0) == 1.5
    assert np.isnan(views_before(vis, "target", 10.0))
