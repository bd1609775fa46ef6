"""target_planes' fixed-lag identity decision (``tp_identity``) on hand-made track states.

The tracks below stand for what the joint tracker hands the decision each frame (10 fps):
two look-alikes pass each other and the tracks that follow them come out of the encounter on
each other's person (a greedy assignment's swap), or stay on their own.
"""
from __future__ import annotations

import numpy as np
import pytest
import pandas as pd

from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_identity import EXCHANGE_LOG_ODDS, IdentityLag
from trackroom.estimators.tp_joint import EXIST_REJECT, JointTrack
from trackroom.recording import Observations
from tests.test_target_planes import calib, right_angle_pair

S0 = np.diag([0.05**2, 0.05**2, 0.1**2, 0.1**2])  # a well-tracked person: 5 cm, 0.1 m/s
TIMES = np.round(np.arange(0.0, 5.01, 0.1), 6)


def merge(a: JointTrack, b: JointTrack) -> None:
    """Tracks a and b share a merged window in one camera this frame."""
    a.status, b.status = {"c": ("merged", str(b.tid), None)}, {"c": ("merged", str(a.tid), None)}


def run(paths, swap_at, lag_s=1.0, output_lag_s=None, times=TIMES, merged=None, **options):
    """Feed ``IdentityLag`` two confirmed tracks following ``paths`` (name -> function t ->
    (x, y, vx, vy)): track 0 on "A" (the target) and track 1 on "B" until ``swap_at``, on each
    other's person after it, at frame ``times``; ``merged`` (t0, t1): merged in one camera in
    the frames between (``merge``). ``options``: further ``IdentityLag`` fields. Returns the
    decision and the identity of each frame's rows."""
    idl = IdentityLag(lag_s, accel_sigma=1.0, radius=0.2, watch=0, output_lag_s=output_lag_s, **options)
    rows = []
    for t in times:
        on = ("A", "B") if t < swap_at else ("B", "A")
        trs = [JointTrack(k, np.array(paths[n](t), float), S0.copy(), confirmed=True, seen=True) for k, n in enumerate(on)]
        if merged is not None and merged[0] - 1e-9 <= t <= merged[1] + 1e-9:
            merge(trs[0], trs[1])
        idl.update(float(t), trs)
        rows += [(t, k) for k in (0, 1)]
    t, tid = np.array(rows).T
    return idl, t, tid.astype(int), idl.relabel(t, tid.astype(int))


def head_on(speed=1.5):
    """A walks east along y = 3.0, B west along y = 3.4 (0.4 m apart), passing at t = 2 s, x = 3 m."""
    return {"A": lambda t: (3.0 + speed * (t - 2.0), 3.0, speed, 0.0), "B": lambda t: (3.0 - speed * (t - 2.0), 3.4, -speed, 0.0)}


def test_head_on_look_alikes_swapped_by_the_tracker_get_their_identities_back_within_the_lag():
    """The tracks swap at the encounter (the greedy outcome: track 0, the target's, leaves on B).
    The pair is ambiguous while nearer than 4 radius = 0.8 m (|t - 2| < 0.23 s at 3 m/s closing:
    frames 1.8-2.2), apart from t1 = 2.3; at td = 3.3 s, a second later, the exchange wins by far
    (opposite velocities) and holds from t1 on, not before."""
    idl, t, tid, ident = run(head_on(), swap_at=2.05)
    (td, a, b, llr), = idl.log
    assert abs(td - 3.3) < 1e-6 and {a, b} == {0, 1}
    assert llr > EXCHANGE_LOG_ODDS
    # after the decision the target's identity is carried by track 1 (on A)
    assert idl.holder(0) == 1
    target_rows = ident == 0
    assert set(tid[target_rows & (t >= 2.3 - 1e-9)]) == {1}
    assert set(tid[target_rows & (t < 2.3 - 1e-9)]) == {0}  # never further back than the lag
    # greedy (the identities as tracked): the target's identity ends on B
    assert set(tid[(tid == 0) & (t > 2.05)]) == {0}


def test_an_output_lag_longer_than_the_decision_reaches_back_to_the_pairs_nearest_approach():
    """The same swap with the output 2 s behind (``output_lag_s``): the exchange, decided at 3.3 s
    as before, holds from the frame the two tracks were nearest (2.0 s, 0.4 m apart, where they
    crossed), not from t1 = 2.3 s: the target's rows 2.1-2.2 s, on B before, follow A."""
    idl, t, tid, ident = run(head_on(), swap_at=2.05, output_lag_s=2.0)
    (d,) = idl.decisions
    assert abs(d["t1"] - 2.3) < 1e-6 and abs(d["t_from"] - 2.0) < 1e-6
    target_rows = ident == 0
    assert set(tid[target_rows & (t >= 2.0 - 1e-9)]) == {1}
    assert set(tid[target_rows & (t < 2.0 - 1e-9)]) == {0}
    # kept pairs are unchanged by the longer output lag
    idl, t, tid, ident = run(head_on(), swap_at=np.inf, output_lag_s=2.0)
    assert (ident == tid).all()


def test_the_reach_back_is_bounded_by_the_output_lag():
    """A 1.2 s output lag reaches 0.2 s before t1 (to 2.1 s), short of the nearest approach."""
    idl, t, tid, ident = run(head_on(), swap_at=2.05, output_lag_s=1.2)
    (d,) = idl.decisions
    assert abs(d["t_from"] - 2.1) < 1e-6


def test_tracks_that_stay_on_their_people_keep_their_identities():
    idl, t, tid, ident = run(head_on(), swap_at=np.inf)
    (_, _, _, llr), = idl.log
    assert llr < -EXCHANGE_LOG_ODDS  # strong evidence for keeping them
    assert (ident == tid).all()


def test_side_by_side_at_the_same_speed_gives_no_evidence_and_identities_stay_as_tracked():
    """Two look-alikes walking east side by side (0.5 m apart, the same 1 m/s) for 3 s, then
    parting at 30 degrees each: positions and velocities after the encounter say nothing about
    who was who before it under a walker model of 1 m/s^2/sqrt(Hz) (a swap is not undone: the
    decision's limit, docs/target_planes.md)."""
    def walker(y0, sign):
        def f(t):
            if t < 3.0:
                return (1.0 + t, y0, 1.0, 0.0)
            c, s = np.cos(np.radians(30)), sign * np.sin(np.radians(30))
            return (4.0 + c * (t - 3.0), y0 + s * (t - 3.0), c, s)
        return f

    idl, t, tid, ident = run({"A": walker(3.0, -1), "B": walker(3.5, +1)}, swap_at=2.5)
    (_, _, _, llr), = idl.log
    assert abs(llr) < EXCHANGE_LOG_ODDS
    assert (ident == tid).all()


def test_the_estimator_with_and_without_the_lag_agrees_where_the_tracker_holds_identities():
    """Hand-made windows of two walkers crossing in one view (as in test_target_planes_joint):
    the tracker keeps them apart, and the decision leaves that as it is. The fixed-lag output
    also reports each track from its birth when it was confirmed within the lag (the greedy one
    from its confirmation, ``confirm_frames`` later)."""
    from tests.test_target_planes_joint import boxes_table, line_path

    south, west = right_angle_pair()
    times = np.round(np.arange(0, 6.0, 0.1), 6)
    paths = {"A": line_path([1.0, 1.0], [5.0, 2.2], times), "B": line_path([5.0, 5.2], [1.0, 3.2], times)}
    boxes = boxes_table([south, west], paths, times, merged_in=("south",))
    obs, cal = Observations({"boxes": boxes}, 6.0), calib([south, west])
    with_lag = TargetPlanes(multi_person=True).run(obs, cal).tracks
    greedy = TargetPlanes(multi_person=True, identity_lag_s=0.0).run(obs, cal).tracks
    assert with_lag.track_id.nunique() == greedy.track_id.nunique() == 2
    both = greedy.merge(with_lag, on=["t", "track_id"], how="left", suffixes=("", "_lag"))
    assert np.allclose(both[["x", "y"]].to_numpy(), both[["x_lag", "y_lag"]].to_numpy())  # same ids, same states
    # the fixed-lag output adds only each track's frames before its confirmation (within the lag)
    extra = with_lag.merge(greedy[["t", "track_id"]], on=["t", "track_id"], how="left", indicator=True)
    extra = extra[extra["_merge"] == "left_only"]
    first = greedy.groupby("track_id")["t"].min()
    assert len(extra) and (extra["t"].to_numpy() < extra["track_id"].map(first).to_numpy()).all()
    assert (extra["t"].to_numpy() >= extra["track_id"].map(first).to_numpy() - 1.0 - 1e-9).all()


