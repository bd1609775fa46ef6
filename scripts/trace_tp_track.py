"""Frame trace of one target_planes track: what each camera showed it and how it moved.

    python -m scripts.trace_tp_track DIR --from T0 --to T1 [--track ID] [--multi] [--updates] [--costs] [--pulls PERSON]
                                     [--axes gap|course] [--param KEY=VALUE ...]

Runs target_planes on one occlusion_lab recording (single-target with the experiment's click,
``experiment_tsutsui.run_target``, or every mover with ``--multi``) and prints, for each frame in
[T0, T1] s where the track exists (id ``--track``, default 0: the hand-chosen target's):

- its state before the frame (after the previous frame's updates): floor position and velocity
  with their standard deviations (m, m/s), and its standing probability mu;
- per camera that could see it: its projection (centroid column u and its sd, columns of the
  projected cylinder, predicted image flow, px and px/s; "hidden by the floor plan" when the
  tracker's ``Occluders`` say that camera cannot see a person there), every window the camera reported
  (columns, rows, flow) and the joint explanation (window index -> the ids of the tracks that
  window was explained by; a window absent is clutter);
- its state after the frame's updates, its mode (planes / area / merged / predicted) and each
  camera's status;
- with ``--updates``, after the cameras' lines, every Kalman update of the track, in order
  (its camera; a target plane - of its own window, or a merged window's edge with the track's
  share of it -, an edge, the width, the depth, the flow) and how far it moved the position and
  velocity
  (issue 12's fifty-fifth session: rendered 2341, 6.0-7.0 s, where a merged window's edge
  carries the stopping target's track off);
- with ``--costs``, after each camera's line, what the joint explanation weighed for the track
  there: its miss cost (``JointTracker.miss_costs``), its walking mode's chance of being too slow
  for a window (``p_slow``) and its standing probability, its cost alone in each window it gates
  (``explain_cost``), and what the camera's best explanation costs more when the track is made
  to hold no window or each of those windows (``explain_camera``'s ``force``: +0.00 is the
  explanation chosen; issue 12's sixty-ninth session: analytic 2812 at 28.2 s in ``obl_ne``);
- with ``--pulls PERSON``, after the frames, which updates drew the track towards that true
  person and which away, summed over the frames (issue 12's hundredth session: rendered 4065,
  19.0-20.2 s, where two views hold a lagging track and one's flow holds its velocity back):
  each Kalman update's change of the position projected on the unit vector from the track (its
  state before the frame) to the person, and its change of the velocity on the unit vector from
  the track's velocity to the person's (m and m/s; positive: towards the person); the first row,
  "motion", is the prediction against the person's own step: minus (the person's change of
  position, velocity less the track's change outside the updates: dt times its velocity, the
  caps and mode mixing), so the rows add up to how much the gap closed, frame by frame along its
  direction (a row "between frames" holds what moved the track outside the frames' steps: the
  prune holding it inside the walls or on the floor); those per-frame directions turn, so the
  sums over frames need not add up to the change in the gap. With ``--axes course`` each
  update's changes are summed as vectors instead and read along the person's course over the
  frames and across it, and the rows add up to the gap's change on those fixed axes (issue 12's
  hundred-and-second session: where the look-alike's track stays short of it in the south-west
  corner);
- the true positions of the people, read here by the experimenter (the tracker never sees them),
  and the columns of each person's cylinder (the person model's height and radius) in every
  camera whose image it falls in, "(unseen)" after a person the recording's truth says that
  camera could not see (``truth_visibility``: behind the floor plan's boxes or other people;
  issue 12's seventieth session: rendered 2839 at 31.3 s, where ``obl_se``'s one window is the
  look-alike's head over the shelf).

The frame traces in docs/target_planes.md can be re-made with it (e.g. rendered development
137, 21.5-22.4 s). Frame times are the estimator's own (``TargetPlanesResult.times``).
"""
from __future__ import annotations

import argparse
from typing import NamedTuple

import numpy as np

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts import experiment_tsutsui as ts
from trackroom.dataset import read_recording
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators import tp_geometry as geo, tp_joint


