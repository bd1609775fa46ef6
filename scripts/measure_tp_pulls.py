"""Which updates hold a lagging or walking-on target track off its person? Pulls summed over frames.

    python -m scripts.measure_tp_pulls DIR [DIR ...] [--jobs N] [--param KEY=VALUE ...]   # occlusion_lab recordings

Runs target_planes on each recording with the experiment's click (``experiment_tsutsui.run_target``,
the single-target run the identity and RMSE targets score) and traces the target's track (id 0)
as ``trace_tp_track --pulls target`` does (``trace_tp_track.frame_pulls``): in every frame, how
far each Kalman update moved its position towards the target (along the unit vector from the
track to the target at the frame's start) and its velocity towards the target's, and the motion
row (the prediction against the target's own step). Frames are put in two kinds and the pulls
summed over each, cameras pooled, by update:

- lag: the target walks (true speed over ``LAG_SPEED``) and the track is ``LAG_GAP``-``NEAR`` m
  from it (a track farther off is an identity question, not this one);
- stop: the target stands or creeps (true speed under ``STOP_SPEED``) while its track walks on
  (speed over ``STOP_TRACK_SPEED``), within ``NEAR`` m.

Positive: towards the target. On rendered development 100-159 (issue 12's hundredth session) the
flow held the velocity back in lag frames about as much as the windows' own planes pushed it on.
The truth is read here, by the experimenter; the tracker never sees it.
"""
from __future__ import annotations

import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts import experiment_tsutsui as ts
from scripts import trace_tp_track as tt
from trackroom.dataset import read_recording

LAG_SPEED = 0.5  # m/s: the target walks
LAG_GAP = 0.2  # m: the track is behind or beside it by more
NEAR = 1.0  # m: farther, the track is someone else's or lost
STOP_SPEED = 0.15  # m/s: the target stands or creeps
STOP_TRACK_SPEED = 0.25  # m/s: the track walks on
KINDS = ("lag", "stop")


def kind_of(gap: float, person_speed: float, track_speed: float) -> str | None:
    """A frame's kind from the gap (m) and the two speeds (m/s): "lag", "stop" or None."""
    if gap >= NEAR:
        return None
    if person_speed > LAG_SPEED and gap > LAG_GAP:
        return "lag"
    if person_speed < STOP_SPEED and track_speed > STOP_TRACK_SPEED:
        return "stop"
    return None


def pulls(d: str, params: dict | None = None, kinds=kind_of) -> dict:
    """One recording's sums: {kind: {"frames": n, update: [position, velocity, updates]}} with the
    motion row under "motion"; ``kinds`` maps (gap, person's speed, track's speed) to a kind."""
    rec = read_recording(d)
    tracer = tt.Tracer(0, moves=True)
    try:
        res = ts.run_target(rec, params)
    finally:
        tracer.close()
    times = np.asarray(res.times, float)
    me = tt.person_rows(ts.people_at(rec.truth.people, times, ("x", "y", "vx", "vy")), ts.TARGET, "measure_tp_pulls")
    out: dict = {}
    for f in tt.frame_pulls(tracer, times, me, sorted(tracer.states)):
        kind = kinds(f.gap[0], *f.speeds)
        if kind is None:
            continue
        acc = out.setdefault(kind, {"frames": 0})
        acc["frames"] += 1
        for (_, update), pv in f.pulls.items():
            acc.setdefault(update.removeprefix("update_"), np.zeros(3))[:] += pv
        acc.setdefault("motion", np.zeros(3))[:] += [*f.motion, 1]
    return out


def _one(args) -> dict:
    return pulls(*args)


def table(results: list[dict]) -> list[str]:
    """The summed pulls of the recordings' ``pulls``, per kind: by update, total and per frame."""
    lines = []
    for kind in KINDS:
        frames = sum(r.get(kind, {}).get("frames", 0) for r in results)
        recs = sum(1 for r in results if r.get(kind, {}).get("frames", 0))
        lines.append(f"{kind}: {frames} frames in {recs} of {len(results)} recording(s)")
        if not frames:
            continue
        acc: dict[str, np.ndarray] = {}
        for r in results:
            for update, v in r.get(kind, {}).items():
                if update != "frames":
                    acc.setdefault(update, np.zeros(3))[:] += v
        lines.append(f"    {'update':12s} {'n':>6s} {'position, m':>12s} {'velocity, m/s':>14s} {'per frame, cm':>14s} {'per frame, m/s':>15s}")
        for update, (p, v, n) in sorted(acc.items(), key=lambda kv: kv[1][1]):
            lines.append(f"    {update:12s} {int(n):6d} {p:+12.2f} {v:+14.2f} {100 * p / frames:+14.2f} {v / frames:+15.3f}")
    return lines


def main(argv=None) -> int:
    ap = ts.measurement_parser(__doc__)
    ap.add_argument("--jobs", type=int, default=1, help="recordings run at once (processes)")
    dirs, params, a = ts.measurement_args(ap, argv)
    ts.refuse_lookahead("measure_tp_pulls", params, "trace")
    if a.jobs < 1:
        raise SystemExit(f"measure_tp_pulls: --jobs must be at least 1, got {a.jobs}")
    work = [(d, params) for d in dirs]
    if a.jobs == 1:
        results = [_one(w) for w in work]
    else:
        with ProcessPoolExecutor(a.jobs) as pool:
            results = list(pool.map(_one, work))
    print("\n".join(table(results)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
