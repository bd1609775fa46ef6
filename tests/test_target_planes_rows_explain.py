"""target_planes: section 3.2's rows in the joint explanation (Config ``rows_explain``, on since
issue 12's sixtieth session; trials in the fifty-seventh to fifty-ninth).

Two people on nearly one line of sight of a camera project to nearly the same columns; at 6 m
their widths differ by about a pixel, but their feet are 9 px apart in the image (the nearer one's
lower). Tracks a few centimetres off sideways, as tracks are, can then swap the two windows by
their columns alone (analytic 2423: the target slows at the north-west corner with the look-alike
just behind it from obl_ne, and the target's track takes the look-alike's window). With
``rows_explain`` each window gated by two or more tracks has its rows weighed against each gating
track's projected head and feet (``JointTracker.rows_cost``, one-sided, as the existence test
weighs them), relative to the track they fit best and then to the track's own best window
(``JointTracker.rows_relative``): the rows choose who takes a window, never whether it is taken.

A track whose projected rows the window's do not reach (``JointTracker.rows_reach``, within 3
standard deviations of each projected row: edge noise and the track's position spread) is not in
it: not alone on a window others gate, nor a member of a merged one.

Windows are the estimator's person model projected by the test cameras
(``tests.test_target_planes_joint.window_row``).
"""
from __future__ import annotations

import numpy as np
from trackroom.estimators.tp_frames import CameraBoxes
from trackroom.estimators.tp_joint import JointTrack
from tests.test_target_planes import four_cameras
from tests.test_target_planes_joint import _box, _tracker, window_row

ALONG = np.array([np.sqrt(0.5), np.sqrt(0.5)])  # camera sw's line of sight through the room's middle
ACROSS = np.array([np.sqrt(0.5), -np.sqrt(0.5)])
VEL = (0.5, -0.5)  # both walking across that line


def _two_on_a_line(cam):
    """People 6.0 m and 6.6 m from camera sw (the farther 3 cm to the side) and their windows."""
    near = cam_xy(cam) + 6.0 * ALONG
    far = cam_xy(cam) + 6.6 * ALONG + 0.03 * ACROSS
    rows = [window_row(cam, near, VEL), window_row(cam, far, VEL)]
    boxes = CameraBoxes(np.array([1, 2], object), np.array([r[0] for r in rows]), np.array([r[1:5] for r in rows]),
                        np.array([r[5:7] for r in rows]))
    return near, far, boxes


def cam_xy(cam):
    return -np.linalg.solve(cam.P[:, :3], cam.P[:, 3])[:2]


def _track(tid, xy):
    return JointTrack(tid, np.r_[xy, VEL], np.diag([0.05**2, 0.05**2, 0.2**2, 0.2**2]), confirmed=True, hits=30)


def test_two_people_on_one_line_of_sight_keep_their_windows_by_their_rows():
    """Tracks 5-10 cm off sideways, the nearer one's projected right of the farther one's (the
    windows the other way round): by columns, widths and flows the two windows are swapped; with
    the rows each track takes its own person's window."""
    sw = four_cameras()[0]
    near, far, boxes = _two_on_a_line(sw)
    assert boxes.win[0, 3] - boxes.win[1, 3] > 8.0  # the nearer person's feet lower in the image
    for on in (False, True):
        _, jt = _tracker([sw], rows_explain=on)
        for off in (0.05, 0.06, 0.1):
            expl, projs = jt.explain_camera(sw.name, [_track(0, near + off * ACROSS), _track(1, far - off * ACROSS)], boxes)
            assert projs[0].u > projs[1].u and boxes.u[0] < boxes.u[1]
            assert expl == ({0: (0,), 1: (1,)} if on else {0: (1,), 1: (0,)})


def test_the_rows_never_leave_a_lone_tracks_window_as_clutter():
    """One track alone under a window whose rows do not fit it (someone 0.6 m nearer on its line
    of sight): the rows compare tracks only, so the explanation and its cost are the same with and
    without them."""
    sw = four_cameras()[0]
    near, far, _ = _two_on_a_line(sw)
    one = _box(sw, near, VEL)
    costs = []
    for on in (False, True):
        _, jt = _tracker([sw], rows_explain=on)
        tr = _track(1, far)
        expl, projs = jt.explain_camera(sw.name, [tr], one)
        assert expl == {0: (0,)}
        costs.append(jt.cost)
        assert jt.rows_cost(sw.name, tr, projs[0], one, 0) > 1.0  # the rows alone would say someone else
    assert costs[1] == costs[0]


