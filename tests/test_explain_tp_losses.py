"""scripts/explain_tp_losses.py: loss episodes of target_planes' single-target output."""
import numpy as np
import pandas as pd

from scripts.explain_tp_losses import episodes, lowest_speed_before, views_before, why_untracked


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


def test_the_targets_lowest_speed_over_the_second_before_the_episode():
    # the target slows to 0.1 m/s at 0.6 s and sets off again; rows before 0.5 s, after t0 = 1.5
    # and the distractor's do not count
    people = pd.DataFrame({
        "t": [0.2, 0.5, 0.6, 1.0, 1.5, 1.6, 0.6],
        "person_id": ["target"] * 6 + ["distractor"],
        "vx": [0.0, 0.6, 0.1, 0.3, 0.8, 0.0, 0.0],
        "vy": [0.0, 0.8, 0.0, 0.4, 0.6, 0.0, 0.0],
    })
    assert lowest_speed_before(people, "target", 1.5) == 0.1
    assert lowest_speed_before(people, "target", 1.0, span=0.3) == 0.5
    assert np.isnan(lowest_speed_before(people, "target", 10.0))


def test_frames_the_target_was_not_reported_in_count_as_not_held():
    """The single-target output misses 1.0-1.9 s of a 4 s run (no track carried the target's
    identity, its track dropped as another's duplicate): identity held is over every frame the
    tracker ran, 30 of 40 here, not over the 30 reported; the RMSEs are over the reported ones."""
    from types import SimpleNamespace

    from scripts.experiment_tsutsui import every_frame, single_target_metrics
    from trackroom.estimators.target_planes import TargetPlanesResult

    times = np.round(np.arange(40) * 0.1, 1)
    shown = (times < 1.0 - 1e-9) | (times > 1.9 + 1e-9)
    truth = pd.concat([pd.DataFrame({"t": times, "person_id": "target", "x": 1.0 + 0.5 * times, "y": 2.0}),
                       pd.DataFrame({"t": times, "person_id": "distractor", "x": 5.0, "y": 5.0})])
    tracks = pd.DataFrame({"t": times[shown], "track_id": 0, "x": 1.0 + 0.5 * times[shown] + 0.1, "y": 2.0, "vx": 0.5,
                           "vy": 0.0, "n_cameras": 2, "mode": "planes"})
    status = pd.DataFrame({"t": [], "track_id": [], "camera": [], "status": [], "reason": [], "window": []})
    res = TargetPlanesResult(tracks, status, times=times)
    full = every_frame(res)
    assert len(full) == 40 and full["x"].isna().sum() == 10 and (full.loc[full["x"].isna(), "n_cameras"] == -1).all()
    m = single_target_metrics(SimpleNamespace(truth=SimpleNamespace(people=truth)), res)
    assert m["identity_held"] == 0.75 and m["frames"] == 30 and m["frames_unreported"] == 10
    assert abs(m["rmse_2plus"] - 0.1) < 1e-9 and m["frames_2plus"] == 30