def _state(tr) -> str:
    sd = np.sqrt(np.diag(tr.S))
    return (f"x {tr.s[0]:.2f},{tr.s[1]:.2f} (sd {sd[0]:.2f},{sd[1]:.2f}) v {tr.s[2]:+.2f},{tr.s[3]:+.2f} "
            f"(sd {sd[2]:.2f},{sd[3]:.2f}) mu {tr.mu:.3f} exist {tr.exist:+.2f}")


def _windows(boxes) -> str:
    return " ".join(f"[{j}: u {b[0]:.0f}-{b[1]:.0f} rows {b[2]:.0f}-{b[3]:.0f} flow {f[0]:+.0f},{f[1]:+.0f}]"
                    for j, (b, f) in enumerate(zip(boxes.win, boxes.flow))) or "none"


UPDATES = ("update_plane", "update_own_edge", "update_width", "update_depth", "update_flow")  # JointTracker's Kalman updates


class Tracer:
    """Wraps ``tp_joint.JointTracker.step`` and ``explain_camera`` for one run, collecting the
    trace lines of one track in every frame it exists, by frame index (the frame times come
    with the run's result); with ``updates`` also each Kalman update of the track (``UPDATES``)
    and how far it moved the state; with ``moves`` those changes kept as numbers (``moves``,
    with the state before and after each frame in ``states``) without their lines; ``close``
    puts the tracker back."""

    def __init__(self, tid: int, updates: bool = False, costs: bool = False, moves: bool = False):
        self.tid = tid
        self.k = -1  # the frame index: one step per frame
        self.frames: list[tuple[int, list[str]]] = []  # (frame index, its lines: before, cameras, after)
        self.track = None  # the traced track during the current frame
        self.states: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # frame index -> the track's state before, after
        self.moves: list[tuple[int, str, str, np.ndarray]] = []  # (frame index, camera, update, change of the state)
        JT = tp_joint.JointTracker
        self.orig = JT.step, JT.explain_camera
        tracer = self

        def step(jt, tracks, frame, dt, *args):
            tracer.k += 1
            tr = next((x for x in tracks if x.tid == tracer.tid), None)
            tracer.track = tr
            if tr is not None:
                tracer.frames.append((tracer.k, [f"before: {_state(tr)}"]))
                s0 = tr.s.copy()
            out = tracer.orig[0](jt, tracks, frame, dt, *args)
            if tr is not None:
                tracer.states[tracer.k] = (s0, tr.s.copy())
                status = " ".join(f"{c} {v[0]}{' (' + str(v[1]) + ')' if v[1] else ''}" for c, v in sorted(tr.status.items()))
                tracer.frames[-1][1].append(f"        after:  {_state(tr)} mode {tr.mode}; {status}")
            tracer.track = None
            return out

        def explain_camera(jt, c, tracks, boxes, *args):
            expl, projs = tracer.orig[1](jt, c, tracks, boxes, *args)
            # by identity: the explanation indexes ``tracks``, which holds only the located tracks
            i = next((k for k, x in enumerate(tracks) if x is tracer.track), None)
            if i is not None and i in projs:
                p = projs[i]
                who = {j: [tracks[i].tid for i in mem] for j, mem in sorted(expl.items())}
                hidden = jt.occluders is not None and not jt.occluders.visible(c, tracks[i].xy)
                tracer.frames[-1][1].append(
                    f"    {c}: projection u {p.u:.0f} (sd {np.sqrt(p.var_u):.0f}) cols {p.win[0]:.0f}-{p.win[1]:.0f} "
                    f"flow {p.flow[0]:+.0f},{p.flow[1]:+.0f}{' hidden by the floor plan' if hidden else ''}; "
                    f"windows {_windows(boxes)}; explained {who}")
                if costs:
                    tracer.frames[-1][1].append(tracer.costs(jt, c, tracks, boxes, i, p))
            return expl, projs

        JT.step, JT.explain_camera = step, explain_camera
        self.depth = 0  # updates under way (one may call another)
        self.show_updates = updates
        self.orig_updates = {name: getattr(JT, name) for name in UPDATES} if updates or moves else {}
        for name, orig in self.orig_updates.items():
            setattr(JT, name, self._update(name, orig))

    def costs(self, jt, c: str, tracks: list, boxes, i: int, p) -> str:
        """``--costs``' line for track ``tracks[i]`` (projection p) in camera c: its miss cost,
        P(slow) and standing probability, its cost alone in each window it gates, and the extra
        cost of the camera's best explanation with the track forced to no window or to each of
        them; the tracker's own result of the frame (``cost``, ``alternative``) is put back."""
        base, alt = jt.cost, jt.alternative
        gated = jt.gated_windows(p, boxes)
        alone = " ".join(f"{j}: {jt.explain_cost(c, [p], boxes, j):.2f}" for j in gated) or "none gated"
        forced = []
        for opt in [None, *gated]:
            self.orig[1](jt, c, tracks, boxes, force=(i, opt))
            forced.append(f"{'none' if opt is None else opt} {jt.cost - base:+.2f}")
        jt.cost, jt.alternative = base, alt
        return (f"      {c} costs: miss {jt.miss_costs(c, tracks, {i: p})[i]:.2f} (P(slow) {jt.p_slow(p):.2f}, standing {tracks[i].mu:.3f}); "
                f"alone in window {alone}; forced to window {', '.join(forced)}")

    def _update(self, name: str, orig):
        """``orig`` (a JointTracker update of one track in camera c) with a trace line of the
        change in the traced track's position and velocity; for a plane, whether its column was
        the track's own window's or a merged window's edge (``own``) and the edge's share. An
        update made inside another (``update_own_edge``'s plane) is that one's line alone."""
        tracer = self

        def update(jt, tr, c, *args, **kwargs):
            before = tr.s.copy()
            tracer.depth += 1
            try:
                out = orig(jt, tr, c, *args, **kwargs)
            finally:
                tracer.depth -= 1
            if tr is tracer.track and tracer.frames and tracer.depth == 0:
                d = tr.s - before
                what, kind = "", name
                if name == "update_plane":
                    side = "own" if kwargs.get("own", True) else "edge"
                    what, kind = f" {side} share {kwargs.get('weight', 1.0):.2f}", f"{name} {side}"
                tracer.moves.append((tracer.frames[-1][0], c, kind, d))
                if tracer.show_updates:
                    tracer.frames[-1][1].append(f"      {c} {name}{what}: dx {d[0]:+.3f},{d[1]:+.3f} dv {d[2]:+.3f},{d[3]:+.3f}")
            return out

        return update

    def close(self) -> None:
        tp_joint.JointTracker.step, tp_joint.JointTracker.explain_camera = self.orig
        for name, orig in self.orig_updates.items():
            setattr(tp_joint.JointTracker, name, orig)


