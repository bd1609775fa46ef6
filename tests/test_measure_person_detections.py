"""scripts/measure_person_detections.py: the person detector's rates and column error, measured
against the truth on a short analytic occlusion_lab recording (``occlusion_lab_6s``, conftest)."""
from __future__ import annotations

import numpy as np
import pandas as pd
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
    assert list(people.columns) == ["t", "camera", "who", "hit", "resid", "still", "view"]
    assert set(people.view) <= set(mpd.VIEWS) and set(ghosts.view) <= {"whole", "border", "hidden"}
    people = people[people.view == "whole"]
    assert len(people) > 100 and people.hit.mean() > 0.85
    r = people.resid[people.hit]
    assert abs(float(r.median())) < 1.0
    assert 1.4826 * float((r - r.median()).abs().median()) < 3.0
    assert len(ghosts) and ((ghosts.chance >= 0.0) & (ghosts.chance <= 1.0)).all()


def test_main_prints_the_rates_and_the_column_error(rec_dir, capsys):
    assert mpd.main([rec_dir]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("people wholly seen:") and "mean miss run" in out[0]
    rest = [line for line in out[1:] if not line.startswith("  ")]
    split = [line.strip() for line in out[1:] if line.startswith("  ")]
    assert split and all(line.startswith(("standing", "walking")) and "longest miss run" in line for line in split)
    assert rest[0].startswith("their detections' columns against the projected axis:") and "robust sd" in rest[0]
    assert rest[1].startswith("ghosts")


def test_miss_runs_are_counted_over_consecutive_frames_per_group():
    """Runs of misses per (camera, person): a detection ends a run, and so does a gap in the
    group's frames (the person out of view); groups are counted apart."""
    t = np.round(np.arange(12) * 0.1, 6)
    hit_a = [1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 0]
    a = pd.DataFrame({"t": t, "camera": "c1", "who": "p", "hit": np.array(hit_a, bool)})
    b = pd.DataFrame({"t": np.r_[t[:3], t[6:9]], "camera": "c2", "who": "p", "hit": False})  # a gap after 0.2 s
    runs = sorted(mpd.miss_runs(pd.concat([a, b]), ["camera", "who"]).tolist())
    assert runs == [1, 3, 3, 3, 4]


def test_views_give_the_rates_of_people_seen_partly(rec_dir, capsys):
    """``--views``: a row per view and people standing, walking or ghost points, each rate a
    probability, the people seen whole detected as in the first line."""
    people, ghosts = mpd.measure(rec_dir, np.random.default_rng(0))
    table = mpd.views_table(people.assign(rec="r"), ghosts.assign(rec="r"))
    assert {"whole", "border"} <= set(table.view) and set(table.who) <= {"standing", "walking", "ghosts"}
    assert ((table.detected >= 0.0) & (table.detected <= 1.0)).all() and (table.frames > 0).all()
    whole = people[people.view == "whole"]
    rows = table[(table.view == "whole") & (table.who != "ghosts")]
    assert (rows.detected * rows.frames).sum() == pytest.approx(float(whole.hit.sum()))
    assert mpd.main([rec_dir, "--views"]) == 0
    out = capsys.readouterr().out
    assert "by view (whole: seen whole; border:" in out and "after_miss" in out
