"""target_planes: a window's likelihood is normalised by the spread of the prediction it is
compared with (``JointTracker.explain_cost``, Config ``fit_normalised``, on by default since issue 12's eighth session; branch tp12m).

On development recordings the movers' largest MOTA loss was a stopped person's track dropped
while the person still stood: a walker that stops makes no flow window, its track's walking state
spreads (white acceleration, capped at ``sigma_max``), and the first window of someone walking
past or stopping beside it - 0.5-1 m away - fitted that spread-out prediction better than the
neighbour's own, well-located track (0.5 d^2 alone, without the Gaussian's normalisation). The
stopped track took the window, jumped onto the neighbour and was dropped as its duplicate (or
left the floor plan, or failed the existence test). With the normalisation 0.5 log(var / var0)
(var0: a perfectly located track's) a spread-out prediction is as unlikely as it is wide.

Windows are the estimator's person model projected by the test cameras
(``tests.test_target_planes_joint._box``).
"""
from __future__ import annotations

import numpy as np

from trackroom.estimators.tp_joint import C_CLUTTER, JointTrack
from tests.test_target_planes import four_cameras
from tests.test_target_planes_joint import _box
from tests.test_target_planes_joint import _tracker as _joint_tracker


def _tracker(cams, on=True):
    """``tests.test_target_planes_joint._tracker`` with ``fit_normalised`` on (the default) or off,
    and the Gaussian width error these comparisons were measured with (``width_tail`` 0: with the
    gross-error tail, one near-tie of the unnormalised fit goes the other way)."""
    return _joint_tracker(cams, fit_normalised=on, width_tail=0.0)


def _pair(off):
    """A: a walker coming to a stop at (3.0, 3.0), its track well located (0.05 m spread) but
    ``off`` metres to the east of it, as tracks are. B: a person who stopped 0.7 m north 2 s ago,
    no window since: standing probability 0.5, standing position where it stands, its walking
    state's spread grown to 1 m (position) and 0.5 m/s."""
    a = JointTrack(0, np.r_[3.0 + off, 3.0, 0.0, 0.0], np.diag([0.05**2, 0.05**2, 0.1**2, 0.1**2]), confirmed=True, hits=30, mu=0.0)
    b = JointTrack(1, np.r_[3.0, 3.7, 0.0, 0.0], np.diag([1.0**2, 1.0**2, 0.5**2, 0.5**2]), confirmed=True, hits=30, mu=0.5)
    b.xs, b.Ps = np.array([3.0, 3.7]), np.diag([0.05**2] * 2)
    return a, b


def test_the_window_of_a_person_stopping_goes_to_its_own_track_not_to_a_stopped_neighbours_spread_out_one():
    cams = four_cameras()
    for on in (True, False):
        cfg, jt = _tracker(cams, on)
        to_b = {}
        for off in (0.0, 0.1, 0.15):
            to_b[off] = 0
            for c in cams:
                a, b = _pair(off)
                expl, _ = jt.explain_camera(c.name, [a, b], _box(c, [3.0, 3.0]))
                assert set(expl) == {0} and len(expl[0]) == 1
                to_b[off] += expl[0] == (1,)
        if on:
            assert to_b == {0.0: 0, 0.1: 0, 0.15: 0}  # A's own track takes its window in every camera
        else:  # without the normalisation B takes it in 2 (0.1 m) and 3 (0.15 m) of 4 cameras
            assert to_b == {0.0: 0, 0.1: 2, 0.15: 3}


def test_a_spread_out_track_alone_still_explains_the_window_on_it():
    """The normalisation is no bar to a track whose prediction is wide: alone, B takes the window
    of B's own start from rest, where it stood (its cost stays below clutter's)."""
    cams = four_cameras()
    cfg, jt = _tracker(cams)
    for c in cams:
        _, b = _pair(0.0)
        box = _box(c, [3.0, 3.7], (0.3, 0.0))
        expl, projs = jt.explain_camera(c.name, [b], box)
        assert expl == {0: (0,)}
        assert jt.explain_cost(c.name, [projs[0]], box, 0) < C_CLUTTER


def test_a_step_keeps_the_stopped_track_where_it_stands():
    """One frame of the tracker with A's window in all four cameras: A takes every one, B has
    none and stays where it stands (without the normalisation B takes windows and moves towards A)."""
    cams = four_cameras()
    for on in (True, False):
        cfg, jt = _tracker(cams, on)
        a, b = _pair(0.15)
        frame = {c.name: _box(c, [3.0, 3.0]) for c in cams}
        jt.step([a, b], frame, 0.1)
        kept = a.n_used == 4 and b.n_used == 0 and not b.seen and np.linalg.norm(b.estimate()[:2] - [3.0, 3.7]) < 0.1
        assert kept == on


def test_the_normalisation_costs_a_lone_spread_track_a_distant_window_and_ranks_two_tracks():
    """With ``fit_normalised`` a walker's wide prediction (0.8 m) loses, in one camera more, a
    window 2 m from it (left as clutter; without the normalisation it is taken in all four), and of
    two tracks for one window the stopped neighbour's spread-out track no longer takes it (three
    cameras without the normalisation, none with it)."""
    cams = four_cameras()

    held, to_b = {}, {}
    for on in (False, True):
        _, jt = _tracker(cams, on)
        held[on] = to_b[on] = 0
        for c in cams:
            b = JointTrack(1, np.r_[3.0, 3.0, 0.5, 0.0], np.diag([0.8**2, 0.8**2, 0.5**2, 0.5**2]), confirmed=True, hits=30, mu=0.0)
            expl, _ = jt.explain_camera(c.name, [b], _box(c, [5.0, 3.0], (0.5, 0.0)))
            held[on] += expl == {0: (0,)}
            a, b = _pair(0.15)
            expl, _ = jt.explain_camera(c.name, [a, b], _box(c, [3.0, 3.0]))
            to_b[on] += expl[0] == (1,)
    assert held == {False: 4, True: 3}
    assert to_b == {False: 3, True: 0}
