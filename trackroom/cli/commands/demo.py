"""trackroom demo: the main job on the bundled scenes, end to end.

For each bundled scene: simulate a short analytic recording and write it (with a top-down
picture), run every registered estimator that applies to it, score the tracks against the
truth, and print the comparison table (also written as results.csv and summary.md).
"""
from __future__ import annotations

from pathlib import Path

from trackroom.cli.commands import add_plugin_argument

# Simulated seconds per scene: bearing-only scenes need about a minute for the person to cross
# several sparse views (Rahimi's office loop takes one minute); the others need less.
DURATIONS = {"bearing_hall": 60.0, "office_floor": 60.0, "overhead_lab": 20.0, "occlusion_lab": 20.0}
DEFAULT_DURATION = 20.0
# The target-plane tracker follows a target chosen by hand; with no one to click on, the demo
# runs its multi-person mode, which tracks every mover.
PARAMS = {"target_planes": {"multi_person": True}}

NAME = "demo"
HELP = "generate each bundled scene, run every applicable estimator, score, and print the summary table"


def add_arguments(p) -> None:
    p.add_argument("--out", help="folder for the demo's recordings, pictures and tables (default: a new temp folder)")
    p.add_argument("--duration", type=float, help="simulated seconds per scene (default: 60 for the bearing-only scenes, 20 for the others)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--scenes", help="comma-separated scene names (default: every bundled scene)")
    add_plugin_argument(p)


def run(args) -> int:
    import tempfile

    import pandas as pd

    from trackroom.estimators import available
    from trackroom.estimators.runner import run_estimator
    from trackroom.metrics.aggregate import summary_markdown
    from trackroom.metrics.score import evaluate
    from trackroom.scenes import load_scene
    from trackroom.scenes.loader import bundled_scenes
    from trackroom.errors import CommandError
    from trackroom.cli.commands.generate import generate_to, summary_line
    from trackroom.topdown import plot_recording

    if args.duration is not None and not args.duration > 0:
        raise CommandError(f"--duration must be positive, got {args.duration}")
    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="trackroom-demo-"))
    root.mkdir(parents=True, exist_ok=True)
    names = [s.strip() for s in args.scenes.split(",")] if args.scenes else bundled_scenes()
    rows = []
    for name in names:
        duration = args.duration or DURATIONS.get(name, DEFAULT_DURATION)
        rec, seconds, folder = generate_to(load_scene(name), args.seed, duration, "analytic", root / name, force=True)
        print(summary_line(rec, seconds, folder))
        print(f"  picture: {plot_recording(rec, folder / 'topdown.png')}")
        for est in available():
            r = run_estimator(rec, est, PARAMS.get(est, {}), errors="record")
            row = {"scene": rec.scene, "seed": rec.seed, "sensing": rec.sensing, "estimator": est,
                   "status": r.status, "reason": r.reason, "runtime_s": r.seconds}
            if r.status == "ok":
                r.tracks.to_csv(folder / f"tracks_{est}.csv", index=False, float_format="%.6f")
                row.update(evaluate(rec, r.tracks).metrics())
                print(f"  {est}: MOTA {row['mota']:.3f}, RMSE {row['rmse']:.3f} m, {r.seconds:.1f} s")
            else:
                print(f"  {est}: {r.status} ({r.reason})")
            rows.append(row)
    results = pd.DataFrame(rows)
    results.to_csv(root / "results.csv", index=False, float_format="%.6g")
    table = summary_markdown(results)
    (root / "summary.md").write_text(f"# Demo: seed {args.seed}, analytic sensing\n\n{table}\n")
    print()
    print(table)
    print(f"\ndemo output in {root}")
    return 0