def test_a_track_is_reported_back_to_a_lag_before_its_confirmation_along_its_velocity():
    """One walker, seen by south from t = 0 and by west from t = 0.5 s only (hand-made windows):
    no track can start before two cameras' planes cross (t = 0.5), and the greedy output starts
    at its confirmation, ``confirm_frames`` later. The fixed-lag output starts 1 s before the
    confirmation: from the birth, and before it the birth's position moved back along the
    velocity at confirmation ("extrapolated"); those frames lie on the walker."""
    from tests.test_target_planes_joint import boxes_table, line_path

    south, west = right_angle_pair()
    times = np.round(np.arange(0, 3.0, 0.1), 6)
    paths = {"C": line_path([2.0, 2.0], [4.5, 3.0], times)}
    boxes = boxes_table([south, west], paths, times)
    boxes = boxes[(boxes.camera != "west") | (boxes.t >= 0.5 - 1e-9)].reset_index(drop=True)
    obs, cal = Observations({"boxes": boxes}, 3.0), calib([south, west])
    lag = TargetPlanes(multi_person=True).run(obs, cal).tracks
    greedy = TargetPlanes(multi_person=True, identity_lag_s=0.0).run(obs, cal).tracks
    assert lag.track_id.nunique() == greedy.track_id.nunique() == 1
    t0_greedy = greedy.t.min()
    assert t0_greedy >= 0.9 - 1e-9  # birth at 0.5 at the earliest, confirmed 4 frames later
    assert abs(lag.t.min() - max(t0_greedy - 1.0, 0.0)) < 1e-6
    early = lag[lag.t < t0_greedy - 1e-9]
    assert (early["mode"] == "extrapolated").sum() >= 3  # the frames before the birth
    k = np.searchsorted(times, early.t.to_numpy() - 1e-9)
    err = np.hypot(early.x.to_numpy() - paths["C"][k, 0], early.y.to_numpy() - paths["C"][k, 1])
    assert err.max() < 0.15


def relink_run(reborn_at):
    """Multi-person ``IdentityLag`` with found-again links (floor 8 m x 6 m): person A walks east
    at 1 m/s along y = 3; its track 0 ends after t = 2.0 s (the existence test rejected it), and a
    new track 2 is confirmed at t = 2.5 s at ``reborn_at`` (moving east at 1 m/s). Track 1, person
    B, stands at (1, 1) throughout. Returns the decision object and each row's identity."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=48.0, sigma_v=1.5, hold_s=6.0)
    rows = []
    for t in TIMES:
        trs = [JointTrack(1, np.array([1.0, 1.0, 0.0, 0.0]), S0.copy(), confirmed=True, seen=True)]
        if t <= 2.0 + 1e-9:
            trs.append(JointTrack(0, np.array([1.0 + t, 3.0, 1.0, 0.0]), S0.copy(), confirmed=True, seen=True))
        if t >= 2.3 - 1e-9:
            x0, y0 = reborn_at
            trs.append(JointTrack(2, np.array([x0 + (t - 2.5), y0, 1.0, 0.0]), S0.copy(), confirmed=t >= 2.5 - 1e-9, seen=True))
        idl.update(float(t), trs)
        rows += [(t, tr.tid) for tr in trs]
    t, tid = np.array(rows).T
    return idl, t, tid.astype(int), idl.relabel(t, tid.astype(int))


def test_a_track_confirmed_where_an_ended_one_walked_on_to_takes_its_identity():
    """A at 1 m/s reaches x = 3.5 at t = 2.5 s: a track confirmed there continues it (its
    log-likelihood ratio against someone new is large), so from A's last frame on it is reported
    as identity 0; its frames while A's track was still reported (none here) would keep its own."""
    idl, t, tid, ident = relink_run((3.5, 3.0))
    (_, new, ended, llr), = idl.links
    assert (new, ended) == (2, 0) and llr > 5.0
    assert set(ident[tid == 2]) == {0}
    assert set(ident[tid == 1]) == {1}
    # never two rows of one identity in a frame
    assert not pd.DataFrame({"t": t, "i": ident}).duplicated().any()


def test_a_track_confirmed_far_from_where_an_ended_one_could_be_is_someone_new():
    """4 m off A's predicted position half a second after it ended: someone new, own identity."""
    idl, t, tid, ident = relink_run((3.5, -1.0))
    assert idl.links == []
    assert set(ident[tid == 2]) == {2}


def test_a_walker_who_stopped_where_its_track_ended_and_walks_off_another_way_keeps_its_identity():
    """A walks east until t = 1 s, then stands at (2, 3) (no windows: its track ends at 1.0 s) and
    sets off north at 1 m/s at t = 3.5 s; a new track is born then and confirmed half a second
    later. The constant-velocity prediction (x = 5 m) is 3 m off; the walker stopped where last
    seen (p = 1 - exp(-3 / 8), the walking mode's switch) and walked off at the new track's
    velocity explains the new track. Someone 3 m north of that spot walking east did not come from
    it: someone new."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=72.0, sigma_v=1.5, hold_s=6.0, walk_s=8.0)
    for t in TIMES:
        trs = []
        if t <= 1.0 + 1e-9:
            trs.append(JointTrack(0, np.array([1.0 + t, 3.0, 1.0, 0.0]), S0.copy(), confirmed=True, seen=True))
        if t >= 3.5 - 1e-9:
            trs.append(JointTrack(2, np.array([2.0, 3.0 + (t - 3.5), 0.0, 1.0]), S0.copy(), confirmed=t >= 4.0 - 1e-9, seen=True))
        idl.update(float(t), trs)
    (_, new, ended, llr), = idl.links
    assert (new, ended) == (2, 0) and llr > 1.0
    # a new track 3 m north of where A stopped, walking east: someone new
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=72.0, sigma_v=1.5, hold_s=6.0, walk_s=8.0)
    for t in TIMES:
        trs = [JointTrack(0, np.array([1.0 + t, 3.0, 1.0, 0.0]), S0.copy(), confirmed=True, seen=True)] if t <= 1.0 + 1e-9 else []
        if t >= 3.5 - 1e-9:
            trs.append(JointTrack(2, np.array([2.0 + (t - 3.5), 6.0, 1.0, 0.0]), S0.copy(), confirmed=t >= 4.0 - 1e-9, seen=True))
        idl.update(float(t), trs)
    assert idl.links == [] and idl.identity(2) == 2


def successor_run(born_at_y):
    """Person A walks east at 1 m/s along y = 3. Its track 0 follows until t = 1.0 s and then falls
    behind (it stalls at x = 2, as a track left behind by its windows does); a new track 2 is born
    at t = 1.5 s at (x_A, ``born_at_y``), moving east at 1 m/s, and confirmed at 2.0 s; track 0
    ends at 2.5 s. Track 1 (B) stands at (1, 1)."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=72.0, sigma_v=1.5, hold_s=6.0)
    wide = np.diag([0.3**2, 0.3**2, 0.5**2, 0.5**2])  # a new track's spreads
    rows = []
    for t in TIMES:
        trs = [JointTrack(1, np.array([1.0, 1.0, 0.0, 0.0]), S0.copy(), confirmed=True, seen=True)]
        if t <= 2.5 + 1e-9:
            x = 1.0 + min(t, 1.0)
            trs.append(JointTrack(0, np.array([x, 3.0, 1.0 if t < 1.0 else 0.0, 0.0]), S0.copy(), confirmed=True, seen=True))
        if t >= 1.5 - 1e-9:
            trs.append(JointTrack(2, np.array([1.0 + t, born_at_y, 1.0, 0.0]), (S0 if t >= 2.0 - 1e-9 else wide).copy(),
                                  confirmed=t >= 2.0 - 1e-9, seen=True))
        idl.update(float(t), trs)
        rows += [(t, tr.tid) for tr in trs]
    t, tid = np.array(rows).T
    return idl, t, tid.astype(int), idl.relabel(t, tid.astype(int))


