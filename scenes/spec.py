"""Typed scene objects: what a scene file describes, after validation.

All lengths in metres, angles in radians (the TOML file uses degrees, suffixed ``_deg``),
rates in Hz. See ``scenes/loader.py`` for the file format and validation.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .camera import Camera


@dataclass(frozen=True)
class Wall:
    """A straight wall segment from ``start`` to ``end`` (floor x, y) of given thickness and height."""

    start: tuple[float, float]
    end: tuple[float, float]
    thickness: float = 0.1
    height: float = 2.5

    def distance(self, xy) -> np.ndarray:
        """Distance (m) from floor points (..., 2) to the wall's centre line segment."""
        return segment_distance(xy, self.start, self.end)


@dataclass(frozen=True)
class Obstacle:
    """A box on the floor: centre (x, y), full size (sx, sy, sz), yaw (radians)."""

    center: tuple[float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    name: str = ""

    def local(self, xy) -> np.ndarray:
        """Floor points (..., 2) in the box's frame (origin at its centre, axes along its sides)."""
        d = np.asarray(xy, float) - np.asarray(self.center, float)
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return np.stack([d[..., 0] * c + d[..., 1] * s, -d[..., 0] * s + d[..., 1] * c], axis=-1)

    def distance(self, xy) -> np.ndarray:
        """Distance (m) from floor points to the box footprint (0 inside)."""
        q = np.abs(self.local(xy)) - 0.5 * np.asarray(self.size[:2], float)
        return np.hypot(np.maximum(q[..., 0], 0.0), np.maximum(q[..., 1], 0.0))

    def corners(self) -> np.ndarray:
        """Footprint corners (4, 2), counter-clockwise."""
        hx, hy = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.center, float)


def nearest_on_segment(xy, a, b) -> np.ndarray:
    """The points (..., 2) of the segment a-b nearest to the points xy (..., 2)."""
    p = np.asarray(xy, float)
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ab = b - a
    denom = float(ab @ ab)
    s = np.clip(((p - a) @ ab) / denom, 0.0, 1.0) if denom > 0 else np.zeros(p.shape[:-1])
    return a + s[..., None] * ab


def segment_distance(xy, a, b) -> np.ndarray:
    """Distance from points (..., 2) to the segment a-b."""
    return np.linalg.norm(np.asarray(xy, float) - nearest_on_segment(xy, a, b), axis=-1)


def point_in_polygon(xy, polygon) -> np.ndarray:
    """Even-odd rule test of floor points (..., 2) against a polygon (N, 2)."""
    p = np.asarray(xy, float)
    poly = np.asarray(polygon, float)
    x, y = p[..., 0], p[..., 1]
    inside = np.zeros(p.shape[:-1], bool)
    for (x0, y0), (x1, y1) in zip(poly, np.roll(poly, -1, axis=0)):
        crosses = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (x < xint)
    return inside


def occluding_boxes(floorplan) -> np.ndarray:
    """The boxes of a floor plan that hide people from cameras: its obstacles and interior walls
    (the outline walls bound the room and stand behind everyone), (B, 6) rows of centre x, y, half
    sizes along the box's own axes, height and yaw (radians). ``floorplan``: a ``Floorplan`` or
    anything with ``obstacles`` and ``walls``."""
    boxes = []
    for o in getattr(floorplan, "obstacles", ()):
        boxes.append((o.center[0], o.center[1], 0.5 * o.size[0], 0.5 * o.size[1], o.size[2], o.yaw))
    for w in getattr(floorplan, "walls", ()):
        a, b = np.asarray(w.start, float), np.asarray(w.end, float)
        d = b - a
        boxes.append((*(0.5 * (a + b)), 0.5 * float(np.hypot(*d)), 0.5 * w.thickness, w.height, float(np.arctan2(d[1], d[0]))))
    return np.array(boxes, float).reshape(-1, 6)


def segment_meets_box(a: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether the segments a + t d, t in [0, 1], meet the axis-aligned box [lo, hi] (a slab test
    over the last axis; the arrays broadcast; a segment parallel to a slab lies in it for every t
    or for none), and the t at which each line leaves the box: (meets, t_out)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - a) / d, (hi - a) / d
    par = d == 0.0
    inside = (a >= lo) & (a <= hi)
    t_in = np.where(par, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2)).max(-1)
    t_out = np.where(par, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2)).min(-1)
    return (t_in <= t_out) & (t_out > 0.0) & (t_in < 1.0), t_out


