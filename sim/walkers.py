"""Walker motion: smooth, collision-free trajectories for every person in a scene.

Each walker's motion model (``WalkerSpec.motion``) proposes a *rough* floor path, sampled at the
simulation rate, one *leg* at a time (a walk to a goal plus an optional stop, or a chunk of a
random process):

- ``random_waypoint`` (Teixeira sec. 7): a goal drawn uniformly in free space, a speed drawn
  uniformly in ``speed``; on arrival a stop with probability ``pause_probability`` lasting
  U(``pause``) seconds.
- ``random_walk`` (Rahimi sec. 6, the synthetic target): the heading performs a random walk
  (theta' = theta + N(0, SIGMA_HEADING^2 dt)), the speed a bounded random walk in ``speed``;
  a step that would enter a wall is reflected about the wall normal (the gradient of the
  clearance field: v <- v - 2 (v.n) n). The result is smoothed (Gaussian, RANDOM_WALK_SMOOTH s).
- ``gauss_markov`` (Rahimi eq. 1): per axis [x, v]_{k+1} = [[1, dt], [0, 1]] [x, v]_k + nu,
  nu ~ N(0, Sigma(dt)) with the exact discretisation of the continuous-time model
  (``GaussMarkovParams.Sigma(dt, "exact")``: [[q_pos dt + q_vel dt^3/3, q_vel dt^2/2],
  [q_vel dt^2/2, q_vel dt]]; GM_DISCRETISATION), so the path sampled at any coarser frame rate
  follows the same exact prior that ``estimators/qp_model.py`` uses by default (the two agree to
  the bit). Chunks of GM_CHUNK seconds are drawn whole, from the current state, until one stays
  in free space and its end state, coasting on at constant velocity for GM_COAST s, would too (a
  whole trajectory of minutes almost never stays in a room; the coasting test avoids dead ends
  that run into a wall). A state with no acceptable continuation in GM_MAX_DRAWS draws is
  dropped (backtracking); backtracking past the start redraws the initial velocity.
  What the conditioning does: inside a chunk the increments are the model's, but accepted paths
  are the process *conditioned on staying in free space* (greedily, chunk by chunk), which adds
  a drift towards the room's interior and caps the speed. Measured in bearing_hall (q_vel = 0.1,
  60 seeds x 60 s): the velocity change over a 2 s chunk has variance 1.1 x q_vel * 2 s, mean
  +0.30 m/s towards the room within 1 m of a wall, +0.21 at 1-2 m and +0.16 further in (std of
  the change 0.45 m/s); median speed 0.66 m/s. An estimator given the matched prior therefore
  sees a mildly mis-specified one (a restoring drift of ~1/3 to 2/3 sigma per 2 s). Draws per
  accepted chunk over 100 seeds x 60 s (q_vel = 0.1): mean 4.3, 95th percentile 10, max 12;
  with the default q_vel = 0.05: mean 6.0, 95th percentile 12, max 18; 0.2-0.7 dropped chunks
  per walker-minute.
  When the scene gives no ``process_noise`` the walker uses ``DEFAULT_WALKER_GM`` (the scene's
  default is the paper's stiff *prior*, for estimators; with it a walker goes straight through a
  wall within seconds). The parameters used are reported in ``Trajectories.gauss_markov``.
- ``waypoints``: the scripted path, planned leg by leg around walls and obstacles; ``loop``
  returns to the first waypoint and repeats; otherwise the walker stands at the last one.
- ``standing``: stands still at ``start`` (or a random free spot).

Seeded variation of scripted walkers (``WalkerSpec.vary``, on by default; scene key ``vary``), so
that every seed is a different scenario rather than the same paths with new sensor noise, drawn
from the walker's own stream when its model is made:

- pace: the walker's speed is multiplied by p ~ U(VARY_PACE) for the whole run (each leg's speed
  is still drawn uniformly in ``speed``);
- waypoints: each is moved by a point uniform in a disc of VARY_JITTER m, redrawn (at most
  VARY_TRIES times, else kept) until the new point keeps the clearance the written one had (up to
  radius + MARGIN) and every leg that was a straight free segment stays one (the scene's
  choreography around obstacles is kept);
- start phase (looped paths): the walker starts U(0, VARY_PHASE) m along the planned first leg
  instead of at the first waypoint (bounded, so that who walks beside whom, and roughly when,
  survives);
- standing people with a given ``start``: moved as a waypoint is, within VARY_JITTER m.

With ``vary = false`` a scripted walker replays the file exactly on every seed: it starts at its
first waypoint and walks every leg at the middle of its ``speed`` range (no draws at all).

Planning. Walls, obstacles and people standing still are obstacles on a floor grid of
``GRID`` metres; a cell is free when its clearance is at least radius + MARGIN. A leg goes
straight when the segment is free, otherwise along the shortest 8-connected grid path
(``scipy.sparse.csgraph.dijkstra``) shortened by line-of-sight ("string pulling").
Along a path the speed follows an acceleration-limited profile (|dv/dt| <= MAX_ACCEL), slowing at
corners, from rest to rest.

People avoid each other by priority: standing people first, then scripted walkers, then random
ones, each in scene order. A proposed leg (including its stop) that comes within
r_i + r_j + PERSONAL_SPACE of an already planned person is rejected; a random model proposes
another leg (new goal, speed or draw), a scripted walker waits a second and tries again. After
MAX_TRIES the leg is taken anyway (unavoidable meetings, e.g. in a narrow door).

Smoothing and derivatives. The rough x, y path is fitted by a least-squares quintic B-spline with
knots every KNOT_SPACING s (C4 continuous). Positions, velocities and accelerations are the
spline and its exact derivatives at the sample times, so the accelerometer sees the true second
derivative. The vertical body centre is

    z(t) = h / 2 + A a(s) (sin^2(pi phi(t)) - 1/2),   phi(t) = integral of f(s) dt,

with A = ``bob_amplitude`` (peak to peak), step rate f(s) = STEP_RATE_0 + STEP_RATE_SLOPE s (Hz,
rising with speed s), a(s) = 1 - exp(-(s / s_b)^2) (s_b = WALKING_SPEED_BOB) fading the bob in
and out at stops, smooth in the velocity so that z'' has no kinks; z is
interpolated by a quintic spline through its samples, so again z, z', z'' are consistent. The yaw
follows the walking direction atan2(vy, vx) (held while standing), unwrapped, smoothed and fitted
by a quintic spline (yaw, yaw rate, yaw acceleration).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d, map_coordinates

from trackroom.scenes.spec import GaussMarkovParams, Scene, WalkerSpec
from .bspline import interp_spline, lsq_spline

GRID = 0.1  # planning grid, m
MARGIN = 0.15  # extra clearance beyond the body radius when planning, m
MAX_ACCEL = 0.8  # m/s^2, speed-profile acceleration limit
PERSONAL_SPACE = 0.1  # m, kept between two bodies
LOOKAHEAD = 3.0  # s a leg's end point must also stay clear (room to start the next leg)
MAX_TRIES = 30
KNOT_SPACING = 0.2  # s, smoothing spline knots
YAW_SMOOTH = 0.25  # s, Gaussian smoothing of the heading before its spline
RANDOM_WALK_SMOOTH = 0.4  # s, Gaussian smoothing of the reflected random walk (Rahimi: "smoothed")
SIGMA_HEADING = 0.6  # rad / sqrt(s), random-walk heading diffusion
SIGMA_SPEED = 0.15  # m/s / sqrt(s), random-walk speed diffusion
RANDOM_WALK_CHUNK = 5.0  # s
GM_CHUNK = 2.0  # s
GM_DISCRETISATION = "exact"  # of Sigma(dt) at the simulation step: "exact" or Rahimi's diagonal "paper"
GM_COAST = 2.0  # s
GM_MAX_DRAWS = 100  # per chunk, before dropping the previous chunk
GM_DRAW_BUDGET = 250  # mean draws per chunk of the duration (at least 5000 in all), then give up with an error
STEP_RATE_0 = 1.0  # Hz
STEP_RATE_SLOPE = 0.6  # Hz per m/s
WALKING_SPEED_BOB = 0.35  # m/s: the gait bob has 63 % of its amplitude at this speed, 87 % at 0.5
# Walker default for gauss_markov when the scene sets no process_noise: a velocity random walk
# strong enough to turn within a 10 m room (std of a velocity change over 5 s: sqrt(0.05*5) =
# 0.5 m/s), with 1 cm/sqrt(s) position jitter. Measured in bearing_hall: ~6 draws per 2 s chunk,
# mean speed 0.6 m/s, 95th percentile acceleration 1.4 m/s^2 (tests/test_walkers.py bounds the draws).
DEFAULT_WALKER_GM = GaussMarkovParams(q_pos=1e-4, q_vel=0.05)
# Seeded variation of scripted walkers (module docstring): speed factor range, waypoint and
# standing-spot jitter radius (m), start offset along a loop's first leg (m), draws per point.
VARY_PACE = (0.85, 1.15)
VARY_JITTER = 0.3
VARY_PHASE = 2.0
VARY_TRIES = 20


@dataclass
class Trajectories:
    """Truth kinematics of every person at the simulation rate.

    t (N,) s; pos, vel, acc (P, N, 3) in m, m/s, m/s^2 (z = body centre height incl. gait bob);
    yaw, yaw_rate, yaw_acc (P, N) in rad, rad/s, rad/s^2 (unwrapped: continuous, not in (-pi, pi]);
    walking (P, N): horizontal speed above ``walking_speed``. ``names`` the walkers' names.
    ``gauss_markov``: per walker the (q_pos, q_vel) actually used by a gauss_markov walker (else None).
    ``draws``: per walker, proposals drawn (rejections included); ``conflicts``: legs taken
    although they come too close to someone (no clear proposal in MAX_TRIES) -- diagnostics.
    """

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    yaw: np.ndarray
    yaw_rate: np.ndarray
    yaw_acc: np.ndarray
    walking: np.ndarray
    names: tuple[str, ...] = ()
    rate: float = 100.0
    gauss_markov: list = field(default_factory=list)
    draws: list = field(default_factory=list)
    conflicts: list = field(default_factory=list)

    @property
    def n_people(self) -> int:
        return self.pos.shape[0]

    @property
    def n_steps(self) -> int:
        return self.t.shape[0]

    def speed(self) -> np.ndarray:
        """Horizontal speed (P, N), m/s."""
        return np.hypot(self.vel[..., 0], self.vel[..., 1])


# ----------------------------------------------------------------------------- free space
class FreeSpace:
    """The floor plan as a clearance grid (m to the nearest wall/obstacle/standing person)."""

    def __init__(self, floorplan, extra_discs: list[tuple[float, float, float]] = ()):
        self.floorplan = floorplan
        x0, y0, x1, y1 = floorplan.bounds()
        self.origin = np.array([x0, y0])
        self.nx = int(np.ceil((x1 - x0) / GRID)) + 1
        self.ny = int(np.ceil((y1 - y0) / GRID)) + 1
        gx = x0 + GRID * np.arange(self.nx)
        gy = y0 + GRID * np.arange(self.ny)
        self.centres = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1)  # (nx, ny, 2)
        self.discs = list(extra_discs)
        self.grid = self.clearance(self.centres)
        self._last = np.array([self.nx - 1, self.ny - 1])
        self._grid_finite = np.where(np.isfinite(self.grid), self.grid, -1.0)
        self._graphs: dict[float, tuple] = {}
        self._free_cells: dict[float, np.ndarray] = {}

    def with_disc(self, x: float, y: float, r: float) -> "FreeSpace":
        """A copy with one more round obstacle (a person standing still)."""
        return FreeSpace(self.floorplan, self.discs + [(x, y, r)])

    def clearance(self, xy) -> np.ndarray:
        """Exact clearance (m) of floor points (..., 2); -inf outside the room."""
        xy = np.asarray(xy, float)
        d = self.floorplan.clearance(xy)
        for cx, cy, r in self.discs:
            d = np.minimum(d, np.hypot(xy[..., 0] - cx, xy[..., 1] - cy) - r)
        return d

    def clearance_fast(self, xy) -> np.ndarray:
        """Bilinear lookup in the clearance grid (for the random walk's many small steps)."""
        xy = np.atleast_2d(np.asarray(xy, float))
        ij = ((xy - self.origin) / GRID).T
        return map_coordinates(self._grid_finite, ij, order=1, mode="nearest")

    def normal(self, xy) -> np.ndarray:
        """Unit gradient of the clearance (points away from the nearest wall)."""
        e = 0.5 * GRID
        p = np.asarray(xy, float)
        g = np.array(
            [
                self.clearance_fast(p + [e, 0])[0] - self.clearance_fast(p - [e, 0])[0],
                self.clearance_fast(p + [0, e])[0] - self.clearance_fast(p - [0, e])[0],
            ]
        )
        n = np.linalg.norm(g)
        return g / n if n > 0 else np.zeros(2)

    def is_free(self, xy, inflate: float, tol: float = 1e-9) -> np.ndarray:
        """clearance(xy) >= inflate - tol for floor points (n, 2), decided exactly but mostly
        from the grid.

        The clearance d is 1-Lipschitz (a minimum of distances), so with g the grid value at
        the nearest node and e = |p - node| <= GRID / sqrt(2): d(p) >= g - e, and d(p) <= g + e
        (where the node lies in the room). Points with g - e >= inflate are free and points with
        g + e < inflate are blocked without computing d; only the points in between (within
        ~GRID of the inflated boundary) get the exact ``clearance``. The answer is therefore
        identical to the exact test, at a fraction of its cost.
        """
        p = np.asarray(xy, float).reshape(-1, 2)
        if len(p) == 1:  # one point (a drawn goal or start): the same test in Python floats
            return np.array([self._free_point(float(p[0, 0]), float(p[0, 1]), inflate - tol)])
        ij = np.minimum(np.maximum(np.rint((p - self.origin) / GRID).astype(np.intp), 0), self._last)
        g = self.grid[ij[:, 0], ij[:, 1]]
        d = p - self.centres[ij[:, 0], ij[:, 1]]
        e = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2) + 1e-9  # + rounding allowance
        thr = inflate - tol
        # g > e: the disc |p - node| < g lies in the room, where d is the 1-Lipschitz distance
        free = (g - e >= thr) & (g > e)
        unsure = ~free & (g + e >= thr)
        unsure |= np.isneginf(g)  # node outside the room: p may still be just inside it
        if unsure.any():
            free[unsure] = self.clearance(p[unsure]) >= thr
        return free

    def _free_point(self, x: float, y: float, thr: float) -> bool:
        """``is_free`` of one point, ``thr`` = inflate - tol: the same operations on Python floats
        (IEEE doubles, rounded alike; ``round`` halves to even as ``np.rint``), without a dozen
        array calls on one element (~1500 drawn points per 10 walker-minutes)."""
        i = min(max(round((x - float(self.origin[0])) / GRID), 0), self.nx - 1)
        j = min(max(round((y - float(self.origin[1])) / GRID), 0), self.ny - 1)
        g = float(self.grid[i, j])
        dx, dy = x - float(self.centres[i, j, 0]), y - float(self.centres[i, j, 1])
        e = math.sqrt(dx * dx + dy * dy) + 1e-9
        if g - e >= thr and g > e:
            return True
        if g + e >= thr or g == -math.inf:
            return bool(self.clearance(np.array([[x, y]]))[0] >= thr)
        return False

    def segment_free(self, a, b, inflate: float) -> bool:
        """Every point of the segment a-b (sampled every GRID / 4) keeps ``inflate`` clearance."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / (0.25 * GRID))) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None]
        return bool(self.is_free(a + s * (b - a), inflate).all())

    def _graph(self, inflate: float):
        if inflate not in self._graphs:
            # imported here: only a path around an obstacle needs the graph, and scipy.sparse.csgraph
            # (with the scipy.sparse.linalg it loads) is a tenth of a second of every start-up
            from scipy.sparse import coo_matrix

            free = self.grid >= inflate
            idx = np.arange(self.nx * self.ny).reshape(self.nx, self.ny)
            rows, cols, w = [], [], []
            for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
                a = free[max(0, -di) : self.nx - max(0, di), max(0, -dj) : self.ny - max(0, dj)]
                b = free[max(0, di) :, max(0, dj) : self.ny + min(0, dj) or None][: a.shape[0], : a.shape[1]]
                ia = idx[max(0, -di) : self.nx - max(0, di), max(0, -dj) : self.ny - max(0, dj)]
                ib = idx[max(0, di) :, max(0, dj) : self.ny + min(0, dj) or None][: a.shape[0], : a.shape[1]]
                ok = a & b
                rows.append(ia[ok])
                cols.append(ib[ok])
                w.append(np.full(ok.sum(), GRID * np.hypot(di, dj)))
            r, c, ww = np.concatenate(rows), np.concatenate(cols), np.concatenate(w)
            g = coo_matrix((ww, (r, c)), shape=(idx.size, idx.size)).tocsr()
            self._graphs[inflate] = (g, free)
        return self._graphs[inflate]

    def nearest_free_cell(self, xy, inflate: float) -> int:
        _, free = self._graph(inflate)
        d2 = ((self.centres - np.asarray(xy, float)) ** 2).sum(-1)
        d2 = np.where(free, d2, np.inf)
        k = int(np.argmin(d2))
        if not np.isfinite(d2.flat[k]):
            raise ValueError("no free floor space for a walker of this radius")
        return k

    def plan(self, a, b, inflate: float) -> np.ndarray:
        """Polyline (M, 2) from a to b that keeps ``inflate`` clearance (straight when possible)."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        if self.segment_free(a, b, inflate):
            return np.stack([a, b])
        from scipy.sparse.csgraph import dijkstra  # see _graph

        g, _ = self._graph(inflate)
        src, dst = self.nearest_free_cell(a, inflate), self.nearest_free_cell(b, inflate)
        _, pred = dijkstra(g, directed=False, indices=src, return_predecessors=True)
        if dst != src and pred[dst] < 0:
            raise ValueError(f"no path from {a.tolist()} to {b.tolist()} for a walker of clearance {inflate:.2f} m")
        cells = [dst]
        while cells[-1] != src:
            cells.append(int(pred[cells[-1]]))
        pts = self.centres.reshape(-1, 2)[cells[::-1]]
        pts = np.vstack([a, pts, b])
        # string pulling: from each kept point, jump to the furthest point in line of sight
        out, i = [pts[0]], 0
        while i < len(pts) - 1:
            j = len(pts) - 1
            while j > i + 1 and not self.segment_free(pts[i], pts[j], inflate - 0.5 * GRID):
                j -= 1
            out.append(pts[j])
            i = j
        return np.array(out)

    def random_free_point(self, rng: np.random.Generator, inflate: float) -> np.ndarray:
        """Uniform over free cells, jittered within the cell and checked exactly."""
        cells = self._free_cells.get(inflate)
        if cells is None:
            cells = self._free_cells[inflate] = np.flatnonzero(self._graph(inflate)[1])
        if cells.size == 0:
            raise ValueError("no free floor space for a walker of this radius")
        for _ in range(100):
            p = self.centres.reshape(-1, 2)[cells[rng.integers(cells.size)]] + rng.uniform(-0.5, 0.5, 2) * GRID
            if self.is_free(p, inflate, 0.0)[0]:
                return p
        return self.centres.reshape(-1, 2)[cells[rng.integers(cells.size)]]


