"""Benchmark: bare MuJoCo rendering vs the full rendered pipeline, and frames/s against workers.

    python scripts/bench_render.py [--scene overhead_lab] [--seconds 5] [--repeat 3] [--workers 0,1,2]
                                   [--generate 60]

All passes use the same world, the same camera frames (the clip's schedule) and the same
``SceneRenderer`` code; each pass is preceded by a warm-up on the first ``--warmup`` steps
(renderer and GL context creation, first-touch allocations), which is excluded. Passes:
1. bare RGB: pose the world and ``Renderer.render()`` RGB for every camera frame.
2. bare RGB + segmentation: the two renders the pipeline needs (segmentation -> truth labels),
   one after the other (``SceneRenderer.segment``), as the pipeline draws them.
3. pipeline: ``sim.rendered.observe`` on the same frames (renders, perception, labels, MP4
   writing) for every worker count of ``--workers`` (default: 0, then 1, 2, 4, 8, 16 up to the
   available cores; 0 = all in the rendering thread); the default count is the available cores.
4. post-render work alone: ``sim.rendered.FrameWork`` (perception, labels, MP4) on frames rendered
   beforehand, for the same worker counts: what the pipeline could reach if rendering cost
   nothing (a GPU renders overhead_lab's frames at thousands per second), i.e. how the CPU side
   scales with threads.
The passes are interleaved and repeated ``--repeat`` times; the median of each is reported with
every run, the load average (other users of the machine add time and noise) and the CPU time of
the process's threads, which other users disturb much less than wall time.
Ratios: pipeline / bare RGB + segmentation (the issue's target <= 1.5) and pipeline / bare RGB.
``--generate S``: also times ``simulate(scene, duration=S, sensing="rendered")`` end to end
(walkers, IMUs, rendering; target < 5 min for a 60 s overhead_lab with 5 walkers).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from dataclasses import fields, replace
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from trackroom.scenes.loader import load_scene  # noqa: E402
from trackroom.sim.render import SceneRenderer, VideoSink  # noqa: E402
from trackroom.sim.rendered import (FrameWork, _pose, camera_schedule, check_cameras, observe,  # noqa: E402
                                    pose_snapshot, worker_count, world_maps)
from trackroom.sim.walkers import plan_trajectories  # noqa: E402
from trackroom.sim.world import build_world  # noqa: E402


def bare(world, scene, traj, segment: bool, warmup: int) -> tuple[float, float, int]:
    """Wall seconds, CPU seconds (every thread of the process) and frames of bare rendering: RGB, and segmentation if ``segment``."""
    model, data, cam_ids, person_geoms = world_maps(world, scene)
    check_cameras(model, scene, cam_ids)
    r = SceneRenderer(model, np.asarray(world.geom_person, np.int16), shadows=scene.render.shadows)
    schedule = list(camera_schedule(scene, traj).items())

    def run(steps) -> int:
        n = 0
        for k, due in steps:
            _pose(world, traj, k)
            for cam, _ in due:
                rr = r.renderer(cam.width, cam.height)
                rr.update_scene(data, camera=cam_ids[cam.name])
                rr.render()
                if segment:
                    r.segment(data, cam_ids[cam.name], cam.width, cam.height)
                n += 1
        return n

    run(schedule[:warmup])
    t0, c0 = time.perf_counter(), time.process_time()
    n = run(schedule)
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    r.close()
    return dt, cpu, n


def head(traj, steps: int):
    """The first ``steps`` simulation steps of a trajectory (the warm-up clip)."""
    cut = {f.name: getattr(traj, f.name)[..., :steps] for f in fields(traj)
           if f.name in ("t", "pos", "vel", "acc", "yaw", "yaw_rate", "yaw_acc", "walking")}
    cut["pos"], cut["vel"], cut["acc"] = (getattr(traj, k)[:, :steps] for k in ("pos", "vel", "acc"))
    return replace(traj, **cut)


def pipeline(world, scene, traj, workers: int, warmup: int) -> tuple[float, float, dict]:
    """Wall and CPU seconds of ``observe`` on the clip, MP4s written (after a warm-up ``observe`` on its first frames)."""
    first = min(camera_schedule(scene, traj))  # a step with frames: the warm-up renders something
    observe(world, scene, head(traj, max(warmup, first + 1)), None, None, workers=workers)
    timings: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        observe(world, scene, traj, None, Path(tmp), timings, workers=workers)
        dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    return dt, cpu, timings


class Rendered:
    """Every camera frame of the clip rendered once (RGB, person index, people's poses), with what
    ``FrameWork`` needs, so the post-render work can be timed alone."""

    def __init__(self, world, scene, traj):
        model, data, cam_ids, person_geoms = world_maps(world, scene)
        self.scene, self.model, self.person_geoms = scene, model, person_geoms
        self.names = [w.name for w in scene.walkers]
        person_of_geom = np.full(model.ngeom, -1, np.int16)
        for i, g in enumerate(person_geoms):
            person_of_geom[g] = i
        all_geoms = np.concatenate(person_geoms) if person_geoms else np.zeros(0, int)
        with SceneRenderer(model, person_of_geom, shadows=scene.render.shadows) as r:
            _pose(world, traj, 0)
            self.backgrounds = {c.name: r.background(data, cam_ids[c.name], c.width, c.height, all_geoms)
                                for c in scene.cameras}
            self.frames = []
            for k, due in camera_schedule(scene, traj).items():
                _pose(world, traj, k)
                poses = pose_snapshot(data, all_geoms)
                for cam, t in due:
                    rgb, seg = r.rgb_and_segment(data, cam_ids[cam.name], cam.width, cam.height)
                    self.frames.append((cam, t, rgb.copy(), seg, poses))

    def work(self, workers: int, warmup: int) -> tuple[float, float]:
        """Wall and CPU seconds of ``FrameWork`` (perception, labels, MP4) on every frame, after a warm-up."""
        def run(frames) -> tuple[float, float]:
            with tempfile.TemporaryDirectory() as tmp:
                sink = VideoSink(tmp)
                fw = FrameWork(self.scene, self.model, self.person_geoms, self.names, self.backgrounds, workers, sink)
                t0, c0 = time.perf_counter(), time.process_time()
                try:
                    for f in frames:
                        fw.submit(*f)
                    fw.finish()
                finally:
                    fw.close()
                    sink.close()
                return time.perf_counter() - t0, time.process_time() - c0

        run(self.frames[:warmup])
        return run(self.frames)


def default_counts(cores: int) -> list[int]:
    return [0] + [n for n in (1, 2, 4, 8, 16) if n <= cores]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="overhead_lab")
    ap.add_argument("--seconds", type=float, default=5.0, help="clip length (s) for the bare-vs-pipeline timing")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=3, help="interleaved repeats of every pass; the median is reported")
    ap.add_argument("--warmup", type=int, default=10, help="simulation steps with frames rendered before timing")
    ap.add_argument("--workers", default=None,
                    help="comma-separated worker counts (default: 0 and 1, 2, 4, 8, 16 up to the available cores)")
    ap.add_argument("--generate", type=float, default=0.0, help="also time a full rendered simulate() of this many seconds")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    args = ap.parse_args(argv)

    cores = worker_count()  # TRACKROOM_RENDER_WORKERS, else the available cores: the pipeline's default
    counts = [int(w) for w in args.workers.split(",")] if args.workers else default_counts(cores)
    scene = load_scene(args.scene, args.overrides)
    traj = plan_trajectories(scene, args.seconds, np.random.default_rng(args.seed))
    world = build_world(scene)
    res = sorted({f"{c.width}x{c.height}" for c in scene.cameras})
    print(f"scene {scene.name}: {len(scene.cameras)} cameras at {', '.join(res)}, {len(scene.walkers)} walkers, "
          f"{args.seconds:g} s clip; {os.cpu_count()} CPUs, {len(os.sched_getaffinity(0))} available, default workers "
          f"{cores}; LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', 'unset')}; MUJOCO_GL={os.environ['MUJOCO_GL']}")
    load0 = os.getloadavg()
    rendered = Rendered(world, scene, traj)
    runs: dict[str, list[float]] = {"rgb": [], "rgbseg": []}
    runs.update({f"pipe{w}": [] for w in counts + [cores]})
    runs.update({f"work{w}": [] for w in counts})
    cpus: dict[str, list[float]] = {k: [] for k in runs}
    stages: dict[str, list[dict]] = {}
    for _ in range(max(1, args.repeat)):
        for key, seg in (("rgb", False), ("rgbseg", True)):
            dt, cpu, n = bare(world, scene, traj, seg, args.warmup)
            runs[key].append(dt)
            cpus[key].append(cpu)
        for w in dict.fromkeys(counts + [cores]):
            dt, cpu, tm = pipeline(world, scene, traj, w, args.warmup)
            runs[f"pipe{w}"].append(dt)
            cpus[f"pipe{w}"].append(cpu)
            stages.setdefault(f"pipe{w}", []).append(tm)
        for w in counts:
            dt, cpu = rendered.work(w, args.warmup)
            runs[f"work{w}"].append(dt)
            cpus[f"work{w}"].append(cpu)
    load1 = os.getloadavg()
    med = {k: statistics.median(v) for k, v in runs.items() if v}
    cpu_med = {k: statistics.median(v) for k, v in cpus.items() if v}

    def line(label, key):
        allv = ", ".join(f"{v:.2f}" for v in runs[key])
        print(f"{label:46s}: {med[key]:6.2f} s  {n / med[key]:7.1f} fps  CPU {1000 * cpu_med[key] / n:5.1f} ms/frame"
              f"   (runs: {allv})")

    print(f"frames: {n} camera frames per pass; median of {max(1, args.repeat)} interleaved runs; "
          f"load average {load0[0]:.2f} before, {load1[0]:.2f} after")
    line("bare rendering, RGB only", "rgb")
    line("bare rendering, RGB + segmentation", "rgbseg")
    line(f"full pipeline ({cores} workers, the default)", f"pipe{cores}")
    t_pipe = med[f"pipe{cores}"]
    print(f"ratio pipeline / bare RGB + segmentation : {t_pipe / med['rgbseg']:5.2f}  (target <= 1.5)")
    print(f"ratio pipeline / bare RGB                : {t_pipe / med['rgb']:5.2f}")
    c_pipe = cpu_med[f"pipe{cores}"]
    print(f"CPU time, pipeline / bare RGB + segmentation: {c_pipe / cpu_med['rgbseg']:5.2f}  (the work it adds, "
          "whatever else runs on the machine)")
    print()
    print("frames/s against worker threads (0: perception, labels and video in the rendering thread);")
    print("post-render work alone: the same work on frames rendered beforehand (rendering free).")
    print("CPU/wall: CPU seconds of all the process's threads per wall second (how many cores it kept busy).")
    print("| workers | pipeline (fps) | pipeline / RGB+seg | CPU/wall | post-render work alone (fps) | CPU/wall |")
    print("| --- | --- | --- | --- | --- | --- |")
    for w in counts:
        p, wk = med[f"pipe{w}"], med[f"work{w}"]
        print(f"| {w} | {n / p:.1f} | {p / med['rgbseg']:.2f} | {cpu_med[f'pipe{w}'] / p:.2f} | {n / wk:.1f} | "
              f"{cpu_med[f'work{w}'] / wk:.2f} |")
    print()
    print(f"pipeline stages at {cores} workers, median run (ms per camera frame; perception, labels and")
    print("video summed over the worker threads, which run alongside the rendering thread):")
    best = sorted(stages[f"pipe{cores}"], key=lambda tm: sum(tm.values()))[len(stages[f"pipe{cores}"]) // 2]
    print("  " + ", ".join(f"{k} {1000 * v / n:.2f}" for k, v in best.items()))

    if args.generate > 0:
        from trackroom.sim.simulate import simulate

        t0 = time.perf_counter()
        rec = simulate(scene, seed=args.seed, duration=args.generate, sensing="rendered")
        dt = time.perf_counter() - t0
        rows = {k: len(v) for k, v in rec.observations.tables.items()}
        print(f"simulate({scene.name}, {args.generate:g} s, rendered, {cores} workers): {dt:.1f} s "
              f"({dt / 60:.2f} min; target < 5 min) rows {rows}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
