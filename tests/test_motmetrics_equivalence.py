"""Our CLEAR MOT and IDF1 equal py-motmetrics' on the same inputs (skipped without motmetrics).

Random scenarios have misses (truth without a track), false tracks, tracks that swap or jump to
another person (switches, also across gaps in which the person was missed), people entering and
leaving, and ties (positions on a coarse lattice, so equal distances are common). motmetrics is
given Euclidean distances with NaN beyond the gate (its ``max_d2`` would be a squared distance).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trackroom.metrics.identity import idf1
from trackroom.metrics.mot import EvalFrames, clear_mot, pairwise_distances

mm = pytest.importorskip("motmetrics")


def random_scenario(rng: np.random.Generator, n_frames: int = 40, lattice: float = 0.25):
    n_people = int(rng.integers(1, 7))
    pos = rng.integers(0, 16, size=(n_people, 2)) * lattice
    alive = np.ones(n_people, bool)
    track_of = np.arange(n_people) + 100  # each person starts with their own track id
    next_id = 200
    truth, tracks = [], []
    for k in range(n_frames):
        pos = pos + rng.integers(-1, 2, size=pos.shape) * lattice  # lattice steps: ties happen
        alive ^= rng.random(n_people) < 0.05  # people leave and come back
        for p in range(n_people):
            if not alive[p]:
                continue
            truth.append((k, p, *pos[p]))
            r = rng.random()
            if r < 0.15:
                continue  # missed: no track this frame (a gap)
            if r < 0.20:
                track_of[p] = next_id  # a fresh id: a switch
                next_id += 1
            elif r < 0.25:
                q = int(rng.integers(n_people))
                track_of[p], track_of[q] = track_of[q], track_of[p]  # two people swap tracks
            noise = rng.integers(-3, 4, size=2) * lattice  # some beyond the gate
            tracks.append((k, int(track_of[p]), *(pos[p] + noise)))
        for _ in range(int(rng.poisson(0.7))):  # false tracks
            tracks.append((k, int(rng.integers(900, 905)), *(rng.integers(0, 16, size=2) * lattice)))
    t = pd.DataFrame(truth, columns=["frame", "person_id", "x", "y"])
    h = pd.DataFrame(tracks, columns=["frame", "track_id", "x", "y"]).drop_duplicates(["frame", "track_id"])
    return EvalFrames(np.arange(n_frames) * 0.1, t, h)


def motmetrics_summary(frames: EvalFrames, gate: float) -> dict:
    acc = mm.MOTAccumulator(auto_id=False)
    for k, ti, hi in frames.by_frame():
        o = frames.truth.iloc[ti]
        h = frames.tracks.iloc[hi]
        d = pairwise_distances(o[["x", "y"]].to_numpy(float), h[["x", "y"]].to_numpy(float))
        d[d > gate] = np.nan
        acc.update(o["person_id"].to_numpy(), h["track_id"].to_numpy(), d, frameid=k)
    mh = mm.metrics.create()
    s = mh.compute(acc, metrics=["mota", "motp", "num_switches", "idf1", "num_false_positives", "num_misses"], name="x")
    return s.iloc[0].to_dict()


@pytest.mark.parametrize("seed", range(25))
def test_equal_to_motmetrics(seed):
    rng = np.random.default_rng(seed)
    frames = random_scenario(rng)
    gate = float(rng.choice([0.5, 0.75, 1.0]))
    ours = clear_mot(frames, gate)
    ref = motmetrics_summary(frames, gate)
    assert ours.num_switches == ref["num_switches"]
    assert ours.fp == ref["num_false_positives"]
    assert ours.fn == ref["num_misses"]
    assert ours.mota == pytest.approx(ref["mota"], abs=1e-9)
    assert ours.motp == pytest.approx(ref["motp"], abs=1e-9)
    assert idf1(frames, gate).idf1 == pytest.approx(ref["idf1"], abs=1e-9)


def test_scenarios_exercise_switches_gaps_and_ties():
    """The generator does produce what the equivalence test claims to cover."""
    rng = np.random.default_rng(0)
    switches = misses = fps = ties = 0
    for _ in range(10):
        frames = random_scenario(rng)
        r = clear_mot(frames, 1.0)
        switches += r.num_switches
        misses += r.fn
        fps += r.fp
        for k, ti, hi in frames.by_frame():
            d = pairwise_distances(frames.truth.iloc[ti][["x", "y"]].to_numpy(float),
                                   frames.tracks.iloc[hi][["x", "y"]].to_numpy(float))
            ties += int(d.size - np.unique(d).size)
    assert switches > 10 and misses > 10 and fps > 10 and ties > 10