def hidden_heights(boxes: np.ndarray, eye, xy) -> np.ndarray:
    """How high up the vertical lines standing at floor points xy (..., 2) the boxes (B, 6; as
    ``occluding_boxes``) hide them from an eye at ``eye`` (3,): (...,) the highest hidden height
    (m; every point of the line below it is hidden too), -inf where no box is in the way, +inf
    where a box taller than the eye is. The sight line to (x, y, z) crosses a box's footprint over
    the part [t_in, t_out] of its length (a slab test in the floor plane; z plays no part); it
    descends from the eye, so it is lowest at min(t_out, 1), where its height is
    E_z + min(t_out, 1) (z - E_z): at most the box's height h for every z up to
    E_z - (E_z - h) / min(t_out, 1)."""
    boxes = np.asarray(boxes, float).reshape(-1, 6)
    xy = np.asarray(xy, float)
    E = np.asarray(eye, float)
    out = np.full(xy.shape[:-1], -np.inf)
    for cx, cy, hx, hy, h, yaw in boxes:
        c, s = np.cos(yaw), np.sin(yaw)
        rot = np.array([[c, -s], [s, c]])  # world -> box frame, applied on the right
        a = (E[:2] - (cx, cy)) @ rot
        half = np.array([hx, hy])
        meets, t_out = segment_meets_box(a, (xy - (cx, cy)) @ rot - a, -half, half)
        if E[2] <= h:
            z = np.where(meets, np.inf, -np.inf)
        else:
            with np.errstate(divide="ignore"):
                z = np.where(meets, E[2] - (E[2] - h) / np.minimum(t_out, 1.0), -np.inf)
        out = np.maximum(out, z)
    return out


@dataclass(frozen=True)
class Floorplan:
    """The room outline (polygon, walls along it), interior walls and box obstacles."""

    outline: np.ndarray  # (N, 2)
    walls: tuple[Wall, ...]  # interior walls
    obstacles: tuple[Obstacle, ...]
    wall_height: float = 2.5
    wall_thickness: float = 0.1

    def outline_walls(self) -> tuple[Wall, ...]:
        pts = [tuple(map(float, p)) for p in self.outline]
        return tuple(
            Wall(a, b, self.wall_thickness, self.wall_height) for a, b in zip(pts, pts[1:] + pts[:1])
        )

    def all_walls(self) -> tuple[Wall, ...]:
        return self.outline_walls() + tuple(self.walls)

    def inside(self, xy) -> np.ndarray:
        return point_in_polygon(xy, self.outline)

    def clearance(self, xy) -> np.ndarray:
        """Free distance (m) from floor points to the nearest wall surface or obstacle.

        Negative or zero means inside a wall or obstacle; points outside the room get -inf.
        """
        xy = np.asarray(xy, float)
        d = np.full(xy.shape[:-1], np.inf)
        for w in self.all_walls():
            d = np.minimum(d, w.distance(xy) - 0.5 * w.thickness)
        for o in self.obstacles:
            d = np.minimum(d, o.distance(xy))
        return np.where(self.inside(xy), d, -np.inf)

    def bounds(self) -> tuple[float, float, float, float]:
        lo, hi = self.outline.min(axis=0), self.outline.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    def to_dict(self) -> dict:
        return {
            "outline": self.outline.tolist(),
            "wall_height": self.wall_height,
            "wall_thickness": self.wall_thickness,
            "walls": [
                {"start": list(w.start), "end": list(w.end), "thickness": w.thickness, "height": w.height}
                for w in self.walls
            ],
            "obstacles": [
                {"name": o.name, "center": list(o.center), "size": list(o.size), "yaw": o.yaw}
                for o in self.obstacles
            ],
        }

    @staticmethod
    def from_dict(d: dict) -> "Floorplan":
        return Floorplan(
            outline=np.asarray(d["outline"], float),
            walls=tuple(Wall(tuple(w["start"]), tuple(w["end"]), w["thickness"], w["height"]) for w in d["walls"]),
            obstacles=tuple(
                Obstacle(tuple(o["center"]), tuple(o["size"]), o["yaw"], o.get("name", "")) for o in d["obstacles"]
            ),
            wall_height=d["wall_height"],
            wall_thickness=d["wall_thickness"],
        )


