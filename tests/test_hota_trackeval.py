"""Our HOTA equals TrackEval's (``trackeval.metrics.HOTA``, PyPI trackeval 1.3) on the same inputs.

TrackEval takes, per frame, the truth and track ids present (as indices 0..n-1) and a similarity
matrix; it is given max(0, 1 - d / gate) from the same distances (``pairwise_distances``) that
``metrics.hota`` computes, and its per-alpha arrays are averaged over alpha as its summary does.
Random scenarios have misses, false tracks, fresh ids and two people swapping tracks, people
leaving and coming back, frames with nobody and nothing, frames with tracks but no truth, frames
with truth but no tracks; continuous positions (some people crowded within a gate of each other,
so frames need the Hungarian step) and lattice positions (ties: equal similarities, some exactly
on an alpha threshold). Skipped without trackeval.
"""
from __future__ import annotations

import contextlib
import io

import numpy as np
import pandas as pd
import pytest

from trackroom.metrics.hota import hota
from trackroom.metrics.mot import EvalFrames, pairwise_distances

trackeval = pytest.importorskip("trackeval")
with contextlib.redirect_stdout(io.StringIO()):  # trackeval prints a line about optional datasets
    from trackeval.metrics import HOTA

FIELDS = {"hota": "HOTA", "deta": "DetA", "assa": "AssA", "loca": "LocA",
          "detre": "DetRe", "detpr": "DetPr", "assre": "AssRe", "asspr": "AssPr"}


def random_scenario(rng: np.random.Generator, n_frames: int = 40, lattice: bool = False) -> EvalFrames:
    n_people = int(rng.integers(1, 8))
    room = 2.0 + 4.0 * rng.random()  # small rooms crowd people within a gate of each other
    pos = rng.uniform(0, room, size=(n_people, 2))
    if lattice:
        pos = np.round(pos * 4) / 4
    alive = np.ones(n_people, bool)
    track_of = np.arange(n_people) + 100
    next_id = 200
    truth, tracks = [], []
    for k in range(n_frames):
        step = rng.integers(-1, 2, size=pos.shape) * 0.25 if lattice else rng.normal(0, 0.15, size=pos.shape)
        pos = pos + step
        alive ^= rng.random(n_people) < 0.05
        kind = rng.random()
        if kind < 0.08:
            continue  # nobody and nothing
        no_tracks = kind < 0.14  # truth, no tracks
        no_truth = 0.14 <= kind < 0.20  # tracks, no truth
        for p in range(n_people):
            if not alive[p]:
                continue
            if not no_truth:
                truth.append((k, p, *pos[p]))
            r = rng.random()
            if no_tracks or r < 0.12:
                continue  # missed
            if r < 0.17:
                track_of[p] = next_id  # a fresh id
                next_id += 1
            elif r < 0.22:
                q = int(rng.integers(n_people))
                track_of[p], track_of[q] = track_of[q], track_of[p]  # two people swap tracks
            noise = rng.integers(-3, 4, size=2) * 0.25 if lattice else rng.normal(0, 0.35, size=2)
            tracks.append((k, int(track_of[p]), *(pos[p] + noise)))
        if not no_tracks:
            for _ in range(int(rng.poisson(0.6))):  # false tracks
                xy = rng.uniform(0, room, size=2)
                tracks.append((k, int(rng.integers(900, 905)), *(np.round(xy * 4) / 4 if lattice else xy)))
    t = pd.DataFrame(truth, columns=["frame", "person_id", "x", "y"])
    h = pd.DataFrame(tracks, columns=["frame", "track_id", "x", "y"]).drop_duplicates(["frame", "track_id"])
    return EvalFrames(np.arange(n_frames) * 0.1, t, h)


