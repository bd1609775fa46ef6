"""The simulation loop: scene + seed -> ``Recording``.

1. Plan every walker's trajectory (``sim.walkers``) at ``sensors.sim_rate``.
2. Build the MuJoCo world (``sim.world``).
3. Read the phones' sensors at the IMU samples (``sim.imu``: MuJoCo's sensors on a world of the
   phone walkers, many samples per pass) and, in analytic mode, pose the world at every camera
   frame and cast the occlusion rays (``sim.analytic.Occlusion``). The camera side (rays, then
   step 4's camera tables) runs in a second thread beside the IMU side (MuJoCo releases the GIL
   while casting, numpy in its array loops); the two share no arrays or random streams, so the
   tables do not depend on the threads' timing.
4. Turn geometry + visibility into observation tables with noise (``sim.analytic``), or, with
   ``sensing="rendered"``, hand over to ``sim.rendered.observe``.
5. Calibration noise: the scene's ``sensors`` figures a user would have measured (rates, noise
   levels, the field) - not ``SIMULATOR_ONLY``, which describe how the simulated detectors behave;
   a rendered recording's ``boxes`` come from the flow detector, so its measured window noise
   (``sim.perception_model.RENDERED_WINDOW_NOISE``: ``box_sigma_px``, ``box_u_sigma_px``,
   ``flow_sigma_px_s``) replaces / adds to them.

Randomness: one ``numpy.random.default_rng(seed)`` spawns independent streams, in this fixed
order: motion, imu, cameras (one child per camera, scene order; an oblique camera's windows
draw from a child of its camera's stream, so a refit of its blob detector leaves them as they
are), rendering. The same scene and seed therefore give bit-identical tables, and e.g. adding a
camera does not change the walkers.
"""
from __future__ import annotations

import dataclasses
import importlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd

from trackroom.scenes.loader import SceneError, scene_sha256, scene_toml
from trackroom.scenes.spec import Scene

from . import analytic, imu, phone_errors
from trackroom.provenance import versions
from trackroom.recording import SENSING_MODES, Calibration, Observations, Recording, Truth
from .walkers import GM_DISCRETISATION, Trajectories, plan_trajectories
from .world import build_world

# ``SensorSpec`` fields that configure the simulated detectors (a privacy camera's blindness to
# people slower than ``still_speed``, the flow tracker's ``flow_min_px_s``): the simulator's own
# knobs, not measurements, so they stay out of ``calibration.noise`` (calibration/sensors.json).
SIMULATOR_ONLY = ("still_speed", "flow_min_px_s", "perception", "mag_disturbance_deg", "mag_disturbance_range_m",
                  "accel_bias", "pocket_yaw_deg", "pocket_tilt_deg", "swing_per_min", "swing_deg")


def perception_model(scene: Scene):
    """The perception model analytic sensing of ``scene`` uses (``sensors.perception``); a file
    that cannot be used is a SceneError naming the scene and the option."""
    from trackroom.scenes.loader import SceneError

    from .perception_model import ModelError, load_model

    try:
        return load_model(scene.sensors.perception)
    except ModelError as e:
        raise SceneError(f"{scene.source or scene.name}: sensors.perception: {e}") from None


def calibration_noise(scene: Scene, sensing: str = "analytic", model=None) -> dict:
    """``calibration.noise`` of a recording of ``scene``: the ``sensors`` figures but
    ``SIMULATOR_ONLY``; where the scene's perception model is a fitted one (``model``, or
    ``sensors.perception`` when not given), the model's measured bearing and floor noise and the
    flow detector's measured window noise replace them in both sensing modes (the model is fitted
    to the rendered detectors, so these are what a user would have measured of them); with
    ``"ideal"`` perception only a rendered recording declares the window noise."""
    noise = {k: v for k, v in dataclasses.asdict(scene.sensors).items() if k not in SIMULATOR_ONLY}
    if model is None:
        model = perception_model(scene)
    if not model.ideal:
        figures = model.noise_figures({c.kind for c in scene.cameras})
        overhead = [c for c in scene.cameras if c.kind == "overhead"]
        privacy = figures.pop("privacy_floor_sigma_m")
        if overhead and all(c.privacy for c in overhead):
            figures["floor_sigma_m"] = privacy
        noise.update(figures)
    if not model.ideal or sensing == "rendered":
        # the rendered boxes come from the flow detector: declare its measured window noise
        from .perception_model import RENDERED_WINDOW_NOISE

        noise.update(RENDERED_WINDOW_NOISE)
    return noise


def phone_ids(scene: Scene) -> list[str]:
    """``phone{i}`` for walker i with a phone, "" without."""
    return [f"phone{i}" if w.phone else "" for i, w in enumerate(scene.walkers)]


