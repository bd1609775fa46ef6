"""Which person each `target_planes` duplicate drop took away: one person seen twice, or two people.

    python -m scripts.measure_tp_duplicates DIR [DIR ...] [--csv FILE]

Runs the multi-person tracker (``TargetPlanes(multi_person=True)``, the recording's calibration
noise) on each recording and reads every confirmed track it dropped as a duplicate
(``TargetPlanesResult.ends``, reason ``duplicate``: nearer than 2 radius to another track, states
alike) against the truth, by the experimenter. Each of the two tracks - the dropped one and the
one it duplicated - is labelled with the person it followed over the second before the drop
(0.45-1.5 s before: the person nearest its output in most of those frames, within 0.7 m; ``none``
otherwise). A drop is **of another person** when both labels are movers (the target and the
look-alike) and differ: the track taken away was following the other person a moment before (it
slid onto the survivor's person, or the two people stood within a body width of each other).
Also per drop: the dropped track's age (s since its first frame), the frames in which it had a
window of its own (``tracking`` in some camera), and ``apart_frames``: frames of the last 2 s in
which one camera had both tracks each alone in a window of its own, different windows (two
regions, seen at once).

The summary counts drops of one person and of another person, with the median age and own-window
frames of each kind.
"""
from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders

from scripts.experiment_tsutsui import distances_at, multi_estimator

MOVERS = ("target", "distractor")
LABEL_M = 0.7  # a track follows the person nearest it within this distance, m
BEFORE_S = (0.45, 1.5)  # the second before a drop (the last frames are the slide itself)
APART_S = 2.0


def follows(rows: pd.DataFrame, people: pd.DataFrame) -> str | None:
    """The person a track's output ``rows`` (t, x, y) was nearest in most frames (within
    ``LABEL_M``; ``none`` otherwise; the experiment's ``distances_at``); None for no rows."""
    if not len(rows):
        return None
    names, D = distances_at(people, rows["t"], rows[["x", "y"]])
    k = D.argmin(1)
    labels = np.where(D[np.arange(len(k)), k] < LABEL_M, np.array(names, object)[k], "none")
    ids, counts = np.unique(labels, return_counts=True)
    return str(ids[np.argmax(counts)])


def apart_frames(status: pd.DataFrame, a: int, b: int, t: float) -> int:
    """Frames of the ``APART_S`` before t in which one camera had tracks a and b each alone in a
    window of its own, different windows."""
    s = status[(status.t > t - APART_S) & (status.t < t + 1e-6) & (status.status == "tracking") & status.track_id.isin([a, b])]
    n = 0
    for _, g in s.groupby(["t", "camera"]):
        n += int(g.track_id.nunique() == 2 and g.window.nunique() == 2)
    return n


def drops(d: str) -> pd.DataFrame:
    rec = read_recording(d)
    res = multi_estimator(rec).run(rec.observations, rec.calibration)
    I, S, people = res.internal, res.status, rec.truth.people
    rows = []
    for e in res.ends[res.ends.reason == "duplicate"].itertuples():
        lo, hi = e.t - BEFORE_S[1], e.t - BEFORE_S[0]
        win = lambda tid: I[(I.track_id == tid) & (I.t > lo) & (I.t < hi)]
        mine = I[I.track_id == e.track_id]
        rows.append({"recording": d, "t": e.t, "dropped": e.track_id, "kept": e.other,
                     "dropped_follows": follows(win(e.track_id), people), "kept_follows": follows(win(e.other), people),
                     "age_s": round(float(e.t - mine.t.min()), 2) if len(mine) else 0.0,
                     "own_window_frames": int(S[(S.track_id == e.track_id) & (S.status == "tracking")].t.nunique()),
                     "apart_frames": apart_frames(S, e.track_id, e.other, e.t)})
    return pd.DataFrame(rows, columns=["recording", "t", "dropped", "kept", "dropped_follows", "kept_follows", "age_s",
                                       "own_window_frames", "apart_frames"])


def of_another(df: pd.DataFrame) -> pd.Series:
    """A drop of another person: both tracks followed movers, different ones."""
    return df.dropped_follows.isin(MOVERS) & df.kept_follows.isin(MOVERS) & (df.dropped_follows != df.kept_follows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR")
    ap.add_argument("--csv", metavar="FILE", help="write one row per drop")
    a = ap.parse_args(argv)
    a.recordings = recording_folders(a.recordings, ap.prog)
    df = pd.concat([drops(d) for d in a.recordings], ignore_index=True)
    if a.csv:
        df.to_csv(a.csv, index=False)
    other = of_another(df)
    print(f"{len(a.recordings)} recordings, {len(df)} duplicate drops: {int(other.sum())} of another person, {int((~other).sum())} of one person seen twice (or not classified)")
    for name, g in (("of another person", df[other]), ("of one person", df[~other])):
        if len(g):
            print(f"  {name}: median age {g.age_s.median():.1f} s, own-window frames {g.own_window_frames.median():.0f}, "
                  f"apart frames (last {APART_S:g} s) {g.apart_frames.median():.0f}; recordings {g.recording.nunique()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
