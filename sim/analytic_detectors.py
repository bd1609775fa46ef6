"""Analytic detectors: a fitted perception model (``sim.perception_model``) applied to analytic
geometry (``sim.analytic``), one camera at a time.

Per camera frame: the people in the field of view are detected with P(detect | features) (misses
correlated from frame to frame), detected people whose images overlap (floor positions lie close,
overhead) merge into one detection with P(merge | overlap), each detection gets its measurement
error from the fitted error quantiles, labels are confused with the scene's other appearance
classes, false detections are added; oblique windows carry the camera tracker's ids (continued,
restarted, merged, swapped at a split). The tables keep the detectors' columns only.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.special import ndtri

from trackroom.scenes.camera import Camera

from .perception_model import EDGE_CORR_KINDS, NEAR_GAP, TAIL_M, DetectorModel, EdgeCorr, correlated_normals, correlated_uniforms, ndtr, run_events, two_timescale_normals


WHOLE = 0.999  # a person seen whole: this share of the rays reaching them and of their image width inside the image


def detected(rng: np.random.Generator, cand: np.ndarray, p: np.ndarray, m: DetectorModel,
             whole: np.ndarray | None = None) -> np.ndarray:
    """(F, P) bool: candidates kept unless missed; misses come in runs (``run_events`` with
    ``m.miss_stay``: a held uniform below 1 - P(detect); with ``m.miss_stay_whole`` and ``whole``
    (F, P), the people seen whole take that stay instead; models without a stay: missed where
    the AR(1) copula's uniform, correlation ``m.rho``, falls above P(detect))."""
    if not cand.any():
        return cand.copy()
    if m.miss_stay is not None and m.miss_stay_whole is not None and whole is not None:
        missed = run_events(rng, 1.0 - p, m.miss_stay, cand & ~whole) | run_events(rng, 1.0 - p, m.miss_stay_whole, cand & whole)
        return cand & ~missed
    if m.miss_stay is not None:
        return cand & ~run_events(rng, 1.0 - p, m.miss_stay, cand)
    return cand & (correlated_uniforms(rng, cand.shape, m.rho) < p)


def error_uniforms(rng: np.random.Generator, shape: tuple[int, int], m: DetectorModel, count: int) -> list[np.ndarray]:
    """``count`` (F, P) grids of uniforms for measurement errors, each person's column correlated
    from frame to frame with ``err_rho``."""
    return [correlated_uniforms(rng, shape, m.err_rho) for _ in range(count)]


def merge_roots(rng: np.random.Generator, det: np.ndarray, feature: np.ndarray, eligible: np.ndarray,
                m: DetectorModel) -> np.ndarray:
    """(F, P) index of the detection each person is reported in: p itself, or the lowest index of
    the group of overlapping detected people it merged with. ``feature`` and ``eligible`` are
    (F, pairs) over ``np.triu_indices(P, 1)``; pair merges chain into groups."""
    F, P = det.shape
    root = np.broadcast_to(np.arange(P), (F, P)).copy()
    if P < 2 or not eligible.any():
        return root
    iu, ju = np.triu_indices(P, 1)
    merge = eligible & det[:, iu] & det[:, ju]
    if m.merge_stay is not None:  # a held uniform per pair: merges last while the pair stays as close
        p = np.zeros(merge.shape)
        p[merge] = m.merge(feature[merge])
        merge = run_events(rng, p, m.merge_stay, merge)
    else:
        z = correlated_normals(rng, eligible.shape, m.merge_rho)  # drawn whole: the random stream as before
        # the copula's uniforms (correlated_uniforms: ndtr of z) and the table only where they decide
        merge[merge] = ndtr(z[merge]) < m.merge(feature[merge])
    # each group's root is its lowest index (merging two groups keeps the lower root), so a
    # minimum passed along the merged pairs until nothing changes gives every frame's groups at once
    f, k = np.nonzero(merge)
    i, j = iu[k], ju[k]
    while len(f):
        low = np.minimum(root[f, i], root[f, j])
        if (low == root[f, i]).all() and (low == root[f, j]).all():
            break
        np.minimum.at(root, (f, i), low)
        np.minimum.at(root, (f, j), low)
    return root


def span_pairs(lo: np.ndarray, hi: np.ndarray):
    """Overlap of two intervals / the narrower one, over all pairs: (F, pairs), and > 0 flags."""
    P = lo.shape[1]
    iu, ju = np.triu_indices(P, 1)
    inter = np.minimum(hi[:, iu], hi[:, ju]) - np.maximum(lo[:, iu], lo[:, ju])
    width = np.maximum(np.minimum(hi[:, iu] - lo[:, iu], hi[:, ju] - lo[:, ju]), 1e-9)
    o = inter / width
    return o, o > 0


def _groups(root: np.ndarray, det: np.ndarray):
    """(frame, root person) of each reported detection: one per group of merged people."""
    f, p = np.nonzero(det & (root == np.arange(root.shape[1])))
    return f, p


def visible_span(g, width: float):
    """Clipped image span [a, b] of each person and the share of the span inside the image."""
    a = np.clip(g.span[..., 0], 0, width)
    b = np.clip(g.span[..., 1], 0, width)
    with np.errstate(invalid="ignore"):  # -inf - -inf: someone wholly behind the camera
        full = np.maximum(np.nan_to_num(g.span[..., 1] - g.span[..., 0], nan=0.0), 1e-9)
    return a, b, np.clip((b - a) / full, 0, 1)


# The candidates of each detector: who could be reported at a camera frame. The sampler below and
# the fit (``sim.perception_fit``) use these same definitions, so rates fitted per candidate are
# applied to the same people.
def blob_candidates(g, width: float):
    """(a, b, clip, cand) of a bearing camera: spans, clip share, and people partly in the image."""
    a, b, clip = visible_span(g, width)
    return a, b, clip, g.near & (clip > 0)


# windows: a person moving at least this fast in the image (px/s) can be in a flow region: merged
# into another's window (a flow tracker gives someone standing still no window, merged or not:
# their pixels inside a walker's window are not a merge), or, missed, in a partial window
MOVING_PX_S = 6.0


def seen_share(frac: np.ndarray, frames: int) -> np.ndarray:
    """The seen share of rays (F, P) as a flow tracker sees it: the mean over the last ``frames``
    frames (fewer at the start). A flow region outlives a ray grazing an obstacle's edge for a
    frame; 1: the frame's own share (models before it)."""
    if frames <= 1:
        return frac
    c = np.cumsum(np.asarray(frac, float), axis=0)
    out = c.copy()
    out[frames:] -= c[:-frames]
    return out / np.minimum(np.arange(1, len(c) + 1), frames)[:, None]


def window_candidates(g, width: float):
    """(clip, image speed px/s, cand) of an oblique camera's windows: people partly in the image
    with a window of some size."""
    e = g.edges
    _, _, clip = visible_span(g, width)
    speed = np.hypot(g.flow[..., 0], g.flow[..., 1])
    return clip, speed, g.near & (clip > 0) & (e[..., 1] > e[..., 0]) & (e[..., 3] > e[..., 2])


def floor_state(cam: Camera, g, traj):
    """(xy (F, P, 2), floor speed (F, P), axis clip (F, P)) of every person at an overhead
    camera's frames; the clip is the share of the person's image axis (feet to the top of the
    head) inside the image: a ceiling camera cuts the heads of people near its image's border
    (its tile's far corners), and the rendered detector then misses many more of them."""
    xy = traj.pos[:, g.steps, :2].transpose(1, 0, 2)
    speed = np.hypot(traj.vel[:, g.steps, 0], traj.vel[:, g.steps, 1]).T
    return xy, speed, segment_clip(g.axis[..., 0, :], g.axis[..., 1, :], cam.width, cam.height)


def segment_clip(p0: np.ndarray, p1: np.ndarray, width: float, height: float) -> np.ndarray:
    """Share (...,) of the image segments p0-p1 (..., 2) inside [0, width] x [0, height]
    (Liang-Barsky: the segment's parameter interval inside each of the four half-planes)."""
    d = p1 - p0
    lo, hi = np.zeros(d.shape[:-1]), np.ones(d.shape[:-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, size in ((0, width), (1, height)):
            for pk, qk in ((-d[..., k], p0[..., k]), (d[..., k], size - p0[..., k])):
                r = qk / pk
                lo = np.where(pk < 0, np.maximum(lo, r), lo)
                hi = np.where(pk > 0, np.minimum(hi, r), hi)
                hi = np.where((pk == 0) & (qk < 0), -1.0, hi)  # parallel to this edge and outside it
    return np.nan_to_num(np.clip(hi - lo, 0.0, 1.0))


def segment_distance(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> np.ndarray:
    """Shortest distance between 2D segments a0-a1 and b0-b1 (arrays (..., 2)); 0 where they cross."""
    def point_to_segment(p, s0, s1):
        d = s1 - s0
        L2 = np.maximum((d * d).sum(-1), 1e-12)
        h = np.clip(((p - s0) * d).sum(-1) / L2, 0.0, 1.0)
        return np.linalg.norm(p - (s0 + h[..., None] * d), axis=-1)

    def side(p, s0, s1):
        return np.sign((s1[..., 0] - s0[..., 0]) * (p[..., 1] - s0[..., 1]) - (s1[..., 1] - s0[..., 1]) * (p[..., 0] - s0[..., 0]))

    cross = (side(a0, b0, b1) * side(a1, b0, b1) < 0) & (side(b0, a0, a1) * side(b1, a0, a1) < 0)
    d = np.minimum(np.minimum(point_to_segment(a0, b0, b1), point_to_segment(a1, b0, b1)),
                   np.minimum(point_to_segment(b0, a0, a1), point_to_segment(b1, a0, a1)))
    return np.where(cross, 0.0, d)


def silhouette_pairs(g, reach: float = np.inf, pairs: np.ndarray | None = None) -> np.ndarray:
    """(F, pairs) over ``np.triu_indices(P, 1)``: how far apart two people's silhouettes lie in an
    overhead camera's image, as the distance between their image axes (feet to the top of the
    head) in units of their mean projected body width. A ceiling camera sees a person as a blob
    stretched away from the point below it, so two people one behind the other (seen from the
    camera) merge at a larger floor distance than two side by side; below about 1 the blobs touch.
    Pairs whose axes' bounding boxes lie ``reach`` widths apart or more get inf without the exact
    distance (which is at least that). ``pairs``: an (F, pairs) mask of the entries wanted (the
    others are inf; each entry is computed on its own, so the wanted ones do not change)."""
    F, P = g.axis.shape[:2]
    iu, ju = np.triu_indices(P, 1)
    lo, hi = g.axis.min(axis=2), g.axis.max(axis=2)  # (F, P, 2) bounding box of each axis
    if pairs is None:  # every entry: whole-array slices
        width = np.maximum(0.5 * (g.width_px[:, iu] + g.width_px[:, ju]), 1e-9)
        box_gap = np.maximum(np.maximum(lo[:, iu] - hi[:, ju], lo[:, ju] - hi[:, iu]), 0.0)  # (F, pairs, 2)
        f, k = np.nonzero(np.hypot(box_gap[..., 0], box_gap[..., 1]) < reach * width)
        width = width[f, k]
    else:  # the wanted entries only, by the same arithmetic
        f, k = np.nonzero(pairs)
        i, j = iu[k], ju[k]
        width = np.maximum(0.5 * (g.width_px[f, i] + g.width_px[f, j]), 1e-9)
        box_gap = np.maximum(np.maximum(lo[f, i] - hi[f, j], lo[f, j] - hi[f, i]), 0.0)  # (n, 2)
        near = np.hypot(box_gap[:, 0], box_gap[:, 1]) < reach * width
        f, k, width = f[near], k[near], width[near]
    out = np.full((F, len(iu)), np.inf)
    if len(f):
        a, b = g.axis[f, iu[k]], g.axis[f, ju[k]]
        out[f, k] = segment_distance(a[:, 0], a[:, 1], b[:, 0], b[:, 1]) / width
    return np.nan_to_num(out, nan=np.inf, posinf=np.inf)


def blobs(cam: Camera, g, frac: np.ndarray, t: np.ndarray, m: DetectorModel, rng: np.random.Generator,
          colours: list[str], palette: list[str]) -> pd.DataFrame | None:
    """``bearings`` rows (t, camera, u, label) of a horizontal or oblique camera."""
    a, b, clip, cand = blob_candidates(g, cam.width)
    whole = (frac >= WHOLE) & (clip >= WHOLE)
    det = detected(rng, cand, m.detect(frac, clip), m, whole=whole)
    o, ok = span_pairs(a, b)
    root = merge_roots(rng, det, o, ok, m)
    F, P = det.shape
    lo, hi = a.copy(), b.copy()
    # whose colour names each group's blob: the rendered detector labels a merged blob by its
    # pixels' majority colour (``perception.split_by_colour``), so the member who fills most of
    # it (projected width times the share of its rays that reach it: the one in front) names it,
    # whatever the people's order in the scene; a person alone names its own
    named = np.broadcast_to(np.arange(P), (F, P)).copy()
    seen_px = frac * (b - a)
    size = np.zeros((F, P), int)  # how many people each root's blob holds
    for r in range(P):  # a merged detection spans its members
        member = det & (root == r)
        size[:, r] = member.sum(axis=1)
        grp = member.any(axis=1)
        if grp.any():
            lo[grp, r] = np.where(member[grp], a[grp], np.inf).min(axis=1)
            hi[grp, r] = np.where(member[grp], b[grp], -np.inf).max(axis=1)
            named[grp, r] = np.argmax(np.where(member[grp], seen_px[grp], -np.inf), axis=1)
    f, p = _groups(root, det)
    clipped = clip[f, p] < 0.999
    (uu,) = error_uniforms(rng, det.shape, m, 1)
    err = np.where(clipped, m.error("u_clip").at(uu[f, p]), m.error("u").at(uu[f, p]))
    u = 0.5 * (lo[f, p] + hi[f, p]) + err
    if "u_whole" in m.errors:  # someone seen whole, alone in the blob: about the projected body centre
        sole = whole[f, p] & (size[f, p] == 1)
        u = np.where(sole, g.uv[f, p, 0] + m.error("u_whole").at(uu[f, p]), u)
    colour_idx = np.array([palette.index(c) for c in colours], int)
    lab_idx = _confuse(rng, colour_idx[named[f, p]], m.label, len(palette))
    # fragments: extra blobs on detected people
    fd, pd_ = np.nonzero(det)
    kf = rng.poisson(m.fragment, len(fd)) if m.fragment > 0 else np.zeros(len(fd), int)
    fd, pd_ = np.repeat(fd, kf), np.repeat(pd_, kf)
    u_frag = 0.5 * (a[fd, pd_] + b[fd, pd_]) + m.error("frag_du").sample(rng, len(fd)) * (b[fd, pd_] - a[fd, pd_])
    frag_lab = np.where(rng.random(len(fd)) < m.fragment_label, colour_idx[pd_], len(palette))
    # false detections
    k = rng.poisson(m.clutter, len(g.steps)) if m.clutter > 0 else np.zeros(len(g.steps), int)
    fc = np.repeat(np.arange(len(g.steps)), k)
    u = np.concatenate([u, u_frag, rng.uniform(0, cam.width, len(fc))])
    clutter_lab = np.where(rng.random(len(fc)) < m.clutter_unlabelled, len(palette), rng.integers(0, len(palette), len(fc)))
    lab_idx = np.concatenate([lab_idx, frag_lab, clutter_lab])
    f = np.concatenate([f, fd, fc])
    keep = (u >= 0) & (u < cam.width)
    if not keep.any():
        return None
    from .analytic import str_column

    return pd.DataFrame({"t": t[f[keep]], "camera": cam.name, "u": u[keep], "label": str_column([*palette, ""], lab_idx[keep])})


def _confuse(rng, idx: np.ndarray, accuracy: float, n_classes: int) -> np.ndarray:
    """Labels kept with probability ``accuracy``, else another class drawn uniformly."""
    if n_classes < 2 or accuracy >= 1 or len(idx) == 0:
        return idx
    wrong = rng.random(len(idx)) >= accuracy
    shift = rng.integers(1, n_classes, len(idx))
    return np.where(wrong, (idx + shift) % n_classes, idx)


# windows: the flow detector's error grows with the image speed and falls short along the motion
# (rendered occlusion_lab development seeds 100-119, ``scripts/measure_flow_errors.py``: median
# -1.5 px/s and robust sd 2-3 px/s below 40 px/s; -5 to -7 and 7-10 px/s at 40-80; -20 and 27 px/s
# above 80; their largest errors are shortfalls). A model with ``flow_along_s<k>`` /
# ``flow_across_s<k>`` tables draws a window's flow error along and across its people's image
# velocity from the tables of its speed bin k (edges below, px/s); a model without them draws
# ``flow_u`` / ``flow_v`` in image axes.
FLOW_SPEED_EDGES = (40.0, 80.0)


def flow_frame(flow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(speed bin (n,), unit direction (n, 2)) of image velocities ``flow`` (n, 2), px/s; the
    direction of a velocity under 1 px/s is the image's u axis."""
    speed = np.hypot(flow[:, 0], flow[:, 1])
    d = np.where((speed >= 1.0)[:, None], flow / np.maximum(speed, 1e-9)[:, None], np.array([1.0, 0.0]))
    return np.searchsorted(FLOW_SPEED_EDGES, speed, side="right"), d


def has_flow_frame(m) -> bool:
    return "flow_along_s0" in m.errors


# the kinds of window whose flow errors a model fitted with ``flow_by_kind`` (the sixteenth fit)
# draws from tables of their own (``flow_kind``): rendered development 110-114, own windows under
# 40 px/s, the horizontal flow's robust sigma against the person's image velocity is 1.8 px/s for
# plain windows inside the image, 4.3 crowded, 1.5 cut by a box; the flow of the border-cut ones
# follows their person at a gain of 0.7-0.8 (100-159; lower where the window stops short of the
# border, ``perception_model.Border``): one pooled table gave every window the mixture
FLOW_KINDS = ("", "_crowded", "_cut", "_border")


def flow_kind(tag: str, at_border: bool) -> str:
    """A window's kind for its flow errors: ``"_border"`` where the image border cuts a member,
    else its ``edge_tables`` tag ``tag``."""
    return "_border" if at_border else tag


def has_flow_kinds(m) -> bool:
    """Whether a model draws its windows' flow errors by kind of window (``flow_along_s<k>_crowded``
    and the other ``FLOW_KINDS`` tables besides the plain ones; the sixteenth fit)."""
    return "flow_along_s0_crowded" in m.errors


# windows: a window whose span comes within this many px of another moving person's image span
# (vertical spans overlapping), or whose people are not all wholly seen, is "crowded": its edge
# errors come from the ``*_crowded`` tables where a model has them (the rendered detector's large
# edge errors are mostly there: a neighbour's flow joins the region, an occluder cuts it; someone
# standing still beside a walker makes no flow and leaves the window alone)
CROWDED_PX = 10.0
# a window with a member the floor plan's boxes cut by more than this (px; about the rendered
# edges' spread, 3-5 px) is "cut": its edge errors come from the ``*_cut`` tables where a model
# has them (fitted on the rendered windows of people seen over a box: a short strip whose
# edges the box and the head fix, not the errors of a whole person's window)
CUT_PX = 5.0
# a model fitted with edge tables by the person's image height (``DetectorModel.edge_heights``;
# the thirteenth fit, not bundled) draws a window's edge errors from the tables of its height
# bin: the rendered edges' errors grow with the image (development 100-109, plain windows: the
# top edge's 95th percentile +7 px under 60 px of height, +20 px at 60-100, +36 px above), and
# one table for every size draws a near person's tail errors on a far one (docs/sensing.md)
EDGE_HEIGHT_PX = (60.0, 100.0)


def height_bin(height: np.ndarray | float, edges=EDGE_HEIGHT_PX) -> np.ndarray:
    """The height bin (0 .. len(edges)) of windows ``height`` px high; the bins' table names end
    in ``_h<bin>`` (``height_table``)."""
    return np.searchsorted(np.asarray(edges, float), height, side="right")


def height_table(name: str, k: int) -> str:
    return f"{name}_h{int(k)}"


def edge_tables(g, e: np.ndarray, frac: np.ndarray, moving: np.ndarray, f: int, members: list[int],
                cut: bool = True, crowd: bool = True) -> str:
    """Which edge-error tables a window of ``members`` at frame f takes: ``"_cut"`` (a member cut
    by a box, ``CUT_PX``), else ``"_crowded"`` (``crowded``), else ``""`` (the plain tables);
    ``cut`` / ``crowd`` False: a model without those tables (the fit measures into both)."""
    if cut and g.cut_px is not None and (g.cut_px[f, members] > CUT_PX).any():
        return "_cut"
    if crowd and crowded(e, frac, moving, f, members):
        return "_crowded"
    return ""


def edge_copula(u_top: np.ndarray, u_bottom: np.ndarray, corr: EdgeCorr, kind: np.ndarray, height: np.ndarray) -> np.ndarray:
    """The bottom edges' uniforms correlated with the top edges' ``u_top`` (one per window) by
    ``corr`` (``EdgeCorr``) for each window's kind (``kind``: its ``edge_tables`` tag, "" plain,
    "_crowded" or "_cut") and the person's image ``height`` (px): the Gaussian copula
    z' = r z_top + sqrt(1 - r^2) z_bottom keeps each edge's marginal and, the two being AR(1)
    with the same ``err_rho``, its frame-to-frame correlation. Windows with r = 0 (cut, or a
    kind or bin without one) keep ``u_bottom`` exactly."""
    r = np.zeros(len(u_top))
    hb = height_bin(height, corr.heights)
    for name, rho in corr.rho.items():
        on = kind == EDGE_CORR_KINDS[name]
        r[on] = np.asarray(rho, float)[hb[on]]
    out = np.asarray(u_bottom, float).copy()
    on = r != 0.0
    if on.any():
        z_top, z_bottom = (ndtri(np.clip(u[on], 1e-15, 1 - 1e-15)) for u in (u_top, u_bottom))
        out[on] = ndtr(r[on] * z_top + np.sqrt(1.0 - r[on] ** 2) * z_bottom)
    return out


def crowded(e: np.ndarray, frac: np.ndarray, moving: np.ndarray, f: int, members: list[int]) -> bool:
    """Whether the window of ``members`` at frame f is crowded (``CROWDED_PX``): ``e`` (F, P, 4)
    image edges, ``frac`` the seen share of rays, ``moving`` who is in the image and moves in it
    (at least ``MOVING_PX_S``)."""
    if (frac[f, members] < 5 / 6).any():
        return True
    lo, hi = e[f, members, 0].min(), e[f, members, 1].max()
    top, bottom = e[f, members, 2].min(), e[f, members, 3].max()
    others = np.setdiff1d(np.nonzero(moving[f])[0], members)
    if not len(others):
        return False
    o = e[f, others]
    return bool(((o[:, 0] <= hi + CROWDED_PX) & (o[:, 1] >= lo - CROWDED_PX) & (o[:, 2] <= bottom) & (o[:, 3] >= top)).any())


def windows(cam: Camera, g, frac: np.ndarray, t: np.ndarray, m: DetectorModel, rng: np.random.Generator,
            head: np.ndarray | None = None) -> pd.DataFrame | None:
    """``boxes`` rows (t, camera, track, u, edges, flow) of an oblique camera's flow tracker
    (``head``: (F, P) 1 where the ray to the top of the head reaches the person)."""
    e = g.edges
    _, speed, cand = window_candidates(g, cam.width)
    frac = seen_share(frac, m.seen_frames)
    head = None if head is None else seen_share(head, m.seen_frames)
    if m.detects_by_head:
        if head is None:
            raise ValueError("this model's windows are detected by the head ray too: give head")
        p_detect = m.detect(frac, head, speed)
    else:
        p_detect = m.detect(frac, speed)
    det = detected(rng, cand, p_detect, m)
    o, ok = span_pairs(e[..., 0], e[..., 1])
    vo, vok = span_pairs(e[..., 2], e[..., 3])
    root = merge_roots(rng, det, o, ok & vok, m)
    F, P = det.shape
    ids = WindowIds(P, m, rng)
    grids = error_uniforms(rng, det.shape, m, 6)
    if m.flow_persist is not None:  # the flows' errors persist on two time scales (drawn after: older models' stream as before)
        grids[4:6] = [ndtr(two_timescale_normals(rng, det.shape, *m.flow_persist)) for _ in range(2)]
    out_f, out_p, out_e, out_fl, out_id, out_c, out_cut, out_k, out_n = [], [], [], [], [], [], [], [], []
    has_cut, has_crowded = "u_left_cut" in m.errors, "u_left_crowded" in m.errors  # the model's edge tables (older fits: fewer)
    moving = cand & (speed >= MOVING_PX_S)
    flow_kinds = has_flow_kinds(m)
    for f in range(F):
        groups = {}
        for p in np.nonzero(det[f])[0]:
            groups.setdefault(int(root[f, p]), []).append(int(p))
        members = list(groups.values())
        tids = ids.step(f, members)
        for mem, tid in zip(members, tids):
            ee = e[f, mem]
            out_f.append(f)
            out_p.append(mem[0])
            out_e.append([ee[:, 0].min(), ee[:, 1].max(), ee[:, 2].min(), ee[:, 3].max()])
            out_fl.append(g.flow[f, mem].mean(axis=0))
            out_id.append(tid)
            out_c.append(edge_tables(g, e, frac, moving, f, mem, has_cut, has_crowded))
            if m.edge_corr is not None or flow_kinds:  # the kind of window its edges' correlation and flow are fitted for, whatever tables the model has
                out_k.append(out_c[-1] if has_cut and has_crowded else edge_tables(g, e, frac, moving, f, mem, True, True))
            out_cut.append((g.span[f, mem, 0].min() <= 0.0, g.span[f, mem, 1].max() >= cam.width))
            out_n.append(len(mem))
    n = len(out_f)
    f = np.asarray(out_f, int)
    edges = np.asarray(out_e, float).reshape(n, 4)
    flow = np.asarray(out_fl, float).reshape(n, 2)
    tid = np.asarray(out_id, np.int64)
    pp = np.asarray(out_p, int)
    tables = np.asarray(out_c, dtype=object)
    height = edges[:, 3] - edges[:, 2]
    hbin = None if m.edge_heights is None else height_bin(height, m.edge_heights)
    U = [grid[f, pp] for grid in grids[:4]]  # each window's uniforms for its four edges
    if m.edge_corr is not None:
        U[3] = edge_copula(U[2], U[3], m.edge_corr, np.asarray(out_k, dtype=object), height)
    for j, name in enumerate(("u_left", "u_right", "v_top", "v_bottom")):
        e_j = m.error(name).at(U[j])
        for tag in ("", "_crowded", "_cut"):
            on = tables == tag
            if tag and on.any():
                e_j[on] = m.error(name + tag).at(U[j][on])
            for k in () if hbin is None else range(len(m.edge_heights) + 1):
                on_k = on & (hbin == k)
                if on_k.any() and height_table(name + tag, k) in m.errors:
                    e_j[on_k] = m.error(height_table(name + tag, k)).at(U[j][on_k])
        edges[:, j] += e_j
    # an edge cut by the image border stays on it, as the rendered flow tracker's does
    # (``perception_flow.current_box``): the image clips the person, its edge has no error
    cut = np.asarray(out_cut, bool).reshape(n, 2)
    edges[cut[:, 0], 0] = 0.0
    edges[cut[:, 1], 1] = cam.width
    true_flow = flow.copy() if m.border is not None else None  # the people's own flow, for ``border_short``
    if has_flow_frame(m):  # along and across the people's image velocity, by its speed
        k, d = flow_frame(flow)
        along, across = np.zeros(n), np.zeros(n)
        if flow_kinds:
            kinds = np.asarray([flow_kind(tag, c[0] or c[1]) for tag, c in zip(out_k, out_cut)], dtype=object)
        else:
            kinds = np.full(n, "", dtype=object)
        for b in np.unique(k):
            for tag in np.unique(kinds[k == b]):
                on = (k == b) & (kinds == tag)
                along[on] = m.error(f"flow_along_s{b}{tag}").at(grids[4][f[on], pp[on]])
                across[on] = m.error(f"flow_across_s{b}{tag}").at(grids[5][f[on], pp[on]])
        flow += along[:, None] * d + across[:, None] * np.column_stack([-d[:, 1], d[:, 0]])
    else:
        flow[:, 0] += m.error("flow_u").at(grids[4][f, pp])
        flow[:, 1] += m.error("flow_v").at(grids[5][f, pp])
    cf, ce, cfl, cid = ids.clutter(F, cam)
    ff, fe, ffl, fid = ids.fragments(det, e, g.flow)
    # drawn last: a model without partial windows samples the same stream as before
    pf, pe, pfl, pid = ids.partials(moving & ~det, frac, e, g.flow, head)
    if m.border is not None:  # drawn after the rest: a model without it samples the same stream as before
        border_short(rng, m, cam.width, f, pp, cut, np.asarray(out_n) == 1, true_flow, edges, flow, det.shape)
    f, edges, flow, tid = (np.concatenate(x) for x in ((f, cf, ff, pf), (edges, ce, fe, pe), (flow, cfl, ffl, pfl), (tid, cid, fid, pid)))
    edges[:, [0, 1]] = np.clip(np.sort(edges[:, [0, 1]], axis=1), 0, cam.width)
    edges[:, [2, 3]] = np.clip(np.sort(edges[:, [2, 3]], axis=1), 0, cam.height)
    keep = (edges[:, 1] > edges[:, 0]) & (edges[:, 3] > edges[:, 2])
    if not keep.any():
        return None
    edges, f = edges[keep], f[keep]
    return pd.DataFrame({
        "t": t[f], "camera": cam.name, "track": tid[keep], "u": 0.5 * (edges[:, 0] + edges[:, 1]),
        "u_left": edges[:, 0], "u_right": edges[:, 1], "v_top": edges[:, 2], "v_bottom": edges[:, 3],
        "flow_u": flow[keep, 0], "flow_v": flow[keep, 1],
    })


def border_short(rng: np.random.Generator, m: DetectorModel, width: float, f: np.ndarray, pp: np.ndarray, cut: np.ndarray,
                 single: np.ndarray, true_flow: np.ndarray, edges: np.ndarray, flow: np.ndarray, shape: tuple[int, int]) -> None:
    """Which windows stop short of the image border that cuts their person (``m.border``,
    ``perception_model.Border``), in place: windows of one person (``single``) cut by one border
    (``cut`` (n, 2): left, right) stop short in runs (``run_events`` per person over the frames
    ``f``, people ``pp``, ``shape`` (F, P)); a short window's cut edge moves ``border_gap_<side>``
    inside the image (a window left with no width is dropped later) and its horizontal flow
    becomes ``gain`` times the person's (``true_flow``) plus ``border_flow_<side>``."""
    b = m.border
    side = np.where(cut[:, 0], 0, 1)
    on = single & (cut[:, 0] != cut[:, 1])
    p, eligible = np.zeros(shape), np.zeros(shape, bool)
    p[f[on], pp[on]] = b.short(side[on], true_flow[on, 0])
    eligible[f[on], pp[on]] = True
    short = run_events(rng, p, b.stay, eligible)[f, pp] & on
    u_gap, u_flow = (correlated_uniforms(rng, shape, m.err_rho)[f, pp] for _ in range(2))
    for k, name in enumerate("lr"):
        s = short & (side == k)
        gap = m.error(f"border_gap_{name}").at(u_gap[s])
        edges[s, k] = gap if k == 0 else width - gap
        flow[s, 0] = b.gain[k] * true_flow[s, 0] + m.error(f"border_flow_{name}").at(u_flow[s])
    gone = short & (edges[:, 1] <= edges[:, 0])
    edges[gone] = 0.0


def _episode_frames(start: np.ndarray, life: np.ndarray, n_frames: int):
    """(episode index, frame) of every frame of episodes starting at ``start`` and lasting
    ``life`` frames, cut at ``n_frames``."""
    k = np.repeat(np.arange(len(start)), life)
    frame = start[k] + (np.arange(len(k)) - np.repeat(np.cumsum(life) - life, life))
    ok = frame < n_frames
    return k[ok], frame[ok]


class WindowIds:
    """A flow tracker's window ids from who is in which window, frame by frame.

    A window continues the id of the window its members were in within ``max_gap`` frames (a
    merged window: the oldest such id); with ``restart`` per frame a continuing window gets a new
    id. Two windows claiming one id (a merged window splitting): the id goes to the window holding
    the person whose id it was, unless ``swap`` hands it to the other; the other window takes its
    members' own earlier id if still alive, else a new one. Ids are never reused.
    """

    def __init__(self, n_people: int, m: DetectorModel, rng: np.random.Generator):
        self.m, self.rng = m, rng
        self.prev = np.full(n_people, -1, np.int64)  # id of the window each person was last in
        self.prev_f = np.full(n_people, -(10**9))
        self.own = np.full(n_people, -1, np.int64)  # id of each person's last window of their own
        self.own_f = np.full(n_people, -(10**9))
        self.owner: dict[int, int] = {}
        self.next_id = 0

    def _new(self) -> int:
        self.next_id += 1
        return self.next_id - 1

    def step(self, f: int, groups: list[list[int]]) -> list[int]:
        alive = lambda fr: f - fr <= self.m.max_gap + 1  # noqa: E731
        claims = []
        for mem in groups:
            prior = sorted({int(self.prev[p]) for p in mem if self.prev[p] >= 0 and alive(self.prev_f[p])})
            claims.append(prior)
        out = [-1] * len(groups)
        taken: set[int] = set()
        # ids claimed by more than one window: a split
        wanted: dict[int, list[int]] = {}
        for gi, prior in enumerate(claims):
            if prior:
                wanted.setdefault(prior[0], []).append(gi)
        for tid, gis in wanted.items():
            if len(gis) == 1:
                winner = gis[0]
            else:
                owner = self.owner.get(tid, -1)
                holders = [gi for gi in gis if owner in groups[gi]]
                others = [gi for gi in gis if gi not in holders]
                if holders and (not others or self.rng.random() >= self.m.swap):
                    winner = holders[0]
                else:
                    winner = others[int(self.rng.integers(len(others)))] if others else gis[0]
            out[winner] = tid
            taken.add(tid)
        for gi, mem in enumerate(groups):
            if out[gi] >= 0:
                if len(mem) == 1 and len(claims[gi]) == 1 and self.m.restart > 0 and self.rng.random() < self.m.restart:
                    out[gi] = self._new()
                continue
            back = [int(self.own[p]) for p in mem if self.own[p] >= 0 and alive(self.own_f[p]) and self.own[p] not in taken]
            out[gi] = back[0] if back else self._new()
            taken.add(out[gi])
        for mem, tid in zip(groups, out):
            for p in mem:
                self.prev[p], self.prev_f[p] = tid, f
            if len(mem) == 1:
                self.own[mem[0]], self.own_f[mem[0]] = tid, f
                self.owner[tid] = mem[0]
            elif tid not in self.owner:
                self.owner[tid] = mem[0]
        return out

    def fragments(self, det: np.ndarray, e: np.ndarray, flow: np.ndarray):
        """Fragment windows: born on a detected person at rate fragment / fragment_frames per
        frame, each living a geometric number of frames (mean ``fragment_frames``) at a fixed
        place and size relative to the person's window, moving with the person's flow."""
        return self._attached(det, e, flow, self.m.fragment, self.m.fragment_frames, "frag")

    def partials(self, missed: np.ndarray, frac: np.ndarray, e: np.ndarray, flow: np.ndarray, head: np.ndarray | None = None):
        """Partial windows of missed moving people (``missed``: (F, P)), as fragments are of
        detected ones: ``partial(frac[, head])`` / ``partial_frames`` born per missed person-frame
        (``frac``: the seen share of the axis rays; ``head``: of the head ray, for a table over
        both), placed by the ``part_*`` tables. A model without them (``partial`` None) draws nothing."""
        m = self.m
        if m.partial is None:
            rate = 0.0
        elif m.uses_head:
            if head is None:
                raise ValueError("this model's partial windows depend on the head ray: give head")
            rate = m.partial(frac, head)
        else:
            rate = m.partial(frac)
        return self._attached(missed, e, flow, rate, self.m.partial_frames, "part")

    def _attached(self, on: np.ndarray, e: np.ndarray, flow: np.ndarray, rate, frames: float, table: str):
        """Windows born on the person-frames ``on`` at ``rate`` (a number, or (F, P)) / ``frames`` per frame, each living
        a geometric number of frames (mean ``frames``) at a fixed place and size relative to the
        person's window (tables ``{table}_du``, ``_dv``, ``_w``, ``_h``), moving with the
        person's flow."""
        m, rng = self.m, self.rng
        empty = (np.zeros(0, int), np.zeros((0, 4)), np.zeros((0, 2)), np.zeros(0, np.int64))
        f0, p0 = np.nonzero(on)
        rate = np.broadcast_to(np.asarray(rate, float), on.shape)[f0, p0]
        if not (rate > 0).any():
            return empty
        births = rng.poisson(rate / frames)
        f0, p0 = np.repeat(f0, births), np.repeat(p0, births)
        if not len(f0):
            return empty
        n = len(f0)
        life = rng.geometric(1.0 / frames, n)
        du, dv = m.error(f"{table}_du").sample(rng, n), m.error(f"{table}_dv").sample(rng, n)
        rw, rh = np.clip(m.error(f"{table}_w").sample(rng, n), 0.05, None), np.clip(m.error(f"{table}_h").sample(rng, n), 0.05, None)
        ids = np.array([self._new() for _ in range(n)], np.int64)
        k, frame = _episode_frames(f0, life, on.shape[0])
        pe = e[frame, p0[k]]
        pw, ph = pe[:, 1] - pe[:, 0], pe[:, 3] - pe[:, 2]
        cu = 0.5 * (pe[:, 0] + pe[:, 1]) + du[k] * pw
        cv = 0.5 * (pe[:, 2] + pe[:, 3]) + dv[k] * ph
        w, h = rw[k] * pw, rh[k] * ph
        edges = np.stack([cu - w / 2, cu + w / 2, cv - h / 2, cv + h / 2], -1)
        fl = flow[frame, p0[k]] + np.stack([m.error("flow_u").sample(rng, len(k)), m.error("flow_v").sample(rng, len(k))], -1)
        return frame, edges, fl, ids[k]

    def clutter(self, n_frames: int, cam: Camera):
        """False windows: born Poisson(clutter / clutter_frames) per frame, each living a
        geometric number of frames (mean ``clutter_frames``) in place, with its own id, placed
        uniformly in the image, with the rendered ones' sizes and flows."""
        m, rng = self.m, self.rng
        empty = (np.zeros(0, int), np.zeros((0, 4)), np.zeros((0, 2)), np.zeros(0, np.int64))
        if m.clutter <= 0 or n_frames == 0:
            return empty
        births = rng.poisson(m.clutter / m.clutter_frames, n_frames)
        f0 = np.repeat(np.arange(n_frames), births)
        if len(f0) == 0:
            return empty
        life = rng.geometric(1.0 / m.clutter_frames, len(f0))
        w = np.maximum(m.error("clutter_w").sample(rng, len(f0)), 2.0)
        h = np.maximum(m.error("clutter_h").sample(rng, len(f0)), 2.0)
        # placed uniformly: the rendered false windows' own places (their marginal distribution in
        # the image) made transfer worse, see docs/sensing.md
        cu, cv = rng.uniform(0, cam.width, len(f0)), rng.uniform(0, cam.height, len(f0))
        fl = np.stack([m.error("clutter_flow_u").sample(rng, len(f0)), m.error("clutter_flow_v").sample(rng, len(f0))], -1)
        ids = np.array([self._new() for _ in f0], np.int64)
        k, frame = _episode_frames(f0, life, n_frames)
        edges = np.stack([cu[k] - w[k] / 2, cu[k] + w[k] / 2, cv[k] - h[k] / 2, cv[k] + h[k] / 2], -1)
        return frame, edges, fl[k], ids[k]


def merged_blob_member(cam: Camera, axis: np.ndarray, members: np.ndarray) -> int:
    """Which of the people merged into one overhead blob the rendered detector places it on.

    ``sim.perception.floor_from_blob`` places a blob by its outermost point along the radial
    direction e from the vertical vanishing point n through the blob: the top of the head of the
    member reaching farthest out. When that end is cut by the image border it uses the innermost
    point instead: the feet of the member reaching farthest in. ``axis`` (P, 2, 2) holds every
    person's image feet and head points at this frame. At a tile edge this is what makes a merged
    pair vanish: each camera places the pair on the person beyond its tile and drops it.
    """
    feet, head = axis[members, 0], axis[members, 1]
    n = cam.vertical_vanishing_point()
    if n is None:
        return int(members[0])
    radial = 0.5 * (feet + head).mean(axis=0) - n
    dist = float(np.hypot(*radial))
    if dist < 1.0:  # under the camera: head and feet project together
        return int(members[0])
    e = radial / dist
    out = int(np.argmax((head - n) @ e))
    if cam.in_image(head[out], 1.0, margin=-1.0):
        return int(members[out])
    return int(members[np.argmin((feet - n) @ e)])


def radial_frame(cam: Camera, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (..., 2) on the floor along and across the direction from the point below a
    ceiling camera to floor points xy (..., 2)."""
    d = np.asarray(xy, float) - np.asarray(cam.position, float)[:2]
    er = d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-9)
    return er, np.stack([-er[..., 1], er[..., 0]], -1)


def _floor_error(err, u: np.ndarray, cam: Camera) -> np.ndarray:
    """Floor position errors (m) at uniforms u from an error table. The fitted residuals of a
    quantising camera include its rounding (variance q^2 / 12), which ``floor`` adds again: only
    the rest of the scatter is kept."""
    e = err.at(u)
    if cam.quantum > 0 and err.sigma > 0:
        keep = np.sqrt(max(0.0, err.sigma**2 - cam.quantum**2 / 12)) / err.sigma
        e = err.bias + (e - err.bias) * keep
    return e


# Error tables of the floor detections (overhead, privacy), by the blob's state: whole or with
# the head cut by the image border, alone or near another detected person (their silhouettes
# within NEAR_GAP body widths in the image: the other person's pixels take from or add to the
# blob's outer end). Each is fitted along (_r) and across (_t) the camera's radial direction: a
# ceiling camera places a blob by its outer end, so errors lie mostly along that direction.
# "xy" (per floor axis, whole blobs) is the declared floor noise and what an older model without
# the radial tables samples from.
FLOOR_TABLES = {(False, False): "xy", (False, True): "xy_near", (True, False): "xy_clip", (True, True): "xy_clip_near"}


def nearest_gap(gap: np.ndarray, P: int) -> np.ndarray:
    """(F, P) the smallest of each person's pair entries in ``gap`` (F, pairs over
    ``np.triu_indices(P, 1)``; inf where none is finite)."""
    out = np.full((gap.shape[0], P), np.inf)
    f, k = np.nonzero(np.isfinite(gap))
    if len(f):
        iu, ju = np.triu_indices(P, 1)
        np.minimum.at(out, (f, iu[k]), gap[f, k])
        np.minimum.at(out, (f, ju[k]), gap[f, k])
    return out


def floor_table(m: DetectorModel, cut: bool, near: bool) -> str | None:
    """The radial error tables' name (without _r / _t) a blob in this state takes: its own, else
    the alone one of its kind, else the whole one's; None for a model without radial tables."""
    for key in ((cut, near), (cut, False), (False, False)):
        name = FLOOR_TABLES[key]
        if name + "_r" in m.errors:
            return name
    return None


def floor_errors(m: DetectorModel, cam: Camera, pos: np.ndarray, ux: np.ndarray, uy: np.ndarray, cut: np.ndarray,
                 near: np.ndarray, head_shift: np.ndarray | None = None) -> np.ndarray:
    """(n, 2) floor errors of detections at ``pos`` from the uniforms ux, uy (along and across the
    radial direction where the model has radial tables), by head cut and nearness (FLOOR_TABLES);
    the radial error adds the fitted share (``head_gain``) of the head-height shift ``head_shift``
    (n,): walking people's heads bob, and the detector places them by the head."""
    if floor_table(m, False, False) is None:  # a model from before the radial tables
        err = m.error("xy")
        e = np.stack([_floor_error(err, ux, cam), _floor_error(err, uy, cam)], -1)
        if "xy_clip_r" in m.errors and cut.any():
            er, et = radial_frame(cam, pos[cut])
            r = _floor_error(m.error("xy_clip_r"), ux[cut], cam)
            tang = _floor_error(m.error("xy_clip_t"), uy[cut], cam)
            e[cut] = r[:, None] * er + tang[:, None] * et
        return e
    e = np.empty((len(pos), 2))
    er, et = radial_frame(cam, pos)
    for c in (False, True):
        for n in (False, True):
            sel = (cut == c) & (near == n)
            if sel.any():
                name = floor_table(m, c, n)
                r = _floor_error(m.error(name + "_r"), ux[sel], cam)
                if head_shift is not None and m.head_gain.get(name):
                    r = r + m.head_gain[name] * head_shift[sel]
                t = _floor_error(m.error(name + "_t"), uy[sel], cam)
                e[sel] = r[:, None] * er[sel] + t[:, None] * et[sel]
    return e


def drift_episodes(rng: np.random.Generator, m: DetectorModel, cam: Camera, f: np.ndarray, p: np.ndarray, pos: np.ndarray,
                   own: np.ndarray, cut: np.ndarray, near: np.ndarray, F: int, P: int) -> tuple[np.ndarray, np.ndarray]:
    """The tail of floor errors (``perception_model.Tail``): (n, 2) extra errors of the detections
    (frame f, person p, at pos) and which of them are missed (the frame after an episode). An
    episode starts at an unmerged detection (``own``) with P(start | head cut, near), lasts a
    geometric number of frames while the person stays detected and unmerged, grows linearly from
    TAIL_M towards its peak (TAIL_M + (peak - TAIL_M) k / L at its k-th frame, k = 1..L), and points at a fitted angle from the camera's radial direction. Episodes
    are rare (about one in a thousand person-frames): the loop is over episodes, not frames."""
    t = m.tail
    n = len(f)
    extra, drop = np.zeros((n, 2)), np.zeros(n, bool)
    start = own & (rng.random(n) < t.start(cut.astype(float), near.astype(float)))
    if not start.any():
        return extra, drop
    rows = np.full((F, P), -1)
    rows[f[own], p[own]] = np.nonzero(own)[0]
    first = np.nonzero(start)[0]
    first = first[np.argsort(f[first], kind="stable")]
    k = len(first)
    length = rng.geometric(1.0 / t.frames, k)
    peak = np.maximum(t.size.at(rng.random(k)), TAIL_M)
    angle = t.angle.at(rng.random(k))
    missed = rng.random(k) < t.miss
    busy = np.full(P, -1)  # each person's episode ends before this frame
    for i, r0 in enumerate(first):
        f0, q = int(f[r0]), int(p[r0])
        if f0 < busy[q]:
            continue
        run = rows[f0:f0 + length[i], q]
        stop = np.nonzero(run < 0)[0]
        run = run[:stop[0]] if len(stop) else run
        L = len(run)
        size = TAIL_M + (peak[i] - TAIL_M) * np.arange(1, L + 1) / L  # above TAIL_M from its first frame
        er, et = radial_frame(cam, pos[run])
        extra[run] = size[:, None] * (np.cos(angle[i]) * er + np.sin(angle[i]) * et)
        busy[q] = f0 + L
        if missed[i] and L == length[i] and f0 + L < F and rows[f0 + L, q] >= 0:
            drop[rows[f0 + L, q]] = True
            busy[q] += 1
    return extra, drop


def floor(cam: Camera, g, frac: np.ndarray, traj, t: np.ndarray, m: DetectorModel, rng: np.random.Generator,
          bounds: tuple[float, float, float, float]) -> pd.DataFrame | None:
    """``floor_detections`` rows (t, camera, x, y) of an overhead camera (regular or privacy)."""
    xy, speed, clip = floor_state(cam, g, traj)
    det = detected(rng, g.near, m.detect(frac, speed, clip), m)
    F, P = det.shape
    edges = m.merge.edges[0]
    reach = edges[-2] if len(edges) > 2 else 0.0
    gap = np.zeros((F, 0))
    if P > 1:
        # only pairs of detected people can merge: their gaps alone are measured (the costliest
        # step of an overhead camera), unless none is in reach, where whether any pair of all is
        # decides if merge_roots draws its uniforms (the random stream, as before)
        # (they are also what makes a detection "near" another: NEAR_GAP, FLOOR_TABLES)
        iu, ju = np.triu_indices(P, 1)
        gap = silhouette_pairs(g, max(reach, NEAR_GAP), det[:, iu] & det[:, ju])
    mgap = gap if P < 2 or (gap < reach).any() else silhouette_pairs(g, reach)
    root = merge_roots(rng, det, mgap, mgap < reach, m)
    f, p = _groups(root, det)
    pos = xy[f, p]
    grouped = det[f] & (root[f] == p[:, None])  # (n, P) members of each detection
    cnt = grouped.sum(axis=1)
    # a merged detection lies on one of the merged people, not between them: in the rendered
    # development recordings 80 % of merged detections lie within 2 cm (regular cameras) or 8 cm
    # (privacy, 15 cm grid) of one person along the line to the other
    member = p.copy()
    for i in np.nonzero(cnt > 1)[0]:
        member[i] = merged_blob_member(cam, g.axis[f[i]], np.nonzero(grouped[i])[0])
        pos[i] = xy[f[i], member[i]]
    gx, gy = error_uniforms(rng, det.shape, m, 2)
    near = np.zeros(len(f), bool)
    if P > 1:
        near = (nearest_gap(gap, P)[f, p] < NEAR_GAP) & (cnt == 1)
    e = floor_errors(m, cam, pos, gx[f, p], gy[f, p], clip[f, p] < 0.999, near,
                     g.head_shift[f, member] if g.head_shift is not None else None)
    pos = pos + e
    if m.tail is not None:
        extra, drop = drift_episodes(rng, m, cam, f, p, pos, cnt == 1, clip[f, p] < 0.999, near, F, P)
        pos, f = (pos + extra)[~drop], f[~drop]
    k = rng.poisson(m.clutter, F) if m.clutter > 0 else np.zeros(F, int)
    fc = np.repeat(np.arange(F), k)
    x0, y0, x1, y1 = cam.region if cam.region is not None else bounds
    clutter = np.stack([rng.uniform(x0, x1, len(fc)), rng.uniform(y0, y1, len(fc))], -1)
    f = np.concatenate([f, fc])
    pos = np.concatenate([pos, clutter])
    keep_region = cam.in_region(pos)
    if cam.quantum > 0:
        pos = cam.quantum * np.round(pos / cam.quantum)
    if not keep_region.any():
        return None
    return pd.DataFrame({"t": t[f[keep_region]], "camera": cam.name, "x": pos[keep_region, 0], "y": pos[keep_region, 1]})
