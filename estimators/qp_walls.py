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
  per point from the current Gauss-Newton iterate and re-decided at every iterate: a point next
  to a wall stays on its side, a point by a wall's end (a door) is held off the end cap only, so
  paths through doors stay possible. This is a local (convex-inner-approximation) rule: a point
  the iterate has already put on the wrong side of a wall is kept there.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from scenes.spec import Floorplan

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


def make_box_constraints(floorplan: Floorplan, T: int, margin: float, reach: float):
    """X -> (C, l): the per-point, per-iterate half-planes of walls and obstacles (module docstring)."""
    convex = is_convex(floorplan.outline)
    bx = boxes(floorplan, include_outline=not convex)

    def constraints(X: np.ndarray):
        xy = np.stack([X[IX::NS], X[IY::NS]], axis=1)
        normals, ks, lows = [], [], []
        for c, h, yaw in bx:
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
        if not ks:
            return sp.csc_matrix((0, NS * T)), np.zeros(0)
        k = np.concatenate(ks)
        return _rows(T, np.concatenate(normals), k), np.concatenate(lows)

    return constraints
