"""trackroom generate: simulate a scene and write a recording folder.

The folder is written atomically (``trackroom.dataset.write_recording``); its manifest records the
command line, every ``--set`` override, the resolved scene (``scene.toml``) and its hash.
"""
from __future__ import annotations

import contextlib
import gc
import math
import os
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
    p.add_argument("--render-workers", type=int, default=None, metavar="N",
                   help="rendered mode: threads for perception, labels and video (default: $TRACKROOM_RENDER_WORKERS, "
                        "else the available cores; 0: none; the recording does not depend on it)")
    p.add_argument("--perception-draw", type=int, default=0, metavar="K",
                   help="analytic mode: K > 0 redraws only the camera tables' random streams (the same walkers, "
                        "phones and click; simulate's perception_draw, as experiment_tsutsui --draw K); 0: the seed's own")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    # numpy backs large arrays with transparent huge pages by default; on this project's VMs the
    # kernel's work for them cost ~0.3 s of system time in a 10-minute analytic run (sys 0.45-0.56 s
    # without, 0.73-0.84 s with; the same user time): off unless the caller chose (effective only
    # before numpy loads, i.e. from the command line)
    os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    keep_freed_memory()
    with imports_without_gc():
        from trackroom.scenes import load_scene
        from trackroom.errors import CommandError

        check_duration(args.duration)
        if args.save_frames and args.sensing != "rendered":
            raise CommandError("--save-frames needs --sensing rendered")
        workers = None
        if args.sensing == "rendered":
            from trackroom.sim.rendered import worker_count

            try:
                workers = worker_count(args.render_workers, "--render-workers")
            except ValueError as e:
                raise CommandError(str(e)) from None
        elif args.render_workers is not None:
            raise CommandError("--render-workers needs --sensing rendered")
        draw = args.perception_draw
        if draw < 0:
            raise CommandError(f"--perception-draw must be a whole number >= 0, got {draw}")
        if draw and args.sensing != "analytic":
            raise CommandError("--perception-draw needs --sensing analytic (it redraws the analytic camera tables)")
        scene = load_scene(args.scene, args.overrides)
        import trackroom.dataset, trackroom.sim.simulate  # noqa: E401,F401  (imported here, with the collector off)
    rec, seconds, out = generate_to(scene, args.seed, args.duration, args.sensing, args.out,
                                    save_frames=args.save_frames, force=args.force, progress=not args.quiet,
                                    command=getattr(args, "_command", None), render_workers=workers, perception_draw=draw)
    print(summary_line(rec, seconds, out))
    # and whatever the run left, out of the collections the interpreter runs on its way out: with
    # the libraries' objects unfrozen those took ~1 s of wall time (0.3-0.5 s of CPU) after the
    # recording was written (under load; gc.collect() alone 0.26 s)
    gc.freeze()
    return 0


@contextlib.contextmanager
def imports_without_gc():
    """The cyclic garbage collector off while the command imports its libraries, which then are
    frozen (``gc.freeze``: never scanned again). Imports create ~10^5 long-lived objects and no
    garbage to speak of, yet each gathering of 700 new objects started a collection, and the
    full ones walked every object loaded so far: 0.13-0.29 s of collections in a 10-minute
    analytic run (two full passes, 0.07-0.16 s, and ~360 young ones), CPU and wall alike."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


def keep_freed_memory() -> None:
    """Ask glibc's malloc to keep freed memory for the next allocations instead of returning it to
    the kernel. By default an array above its (adaptive, at most 32 MiB) mmap threshold gets fresh
    pages from the kernel, which zeroes each one on first touch, and a freed one is unmapped:
    a 10-minute analytic run allocated and faulted in ~800 MB this way (200 k page faults; 9 % of
    its CPU samples in the kernel's page clearing). With the threshold raised, freed arrays are
    reused (the same run: 140 k faults; peak memory 650 -> 720 MB). Memory only: no results change."""
    import ctypes

    try:
        if not os.confstr("CS_GNU_LIBC_VERSION").startswith("glibc"):  # (platform.libc_ver reads the binary: 20 ms)
            return
        libc = ctypes.CDLL("libc.so.6")
    except (AttributeError, ValueError, OSError):  # no confstr (Windows), no such name, no such library
        return
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # malloc.h
    libc.mallopt(M_MMAP_THRESHOLD, 256 << 20)  # arrays below 256 MiB from the heap
    libc.mallopt(M_TRIM_THRESHOLD, 512 << 20)  # the heap's free top kept up to 512 MiB


def check_duration(duration: float, option: str = "--duration") -> None:
    """A duration (s) must be a positive, finite number; else one CommandError line."""
    from trackroom.errors import CommandError

    if not (math.isfinite(duration) and duration > 0):
        raise CommandError(f"{option} must be positive and finite (seconds), got {duration:g}")


def generate_to(scene, seed, duration, sensing, out, save_frames=False, force=False, progress=False, command=None,
                render_workers=None, perception_draw=0):
    """Simulate and write; returns (recording, wall seconds, folder). Refuses, before simulating, a
    folder that exists (without ``force``) and a simulation that would exhaust memory.
    ``render_workers``: the rendered mode's worker threads (``sim.rendered.worker_count``);
    ``perception_draw``: ``simulate``'s (analytic camera tables redrawn; 0: the seed's own)."""
    import shutil
    import tempfile
    from pathlib import Path

    from trackroom.errors import CommandError
    from trackroom.dataset import write_recording
    from trackroom.sim.simulate import memory_problem, simulate

    check_duration(duration)
    if Path(out).exists() and not force:
        raise CommandError(f"{out}: output folder exists (use --force to replace it)")
    problem = memory_problem(scene, duration, sensing)
    if problem:
        raise CommandError(problem)
    t0 = time.perf_counter()
    frames_dir = Path(tempfile.mkdtemp(prefix="trackroom-frames-")) if save_frames else None
    try:
        rec = simulate(scene, seed=seed, duration=duration, sensing=sensing, progress=progress, save_frames=frames_dir,
                       render_workers=render_workers, perception_draw=perception_draw)
        folder = write_recording(rec, out, overwrite=force, extra_dirs={"frames": frames_dir}, command=command)
    finally:
        if frames_dir is not None and frames_dir.exists():
            shutil.rmtree(frames_dir, ignore_errors=True)  # moved into the recording, or left by a failure
    return rec, time.perf_counter() - t0, folder


def summary_line(rec, seconds: float, out) -> str:
    counts = ", ".join(f"{k} {len(v)}" for k, v in rec.observations.tables.items())
    people = rec.truth.people["person_id"].nunique()
    ratio = rec.duration / seconds if seconds > 0 else float("inf")
    speed = f"{ratio:.0f}" if ratio >= 10 else f"{ratio:.2g}"  # a rendered run is slower than real time: 0.29x, not 0x
    return (f"{rec.scene} seed {rec.seed}: {rec.duration:g} s, {people} {'person' if people == 1 else 'people'}, {rec.sensing} sensing -> {out}\n"
            f"  rows: {counts}\n  took {seconds:.1f} s ({speed}x real time)")
