"""Why `target_planes` loses its target: each loss episode of a recording, classified.

    python -m scripts.explain_tp_losses DIR [DIR ...] [--param KEY=VALUE ...] [--csv FILE]

Runs the single-target tracker as ``scripts/experiment_tsutsui.py`` does (the same click) and
reads its output against the truth, by the experimenter. A frame is *held* as in the issue's
figure (the output's nearest true person is the target, within 1 m); a **loss episode** is a run
of frames not held, runs less than 1 s apart joined. For each episode, from the truth and the
tracker's own record (``TargetPlanesResult.internal``: every track it held; ``ends``: each
confirmed track it dropped, and why):

- ``other``: the person the track went to (the one most often nearest its output, within 1 m,
  over the episode; the look-alike, mostly; none: it drifted off everyone), and ``gap``: how far
  that person was from the target when the episode started, m;
- ``cams``: the target's tracking cameras (``n_cameras``) over the second before the episode, mean;
  ``views``: the cameras that truly see it then (the truth's visibility: in view and not hidden by
  the floor plan's boxes or another person), mean - fewer than two: depth from one camera alone;
- ``x``, ``y``: where the target was when the episode started (floor, m);
- ``speed``: the target's lowest speed over the second before the episode and its start (the
  truth's vx, vy), m/s - below 0.5 it was stopping or setting off;
- ``other_track``: whether that person had a confirmed track of its own (within 0.5 m) in the
  frame before the episode - ``tracked`` - or not; if not, how the last track on it ended in the
  10 s before: ``duplicate`` (dropped as one person seen twice; ``of target``: as a duplicate of
  the target's track), ``existence``, ``unseen``, ``off floor``, ``alive`` (a track near it that
  had drifted more than 0.5 m off), or ``never``;
- ``follower``: whether another confirmed track stayed within 0.5 m of the target over at least
  half the episode's frames not held (the target was tracked, under another track's id: a
  hand-over missing); ``followed_frames`` counts those frames. The summary gives the identity
  held with a perfect hand-over (every such frame held): an upper bound on what passing the
  target's identity to the track that follows it could recover.

Causes, in order: ``unreported`` (in most of the episode's frames no reported row carried the
target's identity: e.g. a hand-over gave it to a new track from the end of the encounter on,
before that track's first reported frame),
``apart`` (the track went to no one, or to someone more than 1.5 m from the
target: it drifted on its own),
``beside, untracked`` (the person beside it had no track: every window there was explained as the
target alone), ``beside, tracked`` (both had tracks: the target's went onto the other's person or
the two exchanged). The summary counts them over the recordings.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.experiment_tsutsui import TARGET, every_frame, person_distances, recordings_and_params, run_target, target_held, truth_at
from trackroom.dataset import read_recording

JOIN_S = 1.0  # loss runs less than this apart are one episode
NEAR_M = 1.5  # someone within this of the target is beside it
ON_M = 0.5  # a track this near a person is on that person


def episodes(held: np.ndarray, t: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1] of runs of frames not held, runs less than JOIN_S apart joined."""
    out: list[list[int]] = []
    for i in np.flatnonzero(~held):
        if out and t[i] - t[out[-1][1]] <= JOIN_S + 1e-9:
            out[-1][1] = int(i)
        else:
            out.append([int(i), int(i)])
    return [(a, b) for a, b in out]


def positions(truth: pd.DataFrame) -> dict[str, np.ndarray]:
    return {pid: g[["x", "y"]].to_numpy(float) for pid, g in truth.groupby("person_id")}


def views_before(visibility: pd.DataFrame, person: str, t0: float, span: float = 1.0) -> float:
    """Mean number of cameras that truly see ``person`` (the truth's ``visible``) over the ``span``
    seconds before ``t0``; NaN without visibility rows there."""
    v = visibility[(visibility["person_id"] == person) & (visibility["t"] >= t0 - span - 1e-9) & (visibility["t"] < t0 - 1e-9)]
    if not len(v):
        return float("nan")
    return float(v.groupby("t")["visible"].sum().mean())


def lowest_speed_before(people: pd.DataFrame, person: str, t0: float, span: float = 1.0) -> float:
    """The lowest speed (the truth's vx, vy; m/s) of ``person`` over the ``span`` seconds up to
    and including ``t0``; NaN without rows there."""
    v = people[(people["person_id"] == person) & (people["t"] >= t0 - span - 1e-9) & (people["t"] <= t0 + 1e-9)]
    return float(np.hypot(v["vx"].to_numpy(float), v["vy"].to_numpy(float)).min()) if len(v) else float("nan")


