"""Starting new targets in multi-person mode (beyond the paper: its future work, section 6).

A mover not yet tracked shows as windows no target claims. For every pair of such windows in two
cameras whose target planes cross at an angle of at least ``min_plane_angle_deg``, the crossing
point (eq. 6) is a candidate; it is kept only if it lies inside both windows' single-camera target
areas (section 3.2: depth from the top/bottom rows, width from the edges) and on the floor. Each
further camera with an unclaimed window that also contains the point (centroid within the
position tolerance of the projected person model, and the point in its target area) supports it.
Candidates are taken greedily, most support first, each window used once. While the hand-chosen
target is not yet located, the crossings its locating test accepts go first, nearest its click
first (``prefer``): which of two crossings sharing a window survives must not turn on their
coordinates when one of them is the person the user clicked. A crossing that two or more further
cameras would see whole and show no window at (``ghost``) is two people's planes crossing, not a
person: it is not a candidate. A window slower than a mover's starts and locates nothing; but
while the target is not located (``locate_slow``), one that is a whole person's image and crosses
a mover's window nearer the click than every movers' crossing, and away from it, says that
mover's window is the target's: the nearer movers' crossing may be a ghost of it and someone
else's, so the target is not located that frame, nor anyone started on that window.
"""
from __future__ import annotations

import itertools

import numpy as np

from . import tp_geometry as geo
from .tp_frames import CameraBoxes


def propose(cfg, margin_px: float, Ps: dict[str, np.ndarray], frame: dict[str, CameraBoxes], free: dict[str, np.ndarray], inside_room,
            prefer=None, ghost=None, not_one=None) -> list[tuple[np.ndarray, dict[str, int]]]:
    """New target positions and the windows (camera -> box index) that support them.

    ``margin_px``: the target areas' allowance for window noise (px); ``free``: per camera, the indices of boxes no target claims; ``inside_room``: callable
    telling whether floor points (k, 2) are inside the room; ``prefer``: None, or a callable
    giving a crossing (xy) a distance when it may be the hand-chosen target and None otherwise:
    those crossings are taken first, the nearest first; ``ghost``: None, or a callable (camera,
    xy) -> bool telling that a further camera sees no one at a crossing
    (``JointTracker.sees_no_one``): a crossing two or more further cameras see no one at is two
    people's planes, not a person, and is dropped (one camera seeing no one is common for a
    person too: a missed window, someone standing in front). ``not_one``: None, or a callable
    (camera, xy, width px) -> bool telling that a window is not one whole person at xy
    (``JointTracker.not_one_person``); with ``prefer`` and ``cfg.locate_slow`` it enables the
    slow windows' veto on locating the clicked target (``locate_slow``).
    """
    min_angle = np.radians(cfg.min_plane_angle_deg)
    planes, areas = {}, {}
    slow = set()  # windows slower than a mover's: they can only stop the clicked target being located
    veto = prefer is not None and not_one is not None and cfg.locate_slow
    for c, idx in free.items():
        b = frame[c]
        for j in idx:
            if np.linalg.norm(b.flow[j]) < cfg.mover_flow_px:
                if not veto:
                    continue
                slow.add((c, j))
            a_, b_ = geo.target_plane(Ps[c], b.u[j], 0.5 * (b.win[j, 2] + b.win[j, 3]))
            planes[(c, j)] = (a_, b_)
            areas[(c, j)] = geo.target_area(Ps[c], b.box(j), cfg.height, cfg.radius, margin=cfg.area_margin, margin_px=margin_px)
    cands = []
    near_slow = []  # crossings with a slow window: (locate's distance, the crossing, its mover's window)
    keys = list(planes)
    for k1, k2 in itertools.combinations(keys, 2):
        if k1[0] == k2[0]:
            continue
        A = np.array([planes[k1][0], planes[k2][0]])
        B = np.array([planes[k1][1], planes[k2][1]])
        try:
            xy, _ = geo.intersect_planes(A, B, min_angle)
        except geo.IllConditioned:
            continue
        if not inside_room(xy[None])[0]:
            continue
        with_slow = k1 in slow or k2 in slow
        if with_slow and (prefer(xy) is None or (k1 in slow and k2 in slow)
                          or any(k in slow and not_one(k[0], xy, frame[k[0]].width[k[1]]) for k in (k1, k2))):
            continue  # a slow window counts only with a mover's, near the click, as one whole person's image
        if not (areas[k1].contains(xy, cfg.consistency_margin) and areas[k2].contains(xy, cfg.consistency_margin)):
            continue
        support = {k1[0]: k1[1], k2[0]: k2[1]}
        for k in keys:
            if k[0] in support or k in slow:
                continue
            w = geo.cylinder_window(Ps[k[0]], xy, cfg.height, cfg.radius)
            wc = max(w[1] - w[0], 1.0)
            if abs(frame[k[0]].u[k[1]] - 0.5 * (w[0] + w[1])) <= cfg.position_tol * wc and areas[k].contains(xy, cfg.consistency_margin):
                support.setdefault(k[0], k[1])
        if ghost is not None and sum(ghost(c, xy) for c in Ps if c not in support) >= 2:
            continue
        if with_slow:
            near_slow.append((prefer(xy), xy, [k for k in (k1, k2) if k not in slow]))
            continue
        cands.append((len(support), xy, support))
    def order(c):
        d = prefer(c[1]) if prefer is not None else None
        return (0, d, 0.0, 0.0) if d is not None else (1, -c[0], c[1][0], c[1][1])

    cands.sort(key=order)
    used: set = set()
    if near_slow:
        d_slow, xy_slow, movers = min(near_slow, key=lambda n: n[0])
        near = [(d, xy) for d, xy in ((prefer(xy), xy) for _, xy, _ in cands) if d is not None]
        d_fast, xy_fast = min(near, key=lambda n: n[0]) if near else (np.inf, None)
        if d_slow < d_fast and (xy_fast is None or np.linalg.norm(xy_fast - xy_slow) > 2.0 * cfg.radius):
            # the target's own slow window crosses a mover's nearer the click than any movers'
            # crossing, and not where that one is (another person): that mover's window is the
            # target's, and a crossing of it with someone else's is a ghost; the target is not
            # located this frame, nor anyone started on it
            cands = [cand for cand in cands if prefer(cand[1]) is None]
            used.update(movers)
    out = []
    for n, xy, support in cands:
        if n < cfg.init_min_cameras or any((c, j) in used for c, j in support.items()):
            continue
        used.update(support.items())
        out.append((xy, support))
    return out
