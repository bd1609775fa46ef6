"""The ``rendered`` sensing mode: render every camera, run perception, label from segmentation.

``observe(world, scene, traj, rng, save_frames)`` fills the same observation tables as the
analytic mode (``bearings``, ``boxes``, ``floor_detections``; see ``trackroom/recording.py``) from
pixels only, and the truth tables ``visibility`` and ``labels`` from segmentation renders.

Schedule. Camera c captures at t = j / fps_c (``Camera.frame_times``); the world is posed at the
simulation step k = round(t * sim_rate), and every camera due at that step renders from the same
pose. Perception per camera kind (``sim/perception.py``, ``sim/perception_flow.py``):
horizontal -> bearings (u, width, colour label); overhead -> floor detections (regular or privacy);
oblique -> boxes from the optical-flow tracker, plus bearings from the same background-difference
blobs as a horizontal camera (u of each person blob, colour label).

Threads (``observe(workers=N)``; default ``TRACKROOM_RENDER_WORKERS`` or the available cores):
the calling thread poses the world and draws every render (RGB, then segmentation), and N worker
threads run perception and MP4 writing (each camera in its own ordered lane, ``sim.lanes``: the
stateful detectors see their frames in sequence) and the truth labels (any worker). Rows are
collected per frame and joined in frame order, so the tables are identical whatever N is (0:
everything in the calling thread). No GL call is made from any other thread (``sim.render``: two
threads drawing at once crashed llvmpipe once in CI), and on the CPU (Mesa llvmpipe) one render
already spreads over every core. Frames/s against N: ``scripts/bench_render.py``.

Labels (truth, never given to estimators), per camera frame and person:
  pixels            visible pixels of the person in the segmentation render;
  visible_fraction  pixels / A, where A is the pixel area the person would cover if nothing
                    occluded it. A is computed, not rendered: every geom of a person is convex,
                    so its image is the convex hull of its projected surface samples; the union
                    of the hulls, filled on a mask clipped to the image, is the unoccluded
                    silhouette (a render per person would cost one more render per person and
                    frame; the rasterised hulls cost ~0.1 ms). The mask is the image, so the
                    fraction measures occlusion (walls, obstacles, other people) of the part of
                    the person inside the image; a box touching the image border shows clipping;
  x0, y0, x1, y1    the box of the visible pixels (pixel edges, x1/y1 exclusive).
Visibility: ``in_fov`` = some of the unoccluded silhouette lies in the image;
``visible`` = at least ``VISIBLE_FRACTION`` of it is seen.
"""
from __future__ import annotations

import os
import threading
import time
from collections import defaultdict, deque
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import cv2
import mujoco
import numpy as np
import pandas as pd

from trackroom.scenes.camera import Camera
from trackroom.sim.perception import Appearance, OverheadDetector, PerceptionParams, PersonModel, detect_bearings
from trackroom.sim.perception_flow import FlowTracker
from trackroom.cluster import available_cores
from trackroom.sim.lanes import Lane
from trackroom.sim.render import SceneRenderer, VideoSink

VISIBLE_FRACTION = 0.5


# ----------------------------------------------------------------------------- world access
def world_maps(world, scene):
    """(model, data, {camera name: id}, [geom ids of person i]) of a built ``sim.world.World``."""
    model, data = world.model, world.data
    missing = [c.name for c in scene.cameras if c.name not in world.camera_ids]
    if missing:
        raise ValueError(f"the world has no cameras named {missing}")
    geom_person = np.asarray(world.geom_person, int)
    P = len(scene.walkers)
    return model, data, dict(world.camera_ids), [np.flatnonzero(geom_person == i) for i in range(P)]


def person_model(scene, model, person_geoms) -> PersonModel:
    """The nominal person (``PersonModel``) a deployment assumes: the scene's mean walker height
    and radius, with the top sphere of the world's person shape."""
    if not scene.walkers:
        return PersonModel()
    h = float(np.mean([w.height for w in scene.walkers]))
    r = float(np.mean([w.radius for w in scene.walkers]))
    return PersonModel(top_centre=h - r, top_radius=r, bottom_centre=r, bottom_radius=r)


# ----------------------------------------------------------------------------- unoccluded area
def _unit_sphere(n: int = 48) -> np.ndarray:
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5 ** 0.5) * i
    return np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])


_SPHERE = _unit_sphere()
_CIRCLE = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 32, endpoint=False)),
                           np.sin(np.linspace(0, 2 * np.pi, 32, endpoint=False)), np.zeros(32)])


