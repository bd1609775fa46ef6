"""Record TrackEval's HOTA on the random scenarios of tests/test_hota_trackeval.py.

    pip install --no-deps "trackeval>=1.3"      # its own dependencies would add a second OpenCV
    python -m scripts.record_hota_trackeval       # writes tests/data/hota_trackeval.json

The test compares ``metrics.hota`` with TrackEval live when trackeval is installed, and with this
file always. Each scenario is rebuilt from its seed, so the file holds the seeds, the gate, a
checksum of the scenario (to notice a changed generator) and TrackEval's figures (means over
alpha of HOTA, DetA, AssA, LocA, DetRe, DetPr, AssRe, AssPr, as its summary reports them).

Scenarios (``random_scenario``): 1-7 people in a 2-6 m room for 40 frames, with misses, false
tracks, fresh ids, two people swapping tracks, people leaving and coming back, frames with nobody
and nothing, frames with tracks but no truth and with truth but no tracks; continuous positions
(people crowd within a gate of each other, so frames need the Hungarian step) or, every third
scenario, a 0.25 m lattice (ties: equal similarities, some exactly on an alpha threshold).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import platform
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pandas as pd

import sys
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.metrics.mot import EvalFrames, pairwise_distances

FIXTURE = Path(__file__).resolve().parents[1] / "tests" / "data" / "hota_trackeval.json"
SEEDS = range(24)
GATES = (0.5, 0.75, 1.0, 1.5)
# our name -> TrackEval's field
FIELDS = {"hota": "HOTA", "deta": "DetA", "assa": "AssA", "loca": "LocA",
          "detre": "DetRe", "detpr": "DetPr", "assre": "AssRe", "asspr": "AssPr"}


def random_scenario(rng: np.random.Generator, n_frames: int = 40, lattice: bool = False) -> EvalFrames:
    """Truth and tracks of one random scenario (module docstring)."""
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
        alive ^= rng.random(n_people) < 0.05  # people leave and come back
        kind = rng.random()
        if kind < 0.08:
            continue  # nobody and nothing
        no_tracks = kind < 0.14
        no_truth = 0.14 <= kind < 0.20
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


def scenario(seed: int) -> tuple[EvalFrames, float]:
    """Scenario ``seed`` (a lattice one when seed % 3 == 2) and its gate (m)."""
    rng = np.random.default_rng(seed)
    frames = random_scenario(rng, lattice=seed % 3 == 2)
    return frames, float(rng.choice(GATES))


def checksum(frames: EvalFrames) -> list[float]:
    """Rows and coordinate sums of truth and tracks: a changed generator changes these."""
    return [len(frames.truth), len(frames.tracks),
            round(float(frames.truth[["x", "y"]].to_numpy(float).sum()), 9),
            round(float(frames.tracks[["x", "y"]].to_numpy(float).sum()), 9)]


def trackeval_hota(frames: EvalFrames, gate: float) -> dict[str, float]:
    """TrackEval's HOTA for one sequence, given max(0, 1 - d / gate) per frame; means over alpha."""
    with contextlib.redirect_stdout(io.StringIO()):  # trackeval prints a line about optional datasets
        from trackeval.metrics import HOTA
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=FIXTURE)
    args = ap.parse_args(argv)
    rows = []
    for seed in SEEDS:
        frames, gate = scenario(seed)
        rows.append({"seed": seed, "gate": gate, "checksum": checksum(frames), "trackeval": trackeval_hota(frames, gate)})
    doc = {"what": "TrackEval's HOTA on scripts/record_hota_trackeval.py's scenarios (rerun it to re-record)",
           "trackeval": version("trackeval"), "numpy": np.__version__, "python": platform.python_version(),
           "scenarios": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps(doc, indent=1) + "\n")
    tmp.replace(args.out)
    print(f"wrote {len(rows)} scenarios to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
