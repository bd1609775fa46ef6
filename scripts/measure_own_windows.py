"""What the cameras show of each mover on its own: windows that hold one mover and no other.

    python -m scripts.measure_own_windows DIR [DIR ...] [--runs S] [--between T0,T1]   # rendered recordings

A flow window tells a tracker where one person is only when it holds that person alone: a window
over two walkers is a merge, and a walker in no window at all is seen by no camera. For each
rendered recording and each mover (the scene's target and look-alike), this counts the frames the
mover walks (the truth's ``walking``) by how many cameras give it **a window of its own**: a
window whose columns cover at least ``COVER`` (30 %) of the mover's visible segmentation columns
(``truth_labels``) and at least that share of no other mover's. Printed per recording and mover:
walking frames with own windows in >= 2 cameras (where target planes can intersect), in exactly
one camera (one plane and the depth bound), and in none (only a prediction, a merged share or a
standing person's detections can hold it), and the longest run of walking without one; with
``--runs S`` each such run of S seconds or more; with ``--between T0,T1`` only the frames from T0
to T1 s are counted, and every frame there (walking or standing) is also counted by own-window
cameras, to read one miss episode of ``explain_tp_mota --episodes``. A tracker that loses a mover in a run without own
windows is losing what no camera separated; outside such runs it is losing what the windows
showed (issue 12's forty-seventh session). The truth is read here, by the experimenter.
"""
from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import recording_folders

MOVERS = ("target", "distractor")
COVER = 0.3  # share of a mover's visible columns a window must cover to hold it


def holders(win_cols: np.ndarray, person_cols: dict[str, tuple[float, float]], cover: float = COVER) -> list[set[str]]:
    """For each window (columns u_left, u_right; (n, 2)), the people among ``person_cols`` (name
    -> visible columns x0, x1) whose visible columns it covers by at least ``cover``."""
    out = []
    for ul, ur in np.asarray(win_cols, float).reshape(-1, 2):
        held = set()
        for name, (x0, x1) in person_cols.items():
            w = max(float(x1) - float(x0), 1.0)
            if max(min(ur, x1) - max(ul, x0), 0.0) >= cover * w:
                held.add(name)
        out.append(held)
    return out


def own_window_counts(boxes: pd.DataFrame, labels: pd.DataFrame, movers=MOVERS, cover: float = COVER) -> pd.DataFrame:
    """Per frame time of ``boxes`` (t, camera, u_left, u_right) and mover: the number of cameras
    with a window holding that mover and no other mover (``labels``: t, camera, person_id, x0,
    x1, the segmentation's visible boxes). Frames without windows in a camera count none there."""
    lab = {(round(float(t), 6), c): g for (t, c), g in labels[labels.person_id.isin(movers)].groupby(["t", "camera"])}
    counts: dict[tuple[float, str], int] = {}
    for (t, c), g in boxes.groupby(["t", "camera"]):
        key = (round(float(t), 6), c)
        L = lab.get(key)
        if L is None:
            continue
        cols = {r.person_id: (r.x0, r.x1) for r in L.itertuples()}
        own = set()
        for held in holders(g[["u_left", "u_right"]].to_numpy(float), cols, cover):
            if len(held) == 1:
                own |= held
        for m in own:
            counts[(key[0], m)] = counts.get((key[0], m), 0) + 1
    times = np.unique(np.round(boxes.t.to_numpy(float), 6))
    rows = [(t, m, counts.get((t, m), 0)) for t in times for m in movers]
    return pd.DataFrame(rows, columns=["t", "person_id", "own_cameras"])


def runs_without(flags: np.ndarray, times: np.ndarray) -> list[tuple[float, float]]:
    """The (start, end) times of each run of True in ``flags`` (at ``times``)."""
    edges = np.flatnonzero(np.diff(np.r_[0, flags.astype(int), 0]))
    return [(float(times[a]), float(times[b - 1])) for a, b in zip(edges[::2], edges[1::2])]