def truth_people(scene: Scene, traj: Trajectories) -> pd.DataFrame:
    """Truth ``people`` at the simulation rate, sorted by t then walker (scene order)."""
    P, N = traj.n_people, traj.n_steps
    yaw = np.angle(np.exp(1j * traj.yaw))  # wrapped to (-pi, pi]
    who = np.tile(np.arange(P), N)
    # columns are fresh arrays: the frame takes them as they are (no second copy into blocks)
    return pd.DataFrame(
        {
            "t": np.repeat(traj.t, P),
            "person_id": analytic.str_column(traj.names, who),
            "x": traj.pos[:, :, 0].T.ravel(), "y": traj.pos[:, :, 1].T.ravel(), "z": traj.pos[:, :, 2].T.ravel(),
            "yaw": yaw.T.ravel(), "vx": traj.vel[:, :, 0].T.ravel(), "vy": traj.vel[:, :, 1].T.ravel(),
            "walking": traj.walking.T.ravel(),
            "phone_id": analytic.str_column(phone_ids(scene), who),
        },
        copy=False,
    )


# Peak memory per row while simulating (bytes): the table row plus the working arrays behind it
# (trajectories, camera geometry, occlusion flags, pandas copies while sorting). Measured as peak
# RSS growth per simulated second on the bundled scenes (overhead_lab with 10 walkers: 0.7 MB/s;
# occlusion_lab: 0.6 MB/s, most of it the oblique cameras' window geometry), rounded up.
BYTES_PER_PERSON_STEP = 300  # truth row + trajectory state, per person per sim_rate step
BYTES_PER_IMU_SAMPLE = 300  # IMU row + the phone's sensor readings
BYTES_PER_CAMERA_PERSON_FRAME = {"overhead": 400, "horizontal": 400, "oblique": 2000}
BASE_BYTES = 64 * 2**20  # MuJoCo world, planner grids, interpreter


def estimate_memory(scene: Scene, duration: float, sensing: str = "analytic") -> float:
    """Peak memory (bytes) simulating ``scene`` for ``duration`` seconds needs, from its rates and
    counts: rows (person x sim step, phone x IMU sample, camera frame x person) x bytes per row."""
    people = len(scene.walkers)
    phones = sum(bool(w.phone) for w in scene.walkers)
    per_second = people * scene.sensors.sim_rate * BYTES_PER_PERSON_STEP + phones * scene.sensors.imu_rate * BYTES_PER_IMU_SAMPLE
    per_second += sum(c.fps * people * BYTES_PER_CAMERA_PERSON_FRAME.get(c.kind, 2000) for c in scene.cameras)
    return BASE_BYTES + float(duration) * per_second


def available_memory() -> float | None:
    """Memory available to a new process (bytes): ``MemAvailable`` of /proc/meminfo, else the free
    physical pages; None where neither can be read."""
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def memory_problem(scene: Scene, duration: float, sensing: str = "analytic", parallel: int = 1) -> str | None:
    """Why simulating would exhaust memory (one line with the estimate), or None when it fits.
    ``parallel``: how many such simulations run at once."""
    need = estimate_memory(scene, duration, sensing) * max(1, parallel)
    have = available_memory()
    if have is None or need <= have:
        return None
    at_once = f" x {parallel} at once" if parallel > 1 else ""
    return (f"about {_bytes_text(need)} of tables and working arrays for {duration:g} s of {scene.name}{at_once}; "
            f"this machine has {_bytes_text(have)} available (shorten the duration or the scene)")


def _bytes_text(n: float) -> str:
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 2**10:.3g} KiB"


def progress_bar(progress, total: int, desc: str, unit: str):
    """A tqdm bar (count, rate, ETA) or None. ``progress``: False (none), True (on stderr when it
    is a terminal, so logs and pipes stay clean) or a text stream to draw on whatever it is."""
    if not progress:
        return None
    from tqdm import tqdm

    if progress is True:
        return tqdm(total=total, desc=desc, unit=unit, mininterval=0.5, disable=None)  # None: off unless a TTY
    return tqdm(total=total, desc=desc, unit=unit, mininterval=0.5, file=progress)


def _locked(fn):
    """``fn`` behind a lock (callable from several threads)."""
    lock = threading.Lock()

    def call(*args):
        with lock:
            return fn(*args)

    return call


def camera_tables(scene: Scene, traj: Trajectories, geometry: dict, occlusion, cam_rngs: dict, model) -> dict:
    """Analytic mode's observation tables from the cast rays (``occlusion``): through the
    perception model, or ideal."""
    if model.ideal:
        return analytic.observation_tables(scene, traj, geometry, occlusion.visible, cam_rngs)
    return analytic.modelled_observation_tables(scene, traj, geometry, occlusion.fraction, cam_rngs, model, occlusion.head)