# ----------------------------------------------------------------------------- variation
def jitter_points(free: FreeSpace, points: list, legs: list, inflate: float, rng: np.random.Generator) -> list:
    """Each point (2,) moved by a draw uniform in a disc of VARY_JITTER m, in order.

    A draw is kept when the moved point keeps the clearance the given one had (capped at
    ``inflate``) and every leg (a, b) in ``legs`` (indices into ``points``) touching it that was a
    free straight segment stays one (checked against the neighbours as already moved); otherwise
    it is redrawn, and after VARY_TRIES draws the point stays where it was.
    """
    given = [np.asarray(p, float) for p in points]
    out = [p.copy() for p in given]
    straight = {leg: free.segment_free(given[leg[0]], given[leg[1]], inflate) for leg in legs}
    for k, p in enumerate(given):
        need = min(inflate, float(free.clearance(p)))
        mine = [leg for leg in legs if k in leg and straight[leg]]
        for _ in range(VARY_TRIES):
            r, h = VARY_JITTER * np.sqrt(rng.uniform()), rng.uniform(-np.pi, np.pi)
            q = p + r * np.array([np.cos(h), np.sin(h)])
            if not free.is_free(q, need, 0.0)[0]:
                continue
            ends = [[q if j == k else out[j] for j in leg] for leg in mine]
            if all(free.segment_free(a, b, inflate) for a, b in ends):
                out[k] = q
                break
    return out


