"""target_planes: an unconfirmed track explained only as a share of a merged window
(``merged_keep``, off by default; branch tp12h).

Rendered development seed 137: the look-alike walks 0.5 m beside the target along the north
wall; each time two cameras see it free a track starts at the crossing, and the next frame its
window merges with the target's. Unconfirmed and without a window of its own it was dropped
(``JointTracker.prune``), and the target's track took the merged windows alone and drifted onto
the look-alike. With ``merged_keep`` such a track is kept while merged (not confirmed by it: a
merged share is not a hit); the existence test still decides whether it is a person.
Hand-made track states (the prune decision alone).
"""
from __future__ import annotations

import numpy as np

from trackroom.estimators.tp_joint import JointTrack
from tests.test_target_planes import four_cameras
from tests.test_target_planes_joint import _tracker


def _merged_newborn():
    # seen last frame (a share of a merged window), no window of its own, not yet confirmed
    return JointTrack(5, np.array([3.0, 2.5, 0.6, 0.0]), np.diag([0.04, 0.04, 0.1, 0.1]), hits=1, confirmed=False, seen=True, n_used=0)


def _inside(xy):
    return np.ones(len(np.atleast_2d(xy)), bool)


def test_an_unconfirmed_track_in_a_merged_window_is_kept_with_merged_keep():
    _, jt = _tracker(four_cameras(), merged_keep=True)
    tr = _merged_newborn()
    assert jt.prune([tr], None, _inside) == [tr]
    assert not tr.confirmed


def test_without_merged_keep_it_is_dropped_and_unseen_it_is_dropped_anyway():
    cfg, jt = _tracker(four_cameras())
    assert cfg.merged_keep is False
    assert jt.prune([_merged_newborn()], None, _inside) == []
    _, jt = _tracker(four_cameras(), merged_keep=True)
    tr = _merged_newborn()
    tr.seen = False
    assert jt.prune([tr], None, _inside) == []
