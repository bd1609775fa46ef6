"""Analytic sensing: camera observations from ground truth through the camera model.

Geometry (vectorised over frames and people, no MuJoCo): a person is a vertical cylinder of
radius r from the floor to height h around its axis (x, y); its body centre c = (x, y, z).
Pixels come from the scene's camera model s [u, v, 1]^T = P [X; 1] (``scenes.camera.Camera``).

Field of view (``in_fov``):
- overhead: the projected body centre lies in the image, in front of the camera;
- horizontal and oblique: the body centre is in front of the camera, its u lies in [0, W) and the
  projected axis from floor to head overlaps the rows [0, H).

Visibility (``visible``): in the field of view and not occluded. Occlusion is decided by MuJoCo
ray casts (``mj_multiRay``, one call per camera frame) from the camera's optical centre to points
on the person's axis at VIS_FRACTIONS of the height (body centre, chest, head). A point is seen
when the first geom the ray hits is the person's own capsule (or nothing lies before the point);
walls, obstacles and other people's capsules occlude. A person is visible when at least one point
is seen.

Observations of visible people (noise from ``sim.noise``):
- horizontal and oblique cameras -> ``bearings``: u of the projected body centre, label = the
  walker's colour name (an appearance class, not an id);
- oblique cameras -> ``boxes``: the window of the projected cylinder (its top and bottom circles,
  clipped to the image) cut at the bottom where the floor plan's boxes hide the person's lower
  part (``box_cut_rows``: a flow tracker's window is made of the person's moving pixels, and a
  box's are still), u of the body centre, and the image velocity of the body centre
  d(u, v)/dt = f / Z (Xdot - X Zdot / Z, Ydot - Y Zdot / Z) (px/s; X, Y, Z camera coordinates,
  dots their rates R v). Only where that image speed is at least ``sensors.flow_min_px_s``:
  an optical-flow tracker finds no moving region for a person standing still (the rendered
  Farneback windows of ``sim.perception_flow`` do not either). ``track`` is the camera's tracker
  id: kept while the person stays visible and moving from frame to frame, a new one after a gap;
- overhead cameras -> ``floor_detections``: (x, y) plus noise; with a ``region``, only where the
  *measured* position lies in [xmin, xmax) x [ymin, ymax); a privacy camera quantises and misses
  people whose true horizontal speed is below ``sensors.still_speed``.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pandas as pd

from trackroom.scenes.camera import Camera
from trackroom.scenes.spec import Scene, hidden_heights, occluding_boxes

from . import noise
from .walkers import Trajectories
from .world import World

VIS_FRACTIONS = (0.5, 0.75, 0.95)  # of the person's height, floor = 0
# oblique cameras: one more ray, to the top of the head (this share of the height), tells whether
# any of a person is seen over an obstacle that hides the axis rays (``Occlusion.head``): behind a
# shelf or a standing person, the rendered flow tracker still reports a strip window on the head
HEAD_TOP = 1.0
CIRCLE_SAMPLES = 16  # points on each rim of the cylinder for its window
CUT_LINES = 5  # vertical lines across the cylinder, edge to edge, on which a box's cut is found
PROGRESS_EVERY = 100  # camera frames between progress reports of ``Occlusion.finish``


def str_column(names, index) -> pd.api.extensions.ExtensionArray:
    """``names[index]`` as a pandas string column (the ``str`` dtype pandas infers for text),
    by one Arrow ``take`` from the few distinct names: ~6x faster than converting a long
    object array of Python strings, same values and dtype."""
    return pd.array(np.asarray(names, dtype=object), dtype="str").take(np.asarray(index, dtype=np.intp))


def frame_steps(cam: Camera, traj: Trajectories) -> np.ndarray:
    """Trajectory steps of a camera's frames: every rate/fps steps from t = 0."""
    stride = int(round(traj.rate / cam.fps))
    return np.arange(0, traj.n_steps, stride)


