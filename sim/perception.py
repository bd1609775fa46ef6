"""Perception: from rendered pixels to detections, one detector per camera kind.

Shared pieces (all images are (H, W, 3) uint8 RGB, pixel centres at (i + 0.5, j + 0.5)):

- Foreground by difference against the empty-scene render B (exact here: nothing but people moves
  and rendering is deterministic): F = max_c |I_c - B_c| > ``diff_threshold``.
- Blobs: 8-connected components of F (``cv2.connectedComponentsWithStats``) after a small
  morphological closing; fragments are merged (horizontal cameras: overlapping column spans, since
  a person is a vertical object and an obstacle may cut the silhouette in two; overhead cameras:
  the closing itself).
- Appearance: a pixel's chromaticity c = rgb / (r + g + b) is compared with the chromaticity of
  each walker colour the deployment knows (the paper's appearance vectors); shading scales
  r, g, b alike and leaves c unchanged. Pixels with low saturation (max - min < ``min_chroma``
  of the brightest channel) carry no colour vote. A blob in which several colours each hold a
  large share is split by colour: two people merged into one blob become two detections.

Detectors:

- ``detect_bearings`` (horizontal cameras, Rahimi): per person blob the horizontal centroid
  u = mean(i) + 1/2 (pixels), width = u_right - u_left, label = colour name.
- ``OverheadDetector`` (Teixeira): regular mode maps each person blob to the floor through the
  camera model using the top of the person (see ``floor_from_blob``); privacy mode reports only
  the person blobs that moved themselves since the previous frame (frame differences
  |I_k - I_{k-1}| > threshold on the blob's own pixels; ``sim/perception_privacy.py``), so a
  person standing still gives nothing, and quantises x, y to the camera's ``quantum``. Only
  detections inside the camera's ``region`` are reported.
- The oblique optical-flow tracker is in ``sim/perception_flow.py``.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from trackroom.scenes.camera import Camera


@dataclass(frozen=True)
class Appearance:
    """The walker colours a deployment knows: names and RGB in [0, 1] (scene order)."""

    names: tuple[str, ...]
    rgb: np.ndarray  # (C, 3)

    @staticmethod
    def from_scene(scene) -> "Appearance":
        names, cols = [], []
        for w in scene.walkers:
            if w.color_name not in names:
                names.append(w.color_name)
                cols.append(w.color)
        return Appearance(tuple(names), np.asarray(cols, float).reshape(-1, 3))

    @property
    def chroma(self) -> np.ndarray:
        return self.rgb / np.maximum(self.rgb.sum(axis=1, keepdims=True), 1e-9)


@dataclass(frozen=True)
class PerceptionParams:
    """Detector thresholds. Areas are in pixels at 320x240 and scale with the image area."""

    diff_threshold: int = 12  # grey levels, background difference
    motion_threshold: int = 6  # grey levels, frame difference (privacy cameras)
    min_area: float = 60.0  # smallest person blob
    # privacy: fewest own-motion pixels (frame k-1 -> k) of a person who is reported; a walker at
    # 0.2-0.3 m/s shows >= 5 such pixels in 95% of frames, someone standing still < 3 (10 clips of 8 s)
    min_motion_px: float = 3.0
    min_chroma: float = 0.25  # saturation below which a pixel has no colour vote
    split_share: float = 0.2  # a second colour must hold this share of a blob to split it
    max_chroma_dist: float = 0.15  # a pixel further than this from every walker colour has no vote
    merge_gap_px: float = 2.0  # horizontal cameras: merge blobs whose column spans are this close
    border_px: float = 1.0  # a silhouette end this close to the image edge is taken as clipped

    def area(self, a: float, width: int, height: int) -> float:
        return a * (width * height) / (320 * 240)


def foreground(rgb: np.ndarray, background: np.ndarray, threshold: int) -> np.ndarray:
    """Boolean mask max_c |I_c - B_c| > threshold."""
    d = cv2.absdiff(rgb, background)
    return np.maximum(np.maximum(d[..., 0], d[..., 1]), d[..., 2]) > threshold  # 25x faster than .max(axis=2)


def components(mask: np.ndarray, close_px: int = 3):
    """Closed 8-connected components: (labels image, stats rows [x, y, w, h, area])."""
    m = mask.astype(np.uint8)
    if close_px > 1:
        k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (close_px, close_px))
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, k)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    return labels, stats[1:], n - 1


def colour_votes(pixels_rgb: np.ndarray, app: Appearance, params: PerceptionParams) -> np.ndarray:
    """Nearest walker colour index per pixel (N,), -1 where the pixel has no colour vote.

    A vote depends on the pixel's colour only, so it is computed once per distinct colour (a
    person blob repeats each shade ~4 times) and spread back: the same votes, ~40 % faster."""
    px = np.asarray(pixels_rgb).reshape(-1, 3)
    if px.dtype != np.uint8 or len(px) < 64:
        return _colour_votes(px, app, params)
    packed = (px[:, 0].astype(np.int32) << 16) | (px[:, 1].astype(np.int32) << 8) | px[:, 2]
    _, first, inverse = np.unique(packed, return_index=True, return_inverse=True)
    return _colour_votes(px[first], app, params)[inverse]


def _colour_votes(pixels_rgb: np.ndarray, app: Appearance, params: PerceptionParams) -> np.ndarray:
    p = pixels_rgb.astype(np.float32)
    hi, lo = p.max(axis=1), p.min(axis=1)
    c = p / np.maximum(p.sum(axis=1, keepdims=True), 1.0)
    d = np.linalg.norm(c[:, None, :] - app.chroma[None, :, :].astype(np.float32), axis=2)
    best = d.argmin(axis=1)
    ok = ((hi - lo) >= params.min_chroma * np.maximum(hi, 1.0)) & (d[np.arange(len(p)), best] < params.max_chroma_dist)
    return np.where(ok, best, -1)


def split_by_colour(votes: np.ndarray, app: Appearance, params: PerceptionParams, min_area: float):
    """Groups of a blob's pixels, one per colour with a large share: list of (label, index array).

    With one colour (or none) the whole blob is one group labelled by its majority vote.
    """
    counts = np.bincount(votes[votes >= 0], minlength=len(app.names))
    total = max(int(counts.sum()), 1)
    strong = [c for c in np.flatnonzero(counts) if counts[c] >= max(params.split_share * total, min_area)]
    if len(strong) <= 1:
        label = app.names[int(counts.argmax())] if counts.sum() else ""
        return [(label, np.arange(len(votes)))]
    return [(app.names[c], np.flatnonzero(votes == c)) for c in strong]


@dataclass
class PersonBlob:
    """One person hypothesis in an image: colour index (-1: none) and its pixel rows and columns."""

    colour: int
    ys: np.ndarray
    xs: np.ndarray


def largest_part(ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Indices of the pixels of the largest 8-connected part (after a 3 px closing) of a pixel set."""
    y0, x0 = ys.min(), xs.min()
    m = np.zeros((ys.max() - y0 + 1, xs.max() - x0 + 1), np.uint8)
    m[ys - y0, xs - x0] = 1
    m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)))
    n, lab, st, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n <= 2:
        return np.arange(len(ys))
    return np.flatnonzero(lab[ys - y0, xs - x0] == 1 + int(np.argmax(st[1:, 4])))


