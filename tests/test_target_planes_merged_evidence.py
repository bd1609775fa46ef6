"""target_planes: a merged window as evidence of each member's existence (``JointTracker.
walk_evidence``, Config ``merged_evidence``; issue 12's twenty-third session).

Before, a window explained as several tracks merged counted nothing for any of them. A track
that stayed in merged windows and overlapped another track's projection in every other view (a
duplicate half a metre from its person, a ghost left beside a walker) was then never tested,
and a real person walking beside another gained nothing from windows that were theirs. With
``merged_evidence`` the window counts, for each member, how much better it is explained with the
member than by the others alone.

Windows are the estimator's person model projected by the test cameras
(``tests.test_target_planes_joint.window_row``).
"""
from __future__ import annotations

import numpy as np

from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_frames import CameraBoxes
from trackroom.estimators.tp_joint import EXIST_REJECT, JointTrack
from tests.test_target_planes import four_cameras
from tests.test_target_planes_joint import _tracker, window_row

V = np.array([0.8, 0.0])


def _walker(tid, xy):
    return JointTrack(tid, np.r_[xy, V], np.diag([0.05**2, 0.05**2, 0.1**2, 0.1**2]), confirmed=True, hits=30, seen=True)


def _frame(cams, people):
    """One window per camera: the union of the people's projected cylinders at ``people`` (floor
    points) walking at V, with their mean flow (a merged flow region; one person: its own)."""
    out = {}
    for c in cams:
        rows = [window_row(c, xy, V) for xy in people]
        win = np.r_[min(r[1] for r in rows), max(r[2] for r in rows), min(r[3] for r in rows), max(r[4] for r in rows)]
        flow = np.mean([r[5:] for r in rows], 0)
        out[c.name] = CameraBoxes(np.array([1], object), np.array([0.5 * (win[0] + win[1])]), win[None], flow[None])
    return out


def _step(merged_evidence: bool, people_seen: int) -> tuple[JointTrack, JointTrack]:
    """Tracks a at (3, 3) and b 0.5 m north of it, both walking east; every camera reports the
    union of the first ``people_seen`` of the two true people (0.08 m ahead of the tracks: one
    frame's motion) as one window. Returns the tracks after the frame."""
    cams = four_cameras()
    _, jt = _tracker(cams, merged_evidence=merged_evidence)
    a, b = _walker(0, [3.0, 3.0]), _walker(1, [3.0, 3.5])
    truth = [a.xy + [0.08, 0.0], b.xy + [0.08, 0.0]][:people_seen]
    jt.step([a, b], _frame(cams, truth), 0.1)
    return a, b


def test_a_merged_window_of_two_walkers_is_evidence_that_both_are_there():
    """Two people 0.5 m apart, every view one window spanning both: explained as merged in every
    camera, it counted nothing before; now both tracks gain (existence log-odds above 0)."""
    for on in (False, True):
        a, b = _step(on, people_seen=2)
        assert {c: s[0] for c, s in b.status.items()} == {c: "merged" for c in ("sw", "se", "ne", "nw")}
        if on:
            assert a.exist > 1.0 and b.exist > 1.0
        else:
            assert a.exist == 0.0 and b.exist == 0.0


def test_a_track_whose_merged_window_fits_the_other_alone_is_rejected():
    """A duplicate 0.5 m from the one person there: every window is that person's alone. Where
    the duplicate's projection overlaps the person's it is hidden (no evidence); where the
    explanation merges it into the person's window the window fits the person alone better.
    Before, it was never tested (log-odds 0); now that camera's evidence rejects it, and the
    person's track is accepted either way."""
    for on in (False, True):
        a, b = _step(on, people_seen=1)
        assert "merged" in {s[0] for s in b.status.values()}
        assert a.exist > 1.0
        if on:
            assert b.exist < EXIST_REJECT
        else:
            assert b.exist == 0.0


def test_merged_evidence_is_on_by_default():
    assert TargetPlanes.Config().merged_evidence is True
