"""Geometry of the target-plane tracker (Tsutsui, Miura and Shirai), from a 3x4 matrix P only.

A camera is given by its projection ``P`` (OpenCV: ``h [x, y, 1]^T = P [X, Y, Z, 1]^T``, pixels,
world metres, Z up). Nothing else about the camera is assumed, so the functions work for any
calibrated pinhole camera (eq. 1-2 of the paper, where P is called C).

- ``target_plane``: the vertical plane through the projection line of image point (x, y),
  ``a [X, Y]^T = b`` (eqs. 3-5).
- ``intersect_planes``: the person's axis (X, Y) as the least-squares intersection of m >= 2
  target planes, ``(A^T A)^-1 A^T B`` (eq. 6), refused when the planes are near-parallel.
- ``cylinder_window``: the image window circumscribing the person model (vertical cylinder of
  height H and radius r standing at (X, Y)) - the estimated window of section 3.3.
- ``target_area``: the single-camera target area (section 3.2), the tetragon bounded by the depth
  range (window top row against the head at Z = H, bottom row against the feet at Z = 0) and the
  width range (left and right edges against the radius).
- ``flow_jacobian`` / ``velocity_from_flows``: image velocity of a moving point (eq. 7) and the
  3-D velocity from the tracking cameras' mean flows by least squares.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


# --- camera from P ---------------------------------------------------------------------------
def camera_centre(P: np.ndarray) -> np.ndarray:
    """Optical centre c (3,) of P = [M | p4]: c = -M^-1 p4."""
    P = np.asarray(P, float)
    return -np.linalg.solve(P[:, :3], P[:, 3])


def pixel_ray(P: np.ndarray, uv) -> np.ndarray:
    """Unit world directions (..., 3) of the rays through pixels (..., 2), pointing forward.

    d ~ M^-1 [u, v, 1]^T, its sign chosen so that the point c + d has positive depth
    (third row of P), whatever the overall sign of P.
    """
    P = np.asarray(P, float)
    uv = np.asarray(uv, float)
    hom = np.concatenate([uv, np.ones(uv.shape[:-1] + (1,))], axis=-1)
    d = hom @ np.linalg.inv(P[:, :3]).T
    depth_sign = np.sign(d @ P[2, :3])
    d = d * np.where(depth_sign == 0, 1.0, depth_sign)[..., None]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def project(P: np.ndarray, X) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (..., 2) and projective depth h (...,) of world points X (..., 3) (eq. 1)."""
    P = np.asarray(P, float)
    X = np.asarray(X, float)
    hx = X @ P[:, :3].T + P[:, 3]
    h = hx[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return hx[..., :2] / h[..., None], h


# --- target planes (eqs. 3-6) ----------------------------------------------------------------
def target_plane(P: np.ndarray, x, y) -> tuple[np.ndarray, np.ndarray]:
    """Target plane ``a [X, Y]^T = b`` of image point (x, y), vectorised over x, y (eqs. 4-5).

    With C = P, the projection line of (x, y) is (C_1 - x C_3) X~ = 0, (C_2 - y C_3) X~ = 0;
    eliminating Z gives the vertical plane through it:
      a = [(C11-C31x)(C23-C33y) - (C13-C33x)(C21-C31y), (C12-C32x)(C23-C33y) - (C13-C33x)(C22-C32y)]
      b = (C13-C33x)(C24-C34y) - (C14-C34x)(C23-C33y)
    (the sign of b in eq. 5 follows from moving the constant terms to the right-hand side).
    Returns a (..., 2) and b (...,).
    """
    C = np.asarray(P, float)
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    r1 = C[0][None, :] - x.reshape(-1, 1) * C[2][None, :]  # C_1j - C_3j x
    r2 = C[1][None, :] - y.reshape(-1, 1) * C[2][None, :]  # C_2j - C_3j y
    a0 = r1[:, 0] * r2[:, 2] - r1[:, 2] * r2[:, 0]
    a1 = r1[:, 1] * r2[:, 2] - r1[:, 2] * r2[:, 1]
    b = r1[:, 2] * r2[:, 3] - r1[:, 3] * r2[:, 2]
    shape = np.broadcast(x, y).shape
    return np.stack([a0, a1], axis=-1).reshape(shape + (2,)), b.reshape(shape)


def normalise_planes(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scale each plane so that |a_i| = 1; then a_i X - b_i is the signed distance in metres."""
    n = np.linalg.norm(a, axis=-1)
    if np.any(n < 1e-12):
        raise ValueError("degenerate target plane (|a| = 0): the projection line is vertical")
    return a / n[..., None], b / n


class IllConditioned(ValueError):
    """The target planes are too close to parallel to intersect reliably."""


def plane_conditioning(a: np.ndarray) -> float:
    """|A^T A| of unit-normalised planes: sum over pairs i<j of sin^2(angle_ij) (scale-free)."""
    an = a / np.linalg.norm(a, axis=-1, keepdims=True)
    return float(np.linalg.det(an.T @ an))


def intersect_planes(a: np.ndarray, b: np.ndarray, min_angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares axis position [X, Y] = (A^T A)^-1 A^T B of m >= 2 target planes (eq. 6).

    Rows are normalised first, so |A^T A| = sum_{i<j} sin^2(theta_ij); when it is below
    sin^2(min_angle) (radians) the planes are near-parallel and ``IllConditioned`` is raised
    (the paper's small-determinant case). Returns the position (2,) and the residuals (m,) in
    metres (signed distances of the position from each plane).
    """
    a, b = normalise_planes(np.asarray(a, float), np.asarray(b, float))
    if a.shape[0] < 2:
        raise IllConditioned("need at least two target planes")
    det = plane_conditioning(a)
    if det < np.sin(min_angle) ** 2:
        raise IllConditioned(
            f"target planes near-parallel: |A^T A| = {det:.3g} < sin^2({np.degrees(min_angle):.1f} deg)"
        )
    xy = np.linalg.solve(a.T @ a, a.T @ b)
    return xy, a @ xy - b


# --- person model ---------------------------------------------------------------------------
def cylinder_points(xy, height: float, radius: float, n: int = 16) -> np.ndarray:
    """Points (..., 2n, 3) on the bottom and top rims of vertical cylinders at floor points (..., 2)."""
    xy = np.asarray(xy, float)
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    rim = radius * np.stack([np.cos(ang), np.sin(ang)], axis=-1)  # (n, 2)
    pts = xy[..., None, :] + rim  # (..., n, 2)
    z0 = np.zeros(pts.shape[:-1] + (1,))
    return np.concatenate([np.concatenate([pts, z0], -1), np.concatenate([pts, z0 + height], -1)], axis=-2)


def cylinder_window(P: np.ndarray, xy, height: float, radius: float, n: int = 16) -> np.ndarray:
    """Window [u_left, u_right, v_top, v_bottom] (..., 4) circumscribing the cylinder's projection.

    NaN where any rim point lies behind the camera.
    """
    uv, h = project(P, cylinder_points(xy, height, radius, n))
    win = np.stack(
        [uv[..., 0].min(-1), uv[..., 0].max(-1), uv[..., 1].min(-1), uv[..., 1].max(-1)], axis=-1
    )
    return np.where((h > 1e-6).all(-1)[..., None], win, np.nan)


def cylinder_image_width(P: np.ndarray, xy, z0: float, z1: float, radius: float, n: int = 16) -> np.ndarray:
    """Image width (px, (...)) of vertical cylinders at floor points xy (..., 2) between heights
    z0 and z1: the horizontal extent of their rims' projections."""
    pts = cylinder_points(xy, z1 - z0, radius, n)
    pts[..., 2] += z0
    uv, _ = project(P, pts)
    return uv[..., 0].max(-1) - uv[..., 0].min(-1)


# --- single-camera target area (section 3.2) -----------------------------------------------
@dataclass(frozen=True)
class TargetArea:
    """Single-camera target area on the floor.

    ``origin`` (2,): the camera's foot point; ``direction`` (2,): unit horizontal direction of
    the target plane (the centroid's projection line); ``s_min, s_max``: the depth range, metres
    along ``direction`` from ``origin`` (planes P_h and P_f); ``polygon`` (k, 2): the tetragon
    C_r C_l D_l D_r (its convex hull), counter-clockwise.
    """

    origin: np.ndarray
    direction: np.ndarray
    s_min: float
    s_max: float
    polygon: np.ndarray

    def on_plane(self, xy) -> np.ndarray:
        """The point of the target plane nearest to xy, with its depth clamped to the range."""
        s = float(np.clip((np.asarray(xy, float) - self.origin) @ self.direction, self.s_min, self.s_max))
        return self.origin + s * self.direction

    def contains(self, xy, margin: float = 0.0) -> bool:
        """True when xy lies inside the polygon or within ``margin`` metres of it."""
        poly = self.polygon.astype(np.float32).reshape(-1, 1, 2)
        d = cv2.pointPolygonTest(poly, (float(xy[0]), float(xy[1])), True)
        return d >= -margin


def _horizontal(d: np.ndarray) -> np.ndarray:
    h = np.asarray(d[..., :2], float)
    return h / np.linalg.norm(h, axis=-1, keepdims=True)


def _depth_bound(c: np.ndarray, ray: np.ndarray, dirn: np.ndarray, z: float) -> float | None:
    """Depth along ``dirn`` (m from the camera foot) where ``ray`` from c meets the plane Z = z."""
    if abs(ray[2]) < 1e-12:
        return None
    s = (z - c[2]) / ray[2]
    if s <= 0:
        return None
    return float((s * ray[:2]) @ dirn)


def target_area(
    P: np.ndarray,
    box,
    height: float,
    radius: float,
    max_range: float = 30.0,
    margin: float = 0.0,
    margin_px: float = 0.0,
) -> TargetArea:
    """Single-camera target area from one window ``box = (u, u_left, u_right, v_top, v_bottom)``.

    Depth range (Fig. 4): L_h, the ray through (u, v_top), meets Z = H at M_h; the top of the head
    is not lower than the window top, so for a camera above the head the person is farther than
    M_h. L_f, the ray through (u, v_bottom), meets Z = 0 at M_f; the feet are not higher than the
    window bottom, so the person is nearer than M_f. For a camera without roll the image row of a
    point at a given height depends only on its forward distance f (along the optical axis'
    horizontal heading), and the cylinder's extreme rim points are at most r nearer or farther
    than its axis, so the bounding planes P_h, P_f are taken perpendicular to the heading:
    f(M_h) - r <= f <= f(M_f) + r. On the target plane, s = f / cos(phi), phi the angle between
    the plane and the heading.

    Width range (Fig. 5): with the window inside the person's image (partial extraction), the
    axis is at most r inside the plane through the right edge, and at most r inside the plane
    through the left edge. The two boundary lines are those planes moved r inwards; the area is
    between them. (The same two lines bound a window wider than the person - a merged window -
    on the far side of their crossing, so the convex hull of both is taken: a conservative area.)
    ``margin`` (m) widens every boundary outwards; ``margin_px`` allows for window noise in the
    image first (near head height a pixel of v_top is a large depth change, so the allowance
    belongs in the image): every bound above holds for the true window, which may be up to
    ``margin_px`` *inside* the measured one on each side, so the window is shrunk by it.
    """
    P = np.asarray(P, float)
    u, ul, ur, vt, vb = (float(v) for v in box)
    ul, ur, vt, vb = ul + margin_px, ur - margin_px, vt + margin_px, vb - margin_px
    vm = 0.5 * (vt + vb)
    c = camera_centre(P)
    o = c[:2]
    rays = pixel_ray(P, np.array([[u, vm], [u, vt], [u, vb], [ul, vt], [ul, vb], [ur, vt], [ur, vb]]))
    dirn = _horizontal(rays[0])
    head = _horizontal(P[2, :3][None])[0] if np.linalg.norm(P[2, :2]) > 1e-12 else dirn
    cos_phi = max(float(dirn @ head), 0.2)
    slack = radius + margin
    f_min = 0.0  # camera below the head: the head row gives no near bound
    if c[2] > height:
        s_h = _depth_bound(c, rays[1], dirn, height)
        f_min = (s_h * cos_phi if s_h is not None else max_range) - slack
    s_f = _depth_bound(c, rays[2], dirn, 0.0)
    f_max = (s_f * cos_phi if s_f is not None else max_range) + slack
    f_min = max(f_min, 0.05)
    f_max = min(max(f_max, f_min), max_range)
    s_min, s_max = f_min / cos_phi, f_max / cos_phi

    # width lines: the vertical planes through the left / right edge columns, moved r inwards
    # (towards the image right for the left edge, towards the image left for the right edge).
    # A pitched camera images vertical lines tilted (keystone), so an image column is not one
    # vertical plane: the planes through the edge column at the top and at the bottom row are
    # both taken, and the area is the convex hull of all their corners (conservative).
    right = _horizontal(pixel_ray(P, np.array([u + 1.0, vm])) - rays[0])
    verts = []
    for k, inward in ((3, 1.0), (4, 1.0), (5, -1.0), (6, -1.0)):
        dk = _horizontal(rays[k])
        nk = np.array([-dk[1], dk[0]])
        nk = nk if nk @ right >= 0 else -nk
        p0 = o + (inward * radius - inward * margin) * nk  # margin widens the band outwards
        for f in (f_min, f_max):
            lam = (f - float(head @ (p0 - o))) / float(head @ dk)
            verts.append(p0 + lam * dk)
    hull = cv2.convexHull(np.asarray(verts, np.float32).reshape(-1, 1, 2))
    return TargetArea(origin=o, direction=dirn, s_min=s_min, s_max=s_max, polygon=hull.reshape(-1, 2).astype(float))


# --- velocity (eq. 7) -----------------------------------------------------------------------
def flow_jacobian(P: np.ndarray, X) -> np.ndarray:
    """d[x, y]/dt = J V at world point X (3,) for velocity V (3,) (eq. 7), J (2, 3).

    From h x = C X: x' = (C_1 V - x C_3 V) / h, y' = (C_2 V - y C_3 V) / h, with h = C_3 X~.
    """
    P = np.asarray(P, float)
    (x, y), h = project(P, np.asarray(X, float))
    return np.stack([P[0, :3] - x * P[2, :3], P[1, :3] - y * P[2, :3]]) / h


def velocity_from_flows(
    Ps: list[np.ndarray],
    Xs: list[np.ndarray],
    flows: list[np.ndarray],
    sigmas: list[float] | None = None,
    prior: np.ndarray | None = None,
    prior_sigma: float = np.inf,
) -> np.ndarray:
    """3-D velocity V (3,) from mean image flows (px/s) by least squares over J_i V = v_i (eq. 7).

    With one camera (two equations) the vertical velocity is taken as zero: V = [U, V, 0].
    ``sigmas`` (px/s, one per camera) weight the cameras' equations. With a ``prior`` velocity
    (m/s) and finite ``prior_sigma`` (m/s) the solution minimises
    sum_i |J_i V - v_i|^2 / sigma_i^2 + |V - V_prior|^2 / prior_sigma^2: a single camera sees
    motion along its line of sight only as a small vertical image motion, and the prior keeps
    that poorly observed component from swinging with the flow noise.
    """
    J = np.vstack([flow_jacobian(P, X) for P, X in zip(Ps, Xs)])
    f = np.concatenate([np.asarray(v, float) for v in flows])
    w = np.repeat(1.0 / np.asarray(sigmas, float), 2) if sigmas is not None else np.ones(len(f))
    k = 3 if len(Ps) >= 2 else 2  # one camera: W = 0
    A, b = J[:, :k] * w[:, None], f * w
    if prior is not None and np.isfinite(prior_sigma):
        A = np.vstack([A, np.eye(k) / prior_sigma])
        b = np.concatenate([b, np.asarray(prior, float)[:k] / prior_sigma])
    sol = np.linalg.lstsq(A, b, rcond=None)[0]
    return sol if k == 3 else np.array([sol[0], sol[1], 0.0])


def polygon_area(outline: np.ndarray) -> float:
    """Area of a simple polygon (N, 2), m^2 (shoelace); 0 for fewer than three vertices."""
    p = np.asarray(outline, float).reshape(-1, 2)
    if len(p) < 3:
        return 0.0
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(float(x @ np.roll(y, -1) - y @ np.roll(x, -1)))