def person_blobs(rgb: np.ndarray, background: np.ndarray, app: Appearance, params: PerceptionParams,
                 coherent: bool = False, votes: np.ndarray | None = None) -> list[PersonBlob]:
    """Person blobs of an overhead image: closed foreground components of at least ``min_area``,
    split by colour (``split_by_colour``). ``coherent``: when a blob is split, each colour keeps
    only its largest connected part. ``votes``: an (H, W) integer image that receives every blob
    pixel's colour vote (``colour_votes``); other pixels are left as they are."""
    H, W = rgb.shape[:2]
    labels, stats, n = components(foreground(rgb, background, params.diff_threshold))
    min_area = params.area(params.min_area, W, H)
    out = []
    for k in range(n):
        if stats[k, 4] < min_area:
            continue
        x0, y0, w, h = (int(a) for a in stats[k, :4])  # search the component's box only
        ys, xs = np.nonzero(labels[y0:y0 + h, x0:x0 + w] == k + 1)
        ys += y0
        xs += x0
        v = colour_votes(rgb[ys, xs], app, params)
        if votes is not None:
            votes[ys, xs] = v
        groups = split_by_colour(v, app, params, min_area)
        for label, idx in groups:
            if coherent and len(groups) > 1:
                idx = idx[largest_part(ys[idx], xs[idx])]
            out.append(PersonBlob(app.names.index(label) if label else -1, ys[idx], xs[idx]))
    return out