@dataclass
class CameraGeometry:
    """Noise-free projections of every person at a camera's frames (F frames, P people)."""

    steps: np.ndarray  # (F,)
    uv: np.ndarray  # (F, P, 2) projected body centre
    depth: np.ndarray  # (F, P)
    in_fov: np.ndarray  # (F, P) bool
    # (F, P, 4) u_left, u_right, v_top, v_bottom (oblique), clipped to the image; from
    # ``camera_geometry``, v_bottom is cut where the floor plan's boxes hide the lower part
    edges: np.ndarray | None = None
    span: np.ndarray | None = None  # (F, P, 2) u extent of the projected cylinder, not clipped (horizontal, oblique)
    near: np.ndarray | None = None  # (F, P) bool: some of the person's image lies in the image (in_fov for overhead)
    flow: np.ndarray | None = None  # (F, P, 2) px/s (oblique)
    cut_px: np.ndarray | None = None  # (F, P) px of the window's bottom the floor plan's boxes hide (oblique; 0: none)
    axis: np.ndarray | None = None  # (F, P, 2, 2) image points of the feet and the top of the head (overhead)
    width_px: np.ndarray | None = None  # (F, P) projected body diameter at the body centre, px (overhead)
    # (F, P) overhead: how far out (m, along the camera's radial direction) the rendered detector
    # places a person whose head is higher than the nominal person's (the scene's mean height) by
    # dz, gait bob included: it back-projects the head's outer tangent ray to the nominal head
    # height, so the floor point moves out by dz R / (H - Z) (R the person's horizontal distance
    # from the camera, H the camera's height, Z the nominal head top)
    head_shift: np.ndarray | None = None


def project_people(cam: Camera, traj: Trajectories, heights: np.ndarray, radii: np.ndarray, steps: np.ndarray) -> CameraGeometry:
    """Projections, field of view and (oblique) windows and flow at ``steps``."""
    c = traj.pos[:, steps].transpose(1, 0, 2)  # (F, P, 3)
    uv, depth = cam.project(c)
    if cam.kind == "overhead":
        in_fov = cam.in_image(uv, depth)
        ends = np.repeat(c[..., None, :], 2, axis=-2)  # (F, P, 2, 3): feet, top of the head
        ends[..., 0, 2] = c[..., 2] - 0.5 * heights
        ends[..., 1, 2] = c[..., 2] + 0.5 * heights
        with np.errstate(divide="ignore", invalid="ignore"):
            width_px = np.where(depth > 1e-6, 2.0 * radii * cam.focal / depth, 0.0)
        top = float(np.mean(heights)) if len(heights) else 0.0
        rng_h = np.hypot(c[..., 0] - cam.position[0], c[..., 1] - cam.position[1])
        head_shift = (ends[..., 1, 2] - top) * rng_h / max(float(cam.position[2]) - top, 0.1)
        return CameraGeometry(steps=steps, uv=uv, depth=depth, in_fov=in_fov, near=in_fov,
                              axis=cam.project(ends)[0], width_px=width_px, head_shift=head_shift)
    else:
        foot = c.copy()
        foot[..., 2] = c[..., 2] - 0.5 * heights
        head = c.copy()
        head[..., 2] = foot[..., 2] + heights
        v_foot = cam.project(foot)[0][..., 1]
        v_head = cam.project(head)[0][..., 1]
        lo, hi = np.minimum(v_foot, v_head), np.maximum(v_foot, v_head)
        rows = (depth > 1e-6) & (hi >= 0) & (lo < cam.height)
        in_fov = rows & (uv[..., 0] >= 0) & (uv[..., 0] < cam.width)
    geo = CameraGeometry(steps=steps, uv=uv, depth=depth, in_fov=in_fov, near=in_fov)
    if cam.kind != "overhead":
        ang = np.linspace(0, 2 * np.pi, CIRCLE_SAMPLES, endpoint=False)
        ring = np.stack([np.cos(ang), np.sin(ang)], -1)  # (S, 2)
        base = c[..., None, :2] + radii[None, :, None, None] * ring  # (F, P, S, 2)
        z0 = (c[..., 2] - 0.5 * heights)[..., None, None]
        pts = np.concatenate(
            [
                np.concatenate([base, np.broadcast_to(z0, base.shape[:-1] + (1,))], -1),
                np.concatenate([base, np.broadcast_to(z0 + heights[None, :, None, None], base.shape[:-1] + (1,))], -1),
            ],
            axis=-2,
        )
        puv, pz = cam.project(pts)
        # points behind the camera project mirrored: a person beside a wall camera, partly behind
        # its image plane, would otherwise span the whole image and be "seen" in its middle
        front = (pz > 1e-6)[..., None]
        puv = np.where(front, puv, np.nan)
        with np.errstate(invalid="ignore"):
            geo.span = np.stack([np.fmin.reduce(puv[..., 0], -1), np.fmax.reduce(puv[..., 0], -1)], -1)
        geo.span = np.nan_to_num(geo.span, nan=-np.inf)  # wholly behind: an empty span left of the image
        geo.near = in_fov | (rows & (geo.span[..., 1] > 0) & (geo.span[..., 0] < cam.width))
        if cam.kind == "horizontal":
            return geo
        edges = np.concatenate([geo.span, np.fmin.reduce(puv[..., 1], -1)[..., None], np.fmax.reduce(puv[..., 1], -1)[..., None]], -1)
        edges[..., 0:2] = np.clip(edges[..., 0:2], 0, cam.width)
        edges[..., 2:4] = np.clip(np.nan_to_num(edges[..., 2:4], nan=0.0), 0, cam.height)
        pc = cam.to_camera(c)  # (F, P, 3)
        vc = traj.vel[:, steps].transpose(1, 0, 2) @ cam.R.T
        with np.errstate(divide="ignore", invalid="ignore"):
            Z = pc[..., 2]
            flow = cam.focal / Z[..., None] * (vc[..., :2] - pc[..., :2] * (vc[..., 2] / Z)[..., None])
        geo.edges, geo.flow = edges, np.nan_to_num(flow)
    return geo


