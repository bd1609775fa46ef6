"""scripts/measure_detector_cover.py: where the estimator's geometry lets a person detector test
someone standing, on hand-made rooms (the test cameras of tests/test_target_planes.py)."""
from __future__ import annotations

import numpy as np
import pytest

from scripts.measure_detector_cover import cover, main, shares, text_map
from trackroom.recording import Calibration
from trackroom.scenes.spec import Floorplan, Obstacle
from tests.test_target_planes import calib, cam, four_cameras


def _at(cells, x, y):
    k = int(np.argmin(np.hypot(cells.x - x, cells.y - y)))
    return cells.iloc[k]


def test_the_middle_is_tested_by_every_camera_and_the_walls_by_fewer():
    """Four corner cameras looking at the middle of an 8 m x 7 m room: the middle is seen and
    tested by all four; right below the south-west camera only two see a person at all; against
    the south wall one more camera sees the cylinder, but only a sliver of it at its image's
    border, too little for its detector (``detector_sees``): seen by three, tested by two."""
    cal = calib(four_cameras())
    cells = cover(cal, 0.25)
    mid = _at(cells, 4.0, 3.5)
    assert mid.seen == 4 and mid.tested == 4
    under = _at(cells, 0.375, 0.375)
    assert under.seen == 2 and under.tested == 2
    wall = _at(cells, 3.125, 0.125)
    assert wall.seen == 3 and wall.tested == 2
    assert (cells.tested <= cells.seen).all() and (cells.seen <= 4).all()
    s = shares(cells)
    assert np.allclose(s.sum(axis=1), 1.0)
    assert s.loc["tested", "0"] == pytest.approx(float((cells.tested == 0).mean()))


def test_a_tall_box_between_camera_and_person_takes_that_detector_away():
    """One camera, a person 4 m in front of it: tested. A 2.5 m box halfway between hides every
    ray: neither seen nor tested there; the grid leaves out the box's own floor."""
    c = cam("south", [4.0, 0.2, 2.6], [4.0, 4.0, 0.9])
    outline = np.array([[0, 0], [8, 0], [8, 7], [0, 7]], float)
    open_room = Calibration({"south": c}, Floorplan(outline, (), ()))
    boxed = Calibration({"south": c}, Floorplan(outline, (), (Obstacle((4.0, 2.2), (1.6, 0.4, 2.5)),)))
    before, after = cover(open_room, 0.2), cover(boxed, 0.2)
    p_before, p_after = _at(before, 4.0, 4.1), _at(after, 4.0, 4.1)
    assert p_before.seen == 1 and p_before.tested == 1
    assert p_after.seen == 0 and p_after.tested == 0
    assert len(after) < len(before)  # no axis inside the box
    m = text_map(after, boxed, 0.2)
    assert len(m.splitlines()) == 35 and "#" in m and "x" in m


def test_a_folder_that_is_not_a_recording_is_named(tmp_path, capsys):
    assert main([str(tmp_path / "nowhere")]) == 2
    assert "nowhere" in capsys.readouterr().err