def point_along(poly: np.ndarray, s: float) -> np.ndarray:
    """The point ``s`` m along a polyline (M, 2), at most to 0.1 m before its end."""
    seglen = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seglen)])
    s = float(np.clip(s, 0.0, max(0.0, cum[-1] - 0.1)))
    return np.array([np.interp(s, cum, poly[:, 0]), np.interp(s, cum, poly[:, 1])])


# ----------------------------------------------------------------------------- speed profile
def follow_path(poly: np.ndarray, speed: float, dt: float) -> np.ndarray:
    """Samples (n, 2) every dt s along a polyline, from rest to rest, at most ``speed``.

    Speed cap per arc length: v_max(s) = speed, lowered at a corner of turn angle theta to
    speed (1 + cos theta) / 2 (at least 0.3 m/s), 0 at both ends. With |dv/dt| <= a the reachable
    profile is v(s)^2 = min over s' of (v_max(s')^2 + 2 a |s - s'|), computed by a running
    minimum forwards and backwards. Time t(s) = integral ds / v.
    """
    # (np.diff and np.linalg.norm's arithmetic written out, the corner search only where there are
    # corners: 1443 legs in 10 minutes of 10 walkers, each on a few thousand samples, and the
    # calls' overhead was a third of the cost; the same numbers)
    seg = poly[1:] - poly[:-1]
    seglen = np.sqrt(seg[:, 0] * seg[:, 0] + seg[:, 1] * seg[:, 1])
    keep = seglen > 1e-9
    if not keep.all():
        poly = np.vstack([poly[:1], poly[1:][keep]])
        seg, seglen = seg[keep], seglen[keep]
    total = float(seglen.sum())
    if total < 1e-6:
        return poly[:1].copy()
    ds = min(0.002, total / 20)
    s = np.linspace(0.0, total, int(np.ceil(total / ds)) + 1)
    cum = np.concatenate([[0.0], np.cumsum(seglen)])
    cap2 = np.full(s.shape, speed**2)
    if len(poly) > 2:
        dirs = seg / seglen[:, None]
        # the sample nearest each corner (the lower one on a tie), as argmin |s - cum[k]| would give
        j = np.clip(np.searchsorted(s, cum[1:-1]), 1, len(s) - 1)
        near = np.where(np.abs(s[j - 1] - cum[1:-1]) <= np.abs(s[j] - cum[1:-1]), j - 1, j)
        for k in range(1, len(poly) - 1):
            c = float(np.clip(dirs[k - 1] @ dirs[k], -1, 1))
            v = max(0.3, speed * 0.5 * (1 + c))
            cap2[near[k - 1]] = min(v, speed) ** 2
    cap2[0] = cap2[-1] = 0.0
    a2s = 2 * MAX_ACCEL * s
    fwd = np.minimum.accumulate(cap2 - a2s) + a2s
    bwd = (np.minimum.accumulate((cap2 + a2s)[::-1]))[::-1] - a2s
    v = np.sqrt(np.maximum(np.minimum(fwd, bwd), 0.0))
    vmid = 0.5 * (v[1:] + v[:-1])
    tt = np.empty(len(s))
    tt[0] = 0.0
    np.cumsum((s[1:] - s[:-1]) / np.maximum(vmid, 1e-3), out=tt[1:])
    n = int(np.ceil(tt[-1] / dt)) + 1
    st = np.interp(np.arange(n) * dt, tt, s)
    out = np.empty((n, 2))
    out[:, 0] = np.interp(st, cum, poly[:, 0])
    out[:, 1] = np.interp(st, cum, poly[:, 1])
    return out


