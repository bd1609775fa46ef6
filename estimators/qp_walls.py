"""Walls and obstacles of the floor plan as linear constraints on the trajectory (Rahimi sec. 7-8).

The paper's conclusion suggests encoding known walls as extra constraints. A QP needs convex
(linear) constraints, so:

- **Room outline, convex room**: every point stays inside every edge's half-plane,
  n_e^T (x_k - a_e) >= thickness / 2 + margin  (n_e the inward normal of edge e through a_e).
  Fixed rows, valid for the whole trajectory, so no estimate can leave the room.
- **Interior walls and box obstacles** (and the outline of a non-convex room, edge by edge):
  each is an oriented box. For every point within ``reach`` metres of a box at the current
  iterate, the face the point is most clearly outside of (largest signed distance
  n_f^T (x_k - c) - h_f) gives the half-plane n_f^T (x_k - c) >= h_f + margin. The side is decided
  per point from a reference position and re-decided at every Gauss-Newton iterate: a point
  next to a wall stays on its side, a point by a wall's end (a door) is held off the end cap
  only, so paths through doors stay possible.
- **What a camera could see** (``ray_limits``): a person a camera observed lies on the observed
  bearing ray between the camera and the first wall or obstacle the ray meets (the camera cannot
  see through walls). With c the camera's floor point and r the ray's unit direction (from the
  measured u), that is the linear row  r^T (x_k - c) <= s_hit - clearance,  s_hit the distance
  to the first wall along r and clearance = (thickness / 2 + margin) / |sin(angle of incidence)|.
  It is fixed by the measurement, not by the iterate, so an observed point is never kept in the
  wrong room. For the wall rule above, an observed step's reference position is the iterate
  pulled back onto that visible segment of its ray, c + clip(r^T (x_k - c), margin, s_max) r,
  so its faces are decided on the camera's side of every wall; unobserved steps use the iterate
  itself (a local rule: an unobserved point the iterate has put on the wrong side of a wall is
  kept there, but the observed points on either side of it pull the path through the doors).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from trackroom.scenes.spec import Floorplan

from .qp_model import IX, IY, NS


def is_convex(polygon) -> bool:
    p = np.asarray(polygon, float)
    e = np.roll(p, -1, axis=0) - p
    cross = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
    return bool(np.all(cross >= -1e-12) or np.all(cross <= 1e-12))


def _rows(T: int, normals: np.ndarray, k: np.ndarray) -> sp.csc_matrix:
    """Rows n^T x_k for (normal, step) pairs."""
    r = np.repeat(np.arange(len(k)), 2)
    c = np.stack([k * NS + IX, k * NS + IY], axis=1).ravel()
    return sp.csc_matrix((normals.ravel(), (r, c)), shape=(len(k), NS * T))


def outline_halfplanes(floorplan: Floorplan, T: int, margin: float) -> tuple[sp.csc_matrix, np.ndarray]:
    """Rows C X >= l keeping every step inside a convex room outline."""
    p = np.asarray(floorplan.outline, float)
    if not is_convex(p):
        raise ValueError("the room outline is not convex: use the per-point wall rule")
    e = np.roll(p, -1, axis=0) - p
    normals = np.stack([-e[:, 1], e[:, 0]], axis=1) / np.linalg.norm(e, axis=1)[:, None]
    centroid = p.mean(axis=0)
    flip = np.einsum("ij,ij->i", normals, centroid - p) < 0
    normals[flip] *= -1
    offset = np.einsum("ij,ij->i", normals, p) + 0.5 * floorplan.wall_thickness + margin
    E = len(p)
    k = np.repeat(np.arange(T), E)
    return _rows(T, np.tile(normals, (T, 1)), k), np.tile(offset, T)


def boxes(floorplan: Floorplan, include_outline: bool) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Interior walls and obstacles as oriented boxes (centre (2,), half extents (2,), yaw)."""
    out = []
    walls = list(floorplan.walls) + (list(floorplan.outline_walls()) if include_outline else [])
    for w in walls:
        a, b = np.asarray(w.start, float), np.asarray(w.end, float)
        d = b - a
        out.append((0.5 * (a + b), np.array([0.5 * np.linalg.norm(d), 0.5 * w.thickness]), float(np.arctan2(d[1], d[0]))))
    for o in floorplan.obstacles:
        out.append((np.asarray(o.center, float), 0.5 * np.asarray(o.size[:2], float), float(o.yaw)))
    return out


