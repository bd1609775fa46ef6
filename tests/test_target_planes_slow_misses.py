"""target_planes: a walker who slows to a stop is not rejected by the existence test in the
frame its windows end (``JointTracker.walk_evidence``, Config ``slow_misses``; issue 12's
fifty-fifth session).

A flow tracker makes no window for a person moving slower than about ``mover_flow_px`` in its
image. A walker decelerating to a stop loses its windows camera by camera while the track's
velocity, measured from flows a few frames old, is still a little above that speed. Each such
camera's miss used to count in full against the track's existence (the mode posterior already
weighed it by the chance that the walker is that slow), so a confirmed track could be rejected
within two frames (fresh head-on 2275 and development head-on 117: the waiting look-alike left
untracked). With ``slow_misses`` a camera without a window says log P(no window | walking) =
log(P(slow) + (1 - P(slow)) P(missed)) for a confirmed track whose last frame's position and
velocity came from two or more views (``mode`` ``planes``); one seen by a single view, or not yet
confirmed, keeps the full miss.

Windows are the estimator's person model projected by the test cameras
(``tests.test_target_planes_joint.window_row``).
"""
from __future__ import annotations

import numpy as np
import pytest

from trackroom.estimators.tp_frames import CameraBoxes
from trackroom.estimators.tp_joint import EXIST_ACCEPT, EXIST_REJECT, JointTrack
from tests.test_target_planes import four_cameras
from tests.test_target_planes_joint import _box, _tracker, window_row

DECEL = 0.9  # m/s^2: the scenes' walkers slow to their waypoint stops at about this rate (rendered development truth, docs)
LAG_S = 0.2  # a window's flow is the mean over its camera track's last five frames: the velocity of two frames ago


def _walker(xy, v, mode: str, confirmed: bool = True) -> JointTrack:
    tr = JointTrack(1, np.r_[xy, v], np.diag([0.05**2] * 2 + [0.1**2] * 2), confirmed=confirmed, seen=True,
                    hits=30 if confirmed else 2, exist=EXIST_ACCEPT)
    tr.mode = mode
    return tr


def _miss(slow_misses: bool, mode: str, confirmed: bool = True) -> tuple[float, float, float]:
    """Camera ``ne``'s existence evidence for a walker at (3, 2.5) heading east, predicted to move
    5 % faster than ``mover_flow_px`` in ne's image, when ne shows no window (the frame after one
    with a window); with P(slow) and P(seen after a window) for reference."""
    cams = four_cameras()
    cfg, jt = _tracker(cams, slow_misses=slow_misses)
    ne = next(c for c in cams if c.name == "ne")
    unit = np.linalg.norm(window_row(ne, [3.0, 2.5], (1.0, 0.0))[5:])  # px/s per m/s
    tr = _walker([3.0, 2.5], [1.05 * cfg.mover_flow_px / unit, 0.0], mode, confirmed)
    p = jt.project("ne", tr)
    assert np.linalg.norm(p.flow) == pytest.approx(1.05 * cfg.mover_flow_px, rel=0.01)
    return jt.walk_evidence(tr, "ne", p, None, False), jt.p_slow(p), jt.p_see_after_hit


def test_a_miss_at_the_threshold_speed_is_weighed_by_the_chance_the_walker_is_slower():
    """A track seen by two or more views moving just above ``mover_flow_px``: even odds that the
    walker is too slow for a window, so the miss costs log(P(slow) + (1 - P(slow)) (1 - P(seen)))
    with ``slow_misses``, not log(1 - P(seen)) (about -3.9) as before."""
    on, slow, see = _miss(True, "planes")
    off, _, _ = _miss(False, "planes")
    assert 0.3 < slow < 0.6
    assert off == pytest.approx(np.log(1.0 - see))
    assert on == pytest.approx(np.log(slow + (1.0 - slow) * (1.0 - see)))
    assert on > off + 2.0


def test_a_track_seen_by_one_camera_alone_or_not_yet_confirmed_counts_its_misses_in_full():
    """A track whose last position came from one camera (``mode`` ``area``) has a velocity that
    view measured along its image axis only; how fast it moves in the other views is a guess, so
    their misses count as before, ``slow_misses`` on or off: a ghost made of one camera's windows
    (analytic draw-1 155) is not kept by the doubt about its speed. Nor is a track not yet
    confirmed, still on trial (a crossing of two fragments' planes, analytic 122)."""
    for mode, confirmed in (("area", True), ("planes", False)):
        on, _, _ = _miss(True, mode, confirmed)
        off, _, _ = _miss(False, mode, confirmed)
        assert on == off


def _stop(slow_misses: bool) -> tuple[JointTrack, list[float], float]:
    """A walker at 0.8 m/s east from (2.5, 3.5) slows to a stop at DECEL in view of all four
    cameras; each reports its window (with the flow of ``LAG_S`` before, as the tracker's
    five-frame mean flows are) while the person moves at least ``mover_flow_px`` in its image,
    none after. Returns the track after 4 s, its existence log-odds per frame and where the
    walker stopped (x, m)."""
    cams = four_cameras()
    cfg, jt = _tracker(cams, slow_misses=slow_misses)
    tr = _walker([2.5, 3.5], [0.8, 0.0], "planes")
    x, v, exist = 2.5, 0.8, []
    for _ in range(40):
        v = max(v - 0.1 * DECEL, 0.0)
        v_flow = min(v + LAG_S * DECEL, 0.8) if v > 0.0 else 0.0
        x += 0.1 * v
        frame = {}
        for c in cams:
            moving = np.linalg.norm(window_row(c, [x, 3.5], (v, 0.0))[5:]) >= cfg.mover_flow_px
            frame[c.name] = _box(c, [x, 3.5], (v_flow, 0.0)) if moving else CameraBoxes.empty()
        jt.step([tr], frame, 0.1)
        exist.append(float(tr.exist))
    return tr, exist, x


def test_a_walker_slowing_to_a_stop_ends_standing_and_accepted():
    """The whole stop: the windows end camera by camera; the track ends standing where the walker
    stopped, never rejected, and the existence evidence it loses on the way is less with
    ``slow_misses`` than without."""
    tr, on, x = _stop(True)
    _, off, _ = _stop(False)
    assert tr.mu > 0.9
    assert np.linalg.norm(tr.estimate()[:2] - [x, 3.5]) < 0.2
    assert min(on) > EXIST_REJECT
    assert EXIST_ACCEPT - min(on) < EXIST_ACCEPT - min(off)