class Occlusion:
    """Ray-cast visibility of every person at every camera frame (see the module docstring).

    Call ``on_step(k)`` with the world posed at trajectory step k (``World.set_step`` or
    ``set_pose``); ``finish()`` poses and casts the frames that were not visited and turns the
    ray hits into ``visible`` (camera name -> (F, P) bool).

    Cost: the rays are laid out once, before the loop, in one flat array per camera (only people
    in the field of view, frame after frame), so a camera frame is one ``mj_multiRay`` call on a
    contiguous slice and the hits are judged for all frames at once in ``finish``; the per-frame
    schedule (``due``) is built on first use, so the simulator's ray thread builds it.
    ``frame_steps``: the sorted steps at which some camera casts.
    """

    def __init__(self, world: World, scene: Scene, traj: Trajectories, geometry: dict[str, CameraGeometry], head_ray: bool = False):
        self.world, self.scene, self.traj, self.geometry = world, scene, traj, geometry
        self.heights = np.array([w.height for w in scene.walkers])
        self.visible = {name: np.zeros_like(g.in_fov) for name, g in geometry.items()}
        self.fraction = {name: np.zeros(g.in_fov.shape) for name, g in geometry.items()}  # share of rays that reach the person
        self.cams = [scene.camera(name) for name in geometry]
        V = len(VIS_FRACTIONS)
        # (oblique cameras, with ``head_ray``) 1 where the ray to the top of the head reaches the
        # person; not cast (no entry) for other cameras, or without ``head_ray`` (a model that does
        # not use it: one ray in four less per oblique camera frame)
        self.head = {c.name: np.zeros(geometry[c.name].in_fov.shape) for c in self.cams if head_ray and c.kind == "oblique"}
        self._own = np.asarray(world.person_geom, np.int32)
        self._cams = []  # per camera: (frame index, person index) of each ray group, target lengths, hits
        self._layout = []  # per camera: frame steps, ray bounds of each frame, origin, flat rays and hits, cutoff
        for cam in self.cams:
            g = geometry[cam.name]
            f_idx, p_idx = np.nonzero(g.near)  # row-major: frame after frame (near: in_fov and people cut by the border)
            pos = traj.pos[p_idx, g.steps[f_idx]]  # (R, 3) body centres
            z = (pos[:, 2] - 0.5 * self.heights[p_idx])[:, None] + self.heights[p_idx, None] * np.asarray(VIS_FRACTIONS)
            pts = np.concatenate([np.broadcast_to(pos[:, None, :2], z.shape + (2,)), z[..., None]], -1)  # (R, V, 3)
            origin = np.asarray(cam.position, float)
            if cam.name in self.head:
                top = np.concatenate([pos[:, :2], (pos[:, 2] + (HEAD_TOP - 0.5) * self.heights[p_idx])[:, None]], -1)
                pts = np.concatenate([pts, top[:, None, :]], axis=1)
            n_rays = pts.shape[1]
            vec = pts - origin
            length = np.sqrt((vec * vec).sum(-1))  # (R, n_rays)
            vec = np.ascontiguousarray((vec / length[..., None]).reshape(-1))
            cutoff = float(length.max() + 1.0) if length.size else 1.0
            geomid = np.full(length.size, -1, np.int32)
            dist = np.full(length.size, -1.0)
            self._cams.append((f_idx, p_idx, length, geomid, dist))
            bounds = n_rays * np.searchsorted(f_idx, np.arange(len(g.steps) + 1))  # rays of each frame
            self._layout.append((g.steps, bounds, origin, vec, geomid, dist, cutoff))
        # the trajectory steps at which some camera casts rays
        self.frame_steps = np.unique(np.concatenate([steps[b[1:] > b[:-1]] for steps, b, *_ in self._layout] or [np.zeros(0, int)]))
        self._due: dict[int, list[tuple]] | None = None
        self.done: set[int] = set()

    @property
    def due(self) -> dict[int, list[tuple]]:
        """step -> [(origin, directions, geomid, dist, nray, cutoff)] of the cameras casting there:
        views into the flat arrays (built on first use: ``finish`` may run in another thread)."""
        if self._due is None:
            due: dict[int, list[tuple]] = {}
            for steps, bounds, origin, vec, geomid, dist, cutoff in self._layout:
                bounds = bounds.tolist()
                for k, a, b in zip(steps.tolist(), bounds[:-1], bounds[1:]):
                    if b > a:
                        item = (origin, vec[3 * a : 3 * b], geomid[a:b], dist[a:b], b - a, cutoff)
                        if k in due:
                            due[k].append(item)
                        else:
                            due[k] = [item]
            self._due = due
        return self._due

    def on_step(self, k: int) -> None:
        due = self.due.get(k)
        if due is None:
            return
        m, d, ray = self.world.model, self.world.data, mujoco.mj_multiRay
        for origin, vec, geomid, dist, nray, cutoff in due:
            ray(m, d, origin, vec, None, 1, -1, geomid, dist, None, nray, cutoff)
        self.done.add(k)

    def _rays(self, geomid, dist, length, people) -> np.ndarray:
        """(R, n) bool: a ray reaches its point when it first hits the person's own capsule, hits
        nothing, or hits something only beyond the point (n rays per person: ``length``'s columns)."""
        n = length.shape[-1] if length.ndim > 1 else len(VIS_FRACTIONS)
        own = np.repeat(self._own[people], n)
        seen = (geomid == own) | (geomid < 0) | (dist >= length.ravel() - 1e-6)
        return seen.reshape(len(people), -1)

    def _seen(self, geomid, dist, length, people) -> np.ndarray:
        """A person is seen when any of their V rays reaches them."""
        return self._rays(geomid, dist, length, people).any(axis=1)

    def cast(self, cam: Camera, k: int, people: np.ndarray) -> np.ndarray:
        """Visible flags of ``people`` from ``cam`` with the world posed at step k (any step)."""
        origin = np.asarray(cam.position, float)
        centre = self.traj.pos[people, k]
        z = (centre[:, 2] - 0.5 * self.heights[people])[:, None] + np.outer(self.heights[people], VIS_FRACTIONS)
        pts = np.concatenate([np.broadcast_to(centre[:, None, :2], z.shape + (2,)), z[..., None]], -1).reshape(-1, 3)
        vec = pts - origin
        length = np.sqrt((vec * vec).sum(1))
        vec = np.ascontiguousarray((vec / length[:, None]).ravel())
        geomid, dist = np.zeros(len(length), np.int32), np.zeros(len(length))
        mujoco.mj_multiRay(self.world.model, self.world.data, origin, vec, None, 1, -1, geomid, dist, None, len(length), float(length.max() + 1.0))
        return self._seen(geomid, dist, length, np.asarray(people))

    def finish(self, progress=None) -> None:
        """Pose and cast every frame not visited yet, then judge the hits; ``progress(n)`` every
        PROGRESS_EVERY frames with the number cast since its last call."""
        todo = sorted(set(self.due) - self.done)
        # World.set_pose and on_step, unrolled: this loop runs once per camera frame (12000 for
        # 600 s at 20 Hz), so the MuJoCo functions and arrays are fetched once
        world, ray, kinematics = self.world, mujoco.mj_multiRay, mujoco.mj_kinematics
        m, d, Q, qpos = world.model, world.data, world.packed_positions(self.traj), world.data.qpos
        for j, k in enumerate(todo):
            qpos[:] = Q[k]
            kinematics(m, d)
            for origin, vec, geomid, dist, nray, cutoff in self.due[k]:
                ray(m, d, origin, vec, None, 1, -1, geomid, dist, None, nray, cutoff)
            if progress is not None and j % PROGRESS_EVERY == PROGRESS_EVERY - 1:
                progress(PROGRESS_EVERY)
        if progress is not None and len(todo) % PROGRESS_EVERY:
            progress(len(todo) % PROGRESS_EVERY)
        self.done.update(todo)
        for cam, (f_idx, p_idx, length, geomid, dist) in zip(self.cams, self._cams):
            g_in_fov = self.geometry[cam.name].in_fov
            vis, frac = self.visible[cam.name], self.fraction[cam.name]
            vis[:] = False
            frac[:] = 0.0
            if cam.name in self.head:
                self.head[cam.name][:] = 0.0
            if len(f_idx):
                rays = self._rays(geomid, dist, length, p_idx)
                centre = rays[:, : len(VIS_FRACTIONS)]
                vis[f_idx, p_idx] = centre.any(axis=1) & g_in_fov[f_idx, p_idx]
                frac[f_idx, p_idx] = centre.mean(axis=1)
                if cam.name in self.head:
                    self.head[cam.name][f_idx, p_idx] = rays[:, len(VIS_FRACTIONS)]


