"""Oblique cameras (Tsutsui et al. sec. 2): tracking windows from dense optical flow.

Flow: OpenCV Farneback between consecutive grey frames, computed on an image downscaled by
``scale`` (flow cost grows with the pixel count; FACTS.md: 3-4.5 ms at 160x120, 15-21 ms at
320x240) and expressed back in full-resolution pixels per frame, f(u, v).

Moving pixels: |f| > ``min_flow`` px/frame, restricted to pixels near an actual image change
(|I_k - I_{k-1}| > ``change_threshold``, dilated by 2 px), because Farneback's polynomial
windows spread flow a few pixels into the still background around a mover.

Regions, one per person (the paper: "an object region has almost uniform flow vectors"):

1. fragments: connected components of the moving pixels (after a closing of ``close_px``),
   each split into groups of near-uniform flow around its median flow m:
   |f - m| <= tol(m) = max(``flow_tol_px``, ``flow_tol_rel`` |m|);
2. person prior: a person is a vertical cylinder of height H = ``person_height`` and radius
   r = ``person_radius``. With the camera's calibration, a region whose top row v_t is the
   head lies on the ray through (u, v_t) at Z = H; the cylinder projected there gives the
   person's expected window (w_e, h_e). (If the top is not the head the ray meets Z = H nearer
   the camera and the expected window is larger: the prior errs on the side of merging.)
3. fragments are merged, largest first, while they are one person: horizontal flows alike,
   |m_i,u - m_j,u| <= tol = ``merge_tol_px`` + ``merge_tol_rel`` max(|m_i|, |m_j|), vertical
   flows within tol + ``merge_loom`` h_e (a person walking towards the camera grows) unless one
   box lies inside the other (the vertical flow along a uniformly coloured person's vertical
   edges is ill-posed: the aperture problem), and the silhouette their union stands for
   (``current_box``: motion and flow spread removed) fits one person, width <= ``size_slack`` w_e
   + ``size_pad_px`` and height <= ``size_slack`` h_e + ``size_pad_px``. A person whose window
   broke into a head, edges and legs, or into parts above and below an occluding desk, becomes
   one region; two people walking side by side do not fit one person's width and stay apart;
4. regions holding less than ``min_person_fraction`` of the expected person's pixel area
   (and fewer than ``min_pixels``) are dropped: flow noise, a hand-sized flicker; so are
   windows on the image border narrower or shorter than ``min_side_px`` (a person all but out
   of the image).
   Without a calibrated camera, steps 2-4 fall back to merging overlapping fragments of
   similar flow and the fixed ``min_pixels``.

Tracking windows keep their ids across frames (the paper's steps 1-4, with the region search
done once per frame for all windows): each window's prediction is its previous box shifted by
its previous flow (step 1); regions are assigned to predictions by
``scipy.optimize.linear_sum_assignment`` on cost 1 - IoU(prediction, region box), gated by IoU
>= ``iou_min`` and similar flow (steps 2-3); the window becomes the rectangle circumscribing
the assigned region, moved to the current frame (step 4, ``_update``). A window without a region coasts (unreported) for
``max_missed`` frames along its flow, so a one-frame dropout keeps the id; a region no window
claims starts a new id (ids are never reused).

Each window reports its box and its centroid u, both in the current frame (``current_box``;
u is the box centre by default, ``centre_of_box``: against the projected body axis it scatters
less than the mean column of the region's pixels, 3.4 px against 5.3 px robust sigma on rendered
``occlusion_lab``), and its region's flow m in pixels per frame (the caller multiplies by the
frame rate).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment

from trackroom.scenes.camera import Camera

from .perception_model import RENDERED_WINDOW_NOISE  # noqa: F401  (re-exported)


# This detector's measured window noise, ``RENDERED_WINDOW_NOISE``, is defined in ``sim.perception_model``
# (with the other measured noise figures; importing this module costs OpenCV and scipy.optimize,
# which every analytic recording's calibration would otherwise pay for one dict).


@dataclass(frozen=True)
class FlowParams:
    scale: float = 0.5  # flow computed at this fraction of the resolution
    min_flow: float = 0.3  # px/frame (full resolution)
    change_threshold: int = 6  # grey levels
    flow_tol_px: float = 1.0  # px/frame
    flow_tol_rel: float = 0.5
    close_px: int = 4  # full-resolution pixels: closing that joins a fragment's pieces
    min_pixels: float = 60.0  # at 320x240, full-resolution pixels; scales with the image area
    person_height: float = 1.75  # m, the person prior (vertical cylinder)
    person_radius: float = 0.2  # m
    merge_tol_px: float = 1.0  # px/frame: fragments of one person may differ in flow by this,
    merge_tol_rel: float = 0.5  # plus this fraction of the larger flow,
    merge_loom: float = 0.05  # plus (vertical flow only) this fraction of the person's image height (a person walking towards the camera grows)
    size_slack: float = 1.5  # a merged silhouette may be this much larger than the expected person window,
    size_pad_px: float = 4.0  # plus this (full-res px)
    min_person_fraction: float = 0.12  # regions smaller than this share of a person's area are dropped
    iou_min: float = 0.1  # association gate: IoU of predicted window and region box
    max_missed: int = 2  # frames a window coasts without a region before its id ends
    min_side_px: float = 3.0  # a window on the image border narrower or shorter than this (full-res px: a person leaving the image) is dropped
    spread_px: float = 4.0  # full-res px the moving region extends beyond the silhouette (see ``current_box``)
    centre_of_box: bool = True  # report u as the centre of the window (measured on rendered occlusion_lab: 3.4 px robust spread against the body axis, the region centroid 5.3 px)


@dataclass
class Window:
    track: int
    box: np.ndarray  # u_left, v_top, u_right, v_bottom (full-resolution pixels)
    flow: np.ndarray  # mean flow, px/frame
    u: float = 0.0
    age: int = 0
    missed: int = 0


@dataclass
class Region:
    xs: np.ndarray  # small-image pixel columns
    ys: np.ndarray
    flow: np.ndarray  # median flow, full-resolution px/frame
    box: np.ndarray  # full-resolution u_left, v_top, u_right, v_bottom


@dataclass
class FlowTracker:
    """Per-camera optical-flow tracker; call it with consecutive RGB frames.

    ``camera`` (a calibrated ``scenes.camera.Camera``) enables the person-size prior."""

    width: int
    height: int
    params: FlowParams = field(default_factory=FlowParams)
    camera: Camera | None = None  # calibrated camera for the person-size prior (None: no prior)
    windows: list[Window] = field(default_factory=list)
    _prev: np.ndarray | None = None
    _next_id: int = 0

    def __call__(self, rgb: np.ndarray) -> list[Window]:
        p = self.params
        gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        prev, self._prev = self._prev, gray
        if prev is None:
            return []
        s = p.scale
        small_size = (max(8, int(round(self.width * s))), max(8, int(round(self.height * s))))
        a = cv2.resize(prev, small_size, interpolation=cv2.INTER_AREA)
        b = cv2.resize(gray, small_size, interpolation=cv2.INTER_AREA)
        flow = cv2.calcOpticalFlowFarneback(a, b, None, 0.5, 3, 9, 3, 5, 1.1, 0) / s  # full-res px/frame
        changed = cv2.absdiff(a, b) > p.change_threshold
        near_change = cv2.dilate(changed.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
        moving = (np.hypot(flow[..., 0], flow[..., 1]) > p.min_flow) & near_change
        regions = person_regions(flow, moving, p, self.camera, (self.width, self.height))
        self.windows = self._associate(regions, flow, s)
        return [w for w in self.windows if w.missed == 0]

    def _associate(self, regions: list[Region], flow, s) -> list[Window]:
        p = self.params
        prev = self.windows
        matched: dict[int, int] = {}
        if prev and regions:
            pred = np.array([w.box + np.r_[w.flow, w.flow] for w in prev])
            boxes = np.array([r.box for r in regions])
            iou = box_iou(pred, boxes)
            fp = np.array([w.flow for w in prev])
            fr = np.array([r.flow for r in regions])
            tol = np.maximum(p.flow_tol_px, p.flow_tol_rel * np.hypot(*fp.T))[:, None] + np.maximum(
                p.flow_tol_px, p.flow_tol_rel * np.hypot(*fr.T))[None, :]
            ok = (iou >= p.iou_min) & (np.linalg.norm(fp[:, None] - fr[None], axis=2) <= tol)
            if ok.any():
                rows, cols = linear_sum_assignment(np.where(ok, 1.0 - iou, 10.0))
                matched = {int(j): int(i) for i, j in zip(rows, cols) if ok[i, j]}
        out: list[Window] = []
        taken = set(matched.values())
        for j, r in enumerate(regions):
            if j in matched:
                w = prev[matched[j]]
            else:
                w = Window(track=self._next_id, box=np.zeros(4), flow=np.zeros(2))
                self._next_id += 1
            out.append(_update(w, flow, r, s, p.spread_px, p.centre_of_box, (self.width, self.height)))
        for i, w in enumerate(prev):
            if i not in taken and w.missed < p.max_missed:
                w.missed += 1
                w.box = w.box + np.r_[w.flow, w.flow]
                out.append(w)
        return out


def _update(w: Window, flow, r: Region, s: float, spread: float = 0.0, centre_of_box: bool = False, size=None) -> Window:
    """Step 4. Farneback's flow f(x) lives on the previous frame (I_{k-1}(x) ~ I_k(x + f(x))),
    so the region is where the person *was*; the window and centroid are moved by the region's
    flow m to the current frame. m is the per-axis median over the region (the paper's mean
    flow, made robust: along the long vertical edges of a uniformly coloured person the vertical
    flow is ill-posed - the aperture problem - and a few pixels carry wild values; measured on
    rendered occlusion_lab the median halves the robust spread of the horizontal flow error)."""
    m = np.median(flow[r.ys, r.xs], axis=0)
    w.flow = m
    w.box = current_box(r.box, m, spread, size)
    w.u = float((r.xs.mean() + 0.5) / s + m[0]) if not centre_of_box else 0.5 * (w.box[0] + w.box[2])
    w.age += 1
    w.missed = 0
    return w


def current_box(box: np.ndarray, m: np.ndarray, spread: float, size: tuple[int, int] | None = None) -> np.ndarray:
    """The person's window in frame k from the moving region's box (frame k-1 coordinates).

    For a silhouette spanning [a, b] in frame k-1 and moving by m (> 0), the changed pixels
    cover [a, a + m] and [b, b + m], grown by ``spread`` d (the near-change dilation and the
    flow's smoothing): the region spans [a - d, b + m + d]. The current silhouette [a + m, b + m]
    is therefore [l + d + max(m, 0), r - d + min(m, 0)]; the same holds for rows with m_v.
    An edge on the image border (``size`` = width, height) stays there: the image clips the
    person, not the motion.
    """
    lo = box[:2] + spread + np.maximum(m, 0.0)
    hi = box[2:] - spread + np.minimum(m, 0.0)
    if size is not None:
        lim = np.asarray(size, float)
        lo = np.clip(np.where(box[:2] <= 1.0, box[:2], lo), 0.0, lim)
        hi = np.clip(np.where(box[2:] >= lim - 1.0, box[2:], hi), 0.0, lim)
    mid = 0.5 * (lo + hi)
    lo, hi = np.minimum(lo, mid - 0.5), np.maximum(hi, mid + 0.5)  # at least one pixel, never inverted
    if size is not None:  # ... and inside the image
        lim = np.asarray(size, float)
        shift = np.clip(lo, 0.0, None) - lo + np.clip(hi, None, lim) - hi
        lo, hi = lo + shift, hi + shift
    return np.r_[lo, hi]


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU (n, m) of boxes a (n, 4) and b (m, 4) given as [u_left, v_top, u_right, v_bottom]."""
    iw = np.clip(np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0]), 0, None)
    ih = np.clip(np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1]), 0, None)
    inter = iw * ih
    area = lambda x: (x[:, 2] - x[:, 0]) * (x[:, 3] - x[:, 1])  # noqa: E731
    union = area(a)[:, None] + area(b)[None, :] - inter
    return np.where(union > 0, inter / np.maximum(union, 1e-9), 0.0)


