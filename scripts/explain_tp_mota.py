"""Where `target_planes`' multi-person MOTA is lost: every unmatched frame, classified.

    python -m scripts.explain_tp_mota DIR [DIR ...] [--param KEY=VALUE ...] [--episodes N]

Runs the multi-person tracker on each occlusion_lab recording as ``scripts/experiment_tsutsui.py``
does, scores it against the movers (CLEAR MOT, gate 1 m, ``metrics.score.evaluate``) and reads
each frame the score counts against it with the truth of every person, by the experimenter:

- a false positive (a track matched to no mover) is ``far`` (more than 2 m from anyone), ``off``
  (1-2 m from the nearest person: a track off its person, whose frame is then a miss as well),
  ``standing`` (within 1 m of a standing person: the movers' score does not count them),
  ``duplicate`` (within 1 m of a mover matched to another track that frame) or ``unmatched``
  (within 1 m of a mover left unmatched: the assignment kept an earlier match);
- a false negative (a mover matched to no track) is ``no track`` (none within 2 m), ``track 1-2
  m`` (the nearest 1-2 m away) or ``taken`` (one within 1 m, matched to someone else); and, by
  what the mover was doing (the truth's ``walking``), ``walking``, ``standing`` (stopped after
  walking: a flow tracker sees no window of it) or ``not yet walked`` (standing since the
  start: no flow tracker can have found it), with the distance to the nearest other mover.

It prints one line per recording (MOTA, false positives and negatives by class and by state)
and the totals; with ``--episodes N`` also each track's runs of N or more false-positive frames
of one class (its time span, the nearest person, the mean distance and how far the track moved)
and each mover's runs of N or more false-negative frames (its span, its most frequent class and
state, and how near the other mover came). The recording's own ``scene.toml`` says who walks
(the head-on variant's overrides included).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file

FP_CLASSES = ("far", "off", "standing", "duplicate", "unmatched")
FN_CLASSES = ("no track", "track 1-2 m", "taken")
FN_STATES = ("walking", "standing", "not yet walked")


def _nearest(by_frame: dict, frame, x: float, y: float) -> tuple[pd.DataFrame | None, int, float]:
    """The rows of ``by_frame[frame]`` (floor points ``x, y``) and the index of and distance to
    the one nearest (x, y); (None, -1, inf) when that frame has none."""
    points = by_frame.get(frame)
    if points is None or not len(points):
        return None, -1, np.inf
    d = np.hypot(points["x"].to_numpy(float) - x, points["y"].to_numpy(float) - y)
    k = int(np.argmin(d))
    return points, k, float(d[k])


def mover_states(people: pd.DataFrame, times: np.ndarray) -> pd.DataFrame:
    """Each mover's state on the frame grid ``times``: ``frame, person_id, state``, from the
    truth's ``t, person_id, walking`` (the simulator's own flag; a speed of at least 0.1 m/s from
    ``vx, vy`` where a table has no flag): ``walking``, ``standing`` once it has walked, ``not yet
    walked`` before."""
    rows = []
    for pid, g in people.groupby("person_id", sort=True):
        g = g.sort_values("t", kind="stable")
        t = g["t"].to_numpy(float)
        walk = g["walking"].to_numpy(bool) if "walking" in g.columns else np.hypot(g["vx"], g["vy"]).to_numpy(float) >= 0.1
        k = np.clip(np.searchsorted(t, np.asarray(times, float) - 1e-9), 0, len(t) - 1)
        w, ever = walk[k], np.maximum.accumulate(walk)[k]
        rows.append(pd.DataFrame({"frame": np.arange(len(times)), "person_id": pid,
                                  "state": np.where(w, "walking", np.where(ever, "standing", "not yet walked"))}))
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=["frame", "person_id", "state"])


def classify(tracks: pd.DataFrame, movers: pd.DataFrame, people: pd.DataFrame, matches: pd.DataFrame,
             gate: float = 1.0, states: pd.DataFrame | None = None) -> pd.DataFrame:
    """Each unmatched frame of a movers' CLEAR MOT score, classified (module docstring).

    ``tracks``: ``frame, track_id, x, y``; ``movers``: the scored truth, ``frame, person_id, x,
    y``; ``people``: every person's truth on the same frames (movers and standing people);
    ``matches``: ``frame, person_id, track_id`` of the score. Returns rows ``frame, kind``
    ("fp" / "fn"), ``cls``, ``track_id`` (fp) or ``person_id`` (fn), ``near`` (the nearest
    person; fn: the nearest track), ``d`` (m), the track's ``x, y`` (fp; fn: the mover's), and
    for a false negative ``other`` (m, to the nearest other mover; inf when alone) and ``state``
    (``mover_states``' rows ``frame, person_id, state`` when given, else None)."""
    mover_ids = set(movers["person_id"])
    matched_t = set(zip(matches["frame"], matches["track_id"]))
    matched_p = set(zip(matches["frame"], matches["person_id"]))
    by_frame = {f: g for f, g in people.groupby("frame")}
    rows = []
    for r in tracks.itertuples(index=False):
        if (r.frame, r.track_id) in matched_t:
            continue
        P, k, d = _nearest(by_frame, r.frame, r.x, r.y)
        pid = None if P is None else P["person_id"].iloc[k]
        if d > 2.0 * gate:
            cls = "far"
        elif d > gate:
            cls = "off"
        elif pid not in mover_ids:
            cls = "standing"
        elif (r.frame, pid) in matched_p:
            cls = "duplicate"
        else:
            cls = "unmatched"
        rows.append((r.frame, "fp", cls, r.track_id, pid, d, r.x, r.y, np.nan, None))
    tracks_by_frame = {f: g for f, g in tracks.groupby("frame")}
    movers_by_frame = {f: g for f, g in movers.groupby("frame")}
    state = {} if states is None else dict(zip(zip(states["frame"], states["person_id"]), states["state"]))
    for r in movers.itertuples(index=False):
        if (r.frame, r.person_id) in matched_p:
            continue
        T, k, d = _nearest(tracks_by_frame, r.frame, r.x, r.y)
        cls = "no track" if d > 2.0 * gate else "track 1-2 m" if d > gate else "taken"
        M = movers_by_frame[r.frame]
        M = M[M["person_id"] != r.person_id]
        other = float(np.hypot(M["x"].to_numpy(float) - r.x, M["y"].to_numpy(float) - r.y).min()) if len(M) else np.inf
        rows.append((r.frame, "fn", cls, r.person_id, None if T is None else T["track_id"].iloc[k], d, r.x, r.y,
                     other, state.get((r.frame, r.person_id))))
    return pd.DataFrame(rows, columns=["frame", "kind", "cls", "id", "near", "d", "x", "y", "other", "state"])


def episodes(C: pd.DataFrame, times: np.ndarray, min_frames: int) -> pd.DataFrame:
    """Each track's false-positive frames of one class, when there are at least ``min_frames``:
    ``id, cls, frames, t0, t1, near`` (the most frequent nearest person), ``d`` (mean, m) and
    ``moved`` (the diagonal of the positions' bounding box, m)."""
    fp = C[C["kind"] == "fp"]
    out = []
    for (tid, cls), g in fp.groupby(["id", "cls"]):
        if len(g) < min_frames:
            continue
        near = g["near"].dropna()
        out.append({"id": tid, "cls": cls, "frames": len(g), "t0": float(times[g["frame"].min()]),
                    "t1": float(times[g["frame"].max()]), "near": near.mode().iloc[0] if len(near) else None,
                    "d": float(g["d"].replace(np.inf, np.nan).mean()),
                    "moved": float(np.hypot(np.ptp(g["x"].to_numpy(float)), np.ptp(g["y"].to_numpy(float))))})
    return pd.DataFrame(out, columns=["id", "cls", "frames", "t0", "t1", "near", "d", "moved"])


def fn_episodes(C: pd.DataFrame, times: np.ndarray, min_frames: int, max_gap: int = 2) -> pd.DataFrame:
    """Each mover's runs of false-negative frames (frames at most ``max_gap`` apart), when at
    least ``min_frames`` long: ``id, frames, t0, t1, cls`` and ``state`` (the most frequent) and
    ``other`` (the nearest the other mover came, m)."""
    fn = C[C["kind"] == "fn"].sort_values(["id", "frame"], kind="stable")
    out = []
    for pid, g in fn.groupby("id", sort=True):
        f = g["frame"].to_numpy(int)
        cut = np.flatnonzero(np.diff(f) > max_gap)
        for a, b in zip(np.r_[0, cut + 1], np.r_[cut, len(f) - 1]):
            run = g.iloc[a:b + 1]
            if len(run) < min_frames:
                continue
            st = run["state"].dropna()
            out.append({"id": pid, "frames": len(run), "t0": float(times[f[a]]), "t1": float(times[f[b]]),
                        "cls": run["cls"].mode().iloc[0], "state": st.mode().iloc[0] if len(st) else None,
                        "other": float(run["other"].min())})
    return pd.DataFrame(out, columns=["id", "frames", "t0", "t1", "cls", "state", "other"])


def counts(C: pd.DataFrame) -> dict:
    """False positives and negatives per class, and false negatives per mover state (every
    class and state listed, zeros included)."""
    fp = C[C["kind"] == "fp"]["cls"].value_counts()
    fn = C[C["kind"] == "fn"]["cls"].value_counts()
    st = C[C["kind"] == "fn"]["state"].value_counts()
    return {**{f"fp {c}": int(fp.get(c, 0)) for c in FP_CLASSES}, **{f"fn {c}": int(fn.get(c, 0)) for c in FN_CLASSES},
            **{f"fn {c}": int(st.get(c, 0)) for c in FN_STATES}}


def explain(d: str, params: dict) -> tuple[dict, pd.DataFrame, np.ndarray]:
    """One recording: its score line (seed, MOTA, fp, fn and the class counts), the classified
    frames and the evaluation's frame times."""
    from scripts.experiment_tsutsui import movers_only, multi_estimator
    from trackroom.dataset import read_recording
    from trackroom.metrics.score import evaluate, truth_at
    from trackroom.scenes.loader import load_scene

    rec = read_recording(d)
    scene = load_scene(Path(d) / "scene.toml")
    tracks = multi_estimator(rec, params).estimate(rec.observations, rec.calibration)
    movers = movers_only(rec, scene)
    ev = evaluate(movers, tracks, gate=1.0)
    people = truth_at(rec, ev.frames.times)
    states = mover_states(movers.truth.people, ev.frames.times)
    C = classify(ev.frames.tracks, ev.frames.truth, people, ev.mot.matches, states=states)
    m = ev.metrics()
    line = {"recording": d, "seed": rec.seed, "mota": round(float(m["mota"]), 3), "fp": int(m["fp"]), "fn": int(m["fn"]), **counts(C)}
    return line, C, ev.frames.times


def main(argv=None) -> int:
    from scripts.experiment_tsutsui import parse_params
    from trackroom.dataset import recording_folders

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR", help="occlusion_lab recording folders (globs allowed)")
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="a target_planes Config value (JSON)")
    ap.add_argument("--episodes", type=int, default=0, metavar="N", help="also list false-positive and false-negative runs of N or more frames")
    a = ap.parse_args(argv)
    params = parse_params(a.param)
    dirs = recording_folders(a.recordings, ap.prog)
    lines = []
    for d in dirs:
        line, C, times = explain(d, params)
        lines.append(line)
        print(" ".join(f"{k} {v}" for k, v in line.items() if k != "recording" and (not isinstance(v, int) or v or k in ("fp", "fn"))), flush=True)
        if a.episodes:
            E = episodes(C, times, a.episodes)
            for e in E.itertuples(index=False):
                print(f"    track {e.id} {e.cls}: {e.frames} frames {e.t0:.1f}-{e.t1:.1f} s, near {e.near}, "
                      f"d {e.d:.2f} m, moved {e.moved:.2f} m")
            for e in fn_episodes(C, times, a.episodes).itertuples(index=False):
                print(f"    {e.id} missed, {e.state}: {e.frames} frames {e.t0:.1f}-{e.t1:.1f} s, mostly {e.cls}, "
                      f"other mover within {e.other:.2f} m")
    if len(lines) > 1:
        tot = pd.DataFrame(lines).drop(columns=["recording", "seed", "mota"]).sum()
        print("total " + " ".join(f"{k} {int(v)}" for k, v in tot.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
