"""target_planes: a pair's post velocities from the tracks' displacements over the identity lag
(Config ``post_path``, ``tp_identity.IdentityLag.post_state``; issue 12's fifty-eighth session).

After an encounter the filter's velocity of a track lags the person it is on: in merged frames no
flow updates it, so it still carries what it had before (the other person's, when the tracks
swapped) or what little the first windows after it gave. The decision at td = t1 + lag then reads
that velocity as the person's. With ``post_path`` it reads instead the track's displacement from
t1 to td, over td - t1: the lag's positions, which the windows' planes hold, smoothed.
"""
from __future__ import annotations

import numpy as np

from trackroom.estimators.tp_identity import EXCHANGE_LOG_ODDS, IdentityLag
from trackroom.estimators.tp_joint import JointTrack
from tests.test_target_planes_identity import TIMES, head_on

S = np.diag([0.05**2, 0.05**2, 0.25**2, 0.25**2])  # 5 cm, 0.25 m/s: a track's spread in the room


def _decide(paths, post_path: bool, swap_at: float = 2.05):
    """Two confirmed tracks on ``paths`` (name -> t -> state), track 0 on "A" until ``swap_at`` and
    on "B" after (the tracker's swap); the pair decision's log-odds of an exchange."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, decide_accel=0.35, post_path=post_path)
    for t in TIMES:
        on = ("A", "B") if t < swap_at else ("B", "A")
        idl.update(float(t), [JointTrack(k, np.array(paths[n](t), float), S.copy(), confirmed=True, seen=True)
                              for k, n in enumerate(on)])
    (td, a, b, llr), = idl.log
    return llr


def _carried(paths, tau: float):
    """``paths`` whose velocities after the swap are carried over from the other person's, fading
    with time constant tau (s): a filter whose merged frames gave it no flow."""
    def one(f, g):
        def p(t):
            s = np.array(f(t), float)
            if t >= 2.05:
                w = np.exp(-(t - 2.05) / tau)
                s[2:] = w * np.array(g(t), float)[2:] + (1.0 - w) * s[2:]
            return s
        return p
    return {"A": one(paths["A"], paths["B"]), "B": one(paths["B"], paths["A"])}


def test_post_state_is_the_position_and_the_displacement_over_the_lag():
    """At td the post state is the track's position and (x(td) - x(t1)) / (td - t1), with the
    covariance of two independent positions and their shared end; without a position at t1
    (or with the option off) the filter's state."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, post_path=True)
    C = np.diag([0.04**2, 0.03**2])
    for k, t in enumerate(np.round(np.arange(0.0, 1.01, 0.1), 6)):
        tr = JointTrack(0, np.array([1.0 + 0.8 * t, 2.0, 0.1, 0.0]), np.diag([0.04**2, 0.03**2, 0.2**2, 0.2**2]), confirmed=True)
        idl.update(float(t), [tr])
    s, P = idl.post_state(tr, 0.2, 1.0)
    np.testing.assert_allclose(s, [1.8, 2.0, 0.8, 0.0], atol=1e-12)
    np.testing.assert_allclose(P[:2, :2], C)
    np.testing.assert_allclose(P[:2, 2:], C / 0.8)
    np.testing.assert_allclose(P[2:, 2:], 2.0 * C / 0.8**2)
    s, P = idl.post_state(tr, 0.25, 1.0)  # no frame at t1
    assert s is tr.s and P is tr.S
    idl.post_path = False
    s, P = idl.post_state(tr, 0.2, 1.0)
    assert s is tr.s and P is tr.S


def test_the_decision_no_longer_reads_the_filters_lagging_velocity():
    """Head-on look-alikes at 0.6 m/s whose tracks swap: with the filter's velocities, the more
    of the other person's velocity the tracks carry after the encounter the weaker the exchange
    (5.6 -> 5.0 nats); with ``post_path`` the log-odds are the same however long the carried
    velocity lasts (5.9), and the exchange is made."""
    paths = head_on(0.6)
    plain = [_decide(_carried(paths, tau), False) for tau in (0.01, 1.0, 2.0)]
    post = [_decide(_carried(paths, tau), True) for tau in (0.01, 1.0, 2.0)]
    assert plain[0] > plain[1] > plain[2] and plain[0] - plain[2] > 0.5
    np.testing.assert_allclose(post, post[0], atol=1e-9)
    assert min(post) > EXCHANGE_LOG_ODDS


def test_tracks_that_stay_on_their_people_keep_their_identities_either_way():
    """No swap: both forms keep the identities (log-odds -5.6 and -5.9)."""
    paths = head_on(0.6)
    for post_path in (False, True):
        assert _decide(paths, post_path, swap_at=99.0) < -EXCHANGE_LOG_ODDS