# ----------------------------------------------------------------------------- horizontal cameras
@dataclass
class BearingDetection:
    u: float
    width: float
    label: str
    pixels: int
    v_top: float
    v_bottom: float


def detect_bearings(rgb: np.ndarray, background: np.ndarray, app: Appearance,
                    params: PerceptionParams = PerceptionParams()) -> list[BearingDetection]:
    """Person blobs of a horizontal camera image: u = mean column + 1/2, width, colour label."""
    H, W = rgb.shape[:2]
    fg = foreground(rgb, background, params.diff_threshold)
    labels, stats, n = components(fg)
    if n == 0:
        return []
    # merge fragments whose column spans overlap (or nearly): union-find on sorted spans
    left = stats[:, 0].astype(float)
    right = left + stats[:, 2]
    order = np.argsort(left)
    group = np.empty(n, int)
    g, reach = -1, -np.inf
    for i in order:
        if left[i] > reach + params.merge_gap_px:
            g += 1
            reach = right[i]
        else:
            reach = max(reach, right[i])
        group[i] = g
    min_area = params.area(params.min_area, W, H)
    lut = np.concatenate([[-1], group])
    grp = lut[labels]
    ys, xs = np.nonzero((grp >= 0) & fg)
    gid = grp[ys, xs]
    out: list[BearingDetection] = []
    for k in range(g + 1):
        sel = gid == k
        if sel.sum() < min_area:
            continue
        bx, by = xs[sel], ys[sel]
        votes = colour_votes(rgb[by, bx], app, params)
        for label, idx in split_by_colour(votes, app, params, min_area):
            if len(idx) < min_area:
                continue
            x, y = bx[idx], by[idx]
            out.append(BearingDetection(u=float(x.mean() + 0.5), width=float(x.max() - x.min() + 1), label=label,
                                        pixels=int(len(idx)), v_top=float(y.min()), v_bottom=float(y.max() + 1)))
    out.sort(key=lambda d: d.u)
    return out


# ----------------------------------------------------------------------------- overhead cameras
@dataclass(frozen=True)
class PersonModel:
    """The nominal person a deployment assumes: a vertical body whose top is a sphere of radius
    ``top_radius`` centred at ``top_centre`` m above the floor, and whose bottom is a sphere of
    radius ``bottom_radius`` centred ``bottom_centre`` m above the floor."""

    top_centre: float = 1.55
    top_radius: float = 0.2
    bottom_centre: float = 0.2
    bottom_radius: float = 0.2