def geom_surface_points(model, data, g: int) -> np.ndarray:
    """World points (N, 3) whose convex hull is geom g (sphere, capsule, ellipsoid, cylinder, box)."""
    typ, size = int(model.geom_type[g]), model.geom_size[g]
    pos, R = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
    G = mujoco.mjtGeom
    if typ == G.mjGEOM_SPHERE:
        local = _SPHERE * size[0]
    elif typ == G.mjGEOM_CAPSULE:
        local = np.vstack([_SPHERE * size[0] + [0, 0, size[1]], _SPHERE * size[0] - [0, 0, size[1]]])
    elif typ == G.mjGEOM_ELLIPSOID:
        local = _SPHERE * size[:3]
    elif typ == G.mjGEOM_CYLINDER:
        ring = _CIRCLE * size[0]
        local = np.vstack([ring + [0, 0, size[1]], ring - [0, 0, size[1]]])
    elif typ == G.mjGEOM_BOX:
        local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * size[:3]
    else:
        raise ValueError(f"geom {g}: type {typ} is not a convex primitive")
    return pos + local @ R.T


def unoccluded_pixels(cam: Camera, model, data, geoms, mask: np.ndarray) -> int:
    """Pixel area of the union of the person's geoms projected into the image (no occlusion).
    ``data``: anything with ``geom_xpos`` and ``geom_xmat`` (an ``MjData`` or a ``GeomPoses``)."""
    mask[:] = 0
    for g in geoms:
        uv, depth = cam.project(geom_surface_points(model, data, int(g)))
        if (depth <= 1e-3).any():
            continue  # behind (or at) the camera: not part of the image
        hull = cv2.convexHull((uv - 0.5).astype(np.float32))  # pixel centres at integers for OpenCV
        cv2.fillConvexPoly(mask, np.round(hull * 16).astype(np.int32), 1, lineType=cv2.LINE_8, shift=4)
    return int(cv2.countNonZero(mask))


class GeomPoses(NamedTuple):
    """A snapshot of the geoms' world poses (``MjData.geom_xpos``, ``geom_xmat``) at one step, so
    labels can be computed after the world has moved on."""

    geom_xpos: np.ndarray
    geom_xmat: np.ndarray


def frame_labels(seg: np.ndarray, n_people: int):
    """Visible pixels (P,) and boxes (P, 4) [x0, y0, x1, y1] of each person in a person-index image.

    One pass over the person pixels: counts by ``bincount``, box edges by per-person minimum and
    maximum of their rows and columns (x1, y1 exclusive); people without pixels get a zero box."""
    ys, xs = np.nonzero(seg >= 0)
    who = seg[ys, xs].astype(np.intp)
    keep = who < n_people
    ys, xs, who = ys[keep], xs[keep], who[keep]
    counts = np.bincount(who, minlength=n_people)[:n_people]
    lo = np.full((n_people, 2), np.iinfo(np.intp).max, np.intp)
    hi = np.full((n_people, 2), -1, np.intp)
    np.minimum.at(lo, (who, 0), xs)
    np.minimum.at(lo, (who, 1), ys)
    np.maximum.at(hi, (who, 0), xs)
    np.maximum.at(hi, (who, 1), ys)
    boxes = np.zeros((n_people, 4))
    seen = counts > 0
    boxes[seen, :2] = lo[seen]
    boxes[seen, 2:] = hi[seen] + 1
    return counts, boxes


# ----------------------------------------------------------------------------- the sensing mode
def camera_schedule(scene, traj) -> dict[int, list[tuple[Camera, float]]]:
    """Simulation step -> [(camera, frame time)] of every camera frame over the trajectory."""
    rate = float(traj.rate)
    duration = traj.n_steps / rate
    sched: dict[int, list] = defaultdict(list)
    for cam in scene.cameras:
        for t in cam.frame_times(duration):
            k = min(int(round(t * rate)), traj.n_steps - 1)
            sched[k].append((cam, float(t)))
    return dict(sorted(sched.items()))


WORKERS_ENV = "TRACKROOM_RENDER_WORKERS"  # default worker count; unset: the cores this process may use


def worker_count(workers: int | None = None, option: str = "workers") -> int:
    """The number of worker threads for perception, labels and video: ``workers`` if given, else
    the ``TRACKROOM_RENDER_WORKERS`` environment variable, else the cores this process may use
    (``os.sched_getaffinity``). 0 runs them in the rendering thread. A ValueError names a bad value
    (and ``option``, or the environment variable, where it came from)."""
    source = option
    if workers is None:
        env = os.environ.get(WORKERS_ENV, "").strip()
        if not env:
            return available_cores()
        source, workers = WORKERS_ENV, env
    try:
        n = int(workers)
    except (TypeError, ValueError):
        n = -1
    if n < 0 or str(workers).strip() != str(n):
        raise ValueError(f"{source} must be a whole number >= 0 (0: no worker threads), got {workers!r}")
    return n


