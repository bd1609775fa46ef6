"""target_planes: the two-hypothesis look-ahead (Config ``lookahead``, issue 12's twentieth session).

``JointTracker.explain_camera`` probes one track: besides the best explanation of a camera's
windows it reports the cheapest one in which that track holds another window (or none), as
the extra cost and that window, and it can be forced to give the track a window. The frame
loop (``TargetPlanes.run``) follows both explanations for ``identity_lag_s`` when they are
within 99:1 and keeps the second when its windows are explained 99:1 likelier; its state is
forked and taken over by ``_RunState``. Windows are the estimator's person model projected by the test
cameras (``tests.test_target_planes_joint._box``).
"""
from __future__ import annotations

import numpy as np

from trackroom.estimators.target_planes import TargetPlanes, _RunState
from trackroom.estimators.tp_frames import CameraBoxes
from trackroom.estimators.tp_joint import C_CLUTTER, JointTrack
from tests.test_target_planes import four_cameras
from tests.test_target_planes_joint import _box, _tracker
from tests.test_target_planes_normalised import _pair


def _two_windows(c, xys):
    """Camera c's windows of standing cylinders at ``xys`` (one per person)."""
    rows = [_box(c, xy) for xy in xys]
    return CameraBoxes(np.array([1 + k for k in range(len(rows))], object), np.concatenate([b.u for b in rows]),
                       np.vstack([b.win for b in rows]), np.vstack([b.flow for b in rows]))


def test_the_probe_names_the_second_explanation_and_forcing_it_costs_exactly_that():
    cams = four_cameras()
    cfg, jt = _tracker(cams)
    for off in (0.0, 0.15, 0.3):
        for c in cams:
            a, b = _pair(off)
            plain, _ = jt.explain_camera(c.name, [a, b], _box(c, [3.0, 3.0]))
            best_cost = jt.cost
            expl, _ = jt.explain_camera(c.name, [a, b], _box(c, [3.0, 3.0]), probe=0)
            assert expl == plain and jt.cost == best_cost  # probing leaves the best explanation as it was
            gap, j_alt = jt.alternative
            held = next((j for j, mem in expl.items() if 0 in mem), None)
            assert gap >= 0.0 and j_alt != held
            forced, _ = jt.explain_camera(c.name, [a, b], _box(c, [3.0, 3.0]), force=(0, j_alt))
            assert next((j for j, mem in forced.items() if 0 in mem), None) == j_alt
            assert abs((jt.cost - best_cost) - gap) < 1e-9


def test_the_cost_counts_clutter_and_misses():
    """One track well located on a window and a second window far from every track: the camera's
    cost is the track's explanation plus one clutter window; without windows, the track's miss."""
    cams = four_cameras()
    cfg, jt = _tracker(cams)
    for c in cams:
        a, _ = _pair(0.0)
        boxes = _two_windows(c, [[3.0, 3.0], [6.5, 1.0]])
        expl, projs = jt.explain_camera(c.name, [a], boxes)
        j = next(j for j, mem in expl.items() if mem == (0,))
        expected = jt.explain_cost(c.name, [projs[0]], boxes, j) + jt.walk_cost(a.mu) + C_CLUTTER * (len(boxes) - 1)
        assert abs(jt.cost - expected) < 1e-9
        jt.explain_camera(c.name, [a], CameraBoxes.empty())
        assert abs(jt.cost - jt.miss_cost(projs[0])) < 1e-9


def test_a_fork_is_independent_and_take_continues_with_its_rows():
    tracks = [JointTrack(0, np.r_[1.0, 2.0, 0.5, 0.0], np.eye(4), confirmed=True)]
    st = _RunState(tracks, 0, 1, None, 0.0, cost=3.0)
    st.rows += [("before",)]
    fork = st.fork()
    fork.tracks[0].s[0] = 9.0
    assert st.tracks[0].s[0] == 1.0  # the fork's tracks are copies
    st.rows += [("a",)]
    fork.rows += [("b",)]
    fork.cost = 2.0
    fork.next_id = 5
    st.take(fork)
    assert st.rows == [("before",), ("b",)] and st.cost == 2.0 and st.next_id == 5 and st.tracks[0].s[0] == 9.0


def test_the_look_ahead_is_off_by_default_and_repeatable_on():
    """A short analytic occlusion_lab recording with the target clicked: off, no look-ahead runs
    and the output is the tracker's; on, look-aheads run and the same recording gives the same
    output twice (forks are copies: nothing leaks between the hypotheses)."""
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    rec = simulate(load_scene("occlusion_lab"), seed=3, duration=6.0)
    truth = rec.truth.people
    first = truth[(truth.person_id == "target")].iloc[0]
    xy = [float(first.x), float(first.y)]
    off = TargetPlanes(initial_xy=xy).run(rec.observations, rec.calibration)
    assert off.lookaheads.empty
    on = [TargetPlanes(initial_xy=xy, lookahead=True).run(rec.observations, rec.calibration) for _ in range(2)]
    assert len(on[0].lookaheads) > 0
    assert on[0].tracks.equals(on[1].tracks) and on[0].lookaheads.equals(on[1].lookaheads)
    assert np.array_equal(on[0].tracks["t"].to_numpy(), off.tracks["t"].to_numpy())