def floor_from_blob(cam: Camera, xs: np.ndarray, ys: np.ndarray, person: PersonModel, border_px: float = 1.0):
    """Floor (x, y) of a person from its silhouette pixels in a downward-looking camera.

    A vertical person projects to a radial streak pointing away from the vertical vanishing
    point n (a wide lens sees the head far from the body centre). The silhouette's outermost
    point along the radial direction e is the ray tangent to the top sphere (centre height z_t,
    radius rho): it meets the plane z = z_t at Q, at horizontal distance rho / cos(theta) beyond
    the sphere centre, theta the ray's angle from the vertical. So
        C_xy = Q_xy - e_floor rho / cos(theta).
    When the outer end is cut by the image border, the innermost point (tangent to the bottom
    sphere, on the near side) is used the same way with the sign reversed. Returns (x, y) or None.
    """
    H, W = cam.height, cam.width
    uv = np.column_stack([xs + 0.5, ys + 0.5]).astype(float)
    n = cam.vertical_vanishing_point()
    centroid = uv.mean(axis=0)
    if n is None:
        p = cam.backproject_to_plane(centroid, 0.5 * (person.top_centre + person.bottom_centre))
        return None if not np.isfinite(p).all() else (float(p[0]), float(p[1]))
    radial = centroid - n
    dist = float(np.hypot(*radial))
    if dist < 1.0:  # right under the camera: head and feet project together
        p = cam.backproject_to_plane(centroid, person.top_centre)
        return None if not np.isfinite(p).all() else (float(p[0]), float(p[1]))
    e = radial / dist
    s = (uv - n) @ e
    tang = (uv - n) @ np.array([-e[1], e[0]])
    at_border = (xs <= border_px) | (ys <= border_px) | (xs >= W - 1 - border_px) | (ys >= H - 1 - border_px)
    band = max(2.0, 0.03 * (s.max() - s.min()))
    outer = s >= s.max() - band
    inner = s <= s.min() + band
    if not at_border[outer].any():
        sel, z, rho, sign = outer, person.top_centre, person.top_radius, -1.0
        s_end = s.max()
    elif not at_border[inner].any():
        sel, z, rho, sign = inner, person.bottom_centre, person.bottom_radius, +1.0
        s_end = s.min()
    else:
        p = cam.backproject_to_plane(centroid, 0.5 * (person.top_centre + person.bottom_centre))
        return None if not np.isfinite(p).all() else (float(p[0]), float(p[1]))
    px = n + e * s_end + np.array([-e[1], e[0]]) * float(tang[sel].mean())
    q = cam.backproject_to_plane(px, z)
    if not np.isfinite(q).all():
        return None
    horiz = q[:2] - np.asarray(cam.position, float)[:2]
    hd = float(np.hypot(*horiz))
    if hd < 1e-6:
        return float(q[0]), float(q[1])
    cos_theta = (cam.position[2] - z) / np.hypot(hd, cam.position[2] - z)
    c = q[:2] + sign * (horiz / hd) * rho / max(cos_theta, 0.2)
    return float(c[0]), float(c[1])


class OverheadDetector:
    """Floor detections of one overhead camera.

    Regular mode: every person blob (``person_blobs``) mapped to the floor (``floor_from_blob``).
    Privacy mode (``cam.privacy``): only the blobs that moved since the previous frame
    (``sim.perception_privacy.MotionGate``), with positions quantised to ``cam.quantum``.
    Detections are kept when the (unquantised) position lies in the camera's ``region``.
    """

    def __init__(self, cam: Camera, background: np.ndarray, app: Appearance, person: PersonModel,
                 params: PerceptionParams = PerceptionParams()):
        self.cam, self.background, self.app, self.person, self.params = cam, background, app, person, params
        self.gate = None
        if cam.privacy:
            from trackroom.sim.perception_privacy import MotionGate  # imports this module: imported late

            self.gate = MotionGate(cam, background, app, params)

    def __call__(self, rgb: np.ndarray) -> list[tuple[float, float]]:
        cam, p = self.cam, self.params
        if self.gate is None:
            blobs = person_blobs(rgb, self.background, self.app, p)
        else:
            votes = np.full(rgb.shape[:2], -1, np.int16)  # filled by person_blobs, kept by the gate
            blobs = person_blobs(rgb, self.background, self.app, p, coherent=True, votes=votes)
            blobs = self.gate(rgb, votes, blobs)
        out = []
        for b in blobs:
            xy = floor_from_blob(cam, b.xs, b.ys, self.person, p.border_px)
            if xy is None or not cam.in_region(xy[:2]):
                continue
            if self.gate is not None and cam.quantum > 0:
                xy = (cam.quantum * round(xy[0] / cam.quantum), cam.quantum * round(xy[1] / cam.quantum))
            out.append(xy)
        return out