def in_flight(workers: int) -> int:
    """Frames rendered ahead of the oldest unfinished one at most: enough to keep every worker
    busy while a slow frame finishes, few enough to bound memory (an RGB and a segmentation image
    each, ~0.3 MB at 320x240)."""
    return 8 + 4 * workers


STAGES = ("pose", "render", "segment", "perception", "labels", "video", "wait")


class FrameWork:
    """Perception, truth labels and MP4 writing of rendered camera frames, on ``workers`` threads.

    ``submit(cam, t, rgb, seg, poses)`` takes one frame (``seg``: the person-index image;
    ``poses``: the people's ``GeomPoses`` at the frame) in frame order and may
    wait for the oldest frame in flight (at most ``in_flight(workers)`` are); ``finish()`` waits
    for the rest and returns the rows of every table, frame after frame. Each camera's perception
    and video run in its ``Lane`` (its detectors keep state between frames; its MP4 is sequential),
    its labels on any worker; every frame's rows are kept apart, so the rows do not depend on the
    number of workers. ``workers=0``: each frame is done inside ``submit``. ``progress(1)`` is
    called for every finished frame, in frame order; ``timings`` receives seconds per stage
    (summed over threads) and ``wait`` (the caller waiting in ``submit``/``finish``).
    """

    def __init__(self, scene, model, person_geoms, names, backgrounds: dict, workers: int,
                 sink: VideoSink | None = None, timings: dict | None = None, progress=None):
        self.model, self.person_geoms, self.names, self.backgrounds = model, person_geoms, names, backgrounds
        self.sink, self.progress, self.workers = sink, progress, int(workers)
        self.tm = timings if timings is not None else {}
        for key in STAGES:
            self.tm.setdefault(key, 0.0)
        self.app = Appearance.from_scene(scene)
        self.params = PerceptionParams()
        pm = person_model(scene, model, person_geoms)
        self.overhead = {c.name: OverheadDetector(c, backgrounds[c.name], self.app, pm, self.params)
                         for c in scene.cameras if c.kind == "overhead"}
        self.flow = {c.name: FlowTracker(c.width, c.height, camera=c) for c in scene.cameras if c.kind == "oblique"}
        self.frames: list[dict[str, list]] = []  # each camera frame's rows, in submission order
        self.pool = ThreadPoolExecutor(max_workers=self.workers, thread_name_prefix="perception") if self.workers else None
        self.lanes = {c.name: Lane(self.pool) for c in scene.cameras} if self.pool is not None else {}
        self.pending: deque = deque()  # the futures of each frame in flight, oldest first
        self._local = threading.local()  # each thread's label mask buffers
        self._lock = threading.Lock()  # for the timings

    def submit(self, cam, t: float, rgb: np.ndarray, seg, poses) -> None:
        rows: dict[str, list] = {k: [] for k in COLUMNS}
        self.frames.append(rows)
        if self.pool is None:
            self._perceive(cam, t, rgb, rows)
            self._label(cam, t, seg, poses, rows)
            if self.progress is not None:
                self.progress(1)
            return
        self.pending.append((self.lanes[cam.name].submit(self._perceive, cam, t, rgb, rows),
                             self.pool.submit(self._label, cam, t, seg, poses, rows)))
        if len(self.pending) > in_flight(self.workers):
            self._finish_oldest()

    def finish(self) -> dict[str, list]:
        """Waits for every frame; the rows of each table in frame order."""
        while self.pending:
            self._finish_oldest()
        return {k: [row for rows in self.frames for row in rows[k]] for k in COLUMNS}

    def close(self) -> None:
        """Stops the workers (frames not yet started are dropped: after a failure)."""
        if self.pool is not None:
            for fs in self.pending:
                for f in fs:
                    f.cancel()
            self.pool.shutdown(wait=True)

    def _finish_oldest(self) -> None:
        t0 = time.perf_counter()
        for f in self.pending.popleft():
            f.result()  # re-raises a worker's exception here
        self.tm["wait"] += time.perf_counter() - t0
        if self.progress is not None:
            self.progress(1)

    def _add_time(self, key: str, seconds: float) -> None:
        with self._lock:
            self.tm[key] += seconds

    def _perceive(self, cam, t, rgb, rows) -> None:
        t0 = time.perf_counter()
        _perceive(cam, t, rgb, self.backgrounds, self.overhead, self.flow, self.app, self.params, rows)
        t1 = time.perf_counter()
        if self.sink is not None:
            self.sink.write(cam.name, rgb, cam.fps)
        self._add_time("perception", t1 - t0)
        self._add_time("video", time.perf_counter() - t1)

    def _label(self, cam, t, seg, poses, rows) -> None:
        t0 = time.perf_counter()
        masks = self._local.__dict__.setdefault("masks", {})
        mask = masks.get((cam.width, cam.height))
        if mask is None:
            mask = masks[(cam.width, cam.height)] = np.zeros((cam.height, cam.width), np.uint8)
        _label(cam, t, seg, self.names, self.model, poses, self.person_geoms, mask, rows)
        self._add_time("labels", time.perf_counter() - t0)