BETWEEN = ("", "between frames")  # the pull row of a change of the track made between two frames (``frame_pulls``)


class FramePull(NamedTuple):
    """One traced frame's pulls (``frame_pulls``)."""

    k: int  # the frame index
    gap: tuple[float, float]  # to the person at the frame's start: m, m/s
    speeds: tuple[float, float]  # the person's and the track's, m/s
    pulls: dict  # (camera, update) -> [position pull, velocity pull, updates made], along the gap's directions
    motion: np.ndarray  # the motion row's [position, velocity] pull
    steps: dict  # (camera, update) -> summed change of (x, y, vx, vy), unprojected
    motion_step: np.ndarray  # the motion row unprojected: the track's change outside the updates less the person's step


def nearest_row(me):
    """t -> the row of ``me`` (a person's true rows indexed by time) nearest in time."""
    t_me = me.index.to_numpy(float)
    return lambda t: me.iloc[int(np.argmin(np.abs(t_me - t)))]


def frame_pulls(tracer: Tracer, times: np.ndarray, me, ks: list[int]):
    """Per traced frame k of ``ks`` (frame indices, ascending), a ``FramePull`` - the module
    docstring's pulls, along the gap's directions and unprojected; ``me`` the person's true rows (x, y, vx, vy) indexed by time. The
    motion row counts the person's own step from the previous frame only where that frame is
    the one before; there, a change of the track between the two frames (outside the step: the
    prune holding it inside the walls or on the floor, ``JointTracker.prune``) is the row
    ``BETWEEN``, so that the rows add up over a run of frames."""
    by_frame: dict[int, list] = {}
    for k, c, kind, d in tracer.moves:
        by_frame.setdefault(k, []).append((c, kind, d))
    at = nearest_row(me)
    for n, k in enumerate(ks):
        s0, s1 = tracer.states[k]
        row = at(times[k])
        px, pv = np.array([row.x, row.y]), np.array([row.vx, row.vy])
        e = [px - s0[:2], pv - s0[2:]]
        u = [x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.zeros(2) for x in e]
        pulls: dict[tuple[str, str], np.ndarray] = {}
        steps: dict[tuple[str, str], np.ndarray] = {}
        moved = np.zeros(4)
        for c, kind, d in by_frame.get(k, []):
            pulls[(c, kind)] = pulls.get((c, kind), np.zeros(3)) + [d[:2] @ u[0], d[2:] @ u[1], 1]
            steps[(c, kind)] = steps.get((c, kind), np.zeros(4)) + d
            moved += d
        own = np.zeros(4)  # the person's own step over the frame, from the frame before where that was traced
        if n and ks[n - 1] == k - 1:
            prev = at(times[k - 1])
            own = np.array([row.x - prev.x, row.y - prev.y, row.vx - prev.vx, row.vy - prev.vy])
            # moved between the frames, outside the step: the prune's holds inside the walls and on the floor
            jump = s0 - tracer.states[k - 1][1]
            if np.abs(jump).max() > 1e-12:
                pulls[BETWEEN] = np.array([jump[:2] @ u[0], jump[2:] @ u[1], 1.0])
                steps[BETWEEN] = jump
        rest = (s1 - s0) - moved  # the track's step outside the updates
        motion = np.array([-(own[:2] - rest[:2]) @ u[0], -(own[2:] - rest[2:]) @ u[1]])
        yield FramePull(k, (float(np.linalg.norm(e[0])), float(np.linalg.norm(e[1]))), (float(np.linalg.norm(pv)), float(np.linalg.norm(s0[2:]))),
                        pulls, motion, steps, rest - own)


