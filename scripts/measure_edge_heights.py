"""The flow windows' edge errors by the person's image height, rendered against analytic.

    python scripts/measure_edge_heights.py DIR [DIR ...] [--draw N]   # rendered occlusion_lab recordings

For each rendered recording, ``perception_fit.measure`` matches every oblique camera's windows to
the people's projected windows (cut at the floor plan's boxes) and keeps, for each window of one
person, its four edges' errors in px, by the height bin of that person's projected window
(``analytic_detectors.EDGE_HEIGHT_PX``: under 60 px, 60-100, 100 and more). The recording's
analytic twin (the same scene and seed, perception draw ``--draw``, simulated with the bundled
model, or ``--model``) is measured the same way. Printed per bin: how many windows, and each edge's 5th and
95th percentiles (plain and crowded windows pooled, as the bundled fit pools them; windows a box
cuts have tables of their own and are left out). The rendered edges' errors grow with the image;
a model with one table per edge draws the same errors on every size (docs/sensing.md, "Where the
excess comes from"); the thirteenth fit's tables are per bin (not bundled: docs/sensing.md, "What
the thirteenth fit tried")."""
import argparse
from pathlib import Path

import numpy as np

import sys
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.scenes.loader import load_scene
from trackroom.sim import perception_fit as pf
from trackroom.sim.analytic_detectors import EDGE_HEIGHT_PX, height_table
from trackroom.sim.simulate import simulate

EDGES = ("v_top", "v_bottom", "u_left", "u_right")


def by_bin(errors: dict, name: str, k: int) -> np.ndarray:
    """Edge ``name``'s errors (px) of the plain and crowded windows of height bin k."""
    return np.r_[errors.get(height_table(name, k), []), errors.get(height_table(name + "_crowded", k), [])]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR", help="rendered recording folders (globs allowed)")
    ap.add_argument("--draw", type=int, default=0, help="the analytic twins' perception draw (default 0)")
    ap.add_argument("--model", help="the analytic twins' perception model file (default: the bundled model)")
    args = ap.parse_args(argv)
    stats = {"rendered": [], "analytic": []}
    for d in recording_folders(args.recordings, "measure_edge_heights"):
        d = Path(d)
        rec = read_recording(d)
        if rec.meta.get("sensing") != "rendered":
            raise SystemExit(f"{d}: a {rec.meta.get('sensing')} recording; give rendered ones")
        scene = load_scene(d / "scene.toml")
        twin = load_scene(d / "scene.toml", [f"sensors.perception={args.model}"]) if args.model else scene
        seed, duration = int(rec.meta["seed"]), float(rec.meta["duration"])
        feats = pf.scene_features(scene, seed, duration)
        stats["rendered"].append(pf.measure(rec, scene, feats))
        stats["analytic"].append(pf.measure(simulate(twin, seed, duration, perception_draw=args.draw), scene, feats))
    bounds = (0.0, *EDGE_HEIGHT_PX, np.inf)
    print("| person's image height | mode | windows | " + " | ".join(f"{c} q5 / q95 (px)" for c in EDGES) + " |")
    print("| --- " * (3 + len(EDGES)) + "|")
    for k in range(len(EDGE_HEIGHT_PX) + 1):
        for mode, many in stats.items():
            e = pf.merge_stats(many)["windows"].errors
            cells = [f"{np.quantile(x, 0.05):+.1f} / {np.quantile(x, 0.95):+.1f}" if len(x) else "-"
                     for x in (by_bin(e, c, k) for c in EDGES)]
            print(f"| {bounds[k]:g}-{bounds[k + 1]:g} | {mode} | {len(by_bin(e, 'v_top', k))} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