# ----------------------------------------------------------------------------- motion models
class _Model:
    """Proposes legs: rough floor samples (n, 2) continuing from the current state."""

    smooth = 0.0  # s of Gaussian pre-smoothing of the rough path

    def __init__(self, spec: WalkerSpec, free: FreeSpace, dt: float, rng: np.random.Generator):
        self.spec, self.free, self.dt, self.rng = spec, free, dt, rng
        self.inflate = spec.radius + MARGIN

    def start(self) -> np.ndarray:
        if self.spec.start is not None:
            return np.asarray(self.spec.start, float)
        return self.free.random_free_point(self.rng, self.inflate)

    def commit(self, leg: np.ndarray) -> None:
        """Called when a proposed leg is accepted."""

    def hard(self, leg: np.ndarray) -> bool:
        """A hard constraint the leg must meet (beyond the planner's)."""
        return True

    def wait_leg(self, pos: np.ndarray, seconds: float = 1.0) -> np.ndarray:
        return np.repeat(pos[None], max(1, int(round(seconds / self.dt))), axis=0)


class _Standing(_Model):
    def start(self):
        if self.spec.start is not None and self.spec.vary:
            return jitter_points(self.free, [np.asarray(self.spec.start, float)], [], self.inflate, self.rng)[0]
        return super().start()

    def propose(self, pos, t):
        return self.wait_leg(pos, 3600.0)