MOTION_MODELS = ("random_waypoint", "random_walk", "gauss_markov", "waypoints", "standing")


@dataclass(frozen=True)
class GaussMarkovParams:
    """Rahimi eq. 1 expressed per second: x' = A(dt) x + nu, nu ~ N(0, Sigma(dt)).

    A(dt) = [[1, dt], [0, 1]] per axis; Sigma(dt) = diag(q_pos dt, q_vel dt) per axis, so the
    paper's A (dt = 0.5 s) and Sigma_nu = 1e-6 diag(1e-4, 1) per 0.5 s step are
    q_pos = 2e-10 m^2/s and q_vel = 2e-6 m^2/s^3.

    ``Sigma(dt, "exact")`` is the exact discretisation of the continuous-time model
    dx = v dt + sqrt(q_pos) dW_1, dv = sqrt(q_vel) dW_2 instead: per axis
    [[q_pos dt + q_vel dt^3 / 3, q_vel dt^2 / 2], [q_vel dt^2 / 2, q_vel dt]]. It composes over
    sub-steps (n steps of dt/n give Sigma(dt)), so a prior at any frame rate matches a process
    simulated at a finer one; the paper's diagonal form does not (it drops the q_vel dt^3 / 3
    position variance that the velocity noise accumulates within a step).
    """

    q_pos: float = 2e-10
    q_vel: float = 2e-6

    def A(self, dt: float) -> np.ndarray:
        a = np.array([[1.0, dt], [0.0, 1.0]])
        return np.kron(np.eye(2), a)  # state [x, vx, y, vy]

    def Sigma(self, dt: float, kind: str = "paper") -> np.ndarray:
        """Process covariance of one step of dt s, state [x, vx, y, vy]; kind "paper"
        (diagonal, the default) or "exact" (see the class docstring)."""
        if kind == "paper":
            return np.diag([self.q_pos * dt, self.q_vel * dt, self.q_pos * dt, self.q_vel * dt])
        if kind != "exact":
            raise ValueError(f"discretisation must be 'paper' or 'exact', got {kind!r}")
        qp, qv = self.q_pos, self.q_vel
        block = np.array([[qp * dt + qv * dt**3 / 3.0, qv * dt**2 / 2.0], [qv * dt**2 / 2.0, qv * dt]])
        return np.kron(np.eye(2), block)


@dataclass(frozen=True)
class WalkerSpec:
    """One person. ``motion`` picks the motion model (see ``sim/walkers.py``).

    speed: (min, max) walking speed, m/s. pause: (min, max) stop length at a waypoint, s.
    waypoints: for ``waypoints`` motion, the scripted path (x, y); ``loop`` returns to the start.
    start: initial floor position (None: drawn at random in free space).
    gauss_markov: process noise of the ``gauss_markov`` model (also kept in the recording's
    metadata, so an estimator can be handed the matched prior).
    vary: scripted walkers (``waypoints``, ``standing`` with a ``start``) get seeded variation of
    pace, waypoints, start phase and standing spot (``sim/walkers.py``); False replays the file
    exactly on every seed.
    color_name: the appearance class cameras report as a bearing ``label``; two walkers share one
    only where the scene gives both the same ``color``.
    """

    name: str
    color: tuple[float, float, float]
    color_name: str
    motion: str = "random_waypoint"
    height: float = 1.75
    radius: float = 0.2
    speed: tuple[float, float] = (0.5, 1.5)
    pause: tuple[float, float] = (0.0, 5.0)
    pause_probability: float = 0.5
    waypoints: tuple[tuple[float, float], ...] = ()
    loop: bool = False
    start: tuple[float, float] | None = None
    phone: bool = True
    gauss_markov: GaussMarkovParams = field(default_factory=GaussMarkovParams)
    bob_amplitude: float = 0.03  # gait bob, metres peak-to-peak
    vary: bool = True