def person_rows(truth, person: str, who: str = "trace_tp_track"):
    """The true rows of ``person`` (a ``people_at`` table with x, y, vx, vy), indexed by time;
    an unknown person is refused by name."""
    me = truth[truth["person_id"] == person].set_index("t").sort_index()
    if me.empty:
        raise SystemExit(f"{who}: no true person {person!r} (the recording has {sorted(set(truth['person_id']))})")
    return me


def pull_table(tracer: Tracer, times: np.ndarray, truth, person: str, t0: float, t1: float) -> list[str]:
    """``--pulls``' lines: over the traced frames in [t0, t1] s, each (camera, update)'s changes
    of the track's position and velocity towards ``person`` (the true people table ``truth``
    at every frame time, with velocities), and the motion row (the module docstring)."""
    me = person_rows(truth, person)
    ks = [k for k in sorted(tracer.states) if t0 - 1e-9 <= times[k] <= t1 + 1e-9]
    if not ks:
        return []
    rows: dict[tuple[str, str], np.ndarray] = {}  # (camera, update) -> [position pull, velocity pull, count]
    gap = []
    for f in frame_pulls(tracer, times, me, ks):
        gap.append(f.gap)
        for key, pv in f.pulls.items():
            rows.setdefault(key, np.zeros(3))[:] += pv
        rows.setdefault(("", "motion"), np.zeros(3))[:] += [*f.motion, 1]
    out = [f"pulls towards {person}, {times[ks[0]]:.2f}-{times[ks[-1]]:.2f} s ({len(ks)} frames): gap {gap[0][0]:.2f} m, "
           f"{gap[0][1]:.2f} m/s at the start, {gap[-1][0]:.2f} m, {gap[-1][1]:.2f} m/s at the last frame's start",
           f"    {'camera':8s} {'update':18s} {'n':>4s} {'position, m':>12s} {'velocity, m/s':>14s}"]
    order = sorted(rows, key=lambda key: (key != ("", "motion"), key))
    for c, kind in order:
        dx, dv, n = rows[(c, kind)]
        out.append(f"    {c or '-':8s} {kind:18s} {int(n):4d} {dx:+12.3f} {dv:+14.3f}")
    return out


