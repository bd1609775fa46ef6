"""Pinhole camera geometry, in OpenCV convention, with no MuJoCo dependency.

Conventions (see DESIGN.md): world x, y on the floor, z up, yaw about z from +x.
The camera frame is OpenCV's: x right, y down, z forward along the optical axis.
A world point X projects to pixels by  s [u, v, 1]^T = K (R X + t) = P [X; 1],
with K = [[f, 0, cx], [0, f, cy], [0, 0, 1]], f = 0.5 H / tan(fovy / 2), square
pixels and the principal point at the image centre (as MuJoCo renders).

MuJoCo cameras look along -z with +y up; ``mujoco_xyaxes`` converts once, here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

CAMERA_KINDS = ("horizontal", "overhead", "oblique")


def rotation_from_yaw_pitch(yaw: float, pitch: float) -> np.ndarray:
    """World-to-camera rotation R (rows: camera x, y, z axes in world coordinates).

    yaw: heading of the optical axis on the floor, radians from +x.
    pitch: elevation of the optical axis, radians, positive up (-pi/2 looks straight down).
    Roll is zero: the image x axis stays horizontal (points to the right of the heading).
    """
    z = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    x = np.array([np.sin(yaw), -np.cos(yaw), 0.0])
    y = np.cross(z, x)
    return np.vstack([x, y, z])


def yaw_pitch_towards(position, target) -> tuple[float, float]:
    """Yaw and pitch (radians) of the ray from ``position`` to ``target``."""
    d = np.asarray(target, float) - np.asarray(position, float)
    horiz = float(np.hypot(d[0], d[1]))
    yaw = float(np.arctan2(d[1], d[0])) if horiz > 1e-12 else 0.0
    return yaw, float(np.arctan2(d[2], horiz))


@dataclass(frozen=True)
class Camera:
    """A calibrated pinhole camera: what a user of a real network would have measured.

    The camera is immutable; K, R, t, P are computed once on first use (cached).

    ``kind`` is one of ``horizontal`` (wall-mounted, optical axis parallel to the floor;
    Rahimi), ``overhead`` (ceiling, looking down; Teixeira) or ``oblique`` (any pose;
    Tsutsui). ``fps`` is the frame rate in Hz. ``privacy`` marks an overhead motion camera
    that reports positions quantised to ``quantum`` metres and misses people standing still.
    ``region`` (xmin, ymin, xmax, ymax), for overhead cameras, is the floor tile whose
    detections this camera reports (a network of ceiling cameras tiles the floor).
    """

    name: str
    kind: str
    position: np.ndarray  # (3,) optical centre, world metres
    yaw: float  # radians
    pitch: float  # radians
    fovy: float  # vertical field of view, radians
    width: int
    height: int
    fps: float
    privacy: bool = False
    quantum: float = 0.0
    region: tuple[float, float, float, float] | None = None
    color: tuple[float, float, float] = field(default=(0.2, 0.2, 0.2))

    # --- intrinsics / extrinsics -------------------------------------------------
    @cached_property
    def focal(self) -> float:
        """Focal length in pixels: f = 0.5 H / tan(fovy / 2)."""
        return 0.5 * self.height / np.tan(0.5 * self.fovy)

    @cached_property
    def K(self) -> np.ndarray:
        f = self.focal
        return np.array([[f, 0.0, self.width / 2.0], [0.0, f, self.height / 2.0], [0.0, 0.0, 1.0]])

    @cached_property
    def R(self) -> np.ndarray:
        """World-to-camera rotation (OpenCV camera frame)."""
        return rotation_from_yaw_pitch(self.yaw, self.pitch)

    @cached_property
    def t(self) -> np.ndarray:
        """World-to-camera translation: X_cam = R X_world + t."""
        return -self.R @ np.asarray(self.position, float)

    @cached_property
    def P(self) -> np.ndarray:
        """3x4 projection matrix P = K [R | t]."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    @cached_property
    def fovx(self) -> float:
        """Horizontal field of view, radians."""
        return 2.0 * np.arctan(0.5 * self.width / self.focal)

    def mujoco_xyaxes(self) -> np.ndarray:
        """MuJoCo ``xyaxes`` (camera x and y axes in world): MuJoCo's +y is OpenCV's -y."""
        R = self.R
        return np.concatenate([R[0], -R[1]])

    # --- projection ---------------------------------------------------------------
    def to_camera(self, points) -> np.ndarray:
        """World points (..., 3) to camera-frame points (..., 3)."""
        p = np.asarray(points, float)
        return p @ self.R.T + self.t

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (..., 2) and depth (...,) of world points (..., 3); depth <= 0 is behind."""
        pc = self.to_camera(points)
        z = pc[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = self.focal * pc[..., 0] / z + self.width / 2.0
            v = self.focal * pc[..., 1] / z + self.height / 2.0
        return np.stack([u, v], axis=-1), z

    def bearing_u(self, xy) -> np.ndarray:
        """Horizontal image coordinate u of floor points (..., 2) for a horizontal camera.

        Rahimi eq. 4: u = f R_y (x - p) / R_x (x - p) + cx, with the height ignored
        (for a horizontal camera u does not depend on the point's height).
        """
        xy = np.asarray(xy, float)
        d = xy - np.asarray(self.position, float)[:2]
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        forward = d[..., 0] * c + d[..., 1] * s
        right = d[..., 0] * s - d[..., 1] * c
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.focal * right / forward + self.width / 2.0

    def in_image(self, uv, depth, margin: float = 0.0) -> np.ndarray:
        """True where a projected point lies in front of the camera and inside the image."""
        uv = np.asarray(uv, float)
        return (
            (np.asarray(depth) > 1e-6)
            & (uv[..., 0] >= -margin)
            & (uv[..., 0] < self.width + margin)
            & (uv[..., 1] >= -margin)
            & (uv[..., 1] < self.height + margin)
        )

    def vertical_vanishing_point(self) -> np.ndarray | None:
        """Image point (2,) where vertical world lines meet (the nadir for a downward camera);
        None when they meet behind the camera (a horizontal or upward camera)."""
        d = self.K @ (self.R @ np.array([0.0, 0.0, -1.0]))
        if d[2] <= 1e-9:
            return None
        return d[:2] / d[2]

    def in_fov(self, points) -> np.ndarray:
        """Field-of-view test for world points (..., 3)."""
        uv, z = self.project(points)
        return self.in_image(uv, z)

    def in_horizontal_fov(self, xy) -> np.ndarray:
        """Field-of-view test on the floor plane only (horizontal cameras: the person is tall)."""
        xy = np.asarray(xy, float)
        d = xy - np.asarray(self.position, float)[:2]
        forward = d[..., 0] * np.cos(self.yaw) + d[..., 1] * np.sin(self.yaw)
        u = self.bearing_u(xy)
        return (forward > 1e-6) & (u >= 0) & (u < self.width)

    def in_region(self, xy) -> np.ndarray:
        """True where floor points (..., 2) lie in the camera's ``region`` tile
        (xmin <= x < xmax, ymin <= y < ymax); everywhere when it has none."""
        xy = np.asarray(xy, float)
        if self.region is None:
            return np.ones(xy.shape[:-1], bool)
        x0, y0, x1, y1 = self.region
        return (xy[..., 0] >= x0) & (xy[..., 0] < x1) & (xy[..., 1] >= y0) & (xy[..., 1] < y1)

    def backproject_to_plane(self, uv, z_plane: float) -> np.ndarray:
        """Intersect the rays through pixels (..., 2) with the horizontal plane z = z_plane.

        Returns world points (..., 3); NaN where the ray does not reach the plane ahead.
        """
        uv = np.asarray(uv, float)
        rays_cam = np.stack(
            [
                (uv[..., 0] - self.width / 2.0) / self.focal,
                (uv[..., 1] - self.height / 2.0) / self.focal,
                np.ones(uv.shape[:-1]),
            ],
            axis=-1,
        )
        rays = rays_cam @ self.R  # camera-to-world rotation is R^T
        c = np.asarray(self.position, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (z_plane - c[2]) / rays[..., 2]
        s = np.where(s > 0, s, np.nan)
        return c + s[..., None] * rays

    def frame_times(self, duration: float) -> np.ndarray:
        """Capture times in seconds over [0, duration)."""
        n = int(np.floor(duration * self.fps + 1e-9))
        return np.arange(n) / self.fps