@dataclass(frozen=True)
class SensorSpec:
    """Sensor rates and noise (all one-sigma), and the simulated detectors' behaviour.

    Recordings carry the rates and noise levels in ``calibration.noise`` (what a user would have
    measured); ``still_speed`` and ``flow_min_px_s`` configure the simulator only and are not
    written there (``sim.simulate.SIMULATOR_ONLY``).

    bearing_sigma_px: horizontal image coordinate noise (bearing cameras), pixels.
    box_sigma_px: tracking-window edge noise (oblique cameras), pixels.
    floor_sigma_m: overhead floor position noise per axis (Teixeira: 0.15 m).
    privacy_quantum_m: privacy-camera position quantisation (Teixeira: 0.15 m).
    still_speed: speed (m/s) below which a privacy camera does not see a person, and truth's
    ``walking`` is false (simulator only).
    imu_rate: phone sample rate, Hz. accel_sigma (m/s^2), gyro_sigma (rad/s), mag_sigma
    (field units; MuJoCo's default field has magnitude 0.5).
    magnetic_field: ``option.magnetic`` (world frame).
    sim_rate: base simulation rate, Hz; truth is sampled at it and every sensor rate divides it.
    flow_sigma_px_s: noise of a tracking window's mean image flow (oblique cameras), px/s per axis:
    a flow averaged over the object region, not an edge difference (the rendered Farneback
    windows on occlusion_lab measure a robust spread of ~6 px/s in u, ~8 px/s in v).
    flow_min_px_s: image speed (px/s) of a person's centre below which an optical-flow tracker
    finds no moving region, so an oblique camera reports no window (a person standing still);
    3 px/s = the rendered tracker's 0.3 px/frame at 10 fps (simulator only).
    perception: how analytic sensing turns geometry into detections (simulator only):
    ``"fitted"`` (default) the bundled perception model fitted on rendered recordings
    (``sim/perception_model.py``: misses, merges, label confusion, false detections, tracker ids,
    measured error distributions), ``"ideal"`` every visible person detected with exact labels and
    the Gaussian noise above, or the path of a model file written by ``trackroom calibrate-sensing``
    (relative to the working directory).
    """

    bearing_sigma_px: float = 1.0
    box_sigma_px: float = 1.0
    floor_sigma_m: float = 0.15
    privacy_quantum_m: float = 0.15
    still_speed: float = 0.1
    imu_rate: float = 100.0
    accel_sigma: float = 0.03
    gyro_sigma: float = 0.01
    mag_sigma: float = 0.02
    magnetic_field: tuple[float, float, float] = (0.0, -0.5, 0.0)
    sim_rate: float = 100.0
    flow_sigma_px_s: float = 5.0
    flow_min_px_s: float = 3.0
    perception: str = "fitted"
    # phone errors (``sim/phone_errors.py``; simulator only): indoor magnetic disturbance (deg at
    # a wall, decaying over the range, m), accelerometer bias (m/s^2, per axis), the phone's yaw
    # offset and tilt in the pocket (deg, largest), phone-in-hand swings (episodes per minute,
    # amplitude deg). Modest by default: a phone in a trouser pocket, a building with some steel.
    mag_disturbance_deg: float = 10.0
    mag_disturbance_range_m: float = 1.0
    accel_bias: float = 0.05
    pocket_yaw_deg: float = 30.0
    pocket_tilt_deg: float = 10.0
    swing_per_min: float = 0.5
    swing_deg: float = 30.0

    def phone_errors(self) -> bool:
        """Whether any phone error is switched on."""
        return any(v > 0 for v in (self.mag_disturbance_deg, self.accel_bias, self.pocket_yaw_deg,
                                   self.pocket_tilt_deg, self.swing_per_min))


@dataclass(frozen=True)
class RenderSpec:
    """Rendering options (rendered sensing mode)."""

    shadows: bool = False


@dataclass(frozen=True)
class Scene:
    """A validated scene: floor plan, cameras, walkers and sensors."""

    name: str
    description: str
    floorplan: Floorplan
    cameras: tuple[Camera, ...]
    walkers: tuple[WalkerSpec, ...]
    sensors: SensorSpec
    render: RenderSpec
    source: str = ""  # where it came from: a bundled scene's name or a path relative to the working directory
    raw: dict = field(default_factory=dict, repr=False, compare=False)  # parsed TOML, after overrides
    overrides: tuple[str, ...] = field(default=(), compare=False)  # the ``key=value`` overrides applied

    def camera(self, name: str) -> Camera:
        for c in self.cameras:
            if c.name == name:
                return c
        raise KeyError(f"scene {self.name!r} has no camera {name!r}")