def test_a_track_born_on_the_person_an_older_track_fell_behind_takes_its_identity_when_that_one_ends():
    """At track 2's birth (t = 1.5 s, x = 2.5) the stalled track 0 is 0.5 m behind it on A's
    line: the successor continues that person, so from track 0's end it carries identity 0, and
    no frame reports an identity twice."""
    idl, t, tid, ident = successor_run(3.0)
    assert [(new, ended) for _, new, ended, _ in idl.links] == [(2, 0)]
    assert set(ident[(tid == 2) & (t > 2.5 + 1e-6)]) == {0}
    assert set(ident[(tid == 2) & (t <= 2.5)]) == {2}
    assert not pd.DataFrame({"t": t, "i": ident}).duplicated().any()


def test_a_track_born_on_someone_else_does_not_take_the_identity_of_a_track_that_ends():
    """The same, but track 2 is born 3 m away (y = 6): someone else, its own identity."""
    idl, t, tid, ident = successor_run(6.0)
    assert idl.links == []
    assert set(ident[tid == 2]) == {2}


def test_an_identity_still_carried_is_not_given_to_a_new_track():
    """Track 1 (B) is alive: its identity is never handed out, even to a track confirmed right on
    it (two tracks on one person are the tracker's to merge, not a found-again person)."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=48.0)
    for t in TIMES[:10]:
        trs = [JointTrack(1, np.array([1.0, 1.0, 0.0, 0.0]), S0.copy(), confirmed=True, seen=True),
               JointTrack(2, np.array([1.0, 1.05, 0.0, 0.0]), S0.copy(), confirmed=t >= 0.5, seen=True)]
        idl.update(float(t), trs)
    assert idl.links == [] and idl.identity(2) == 2


def watched_successor_run(born_at_y, rejected_mu=0.0, successor_reject=EXIST_REJECT, merged=False, seen_at_birth=False,
                          successor_lagged=False, successor_log_odds=EXCHANGE_LOG_ODDS, successor_recent_s=None,
                          early_reject=False, found_again=False, ended_before=False):
    """Single-target mode (``watch`` 0). Person A walks east at 1 m/s along y = 3; the target's
    track 0 follows until t = 1.3 s and then stalls at x = 2.3 (its windows walked on without it);
    a new track 2 is born at a two-camera crossing at t = 1.5 s at (x_A, ``born_at_y``), moving
    east at 1 m/s, and confirmed at 2.0 s. From t = 2.5 s track 0's existence log-odds are below
    the tracker's rejection level (the target's track is never dropped), likelier standing with
    ``rejected_mu`` >= 1/2, and with ``merged`` sharing a merged window with track 2 in one
    camera. Track 1 (B) stands at (1, 1). ``seen_at_birth``: track 0 has a window of its own in
    two cameras in track 2's first frame. ``early_reject``: track 0 is also rejected at 0.5-0.6 s
    (walking on its person, before track 2 exists), and accepted again. ``ended_before``: a
    confirmed track 5 walks where track 2 is then born (east at 1 m/s on y = ``born_at_y``) until
    1.4 s and ends; ``found_again``: ``successor_found_again``."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, area=72.0, sigma_v=1.5, hold_s=6.0,
                      successor_reject=successor_reject, successor_lagged=successor_lagged,
                      successor_log_odds=successor_log_odds, successor_recent_s=successor_recent_s,
                      successor_found_again=found_again)
    wide = np.diag([0.3**2, 0.3**2, 0.5**2, 0.5**2])  # a new track's spreads
    rows = []
    for t in TIMES:
        x = 1.0 + min(t, 1.3)
        late = t >= 2.5 - 1e-9 or (early_reject and 0.5 - 1e-9 <= t <= 0.6 + 1e-9)
        trs = [JointTrack(0, np.array([x, 3.0, 1.0 if t < 1.3 else 0.0, 0.0]), S0.copy(), confirmed=True, seen=True,
                          exist=EXIST_REJECT - 1.0 if late else 4.6, mu=rejected_mu if late else 0.0,
                          status={"north": ("merged", "2", None)} if (late and merged) else
                          {"north": ("tracking", "", None), "east": ("tracking", "", None)} if (seen_at_birth and abs(t - 1.5) < 1e-9) else {}),
               JointTrack(1, np.array([1.0, 1.0, 0.0, 0.0]), S0.copy(), confirmed=True, seen=True)]
        if ended_before and t <= 1.4 + 1e-9:
            trs.append(JointTrack(5, np.array([1.0 + t, born_at_y, 1.0, 0.0]), S0.copy(), confirmed=True, seen=True))
        if t >= 1.5 - 1e-9:
            s2 = np.array([1.0 + t, born_at_y, 1.0, 0.0])
            trs.append(JointTrack(2, s2, (S0 if t >= 2.0 - 1e-9 else wide).copy(), confirmed=t >= 2.0 - 1e-9, seen=True,
                                  born=(1.5, np.array([2.5, born_at_y, 1.0, 0.0]), wide.copy())))
        idl.update(float(t), trs)
        rows += [(t, tr.tid) for tr in trs]
    t, tid = np.array(rows).T
    return idl, t, tid.astype(int), idl.relabel(t, tid.astype(int))


def test_a_rejected_target_track_gives_the_identity_to_the_track_born_on_its_person_while_it_lagged():
    """At t = 2.5 s the stalled target track, likelier walking, is rejected: track 2, born 0.2 m
    ahead of it on A's line, is its successor and carries the target's identity from its birth
    on (within the output lag); the stalled track carries track 2's; no frame reports the target
    twice."""
    idl, t, tid, ident = watched_successor_run(3.0)
    made = [d for d in idl.decisions if d["kind"] == "successor"]
    assert made and made[-1]["b"] == 2 and made[-1]["log_odds"] > EXCHANGE_LOG_ODDS
    assert idl.holder(0) == 2
    assert set(ident[(tid == 2) & (t >= 1.5 - 1e-9)]) == {0}
    assert set(ident[(tid == 0) & (t >= 1.5 - 1e-9)]) == {2}
    assert not pd.DataFrame({"t": t, "i": ident}).duplicated().any()


@pytest.mark.parametrize("case", ["born on someone else", "standing", "merged with it", "off"])
def test_a_rejected_target_track_keeps_the_identity_without_a_successor_when_standing_merged_or_off(case):
    """Track 2 born 3 m away (someone else); the rejected track likelier standing (a standing
    target makes no window: its track is rejected and is still the target's); the rejected track
    sharing a merged window with track 2 (the tracker holds both people there, and a merge's
    frames can reject a track on its person: a look-alike born beside the target walking past it
    as it stops, seen analytic 1875 draw 1 and 1817); the rule off: the identity stays on track 0."""
    kw = {"born on someone else": dict(born_at_y=6.0), "standing": dict(born_at_y=3.0, rejected_mu=0.9),
          "merged with it": dict(born_at_y=3.0, merged=True), "off": dict(born_at_y=3.0, successor_reject=None)}[case]
    idl, t, tid, ident = watched_successor_run(**kw)
    assert idl.holder(0) == 0
    assert set(ident[tid == 0]) == {0} and set(ident[tid == 2]) == {2}


@pytest.mark.parametrize("seen_at_birth, lagged, successor", [(False, True, True), (True, True, False), (True, False, True)])
def test_a_successor_must_be_born_while_the_target_track_lagged(seen_at_birth, lagged, successor):
    """``successor_lagged``: track 2, born beside the target's track while that one had a window
    of its own in two cameras (it was on someone), is someone else, not its successor (analytic
    2472: the look-alike's track, born 0.43 m behind the target and walking with it, took the
    identity 8 s later when the target's track was rejected). Born while the target's track had
    none, it is still the successor; off, the birth's views are not read."""
    idl, t, tid, ident = watched_successor_run(3.0, seen_at_birth=seen_at_birth, successor_lagged=lagged)
    assert (idl.holder(0) == 2) == successor
    assert set(ident[(tid == 2) & (t >= 1.5 - 1e-9)]) == ({0} if successor else {2})