def camera_geometry(scene: Scene, traj: Trajectories) -> dict[str, CameraGeometry]:
    """Every camera's projections of every person at its frames; oblique windows cut at the
    floor plan's boxes (``box_cut_rows``)."""
    heights = np.array([w.height for w in scene.walkers])
    radii = np.array([w.radius for w in scene.walkers])
    out = {}
    boxes = occluding_boxes(scene.floorplan)
    for c in scene.cameras:
        g = out[c.name] = project_people(c, traj, heights, radii, frame_steps(c, traj))
        if c.kind == "oblique" and len(boxes):
            cut = box_cut_rows(c, traj, heights, radii, g.steps, boxes)
            bottom = np.minimum(g.edges[..., 3], np.maximum(cut, g.edges[..., 2] + 1.0))
            g.cut_px = g.edges[..., 3] - bottom
            g.edges[..., 3] = bottom
    return out


def box_cut_rows(cam: Camera, traj: Trajectories, heights: np.ndarray, radii: np.ndarray, steps: np.ndarray,
                 boxes: np.ndarray) -> np.ndarray:
    """(F, P) the lowest image row of each person that the boxes (``occluding_boxes``) leave seen
    from oblique camera ``cam`` at ``steps``; +inf where some of the person is seen down to the
    floor (no cut). The person is taken as CUT_LINES vertical lines across its cylinder, square
    to the camera's view; on each, ``hidden_heights`` gives how high the boxes hide it; the row
    is the lowest of the lines' seen bottoms (the top of the head's row where every line is
    hidden). Other people are not cut out: they move, and a flow tracker merges them in."""
    c = traj.pos[:, steps].transpose(1, 0, 2)  # (F, P, 3)
    eye = np.asarray(cam.position, float)
    along = c[..., :2] - eye[:2]
    along /= np.maximum(np.hypot(along[..., 0], along[..., 1]), 1e-9)[..., None]
    across = np.stack([-along[..., 1], along[..., 0]], -1)
    offs = np.linspace(-1.0, 1.0, CUT_LINES)[None, None, :, None] * radii[None, :, None, None]
    xy = c[..., None, :2] + offs * across[..., None, :]  # (F, P, L, 2)
    feet = (c[..., 2] - 0.5 * heights)[..., None]  # (F, P, 1)
    z = hidden_heights(boxes, eye, xy)  # (F, P, L)
    top = feet + heights[None, :, None]
    pts = np.concatenate([xy, np.clip(z, feet, top)[..., None]], -1)
    v = cam.project(pts)[0][..., 1]  # (F, P, L): each line's seen bottom
    rows = np.where(np.isnan(v), -np.inf, v).max(-1)
    # no cut where some line is seen at the floor, or no row is defined (a point in the camera's plane)
    return np.where((z < feet).any(-1) | ~np.isfinite(rows), np.inf, rows)