def pose_snapshot(data, geoms: np.ndarray) -> GeomPoses:
    """The given geoms' world poses now (others zero), for labels computed after the world moves on."""
    xpos = np.zeros_like(data.geom_xpos)
    xmat = np.zeros_like(data.geom_xmat)
    xpos[geoms], xmat[geoms] = data.geom_xpos[geoms], data.geom_xmat[geoms]
    return GeomPoses(xpos, xmat)


def observe(world, scene, traj, rng=None, save_frames=None, timings: dict | None = None,
            workers: int | None = None, progress=None):
    """Render every camera, run perception, label from segmentation.

    Returns (observation tables, truth tables): ``bearings`` (+ ``width``), ``boxes``,
    ``floor_detections``; ``visibility``, ``labels``. ``save_frames``: a folder to write
    ``<camera>.mp4`` into, or None. ``rng`` is unused: pixels are deterministic and the
    perception errors are the measurement noise. ``timings``: a dict that receives seconds spent
    per stage (pose, render, segment in the rendering thread; perception, labels, video summed
    over the threads that run them; ``wait``: the rendering thread waiting for those).
    ``progress``: called with 1 for every camera frame finished, in frame order.

    ``workers`` (default ``worker_count()``: ``TRACKROOM_RENDER_WORKERS`` or the available cores):
    threads that run perception, labels and MP4 writing (``FrameWork``) while this thread poses
    and renders the next frames (MuJoCo's render and OpenCV release the GIL). The tables are identical whatever the number of workers;
    0: everything in the calling thread.
    """
    tm = timings if timings is not None else {}
    for key in STAGES:
        tm.setdefault(key, 0.0)
    workers = worker_count(workers)
    model, data, cam_ids, person_geoms = world_maps(world, scene)
    check_cameras(model, scene, cam_ids)
    P = len(person_geoms)
    names = list(traj.names) if len(getattr(traj, "names", ())) == P else [w.name for w in scene.walkers]
    person_of_geom = np.full(model.ngeom, -1, np.int16)
    for i, g in enumerate(person_geoms):
        person_of_geom[g] = i
    all_geoms = np.concatenate(person_geoms) if P else np.zeros(0, int)
    sink = VideoSink(save_frames) if save_frames else None
    renderer = SceneRenderer(model, person_of_geom, shadows=scene.render.shadows)
    work = None
    try:
        _pose(world, traj, 0)
        backgrounds = {c.name: renderer.background(data, cam_ids[c.name], c.width, c.height, all_geoms)
                       for c in scene.cameras}
        work = FrameWork(scene, model, person_geoms, names, backgrounds, workers, sink, tm, progress)
        for k, due in camera_schedule(scene, traj).items():
            t0 = time.perf_counter()
            _pose(world, traj, k)
            poses = pose_snapshot(data, all_geoms)
            tm["pose"] += time.perf_counter() - t0
            for cam, t in due:
                t1 = time.perf_counter()
                r = renderer.renderer(cam.width, cam.height)
                r.update_scene(data, camera=cam_ids[cam.name])
                rgb = r.render()
                t2 = time.perf_counter()
                seg = renderer.segment(data, cam_ids[cam.name], cam.width, cam.height)
                tm["segment"] += time.perf_counter() - t2
                tm["render"] += t2 - t1
                work.submit(cam, t, rgb, seg, poses)
        rows = work.finish()
    finally:
        if work is not None:
            work.close()
        renderer.close()
        if sink is not None:
            sink.close()
    return _tables(rows)


def _pose(world, traj, k: int) -> None:
    """Positions only (kinematics) are enough to render; ``mj_kinematics`` leaves cameras and
    lights alone, so ``mj_camlight`` places them."""
    (getattr(world, "set_pose", None) or world.set_step)(traj, k)
    mujoco.mj_camlight(world.model, world.data)