@pytest.mark.parametrize("recent_s, early_reject, successor", [(None, False, True), (1.2, False, True), (0.5, False, False),
                                                             (0.5, True, False)])
def test_a_successor_must_be_born_no_earlier_than_the_existence_test_takes_to_reject(recent_s, early_reject, successor):
    """``successor_recent_s``: track 2 is born at 1.5 s, the target's track is rejected from
    2.5 s. Born within 1.2 s of the rejection's first frame it may be the successor; with 0.5 s
    it was born before the target's track can have lost its person (the existence test would
    have rejected it sooner), and is someone else. The window counts back from the first frame
    of the current rejection: an earlier one, ended (``early_reject``: 0.5-0.6 s, which would
    admit every track born since), does not count."""
    idl, t, tid, ident = watched_successor_run(3.0, successor_recent_s=recent_s, early_reject=early_reject)
    assert (idl.holder(0) == 2) == successor
    assert set(ident[(tid == 2) & (t >= 1.5 - 1e-9)]) == ({0} if successor else {2})


@pytest.mark.parametrize("level, successor", [(EXCHANGE_LOG_ODDS, False), (float(np.log(3 / 2)), True)])
def test_a_successor_between_the_measured_prior_and_the_one_percent_level(level, successor):
    """Track 2 born 0.6 m off the stalled target track's line: its successor log-odds (about 3.2)
    pass Bayes' decision at the measured prior odds (``successor_log_odds``, log(3 / 2)) and not
    the old 1 % level (log 99), which kept the identity on the track left behind."""
    idl, t, tid, ident = watched_successor_run(3.6, successor_lagged=True, successor_log_odds=level)
    made = [d["log_odds"] for d in idl.decisions if d["kind"] == "successor"]
    assert made and float(np.log(3 / 2)) < max(made) < EXCHANGE_LOG_ODDS
    assert (idl.holder(0) == 2) == successor
    assert set(ident[(tid == 2) & (t >= 1.5 - 1e-9)]) == ({0} if successor else {2})


@pytest.mark.parametrize("ended_before, found_again, successor", [(True, True, False), (True, False, True), (False, True, True)])
def test_a_track_born_where_another_ended_is_that_persons_not_the_successor(ended_before, found_again, successor):
    """``successor_found_again``: track 2 is born 0.6 m off the stalled target track's line, where
    a confirmed track 5 walked until 0.1 s before and ended (head-on 2636: the look-alike's
    track, dropped as a duplicate of the target's in the pass-through, and born again). Its
    birth state is likelier track 5's person found again than the target's track's, so it is
    not the successor; scored against someone new alone (off), it is; with no track ended there,
    it still is."""
    idl, t, tid, ident = watched_successor_run(3.6, successor_log_odds=float(np.log(2)), ended_before=ended_before,
                                               found_again=found_again)
    assert (idl.holder(0) == 2) == successor
    assert set(ident[(tid == 2) & (t >= 1.5 - 1e-9)]) == ({0} if successor else {2})


def test_an_ended_tracks_last_seen_position_is_kept_only_until_its_end_is_read():
    """Single-target mode too: track 5 ends at 1.4 s; its last position with a window is read in
    the next frame (``successor_found_again``'s dropped tracks) and then forgotten, so the
    identity bookkeeping holds entries for the living tracks only."""
    idl, t, tid, ident = watched_successor_run(3.6, successor_log_odds=float(np.log(2)), ended_before=True, found_again=True)
    assert 5 in idl.dropped and idl.dropped[5][4][0][0] == pytest.approx(2.4)
    assert set(idl.last_seen) == {0, 1, 2}


def test_the_successor_rule_defaults_to_the_measured_level_among_recent_candidates():
    cfg = TargetPlanes.Config()
    assert cfg.successor_recent and cfg.successor_found_again and not cfg.successor_lagged
    assert cfg.successor_log_odds == pytest.approx(np.log(3))


def run_gone(paths, swap_at, end_at, new_from, new_on, handover=True, gone_confirmed=True, area=48.0, gone_swaps=False,
             born_at=None, **options):
    """As ``run``, but track 1 (on "B", the target's track 0 on "A") ends at ``end_at`` (dropped
    by the tracker, e.g. as a duplicate of track 0) and a new confirmed track 2 follows
    ``new_on`` from ``new_from``; track 0 is on "B" from ``swap_at``, and so is track 1 on "A"
    with ``gone_swaps``. With ``born_at`` track 2 is there from then, unconfirmed, standing
    in the far corner (0.5, 6), until ``new_from``. ``options``: further ``IdentityLag``
    fields. Returns as ``run``."""
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, area=area, sigma_v=1.5, handover=handover, **options)
    rows = []
    for t in TIMES:
        trs = [JointTrack(0, np.array(paths["A" if t < swap_at else "B"](t), float), S0.copy(), confirmed=True, seen=True)]
        if t < end_at - 1e-9:
            on = "A" if gone_swaps and t >= swap_at else "B"
            trs.append(JointTrack(1, np.array(paths[on](t), float), S0.copy(), confirmed=gone_confirmed, seen=True))
        if t >= new_from - 1e-9:
            trs.append(JointTrack(2, np.array(paths[new_on](t), float), S0.copy(), confirmed=True, seen=True))
        elif born_at is not None and t >= born_at - 1e-9:
            trs.append(JointTrack(2, np.array([0.5, 6.0, 0.0, 0.0]), S0.copy(), confirmed=False, seen=True))
        idl.update(float(t), trs)
        rows += [(t, tr.tid) for tr in trs]
    t, tid = np.array(rows).T
    return idl, t, tid.astype(int), idl.relabel(t, tid.astype(int))


def test_a_target_track_left_on_the_look_alike_when_its_track_ends_hands_the_identity_to_the_new_track_on_the_target():
    """Head-on: the target's track leaves the encounter on B (2.05 s), B's own track is dropped
    (2.1 s: nothing left to exchange with), and a new track starts on A (2.3 s). A lag after the
    end (3.1 s) the new track takes the target's identity, from the end on, and the survivor B's."""
    idl, t, tid, ident = run_gone(head_on(), swap_at=2.05, end_at=2.1, new_from=2.3, new_on="A")
    assert idl.holder(0) == 2 and idl.holder(1) == 0
    (h,) = idl.handovers
    assert abs(h["t"] - 3.1) < 1e-6 and h["a"] == 0 and h["b"] == 2 and h["gone"] == 1 and h["log_odds"] > EXCHANGE_LOG_ODDS
    target_rows = ident == 0
    assert set(tid[target_rows & (t >= 2.1 - 1e-9)]) == {2}
    assert set(tid[target_rows & (t < 2.1 - 1e-9)]) == {0}  # never further back than the lag


def crossed_then_rejected(handover_reach=True):
    """Head-on: the tracks swap people where they cross (2.05 s); the look-alike's track 1, now
    on the target A, is rejected 0.45 s later (2.5 s); a new track 2 follows A from 2.7 s. The
    output is 2 s behind. Returns ``run_gone``'s, and each row's person."""
    idl, t, tid, ident = run_gone(head_on(), swap_at=2.05, end_at=2.5, new_from=2.7, new_on="A", gone_swaps=True,
                                  output_lag_s=2.0, handover_reach=handover_reach)
    late = t >= 2.05
    on = np.where(tid == 2, "A", np.where((tid == 0) == late, "B", "A"))
    return idl, t, tid, ident, on


