"""Benchmark: bare MuJoCo rendering vs the full rendered pipeline, on the same frames, one run.

    python scripts/bench_render.py [--scene overhead_lab] [--seconds 5] [--generate 60]

1. bare: pose the world and render RGB for every camera frame of the clip (``Renderer.render``);
   also RGB + segmentation, the renders the pipeline needs (segmentation feeds the truth labels).
2. pipeline: ``sim.rendered.observe`` on the same frames: RGB + segmentation renders, perception,
   labels and MP4 writing, with the time per stage.
Reports seconds, frames per second and the ratio pipeline / bare (target <= 1.5).
``--generate S``: also times ``simulate(scene, duration=S, sensing="rendered")`` end to end
(walkers, IMUs, rendering; target < 5 min for a 60 s overhead_lab with 5 walkers).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from scenes.loader import load_scene  # noqa: E402
from sim.render import SceneRenderer  # noqa: E402
from sim.rendered import _pose, camera_schedule, check_cameras, observe, world_maps  # noqa: E402
from sim.walkers import plan_trajectories  # noqa: E402
from sim.world import build_world  # noqa: E402


def bare(world, scene, traj, segment: bool) -> tuple[float, int]:
    model, data, cam_ids, person_geoms = world_maps(world, scene)
    check_cameras(model, scene, cam_ids)
    r = SceneRenderer(model, np.asarray(world.geom_person, np.int16), shadows=scene.render.shadows)
    n = 0
    t0 = time.perf_counter()
    for k, due in camera_schedule(scene, traj).items():
        _pose(world, traj, k)
        for cam, _ in due:
            if segment:
                r.rgb_and_segment(data, cam_ids[cam.name], cam.width, cam.height)
            else:
                r.rgb(data, cam_ids[cam.name], cam.width, cam.height)
            n += 1
    dt = time.perf_counter() - t0
    r.close()
    return dt, n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="overhead_lab")
    ap.add_argument("--seconds", type=float, default=5.0, help="clip length (s) for the bare-vs-pipeline timing")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--generate", type=float, default=0.0, help="also time a full rendered simulate() of this many seconds")
    ap.add_argument("--set", dest="overrides", action="append", default=[])
    args = ap.parse_args(argv)

    scene = load_scene(args.scene, args.overrides)
    traj = plan_trajectories(scene, args.seconds, np.random.default_rng(args.seed))
    world = build_world(scene)
    res = sorted({f"{c.width}x{c.height}" for c in scene.cameras})
    print(f"scene {scene.name}: {len(scene.cameras)} cameras at {', '.join(res)}, {len(scene.walkers)} walkers, {args.seconds:g} s clip")

    t_rgb, n = bare(world, scene, traj, segment=False)
    t_rgbseg, _ = bare(world, scene, traj, segment=True)
    timings: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        observe(world, scene, traj, None, Path(tmp), timings)
        t_pipe = time.perf_counter() - t0
    print(f"frames: {n}")
    print(f"bare rendering, RGB only        : {t_rgb:7.2f} s  {n / t_rgb:7.1f} fps")
    print(f"bare rendering, RGB + segment   : {t_rgbseg:7.2f} s  {n / t_rgbseg:7.1f} fps")
    print(f"full pipeline (render+perception+labels+MP4): {t_pipe:7.2f} s  {n / t_pipe:7.1f} fps")
    print(f"ratio pipeline / bare RGB          : {t_pipe / t_rgb:5.2f}  (target <= 1.5)")
    print(f"ratio pipeline / bare RGB + segment: {t_pipe / t_rgbseg:5.2f}")
    other = t_pipe - sum(timings.values())
    print("pipeline time by stage (s, ms/frame):")
    for k, v in list(timings.items()) + [("other (backgrounds, tables)", other)]:
        print(f"  {k:28s} {v:7.2f}  {1000 * v / n:6.2f}")

    if args.generate > 0:
        from sim.simulate import simulate

        t0 = time.perf_counter()
        rec = simulate(scene, seed=args.seed, duration=args.generate, sensing="rendered")
        dt = time.perf_counter() - t0
        rows = {k: len(v) for k, v in rec.observations.tables.items()}
        print(f"simulate({scene.name}, {args.generate:g} s, rendered): {dt:.1f} s ({dt / 60:.2f} min; target < 5 min) rows {rows}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
