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

Threads (``observe(overlap=True)``, the default): the main thread poses the world and draws the
RGB renders, ``sim.render.SegmentationThread`` draws the segmentation renders alongside, and one
worker thread runs perception, labels and MP4 writing on each frame in order (the stateful
detectors see the same sequence), so the tables are identical to the one-thread run. On the
2-core machine this is 1.2-1.3x faster end to end than one thread (``scripts/bench_render.py``).

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

import time
from collections import defaultdict, deque
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import NamedTuple

import cv2
import mujoco
import numpy as np
import pandas as pd

from trackroom.scenes.camera import Camera
from trackroom.sim.perception import Appearance, OverheadDetector, PerceptionParams, PersonModel, detect_bearings
from trackroom.sim.perception_flow import FlowTracker
from trackroom.sim.render import SceneRenderer, SegmentationThread, VideoSink

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


OVERLAP = True  # default of ``observe(overlap=...)``: measured faster end to end (scripts/bench_render.py)
MAX_IN_FLIGHT = 8  # frames rendered ahead of the perception worker at most


def observe(world, scene, traj, rng=None, save_frames=None, timings: dict | None = None,
            overlap: bool | None = None):
    """Render every camera, run perception, label from segmentation.

    Returns (observation tables, truth tables): ``bearings`` (+ ``width``), ``boxes``,
    ``floor_detections``; ``visibility``, ``labels``. ``save_frames``: a folder to write
    ``<camera>.mp4`` into, or None. ``rng`` is unused: pixels are deterministic and the
    perception errors are the measurement noise. ``timings``: a dict that receives seconds spent
    per stage (pose, render, segment in the rendering thread; perception, labels, video in the
    thread that runs them; ``wait``: the rendering thread waiting for that one).

    ``overlap`` (default ``OVERLAP``): perception, labels and MP4 writing of each frame run in one
    worker thread while the main thread poses and renders the next frames (MuJoCo's render and
    OpenCV release the GIL). One worker takes the frames in order, so the stateful detectors (flow
    tracker, privacy gate) see the same sequence and the tables are identical either way.
    """
    tm = timings if timings is not None else {}
    for key in ("pose", "render", "segment", "perception", "labels", "video", "wait"):
        tm.setdefault(key, 0.0)
    overlap = OVERLAP if overlap is None else bool(overlap)
    model, data, cam_ids, person_geoms = world_maps(world, scene)
    check_cameras(model, scene, cam_ids)
    P = len(person_geoms)
    names = list(traj.names) if len(getattr(traj, "names", ())) == P else [w.name for w in scene.walkers]
    person_of_geom = np.full(model.ngeom, -1, np.int16)
    for i, g in enumerate(person_geoms):
        person_of_geom[g] = i
    app = Appearance.from_scene(scene)
    params = PerceptionParams()
    pm = person_model(scene, model, person_geoms)
    schedule = camera_schedule(scene, traj)
    sink = VideoSink(save_frames) if save_frames else None
    renderer = SceneRenderer(model, person_of_geom, shadows=scene.render.shadows)
    rows = {k: [] for k in ("bearings", "boxes", "floor_detections", "visibility", "labels")}
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="perception") if overlap else None
    segmenter = SegmentationThread(renderer) if overlap else None
    pending: deque = deque()
    try:
        _pose(world, traj, 0)
        all_person_geoms = np.concatenate(person_geoms) if P else np.zeros(0, int)
        backgrounds = {c.name: renderer.background(data, cam_ids[c.name], c.width, c.height, all_person_geoms)
                       for c in scene.cameras}
        overhead = {c.name: OverheadDetector(c, backgrounds[c.name], app, pm, params)
                    for c in scene.cameras if c.kind == "overhead"}
        flow = {c.name: FlowTracker(c.width, c.height, camera=c) for c in scene.cameras if c.kind == "oblique"}
        masks = {(c.width, c.height): np.zeros((c.height, c.width), np.uint8) for c in scene.cameras}
        all_geoms = np.concatenate(person_geoms) if P else np.zeros(0, int)

        def process(cam, t, rgb, seg, poses):
            if not isinstance(seg, np.ndarray):
                seg = seg.result()  # the segmentation thread's Future
            t2 = time.perf_counter()
            _perceive(cam, t, rgb, backgrounds, overhead, flow, app, params, rows)
            t3 = time.perf_counter()
            _label(cam, t, seg, names, model, poses, person_geoms, masks[(cam.width, cam.height)], rows)
            t4 = time.perf_counter()
            if sink is not None:
                sink.write(cam.name, rgb, cam.fps)
            t5 = time.perf_counter()
            tm["perception"] += t3 - t2
            tm["labels"] += t4 - t3
            tm["video"] += t5 - t4

        for k, due in schedule.items():
            t0 = time.perf_counter()
            _pose(world, traj, k)
            # the people's geom poses at this step, for the labels (the world moves on meanwhile)
            xpos = np.zeros_like(data.geom_xpos)
            xmat = np.zeros_like(data.geom_xmat)
            xpos[all_geoms], xmat[all_geoms] = data.geom_xpos[all_geoms], data.geom_xmat[all_geoms]
            poses = GeomPoses(xpos, xmat)
            tm["pose"] += time.perf_counter() - t0
            for c, t in due:
                cam = c
                t0 = time.perf_counter()
                if segmenter is not None:  # drawn in its own thread while the RGB render runs
                    seg = segmenter.submit(data, cam_ids[cam.name], cam.width, cam.height)
                t1 = time.perf_counter()
                r = renderer.renderer(cam.width, cam.height)
                r.update_scene(data, camera=cam_ids[cam.name])
                rgb = r.render()
                t2 = time.perf_counter()
                if segmenter is None:
                    seg = renderer.segment(data, cam_ids[cam.name], cam.width, cam.height)
                t3 = time.perf_counter()
                tm["segment"] += (t1 - t0) + (t3 - t2)
                tm["render"] += t2 - t1
                if pool is None:
                    process(cam, t, rgb, seg, poses)
                    continue
                pending.append(pool.submit(process, cam, t, rgb, seg, poses))
                if len(pending) > MAX_IN_FLIGHT:
                    t0 = time.perf_counter()
                    pending.popleft().result()  # re-raises a worker's exception here
                    tm["wait"] += time.perf_counter() - t0
        t0 = time.perf_counter()
        while pending:
            pending.popleft().result()
        tm["wait"] += time.perf_counter() - t0
    finally:
        if pool is not None:
            for f in pending:
                f.cancel()
            pool.shutdown(wait=True)
        if segmenter is not None:
            segmenter.close()
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