class _RandomWaypoint(_Model):
    def propose(self, pos, t):
        spec, rng = self.spec, self.rng
        goal = self.free.random_free_point(rng, self.inflate)
        speed = rng.uniform(*spec.speed)
        leg = follow_path(self.free.plan(pos, goal, self.inflate), speed, self.dt)
        if rng.random() < spec.pause_probability:
            leg = np.vstack([leg, self.wait_leg(leg[-1], rng.uniform(*spec.pause))])
        return leg


class _Waypoints(_Model):
    def __init__(self, *a):
        super().__init__(*a)
        self.targets = [np.asarray(w, float) for w in self.spec.waypoints]
        self.pace = 1.0
        if self.spec.vary:
            self.pace = float(self.rng.uniform(*VARY_PACE))
            n = len(self.targets)
            legs = [(k, k + 1) for k in range(n - 1)] + ([(n - 1, 0)] if self.spec.loop and n > 2 else [])
            self.targets = jitter_points(self.free, self.targets, legs, self.inflate, self.rng)
        self.next = 1
        self.done = False

    def start(self):
        if self.spec.vary and self.spec.loop:  # start phase: somewhere along the first leg
            first = self.free.plan(self.targets[0], self.targets[1], self.inflate)
            return point_along(first, self.rng.uniform(0.0, VARY_PHASE))
        return self.targets[0].copy()

    def propose(self, pos, t):
        if self.done:
            return self.wait_leg(pos, 3600.0)
        lo, hi = self.spec.speed
        speed = self.pace * (self.rng.uniform(lo, hi) if self.spec.vary else 0.5 * (lo + hi))
        self._goal_next = self.next + 1
        return follow_path(self.free.plan(pos, self.targets[self.next % len(self.targets)], self.inflate), speed, self.dt)

    def commit(self, leg):
        if self.done:
            return
        self.next += 1
        if self.next >= len(self.targets) and not self.spec.loop:
            self.done = True
        elif self.next > len(self.targets):
            self.next = 1  # back at the start: go round again


