"""How near two movers come: the closest approach of their centres in a recording's truth.

    python -m scripts.measure_encounters DIR [DIR ...]                 # recordings (either mode)
    python -m scripts.measure_encounters --seeds 1920,1932 [--set KEY=VALUE ...]   # occlusion_lab, simulated

For each recording and each pair of movers (``--people``, by default the scene's target and
look-alike): the smallest distance between their floor centres (m) and when, and the number of
time (s: truth samples times the sampling interval) with the centres nearer than the sum of their
radii (the two bodies overlap) and nearer than that plus the walker planner's personal space
(``sim/walkers.PERSONAL_SPACE``).

The walker planner keeps that space between people by waiting or re-drawing a leg, but after
``MAX_TRIES`` it takes the leg anyway: two scripted walkers meeting head-on on one lane (the
head-on variant, ``--set`` below) pass through each other. At such samples "the output's nearest
true person", the identity measure, cannot tell the two apart, and a tracker's rule that two
bodies are never nearer than two radii is false (issue 12's forty-seventh session). The truth is
read here, by the experimenter. ``--seeds`` simulates the analytic recording for the truth only
(the walkers do not depend on the sensing):

    python -m scripts.measure_encounters --seeds 1920,1932 --set 'walkers.people.1.waypoints=[[1.0, 1.2], [5.0, 1.2], [7.8, 4.0], [6.5, 6.3], [3.0, 6.3], [1.0, 4.0]]'
"""
from __future__ import annotations

import argparse
import itertools
import tomllib

import numpy as np
import pandas as pd

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import recording_folders
from trackroom.scenes.loader import load_scene, parse_scene
from trackroom.sim.walkers import PERSONAL_SPACE

MOVERS = ("target", "distractor")


def encounters(people: pd.DataFrame, radii: dict[str, float], names=MOVERS,
               personal_space: float = PERSONAL_SPACE) -> pd.DataFrame:
    """For each pair of ``names`` in a truth people table (t, person_id, x, y): the closest
    approach of the centres (``d_min``, m) and its time (``t_min``, s), and how long (s: their
    common samples times the median sampling interval) the centres are nearer than r_i + r_j
    (``overlap_s``) and than r_i + r_j + ``personal_space`` (``inside_space_s``). A pair not both
    in the table is left out."""
    rows = []
    for a, b in itertools.combinations(names, 2):
        pa = people.loc[people.person_id == a, ["t", "x", "y"]]
        pb = people.loc[people.person_id == b, ["t", "x", "y"]]
        both = pa.merge(pb, on="t", suffixes=("_a", "_b"))
        if both.empty:
            continue
        d = np.hypot(both.x_a.to_numpy(float) - both.x_b.to_numpy(float), both.y_a.to_numpy(float) - both.y_b.to_numpy(float))
        k = int(np.argmin(d))
        touch = radii[a] + radii[b]
        times = both.t.to_numpy(float)
        dt = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
        rows.append((a, b, float(d[k]), float(times[k]), dt * int((d < touch).sum()), dt * int((d < touch + personal_space).sum())))
    return pd.DataFrame(rows, columns=["a", "b", "d_min", "t_min", "overlap_s", "inside_space_s"])


def radii_of(scene) -> dict[str, float]:
    """Each walker's body radius (m), by name."""
    return {w.name: float(w.radius) for w in scene.walkers}


def _recordings(args):
    """(label, people table, radii) for each recording asked for."""
    from trackroom.dataset import read_recording

    for path in recording_folders(args.dirs, "measure_encounters"):
        rec = read_recording(path)
        if rec.scene_toml is None:
            raise SystemExit(f"measure_encounters: {path} has no scene file: the people's radii are unknown")
        scene = parse_scene(tomllib.loads(rec.scene_toml), source=path)
        yield path, rec.truth.people, radii_of(scene)
    if args.seeds:
        from trackroom.sim.simulate import simulate

        scene = load_scene(args.scene, args.set or None)
        for seed in args.seeds:
            rec = simulate(scene, seed=seed, duration=args.duration, sensing="analytic")
            yield f"{args.scene} seed {seed}", rec.truth.people, radii_of(scene)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="*", metavar="DIR", help="recording folders (globs allowed)")
    ap.add_argument("--seeds", type=lambda s: [int(x) for x in s.split(",") if x.strip()], default=[],
                    help="comma-separated seeds to simulate (analytic, for the truth)")
    ap.add_argument("--scene", default="occlusion_lab", help="the scene simulated with --seeds")
    ap.add_argument("--set", action="append", metavar="KEY=VALUE", help="a scene override for --seeds (repeatable)")
    ap.add_argument("--duration", type=float, default=35.0, help="seconds simulated with --seeds")
    ap.add_argument("--people", default=",".join(MOVERS), help="comma-separated walker names (default: target,distractor)")
    args = ap.parse_args(argv)
    if not args.dirs and not args.seeds:
        ap.error("give recording folders or --seeds")
    names = tuple(n.strip() for n in args.people.split(",") if n.strip())
    if len(names) < 2:
        ap.error("--people needs at least two walker names")
    rows = []
    for label, people, radii in _recordings(args):
        missing = [n for n in names if n not in radii]
        if missing:
            raise SystemExit(f"measure_encounters: {label}: no walker named {', '.join(missing)} (walkers: {', '.join(radii)})")
        for r in encounters(people, radii, names).itertuples(index=False):
            rows.append((label, r.a, r.b, r.d_min, r.t_min, r.overlap_s, r.inside_space_s))
    tab = pd.DataFrame(rows, columns=["recording", "a", "b", "d_min", "t_min", "overlap_s", "inside_space_s"])
    print(tab.to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    n = tab.recording.nunique()
    print(f"{n} recordings; pairs whose bodies overlap (centres nearer than the sum of the radii): "
          f"{int((tab.overlap_s > 0).sum())} of {len(tab)}; closest approach {tab.d_min.min():.2f}-{tab.d_min.max():.2f} m")


if __name__ == "__main__":
    main()
