"""scripts/classify_losses.py: the first loss of the target and its class, on a hand-made truth."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from scripts.classify_losses import describe, first_loss, loss_context


def test_the_first_loss_is_the_first_run_of_frames_not_held():
    held = np.array([1, 1, 0, 1, 0, 0, 0, 0, 1], bool)
    assert first_loss(held) == 4  # the single frame at 2 is a slip
    assert first_loss(held, run=1) == 2
    assert first_loss(np.ones(5, bool)) is None


def _truth(target_speeds, other=("distractor", 0.6, 1.0)):
    """Ten frames (0.1 s): the target at (0, 0) with the speeds given, one other person at
    (x, 0) walking at the speed given."""
    rows = []
    name, x, v = other
    for k, s in enumerate(target_speeds):
        t = round(0.1 * k, 1)
        rows.append({"t": t, "person_id": "target", "x": 0.0, "y": 0.0, "vx": s, "vy": 0.0})
        rows.append({"t": t, "person_id": name, "x": x, "y": 0.0, "vx": 0.0, "vy": v})
    return pd.DataFrame(rows)


def test_a_target_slow_in_the_second_before_taken_by_a_walker():
    people = _truth([1.0, 0.8, 0.3, 0.1, 0.0, 0.0, 0.2, 0.4, 0.6, 0.7, 0.7])
    ctx = loss_context(people, 1.0, (0.55, 0.05))
    assert ctx["kind"] == "taken while slow"
    assert ctx["target_min_speed"] == pytest.approx(0.0) and ctx["target_speed"] == pytest.approx(0.7)
    assert ctx["nearest"] == "distractor" and ctx["nearest_m"] == pytest.approx(0.6) and ctx["nearest_speed"] == pytest.approx(1.0)
    assert ctx["output_nearest"] == "distractor" and ctx["output_target_m"] == pytest.approx(np.hypot(0.55, 0.05))
    assert "taken while slow" in describe("rec", 0.5, ctx) and "nearest distractor 0.60 m away" in describe("rec", 0.5, ctx)


def test_walking_taken_off_and_no_output_are_told_apart():
    walking = _truth([1.0] * 11)
    assert loss_context(walking, 1.0, (0.55, 0.0))["kind"] == "taken"
    assert loss_context(walking, 1.0, (-1.2, 0.0))["kind"] == "off"  # nearest the target, over 1 m from it
    assert loss_context(walking, 1.0, (np.nan, np.nan))["kind"] == "no output"
    standing = _truth([0.0] * 11, other=("distractor", 0.6, 0.0))
    assert loss_context(standing, 1.0, (0.55, 0.0))["kind"] == "taken"  # the other stands: not a walker's
    assert "no loss" in describe("rec", 1.0, None)


def test_a_truth_without_the_target_is_named():
    people = _truth([1.0] * 3).replace({"person_id": {"target": "someone"}})
    with pytest.raises(ValueError, match="no 'target'"):
        loss_context(people, 0.1, (0.0, 0.0))