class _RandomWalk(_Model):
    smooth = RANDOM_WALK_SMOOTH

    def __init__(self, *a):
        super().__init__(*a)
        self.heading = self.rng.uniform(-np.pi, np.pi)
        self.speed = self.rng.uniform(*self.spec.speed)
        self._state = None

    def propose(self, pos, t):
        rng, dt = self.rng, self.dt
        lo, hi = self.spec.speed
        n = int(round(RANDOM_WALK_CHUNK / dt))
        dtheta = rng.normal(0.0, SIGMA_HEADING * np.sqrt(dt), n)
        dspeed = rng.normal(0.0, SIGMA_SPEED * np.sqrt(dt), n)
        heading, speed = self.heading, self.speed
        p = np.array(pos, float)
        out = np.empty((n, 2))
        # the reflection needs the wall test at every step, so this loop is inherently sequential
        for k in range(n):
            heading += dtheta[k]
            speed = float(np.clip(speed + dspeed[k], lo, hi))
            v = speed * np.array([np.cos(heading), np.sin(heading)])
            q = p + v * dt
            if self.free.clearance_fast(q)[0] < self.inflate:
                nrm = self.free.normal(p)
                if v @ nrm < 0:
                    v = v - 2 * (v @ nrm) * nrm  # reflect off the wall
                heading = float(np.arctan2(v[1], v[0]))
                q = p + v * dt
                if self.free.clearance_fast(q)[0] < self.inflate:
                    q = p  # wedged in a corner: stay this step
            p = q
            out[k] = p
        self._state = (heading, speed)
        return out

    def commit(self, leg):
        self.heading, self.speed = self._state


class _GaussMarkov(_Model):
    def __init__(self, spec, free, dt, rng, params: GaussMarkovParams):
        super().__init__(spec, free, dt, rng)
        self.params = params
        S = params.Sigma(dt, GM_DISCRETISATION)
        l11 = np.sqrt(S[1, 1])
        l21 = S[0, 1] / l11
        self._chol = (l11, l21, np.sqrt(S[0, 0] - l21**2))
        self.vel = self.initial_velocity()
        self._vel = None
        self.chunks = self.backtracks = self.restarts = 0  # diagnostics: accepted, dropped chunks

    def initial_velocity(self) -> np.ndarray:
        """v_0: speed U(``speed``), heading uniform."""
        speed = self.rng.uniform(*self.spec.speed)
        h = self.rng.uniform(-np.pi, np.pi)
        return speed * np.array([np.cos(h), np.sin(h)])

    def propose(self, pos, t):
        """One chunk of Rahimi eq. 1 at step dt, drawn from the current state [x, v]:
        x_{k+1} = x_k + dt v_k + nu_x, v_{k+1} = v_k + nu_v per axis, (nu_x, nu_v) ~ N(0, S) with S
        = ``Sigma(dt, GM_DISCRETISATION)`` (exact: S_xx = q_pos dt + q_vel dt^3/3, S_xv = q_vel
        dt^2/2, S_vv = q_vel dt), drawn as nu_v = l11 z_v, nu_x = l21 z_v + l22 z_x (Cholesky,
        l11 = sqrt(S_vv), l21 = S_xv / l11, l22 = sqrt(S_xx - l21^2); z standard normal)."""
        rng, dt = self.rng, self.dt
        n = int(round(GM_CHUNK / dt))
        l11, l21, l22 = self._chol
        z_v = rng.standard_normal((n, 2))
        nu_v = l11 * z_v
        nu_x = l22 * rng.standard_normal((n, 2))
        if l21:
            nu_x += l21 * z_v
        v = self.vel + np.cumsum(nu_v, axis=0)
        v_prev = np.vstack([self.vel, v[:-1]])  # x_{k+1} = x_k + dt v_k + nu_x
        x = np.asarray(pos, float) + np.cumsum(dt * v_prev + nu_x, axis=0)
        self._vel = v[-1]
        return x

    def hard(self, leg):
        """The chunk keeps the body's clearance, and so does its end state coasting on for
        GM_COAST s (x_end + v_end s): a chunk that ends running into a wall is a dead end that
        would cost many rejected continuations."""
        coast = leg[-1] + np.outer(np.linspace(0.0, GM_COAST, 9), self._vel)
        pts = np.vstack([leg[:: max(1, int(0.05 / self.dt))], coast])
        return bool(self.free.is_free(pts, self.inflate, 0.0).all())

    def commit(self, leg):
        self.vel = self._vel


def walker_gauss_markov(scene: Scene, i: int) -> GaussMarkovParams:
    """The process noise a gauss_markov walker uses: the scene's ``process_noise`` when the file
    (or an override) sets it for this walker, else ``DEFAULT_WALKER_GM``."""
    raw = scene.raw.get("walkers", {}) if isinstance(scene.raw, dict) else {}
    people = raw.get("people", []) if isinstance(raw, dict) else []
    given = "process_noise" in raw or (i < len(people) and "process_noise" in people[i])
    return scene.walkers[i].gauss_markov if given else DEFAULT_WALKER_GM


# ----------------------------------------------------------------------------- smoothing
def _lsq_quintic(t: np.ndarray, y: np.ndarray, spacing: float):
    """Least-squares quintic B-spline of y(t) (N, d) with interior knots every ``spacing`` s."""
    k = 5
    n_int = max(0, int(np.floor((t[-1] - t[0]) / spacing)) - 1)
    inner = np.linspace(t[0], t[-1], n_int + 2)[1:-1]
    knots = np.concatenate([[t[0]] * (k + 1), inner, [t[-1]] * (k + 1)])
    if len(t) < len(knots) - k:  # too short for a least-squares fit
        return interp_spline(t, y, min(k, len(t) - 1 - (len(t) % 2 == 0)) if len(t) > 1 else 0)
    return lsq_spline(t, y, knots, k)