def expected_person_window(camera, u: float, v_top: float, height: float, radius: float) -> np.ndarray | None:
    """The window [u_left, v_top, u_right, v_bottom] (px) of the person cylinder whose head
    (Z = ``height``) is seen at pixel (u, v_top); None where that ray does not reach Z = height
    in front of the camera."""
    X = camera.backproject_to_plane(np.array([u, v_top], float), height)
    if not np.isfinite(X).all():
        return None
    ang = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.column_stack([X[0] + radius * np.cos(ang), X[1] + radius * np.sin(ang)])
    pts = np.vstack([np.column_stack([ring, np.zeros(12)]), np.column_stack([ring, np.full(12, height)])])
    uv, depth = camera.project(pts)
    if (depth <= 1e-3).any():
        return None
    return np.array([uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max()])


def _fragments(flow, moving, p: FlowParams, min_px: float) -> list[Region]:
    """Connected moving regions split into groups of near-uniform flow."""
    s = p.scale
    k = max(1, int(round(p.close_px * s))) | 1
    joined = cv2.morphologyEx(moving.astype(np.uint8), cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(joined, connectivity=8)
    out = []
    for c in range(1, n):
        if stats[c, 4] < min_px:
            continue
        x0, y0, w, h = stats[c, :4]
        sub = (labels[y0 : y0 + h, x0 : x0 + w] == c) & moving[y0 : y0 + h, x0 : x0 + w]
        ys, xs = np.nonzero(sub)
        ys, xs = ys + y0, xs + x0
        for _ in range(3):  # peel off near-uniform groups around the median flow
            if len(xs) < min_px:
                break
            f = flow[ys, xs]
            med = np.median(f, axis=0)
            tol = max(p.flow_tol_px, p.flow_tol_rel * float(np.hypot(*med)))
            near = np.hypot(*(f - med).T) <= tol
            if near.sum() >= min_px:
                out.append(_region(xs[near], ys[near], med, s))
            xs, ys = xs[~near], ys[~near]
    return out


def _region(xs, ys, med, s) -> Region:
    return Region(xs, ys, np.asarray(med, float), np.array([xs.min() / s, ys.min() / s, (xs.max() + 1) / s, (ys.max() + 1) / s]))


def person_regions(flow, moving, p: FlowParams, camera, size: tuple[int, int]) -> list[Region]:
    """One region per person: fragments merged under the person prior (module docstring)."""
    s = p.scale
    min_px_full = p.min_pixels * (size[0] * size[1]) / (320 * 240)
    frags = _fragments(flow, moving, p, max(2.0, 0.25 * min_px_full * s * s))
    frags.sort(key=lambda r: -len(r.xs))
    merged = True
    while merged and len(frags) > 1:
        merged = False
        for i in range(len(frags)):
            for j in range(i + 1, len(frags)):
                a, b = frags[i], frags[j]
                box = np.r_[np.minimum(a.box[:2], b.box[:2]), np.maximum(a.box[2:], b.box[2:])]
                if not _fits_person(box, a, b, p, camera):
                    continue
                xs, ys = np.r_[a.xs, b.xs], np.r_[a.ys, b.ys]
                m = (len(a.xs) * a.flow + len(b.xs) * b.flow) / (len(xs))
                frags[i] = Region(xs, ys, m, box)
                del frags[j]
                merged = True
                break
            if merged:
                break
    out = []
    for r in frags:
        need = min_px_full
        if camera is not None:
            e = expected_person_window(camera, 0.5 * (r.box[0] + r.box[2]), r.box[1], p.person_height, p.person_radius)
            if e is not None:
                need = min(need, p.min_person_fraction * (e[2] - e[0]) * (e[3] - e[1]) * np.pi / 4)
        cur = current_box(r.box, r.flow, p.spread_px, size)
        at_border = cur[0] <= 0.0 or cur[1] <= 0.0 or cur[2] >= size[0] or cur[3] >= size[1]
        sliver = at_border and min(cur[2] - cur[0], cur[3] - cur[1]) < p.min_side_px
        if len(r.xs) / (s * s) >= need and not sliver:
            out.append(r)
    return out


def _fits_person(box, a: Region, b: Region, p: FlowParams, camera) -> bool:
    """Fragments a, b are one person: similar flow (per axis, |m_a - m_b| <= merge_tol_px +
    merge_tol_rel max(|m_a|, |m_b|), plus merge_loom h_e vertically; the horizontal part only
    when one box lies inside the other) and their union box fits the expected person window
    (with the calibration), or they overlap (without it)."""
    d = np.abs(a.flow - b.flow)
    tol = p.merge_tol_px + p.merge_tol_rel * max(float(np.hypot(*a.flow)), float(np.hypot(*b.flow)))
    if camera is None:
        return bool((d <= tol).all()) and (box_iou(a.box[None], b.box[None])[0, 0] > 0 or _gap(a.box, b.box) <= p.close_px)
    e = expected_person_window(camera, 0.5 * (box[0] + box[2]), box[1], p.person_height, p.person_radius)
    if e is None:
        return False
    h_e = e[3] - e[1]
    if d[0] > tol:
        return False
    if _contained(a.box, b.box) >= 0.7:
        return True  # one lies inside the other: the same region (the vertical flow along a vertical edge is ill-posed, the aperture problem)
    if d[1] > tol + p.merge_loom * h_e:
        return False
    m = np.maximum(np.abs(a.flow), np.abs(b.flow))
    cur = current_box(box, m, p.spread_px)  # the silhouette the union stands for (motion and flow spread removed)
    return (cur[2] - cur[0]) <= p.size_slack * (e[2] - e[0]) + p.size_pad_px and (cur[3] - cur[1]) <= p.size_slack * h_e + p.size_pad_px


def _contained(a, b) -> float:
    """Intersection area over the smaller box's area."""
    iw = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    ih = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    small = min((a[2] - a[0]) * (a[3] - a[1]), (b[2] - b[0]) * (b[3] - b[1]))
    return iw * ih / small if small > 0 else 0.0


def _gap(a, b) -> float:
    return max(0.0, max(a[0], b[0]) - min(a[2], b[2]), max(a[1], b[1]) - min(a[3], b[3]))