def test_a_track_fitting_its_window_pays_nothing_for_the_rows():
    """Each track on its own person's window: the explanation's cost is the same with the rows."""
    sw = four_cameras()[0]
    near, far, boxes = _two_on_a_line(sw)
    costs = []
    for on in (False, True):
        _, jt = _tracker([sw], rows_explain=on)
        jt.explain_camera(sw.name, [_track(0, near), _track(1, far)], boxes)
        costs.append(jt.cost)
    assert costs[1] == costs[0]


def test_a_far_track_is_no_member_of_a_near_persons_window_its_rows_do_not_reach():
    """A person 1 m from camera sw shows only the head, at the bottom of the image (rows 192-240),
    in columns that hold the projection of a track 6 m away on the same line of sight (rows
    71-147). By columns the window is the two merged (analytic head-on 114: the far track then
    took the near person's flow and ran off); with the rows it is the near person's alone and the
    far track has no window."""
    sw = four_cameras()[0]
    near = cam_xy(sw) + 1.0 * ALONG
    far = cam_xy(sw) + 6.0 * ALONG
    r = window_row(sw, near, VEL)
    win = np.array([max(r[1], 0.0), min(r[2], sw.width), max(r[3], 0.0), min(r[4], sw.height)])
    boxes = CameraBoxes(np.array([1], object), np.array([0.5 * (win[0] + win[1])]), win[None], r[None, 5:7])
    for on in (False, True):
        _, jt = _tracker([sw], rows_explain=on)
        expl, projs = jt.explain_camera(sw.name, [_track(0, near), _track(1, far)], boxes)
        assert projs[1].win[3] < win[2]  # the far track's projected feet above the window's top
        assert expl == ({0: (0,)} if on else {0: (0, 1)})


def _near_and_far():
    """Camera sw; a track 2 m from it walking slowly (0.22 m/s), one 6 m away on nearly the same
    line of sight 0.2 m off sideways from its walker, and that walker's window (the only one)."""
    sw = four_cameras()[0]
    near_xy = cam_xy(sw) + 2.0 * ALONG
    far_xy = cam_xy(sw) + 6.0 * ALONG + 0.05 * ACROSS
    near = JointTrack(0, np.r_[near_xy, 0.2, -0.1], np.diag([0.05**2, 0.05**2, 0.3**2, 0.3**2]), confirmed=True, hits=30)
    return sw, near, _track(1, far_xy - 0.2 * ACROSS), _box(sw, far_xy, VEL)


def test_a_near_track_takes_a_far_window_within_its_rows_alone():
    """The limit: someone 2 m from camera sw walking slowly (0.22 m/s) in front of a walker 6 m
    away on nearly the same line of sight, whose window (whole) is the only one; the far track
    0.2 m off sideways. The window lies within the near track's columns and its rows reach the
    near track's projected head; it is the near track's best window, so relative to that its rows
    cost nothing, and by columns, widths and flows the near track alone takes it."""
    sw, near, far, boxes = _near_and_far()
    for on in (False, True):
        _, jt = _tracker([sw], rows_explain=on)
        expl, projs = jt.explain_camera(sw.name, [near, far], boxes)
        assert projs[0].win[0] < boxes.win[0, 0] and boxes.win[0, 1] < projs[0].win[1]  # the window within the near one's columns
        assert jt.rows_reach(jt.row_vars(sw.name, near), projs[0], boxes, 0)
        assert expl == {0: (0,)}


def test_a_near_track_takes_no_far_window_above_its_head_alone():
    """Analytic head-on 114's frame as it was: the far walker's window holds only the part of it
    seen above the near person's head (rows 65-98 against the near track's projected 120-239 in
    ``obl_ne``). Its columns lie within the near track's projection, so by columns, widths and
    flows the near track alone takes it, and relative to its own best window the rows cost it
    nothing (the fifty-ninth session's 'own_best'). A track is not alone on a window gated by
    others whose rows do not reach its projected rows: with the rows the far track is in the
    window's explanation."""
    sw, near, far, full = _near_and_far()
    for on in (False, True):
        _, jt = _tracker([sw], rows_explain=on)
        head = jt.project(sw.name, near).win[2]  # the near track's projected head row
        win = full.win.copy()
        win[0, 3] = head - 8.0  # the far person seen down to 8 px above the near one's head
        boxes = CameraBoxes(full.track, full.u, win, full.flow)
        expl, projs = jt.explain_camera(sw.name, [near, far], boxes)
        assert projs[0].win[0] < win[0, 0] and win[0, 1] < projs[0].win[1]  # the window within the near one's columns
        assert not jt.rows_reach(jt.row_vars(sw.name, near), projs[0], boxes, 0)
        assert jt.rows_reach(jt.row_vars(sw.name, far), projs[1], boxes, 0)
        assert (1 in expl[0]) == on
