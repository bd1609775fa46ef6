"""How high the floor plan's boxes hide a person from a camera (``scenes.spec.hidden_heights``),
and the analytic windows cut there (``sim.analytic.box_cut_rows``): checked against a hand-worked
case and against the estimators' independent ray-against-box test (``tp_joint.Occluders``)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from trackroom.estimators.tp_joint import Occluders
from trackroom.scenes.loader import load_scene
from trackroom.scenes.spec import hidden_heights, occluding_boxes
from trackroom.sim.analytic import CUT_LINES, box_cut_rows

# a box 1 m high, 1 m wide, from y = 1.9 to 2.1, seen from (0, 0) 1.5 m up: the sight line to a
# point of the vertical line at (0, 4) leaves the box's footprint at 2.1 / 4 of its length, where
# its height is 1.5 + (z - 1.5) 0.525, at most 1 m for z <= 1.5 - 0.5 / 0.525 = 0.548 m
BOX = SimpleNamespace(center=(0.0, 2.0), size=(1.0, 0.2, 1.0), yaw=0.0)
EYE = (0.0, 0.0, 1.5)


def test_the_hidden_height_worked_out_by_hand():
    boxes = occluding_boxes(SimpleNamespace(obstacles=[BOX], walls=[]))
    assert np.isclose(hidden_heights(boxes, EYE, [0.0, 4.0]), 1.5 - 0.5 / 0.525)
    assert hidden_heights(boxes, EYE, [3.0, 4.0]) == -np.inf  # the sight line passes beside the box
    assert hidden_heights(boxes, EYE, [0.0, 1.0]) == -np.inf  # in front of it
    assert hidden_heights(boxes[:0], EYE, [0.0, 4.0]) == -np.inf  # no boxes
    wall = SimpleNamespace(start=(-1.0, 2.0), end=(1.0, 2.0), thickness=0.1, height=2.5)
    walls = occluding_boxes(SimpleNamespace(obstacles=[], walls=[wall]))
    assert hidden_heights(walls, EYE, [0.0, 4.0]) == np.inf  # taller than the eye: hidden whole


@settings(max_examples=60, deadline=None)
@given(cx=st.floats(-2, 2), cy=st.floats(1, 3), sx=st.floats(0.2, 2), sy=st.floats(0.2, 2), h=st.floats(0.3, 2.0),
       yaw=st.floats(-np.pi, np.pi), ex=st.floats(-3, 3), ez=st.floats(2.1, 3.0), px=st.floats(-3, 3), py=st.floats(3.2, 6))
def test_the_hidden_height_agrees_with_a_ray_test_at_every_height(cx, cy, sx, sy, h, yaw, ex, ez, px, py):
    box = SimpleNamespace(center=(cx, cy), size=(sx, sy, h), yaw=yaw)
    plan = SimpleNamespace(obstacles=[box], walls=[])
    eye = np.array([ex, -0.5, ez])
    P = np.c_[np.eye(3), -eye]  # a camera whose optical centre is the eye
    z = np.linspace(0.0, 1.9, 191)
    clear = Occluders(plan, {"c": P}, 1.0).clear_heights("c", np.array([[px, py]]), z)[0]
    top = hidden_heights(occluding_boxes(plan), eye, [px, py])
    far = np.abs(z - top) > 1e-6  # a sight line grazing the box's edge is either
    assert np.array_equal(clear[far], (z > top)[far])


def _standing_at(xy, scene):
    """A stand-in for the trajectories: every walker standing at xy (one step)."""
    heights = np.array([w.height for w in scene.walkers])
    pos = np.zeros((len(heights), 1, 3))
    pos[:, 0, :2] = xy
    pos[:, 0, 2] = 0.5 * heights
    return SimpleNamespace(pos=pos), heights, np.array([w.radius for w in scene.walkers])


def _brute_force_row(cam, plan, xy, height, radius):
    """The lowest image row of the person that a fine scan of heights on CUT_LINES lines across
    it finds seen (the independent ray test), +inf if some line is seen at the floor."""
    occ = Occluders(plan, {cam.name: np.c_[np.eye(3), -np.asarray(cam.position, float)]}, 1.0)
    along = np.asarray(xy, float) - np.asarray(cam.position, float)[:2]
    along /= np.hypot(*along)
    lines = np.asarray(xy, float) + np.outer(np.linspace(-radius, radius, CUT_LINES), [-along[1], along[0]])
    z = np.linspace(0.0, height, 2001)
    clear = occ.clear_heights(cam.name, lines, z)
    if clear[:, 0].any():
        return np.inf
    rows = [cam.project(np.r_[p, z[np.argmax(c)]])[0][1] for p, c in zip(lines, clear) if c.any()]
    return max(rows)


def test_a_person_behind_the_shelf_is_cut_at_its_edge_and_one_in_the_open_is_not():
    scene = load_scene("occlusion_lab")
    boxes = occluding_boxes(scene.floorplan)
    # behind the shelf from obl_ne (head and shoulders seen), behind the desk from obl_sw (the
    # lower legs hidden), in the open
    for c, xy, hidden in (("obl_ne", (3.0, 3.0), True), ("obl_sw", (3.0, 3.0), True), ("obl_ne", (1.5, 1.0), False)):
        cam = scene.camera(c)
        traj, heights, radii = _standing_at(xy, scene)
        rows = box_cut_rows(cam, traj, heights, radii, np.array([0]), boxes)[0]
        want = _brute_force_row(cam, scene.floorplan, xy, heights[0], radii[0])
        assert np.isfinite(want) == hidden
        if hidden:
            assert abs(rows[0] - want) < 0.5  # px: the scan's step is under a millimetre
            (_, v_feet), _ = cam.project(np.r_[xy, 0.0])
            assert rows[0] < v_feet - 10  # well above the feet
        else:
            assert rows[0] == np.inf