def test_a_hand_over_holds_from_the_crossing_where_the_gone_track_carried_the_target():
    """The hand-over (a lag after the end, 3.5 s) holds from the pair's nearest approach (2.0 s),
    as a pair's exchange does: the survivor takes the gone identity there, the gone track the
    target's until its end, the new track the target's from then on. Every target row after the
    crossing is on A; before it, the target's rows stay on its own track. Without
    ``handover_reach`` the exchange holds from the end: the target's rows 2.05-2.4 s are on B."""
    idl, t, tid, ident, on = crossed_then_rejected()
    (h,) = idl.handovers
    assert h["b"] == 2 and h["log_odds"] > EXCHANGE_LOG_ODDS and idl.holder(0) == 2 and idl.holder(1) == 0
    target = ident == 0
    assert (on[target & (t >= 2.05 - 1e-9)] == "A").all()
    assert set(tid[target & (t >= 2.0 - 1e-9) & (t < 2.5 - 1e-9)]) == {1}
    assert set(tid[target & (t < 2.0 - 1e-9)]) == {0} and (on[target & (t < 2.0 - 1e-9)] == "A").all()
    assert not (target & (t >= 2.5 - 1e-9) & (t < 2.7 - 1e-9)).any()  # no track was on A then
    assert ((ident == 1) == (((tid == 0) & (t >= 2.0 - 1e-9)) | ((tid == 1) & (t < 2.0 - 1e-9)))).all()
    idl, t, tid, ident, on = crossed_then_rejected(handover_reach=False)
    target = ident == 0
    assert (on[target & (t >= 2.05 - 1e-9) & (t < 2.5 - 1e-9)] == "B").all()
    assert set(tid[target & (t < 2.5 - 1e-9)]) == {0}


@pytest.mark.parametrize("since_confirmed", [False, True])
def test_a_hand_over_candidate_is_a_track_confirmed_since_the_encounter_began(since_confirmed):
    """The hand-over above, but the new track was born at 1.0 s, before the encounter's pre
    states (1.7 s), and confirmed only at 2.3 s, on the target (analytic development 158: born
    0.5 s before, confirmed after). With ``since_confirmed`` it is a candidate - the design's
    "each track confirmed since the encounter began" - and takes the target's identity; counted
    from its birth it is not scored and the target's identity stays on the look-alike."""
    idl, t, tid, ident = run_gone(head_on(), swap_at=2.05, end_at=2.1, new_from=2.3, new_on="A", born_at=1.0,
                                  since_confirmed=since_confirmed)
    if since_confirmed:
        (h,) = idl.handovers
        assert h["b"] == 2 and h["log_odds"] > EXCHANGE_LOG_ODDS and idl.holder(0) == 2
    else:
        assert not idl.handovers and idl.holder(0) == 0


def test_a_survivor_on_its_own_person_keeps_its_identity_when_the_other_track_ends():
    idl, t, tid, ident = run_gone(head_on(), swap_at=np.inf, end_at=2.1, new_from=2.3, new_on="B")
    assert idl.holder(0) == 0
    assert idl.handovers and all(h["log_odds"] < 0 for h in idl.handovers)
    assert (ident == tid).all()


def test_a_new_track_on_someone_else_is_not_handed_the_identity():
    """The new track walks far from where either person of the encounter could be: someone new
    (anywhere on the 48 m^2 floor) explains it better than the target does."""
    paths = {**head_on(), "C": lambda t: (0.5, 0.5 + 0.8 * t, 0.0, 0.8)}
    idl, t, tid, ident = run_gone(paths, swap_at=2.05, end_at=2.1, new_from=2.3, new_on="C")
    assert idl.holder(0) == 0
    assert (ident == tid).all()


def test_no_hand_over_after_a_track_never_confirmed_ends_or_with_handover_off():
    idl, t, tid, ident = run_gone(head_on(), swap_at=2.05, end_at=2.1, new_from=2.3, new_on="A", gone_confirmed=False)
    assert idl.holder(0) == 0 and not idl.handovers
    idl, t, tid, ident = run_gone(head_on(), swap_at=2.05, end_at=2.1, new_from=2.3, new_on="A", handover=False)
    assert idl.holder(0) == 0 and (ident == tid).all()
    assert idl.handovers and idl.handovers[0]["log_odds"] > EXCHANGE_LOG_ODDS  # scored, for diagnosis, not exchanged


def test_a_decision_that_closes_another_encounter_of_its_tracks_in_the_same_frame():
    """Two encounters of the target's track decided in one frame: the first exchanges and closes
    the second (scored with the old identities); the frame's loop goes on without it."""
    from trackroom.estimators.tp_identity import Episode

    def state(x, y, vx, vy):
        return np.array([x, y, vx, vy], float)

    now = {0: state(5, 0, 1, 0), 1: state(0, 0, -1, 0), 2: state(0, 5, 0, 1)}
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0)
    # encounter (0, 1): each track's pre state is the other's present one, a second back: exchanged
    # (both came near during the encounter: their pre states are no longer refreshed)
    idl.episodes[(0, 1)] = Episode(0, 1, {0: (state(1, 0, -1, 0), S0, 0.0), 1: (state(4, 0, 1, 0), S0, 0.0)}, t1=0.0, near=True)
    idl.episodes[(0, 2)] = Episode(0, 2, {0: (state(4, 0, 1, 0), S0, 0.0), 2: (state(0, 4, 0, 1), S0, 0.0)}, t1=0.0, near=True)
    idl.update(1.0, [JointTrack(k, now[k], S0.copy(), confirmed=True, seen=True) for k in (0, 1, 2)])
    assert idl.holder(0) == 1 and not idl.episodes


def encounter_run(end_state, new_on, swap_at=2.05):
    """Multi-person ``IdentityLag``: head-on look-alikes (``head_on``), found-again links on (floor 48 m^2, the
    walkers' ``identity_accel`` 0.35): track 0 follows A (the target) until ``swap_at``, then B;
    B's track 1 ends at 2.1 s (dropped as a duplicate of track 0), its states from 1.75 s given by
    ``end_state(t, s)`` (what merged windows leave of them); a new track 2 follows ``new_on`` from
    2.3 s, confirmed at 2.75 s."""
    paths = head_on()
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=48.0, area=48.0, sigma_v=1.5,
                      hold_s=6.0, handover=True, decide_accel=0.35)
    for t in TIMES:
        trs = [JointTrack(0, np.array(paths["A" if t < swap_at else "B"](t), float), S0.copy(), confirmed=True, seen=True)]
        if t < 2.1 - 1e-9:
            s, S = np.array(paths["B"](t), float), S0.copy()
            if t >= 1.75 - 1e-9:
                s, S = end_state(t, s)
            trs.append(JointTrack(1, s, S, confirmed=True, seen=True))
        if t >= 2.3 - 1e-9:
            trs.append(JointTrack(2, np.array(paths[new_on](t), float), S0.copy(), confirmed=t >= 2.75 - 1e-9, seen=True))
        idl.update(float(t), trs)
    return idl


def collapsed(t, s):
    """B's track in merged windows: its velocity gone, its spreads wide."""
    return np.r_[s[:2], 0.0, 0.0], np.diag([0.15**2, 0.15**2, 0.6**2, 0.6**2])


def test_a_track_ended_in_an_encounter_waits_for_the_hand_over_instead_of_being_found_again_alone():
    """A's track (identity 0) leaves the head-on encounter on B and B's track, its velocity
    collapsed by merged windows, is dropped; a new track starts on A. From B's track's last state alone
    (standing at the crossing) the new track looks like B found again (log-odds 2.8 against
    someone new: before this rule it took B's identity at its confirmation, 2.8 s, and A's
    identity stayed on B). The hand-over scores the survivor too, from the pair's states before the
    encounter, and hands A's identity to the new track on A (multi-person mode: found-again
    links are on)."""
    idl = encounter_run(collapsed, "A")
    assert idl.links == []
    (h,) = idl.handovers
    assert h["b"] == 2 and h["log_odds"] > EXCHANGE_LOG_ODDS
    assert idl.identity(2) == 0 and idl.identity(0) == 1


def test_a_hand_over_that_keeps_identities_gives_the_gone_one_to_the_new_track_that_continues_it():
    """A's track stays on A; B's track ends and a new track starts on B: kept, and the
    new track is B found again - the found-again link, scored at its confirmation, waits for the
    hand-over (3.1 s) and is made then; it carries B's identity from the end on."""
    idl = encounter_run(lambda t, s: (s, S0.copy()), "B", swap_at=np.inf)
    (h,) = idl.handovers
    assert h["log_odds"] < 0
    (link,) = idl.links
    assert link[1:3] == (2, 1) and link[3] > 0.0  # found again at its confirmation, made at the hand-over
    assert idl.identity(2) == 1 and idl.identity(0) == 0 and not idl.deferred