def camera_quat(cam: Camera) -> np.ndarray:
    """MuJoCo camera orientation (w, x, y, z) of a calibrated camera: columns x = right,
    y = up (OpenCV's -y), z = backward (OpenCV's -z)."""
    R = cam.R
    mat = np.column_stack([R[0], -R[1], -R[2]])
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    return q


CAMERA_TOL = 1e-9  # position (m), orientation (quaternion components), fovy (degrees)


def check_cameras(model, scene, cam_ids) -> None:
    """Check that each compiled MuJoCo camera is the calibrated ``Camera`` (position,
    orientation, fovy, fixed mode): the camera model is the reference that the analytic mode and
    the estimators use, so the pixels must come from exactly that camera. ``sim.world`` builds
    them so (since commit 3d17992; a MuJoCo-marker render's segmentation centroid lies within
    0.25 px of ``Camera.project`` for every camera kind); a ValueError names a camera that is not."""
    for c in scene.cameras:
        i = cam_ids[c.name]
        q, qc = model.cam_quat[i], camera_quat(c)
        bad = []
        if np.abs(model.cam_pos[i] - np.asarray(c.position, float)).max() > CAMERA_TOL:
            bad.append(f"position {model.cam_pos[i].tolist()} != {list(c.position)}")
        if min(np.abs(q - qc).max(), np.abs(q + qc).max()) > CAMERA_TOL:
            bad.append(f"orientation {q.tolist()} != {qc.tolist()}")
        if abs(model.cam_fovy[i] - np.degrees(c.fovy)) > CAMERA_TOL:
            bad.append(f"fovy {model.cam_fovy[i]} != {np.degrees(c.fovy)}")
        if model.cam_mode[i] != mujoco.mjtCamLight.mjCAMLIGHT_FIXED:
            bad.append("not a fixed camera")
        if bad:
            raise ValueError(f"MuJoCo camera {c.name!r} is not the calibrated camera: {'; '.join(bad)}")


def _perceive(cam, t, rgb, backgrounds, overhead, flow, app, params, rows) -> None:
    if cam.kind in ("horizontal", "oblique"):
        for d in detect_bearings(rgb, backgrounds[cam.name], app, params):
            rows["bearings"].append((t, cam.name, d.u, d.label, d.width))
    if cam.kind == "overhead":
        for x, y in overhead[cam.name](rgb):
            rows["floor_detections"].append((t, cam.name, x, y))
    if cam.kind == "oblique":
        for w in flow[cam.name](rgb):
            b = w.box
            rows["boxes"].append((t, cam.name, w.track, w.u, b[0], b[2], b[1], b[3],
                                  float(w.flow[0] * cam.fps), float(w.flow[1] * cam.fps)))


def _label(cam, t, seg, names, model, poses, person_geoms, mask, rows) -> None:
    counts, boxes = frame_labels(seg, len(person_geoms))
    for i, geoms in enumerate(person_geoms):
        area = unoccluded_pixels(cam, model, poses, geoms, mask)
        frac = min(1.0, counts[i] / area) if area > 0 else 0.0
        rows["visibility"].append((t, cam.name, names[i], area > 0, bool(counts[i] > 0 and frac >= VISIBLE_FRACTION)))
        if counts[i] > 0:
            rows["labels"].append((t, cam.name, names[i], int(counts[i]), frac, *boxes[i]))


COLUMNS = {
    "bearings": ["t", "camera", "u", "label", "width"],
    "boxes": ["t", "camera", "track", "u", "u_left", "u_right", "v_top", "v_bottom", "flow_u", "flow_v"],
    "floor_detections": ["t", "camera", "x", "y"],
    "visibility": ["t", "camera", "person_id", "in_fov", "visible"],
    "labels": ["t", "camera", "person_id", "pixels", "visible_fraction", "x0", "y0", "x1", "y1"],
}


def _tables(rows):
    tables = {}
    for kind, cols in COLUMNS.items():
        df = pd.DataFrame(rows[kind], columns=cols)
        for c in cols:
            if c in ("camera", "label", "person_id"):
                df[c] = df[c].astype(object)
            elif c in ("in_fov", "visible"):
                df[c] = df[c].astype(bool)
            elif c in ("track", "pixels"):
                df[c] = df[c].astype(np.int64)
            else:
                df[c] = df[c].astype(float)
        tables[kind] = df.sort_values("t", kind="stable").reset_index(drop=True)
    obs = {k: tables[k] for k in ("bearings", "boxes", "floor_detections")}
    truth = {k: tables[k] for k in ("visibility", "labels")}
    return obs, truth