def simulate(scene: Scene, seed: int, duration: float, sensing: str = "analytic", progress=False, save_frames=None,
             render_workers: int | None = None, perception_draw: int = 0) -> Recording:
    """Simulate ``scene`` for ``duration`` seconds with ``seed``; see the module docstring.

    sensing: "analytic" (projection + ray-cast occlusion) or "rendered" (``sim.rendered``).
    save_frames: passed to the rendered mode (where to keep rendered frames), ignored otherwise.
    progress: a bar (tqdm) on stderr when it is a terminal (True), or on the given stream: over the
    IMU samples and ray-cast camera frames in analytic mode, over the rendered camera frames in rendered mode (the
    rendering is nearly all of its time). render_workers: the rendered mode's worker threads
    (``sim.rendered.worker_count``; the tables do not depend on it). perception_draw: 0 (the
    default) is the recording of ``seed``; k > 0 redraws only the analytic camera tables' random
    streams (``numpy.random.SeedSequence((seed, k))``; walkers and phones unchanged), so figures can be
    averaged over several draws of the perception model on the same paths (``scripts.sensing_transfer
    --draws``).
    """
    if sensing not in SENSING_MODES:
        raise ValueError(f"sensing must be one of {SENSING_MODES}, got {sensing!r}")
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive, finite number of seconds, got {duration}")
    if not scene.walkers:
        raise SceneError(f"{scene.source or scene.name}: no people to simulate (walkers.count is 0)")
    model = perception_model(scene)
    rng = np.random.default_rng(seed)
    motion_rng, imu_rng, cam_rng, render_rng = rng.spawn(4)
    if perception_draw:
        cam_rng = np.random.default_rng(np.random.SeedSequence((int(seed), int(perception_draw))))
    cam_rngs = dict(zip([c.name for c in scene.cameras], cam_rng.spawn(len(scene.cameras))))

    traj = plan_trajectories(scene, duration, motion_rng)
    world = build_world(scene)
    pids = phone_ids(scene)
    steps = imu.imu_steps(traj, scene.sensors.imu_rate)

    occlusion, bar = None, None
    if sensing == "analytic":
        geometry = analytic.camera_geometry(scene, traj)
        occlusion = analytic.Occlusion(world, scene, traj, geometry, head_ray=model.uses_head)
        # one bar over the IMU samples and the ray-cast camera frames
        bar = progress_bar(progress, len(steps) + len(occlusion.frame_steps), f"{scene.name} ({sensing})", "step")

    with ThreadPoolExecutor(max_workers=1) as pool:
        # the camera side (rays, then the camera tables) runs beside the IMU side: MuJoCo releases
        # the GIL while casting, numpy in its array loops, and each side has its own arrays and
        # random streams, so the tables do not depend on the threads' timing
        tick = _locked(bar.update) if bar is not None else None  # one bar, two threads
        if occlusion is not None:
            rays = pool.submit(occlusion.finish, progress=tick)
            cameras = pool.submit(camera_tables, scene, traj, geometry, occlusion, cam_rngs, model)  # after the rays
        readings = imu.read_phones(world, traj, steps, progress=tick)
        if scene.sensors.phone_errors():
            # a stream of its own (the fifth child): the other streams, and so the rest of the
            # recording, are the same with or without phone errors
            readings = phone_errors.apply(readings, traj.pos[:, steps, :2], traj.t[steps], scene.floorplan, scene.sensors,
                                          rng.spawn(1)[0])
        tables = {"imu": imu.imu_table(readings, traj.t[steps], pids, scene, imu_rng)}
        truth_tables = {"people": truth_people(scene, traj)}
        if occlusion is not None:
            rays.result()
            truth_tables["visibility"] = analytic.visibility_table(scene, traj, geometry, occlusion.visible)
            tables.update(cameras.result())
    if bar is not None:
        bar.close()
    if sensing == "rendered":
        try:
            rendered = importlib.import_module("trackroom.sim.rendered")
        except ModuleNotFoundError as e:
            raise RuntimeError("sensing='rendered' needs sim/rendered.py (the rendering pipeline), which is not installed") from e
        frames = sum(len(due) for due in rendered.camera_schedule(scene, traj).values())
        bar = progress_bar(progress, frames, f"{scene.name} (rendered)", "frame")
        try:
            obs, extra = rendered.observe(world, scene, traj, render_rng, save_frames, workers=render_workers,
                                          progress=bar.update if bar is not None else None)
        finally:
            if bar is not None:
                bar.close()
        tables.update(obs)
        truth_tables.update(extra)
    if len(tables["imu"]) == 0:
        del tables["imu"]

    meta = {
        "scene": scene.name,
        "source": scene.source,
        "overrides": list(scene.overrides),
        "scene_sha256": scene_sha256(scene),
        "seed": int(seed),
        "duration": float(duration),
        "sensing": sensing,
        "sim_rate": float(scene.sensors.sim_rate),
        "walkers": [
            {
                "name": w.name, "color": w.color_name, "motion": w.motion, "phone_id": pids[i],
                "gauss_markov": {"q_pos": traj.gauss_markov[i].q_pos, "q_vel": traj.gauss_markov[i].q_vel, "discretisation": GM_DISCRETISATION}
                if traj.gauss_markov[i]
                else None,
            }
            for i, w in enumerate(scene.walkers)
        ],
        "versions": versions(),
        # the perception model behind analytic detections and every recording's declared noise
        "perception": {"model": scene.sensors.perception, "sha256": model.sha256},
    }
    calibration = Calibration(cameras={c.name: c for c in scene.cameras}, floorplan=scene.floorplan,
                              noise=calibration_noise(scene, sensing, model))
    return Recording(calibration=calibration, observations=Observations(tables, float(duration)), truth=Truth(truth_tables), meta=meta,
                     scene_toml=scene_toml(scene))