def _derivs(spl, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return spl(t), spl(t, 1), spl(t, 2)


def _smooth_all(t: np.ndarray, rough: list, specs, smooth_s: list, dt: float):
    """Spline every rough path (one joint fit: the walkers share times and knots), add the gait
    bob and the heading. Returns pos, vel, acc (P, N, 3) and yaw, yaw', yaw'' (P, N)."""
    P, n = len(specs), len(t)
    xy = np.stack(
        [gaussian_filter1d(r, s / dt, axis=0, mode="nearest") if s > 0 else r for r, s in zip(rough, smooth_s)], axis=1
    ).reshape(n, 2 * P)
    p, v, a = (x.reshape(n, P, 2).transpose(1, 0, 2) for x in _derivs(_lsq_quintic(t, xy, KNOT_SPACING), t))
    speed = np.hypot(v[..., 0], v[..., 1])  # (P, N)
    # gait bob: z = h/2 + A a(s) (sin^2(pi phi) - 1/2), phi = cumulative step count
    f = STEP_RATE_0 + STEP_RATE_SLOPE * speed
    phi = np.concatenate([np.zeros((P, 1)), np.cumsum(0.5 * (f[:, 1:] + f[:, :-1]) * dt, axis=1)], axis=1)
    height = np.array([w.height for w in specs])[:, None]
    bob = np.array([w.bob_amplitude for w in specs])[:, None]
    amp = bob * (1.0 - np.exp(-((speed / WALKING_SPEED_BOB) ** 2)))  # smooth in v: no kinks in z''
    z = 0.5 * height + amp * (np.sin(np.pi * phi) ** 2 - 0.5)
    pz, vz, az = (x.T for x in _derivs(interp_spline(t, z.T, 5), t))
    # heading: direction of travel while moving, held while standing
    heading = np.zeros((P, n))
    direction = np.arctan2(v[..., 1], v[..., 0])  # (P, N)
    steps = np.arange(n)
    for i in range(P):
        moving = speed[i] > 0.2
        if moving.any():
            idx = np.maximum.accumulate(np.where(moving, steps, -1))
            idx[idx < 0] = np.flatnonzero(moving)[0]
            heading[i] = np.unwrap(direction[i, idx])
    heading = gaussian_filter1d(heading, YAW_SMOOTH / dt, axis=1, mode="nearest")
    yaw, yaw_rate, yaw_acc = (x.T for x in _derivs(_lsq_quintic(t, heading.T, KNOT_SPACING), t))
    pos, vel, acc = (np.empty((P, n, 3)) for _ in range(3))  # filled in place: no stacked temporaries
    for out, horizontal, vertical in ((pos, p, pz), (vel, v, vz), (acc, a, az)):
        out[..., :2] = horizontal
        out[..., 2] = vertical
    for i, w in enumerate(specs):
        if w.motion == "standing":  # exactly still
            pos[i, :, :2] = rough[i][0]
            pos[i, :, 2] = 0.5 * w.height
            vel[i] = acc[i] = 0.0
            yaw_rate[i] = yaw_acc[i] = 0.0
    return pos, vel, acc, yaw, yaw_rate, yaw_acc


# ----------------------------------------------------------------------------- planning
def _priority(spec: WalkerSpec) -> int:
    return {"standing": 0, "waypoints": 1}.get(spec.motion, 2)


def plan_trajectories(scene: Scene, duration: float, rng: np.random.Generator, walking_speed: float | None = None) -> Trajectories:
    """Plan every walker of ``scene`` over [0, duration) s at ``scene.sensors.sim_rate`` (Hz).

    ``rng`` drives every random choice; one child stream per walker (in scene order) keeps a
    walker's path independent of how many draws the others needed. ``walking`` is horizontal
    speed above ``walking_speed`` (default ``scene.sensors.still_speed``).
    """
    if duration <= 0:
        raise ValueError(f"duration must be positive, got {duration}")
    rate = float(scene.sensors.sim_rate)
    dt = 1.0 / rate
    n = int(np.floor(duration * rate + 1e-9))
    t = np.arange(n) * dt
    specs = scene.walkers
    P = len(specs)
    streams = rng.spawn(P) if P else []
    free = FreeSpace(scene.floorplan)
    rough: list = [None] * P
    draws = [0] * P
    conflicts = [0] * P
    gm_used: list = [None] * P
    smooth = [0.0] * P
    stride = max(1, int(round(0.1 * rate)))  # person-person checks every 0.1 s
    for i in sorted(range(P), key=lambda i: (_priority(specs[i]), i)):
        spec, r = specs[i], streams[i]
        if spec.motion == "gauss_markov":
            gm_used[i] = walker_gauss_markov(scene, i)
            model = _GaussMarkov(spec, free, dt, r, gm_used[i])
        else:
            cls = {"standing": _Standing, "random_waypoint": _RandomWaypoint, "random_walk": _RandomWalk, "waypoints": _Waypoints}
            model = cls[spec.motion](spec, free, dt, r)
        smooth[i] = model.smooth
        others = _Others(i, rough, specs)
        start = model.start()
        if spec.start is None and spec.motion != "waypoints":  # a random start: not on top of someone
            for _ in range(MAX_TRIES):
                if _clear_of_others(start[None], 0, others, 1, int(round(LOOKAHEAD * rate))):
                    break
                start = free.random_free_point(r, model.inflate)
        if spec.motion == "gauss_markov":
            xy = _plan_gauss_markov(model, start, n, i, others, stride, draws, specs[i].name)
        else:
            xy = _plan_legs(model, start, n, i, others, stride, draws, conflicts)
        rough[i] = xy
        if spec.motion == "standing":
            free = free.with_disc(xy[0, 0], xy[0, 1], spec.radius)
    pos, vel, acc, yaw, yaw_rate, yaw_acc = _smooth_all(t, rough, specs, smooth, dt)
    for i, spec in enumerate(specs):
        if spec.motion == "standing":
            yaw[i] = streams[i].uniform(-np.pi, np.pi)
    ws = scene.sensors.still_speed if walking_speed is None else walking_speed
    walking = np.hypot(vel[..., 0], vel[..., 1]) > ws
    return Trajectories(
        t=t, pos=pos, vel=vel, acc=acc, yaw=yaw, yaw_rate=yaw_rate, yaw_acc=yaw_acc, walking=walking,
        names=tuple(s.name for s in specs), rate=rate, gauss_markov=gm_used, draws=draws, conflicts=conflicts,
    )


class _Others:
    """The people planned before walker ``i`` (every path complete, n samples), stacked (J, n, 2),
    with the distance each must keep from i: one vectorised check per proposed leg."""

    def __init__(self, i: int, rough: list, specs):
        js = [j for j, other in enumerate(rough) if other is not None and j != i]
        self.paths = np.stack([rough[j] for j in js]) if js else np.zeros((0, 0, 2))
        self.keep = np.array([specs[i].radius + specs[j].radius + PERSONAL_SPACE for j in js])[:, None]


def _clear_of_others(leg: np.ndarray, k0: int, others: _Others, stride: int, lookahead: int = 0) -> bool:
    """True when ``leg`` (samples from step k0), and its end point for ``lookahead`` more steps,
    keeps personal space to every planned person (checked every ``stride`` samples)."""
    if lookahead:
        leg = np.vstack([leg, np.repeat(leg[-1:], lookahead, axis=0)])
    m = min(len(leg), others.paths.shape[1] - k0)
    if m <= 0 or not len(others.keep):
        return True
    d = leg[:m:stride] - others.paths[:, k0 : k0 + m : stride]  # (J, q, 2)
    return not (np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) < others.keep).any()