def test_a_link_still_waiting_for_its_hand_over_when_the_recording_ends_is_made():
    """The same kept encounter cut at 2.9 s, before the hand-over's lag has passed: the found-again
    link is waiting (``deferred``); at the end of the recording (``finish``) it is made."""
    paths = head_on()
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=None, relink_area=48.0, area=48.0, sigma_v=1.5,
                      hold_s=6.0, handover=True, decide_accel=0.35)
    for t in TIMES[TIMES <= 2.9 + 1e-9]:
        trs = [JointTrack(0, np.array(paths["A"](t), float), S0.copy(), confirmed=True, seen=True)]
        if t < 2.1 - 1e-9:
            trs.append(JointTrack(1, np.array(paths["B"](t), float), S0.copy(), confirmed=True, seen=True))
        if t >= 2.3 - 1e-9:
            trs.append(JointTrack(2, np.array(paths["B"](t), float), S0.copy(), confirmed=t >= 2.75 - 1e-9, seen=True))
        idl.update(float(t), trs)
    assert idl.links == [] and set(idl.deferred) == {1}
    idl.finish(trs)
    assert [(new, ended) for _, new, ended, _ in idl.links] == [(2, 1)] and idl.identity(2) == 1 and not idl.deferred


def test_an_encounter_still_waiting_for_its_decision_when_the_recording_ends_is_decided_then():
    """The head-on swap cut at 2.8 s: the pair separated at t1 = 2.3 s, but the lag (1 s) has not
    passed when the recording ends. ``finish`` decides it with the states there are (0.5 s after
    the separation: opposite velocities already): the exchange is made. Decided 0.5 s after t1,
    within the output lag (1 s) of the pair's nearest approach (2.0 s), it holds from there, by
    the rule every decision follows (``reach``). Without ``finish`` nothing is decided."""
    paths = head_on()
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0)
    rows = []
    for t in TIMES[TIMES <= 2.8 + 1e-9]:
        on = ("A", "B") if t < 2.05 else ("B", "A")
        trs = [JointTrack(k, np.array(paths[n](t), float), S0.copy(), confirmed=True, seen=True) for k, n in enumerate(on)]
        idl.update(float(t), trs)
        rows += [(t, k) for k in (0, 1)]
    assert idl.log == [] and idl.holder(0) == 0
    idl.finish(trs)
    (td, a, b, llr), = idl.log
    assert abs(td - 2.8) < 1e-6 and llr > EXCHANGE_LOG_ODDS and idl.holder(0) == 1
    t, tid = np.array(rows).T
    ident = idl.relabel(t, tid.astype(int))
    assert set(tid[(ident == 0) & (t >= 2.0 - 1e-9)].astype(int)) == {1}
    assert set(tid[(ident == 0) & (t < 2.0 - 1e-9)].astype(int)) == {0}


def left_behind_run(new_path, left_behind=True, stop_at=2.05, born_at=None, behind_at_birth=True):
    """Single-target ``IdentityLag`` (floor 48 m^2, the walkers' ``identity_accel`` 0.35): head-on
    look-alikes (``head_on``). Track 0, the target's, follows A until ``stop_at``, then stays where
    the two met, likelier standing (mu 0.99: what a window of both explained as it alone leaves,
    head-on evaluation 1151); track 1 follows B; a new track 2 follows ``new_path`` (t -> state)
    from 2.3 s, confirmed at 2.75 s; with ``born_at`` its state then is kept as its birth at a
    two-camera crossing (``JointTrack.born``), which ``behind_at_birth`` scores."""
    paths = head_on()
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, area=48.0, sigma_v=1.5, handover=True,
                      decide_accel=0.35, left_behind=left_behind, stand_s=3.0, behind_at_birth=behind_at_birth)
    stop = np.array(paths["A"](stop_at), float)
    for t in TIMES:
        if t < stop_at:
            t0 = JointTrack(0, np.array(paths["A"](t), float), S0.copy(), confirmed=True, seen=True)
        else:
            t0 = JointTrack(0, np.r_[stop[:2], 0.0, 0.0], S0.copy(), confirmed=True, seen=False, mu=0.99)
            t0.xs, t0.Ps = stop[:2].copy(), S0[:2, :2].copy()
        trs = [t0, JointTrack(1, np.array(paths["B"](t), float), S0.copy(), confirmed=True, seen=True)]
        if t >= 2.3 - 1e-9:
            trs.append(JointTrack(2, np.array(new_path(t), float), S0.copy(), confirmed=t >= 2.75 - 1e-9, seen=True))
            if born_at is not None:  # born at a two-camera crossing: its first state kept (``JointTrack.born``)
                trs[-1].born = (born_at, np.array(new_path(born_at), float), S0.copy())
        idl.update(float(t), trs)
    return idl


def test_a_target_track_left_standing_where_the_pair_met_gives_the_identity_to_the_new_track_on_the_target():
    """The target walks on after the head-on pass; its track stopped where they met and is held
    standing, and a new track follows the target. The pair decision keeps identities (neither
    track of the pair is on the other's person); the new track continuing the target's state from
    before the encounter is far likelier than someone new, so it takes the target's identity
    (``left_behind``); without the rule the identity stays on the standing track."""
    idl = left_behind_run(head_on()["A"])
    (d,) = [d for d in idl.decisions if d["kind"] == "left behind"]
    (made,) = [d for d in idl.decisions if d["kind"] == "left behind made"]
    assert d["a"] == 0 and d["b"] == 2 and d["log_odds"] > EXCHANGE_LOG_ODDS and made["t"] == d["t"]
    assert idl.holder(0) == 2 and idl.identity(0) == 2
    # the new track is the target from its first frame, but no earlier than the output lag (here
    # lag_s, 1 s) before the decision
    assert d["t"] == pytest.approx(3.5)
    t = np.array([2.3, 2.4, 2.5, 5.0])
    assert (idl.relabel(t, np.full(4, 2)) == [2, 2, 0, 0]).all()
    off = left_behind_run(head_on()["A"], left_behind=False)
    assert off.holder(0) == 0 and not [d for d in off.decisions if d["kind"] == "left behind"]


def test_a_new_track_on_someone_else_does_not_take_the_standing_targets_identity():
    """The same standing track, but the new track is someone walking elsewhere (from (1, 6) east at
    1 m/s): it is likelier someone new than the target walked on, and the identity stays."""
    idl = left_behind_run(lambda t: (1.0 + (t - 2.3), 6.0, 1.0, 0.0))
    scored = [d for d in idl.decisions if d["kind"] == "left behind"]
    assert scored and all(d["log_odds"] < 0.0 for d in scored)
    assert idl.holder(0) == 0 and not idl.behind  # not even pending: someone new is likelier


def test_a_left_behind_candidate_is_scored_where_it_was_born():
    """``walked_on`` with ``behind_at_birth``: the standing track g stopped at (3.3, 3.0); its
    person walked east at 0.6 m/s before (pre state at 2 s). A candidate born on that walker's
    path is g's person walked on, now and at its birth. One born at 2.5 s 0.9 m behind the stop
    (rendered evaluation 2030: the look-alike setting off from where it stood) and now, at 4 s,
    where the walker would be fits g's person by its state now (log-odds 4.1: with the stand's
    duration it would take the identity) but not by where it began."""
    def score(at_birth, born, now):
        idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, area=48.0, sigma_v=1.5, decide_accel=0.35,
                          left_behind=True, behind_at_birth=at_birth)
        g = JointTrack(0, np.array([3.3, 3.0, 0.0, 0.0]), S0.copy(), confirmed=True, mu=0.99)
        g.xs, g.Ps = g.s[:2].copy(), S0[:2, :2].copy()
        n = JointTrack(2, np.array(now, float), S0.copy(), confirmed=True, seen=True)
        n.born = (born[0], np.array(born[1], float), S0.copy())
        idl.born = {0: 0.0, 2: born[0]}
        return idl.walked_on(4.0, n, (np.array([3.0, 3.0, 0.6, 0.0]), S0.copy(), 2.0), g)

    on_path = ((2.8, (3.48, 3.0, 0.6, 0.0)), (4.2, 3.0, 0.6, 0.0))
    assert score(True, *on_path) > EXCHANGE_LOG_ODDS and score(False, *on_path) > 0.0
    set_off = ((2.5, (2.4, 3.15, 1.2, -0.1)), (4.2, 3.0, 1.2, -0.1))
    assert score(False, *set_off) > 3.0
    assert score(True, *set_off) < -EXCHANGE_LOG_ODDS