def _sorted(df: pd.DataFrame, value: str) -> pd.DataFrame:
    # by time, camera, then a measured value: row order must not reveal who is who
    return df.sort_values(["t", "camera", value], kind="mergesort", ignore_index=True)


def observation_tables(scene: Scene, traj: Trajectories, geometry: dict[str, CameraGeometry], visible: dict[str, np.ndarray], rngs: dict[str, np.random.Generator]) -> dict[str, pd.DataFrame]:
    """bearings, boxes, floor_detections from the geometry and visibility (noise per camera)."""
    s = scene.sensors
    labels = np.array([w.color_name for w in scene.walkers], dtype=object)
    out: dict[str, list] = {"bearings": [], "boxes": [], "floor_detections": []}
    for cam in scene.cameras:
        g, vis, rng = geometry[cam.name], visible[cam.name], rngs[cam.name]
        f_idx, p_idx = np.nonzero(vis)  # row-major: by frame, then person
        t = traj.t[g.steps[f_idx]]
        if cam.kind in ("horizontal", "oblique") and len(f_idx):
            u = noise.bearing(rng, g.uv[f_idx, p_idx, 0], s)
            out["bearings"].append(pd.DataFrame({"t": t, "camera": cam.name, "u": u, "label": str_column(labels, p_idx)}))
        if cam.kind == "oblique":
            moving = flow_detectable(g, s.flow_min_px_s) & vis
            fb, pb = np.nonzero(moving)
        if cam.kind == "oblique" and len(fb):
            edges, u, flow = noise.box(rng, g.edges[fb, pb], g.uv[fb, pb, 0], g.flow[fb, pb], cam.fps, s)
            track = _track_ids(moving, g.uv[..., 0])[fb, pb]
            out["boxes"].append(
                pd.DataFrame(
                    {
                        "t": traj.t[g.steps[fb]], "camera": cam.name, "track": track, "u": u,
                        "u_left": edges[:, 0], "u_right": edges[:, 1], "v_top": edges[:, 2], "v_bottom": edges[:, 3],
                        "flow_u": flow[:, 0], "flow_v": flow[:, 1],
                    }
                )
            )
        if cam.kind == "overhead":
            keep = np.ones(len(f_idx), bool)
            if cam.privacy:
                speed = np.hypot(traj.vel[p_idx, g.steps[f_idx], 0], traj.vel[p_idx, g.steps[f_idx], 1])
                keep = speed >= s.still_speed
            xy = noise.floor_position(rng, traj.pos[p_idx, g.steps[f_idx], :2], s, cam.quantum if cam.privacy else 0.0)
            keep &= cam.in_region(xy)
            if keep.any():
                out["floor_detections"].append(pd.DataFrame({"t": t[keep], "camera": cam.name, "x": xy[keep, 0], "y": xy[keep, 1]}))
    return _collect(out)


