"""Oblique cameras (Tsutsui et al. sec. 2): tracking windows from dense optical flow.

Flow: OpenCV Farneback between consecutive grey frames, computed on an image downscaled by
``scale`` (flow cost grows with the pixel count; FACTS.md: 3-4.5 ms at 160x120, 15-21 ms at
320x240) and expressed back in full-resolution pixels per frame, f(u, v).

Moving pixels: |f| > ``min_flow`` px/frame, restricted to pixels near an actual image change
(|I_k - I_{k-1}| > ``change_threshold``, dilated by the flow window), because Farneback's
polynomial windows spread flow a few pixels into the still background around a mover.

Per camera, a tracker follows the paper's four steps for every tracking window W_{k-1}:
  1. prediction window = W_{k-1} shifted by the previous mean flow m_{k-1} (and widened by a
     margin, the "neighbourhood");
  2. m_k = mean flow of the moving pixels inside it;
  3. object region = moving pixels there whose flow is similar to m_k:
     |f - m_k| <= max(``flow_tol_px``, ``flow_tol_rel`` |m_k|);
  4. W_k = the rectangle circumscribing the object region (u_left, u_right, v_top, v_bottom).
A window whose region has fewer than ``min_pixels`` pixels is lost (its id is never reused).
Moving pixels claimed by no window are grouped into connected regions of near-uniform flow
(components split around their median flow), and each large enough region starts a new window.
Each window reports its region's centroid u and its mean flow in pixels per second
(m_k times the frame rate).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np


@dataclass(frozen=True)
class FlowParams:
    scale: float = 0.5  # flow computed at this fraction of the resolution
    min_flow: float = 0.3  # px/frame (full resolution)
    change_threshold: int = 6  # grey levels
    flow_tol_px: float = 1.0  # px/frame
    flow_tol_rel: float = 1.0
    margin_frac: float = 0.25  # prediction window margin, fraction of its size
    margin_px: float = 4.0
    min_pixels: float = 60.0  # at 320x240, full-resolution pixels; scales with the image area
    join_px: int = 12  # full-resolution pixels: moving fragments this close form one region


@dataclass
class Window:
    track: int
    box: np.ndarray  # u_left, v_top, u_right, v_bottom (full-resolution pixels)
    flow: np.ndarray  # mean flow, px/frame
    u: float = 0.0
    age: int = 0


@dataclass
class FlowTracker:
    """Per-camera optical-flow tracker; call it with consecutive RGB frames."""

    width: int
    height: int
    params: FlowParams = field(default_factory=FlowParams)
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
        min_px = p.min_pixels * (self.width * self.height) / (320 * 240) * s * s  # in small pixels
        claimed = np.zeros_like(moving)
        kept: list[Window] = []
        for w in self.windows:
            region = self._follow(w, flow, moving & ~claimed, s, small_size)
            if region is None or len(region[0]) < min_px:
                continue
            ys, xs = region
            claimed[ys, xs] = True
            kept.append(self._update(w, flow, xs, ys, s))
        # drop a window that has come to cover the same person as an older one
        kept = _suppress_duplicates(kept)
        for xs, ys in _new_regions(flow, moving & ~claimed, p, min_px):
            w = Window(track=self._next_id, box=np.zeros(4), flow=np.zeros(2))
            self._next_id += 1
            kept.append(self._update(w, flow, xs, ys, s))
        self.windows = kept
        return list(kept)

    def _follow(self, w: Window, flow, moving, s, size):
        p = self.params
        box = (w.box + np.r_[w.flow, w.flow]) * s  # 1. prediction window, in small pixels
        mu, mv = p.margin_frac * (box[2] - box[0]) + p.margin_px * s, p.margin_frac * (box[3] - box[1]) + p.margin_px * s
        x0, y0 = int(max(0, np.floor(box[0] - mu))), int(max(0, np.floor(box[1] - mv)))
        x1, y1 = int(min(size[0], np.ceil(box[2] + mu))), int(min(size[1], np.ceil(box[3] + mv)))
        if x1 <= x0 or y1 <= y0:
            return None
        ys, xs = np.nonzero(moving[y0:y1, x0:x1])
        if len(xs) == 0:
            return None
        ys, xs = ys + y0, xs + x0
        f = flow[ys, xs]
        m = f.mean(axis=0)  # 2. mean flow in the prediction window
        tol = max(p.flow_tol_px, p.flow_tol_rel * float(np.hypot(*m)))
        keep = np.hypot(*(f - m).T) <= tol  # 3. pixels with similar flow
        return ys[keep], xs[keep]

    def _update(self, w: Window, flow, xs, ys, s) -> Window:
        w.box = np.array([xs.min() / s, ys.min() / s, (xs.max() + 1) / s, (ys.max() + 1) / s])  # 4.
        w.flow = flow[ys, xs].mean(axis=0)
        w.u = float((xs.mean() + 0.5) / s)
        w.age += 1
        return w


def _suppress_duplicates(windows: list[Window]) -> list[Window]:
    out: list[Window] = []
    for w in sorted(windows, key=lambda w: w.track):
        if all(_overlap(w.box, o.box) < 0.3 for o in out):
            out.append(w)
    return out


def _overlap(a, b) -> float:
    """Intersection area over the smaller box's area."""
    iw = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    ih = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    small = min((a[2] - a[0]) * (a[3] - a[1]), (b[2] - b[0]) * (b[3] - b[1]))
    return iw * ih / small if small > 0 else 0.0


def _new_regions(flow, moving, p: FlowParams, min_px: float):
    """Connected moving regions of near-uniform flow: yields (xs, ys) in small pixels."""
    k = max(3, int(round(p.join_px * p.scale)) | 1)
    joined = cv2.morphologyEx(moving.astype(np.uint8), cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(joined, connectivity=8)
    for k in range(1, n):
        if stats[k, 4] < min_px:
            continue
        ys, xs = np.nonzero((labels == k) & moving)
        for _ in range(3):  # peel off near-uniform groups around the median flow
            if len(xs) < min_px:
                break
            f = flow[ys, xs]
            med = np.median(f, axis=0)
            tol = max(p.flow_tol_px, p.flow_tol_rel * float(np.hypot(*med)))
            near = np.hypot(*(f - med).T) <= tol
            if near.sum() >= min_px:
                yield xs[near], ys[near]
            xs, ys = xs[~near], ys[~near]