def _plan_legs(model: _Model, start, n, i, others: _Others, stride, draws, conflicts) -> np.ndarray:
    """Leg after leg until n samples; a leg too close to someone is re-drawn (random models) or
    preceded by a one-second wait (scripted); after MAX_TRIES it is taken anyway."""
    pieces, k = [np.asarray(start, float)[None]], 1
    look = int(round(LOOKAHEAD / model.dt))
    while k < n:
        pos = pieces[-1][-1]
        leg, commit = None, True
        for _ in range(MAX_TRIES):
            cand = model.propose(pos, k * model.dt)
            draws[i] += 1
            if _clear_of_others(cand, k, others, stride, look):
                leg = cand
                break
            if isinstance(model, _Waypoints):
                wait = model.wait_leg(pos, 1.0)
                if _clear_of_others(wait, k, others, stride, look):
                    leg, commit = wait, False
                    break
        if leg is None:
            leg = cand  # unavoidable (a narrow passage, or nobody can move out of the way)
            conflicts[i] += 1
        if commit:
            model.commit(leg)
        pieces.append(leg)
        k += len(leg)
    return np.vstack(pieces)[:n]


def _plan_gauss_markov(model: "_GaussMarkov", start, n, i, others: _Others, stride, draws, name: str) -> np.ndarray:
    """Chunks of Rahimi eq. 1 drawn until one stays in free space (and, if possible, clear of the
    others).

    Backtracking: a state with no acceptable continuation in GM_MAX_DRAWS draws is a dead end
    (e.g. fast towards a wall, too close to turn): its chunk is dropped and the one before is
    drawn again. Backtracking past the first chunk redraws the initial velocity (speed
    U(``speed``), heading uniform), which is a draw of the initial state, not of the process: a
    walker that starts near a wall heading into it has no Gauss-Markov continuation at all.
    Only after GM_DRAW_BUDGET draws per chunk of the duration (measured means are 4-12) does it
    give up, with an error naming the process noise (a prior so stiff that no path of this
    duration stays in the room: e.g. q_vel = 1e-3 in bearing_hall fails in a few seconds).
    """
    pieces, vels, k = [np.asarray(start, float)[None]], [model.vel.copy()], 1
    budget = max(5000, GM_DRAW_BUDGET * int(np.ceil(n * model.dt / GM_CHUNK)))
    while k < n:
        model.vel = vels[-1]
        fallback, leg = None, None
        for attempt in range(GM_MAX_DRAWS):
            cand = model.propose(pieces[-1][-1], k * model.dt)
            draws[i] += 1
            if not model.hard(cand):
                continue
            if _clear_of_others(cand, k, others, stride):
                leg = (cand, model._vel.copy())
                break
            fallback = fallback or (cand, model._vel.copy())
            if attempt >= MAX_TRIES:
                break
        leg = leg or fallback
        if leg is None:
            if draws[i] > budget:
                raise ValueError(
                    f"walker {name!r}: no Gauss-Markov path stays in free space after {draws[i]} draws; "
                    f"change process_noise (q_pos, q_vel) = ({model.params.q_pos}, {model.params.q_vel})"
                )
            model.backtracks += 1
            if len(pieces) == 1:  # dead end from the start: a new initial velocity
                vels[0] = model.initial_velocity()
                model.restarts += 1
            else:
                k -= len(pieces.pop())
                vels.pop()
            continue
        pieces.append(leg[0])
        vels.append(leg[1])
        model.chunks += 1
        k += len(leg[0])
    return np.vstack(pieces)[:n]
