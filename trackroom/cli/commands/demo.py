"""trackroom demo: the main job on the bundled scenes, end to end.

For each bundled scene: simulate a short analytic recording and write it (with a top-down
picture), run every registered estimator that applies to it, score the tracks against the
truth, and print the comparison table (also written as results.csv and summary.md).

The demo folder is built in a hidden sibling (``.NAME.partial-PID``) and renamed when complete, so
an interrupted demo (Ctrl-C, ``demo | head -1`` closing the pipe) leaves no partial folder.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

from trackroom.cli.commands import add_plugin_argument

# Simulated seconds per scene: the wandering bearing-only scenes need about a minute for the person
# to cross several sparse views (Rahimi's office loop takes one minute); the others need less
# (bearing_corridor's walker passes its three cameras in 20 s and would reach the far end soon after).
DURATIONS = {"bearing_hall": 60.0, "office_floor": 60.0, "bearing_corridor": 20.0, "overhead_lab": 20.0,
             "occlusion_lab": 20.0}
DEFAULT_DURATION = 20.0
# The target-plane tracker follows a target chosen by hand; with no one to click on, the demo
# runs its multi-person mode, which tracks every mover.
PARAMS = {"target_planes": {"multi_person": True}}

NAME = "demo"
HELP = "generate each bundled scene, run every applicable estimator, score, and print the summary table"


def add_arguments(p) -> None:
    p.add_argument("--out", help="folder for the demo's recordings, pictures and tables (default: a new temp folder)")
    p.add_argument("--duration", type=float, help="simulated seconds per scene (default: 60 for bearing_hall and office_floor, 20 for the others)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--scenes", help="comma-separated scene names (default: every bundled scene)")
    add_plugin_argument(p)


def run(args) -> int:
    import tempfile

    from trackroom.cli.commands.generate import check_duration
    from trackroom.dataset import clean_leftovers
    from trackroom.errors import CommandError

    if args.duration is not None:
        check_duration(args.duration)
    if args.out:
        root = Path(args.out).resolve()
        # the whole folder is replaced at the end: only ever an empty one or an earlier demo's
        if root.exists() and any(root.iterdir()) and not (root / "summary.md").is_file():
            raise CommandError(f"{args.out}: folder exists and is not an earlier demo's output; choose a new --out")
    else:
        root = Path(tempfile.mkdtemp(prefix="trackroom-demo-"))
        root.rmdir()  # only the unique name is wanted: the folder appears, complete, at the end
    root.parent.mkdir(parents=True, exist_ok=True)
    clean_leftovers(root)
    work = root.parent / f".{root.name}.partial-{os.getpid()}"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    try:
        table = _run_demo(args, work, root)
        if root.exists():
            aside = root.parent / f".{root.name}.old-{os.getpid()}"
            root.rename(aside)
            work.rename(root)
            shutil.rmtree(aside, ignore_errors=True)
        else:
            work.rename(root)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    print()
    print(table)
    print(f"\ndemo output in {root}")
    return 0


def _run_demo(args, work: Path, root: Path) -> str:
    """Generate, estimate and score into ``work`` (renamed to ``root`` when done); the table."""
    import pandas as pd

    from trackroom.cli.commands.generate import generate_to, summary_line
    from trackroom.estimators import available
    from trackroom.estimators.runner import run_estimator
    from trackroom.metrics.aggregate import summary_markdown
    from trackroom.metrics.score import evaluate
    from trackroom.scenes import load_scene
    from trackroom.scenes.loader import bundled_scenes
    from trackroom.topdown import plot_recording

    names = [s.strip() for s in args.scenes.split(",")] if args.scenes else bundled_scenes()
    command = getattr(args, "_command", None)
    rows = []
    for name in names:
        duration = args.duration or DURATIONS.get(name, DEFAULT_DURATION)
        rec, seconds, folder = generate_to(load_scene(name), args.seed, duration, "analytic", work / name, force=True,
                                           command=command)
        # progress lines are flushed as they come (a reader sees them while the demo runs)
        print(summary_line(rec, seconds, root / name), flush=True)
        plot_recording(rec, folder / "topdown.png")
        print(f"  picture: {root / name / 'topdown.png'}", flush=True)
        for est in available():
            r = run_estimator(rec, est, PARAMS.get(est, {}), errors="record")
            row = {"scene": rec.scene, "seed": rec.seed, "sensing": rec.sensing, "estimator": est,
                   "status": r.status, "reason": r.reason, "runtime_s": r.seconds}
            if r.status == "ok":
                r.tracks.to_csv(folder / f"tracks_{est}.csv", index=False, float_format="%.6f")
                row.update(evaluate(rec, r.tracks).metrics())
                print(f"  {est}: MOTA {row['mota']:.3f}, HOTA {row['hota']:.3f}, RMSE {row['rmse']:.3f} m, {r.seconds:.1f} s", flush=True)
            else:
                print(f"  {est}: {r.status} ({r.reason})", flush=True)
            rows.append(row)
    results = pd.DataFrame(rows)
    results.to_csv(work / "results.csv", index=False, float_format="%.6g")
    table = summary_markdown(results)
    (work / "summary.md").write_text(f"# Demo: seed {args.seed}, analytic sensing\n\n{table}\n")
    return table