def test_a_track_born_on_the_target_that_then_turned_takes_the_identity_of_its_standing_track():
    """``left_behind_run``'s head-on pass, the target's track left standing where the pair met; a
    new track, born at 2.3 s on the target walking on east, follows it as it turns north at 2.6 s
    (head-on development 131's pattern: there the target paused at the north wall and turned
    east). By its state at the decision (3.5 s) it is neither the
    walker walked on nor one who stood and walked off; by its birth it is the target walked on,
    and it takes the identity."""
    a = head_on()["A"]
    turned = lambda t: a(t) if t < 2.6 else (a(2.6)[0], 3.0 + 1.5 * (t - 2.6), 0.0, 1.5)
    idl = left_behind_run(turned, born_at=2.3)
    (d,) = [d for d in idl.decisions if d["kind"] == "left behind"]
    assert d["b"] == 2 and d["log_odds"] > EXCHANGE_LOG_ODDS and idl.holder(0) == 2
    off = left_behind_run(turned, born_at=2.3, behind_at_birth=False)
    (d,) = [d for d in off.decisions if d["kind"] == "left behind"]
    assert d["log_odds"] < 0.0 and off.holder(0) == 0


def test_a_waiting_left_behind_decision_counts_the_stand_and_ends_when_the_track_walks():
    """A pending left-behind decision (scored 3.0 log-odds, below log(99)): its log-odds grow by
    the stand's duration over ``stand_s`` (3 s) - 3.0 + 4/3 at 4 s after the stand began is still
    below, 3.0 + 5/3 at 5 s is above, and the new track takes the identity then, from no earlier
    than the lag before. A standing track that walks again (mu < 1/2) ends the wait."""
    def tracks(mu):
        g = JointTrack(0, np.array([3.0, 3.0, 0.0, 0.0]), S0.copy(), confirmed=True, mu=mu)
        n = JointTrack(2, np.array([6.0, 3.0, 1.0, 0.0]), S0.copy(), confirmed=True, seen=True)
        return {0: g, 2: n}

    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, left_behind=True, stand_s=3.0)
    idl.born, idl.stand_from, idl.behind, idl.ident = {0: 0.0, 2: 1.0}, {0: 0.0}, {0: (2, 3.0)}, {0: 0, 2: 2}
    idl._still_behind(4.0, tracks(0.99))
    assert idl.behind and idl.holder(0) == 0
    idl._still_behind(5.0, tracks(0.99))
    assert not idl.behind and idl.holder(0) == 2 and idl.identity(0) == 2
    assert idl.events[-1] == (4.0, {0: 2, 2: 0})  # from the decision less the lag (1 s): after the new track's birth
    (made,) = [d for d in idl.decisions if d["kind"] == "left behind made"]
    assert made["log_odds"] == pytest.approx(3.0 + 5.0 / 3.0)
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, left_behind=True, stand_s=3.0)
    idl.born, idl.stand_from, idl.behind, idl.ident = {0: 0.0, 2: 1.0}, {0: 0.0}, {0: (2, 3.0)}, {0: 0, 2: 2}
    idl._still_behind(4.0, tracks(0.2))
    assert not idl.behind and idl.holder(0) == 0


def chain_rows(gap_from, gap_to, times=TIMES):
    """The output of one identity (0) carried by track A until ``gap_from`` and, after a decision
    joined them, by track B from ``gap_to`` (no row between), for a walker at (1 + 1.2 t, 3 + 0.5 t);
    identity 1 (someone else) reported in every frame."""
    rows = []
    for t in times:
        if t < gap_from - 1e-9 or t >= gap_to - 1e-9:
            rows.append((t, 0, 1.0 + 1.2 * t, 3.0 + 0.5 * t, 1.2, 0.5, 2, "planes"))
        rows.append((t, 1, 5.0, 5.0, 0.0, 0.0, 2, "planes"))
    return pd.DataFrame(rows, columns=["t", "track_id", "x", "y", "vx", "vy", "n_cameras", "mode"])


def test_a_gap_between_two_tracks_of_one_identity_is_bridged_within_the_output_lag():
    """The target's rows stop at 1.95 s (its track ended) and resume at 2.6 s (the new track that
    a hand-over gave its identity): the six frames between are reported on the curve through
    both ends' positions and velocities - here the walker's own straight line - as ``bridged``
    with no camera; everyone else's rows are untouched."""
    from trackroom.estimators.target_planes import bridge_gaps

    out = bridge_gaps(chain_rows(2.0, 2.6), TIMES, 3.5, lambda xy: np.ones(len(xy), bool))
    tgt = out[out.track_id == 0]
    assert np.allclose(tgt.t.to_numpy(), TIMES)  # every frame, once
    br = tgt[tgt["mode"] == "bridged"]
    assert np.allclose(br.t.to_numpy(), [2.0, 2.1, 2.2, 2.3, 2.4, 2.5])
    assert (br.n_cameras == 0).all()
    assert np.allclose(br.x.to_numpy(), 1.0 + 1.2 * br.t.to_numpy()) and np.allclose(br.y.to_numpy(), 3.0 + 0.5 * br.t.to_numpy())
    assert np.allclose(br.vx.to_numpy(), 1.2) and np.allclose(br.vy.to_numpy(), 0.5)
    assert len(out[out.track_id == 1]) == len(TIMES)


def test_a_gap_longer_than_the_output_lag_or_off_the_floor_is_not_bridged():
    """A gap of 1.5 s with a lag of 1 s stays a gap (the rows on either side would be final before
    the smoother had both); so does one whose curve leaves the floor plan, and one after an
    extrapolated row (frames a track's extension back from its birth left out on purpose)."""
    from trackroom.estimators.target_planes import bridge_gaps

    rows = chain_rows(1.0, 2.6)
    assert len(bridge_gaps(rows, TIMES, 1.0, lambda xy: np.ones(len(xy), bool))) == len(rows)
    short = chain_rows(2.0, 2.6)
    assert len(bridge_gaps(short, TIMES, 3.5, lambda xy: xy[:, 0] < 3.0)) == len(short)
    assert len(bridge_gaps(short, TIMES, 3.5, lambda xy: xy[:, 0] < 4.5)) == len(short) + 6
    extended = short.copy()
    extended.loc[(extended.track_id == 0) & (extended.t < 2.0 - 1e-9) & (extended.t > 1.5 - 1e-9), "mode"] = "extrapolated"
    assert len(bridge_gaps(extended, TIMES, 3.5, lambda xy: np.ones(len(xy), bool))) == len(short)


def test_a_pair_is_exchanged_above_its_own_threshold_and_a_hand_over_above_its_own():
    """The decisions' thresholds are ``pair_log_odds`` and ``handover_log_odds`` (log 99 unless
    set): the same scored decision exchanges identities just below its log-odds and not just
    above them, and one kind's threshold does not move the other's."""
    idl, *_ = run(head_on(), swap_at=2.05)
    (d,) = idl.decisions
    for delta, exchanged in ((-1e-3, True), (1e-3, False)):
        i2, *_ = run(head_on(), swap_at=2.05, pair_log_odds=d["log_odds"] + delta)
        assert (i2.holder(0) == 1) is exchanged
    idl, *_ = run_gone(head_on(), swap_at=2.05, end_at=2.1, new_from=2.3, new_on="A")
    (h,) = idl.handovers
    for delta, made in ((-1e-3, True), (1e-3, False)):
        idl, *_ = run_gone(head_on(), swap_at=2.05, end_at=2.1, new_from=2.3, new_on="A", handover_log_odds=h["log_odds"] + delta,
                           pair_log_odds=1e9)
        assert (idl.holder(0) == 2) is made