def course_table(tracer: Tracer, times: np.ndarray, truth, person: str, t0: float, t1: float) -> list[str]:
    """``--pulls`` with ``--axes course``: the same rows, each update's changes summed as vectors
    over the traced frames in [t0, t1] s and then read along fixed axes - along the person's
    course (the unit vector of their displacement from the first frame to the last) and across
    it (its left normal) - so that, unlike the per-frame directions, the rows add up to how much
    of the gap (person less track, position and velocity) closed along and across, over frames
    traced back to back. The motion row is the track's change outside the updates less the
    person's own step; the row "between frames" what moved the track outside the steps."""
    me = person_rows(truth, person)
    ks = [k for k in sorted(tracer.states) if t0 - 1e-9 <= times[k] <= t1 + 1e-9]
    if not ks:
        return []
    at = nearest_row(me)
    first, last = at(times[ks[0]]), at(times[ks[-1]])
    course = np.array([last.x - first.x, last.y - first.y])
    if np.linalg.norm(course) < 1e-6:
        raise SystemExit(f"trace_tp_track: {person} did not move between {times[ks[0]]:.2f} and {times[ks[-1]]:.2f} s; "
                         "--axes course needs a course (use --axes gap)")
    along = course / np.linalg.norm(course)
    axes = np.array([along, [-along[1], along[0]]])  # rows: along, across (left)
    rows: dict[tuple[str, str], np.ndarray] = {}  # (camera, update) -> [x, y, vx, vy, count]
    for f in frame_pulls(tracer, times, me, ks):
        for key, d in f.steps.items():
            rows.setdefault(key, np.zeros(5))[:] += [*d, f.pulls[key][2]]
        rows.setdefault(("", "motion"), np.zeros(5))[:] += [*f.motion_step, 1]
    g0 = np.array([first.x, first.y, first.vx, first.vy]) - tracer.states[ks[0]][0]
    g1 = np.array([last.x, last.y, last.vx, last.vy]) - tracer.states[ks[-1]][1]
    on = lambda v: (axes @ v[:2], axes @ v[2:4])
    (p0, v0), (p1, v1) = on(g0), on(g1)
    out = [f"pulls along {person}'s course ({along[0]:+.2f},{along[1]:+.2f}), {times[ks[0]]:.2f}-{times[ks[-1]]:.2f} s "
           f"({len(ks)} frames): gap along {p0[0]:+.2f} m, across {p0[1]:+.2f} m, velocity {v0[0]:+.2f}, {v0[1]:+.2f} m/s "
           f"at the start; {p1[0]:+.2f} m, {p1[1]:+.2f} m, {v1[0]:+.2f}, {v1[1]:+.2f} m/s after the last frame",
           f"    {'camera':8s} {'update':18s} {'n':>4s} {'along, m':>9s} {'across, m':>10s} {'along, m/s':>11s} {'across, m/s':>12s}"]
    for c, kind in sorted(rows, key=lambda key: (key != ("", "motion"), key)):
        (pa, pc), (va, vc) = on(rows[(c, kind)])
        out.append(f"    {c or '-':8s} {kind:18s} {int(rows[(c, kind)][4]):4d} {pa:+9.3f} {pc:+10.3f} {va:+11.3f} {vc:+12.3f}")
    return out