def _segments(floorplan: Floorplan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every wall (outline and interior) and obstacle edge as segments: start (S, 2), end (S, 2),
    half thickness (S,)."""
    a, b, h = [], [], []
    for w in list(floorplan.walls) + list(floorplan.outline_walls()):
        a.append(w.start)
        b.append(w.end)
        h.append(0.5 * w.thickness)
    for o in floorplan.obstacles:
        c, s, yaw = np.asarray(o.center, float), 0.5 * np.asarray(o.size[:2], float), float(o.yaw)
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        corners = c + np.array([[-s[0], -s[1]], [s[0], -s[1]], [s[0], s[1]], [-s[0], s[1]]]) @ R.T
        for i in range(4):
            a.append(corners[i])
            b.append(corners[(i + 1) % 4])
            h.append(0.0)
    return np.asarray(a, float).reshape(-1, 2), np.asarray(b, float).reshape(-1, 2), np.asarray(h, float)


@dataclass(frozen=True)
class RayLimits:
    """Visible segment of each observed step's bearing ray: points c + s r, s in [s_min, s_max]."""

    k: np.ndarray  # (M,) step
    c: np.ndarray  # (M, 2) camera floor point
    r: np.ndarray  # (M, 2) unit ray direction
    s_min: np.ndarray  # (M,)
    s_max: np.ndarray  # (M,)

    def reference(self, xy: np.ndarray) -> np.ndarray:
        """xy (T, 2) with the observed steps pulled back onto their visible segments."""
        ref = xy.copy()
        s = np.einsum("ij,ij->i", xy[self.k] - self.c, self.r)
        ref[self.k] = self.c + np.clip(s, self.s_min, self.s_max)[:, None] * self.r
        return ref


def ray_limits(obs, floorplan: Floorplan, T: int, margin: float, fov_margin: float):
    """Rows C X >= l (one per observed step: -r^T x_k >= -(r^T c + s_max)) and the ``RayLimits``.

    obs: ``qp_model.Bearings``. The ray of observation j is the floor line u(x) = u_j, i.e.
    (a_j - u_j b_j) . x + (c_j - u_j d_j) = 0, through the camera floor point c (a . c + c = 0,
    b . c + d = 0), pointing where b . r > 0 (in front). One row per step (its first observation).
    """
    if len(obs) == 0:
        return sp.csc_matrix((0, NS * T)), np.zeros(0), None
    _, first = np.unique(obs.k, return_index=True)
    k = obs.k[first]
    a, b, c, d, u = obs.a[first], obs.b[first], obs.c[first], obs.d[first], obs.u[first]
    M = np.stack([a, b], axis=1)  # (m, 2, 2)
    cam = np.linalg.solve(M, -np.stack([c, d], axis=1)[..., None])[..., 0]
    nrm = a - u[:, None] * b
    r = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    r[np.einsum("ij,ij->i", r, b) < 0] *= -1
    A, B, H = _segments(floorplan)
    e = B - A  # (S, 2)
    # c + s r = A + t e  ->  [r, -e] [s, t]^T = A - c
    den = r[:, None, 0] * (-e[None, :, 1]) - r[:, None, 1] * (-e[None, :, 0])  # (m, S)
    w = A[None] - cam[:, None]  # (m, S, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (w[..., 0] * (-e[None, :, 1]) - w[..., 1] * (-e[None, :, 0])) / den
        t = (r[:, None, 0] * w[..., 1] - r[:, None, 1] * w[..., 0]) / den
        sin_inc = np.abs(den) / np.linalg.norm(e, axis=1)[None]
        clear = (H[None] + margin) / sin_inc
        # the wall's own thickness also blocks rays that pass just beyond its end
        ext = H[None] / np.linalg.norm(e, axis=1)[None]
        hit = (np.abs(den) > 1e-12) & (s > 1e-6) & (t >= -ext) & (t <= 1 + ext)
    s_hit = np.where(hit, s - clear, np.inf).min(axis=1)
    s_min = np.full(len(k), fov_margin)
    s_max = np.maximum(s_hit, s_min)
    ok = np.isfinite(s_max)
    k, cam, r, s_min, s_max = k[ok], cam[ok], r[ok], s_min[ok], s_max[ok]
    rows = _rows(T, -r, k)
    lower = -(np.einsum("ij,ij->i", r, cam) + s_max)
    return rows, lower, RayLimits(k, cam, r, s_min, s_max)


def make_box_constraints(floorplan: Floorplan, T: int, margin: float, reach: float, rays: RayLimits | None = None):
    """X -> (C, l, keys): the per-point, per-iterate half-planes of walls and obstacles (module
    docstring), keys identifying each row (step, box, face) so a solver can carry its active set
    over iterates; with ``rays``, observed steps decide their faces from their visible ray segment."""
    convex = is_convex(floorplan.outline)
    bx = boxes(floorplan, include_outline=not convex)

    def constraints(X: np.ndarray):
        xy = np.stack([X[IX::NS], X[IY::NS]], axis=1)
        if rays is not None:
            xy = rays.reference(xy)
        normals, ks, lows, keys = [], [], [], []
        for ib, (c, h, yaw) in enumerate(bx):
            ca, sa = np.cos(yaw), np.sin(yaw)
            ax = np.array([[ca, sa], [-sa, ca], [-ca, -sa], [sa, -ca]])  # face normals +x, +y, -x, -y
            half = np.array([h[0], h[1], h[0], h[1]])
            sd = (xy - c) @ ax.T - half  # (T, 4) signed distance beyond each face
            q = np.maximum(sd[:, :2], sd[:, 2:])  # |local| - half per axis
            dist = np.hypot(np.maximum(q[:, 0], 0), np.maximum(q[:, 1], 0))
            near = np.nonzero(dist < reach)[0]
            if not len(near):
                continue
            face = np.argmax(sd[near], axis=1)
            n = ax[face]
            normals.append(n)
            ks.append(near)
            lows.append(n @ c + half[face] + margin)
            keys.append((near * len(bx) + ib) * 4 + face)
        if not ks:
            return sp.csc_matrix((0, NS * T)), np.zeros(0), np.zeros(0, np.int64)
        k, nrm, low, key = np.concatenate(ks), np.concatenate(normals), np.concatenate(lows), np.concatenate(keys)
        # collinear walls (a wall split by a door) give the same half-plane twice: keep one
        # (duplicate active rows would make the step's KKT system singular)
        sig = np.c_[k, np.round(nrm, 9), np.round(low, 9)]
        _, first = np.unique(sig, axis=0, return_index=True)
        first = np.sort(first)
        return _rows(T, nrm[first], k[first]), low[first], key[first]

    return constraints