def test_the_estimators_thresholds_reach_the_identity_decision(monkeypatch):
    """``TargetPlanes.Config``'s ``pair_log_odds`` and ``handover_log_odds`` are the thresholds
    of the decision the estimator runs; by default Bayes' decision at the prior odds measured on
    development truth (11 pair exchanges of 2433, 8 hand-overs of 117), log 99 in ``IdentityLag``
    used alone."""
    from tests.test_target_planes_joint import boxes_table, line_path
    from trackroom.estimators import target_planes as tp

    made = []

    class Recorded(IdentityLag):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(tp, "IdentityLag", Recorded)
    south, west = right_angle_pair()
    times = np.round(np.arange(0, 2.0, 0.1), 6)
    paths = {"A": line_path([1.0, 1.0], [3.0, 1.6], times)}
    obs, cal = Observations({"boxes": boxes_table([south, west], paths, times)}, 2.0), calib([south, west])
    TargetPlanes(multi_person=True, pair_log_odds=5.0, handover_log_odds=2.5).run(obs, cal)
    TargetPlanes(multi_person=True).run(obs, cal)
    assert [(i.pair_log_odds, i.handover_log_odds) for i in made] == [(5.0, 2.5), (np.log(2422 / 11), np.log(109 / 8))]
    assert IdentityLag(1.0, 1.0, 0.2).pair_log_odds == IdentityLag(1.0, 1.0, 0.2).handover_log_odds == EXCHANGE_LOG_ODDS


def test_an_encounter_still_ambiguous_at_the_end_is_logged_open_and_unscored():
    """Two look-alikes side by side (0.5 m apart) the whole recording, their tracks swapped at
    2.5 s: the pair never comes apart, so nothing is decided; ``finish`` logs the encounter as
    "open" with no log-odds, its post states the tracks at the end (on each other's person)."""
    paths = {"A": lambda t: (1.0 + t, 3.0, 1.0, 0.0), "B": lambda t: (1.0 + t, 3.5, 1.0, 0.0)}
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0)
    for t in TIMES:
        on = ("A", "B") if t < 2.5 else ("B", "A")
        trs = [JointTrack(k, np.array(paths[n](t), float), S0.copy(), confirmed=True, seen=True) for k, n in enumerate(on)]
        idl.update(float(t), trs)
    assert not idl.decisions
    idl.finish(trs)
    (d,) = idl.decisions
    assert d["kind"] == "open" and np.isnan(d["log_odds"]) and d["t"] == pytest.approx(TIMES[-1])
    assert d["a_pre"][1] == pytest.approx(3.0) and d["a_post"][1] == pytest.approx(3.5)  # track 0 ends on B
    assert idl.holder(0) == 0  # left as tracked


@pytest.mark.parametrize("pre_while_apart, t_pre, undone", [(False, 1.0, False), (True, 1.7, True)])
def test_the_pre_states_are_refreshed_until_the_pair_first_comes_near(pre_while_apart, t_pre, undone):
    """Head-on, merged in one view at 1.0-1.1 s while 3 m apart (an episode opens), merged nowhere
    at 1.2-1.7 s as they close in, nearer than 4 radius from 1.8 s, swapped at 2.05 s. The pre
    states are those of the last merged frame before they came near (1.0 s), or with
    ``pre_while_apart`` of the last frame before they came near at all (1.7 s): the prediction
    to the decision is that much shorter. Predicted from 1.0 s (through 2.3 s more of a walker
    model of 1 m/s^2/sqrt(Hz)) the exchange scores 4.2, under log 99, and the swap stands; from
    1.7 s it is undone."""
    idl, *_ = run(head_on(), swap_at=2.05, merged=(1.0, 1.1), pre_while_apart=pre_while_apart)
    (d,) = idl.decisions
    assert d["t_pre"] == pytest.approx(t_pre) and d["log_odds"] > 0.0
    assert (d["log_odds"] > EXCHANGE_LOG_ODDS) is undone and (idl.holder(0) == 1) is undone


@pytest.mark.parametrize("decide_apart", [False, True])
def test_a_pair_apart_on_the_floor_is_decided_while_still_merged_in_a_view(decide_apart):
    """Head-on, nearer than 4 radius at 1.8-2.2 s, swapped at 2.05 s; from 2.3 s apart on the
    floor but merged in one view until 8.0 s (a camera that sees them along one line of sight:
    head-on development 120 stayed so 5 s). Without ``decide_apart`` the encounter lasts until
    the view parts them and is decided at 9.1 s from the pre states of 1.7 s: 7.4 s of a walker
    model of 1 m/s^2/sqrt(Hz) leaves 4.3, under log 99, and the swap stands. With it the pair is
    decided a lag after it parted on the floor (3.3 s, 12.3) and the swap is undone; the
    encounter goes on from there in the merged view, kept at its end."""
    idl, *_ = run(head_on(), swap_at=2.05, times=np.round(np.arange(0.0, 10.01, 0.1), 6), merged=(2.3, 8.0),
                  decide_apart=decide_apart)
    td = [d[0] for d in idl.log]
    if decide_apart:
        assert td == pytest.approx([3.3, 9.1]) and idl.log[0][3] > EXCHANGE_LOG_ODDS and idl.log[1][3] < 0.0
        assert idl.holder(0) == 1
    else:
        assert td == pytest.approx([9.1]) and 0.0 < idl.log[0][3] < EXCHANGE_LOG_ODDS
        assert idl.holder(0) == 0


def test_a_track_left_behind_after_a_decision_while_merged_is_found_from_the_encounters_first_pre_states():
    """``decide_apart`` with ``left_behind``: the pair of the test above keeps its people, is
    decided kept at 3.3 s while still merged in a view, and the encounter goes on. Track 0 (the
    target's) stops at 4.0 s and is held standing there, while the target walks on with a new
    track 2, born at 4.3 s. At the encounter's last decision (7.1 s) track 2 is scored as the
    target walked on from the encounter's first pre states (1.7 s), which it was born after, and
    takes the identity. With the pre states of the encounter's last part (5.9 s, refreshed while
    the pair was merged and apart) track 2 would be older than the encounter and not scored: the
    identity would stay on the standing track (head-on development 131)."""
    paths = head_on()
    idl = IdentityLag(1.0, accel_sigma=1.0, radius=0.2, watch=0, area=48.0, sigma_v=1.5, left_behind=True, stand_s=3.0,
                      decide_accel=0.35, decide_apart=True)
    stop = np.array(paths["A"](4.0), float)
    for t in np.round(np.arange(0.0, 8.01, 0.1), 6):
        if t < 4.0:
            t0 = JointTrack(0, np.array(paths["A"](t), float), S0.copy(), confirmed=True, seen=True)
        else:
            t0 = JointTrack(0, np.r_[stop[:2], 0.0, 0.0], S0.copy(), confirmed=True, seen=False, mu=0.99)
            t0.xs, t0.Ps = stop[:2].copy(), S0[:2, :2].copy()
        trs = [t0, JointTrack(1, np.array(paths["B"](t), float), S0.copy(), confirmed=True, seen=True)]
        if 2.3 - 1e-9 <= t <= 6.0 + 1e-9:
            merge(trs[0], trs[1])
        if t >= 4.3 - 1e-9:
            trs.append(JointTrack(2, np.array(paths["A"](t), float), S0.copy(), confirmed=t >= 4.75 - 1e-9, seen=True))
            trs[-1].born = (4.3, np.array(paths["A"](4.3), float), S0.copy())
        idl.update(float(t), trs)
    pairs = [(d["t"], d["t_pre"]) for d in idl.decisions if d["kind"] == "pair" and {d["a"], d["b"]} == {0, 1}]
    assert pairs == [pytest.approx((3.3, 1.7)), pytest.approx((7.1, 5.9))]
    (d,) = [d for d in idl.decisions if d["kind"] == "left behind"]
    assert (d["a"], d["b"]) == (0, 2) and d["t"] == pytest.approx(7.1) and d["t_pre"] == pytest.approx(1.7) and d["log_odds"] > 0.0
    assert idl.holder(0) == 2
