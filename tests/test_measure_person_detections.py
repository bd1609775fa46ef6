"""scripts/measure_person_detections.py: the person detector's rates and column error, measured
against the truth on a short analytic occlusion_lab recording (``occlusion_lab_6s``, conftest)."""
from __future__ import annotations

import numpy as np
import pytest

from scripts import measure_person_detections as mpd


@pytest.fixture(scope="module")
def rec_dir(occlusion_lab_6s):
    return occlusion_lab_6s


def test_people_seen_whole_are_detected_near_their_axis(rec_dir):
    """Every camera frame of a person wholly in view and clear of the shelves is a row; the fitted
    detector finds nearly all of them, and its columns lie about the projected axis within a few
    pixels (the analytic model's spread, about 1.5 px robust sd on the development recordings)."""
    people, ghosts = mpd.measure(rec_dir, np.random.default_rng(0))
    assert list(people.columns) == ["t", "camera", "who", "hit", "resid"]
    assert len(people) > 100 and people.hit.mean() > 0.85
    r = people.resid[people.hit]
    assert abs(float(r.median())) < 1.0
    assert 1.4826 * float((r - r.median()).abs().median()) < 3.0
    assert len(ghosts) and ((ghosts.chance >= 0.0) & (ghosts.chance <= 1.0)).all()


def test_main_prints_the_rates_and_the_column_error(rec_dir, capsys):
    assert mpd.main([rec_dir]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("people wholly seen:") and "mean miss run" in out[0]
    assert out[1].startswith("their detections' columns against the projected axis:") and "robust sd" in out[1]
    assert out[2].startswith("ghosts")
