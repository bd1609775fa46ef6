"""How many further cameras see no one at `target_planes`' two-camera crossings, for people and for ghosts.

    python -m scripts.measure_ghost_crossings DIR [DIR ...] [--csv FILE]

Runs the multi-person tracker (``TargetPlanes(multi_person=True)``, the recording's calibration
noise) on each recording and records every crossing of two unclaimed windows' target planes that
``tp_initiate.propose`` considers (inside both windows' target areas and on the floor) with the
number of further cameras that would see a person there whole and show no window near it
(``JointTracker.sees_no_one``). The experimenter labels each crossing against the truth: a
**person** when someone (a walker or a standing person) stands within ``PERSON_M`` of it, a
**ghost** (two people's planes crossing, or a fragment's) otherwise.

The table counts crossings by that number (0, 1, 2 or more) and label: the evidence for
``ghost_test``'s rule (a crossing two further cameras see no one at is not a person). One camera
seeing no one is common for people too - a window missed for a few frames, a person hidden behind
someone standing - two at once rarely.
"""
from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import target_planes as tp_module

from scripts.experiment_tsutsui import multi_estimator

PERSON_M = 0.5  # a crossing within this distance of someone is that person, m


def label_crossings(crossings: pd.DataFrame, people: pd.DataFrame) -> pd.DataFrame:
    """``crossings`` (t, x, y, no_one) with ``person``: True when someone in ``people`` (t,
    person_id, x, y) stands within ``PERSON_M`` of it at its frame time."""
    out = crossings.copy()
    near = np.zeros(len(out), bool)
    by_t = {round(float(t), 6): g[["x", "y"]].to_numpy(float) for t, g in people.groupby("t")}
    for k, (t, x, y) in enumerate(out[["t", "x", "y"]].itertuples(index=False)):
        P = by_t.get(round(float(t), 6))
        near[k] = P is not None and len(P) > 0 and float(np.min(np.hypot(P[:, 0] - x, P[:, 1] - y))) < PERSON_M
    out["person"] = near
    return out


def summary(labelled: pd.DataFrame) -> pd.DataFrame:
    """Crossings by further cameras seeing no one (0, 1, 2+) and label (person, ghost)."""
    n = np.minimum(labelled["no_one"].to_numpy(int), 2)
    tab = pd.crosstab(pd.Series(np.where(n >= 2, "2+", n.astype(str)), name="cameras seeing no one"),
                      pd.Series(np.where(labelled["person"], "person", "ghost"), name="crossing"))
    for c in ("person", "ghost"):
        if c not in tab.columns:
            tab[c] = 0
    tab = tab[["person", "ghost"]]
    tab["ghost share"] = (tab["ghost"] / tab.sum(axis=1)).round(3)
    return tab


def crossings_of(rec) -> pd.DataFrame:
    """Every crossing the multi-person tracker's ``propose`` considered on ``rec``: t, x, y,
    no_one (further cameras seeing no one there; the estimator's own test)."""
    split, propose = tp_module.split_boxes, tp_module.propose
    time_of: dict[int, float] = {}
    rows: list = []

    def split_recorded(*a, **k):
        frames = split(*a, **k)
        for t, fr in frames.items():
            for b in fr.values():
                time_of[id(b)] = float(t)
        return frames

    def propose_recorded(cfg, margin_px, Ps, frame, free, inside_room, prefer=None, ghost=None):
        t = next((time_of[id(b)] for b in frame.values() if id(b) in time_of), None)
        if ghost is None or t is None:
            return propose(cfg, margin_px, Ps, frame, free, inside_room, prefer, ghost)
        seen: dict = {}

        def counted(c, xy):
            r = bool(ghost(c, xy))
            seen.setdefault(tuple(np.round(np.asarray(xy, float), 6)), []).append(r)
            return r

        out = propose(cfg, margin_px, Ps, frame, free, inside_room, prefer, counted)
        rows.extend((t, xy[0], xy[1], sum(v)) for xy, v in seen.items())
        return out

    tp_module.split_boxes, tp_module.propose = split_recorded, propose_recorded
    try:
        multi_estimator(rec).run(rec.observations, rec.calibration)
    finally:
        tp_module.split_boxes, tp_module.propose = split, propose
    return pd.DataFrame(rows, columns=["t", "x", "y", "no_one"]).drop_duplicates(["t", "x", "y"])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", metavar="DIR", help="occlusion_lab recording folders")
    ap.add_argument("--csv", help="write every labelled crossing here")
    args = ap.parse_args(argv)
    parts = []
    for d in recording_folders(args.dirs, ap.prog):
        rec = read_recording(d)
        people = rec.truth.people[["t", "person_id", "x", "y"]]
        lab = label_crossings(crossings_of(rec), people)
        lab.insert(0, "rec", d)
        parts.append(lab)
        n2 = lab[lab.no_one >= 2]
        print(f"{d}: {len(lab)} crossings, {len(n2)} that two or more cameras see no one at ({int(n2.person.sum())} a person)", flush=True)
    allc = pd.concat(parts, ignore_index=True)
    if args.csv:
        allc.to_csv(args.csv, index=False)
    print()
    print(summary(allc).to_string())


if __name__ == "__main__":
    main()