def explain(d: str, params: dict | None = None) -> list[dict]:
    rec = read_recording(d)
    res = run_target(rec, params)
    out = every_frame(res)  # a frame the target was not reported in is not held
    t = out["t"].to_numpy(float)
    P = positions(truth_at(rec, t))
    est = out[["x", "y"]].to_numpy(float)
    names, D = person_distances(rec, out)
    nearest = np.array(names)[D.argmin(1)]
    held = target_held(names, D)
    internal = res.internal[res.internal["confirmed"].astype(bool)]
    by_t = {round(k, 6): g for k, g in internal.groupby(internal["t"].round(6))}
    ends = res.ends
    vis = rec.truth.tables.get("visibility")
    rows = []
    for i0, i1 in episodes(held, t):
        t0 = t[i0]
        # the person the track went to: the one most often nearest its output over the episode
        # (within 1 m; none: it drifted off everyone)
        took = [n for n, dn in zip(nearest[i0:i1 + 1], D[i0:i1 + 1].min(1)) if n != TARGET and dn < 1.0]
        other = max(set(took), key=took.count) if took else ""
        gap = float(np.hypot(*(P[other][i0] - P[TARGET][i0]))) if other else np.inf
        before = (t >= t0 - 1.0) & (t < t0)
        cams = float(out["n_cameras"].to_numpy()[before].mean()) if before.any() else float("nan")
        views = views_before(vis, TARGET, t0) if vis is not None else float("nan")
        speed = lowest_speed_before(rec.truth.people, TARGET, t0)
        # the target's internal track in the frame before: the one at the output's position
        ib = max(i0 - 1, 0)
        g = by_t.get(round(t[ib], 6), internal.iloc[:0])
        xy = g[["x", "y"]].to_numpy(float)
        own = g["track_id"].to_numpy()[np.argmin(np.hypot(*(xy - est[ib]).T))] if len(g) else None
        other_track = "-"
        if other:
            on = g[(g["track_id"] != own) & (np.hypot(*(xy - P[other][ib]).T) < ON_M)] if len(g) else g
            if len(on):
                other_track = "tracked"
            else:
                other_track = why_untracked(ends, internal, t, P[other], t0, own)
        span = t[i0:i1 + 1]
        fol = 0
        for k, tk in enumerate(span):
            gk = by_t.get(round(tk, 6))
            if gk is None:
                continue
            xk = gk[["x", "y"]].to_numpy(float)
            d_t = np.hypot(*(xk - P[TARGET][i0 + k]).T)
            d_o = np.hypot(*(xk - est[i0 + k]).T)
            fol += bool(np.any((d_t < ON_M) & (d_o > 1e-6)) and not held[i0 + k])
        follower = fol >= 0.5 * len(span)
        if np.isnan(est[i0:i1 + 1, 0]).mean() > 0.5:
            cause = "unreported"  # mostly frames no track carried the target's identity in
        elif gap > NEAR_M:
            cause = "apart"
        elif other_track == "tracked":
            cause = "beside, tracked"
        else:
            cause = "beside, untracked"
        rows.append({"recording": d, "seed": rec.seed, "t0": round(float(t0), 1), "t1": round(float(t[i1]), 1),
                     "frames": int((~held[i0:i1 + 1]).sum()), "other": other, "gap": round(gap, 2),
                     "cams": round(cams, 1), "views": round(views, 1),
                     "x": round(float(P[TARGET][i0][0]), 2), "y": round(float(P[TARGET][i0][1]), 2), "speed": round(speed, 2), "other_track": other_track, "follower": follower, "followed_frames": fol,
                     "cause": cause,
                     "identity_held": float(held.mean()), "n_frames": len(t)})
    return rows


def why_untracked(ends: pd.DataFrame, internal: pd.DataFrame, t: np.ndarray, xy: np.ndarray, t0: float, own) -> str:
    """How the last confirmed track on this person ended in the 10 s before ``t0``."""
    last = None
    for tid, g in internal[(internal["t"] >= t0 - 10.0) & (internal["t"] < t0)].groupby("track_id"):
        if tid == own:
            continue
        k = np.clip(np.searchsorted(t, g["t"].to_numpy(float) - 1e-9), 0, len(t) - 1)
        on = np.hypot(*(g[["x", "y"]].to_numpy(float) - xy[k]).T) < ON_M
        if on.any():
            t_on = float(g["t"].to_numpy()[on][-1])
            if last is None or t_on > last[1]:
                last = (tid, t_on)
    if last is None:
        return "never"
    e = ends[ends["track_id"] == last[0]]
    if not len(e):
        return "alive"
    r = e.iloc[0]
    return f"{r.reason} of target" if r.reason == "duplicate" and r.other == own else str(r.reason)


def main(argv=None) -> int:
    dirs, params, csv = recordings_and_params(__doc__, argv, csv_help="write the episodes here")
    rows = []
    for d in dirs:
        ep = explain(d, params)
        for r in ep:
            print(f"seed {r['seed']!s:>4} {r['t0']:5.1f}-{r['t1']:5.1f} s  {r['frames']:3d} frames  other {r['other']} "
                  f"{r['gap']:.2f} m  cams {r['cams']:.1f} of {r['views']:.1f} seeing  at ({r['x']:.1f}, {r['y']:.1f})  speed {r['speed']:.2f}  other's track {r['other_track']:18s} "
                  f"follower {'yes' if r['follower'] else 'no '}  {r['cause']}", flush=True)
        rows += ep
    df = pd.DataFrame(rows)
    if csv:
        df.to_csv(csv, index=False)
    if not len(df):
        print(f"{len(dirs)} recordings: the target is never lost")
        return 0
    per = df.groupby("recording").agg(held=("identity_held", "first"), followed=("followed_frames", "sum"),
                                      n=("n_frames", "first"))
    lost = per["held"] < 0.99
    handed = per["held"] + per["followed"] / per["n"]
    big = df[df["recording"].isin(lost[lost].index)]
    print(f"\n{len(dirs)} recordings, {len(df)} loss episodes, {int(lost.sum())} recordings below 99 % held; "
          f"with a perfect hand-over to the track following the target: {int((handed < 0.99).sum())} below 99 %")
    for name, sub in (("all episodes", df), ("recordings below 99 %: their episodes of 5+ frames", big[big["frames"] >= 5])):
        print(f"\n{name} ({len(sub)}; frames not held {int(sub['frames'].sum())}):")
        print(sub.groupby(["cause", "other_track"]).agg(episodes=("frames", "size"), frames=("frames", "sum"),
                                                        followed=("follower", "sum")).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
