"""trackroom generate: simulate a scene and write a recording folder."""
from __future__ import annotations

import time

NAME = "generate"
HELP = "simulate a scene (bundled name or TOML file) and write a recording folder"


def add_arguments(p) -> None:
    p.add_argument("scene", help="bundled scene name (e.g. overhead_lab) or a path to a scene TOML file")
    p.add_argument("--seed", type=int, default=0, help="random seed (same scene and seed give the same recording)")
    p.add_argument("--duration", type=float, default=60.0, help="simulated seconds (default 60)")
    p.add_argument("--sensing", choices=["analytic", "rendered"], default="analytic")
    p.add_argument("--out", required=True, help="output folder (written atomically)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field, e.g. --set walkers.count=10 (repeatable)")
    p.add_argument("--save-frames", action="store_true", help="rendered mode: also write an MP4 per camera")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    from trackroom.scenes import load_scene
    from trackroom.errors import CommandError

    if args.duration <= 0:
        raise CommandError(f"--duration must be positive, got {args.duration}")
    if args.save_frames and args.sensing != "rendered":
        raise CommandError("--save-frames needs --sensing rendered")
    scene = load_scene(args.scene, args.overrides)
    rec, seconds, out = generate_to(scene, args.seed, args.duration, args.sensing, args.out,
                                    save_frames=args.save_frames, force=args.force, progress=not args.quiet)
    print(summary_line(rec, seconds, out))
    return 0


def generate_to(scene, seed, duration, sensing, out, save_frames=False, force=False, progress=False):
    """Simulate and write; returns (recording, wall seconds, folder)."""
    import tempfile
    from pathlib import Path

    from trackroom.errors import CommandError
    from trackroom.dataset import write_recording
    from trackroom.sim.simulate import simulate

    if Path(out).exists() and not force:
        raise CommandError(f"{out}: output folder exists (use --force to replace it)")
    t0 = time.perf_counter()
    frames_dir = Path(tempfile.mkdtemp(prefix="trackroom-frames-")) if save_frames else None
    rec = simulate(scene, seed=seed, duration=duration, sensing=sensing, progress=progress, save_frames=frames_dir)
    folder = write_recording(rec, out, overwrite=force, extra_dirs={"frames": frames_dir})
    return rec, time.perf_counter() - t0, folder


def summary_line(rec, seconds: float, out) -> str:
    counts = ", ".join(f"{k} {len(v)}" for k, v in rec.observations.tables.items())
    people = rec.truth.people["person_id"].nunique()
    speed = rec.duration / seconds if seconds > 0 else float("inf")
    return (f"{rec.scene} seed {rec.seed}: {rec.duration:g} s, {people} {'person' if people == 1 else 'people'}, {rec.sensing} sensing -> {out}\n"
            f"  rows: {counts}\n  took {seconds:.1f} s ({speed:.0f}x real time)")