def summarise(counts: pd.DataFrame, people: pd.DataFrame, movers=MOVERS, between: tuple[float, float] | None = None) -> list[dict]:
    """Per mover: walking frames by own-window cameras (>= 2, 1, 0), every frame likewise
    (``all_two_plus``, ``all_one``, ``all_none`` of ``frames``), and the runs of walking with none
    (``runs``: (start, end) s; the frame interval added to their length); ``between``: only the
    frames from T0 to T1 s."""
    out = []
    if between is not None:
        counts = counts[(counts.t >= between[0] - 1e-9) & (counts.t <= between[1] + 1e-9)]
    for m in movers:
        c = counts[counts.person_id == m].sort_values("t")
        p = people[people.person_id == m].sort_values("t")
        if c.empty or p.empty:
            continue
        t = c.t.to_numpy(float)
        k = np.clip(np.searchsorted(p.t.to_numpy(float), t - 1e-9), 0, len(p) - 1)
        walking = p.walking.to_numpy(bool)[k]
        n = c.own_cameras.to_numpy(int)
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        runs = runs_without(walking & (n == 0), t)
        out.append({"person": m, "walking": int(walking.sum()), "two_plus": int((walking & (n >= 2)).sum()),
                    "one": int((walking & (n == 1)).sum()), "none": int((walking & (n == 0)).sum()),
                    "frames": len(n), "all_two_plus": int((n >= 2).sum()), "all_one": int((n == 1).sum()),
                    "all_none": int((n == 0).sum()), "dt": dt, "runs": [(a, b + dt) for a, b in runs]})
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", metavar="DIR", help="rendered recording folders (globs allowed)")
    ap.add_argument("--runs", type=float, default=None, metavar="S", help="also list runs without own windows of S s or more")
    ap.add_argument("--between", default=None, metavar="T0,T1", help="count only the frames from T0 to T1 s")
    args = ap.parse_args(argv)
    between = None
    if args.between is not None:
        try:
            t0, t1 = (float(x) for x in args.between.split(","))
        except ValueError:
            ap.error(f"--between takes T0,T1 in seconds, not {args.between!r}")
        between = (t0, t1)
    from trackroom.dataset import read_recording

    paths = recording_folders(args.dirs, "measure_own_windows")
    print("recording | mover | walking frames | own windows in >= 2 cameras | in 1 | in none | longest run without, s")
    for path in paths:
        rec = read_recording(path)
        labels = rec.truth.tables.get("labels")
        if labels is None or not len(labels):
            raise SystemExit(f"measure_own_windows: {path} has no segmentation labels (truth_labels): a rendered recording is needed")
        boxes = rec.observations["boxes"]
        if not len(boxes):
            raise SystemExit(f"measure_own_windows: {path} has no windows (boxes)")
        for s in summarise(own_window_counts(boxes, labels), rec.truth.people, between=between):
            w = max(s["walking"], 1)
            longest = max((b - a for a, b in s["runs"]), default=0.0)
            print(f"{path} | {s['person']} | {s['walking']} | {s['two_plus']} ({100 * s['two_plus'] / w:.0f} %) | "
                  f"{s['one']} ({100 * s['one'] / w:.0f} %) | {s['none']} ({100 * s['none'] / w:.0f} %) | {longest:.1f}")
            if between is not None:
                print(f"    {s['person']}, every frame of {between[0]:.1f}-{between[1]:.1f} s: {s['frames']}; own windows in >= 2 "
                      f"cameras {s['all_two_plus']}, in 1 {s['all_one']}, in none {s['all_none']}")
            if args.runs is not None:
                for a, b in s["runs"]:
                    if b - a >= args.runs:
                        print(f"    {s['person']} walking without a window of its own: {a:.1f}-{b:.1f} s ({b - a:.1f} s)")


if __name__ == "__main__":
    main()