def trackeval_hota(frames: EvalFrames, gate: float) -> dict[str, float]:
    """TrackEval's HOTA summary (means over alpha) for one sequence."""
    o_idx, o_ids = pd.factorize(frames.truth["person_id"])
    h_idx, h_ids = pd.factorize(frames.tracks["track_id"])
    t_xy = frames.truth[["x", "y"]].to_numpy(float)
    h_xy = frames.tracks[["x", "y"]].to_numpy(float)
    data = {"gt_ids": [], "tracker_ids": [], "similarity_scores": [],
            "num_gt_dets": len(frames.truth), "num_tracker_dets": len(frames.tracks),
            "num_gt_ids": len(o_ids), "num_tracker_ids": len(h_ids)}
    for _, ti, hi in frames.by_frame():
        d = pairwise_distances(t_xy[ti], h_xy[hi])
        data["gt_ids"].append(o_idx[ti])
        data["tracker_ids"].append(h_idx[hi])
        data["similarity_scores"].append(np.maximum(0.0, 1.0 - d / gate))
    res = HOTA().eval_sequence(data)
    return {ours: float(np.mean(res[theirs])) for ours, theirs in FIELDS.items()}


def check_equal(frames: EvalFrames, gate: float) -> dict[str, float]:
    ours = hota(frames, gate).metrics()
    ref = trackeval_hota(frames, gate)
    for k in FIELDS:
        assert ours[k] == pytest.approx(ref[k], abs=1e-9), k
    return ours


@pytest.mark.parametrize("seed", range(24))
def test_equal_to_trackeval(seed):
    rng = np.random.default_rng(seed)
    frames = random_scenario(rng, lattice=seed % 3 == 2)
    check_equal(frames, float(rng.choice([0.5, 0.75, 1.0, 1.5])))


def _frames(truth, tracks, n=3):
    return EvalFrames(np.arange(n) * 0.1, pd.DataFrame(truth, columns=["frame", "person_id", "x", "y"]),
                      pd.DataFrame(tracks, columns=["frame", "track_id", "x", "y"]))


@pytest.mark.parametrize("truth,tracks", [
    ([], []),  # nothing at all
    ([(0, "a", 0.0, 0.0), (1, "a", 0.1, 0.0)], []),  # no tracks
    ([], [(0, 1, 0.0, 0.0), (2, 1, 0.0, 0.0)]),  # no truth
    ([(0, "a", 0.0, 0.0)], [(1, 1, 0.0, 0.0)]),  # never in the same frame
    ([(0, "a", 0.0, 0.0)], [(0, 1, 5.0, 0.0)]),  # together but beyond the gate
])
def test_empty_cases_equal_trackeval(truth, tracks):
    ours = check_equal(_frames(truth, tracks), 1.0)
    assert ours["hota"] == ours["deta"] == ours["assa"] == 0.0 and ours["loca"] == 1.0


def test_scenarios_exercise_what_the_test_claims():
    """The generator gives empty frames, one-sided frames, ties on an alpha, and Hungarian frames."""
    rng = np.random.default_rng(0)
    empty = no_truth = no_tracks = crowded = on_alpha = 0
    for i in range(12):
        frames = random_scenario(rng, lattice=i % 3 == 2)
        t_xy = frames.truth[["x", "y"]].to_numpy(float)
        h_xy = frames.tracks[["x", "y"]].to_numpy(float)
        for _, ti, hi in frames.by_frame():
            empty += not len(ti) and not len(hi)
            no_truth += not len(ti) and bool(len(hi))
            no_tracks += bool(len(ti)) and not len(hi)
            s = np.maximum(0.0, 1.0 - pairwise_distances(t_xy[ti], h_xy[hi]) / 1.0)
            crowded += bool(((s > 0).sum(axis=0) > 1).any() or ((s > 0).sum(axis=1) > 1).any())
            on_alpha += int(np.isin(np.round(s, 12), [0.25, 0.5, 0.75]).sum())
    assert min(empty, no_truth, no_tracks) > 5 and crowded > 50 and on_alpha > 20
