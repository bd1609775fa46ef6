"""One tracked person of the target-plane method: prediction, per-camera status, estimation.

Each camera is, for each target, in one of three states (Tsutsui et al., sections 1, 3.3, 4):

- ``tracking``: it follows the target with its own tracker (a track id in the ``boxes`` table);
  its window enters the position (eq. 6 / section 3.2) and velocity (eq. 7) estimates.
- ``lost``: it does not see the target; it searches the *estimated window* (the person model at
  the predicted position, or over the whole target area, projected into it, section 3.3) for a
  window whose flow matches the *predicted image velocity* (section 3.4.2).
- ``unreliable``: it follows something that may not be the target alone (section 4): another
  mover with a similar image velocity overlaps the target's window (4.1), the window grew more
  than eq. 8 allows (4.2, threshold 1), or its position left the estimated window (4.3). Its
  information is left out; it searches the estimated window like a lost camera and is reliable
  again once a window there is separate from every other mover.

Symbols: ``w_c`` estimated window width (px, the cylinder at the predicted position), ``u_c`` its
centre; ``v_pred`` predicted image velocity (px/s, eq. 7 at the predicted position).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from . import tp_geometry as geo
from .tp_frames import CameraBoxes

TRACKING, LOST, UNRELIABLE = "tracking", "lost", "unreliable"


@dataclass
class CameraState:
    status: str = LOST
    track: object = None  # the camera tracker's id being followed
    reason: str = ""
    near: dict = field(default_factory=dict)  # other movers beside the target last frame: id -> (u_l, u_r, flow_u)
    others: set = field(default_factory=set)  # track ids seen beside the target's own window: other people (4.1)
    pending: object = None  # window (track id) found but not yet confirmed as the target
    pending_n: int = 0  # consecutive frames it was found


@dataclass
class CameraView:
    """What one camera expects of one target this frame."""

    win_point: np.ndarray  # (4,) estimated window at the predicted position
    win_area: np.ndarray  # (4,) estimated window over the target area (search window)
    v_pred: np.ndarray | None  # (2,) predicted image velocity, px/s (None until a velocity is known)
    v_slack: float = 0.0  # px/s: the target's velocity uncertainty sigma_v seen in this camera, |J| sigma_v

    @property
    def u_c(self) -> float:
        return 0.5 * (self.win_point[0] + self.win_point[1])

    @property
    def w_c(self) -> float:
        return max(self.win_point[1] - self.win_point[0], 1.0)


def _focal(P: np.ndarray) -> float:
    """Focal length (px) of P = K [R | t] with K = [[f, 0, cx], [0, f, cy], [0, 0, 1]]:
    M M^T = K K^T for M = P[:, :3], so f^2 = (K K^T)_00 - cx^2 with cx = (K K^T)_02 / (K K^T)_22."""
    M = np.asarray(P, float)[:, :3]
    KK = M @ M.T
    KK = KK / KK[2, 2]
    return float(np.sqrt(max(KK[0, 0] - KK[0, 2] ** 2, 1e-12)))


def width_ratio(width_t: float, width_c: float) -> float:
    """Eq. 8: (width_t - width_c) / width_c, tracking against estimated window width."""
    return (width_t - width_c) / width_c


@dataclass
class Target:
    """State of one tracked person: floor position (m), 3-D velocity (m/s), per-camera states."""

    tid: int
    xy: np.ndarray
    cams: dict[str, CameraState]
    vel: np.ndarray = field(default_factory=lambda: np.zeros(3))
    vel_known: bool = False
    sigma: float = 0.3  # radius (m) of the position uncertainty used for the search window
    sigma_v: float = 0.0  # m/s: uncertainty of the velocity (grows while no camera tracks: stops, turns)
    area: np.ndarray | None = None  # single-camera target area (polygon) when that was the estimate
    hits: int = 0
    misses_s: float = 0.0
    confirmed: bool = False
    n_used: int = 0
    mode: str = ""

    def sample_points(self, xy_pred: np.ndarray) -> np.ndarray:
        """Floor points spanning where the target may be: the moved target area, or a disc."""
        if self.area is not None:
            shift = xy_pred - self.xy
            poly = self.area + shift
            return np.vstack([poly, 0.5 * (poly + np.roll(poly, -1, 0)), xy_pred[None]])
        ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        return np.vstack([xy_pred[None], xy_pred + self.sigma * np.stack([np.cos(ang), np.sin(ang)], 1)])


class TargetUpdater:
    """The per-frame logic for targets, configured once from the estimator's Config."""

    def __init__(self, cfg, Ps: dict[str, np.ndarray], flow_sigma: dict[str, float] | None = None, window_sigma_px: float = 0.0,
                 centroid_sigma_px: float | None = None):
        self.cfg = cfg
        self.margin_px = cfg.window_margin_px + 3.0 * window_sigma_px  # target-area allowance for window noise
        self.Ps = Ps
        self.centroid_sigma_px = window_sigma_px if centroid_sigma_px is None else centroid_sigma_px
        self.focal = {c: _focal(P) for c, P in Ps.items()}
        self.flow_sigma = flow_sigma or {}
        self.min_angle = np.radians(cfg.min_plane_angle_deg)
        self.image_width: dict[str, float] = {}  # image widths (px): a window edge there is cut by the border

    def search_sigma(self, xy: np.ndarray, cams) -> float:
        """Search radius (m) after an estimate from ``cams``: ``sigma_planes`` plus three times
        the floor error that the calibrated centroid noise sigma_u (px, ``bearing_sigma_px``)
        causes across the line of sight, max over the cameras of sigma_u d_c / f_c (d_c depth of
        the target, f_c focal length)."""
        X = np.array([xy[0], xy[1], self.cfg.flow_height_fraction * self.cfg.height, 1.0])
        lateral = [self.centroid_sigma_px * float(self.Ps[c][2] @ X) / self.focal[c] for c in cams if c in self.Ps]
        return self.cfg.sigma_planes + 3.0 * max(lateral, default=0.0)

    # --- prediction -------------------------------------------------------------------------
    def views(self, tgt: Target, xy_pred: np.ndarray) -> dict[str, CameraView]:
        cfg = self.cfg
        pts = tgt.sample_points(xy_pred)
        X = np.array([xy_pred[0], xy_pred[1], cfg.flow_height_fraction * cfg.height])
        out = {}
        for name, P in self.Ps.items():
            wp = geo.cylinder_window(P, xy_pred, cfg.height, cfg.radius)
            wa = geo.cylinder_window(P, pts, cfg.height, cfg.radius)
            if not np.isfinite(wp).all() or not np.isfinite(wa).all():
                continue  # behind the camera
            J = geo.flow_jacobian(P, X)
            vp = J @ tgt.vel if tgt.vel_known else None
            out[name] = CameraView(wp, geo.union_window(wa), vp, float(np.linalg.norm(J[:, :2], 2)) * tgt.sigma_v)
        return out

    def flow_tol(self, c: str, v: np.ndarray) -> float:
        """|v - v'| allowed between similar image velocities (px/s): a fixed part, a part
        proportional to |v|, and three sigma of the (averaged) flow noise of the difference."""
        return self.cfg.flow_tol_px + self.cfg.flow_tol_rel * float(np.linalg.norm(v)) + 3.0 * np.sqrt(2.0) * self.flow_sigma.get(c, 0.0)

    def flow_ok(self, c: str, view: CameraView, flow: np.ndarray) -> np.ndarray:
        """Section 3.4.2: flows (k, 2) similar to the predicted image velocity."""
        if view.v_pred is None:
            return np.ones(len(flow), bool)
        return np.linalg.norm(flow - view.v_pred, axis=1) <= self.flow_tol(c, view.v_pred) + view.v_slack

    def similar_flow(self, c: str, f0: np.ndarray, flows: np.ndarray) -> np.ndarray:
        return np.linalg.norm(flows - f0, axis=1) <= self.flow_tol(c, f0)

    def overlapping(self, c: str, boxes: CameraBoxes, j: int, exclude=()) -> bool:
        """Section 4.1: another mover with a similar image velocity overlaps window j."""
        if len(boxes) < 2:
            return False
        gap = self.cfg.overlap_gap * max(boxes.width[j], 1.0)
        lo, hi = boxes.win[j, 0] - gap, boxes.win[j, 1] + gap
        others = np.ones(len(boxes), bool)
        others[j] = False
        for k in exclude:
            others[k] = False
        hit = others & (boxes.win[:, 1] >= lo) & (boxes.win[:, 0] <= hi)
        hit &= (boxes.win[:, 3] >= boxes.win[j, 2]) & (boxes.win[:, 2] <= boxes.win[j, 3])
        return bool((hit & self.similar_flow(c, boxes.flow[j], boxes.flow)).any())

    def merged(self, cam: CameraState, boxes: CameraBoxes, j: int, dt: float, w_c: float) -> bool:
        """Beginning of an overlap by merging: a mover that was beside the target last frame has
        vanished, its predicted window now falls on the target's window, and that window is wider
        than one person (eq. 8 above ``rejoin_width_ratio``; a neighbour that merely went out of
        sight or stopped leaves the target's window as it was)."""
        if width_ratio(boxes.width[j], w_c) <= self.cfg.rejoin_width_ratio:
            return False
        for tr, (ul, ur, fu) in cam.near.items():
            if (boxes.track == tr).any():
                continue
            ul2, ur2 = ul + fu * dt, ur + fu * dt
            if ur2 >= boxes.win[j, 0] and ul2 <= boxes.win[j, 1]:
                return True
        return False

    def remember_neighbours(self, cam: CameraState, boxes: CameraBoxes, j: int) -> None:
        """Section 4.1: track other movers in the search areas beside the target window."""
        w = max(boxes.width[j], 1.0)
        lo, hi = boxes.win[j, 0] - self.cfg.neighbour_span * w, boxes.win[j, 1] + self.cfg.neighbour_span * w
        near = {}
        for k in range(len(boxes)):
            if k != j and boxes.win[k, 1] >= lo and boxes.win[k, 0] <= hi and np.linalg.norm(boxes.flow[k]) > self.cfg.mover_flow_px:
                near[boxes.track[k]] = (boxes.win[k, 0], boxes.win[k, 1], boxes.flow[k, 0])
        cam.near = near
        cam.others.update(near)

    def check_reliable(self, c: str, cam: CameraState, view: CameraView, boxes: CameraBoxes, j: int, dt: float) -> str:
        """Reason the window j a camera is tracking is unreliable, or "" (section 4)."""
        cfg = self.cfg
        if self.overlapping(c, boxes, j) or self.merged(cam, boxes, j, dt, view.w_c):
            return "overlap"  # 4.1
        if width_ratio(boxes.width[j], view.w_c) > cfg.width_ratio_threshold:
            return "width"  # eq. 8
        if abs(boxes.u[j] - view.u_c) > cfg.position_tol * view.w_c + self._area_slack(view):
            return "position"  # 4.3
        if not self.flow_ok(c, view, boxes.flow[j : j + 1])[0]:
            return "velocity"
        return ""

    def _area_slack(self, view: CameraView) -> float:
        """Extra horizontal tolerance (px) when the prediction is an area, not a point."""
        return 0.5 * max((view.win_area[1] - view.win_area[0]) - (view.win_point[1] - view.win_point[0]), 0.0)

    def search_costs(self, c: str, view: CameraView, boxes: CameraBoxes, claimed: set[int], others: set = frozenset()) -> np.ndarray:
        """Cost of each box as the target in a lost/unreliable camera; inf where gated out.

        Gates: centroid inside the estimated (area) window widened by ``search_margin`` widths,
        vertical overlap with it, flow similar to v_pred (3.4.2), width ratio (eq. 8) under the
        threshold, and separate from every other mover with a similar flow (4.2/4.3).
        Windows whose track ids ``others`` were seen beside the target (another person tracked
        for section 4.1) are never the target. Cost: |u - u_c| / w_c.
        """
        cfg = self.cfg
        cost = np.full(len(boxes), np.inf)
        if not len(boxes):
            return cost
        m = cfg.search_margin * view.w_c
        wa = view.win_area
        inside = (boxes.u >= wa[0] - m) & (boxes.u <= wa[1] + m)
        inside &= (boxes.win[:, 3] >= wa[2]) & (boxes.win[:, 2] <= wa[3])
        ok = inside & self.flow_ok(c, view, boxes.flow)
        ok &= width_ratio(boxes.width, view.w_c) <= cfg.width_ratio_threshold
        for j in np.flatnonzero(ok):
            if j in claimed or boxes.track[j] in others or self.overlapping(c, boxes, j):
                continue
            cost[j] = abs(boxes.u[j] - view.u_c) / view.w_c
        return cost

    def split_window(self, view: CameraView, partner: CameraView, win: np.ndarray, image_width: float | None) -> np.ndarray | None:
        """The target's part of a window that holds it and a tracked neighbour merged (beyond the
        paper: two people side by side with the same image velocity make one flow region).

        The target is predicted at u_c (estimated window width w_c), the neighbour at u_c'. When
        both centres lie inside the merged window [u_l, u_r] (widened by half a width) and they
        are apart in the image (|u_c - u_c'| >= ``split_min_sep`` min(w_c, w_c')), and the merged
        window is as wide as the union of their two estimated windows (within
        ``rejoin_width_ratio`` min(w_c, w_c'): it holds these two, not a third or a ghost), the merged
        window's outer edge on the target's side is the target's own edge (the person on that
        side bounds the region there), so the target's window is [u_l, u_l + w_c] if u_c < u_c',
        else [u_r - w_c, u_r]; its rows are the estimated window's (clipped to the merged
        window's; those belong to whichever of the two is nearer the camera). Returns None where the target's edge
        is cut by the image border, the two are in line (one behind the other), or a centre lies
        outside the window."""
        cfg = self.cfg
        ul, ur = float(win[0]), float(win[1])
        w, wp = view.w_c, partner.w_c
        if ur - ul <= w:
            return None
        for u, ww in ((view.u_c, w), (partner.u_c, wp)):
            if not (ul - 0.5 * ww <= u <= ur + 0.5 * ww):
                return None
        d = view.u_c - partner.u_c
        if abs(d) < cfg.split_min_sep * min(w, wp):
            return None
        union = max(view.win_point[1], partner.win_point[1]) - min(view.win_point[0], partner.win_point[0])
        if abs((ur - ul) - union) > cfg.rejoin_width_ratio * min(w, wp):
            return None  # not the two of them: the window's width is not their estimated windows' union
        # rows: the merged window's top and bottom are those of whichever of the two is nearer
        # the camera; the target's own come from the prediction, inside the merged window's
        vt = float(np.clip(view.win_point[2], win[2], win[3]))
        vb = float(np.clip(view.win_point[3], vt, win[3]))
        if d < 0:
            if ul <= 0.5:
                return None
            return np.array([ul, ul + w, vt, vb])
        if image_width is not None and ur >= image_width - 0.5:
            return None
        return np.array([ur - w, ur, vt, vb])

    # --- estimation ---------------------------------------------------------------------------
    def estimate(self, tgt: Target, xy_pred: np.ndarray, used: dict[str, int], frame: dict[str, CameraBoxes], unreliable_areas: list[str]):
        """Position from the tracking cameras (sections 3.1-3.2 and the area intersection of 5).

        Returns (xy, area polygon or None, mode, cameras dropped as inconsistent).
        """
        cfg = self.cfg
        dropped: list[str] = []
        areas = {c: geo.target_area(self.Ps[c], frame[c].box(j), cfg.height, cfg.radius, margin=cfg.area_margin, margin_px=self.margin_px) for c, j in used.items()}
        while len(used) >= 2:
            try:
                xy, out = self._solve(used, frame, areas, xy_pred)
            except geo.IllConditioned:
                break
            if not out:
                return xy, None, "planes", dropped
            # position test failed: leave out the camera without which the rest agree best
            # (with two cameras, the one whose window strays farther from the prediction)
            names = list(used)
            if len(names) >= 3:
                def score(c):
                    rest = {k: v for k, v in used.items() if k != c}
                    try:
                        _, bad = self._solve(rest, frame, areas, xy_pred)
                    except geo.IllConditioned:
                        return (1, 0.0)
                    return (len(bad), self._stray(c, frame[c], used[c], xy_pred) * -1)
                worst = min(names, key=score)
            else:
                worst = max(names, key=lambda c: self._stray(c, frame[c], used[c], xy_pred))
            dropped.append(worst)
            used.pop(worst)
        if not used:
            return xy_pred.copy(), None, "predicted", dropped
        # one camera, or near-parallel planes: single-camera target areas (section 3.2), and
        # their intersection with every other tracking camera's area (section 5)
        polys = [areas[c].polygon for c in used]
        best = min(used, key=lambda c: areas[c].s_max - areas[c].s_min)
        if cfg.intersect_areas:
            polys += [geo.target_area(self.Ps[c], frame[c].box(j), cfg.height, cfg.radius, margin=cfg.area_margin, margin_px=self.margin_px).polygon for c, j in unreliable_areas]
            inter = geo.intersect_areas(polys) if len(polys) > 1 else polys[0]
            if inter is None:
                inter = areas[best].polygon
        else:
            inter = areas[best].polygon
        xy = self._point_in_area(areas[best], inter, xy_pred, cfg.consistency_margin)
        return xy, inter, "area", dropped

    def _solve(self, used, frame, areas, xy_pred):
        """Eq. 6 over the cameras in ``used``; returns the position and the cameras whose own
        target area (depth and width ranges) it falls outside."""
        names = list(used)
        ab = [geo.target_plane(self.Ps[c], frame[c].u[used[c]], self._centroid_row(c, xy_pred)) for c in names]
        xy, _ = geo.intersect_planes(np.array([a for a, _ in ab]), np.array([b for _, b in ab]), self.min_angle)
        return xy, [c for c in names if not areas[c].contains(xy, self.cfg.consistency_margin)]

    def _centroid_row(self, c: str, xy_pred: np.ndarray) -> float:
        """Image row of the region's centroid, at the predicted position and ``flow_height_fraction``
        of the height: a pitched camera images vertical lines tilted, so the target plane of
        column u depends (slightly) on the row (eq. 4)."""
        X = np.array([xy_pred[0], xy_pred[1], self.cfg.flow_height_fraction * self.cfg.height])
        return float(geo.project(self.Ps[c], X)[0][1])

    def area_of(self, c: str, boxes: CameraBoxes, j: int) -> geo.TargetArea:
        """Single-camera target area (section 3.2) of window j of camera c."""
        return geo.target_area(self.Ps[c], boxes.box(j), self.cfg.height, self.cfg.radius, margin=self.cfg.area_margin, margin_px=self.margin_px)

    def search_radius(self, tgt: Target) -> float:
        """How far (m) from the prediction the target may be: the search radius, plus (at most
        ``area_gate_max``) the extent of the target area when the last estimate was a
        single-camera area."""
        r = tgt.sigma
        if tgt.area is not None:
            r += min(float(np.max(np.linalg.norm(tgt.area - tgt.xy, axis=1))), self.cfg.area_gate_max)
        return r

    def agree(self, used: dict[str, int], frame: dict[str, CameraBoxes], xy_pred: np.ndarray, gate: float) -> bool:
        """The cameras' target planes cross (eq. 6, well conditioned) inside every camera's target
        area and within ``gate`` metres of the prediction; for near-parallel planes, their
        target areas overlap within ``gate`` of the prediction."""
        areas = {c: self.area_of(c, frame[c], j) for c, j in used.items()}
        try:
            xy, out = self._solve(used, frame, areas, xy_pred)
        except geo.IllConditioned:
            # near-parallel planes (cameras in line with the target): their target areas must
            # overlap (section 5), and the overlap come within the gate of the prediction
            inter = geo.intersect_areas([a.polygon for a in areas.values()])
            if inter is None:
                return False
            d = cv2.pointPolygonTest(inter.astype(np.float32).reshape(-1, 1, 2), (float(xy_pred[0]), float(xy_pred[1])), True)
            return d >= -gate
        return not out and float(np.linalg.norm(xy - xy_pred)) <= gate

    def stray(self, c: str, boxes: CameraBoxes, j: int, xy_pred: np.ndarray) -> float:
        return self._stray(c, boxes, j, xy_pred)

    def _stray(self, c: str, boxes: CameraBoxes, j: int, xy_pred: np.ndarray) -> float:
        w = geo.cylinder_window(self.Ps[c], xy_pred, self.cfg.height, self.cfg.radius)
        return abs(boxes.u[j] - 0.5 * (w[0] + w[1])) / max(w[1] - w[0], 1.0)

    @staticmethod
    def _point_in_area(area: geo.TargetArea, poly: np.ndarray, xy_pred: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """The point of the target plane inside ``poly`` (or within ``tol`` metres of it: a narrow
        window's area is a sliver the centroid ray can graze) nearest the prediction in depth."""
        s = np.linspace(area.s_min, area.s_max, 64)
        pts = area.origin + s[:, None] * area.direction
        p32 = poly.astype(np.float32).reshape(-1, 1, 2)
        dist = np.array([cv2.pointPolygonTest(p32, (float(x), float(y)), True) for x, y in pts])
        inside = dist >= -tol
        if inside.any():
            pts = pts[inside]
        s_pred = (xy_pred - area.origin) @ area.direction
        s_in = (pts - area.origin) @ area.direction
        return pts[int(np.argmin(np.abs(s_in - s_pred)))]

    def velocity(self, tgt: Target, xy: np.ndarray, used: dict[str, int], frame: dict[str, CameraBoxes]) -> None:
        """Eq. 7 by least squares over the tracking cameras' mean flows (W = 0 with one camera)."""
        if not used:
            return
        X = np.array([xy[0], xy[1], self.cfg.flow_height_fraction * self.cfg.height])
        names = list(used)
        sig = [np.hypot(self.flow_sigma.get(c, 0.0), self.cfg.flow_model_sigma) for c in names]
        prior = tgt.vel if tgt.vel_known else None
        V = geo.velocity_from_flows([self.Ps[c] for c in names], [X] * len(names), [frame[c].flow[used[c]] for c in names], sig, prior, self.cfg.velocity_prior_sigma)
        speed = np.linalg.norm(V[:2])
        if speed > self.cfg.max_speed:
            V = V * (self.cfg.max_speed / speed)
        a = self.cfg.velocity_smoothing if tgt.vel_known else 1.0
        tgt.vel = a * V + (1 - a) * tgt.vel
        tgt.vel[2] = 0.0
        tgt.vel_known = True