def flow_detectable(g: CameraGeometry, min_px_s: float) -> np.ndarray:
    """(F, P) bool: the image speed |d(u, v)/dt| of the body centre is at least ``min_px_s``
    (px/s), so an optical-flow tracker sees the person move."""
    return np.hypot(g.flow[..., 0], g.flow[..., 1]) >= min_px_s


def _track_ids(vis: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Per-camera tracker ids (F, P): a new id each time a person becomes visible, kept while
    they stay visible in consecutive frames; numbered in order of appearance (by frame, then by
    image column u, so the numbering does not follow the scene's walker order)."""
    starts = vis & ~np.vstack([np.zeros((1, vis.shape[1]), bool), vis[:-1]])
    ids = np.full(vis.shape, -1, np.int64)
    f, p = np.nonzero(starts)
    order = np.lexsort((u[f, p], f))
    ids[f[order], p[order]] = np.arange(len(f))
    # carry each id forward while visible
    for f in range(1, vis.shape[0]):
        cont = vis[f] & ~starts[f]
        ids[f, cont] = ids[f - 1, cont]
    return ids


def visibility_table(scene: Scene, traj: Trajectories, geometry: dict[str, CameraGeometry], visible: dict[str, np.ndarray]) -> pd.DataFrame:
    """Truth ``visibility``: t, camera, person_id, in_fov, visible for every frame and person,
    sorted by t then camera (stably: people in scene order)."""
    names = np.array([w.name for w in scene.walkers], dtype=object)
    if not scene.cameras:
        return pd.DataFrame({"t": pd.Series(dtype=float), "camera": pd.Series(dtype=object), "person_id": pd.Series(dtype=object), "in_fov": pd.Series(dtype=bool), "visible": pd.Series(dtype=bool)})
    cams = [c.name for c in scene.cameras]
    P = len(names)
    t = np.concatenate([np.repeat(traj.t[geometry[c].steps], P) for c in cams])
    cam = np.concatenate([np.full(geometry[c].in_fov.size, j) for j, c in enumerate(cams)])
    # the order a stable sort by (t, camera name) gives, taken once for every column
    order = np.lexsort((np.argsort(np.argsort(cams, kind="stable"), kind="stable")[cam], t))
    return pd.DataFrame(
        {
            "t": t[order], "camera": str_column(cams, cam[order]),
            "person_id": str_column(names, np.concatenate([np.tile(np.arange(P), geometry[c].in_fov.shape[0]) for c in cams])[order]),
            "in_fov": np.concatenate([geometry[c].in_fov.ravel() for c in cams])[order],
            "visible": np.concatenate([visible[c].ravel() for c in cams])[order],
        },
        copy=False,
    )


def modelled_observation_tables(scene: Scene, traj: Trajectories, geometry: dict[str, CameraGeometry], fraction: dict[str, np.ndarray],
                                rngs: dict[str, np.random.Generator], model, head: dict[str, np.ndarray] | None = None) -> dict[str, pd.DataFrame]:
    """bearings, boxes, floor_detections from the geometry through a fitted perception model
    (``sim.perception_model``, ``sim.analytic_detectors``): misses, merges, label confusion,
    false detections and tracker ids as the rendered detectors make them. ``head``: the oblique
    cameras' head rays (``Occlusion.head``), which a windows model's partial windows may use."""
    from . import analytic_detectors as det

    colours = [w.color_name for w in scene.walkers]
    palette = sorted(set(colours))
    outline = np.asarray(scene.floorplan.outline, float)
    bounds = (*outline.min(axis=0), *outline.max(axis=0))
    out: dict[str, list] = {"bearings": [], "boxes": [], "floor_detections": []}
    for cam in scene.cameras:
        g, frac, rng = geometry[cam.name], fraction[cam.name], rngs[cam.name]
        t = traj.t[g.steps]
        if cam.kind in ("horizontal", "oblique"):
            out["bearings"].append(det.blobs(cam, g, frac, t, model[cam.kind], rng, colours, palette))
        if cam.kind == "oblique":  # the windows from a stream of their own: a refit of the blob detector leaves them as they are
            out["boxes"].append(det.windows(cam, g, frac, t, model["windows"], rng.spawn(1)[0], None if head is None else head.get(cam.name)))
        if cam.kind == "overhead":
            m = model["privacy" if cam.privacy else "overhead"]
            out["floor_detections"].append(det.floor(cam, g, frac, traj, t, m, rng, bounds))
    return _collect(out)


def _collect(out: dict[str, list]) -> dict[str, pd.DataFrame]:
    """One table per kind from the cameras' parts (None: a camera with nothing), rows sorted by
    time, camera and a measured value; kinds without rows are left out."""
    tables = {}
    for kind, key in (("bearings", "u"), ("boxes", "u"), ("floor_detections", "x")):
        parts = [d for d in out[kind] if d is not None]
        if parts:
            df = pd.concat(parts, ignore_index=True)
            if kind == "boxes":
                df["track"] = df["track"].astype(np.int64)
            tables[kind] = _sorted(df, key)
    return tables
