"""Benchmark: bare MuJoCo rendering vs the full rendered pipeline, on the same frames, one run.

    python scripts/bench_render.py [--scene overhead_lab] [--seconds 5] [--repeat 2] [--generate 60]

All passes use the same world, the same camera frames (the clip's schedule) and the same
``SceneRenderer`` code; each pass is preceded by a warm-up on the first ``--warmup`` frames
(renderer and GL context creation, first-touch allocations), which is excluded. Passes:
1. bare RGB: pose the world and ``Renderer.render()`` RGB for every camera frame.
2. bare RGB + segmentation: the two renders the pipeline needs (segmentation -> truth labels),
   segmentation through ``SceneRenderer.segment`` as in the pipeline.
3. pipeline: ``sim.rendered.observe`` on the same frames (renders, perception, labels, MP4
   writing), with perception/labels/MP4 in a worker thread (``overlap``, the default) and inline.
The passes are interleaved and repeated ``--repeat`` times; the minimum of each is reported
(other users of the machine only ever add time), with the load average. Ratios: pipeline / bare
RGB (the issue's target <= 1.5) and pipeline / bare RGB + segmentation (the renders it needs).
``--generate S``: also times ``simulate(scene, duration=S, sensing="rendered")`` end to end
(walkers, IMUs, rendering; target < 5 min for a 60 s overhead_lab with 5 walkers).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from dataclasses import fields, replace
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from trackroom.scenes.loader import load_scene  # noqa: E402
from trackroom.sim.render import SceneRenderer, SegmentationThread  # noqa: E402
from trackroom.sim.rendered import _pose, camera_schedule, check_cameras, observe, world_maps  # noqa: E402
from trackroom.sim.walkers import plan_trajectories  # noqa: E402
from trackroom.sim.world import build_world  # noqa: E402


def bare(world, scene, traj, segment: bool, warmup: int, threaded: bool = False) -> tuple[float, int]:
    """Seconds and frames of bare rendering: RGB, and segmentation if ``segment`` (in its own
    thread, overlapping the RGB renders, if ``threaded``: ``SegmentationThread``)."""
    model, data, cam_ids, person_geoms = world_maps(world, scene)
    check_cameras(model, scene, cam_ids)
    r = SceneRenderer(model, np.asarray(world.geom_person, np.int16), shadows=scene.render.shadows)
    seg_thread = SegmentationThread(r) if segment and threaded else None
    schedule = list(camera_schedule(scene, traj).items())

    def run(steps) -> int:
        n = 0
        for k, due in steps:
            _pose(world, traj, k)
            for cam, _ in due:
                if seg_thread is not None:
                    job = seg_thread.submit(data, cam_ids[cam.name], cam.width, cam.height)
                rr = r.renderer(cam.width, cam.height)
                rr.update_scene(data, camera=cam_ids[cam.name])
                rr.render()
                if seg_thread is not None:
                    job.result()
                elif segment:
                    r.segment(data, cam_ids[cam.name], cam.width, cam.height)
                n += 1
        return n

    run(schedule[:warmup])
    t0 = time.perf_counter()
    n = run(schedule)
    dt = time.perf_counter() - t0
    if seg_thread is not None:
        seg_thread.close()
    r.close()
    return dt, n


def head(traj, steps: int):
    """The first ``steps`` simulation steps of a trajectory (the warm-up clip)."""
    cut = {f.name: getattr(traj, f.name)[..., :steps] for f in fields(traj)
           if f.name in ("t", "pos", "vel", "acc", "yaw", "yaw_rate", "yaw_acc", "walking")}
    cut["pos"], cut["vel"], cut["acc"] = (getattr(traj, k)[:, :steps] for k in ("pos", "vel", "acc"))
    return replace(traj, **cut)


def pipeline(world, scene, traj, overlap: bool, warmup: int) -> tuple[float, dict]:
    """Seconds of ``observe`` on the clip (after a warm-up ``observe`` on its first frames)."""
    first = min(camera_schedule(scene, traj))  # a step with frames: the warm-up renders something
    observe(world, scene, head(traj, max(warmup, first + 1)), None, None, overlap=overlap)
    timings: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        observe(world, scene, traj, None, Path(tmp), timings, overlap=overlap)
        dt = time.perf_counter() - t0
    return dt, timings


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="overhead_lab")
    ap.add_argument("--seconds", type=float, default=5.0, help="clip length (s) for the bare-vs-pipeline timing")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=2, help="interleaved repeats of every pass; the minimum is reported")
    ap.add_argument("--warmup", type=int, default=10, help="simulation steps with frames rendered before timing")
    ap.add_argument("--generate", type=float, default=0.0, help="also time a full rendered simulate() of this many seconds")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    args = ap.parse_args(argv)

    scene = load_scene(args.scene, args.overrides)
    traj = plan_trajectories(scene, args.seconds, np.random.default_rng(args.seed))
    world = build_world(scene)
    res = sorted({f"{c.width}x{c.height}" for c in scene.cameras})
    print(f"scene {scene.name}: {len(scene.cameras)} cameras at {', '.join(res)}, {len(scene.walkers)} walkers, "
          f"{args.seconds:g} s clip; LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', 'unset')}, "
          f"{os.cpu_count()} CPUs")
    load0 = os.getloadavg()
    runs: dict[str, list[float]] = {"rgb": [], "rgbseg": [], "rgbseg_thread": [], "pipe": [], "pipe_inline": []}
    stages: dict = {"pipe": {}, "pipe_inline": {}}
    for _ in range(max(1, args.repeat)):
        dt, n = bare(world, scene, traj, False, args.warmup)
        runs["rgb"].append(dt)
        runs["rgbseg"].append(bare(world, scene, traj, True, args.warmup)[0])
        runs["rgbseg_thread"].append(bare(world, scene, traj, True, args.warmup, threaded=True)[0])
        for key, overlap in (("pipe", True), ("pipe_inline", False)):
            dt, tm = pipeline(world, scene, traj, overlap, args.warmup)
            if not runs[key] or dt < min(runs[key]):
                stages[key] = tm
            runs[key].append(dt)
    load1 = os.getloadavg()
    best = {k: min(v) for k, v in runs.items()}
    t_rgb, t_rgbseg, t_pipe, t_inline = best["rgb"], best["rgbseg"], best["pipe"], best["pipe_inline"]

    def line(label, key):
        allv = ", ".join(f"{v:.2f}" for v in runs[key])
        print(f"{label:46s}: {best[key]:6.2f} s  {n / best[key]:7.1f} fps   (runs: {allv})")

    print(f"frames: {n} per pass; load average {load0[0]:.2f} before, {load1[0]:.2f} after")
    line("bare rendering, RGB only", "rgb")
    line("bare rendering, RGB + segmentation", "rgbseg")
    line("bare RGB + segmentation (own thread)", "rgbseg_thread")
    line("full pipeline (overlapped worker, default)", "pipe")
    line("full pipeline (inline, one thread)", "pipe_inline")
    print(f"ratio pipeline / bare RGB              : {t_pipe / t_rgb:5.2f}  (target <= 1.5; inline {t_inline / t_rgb:.2f})")
    print(f"ratio pipeline / bare RGB + segment    : {t_pipe / t_rgbseg:5.2f}  (inline {t_inline / t_rgbseg:.2f})")
    t_rst = best["rgbseg_thread"]
    print(f"ratio pipeline / bare RGB + seg thread : {t_pipe / t_rst:5.2f}  (the renders the overlapped pipeline makes, alone)")
    print("pipeline time by stage, best runs (s; ms/frame). Overlapped: perception, labels and video run in")
    print("the worker thread concurrently with pose/render/segment; wait = the renderer waiting for the worker.")
    print(f"  {'stage':28s} {'overlapped':>16s} {'inline':>16s}")
    for k in stages["pipe"]:
        a, b = stages["pipe"][k], stages["pipe_inline"].get(k, 0.0)
        print(f"  {k:28s} {a:7.2f} {1000 * a / n:7.2f}  {b:7.2f} {1000 * b / n:7.2f}")
    main_thread = ("pose", "render", "segment", "wait")
    o_a = t_pipe - sum(v for k, v in stages["pipe"].items() if k in main_thread)
    o_b = t_inline - sum(stages["pipe_inline"].values())
    print(f"  {'other (backgrounds, tables)':28s} {o_a:7.2f} {1000 * o_a / n:7.2f}  {o_b:7.2f} {1000 * o_b / n:7.2f}")

    if args.generate > 0:
        from trackroom.sim.simulate import simulate

        t0 = time.perf_counter()
        rec = simulate(scene, seed=args.seed, duration=args.generate, sensing="rendered")
        dt = time.perf_counter() - t0
        rows = {k: len(v) for k, v in rec.observations.tables.items()}
        print(f"simulate({scene.name}, {args.generate:g} s, rendered): {dt:.1f} s ({dt / 60:.2f} min; target < 5 min) rows {rows}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