def trace(d: str, tid: int, t0: float, t1: float, multi: bool = False, params: dict | None = None,
          updates: bool = False, costs: bool = False, pulls: str | None = None, axes: str = "gap") -> list[str]:
    """The trace lines of track ``tid`` over [t0, t1] s of the recording in folder ``d``, each
    frame's true positions after it (``updates``: each Kalman update's change of the state too;
    ``pulls``: after the frames, the updates' pulls towards that true person, ``pull_table``, or
    with ``axes="course"`` along and across the person's course, ``course_table``)."""
    if not t1 >= t0:
        raise SystemExit(f"trace_tp_track: --to ({t1}) must not be before --from ({t0})")
    ts.refuse_lookahead("trace_tp_track", params, "trace")
    rec = read_recording(d)
    tracer = Tracer(tid, updates, costs, moves=pulls is not None)
    try:
        if multi:
            res = ts.multi_estimator(rec, params).run(rec.observations, rec.calibration)
        else:
            res = ts.run_target(rec, params)
    finally:
        tracer.close()
    times = np.asarray(res.times, float)
    frames = [(float(times[k]), lines) for k, lines in tracer.frames if t0 - 1e-9 <= times[k] <= t1 + 1e-9]
    truth = ts.people_at(rec.truth.people, np.array([t for t, _ in frames]))
    cfg = TargetPlanes(**{**ts.estimator_config(rec), **(params or {})}).resolved_config(rec.calibration)
    cams = {c: (np.asarray(cam.P, float), float(cam.width)) for c, cam in rec.calibration.cameras_of_kind("oblique").items()}
    vis = rec.truth.visibility
    out = []
    for t, (before, *rest) in frames:
        now = truth[np.isclose(truth["t"], t)]
        out += [f"t {t:.2f} {before}", *rest, "        truth:  " + " ".join(f"{r.person_id} {r.x:.2f},{r.y:.2f}" for r in now.itertuples())]
        unseen = set()  # (camera, person) the simulator says that camera could not see this frame
        if vis is not None and len(vis):
            v = vis[np.isclose(vis["t"].to_numpy(float), t) & ~vis["visible"].to_numpy(bool)]
            unseen = set(zip(v["camera"], v["person_id"]))
        for c, (P, width) in sorted(cams.items()):
            cols = [(r.person_id, geo.cylinder_window(P, (r.x, r.y), cfg.height, cfg.radius)) for r in now.itertuples()]
            seen = " ".join(f"{who} {w[0]:.0f}-{w[1]:.0f}{' (unseen)' if (c, who) in unseen else ''}"
                            for who, w in cols if np.isfinite(w).all() and w[1] >= 0 and w[0] <= width)
            if seen:
                out.append(f"        truth in {c}: {seen}")
    if pulls is not None and frames:
        table = course_table if axes == "course" else pull_table
        out += table(tracer, times, ts.people_at(rec.truth.people, times, ("x", "y", "vx", "vy")), pulls, t0, t1)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recording", metavar="DIR", help="an occlusion_lab recording folder")
    ap.add_argument("--from", dest="t0", type=float, required=True, help="first frame time, s")
    ap.add_argument("--to", dest="t1", type=float, required=True, help="last frame time, s")
    ap.add_argument("--track", type=int, default=0, help="track id (default 0: the hand-chosen target's)")
    ap.add_argument("--multi", action="store_true", help="track every mover (multi_person=true) instead of the clicked target")
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="a target_planes Config value (JSON)")
    ap.add_argument("--updates", action="store_true", help="also each Kalman update of the track and how far it moved the state")
    ap.add_argument("--costs", action="store_true", help="also, per camera, the joint explanation's costs for the track: its miss, "
                    "alone in each window it gates, and the explanation forced to each option")
    ap.add_argument("--pulls", metavar="PERSON", help="after the frames, which updates drew the track towards that true person "
                    "(e.g. target) and which away, in position and velocity, summed over the frames")
    ap.add_argument("--axes", choices=("gap", "course"), default="gap", help="--pulls along each frame's direction to the person "
                    "(gap, default) or summed as vectors and read along and across the person's course over the frames (course)")
    a = ap.parse_args(argv)
    lines = trace(a.recording, a.track, a.t0, a.t1, a.multi, ts.parse_params(a.param), a.updates, a.costs, a.pulls, a.axes)
    if not lines:
        print(f"track {a.track} does not exist between {a.t0:g} and {a.t1:g} s")
        return 1
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
