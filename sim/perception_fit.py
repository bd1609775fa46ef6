"""Fitting the perception model (``sim.perception_model``) to rendered recordings, and measuring
any recording's detector statistics the same way.

``measure(rec, scene)`` re-plans the recording's walkers from its seed (the motion stream does not
depend on the sensing mode, so the paths are the rendered ones), computes the analytic features of
every camera frame and person (``sim.analytic``: field of view, share of occlusion rays that reach
the person, image span and its clipped share, window, image or floor speed), matches the
recording's detections to people (``linear_sum_assignment``, per camera frame), and collects:

  candidates  features and whether reported (on a detection of its own or merged into another's) or missed;
  pairs       overlapping (image) or close (floor) detected people, and whether they merged;
  errors      detection minus the analytic reference, for detections of one person;
  labels      whether a blob's label is the person's colour;
  ids         (windows) continuing windows whose id changed, and who inherits a merged window's id
              when it splits;
  clutter     detections nobody explains, per camera frame.

``fit(stats)`` turns the rendered statistics into a model; ``summary(stats)`` gives the per-detector
figures ``trackroom calibrate-sensing`` prints for rendered and analytic recordings side by side.
"""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from trackroom.scenes.spec import Scene

from .analytic_detectors import (WHOLE, EDGE_HEIGHT_PX, FLOOR_TABLES, FLOW_KINDS, FLOW_SPEED_EDGES, MOVING_PX_S, edge_tables, flow_frame, flow_kind, height_bin, height_table, seen_share, blob_candidates, floor_state, nearest_gap, radial_frame, silhouette_pairs, span_pairs,
                                 window_candidates)
from .perception_model import BORDER_EDGES, DETECTORS, EDGE_CORR_KINDS, LEVELS, NEAR_GAP, TAIL_M, Border, DetectorModel, EdgeCorr, PerceptionModel, Quantiles, Table, Tail, correlated_uniforms, run_events

INF = float("inf")
SEEN_EDGES = [-INF, 1 / 6, 1 / 2, 5 / 6, INF]  # 0, 1/3, 2/3, 1 of the rays
CLIP_EDGES = [-INF, 0.25, 0.5, 0.75, 0.999, INF]
# px/s (windows). Below 0.5: standing still (no flow, no window); 0.5-3: a walker slowing to a stop
# or setting off, whom the rendered flow tracker still reports at about half the frames
# (development seeds 100-119, the frame a walker stops: 56 % of oblique camera-frames with a
# window on the axis), not the near-zero rate of people standing still that one bin below 3 gave
IMAGE_SPEED_EDGES = [-INF, 0.5, 3, 6, 12, 25, 50, INF]
# m/s (privacy cameras; below 5 mm/s: standing still, which a motion camera misses far more often
# than someone slowing down: 10 % against 25-47 % detected on the privacy development recordings)
FLOOR_SPEED_EDGES = [-INF, 0.005, 0.05, 0.1, 0.2, 0.4, 0.8, INF]
OVERLAP_EDGES = [-INF, 0.25, 0.5, 0.75, INF]
# overhead: share of the image axis (feet to head) inside the image. People whose head the image
# border cuts (a ceiling camera's far corners) are detected less often: on the rendered
# development recordings 97.3 % of them at least 0.3 m inside the tile, against 99.8 % of whole ones
AXIS_CLIP_EDGES = [-INF, 0.5, 0.8, 0.999, INF]
# overhead: distance between two people's silhouettes in the image, in body widths
# (``silhouette_pairs``); pairs nearer than 1.5 widths may merge
SILHOUETTE_EDGES = [-INF, 0.1, 0.25, 0.5, 0.75, 1.0, 1.5, INF]
GATE_PX = 10.0  # a blob explains a person when it lies within the person's span +- GATE_PX
IOU_GATE = 0.1  # a window explains a person's projected window at this IoU
FLOOR_GATE_M = 0.75
# windows: detection and partial windows by the seen share of rays averaged over this many frames
# (``analytic_detectors.seen_share``: a flow region outlives a ray grazing an obstacle for a frame)
WINDOW_SEEN_FRAMES = 3
# windows: detection by the axis rays' seen share, the head ray's and the image speed: the windows
# are cut at the floor plan's boxes, so someone whose head alone shows over a shelf has a window of
# their own, the strip (rendered development 100-109, walkers at 12-50 px/s whose axis rays are all
# hidden: detected 0.89-0.90 with the head seen, 0.05-0.12 without; the twelfth fit)
HEAD_EDGES = [-INF, 0.5, INF]  # the head ray: hidden / seen
# windows: partial windows of missed walkers by the seen share of the axis rays and of the head ray
# (both over WINDOW_SEEN_FRAMES): the head over a shelf or a standing person leaves a strip window
PARTIAL_EDGES = [SEEN_EDGES, HEAD_EDGES]
REGION_MARGIN_M = 0.3  # overhead: detection rates from people this far inside the camera's tile
DETECT_EDGES = {"horizontal": [SEEN_EDGES, CLIP_EDGES], "oblique": [SEEN_EDGES, CLIP_EDGES],  # detection table bins
                "windows": [SEEN_EDGES, HEAD_EDGES, IMAGE_SPEED_EDGES], "overhead": [SEEN_EDGES, [-INF, INF], AXIS_CLIP_EDGES],
                "privacy": [SEEN_EDGES, FLOOR_SPEED_EDGES, AXIS_CLIP_EDGES]}
RHO_GRID = (0.0, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.998)
# mean runs (frames) tried when fitting a held uniform's stay probability (stay = 1 - 1 / run)
RUN_GRID = (1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0, 64.0, 100.0)
MAX_STAY = 0.995


@dataclass
class DetectorStats:
    feats: list = field(default_factory=list)  # per candidate: feature tuple
    hit: list = field(default_factory=list)
    runs: list = field(default_factory=list)  # (sequence key, frame, candidate index)
    pair_feat: list = field(default_factory=list)  # overlap (image) or silhouette distance (overhead)
    pair_merged: list = field(default_factory=list)
    pair_runs: list = field(default_factory=list)  # (sequence key, pair, frame, pair index)
    errors: dict = field(default_factory=lambda: defaultdict(list))
    err_seq: list = field(default_factory=list)  # (sequence key, person, frame, main error) for err_rho
    flow_seq: list = field(default_factory=list)  # (sequence key, person, frame, flow error along the motion) for flow_persist
    label_ok: list = field(default_factory=list)
    frames: int = 0
    clutter: int = 0
    clutter_unlabelled: int = 0
    fragments: int = 0
    fragment_ids: set = field(default_factory=set)
    fragment_labelled: int = 0
    clutter_ids: set = field(default_factory=set)
    # windows: unmatched windows on a missed moving person (a flow region on part of the body),
    # and the missed moving person-frames they are counted against
    partials: int = 0
    partial_ids: set = field(default_factory=set)
    partial_feat: list = field(default_factory=list)  # per missed moving person-frame: seen share of axis and head rays
    partial_hit: list = field(default_factory=list)  # and whether a partial window is on them
    continuing: int = 0
    restarts: int = 0
    splits: int = 0
    swaps: int = 0
    # floor detectors: |error| of every unmerged detection; drift episodes (runs of |error| >
    # TAIL_M) as (head cut, near, frames, peak, angle from radial, missed after); per unmerged
    # detection outside an episode, its state and whether an episode starts there
    floor_abs: list = field(default_factory=list)
    tail_eps: list = field(default_factory=list)
    tail_feat: list = field(default_factory=list)
    tail_hit: list = field(default_factory=list)
    # windows: own windows of a person the image border cuts (one border): (side 0 left / 1 right,
    # gap of the window's cut edge from that border px, window flow u, the person's image flow u,
    # image speed px/s, visible share of the span, sequence key, person, frame)
    border: list = field(default_factory=list)

    def partial_columns(self) -> list[np.ndarray]:
        """The partial-window features as columns: the axis rays' seen share, the head ray's."""
        return list(np.asarray(self.partial_feat, float).reshape(-1, 2).T)

    def arrays(self, n_features: int):
        """(features (candidates, n_features), hit (candidates,))."""
        X = np.asarray(self.feats, float).reshape(-1, n_features) if self.feats else np.zeros((0, n_features))
        return X, np.asarray(self.hit, bool)


def scene_features(scene: Scene, seed: int, duration: float):
    """(trajectories, camera geometry, ray fraction, head ray) of ``scene`` at ``seed``: the
    analytic view of exactly the walkers a recording with that seed holds (``Occlusion``'s
    ``fraction`` and, for oblique cameras, ``head``)."""
    from . import analytic
    from .walkers import plan_trajectories
    from .world import build_world

    motion_rng = np.random.default_rng(seed).spawn(4)[0]  # the motion stream (sim.simulate)
    traj = plan_trajectories(scene, duration, motion_rng)
    world = build_world(scene)
    geometry = analytic.camera_geometry(scene, traj)
    occ = analytic.Occlusion(world, scene, traj, geometry, head_ray=True)
    occ.finish()
    return traj, geometry, occ.fraction, occ.head


def _frames(df: pd.DataFrame, cam, n: int) -> dict[int, pd.DataFrame]:
    if df is None or not len(df):
        return {}
    d = df[df["camera"] == cam.name]
    j = np.rint(d["t"].to_numpy() * cam.fps).astype(int)
    return {int(k): g for k, g in d.assign(_j=j).groupby("_j") if 0 <= k < n}


def _assign(cost: np.ndarray, ok: np.ndarray):
    """Rows and columns matched by minimum cost among allowed entries."""
    if not ok.any():
        return np.zeros(0, int), np.zeros(0, int)
    c = np.where(ok, cost, 1e9)
    r, k = linear_sum_assignment(c)
    good = ok[r, k]
    return r[good], k[good]


def measure(rec, scene: Scene, features=None) -> dict[str, DetectorStats]:
    """Detector statistics of a recording (see the module docstring)."""
    seed, duration = int(rec.meta["seed"]), float(rec.meta["duration"])
    traj, geometry, fraction, head = features or scene_features(scene, seed, duration)
    obs = rec.observations.tables
    stats = {k: DetectorStats() for k in DETECTORS}
    colours = [w.color_name for w in scene.walkers]
    for cam in scene.cameras:
        g, frac = geometry[cam.name], fraction[cam.name]
        if cam.kind in ("horizontal", "oblique"):
            _measure_blobs(stats[cam.kind], cam, g, frac, obs.get("bearings"), colours)
        if cam.kind == "oblique":
            _measure_windows(stats["windows"], cam, g, frac, obs.get("boxes"), head[cam.name])
        if cam.kind == "overhead":
            _measure_floor(stats["privacy" if cam.privacy else "overhead"], cam, g, frac, traj, obs.get("floor_detections"))
    return stats


def _pair(s: DetectorStats, key, i: int, j: int, f: int, feature: float, merged_with: dict) -> None:
    """Record a pair of detected people who could have merged (overlapping in the image, or
    close in an overhead image) in camera frame ``f``, and whether they did."""
    s.pair_runs.append((key, (i, j), f, len(s.pair_merged)))
    s.pair_feat.append(float(feature))
    s.pair_merged.append(merged_with.get(i) == j or merged_with.get(j) == i)


def _candidates(s: DetectorStats, key, cand, feats, hit):
    """Record each candidate (camera frame, person): its features and whether it was reported."""
    for f, p in zip(*np.nonzero(cand)):
        s.runs.append((key, p, f, len(s.hit)))
        s.feats.append(feats(f, p))
        s.hit.append(bool(hit[f, p]))


def _measure_blobs(s: DetectorStats, cam, g, frac, bearings, colours):
    a, b, clip, cand = blob_candidates(g, cam.width)
    centre = 0.5 * (a + b)
    F, P = cand.shape
    by_frame = _frames(bearings, cam, F)
    hit, own = np.zeros((F, P), bool), np.zeros((F, P), bool)
    o_all, ok_all = span_pairs(a, b)
    iu, ju = np.triu_indices(P, 1)
    s.frames += F
    E = np.full((F, P, 2), np.nan)  # error of each unmerged detection
    state = np.zeros((F, P, 2), bool)  # its (head cut, near)
    for f in range(F):
        d = by_frame.get(f)
        u = d["u"].to_numpy() if d is not None else np.zeros(0)
        lab = d["label"].to_numpy() if d is not None else np.zeros(0, object)
        people = np.nonzero(cand[f])[0]
        cost = np.abs(u[:, None] - centre[f, people][None])
        ok = (u[:, None] >= a[f, people][None] - GATE_PX) & (u[:, None] <= b[f, people][None] + GATE_PX)
        r, k = _assign(cost, ok)
        match = {int(people[kk]): int(rr) for rr, kk in zip(r, k)}
        merged_with = {}
        for p in people:
            if p in match:
                continue
            for q, kk in match.items():
                lo, hi = min(a[f, p], a[f, q]) - GATE_PX, max(b[f, p], b[f, q]) + GATE_PX
                if min(b[f, p], b[f, q]) > max(a[f, p], a[f, q]) and lo <= u[kk] <= hi:
                    merged_with[int(p)] = q
                    break
        for p, rr in match.items():
            hit[f, p] = True
            own[f, p] = True
        for p, q in merged_with.items():
            hit[f, p] = True
            own[f, p] = own[f, q] = False
        for p, rr in match.items():
            if own[f, p]:
                err = u[rr] - centre[f, p]
                if clip[f, p] >= WHOLE and frac[f, p] >= WHOLE:
                    # someone seen whole is detected about the projected body centre (the blob's
                    # centroid), which the visible span's centre misses by up to a pixel in an
                    # oblique view (the span is the union of the body's projection over its height)
                    s.errors["u_whole"].append(u[rr] - g.uv[f, p, 0])
                else:
                    s.errors["u" if clip[f, p] >= 0.999 else "u_clip"].append(err)
                s.err_seq.append((cam.name, p, f, err))
                s.label_ok.append(lab[rr] == colours[p])
        matched = set(match.values())
        for rr in range(len(u)):
            if rr in matched:
                continue
            near = [p for p in people if a[f, p] - GATE_PX <= u[rr] <= b[f, p] + GATE_PX and hit[f, p]]
            if near:  # a fragment of the nearest detected person
                p = min(near, key=lambda q: abs(u[rr] - centre[f, q]))
                s.fragments += 1
                s.fragment_labelled += int(lab[rr] == colours[p])
                s.errors["frag_du"].append((u[rr] - centre[f, p]) / max(b[f, p] - a[f, p], 1.0))
            else:
                s.clutter += 1
                s.clutter_unlabelled += int(lab[rr] == "")
        # pairs of detected people whose spans overlap
        both = hit[f, iu] & hit[f, ju] & ok_all[f]
        for k in np.nonzero(both)[0]:
            _pair(s, cam.name, int(iu[k]), int(ju[k]), f, o_all[f, k], merged_with)
    _candidates(s, cam.name, cand, lambda f, p: (frac[f, p], clip[f, p]), hit)


def _iou(e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """IoU of windows (n, 4) x (m, 4) [u_left, u_right, v_top, v_bottom]."""
    w = np.clip(np.minimum(e1[:, None, 1], e2[None, :, 1]) - np.maximum(e1[:, None, 0], e2[None, :, 0]), 0, None)
    h = np.clip(np.minimum(e1[:, None, 3], e2[None, :, 3]) - np.maximum(e1[:, None, 2], e2[None, :, 2]), 0, None)
    inter = w * h
    area = lambda e: (e[:, 1] - e[:, 0]) * (e[:, 3] - e[:, 2])  # noqa: E731
    return inter / np.maximum(area(e1)[:, None] + area(e2)[None] - inter, 1e-9), inter / np.maximum(area(e2)[None], 1e-9)


def _measure_windows(s: DetectorStats, cam, g, frac, boxes, head):
    frac = seen_share(frac, WINDOW_SEEN_FRAMES)
    head = seen_share(head, WINDOW_SEEN_FRAMES)
    e = g.edges
    clip, speed, cand = window_candidates(g, cam.width)
    moving = cand & (speed >= MOVING_PX_S)
    F, P = cand.shape
    by_frame = _frames(boxes, cam, F)
    hit, own = np.zeros((F, P), bool), np.zeros((F, P), bool)
    has_part = np.zeros((F, P), bool)  # a missed moving person with a partial window
    o_all, ok_all = span_pairs(e[..., 0], e[..., 1])
    iu, ju = np.triu_indices(P, 1)
    window_of = np.full((F, P), -1, np.int64)  # track id of the window each person is in
    members = [dict() for _ in range(F)]  # track id -> people in it
    s.frames += F
    cols = ["u_left", "u_right", "v_top", "v_bottom"]
    for f in range(F):
        d = by_frame.get(f)
        people = np.nonzero(cand[f])[0]
        if d is None:
            continue
        W = d[cols].to_numpy(float)
        fl = d[["flow_u", "flow_v"]].to_numpy(float)
        tid = d["track"].to_numpy(np.int64)
        iou, cover = _iou(W, e[f, people]) if len(people) else (np.zeros((len(W), 0)), np.zeros((len(W), 0)))
        r, k = _assign(1 - iou, iou >= IOU_GATE)
        match = {int(people[kk]): int(rr) for rr, kk in zip(r, k)}
        merged_with = {}
        for pi, p in enumerate(people):
            if p in match:
                continue
            if speed[f, p] < MOVING_PX_S:  # someone standing has no window to merge (``MOVING_PX_S``)
                continue
            for q, rr in match.items():
                if cover[rr, pi] >= 0.5 and min(e[f, p, 1], e[f, q, 1]) > max(e[f, p, 0], e[f, q, 0]):
                    merged_with[int(p)] = q
                    break
        for p, rr in match.items():
            hit[f, p] = own[f, p] = True
            window_of[f, p] = tid[rr]
        for p, q in merged_with.items():
            hit[f, p] = True
            own[f, p] = own[f, q] = False
            window_of[f, p] = window_of[f, q]
        for p, rr in match.items():
            if own[f, p]:
                tag = edge_tables(g, e, frac, moving, f, [p])
                hk = height_bin(e[f, p, 3] - e[f, p, 2])
                for j, c in enumerate(cols):
                    s.errors[c + tag].append(W[rr, j] - e[f, p, j])
                    if tag != "_cut":  # (a cut window's strip is fixed by the box and the head, not by its size)
                        s.errors[height_table(c + tag, hk)].append(W[rr, j] - e[f, p, j])
                s.errors["u"].append(0.5 * (W[rr, 0] + W[rr, 1]) - 0.5 * (e[f, p, 0] + e[f, p, 1]))
                s.err_seq.append((cam.name, p, f, s.errors["u"][-1]))
                ef = fl[rr] - g.flow[f, p]
                s.errors["flow_u"].append(ef[0])
                s.errors["flow_v"].append(ef[1])
                (k,), (d,) = flow_frame(g.flow[f, p][None])
                s.errors[f"flow_along_s{k}"].append(float(ef @ d))
                s.flow_seq.append((cam.name, p, f, float(ef @ d)))
                s.errors[f"flow_across_s{k}"].append(float(ef[1] * d[0] - ef[0] * d[1]))
                left, right = g.span[f, p, 0] <= 0.0, g.span[f, p, 1] >= cam.width  # the image border cuts the person
                kind = flow_kind(tag, left or right)  # (``fit``'s flow_by_kind)
                s.errors[f"kflow_along_s{k}{kind}"].append(float(ef @ d))
                s.errors[f"kflow_across_s{k}{kind}"].append(float(ef[1] * d[0] - ef[0] * d[1]))
                if left != right:
                    gap = W[rr, 0] if left else cam.width - W[rr, 1]
                    s.border.append((int(right), float(gap), float(fl[rr, 0]), float(g.flow[f, p, 0]), float(speed[f, p]),
                                     float(clip[f, p]), cam.name, int(p), int(f)))
        used = set(match.values())
        for rr in range(len(W)):
            if rr in used:
                continue
            cu, cv = 0.5 * (W[rr, 0] + W[rr, 1]), 0.5 * (W[rr, 2] + W[rr, 3])
            pe = e[f]
            pw, ph = np.maximum(pe[:, 1] - pe[:, 0], 1.0), np.maximum(pe[:, 3] - pe[:, 2], 1.0)
            du, dv = (cu - 0.5 * (pe[:, 0] + pe[:, 1])) / pw, (cv - 0.5 * (pe[:, 2] + pe[:, 3])) / ph
            near = [p for p in people if hit[f, p] and abs(du[p]) <= 1.0 and abs(dv[p]) <= 1.0]
            part = [p for p in people if not hit[f, p] and speed[f, p] >= MOVING_PX_S and abs(du[p]) <= 1.0 and abs(dv[p]) <= 1.0]
            if near or part:  # a fragment of the nearest detected person, else a partial window
                p = min(near or part, key=lambda q: du[q] ** 2 + dv[q] ** 2)
                name = "frag" if near else "part"
                if near:
                    s.fragments += 1
                    s.fragment_ids.add((cam.name, int(tid[rr])))
                else:
                    s.partials += 1
                    s.partial_ids.add((cam.name, int(tid[rr])))
                    has_part[f, p] = True
                s.errors[f"{name}_du"].append(du[p])
                s.errors[f"{name}_dv"].append(dv[p])
                s.errors[f"{name}_w"].append((W[rr, 1] - W[rr, 0]) / pw[p])
                s.errors[f"{name}_h"].append((W[rr, 3] - W[rr, 2]) / ph[p])
            else:
                s.clutter += 1
                s.clutter_ids.add((cam.name, int(tid[rr])))
                s.errors["clutter_w"].append(W[rr, 1] - W[rr, 0])
                s.errors["clutter_h"].append(W[rr, 3] - W[rr, 2])
                s.errors["clutter_flow_u"].append(fl[rr, 0])
                s.errors["clutter_flow_v"].append(fl[rr, 1])
        for p in np.nonzero(window_of[f] >= 0)[0]:
            members[f].setdefault(int(window_of[f, p]), []).append(int(p))
        both = hit[f, iu] & hit[f, ju] & ok_all[f]
        for k in np.nonzero(both)[0]:
            _pair(s, cam.name, int(iu[k]), int(ju[k]), f, o_all[f, k], merged_with)
    missed = moving & ~hit
    s.partial_feat += list(zip(frac[missed].tolist(), head[missed].tolist()))
    s.partial_hit += has_part[missed].tolist()
    _window_ids(s, window_of, members, own)
    _candidates(s, cam.name, cand, lambda f, p: (frac[f, p], head[f, p], speed[f, p]), hit)


def _window_ids(s: DetectorStats, window_of, members, own):
    """Restarts (a person's own window in consecutive frames under two ids) and swaps (a merged
    window splits and its id stays with someone other than the person whose window it was)."""
    F, P = window_of.shape
    owner: dict[int, int] = {}
    for f in range(F):
        if f:
            for p in range(P):
                if own[f, p] and own[f - 1, p]:
                    s.continuing += 1
                    s.restarts += int(window_of[f, p] != window_of[f - 1, p])
            for tid, mem in members[f - 1].items():
                if len(mem) < 2 or tid not in owner:
                    continue
                now = [p for p in mem if own[f, p]]
                if len(now) == len(mem) and len({int(window_of[f, p]) for p in now}) == len(now):
                    s.splits += 1
                    s.swaps += int(window_of[f, owner[tid]] != tid)
        for tid, mem in members[f].items():
            if len(mem) == 1:
                owner[tid] = mem[0]


def _measure_floor(s: DetectorStats, cam, g, frac, traj, det):
    xy, speed, clip = floor_state(cam, g, traj)
    cand = g.near.copy()
    F, P = cand.shape
    inside = np.ones((F, P), bool)
    if cam.region is not None:
        x0, y0, x1, y1 = cam.region
        m = REGION_MARGIN_M
        inside = (xy[..., 0] >= x0 + m) & (xy[..., 0] < x1 - m) & (xy[..., 1] >= y0 + m) & (xy[..., 1] < y1 - m)
    # the camera reports only its own tile: someone standing outside it is not reported by it (not
    # missed, not merged), so merges are judged between people inside the tile only (counting the
    # unreported neighbour across the tile's edge as merged was most of the "merges" measured)
    reportable = cam.in_region(xy)
    by_frame = _frames(det, cam, F)
    hit, own = np.zeros((F, P), bool), np.zeros((F, P), bool)
    iu, ju = np.triu_indices(P, 1)
    reach = SILHOUETTE_EDGES[-2]
    gap = silhouette_pairs(g, reach) if P > 1 else np.zeros((F, 0))
    pair_index = {(int(i), int(j)): k for k, (i, j) in enumerate(zip(iu, ju))}
    # nearness among people in the camera's view (the sampler: among those it detected)
    nearest = nearest_gap(np.where(cand[:, iu] & cand[:, ju], gap, INF), P) if P > 1 else np.full((F, P), INF)
    s.frames += F
    E = np.full((F, P, 2), np.nan)  # error of each unmerged detection
    state = np.zeros((F, P, 2), bool)  # its (head cut, near)
    for f in range(F):
        d = by_frame.get(f)
        D = d[["x", "y"]].to_numpy(float) if d is not None else np.zeros((0, 2))
        people = np.nonzero(cand[f])[0]
        dist = np.linalg.norm(D[:, None] - xy[f, people][None], axis=2)
        r, k = _assign(dist, dist <= FLOOR_GATE_M)
        match = {int(people[kk]): int(rr) for rr, kk in zip(r, k)}
        # an unreported person merged into a reported one's blob: their silhouettes within reach of
        # merging in the image, wherever the blob lies on the floor. The detector places a merged
        # blob on the member reaching farthest out (``merged_blob_member``), so in a file away from
        # the camera the other member stands a metre or more from it: counted as missed, those
        # merges (9.9 frames long on the rendered development recordings) were most of the long
        # rendered miss runs, and the merges measured were the short ones of people side by side
        merged_with = {}
        for p in people:
            if p in match or not reportable[f, p]:
                continue
            for q in match:
                if reportable[f, q] and gap[f, pair_index[(min(p, q), max(p, q))]] < reach:
                    merged_with[int(p)] = q
                    break
        for p in match:
            hit[f, p] = own[f, p] = True
        for p, q in merged_with.items():
            hit[f, p] = True
            own[f, p] = own[f, q] = False
        for p, rr in match.items():
            if own[f, p]:
                e = D[rr] - xy[f, p]
                # the blob's state (FLOOR_TABLES): head cut by the image border; near another person
                # in the camera's view (whether it reports them in its tile or not: their pixels touch the blob)
                near = nearest[f, p] < NEAR_GAP
                if clip[f, p] >= 0.999:  # every whole blob's, per floor axis: the declared floor noise
                    s.errors["xy"].extend(e.tolist())
                name = FLOOR_TABLES[(bool(clip[f, p] < 0.999), bool(near))]
                er, et = radial_frame(cam, xy[f, p])  # errors along and across the camera's radial direction
                s.errors[name + "_r"].append(float(e @ er))
                s.errors[name + "_t"].append(float(e @ et))
                s.errors[name + "_h"].append(float(g.head_shift[f, p]))  # the head-height shift (fit: head_gain)
                s.err_seq.append((cam.name, p, f, (float(e @ er), float(g.head_shift[f, p]), name)))
                E[f, p] = e
                state[f, p] = (clip[f, p] < 0.999, near)
        s.clutter += len(D) - len(match)
        both = hit[f, iu] & hit[f, ju] & reportable[f, iu] & reportable[f, ju]
        for k in np.nonzero(both)[0]:
            if gap[f, k] < reach:
                _pair(s, cam.name, int(iu[k]), int(ju[k]), f, gap[f, k], merged_with)
    _candidates(s, cam.name, cand & inside, lambda f, p: (frac[f, p], speed[f, p], clip[f, p]), hit)
    _measure_tail(s, cam, xy, E, state, hit, cand & reportable)


def _measure_tail(s: DetectorStats, cam, xy: np.ndarray, E: np.ndarray, state: np.ndarray, hit: np.ndarray, present: np.ndarray) -> None:
    """Drift episodes of a floor detector (``perception_model.Tail``): runs of consecutive frames
    in which a person's unmerged detection errs by more than TAIL_M. ``E`` (F, P, 2) errors (NaN:
    no unmerged detection) of people at ``xy`` (F, P, 2), ``state`` (F, P, 2) head cut and near, ``hit`` detected (or merged),
    ``present`` in the camera's view and tile."""
    F, P = E.shape[:2]
    size = np.linalg.norm(E, axis=-1)
    own = np.isfinite(size)
    s.floor_abs.extend(size[own].tolist())
    big = own & (size > TAIL_M)
    for p in range(P):
        f = 0
        while f < F:
            if not own[f, p]:
                f += 1
                continue
            s.tail_feat.append(tuple(float(v) for v in state[f, p]))
            s.tail_hit.append(bool(big[f, p]))
            if not big[f, p]:
                f += 1
                continue
            end = f
            while end + 1 < F and big[end + 1, p]:
                end += 1
            k = f + int(np.argmax(size[f:end + 1, p]))
            er, et = radial_frame(cam, xy[k, p])  # the peak's direction from the camera's radial one
            angle = float(np.arctan2(E[k, p] @ et, E[k, p] @ er))
            missed = bool(end + 1 < F and present[end + 1, p] and not hit[end + 1, p])
            s.tail_eps.append((*(bool(v) for v in state[f, p]), end - f + 1, float(size[k, p]), angle, missed))
            f = end + 1


# ----------------------------------------------------------------------------- fitting
def merge_stats(many: list[dict[str, DetectorStats]]) -> dict[str, DetectorStats]:
    """One DetectorStats per detector from several recordings' (sequence keys kept apart)."""
    out = {k: DetectorStats() for k in DETECTORS}
    for i, stats in enumerate(many):
        for k, s in stats.items():
            o = out[k]
            base = len(o.hit)
            o.feats += s.feats
            o.hit += s.hit
            o.runs += [((i, key), p, f, base + idx) for key, p, f, idx in s.runs]
            o.err_seq += [((i, key), p, f, v) for key, p, f, v in s.err_seq]
            o.flow_seq += [((i, key), p, f, v) for key, p, f, v in s.flow_seq]
            o.pair_runs += [((i, key), pair, f, len(o.pair_merged) + idx) for key, pair, f, idx in s.pair_runs]
            o.pair_feat += s.pair_feat
            o.pair_merged += s.pair_merged
            for name, v in s.errors.items():
                o.errors[name] += v
            o.label_ok += s.label_ok
            o.floor_abs += s.floor_abs
            o.tail_eps += s.tail_eps
            o.tail_feat += s.tail_feat
            o.tail_hit += s.tail_hit
            o.clutter_ids |= {(i, *c) for c in s.clutter_ids}
            o.fragment_ids |= {(i, *c) for c in s.fragment_ids}
            o.partial_ids |= {(i, *c) for c in s.partial_ids}
            o.partial_feat += s.partial_feat
            o.partial_hit += s.partial_hit
            o.border += [(*b[:6], (i, b[6]), *b[7:]) for b in s.border]
            for a in ("frames", "clutter", "clutter_unlabelled", "fragments", "fragment_labelled", "continuing", "restarts", "splits", "swaps",
                      "partials"):
                setattr(o, a, getattr(o, a) + getattr(s, a))
    return out


def non_increasing(p: np.ndarray, n: np.ndarray | None) -> np.ndarray:
    """Bin rates made non-increasing along the bins (``scipy.optimize.isotonic_regression``,
    weighted by the trials per bin plus one): P(merge) of a floor detector by silhouette gap. The
    merge's held uniform (``run_events``) then keeps two people merged while they stay at least as
    close as when they merged; a rate that rose again with the gap would split a merge in the
    middle of an encounter. On the overhead development recordings the closest bin's rate is
    lowered by the calibration scenes' pairs standing in file in unlike colours, which the
    rendered detector splits by colour and never merges."""
    from scipy.optimize import isotonic_regression

    w = (np.asarray(n, float) if n is not None else np.zeros(len(p))) + 1.0
    return np.clip(isotonic_regression(np.asarray(p, float), weights=w, increasing=False).x, 0.0, 1.0)


def mean_run(seqs: list[np.ndarray], flags: np.ndarray) -> float:
    """Mean length (frames) of the runs of True ``flags`` within each sequence of indices."""
    lengths = []
    for seq in seqs:
        run = 0
        for h in flags[seq]:
            if h:
                run += 1
            elif run:
                lengths.append(run)
                run = 0
        if run:
            lengths.append(run)
    return float(np.mean(lengths)) if lengths else 0.0


def miss_runs(s: DetectorStats, hits: np.ndarray | None = None) -> float:
    """Mean length (frames) of runs of misses within consecutive candidate frames."""
    hits = np.asarray(s.hit, bool) if hits is None else hits
    return mean_run(_sequences(s.runs), ~hits)


def merge_runs(s: DetectorStats, merged: np.ndarray | None = None) -> float:
    """Mean length (frames) of runs of merges within consecutive frames of a pair that could merge."""
    merged = np.asarray(s.pair_merged, bool) if merged is None else merged
    return mean_run(_sequences(s.pair_runs), merged)


def _sequences(runs: list) -> list[np.ndarray]:
    """Indices of each (recording, camera, person or pair) in unbroken runs of frames."""
    by: dict = defaultdict(list)
    for key, p, f, idx in runs:
        by[(key, p)].append((f, idx))
    out = []
    for items in by.values():
        items.sort()
        f = np.array([x[0] for x in items])
        idx = np.array([x[1] for x in items])
        for chunk in np.split(idx, np.nonzero(np.diff(f) > 1)[0] + 1):
            out.append(chunk)
    return out


def fit_run_rho(seqs: list[np.ndarray], p: np.ndarray, target: float, below: bool, seed: int = 0) -> float:
    """The copula correlation under which the sampler's events come in runs of mean length
    ``target``: the sampler compares each sequence's correlated uniforms with ``p``, and the event
    is the uniform falling below p (``below``: a merge) or not (a miss, where p = P(detect))."""
    if target == 0 or not len(p):
        return 0.0
    rng = np.random.default_rng(seed)
    best, best_err = 0.0, np.inf
    for rho in RHO_GRID:
        sims = []
        for _ in range(3):
            events = np.zeros(len(p), bool)
            for seq in seqs:
                events[seq] = (correlated_uniforms(rng, (len(seq), 1), rho)[:, 0] < p[seq]) == below
            sims.append(mean_run(seqs, events))
        err = abs(np.mean(sims) - target)
        if err < best_err:
            best, best_err = rho, err
    return best


def fit_run_stay(seqs: list[np.ndarray], p: np.ndarray, target: float, seed: int = 0) -> float:
    """The stay probability of ``run_events`` under which the sampler's events come in runs of
    mean length ``target`` on the measured sequences (``p``: P(event) per entry: of a merge, or
    1 - P(detect) of a miss). Mean simulated runs (3 draws) at each of ``RUN_GRID``'s stays; the
    answer interpolates between the two that bracket the target (the mean run grows with stay)."""
    if target == 0 or not len(p) or not seqs:
        return 0.0
    # the sequences end to end, one ineligible frame between two (a run never crosses it)
    order = np.concatenate([np.append(seq, -1) for seq in seqs])
    eligible = order >= 0
    pp = np.where(eligible, np.asarray(p, float)[np.maximum(order, 0)], 0.0)[:, None]
    rng = np.random.default_rng(seed)
    stays = np.array([1.0 - 1.0 / r for r in RUN_GRID])
    runs = []
    for stay in stays:
        sims = []
        for _ in range(3):
            ev = run_events(rng, pp, float(stay), eligible[:, None])[:, 0]
            events = np.zeros(len(p), bool)
            events[order[eligible]] = ev[eligible]
            sims.append(mean_run(seqs, events))
        runs.append(np.mean(sims))
    runs = np.maximum.accumulate(np.asarray(runs))
    if target <= runs[0]:
        return 0.0
    if target >= runs[-1]:
        return float(min(stays[-1], MAX_STAY))
    return float(min(np.interp(target, runs, stays), MAX_STAY))


def fit_miss_stay(s: DetectorStats, p: np.ndarray, seed: int = 0) -> float:
    """The miss uniform's stay probability: simulated mean miss run = the measured one (``p``: P(detect))."""
    return fit_run_stay(_sequences(s.runs), 1.0 - np.asarray(p, float), miss_runs(s), seed)


def whole_candidates(s: DetectorStats) -> np.ndarray:
    """(candidates,) bool: a bearing blob detector's candidates seen whole (its features: the
    seen share of the rays and the share of the image width inside the image, both 1)."""
    X, _ = s.arrays(2)
    return (X[:, 0] >= WHOLE) & (X[:, 1] >= WHOLE) if len(X) else np.zeros(0, bool)


def split_sequences(seqs: list[np.ndarray], mask: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each sequence cut into its unbroken stretches where ``mask`` holds and where it does not."""
    yes, no = [], []
    for seq in seqs:
        if not len(seq):
            continue
        for chunk in np.split(seq, np.nonzero(np.diff(mask[seq].astype(int)))[0] + 1):
            (yes if mask[chunk[0]] else no).append(chunk)
    return yes, no


def _split_misses(s: DetectorStats) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    """(sequences of candidates seen whole, the other sequences, misses (candidates,) bool) of a
    bearing blob detector."""
    whole, part = split_sequences(_sequences(s.runs), whole_candidates(s))
    return whole, part, ~np.asarray(s.hit, bool)


def miss_runs_split(s: DetectorStats) -> tuple[float, float]:
    """Mean miss runs (frames) of a bearing blob detector's candidates seen whole and of the rest."""
    whole, part, misses = _split_misses(s)
    return mean_run(whole, misses), mean_run(part, misses)


def fit_miss_stays(s: DetectorStats, p: np.ndarray, seed: int = 0) -> tuple[float, float]:
    """(miss_stay, miss_stay_whole) of a bearing blob detector: each stay's simulated mean miss
    run = the measured one, over the candidates partly seen and over those seen whole."""
    whole, part, misses = _split_misses(s)
    q = 1.0 - np.asarray(p, float)
    return (fit_run_stay(part, q, mean_run(part, misses), seed), fit_run_stay(whole, q, mean_run(whole, misses), seed))


def fit_merge_stay(s: DetectorStats, merge: Table, seed: int = 0) -> float:
    """The merge uniform's stay probability: simulated mean merge run = the measured one."""
    if not s.pair_merged:
        return 0.0
    return fit_run_stay(_sequences(s.pair_runs), merge(np.asarray(s.pair_feat, float)), merge_runs(s), seed)


def fit_rho(s: DetectorStats, p: np.ndarray, seed: int = 0) -> float:
    """The miss copula's correlation: simulated mean miss run = the measured one (``p``: P(detect))."""
    return fit_run_rho(_sequences(s.runs), p, miss_runs(s), False, seed)


def fit_merge_rho(s: DetectorStats, merge: Table, seed: int = 0) -> float:
    """The merge copula's correlation: simulated mean merge run = the measured one."""
    if not s.pair_merged:
        return 0.0
    p = merge(np.asarray(s.pair_feat, float))
    return fit_run_rho(_sequences(s.pair_runs), p, merge_runs(s), True, seed)


def normal_scores(v: np.ndarray) -> np.ndarray:
    """Normal scores of ``v``: the standard normal quantiles of its ranks (the Gaussian copula's
    view of a sample, whatever its marginal distribution)."""
    from scipy.special import ndtri
    from scipy.stats import rankdata

    return ndtri((rankdata(v) - 0.5) / len(v))


def lagged_products(keys, frames, x: np.ndarray, max_lag: int, min_pairs: int) -> np.ndarray:
    """c(L), L = 0..max_lag: the mean of x_i x_j over the pairs of entries L frames apart in one
    sequence (same key); NaN from the first lag with fewer than ``min_pairs`` pairs."""
    at = {(k, f): i for i, (k, f) in enumerate(zip(keys, frames))}
    out = np.full(max_lag + 1, np.nan)
    for L in range(max_lag + 1):
        pairs = np.array([(i, j) for (k, f), i in at.items() if (j := at.get((k, f + L))) is not None], int).reshape(-1, 2)
        if len(pairs) < min_pairs:
            break
        out[L] = float(np.mean(x[pairs[:, 0]] * x[pairs[:, 1]]))
    return out


def fit_err_rho(s: DetectorStats, head_gain: dict | None = None) -> float:
    """Lag-one correlation of a person's errors in consecutive frames, on normal scores (the
    Gaussian copula the sampler uses); 0 without enough pairs. Floor errors are (radial error,
    head shift, table): their correlation is that of what the tables draw, the radial error less
    the fitted share of the head shift (``head_gain``)."""
    if len(s.err_seq) < 30:
        return 0.0
    seq = sorted(s.err_seq, key=lambda r: (str(r[0]), r[1], r[2]))
    gain = head_gain or {}
    v = np.array([r[3][0] - gain.get(r[3][2], 0.0) * r[3][1] if isinstance(r[3], tuple) else r[3] for r in seq], float)
    z = normal_scores(v)
    same = np.array([str(a[0]) == str(b[0]) and a[1] == b[1] and b[2] == a[2] + 1 for a, b in zip(seq[:-1], seq[1:])])
    if same.sum() < 30:
        return 0.0
    r = float(np.corrcoef(z[:-1][same], z[1:][same])[0, 1])
    return float(np.clip(r, 0.0, 0.999)) if np.isfinite(r) else 0.0


MIN_EDGE_PAIRS = 30  # windows of a kind and height bin below which its edges' correlation is 0


def edge_pairs(s: DetectorStats, tag: str, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(top, bottom) edge errors of the own windows of tables ``tag`` ("" plain, "_crowded") in
    height bin ``k``: each window files its four errors together (``_measure_windows``), so
    the two tables' entries pair by index."""
    return tuple(np.asarray(s.errors.get(height_table(name + tag, k), ()), float) for name in ("v_top", "v_bottom"))


def score_corr(x: np.ndarray, y: np.ndarray) -> float:
    """The correlation of x's and y's normal scores (the Gaussian copula's correlation, whatever
    the marginals); 0 under ``MIN_EDGE_PAIRS`` pairs."""
    if len(x) < MIN_EDGE_PAIRS:
        return 0.0
    r = float(np.corrcoef(normal_scores(x), normal_scores(y))[0, 1])
    return float(np.clip(r, -0.99, 0.99)) if np.isfinite(r) else 0.0


def fit_edge_corr(s: DetectorStats) -> EdgeCorr:
    """The windows' top and bottom edge errors' correlation (``EdgeCorr``) per kind of window
    and height bin (``analytic_detectors.EDGE_HEIGHT_PX``): the normal scores' correlation of
    the own windows' errors (``score_corr``)."""
    return EdgeCorr(EDGE_HEIGHT_PX, {kind: tuple(score_corr(*edge_pairs(s, tag, k)) for k in range(len(EDGE_HEIGHT_PX) + 1))
                                     for kind, tag in EDGE_CORR_KINDS.items()})


FLOW_PERSIST_LAGS = 20  # frames: lags of the flow errors' autocorrelation that flow_persist is fitted to
MIN_FLOW_PAIRS = 200  # pairs of consecutive flow errors below which no flow_persist is fitted


def fit_flow_persist(s: DetectorStats) -> tuple[float, float, float] | None:
    """(w, a_slow, a_fast) of the flow errors' persistence (windows): their normal scores'
    autocorrelation over lags 1..FLOW_PERSIST_LAGS frames (pairs in one camera's sequence of one
    person) fitted by w a_slow^L + (1 - w) a_fast^L, the autocorrelation of the two-timescale
    Gaussian copula the sampler draws (``perception_model.two_timescale_normals``). The rendered
    flow detector's errors have a slow part (long shortfalls of a fast, textureless person)
    that one lag-one correlation (``err_rho``) decays far too fast for. None: too few pairs."""
    if len(s.flow_seq) < MIN_FLOW_PAIRS:
        return None
    from scipy.optimize import curve_fit

    z = normal_scores(np.array([r[3] for r in s.flow_seq], float))
    c = lagged_products([str((r[0], r[1])) for r in s.flow_seq], [r[2] for r in s.flow_seq], z, FLOW_PERSIST_LAGS, MIN_FLOW_PAIRS)[1:]
    rho = c[: np.flatnonzero(np.isnan(c))[0]] if np.isnan(c).any() else c
    if len(rho) < 3:
        return None
    lags = np.arange(1, len(rho) + 1)
    (w, a_s, a_f), _ = curve_fit(lambda x, w, a, b: w * a**x + (1.0 - w) * b**x, lags, np.asarray(rho), p0=(0.5, 0.9, 0.5),
                                 bounds=([0.0, 0.0, 0.0], [1.0, 0.999, 0.999]))
    if a_s < a_f:  # name the slower part a_slow
        w, a_s, a_f = 1.0 - w, a_f, a_s
    return float(w), float(a_s), float(a_f)


TAIL_EDGES = [[-INF, 0.5, INF], [-INF, 0.5, INF]]  # head cut, near (0 or 1)
MIN_TAIL_EPISODES = 5


def fit_tail(s: DetectorStats) -> Tail | None:
    """The drift episodes of a floor detector (``perception_model.Tail``) from the measured ones
    (``_measure_tail``): P(start | head cut, near) per unmerged detection outside an episode
    (shrunk towards the pooled rate), the mean length, the peaks' and angles' quantiles, the
    share followed by a miss. None with fewer than MIN_TAIL_EPISODES episodes."""
    if len(s.tail_eps) < MIN_TAIL_EPISODES:
        return None
    X = np.asarray(s.tail_feat, float).reshape(-1, 2)
    start = Table.fit(TAIL_EDGES, list(X.T), np.asarray(s.tail_hit, bool))
    eps = np.asarray([e[2:] for e in s.tail_eps], float)  # frames, peak, angle, missed
    return Tail(start, frames=float(eps[:, 0].mean()), size=Quantiles(np.quantile(eps[:, 1], LEVELS)),
                angle=Quantiles(np.quantile(eps[:, 2], LEVELS)), miss=float(eps[:, 3].mean()))


def tail_share(s: DetectorStats) -> float:
    """Share of a floor detector's unmerged detections off by more than TAIL_M (NaN: none)."""
    return float(np.mean(np.asarray(s.floor_abs) > TAIL_M)) if s.floor_abs else np.nan


EDGE_NAMES = ("u_left", "u_right", "v_top", "v_bottom")  # the windows' edge-error tables (and their _crowded, _cut, _h<bin>)


def height_of(name: str) -> tuple[str, int] | None:
    """(the edge table over every height, the bin) of a per-height edge table's ``name``
    (``analytic_detectors.height_table``); None for any other table."""
    base, _, k = name.rpartition("_h")
    return (base, int(k)) if base.startswith(EDGE_NAMES) and k.isdigit() else None


# a rendered window's cut edge farther than this from the image border stops short of it
# (``tp_joint.BORDER_PX``, the tracker's own test of a window reaching the border)
BORDER_SHORT_PX = 0.5


def fit_border(s: DetectorStats) -> tuple[Border | None, dict[str, Quantiles]]:
    """(``Border``, its error tables) from the border-cut people's own windows (``s.border``):
    P(short) by side and the person's image velocity u, the stay that gives the measured mean run
    of short windows, and per side the gap's quantiles and the short windows' flow u as a gain on
    the person's (least squares) and the rest's quantiles; (None, {}) without such windows."""
    if not s.border:
        return None, {}
    side, gap, flow, motion = (np.asarray([b[i] for b in s.border], float) for i in range(4))
    short = gap > BORDER_SHORT_PX
    table = Table.fit(BORDER_EDGES, [side, motion], short)
    seqs = _sequences([(b[6], b[7], b[8], i) for i, b in enumerate(s.border)])
    stay = fit_run_stay(seqs, table(side, motion), mean_run(seqs, short))
    gains, errors = [], {}
    for k, name in enumerate(("l", "r")):
        on = short & (side == k)
        gain = float(np.polyfit(motion[on], flow[on], 1)[0]) if on.sum() >= 30 and motion[on].std() > 0 else 1.0
        gains.append(gain)
        errors[f"border_gap_{name}"] = Quantiles.fit(gap[on], fallback=Quantiles.gaussian(0.0, 6.0))
        errors[f"border_flow_{name}"] = Quantiles.fit(flow[on] - gain * motion[on])
    return Border(table, stay, tuple(gains)), errors


def fit(stats: dict[str, DetectorStats], fitted_on: list[str], crowded: bool = True, flow_persist: bool = False,
        by_height: bool = False, edge_corr: bool = False, border: bool = False, flow_by_kind: bool = False) -> PerceptionModel:
    """A perception model from rendered statistics (``merge_stats`` of several recordings);
    ``crowded`` False: the windows' edge errors in one table each, crowded or not (no
    ``*_crowded`` tables, as the bundled eighth and tenth fits); ``flow_persist``: the windows'
    flow errors persist on two time scales (``fit_flow_persist``; the eleventh fit, not bundled);
    ``by_height``: the windows' edge errors (plain and crowded) also in tables per bin of the
    person's image height (``analytic_detectors.EDGE_HEIGHT_PX``; a bin with under 30 windows
    takes its edge's table over every height; the thirteenth fit, not bundled); ``edge_corr``: the
    windows' top and bottom edge errors correlated by kind of window and height bin
    (``fit_edge_corr``; the fourteenth fit, not bundled); ``border``: windows of a person cut by
    the image border stop short of it in runs, their flow falling behind (``fit_border``; the
    fifteenth fit); ``flow_by_kind``: the windows' flow errors in tables per kind of window too
    (``flow_along_s<k>`` of plain windows, ``..._crowded``, ``..._cut``, ``..._border``:
    ``analytic_detectors.flow_kind``; a kind's bin with under 30 windows takes the table of every
    kind; the sixteenth fit)."""
    from .perception_flow import FlowParams

    out = {}
    for k in DETECTORS:
        s = stats[k]
        X, hit = s.arrays(len(DETECT_EDGES[k]))
        detect = Table.fit(DETECT_EDGES[k], list(X.T), hit)
        p = detect(*X.T) if len(X) else np.zeros(0)
        pair_edges = SILHOUETTE_EDGES if k in ("overhead", "privacy") else OVERLAP_EDGES
        merge = Table.fit([pair_edges], [np.asarray(s.pair_feat, float)], np.asarray(s.pair_merged, bool))
        if k in ("overhead", "privacy"):
            merge.p = non_increasing(merge.p, merge.n)
        errors, head_gain = {}, {}
        for name in FLOOR_TABLES.values() if k in ("overhead", "privacy") else ():
            r, h = np.asarray(s.errors.get(name + "_r", ()), float), np.asarray(s.errors.get(name + "_h", ()), float)
            if len(r) >= 30:
                # the radial error's share of the head-height shift, by least squares; the
                # table then holds the rest
                head_gain[name] = float(r @ h / (h @ h)) if h @ h > 0 else 0.0
                errors[name + "_r"] = Quantiles.fit(r - head_gain[name] * h)
        samples = dict(s.errors)
        by_kind = {n: samples.pop(n) for n in list(samples) if n.startswith("kflow_")}  # the flow errors per kind of window
        by_h = {}  # the edge tables per height bin: name -> its table over every height
        for name, (base, hk) in [(n, height_of(n)) for n in list(samples) if height_of(n)]:
            if not by_height:
                samples.pop(name)
            elif crowded or not base.endswith("_crowded"):
                by_h[name] = base
            else:  # pooled: a crowded bin's windows join the plain bin's
                base = base[: -len("_crowded")]
                samples[height_table(base, hk)] = list(samples.get(height_table(base, hk), ())) + list(samples.pop(name))
                by_h[height_table(base, hk)] = base
        if not crowded:
            for name in [n for n in samples if n.endswith("_crowded")]:
                plain = name[: -len("_crowded")]
                samples[plain] = list(samples.get(plain, ())) + list(samples.pop(name))
        for name, v in samples.items():
            if name in errors or name in by_h or name in {t + "_h" for t in FLOOR_TABLES.values()}:  # (not the windows' frag_h, clutter_h)
                continue
            errors[name] = Quantiles.fit(np.asarray(v, float), fallback=errors.get("u"))
        for name, base in by_h.items():
            errors[name] = Quantiles.fit(np.asarray(samples[name], float), fallback=errors.get(base))
        if "flow_along_s0" in errors:  # a speed bin with too few windows takes the next slower bin's tables
            for b in range(1, len(FLOW_SPEED_EDGES) + 1):
                for axis in ("along", "across"):
                    if len(s.errors.get(f"flow_{axis}_s{b}", ())) < 30:
                        errors[f"flow_{axis}_s{b}"] = errors[f"flow_{axis}_s{b - 1}"]
        if flow_by_kind and "flow_along_s0" in errors:  # each kind's table per speed bin; too few windows: the bin's table of every kind
            for b in range(len(FLOW_SPEED_EDGES) + 1):
                for axis in ("along", "across"):
                    pooled = errors[f"flow_{axis}_s{b}"]
                    for tag in FLOW_KINDS:
                        errors[f"flow_{axis}_s{b}{tag}"] = Quantiles.fit(np.asarray(by_kind.get(f"kflow_{axis}_s{b}{tag}", ()), float),
                                                                         fallback=pooled)
        if k in ("horizontal", "oblique") and "u_clip" not in errors and "u" in errors:
            errors["u_clip"] = errors["u"]
        for name in FLOOR_TABLES.values():  # too few blobs in a state: they take another state's tables (floor_table)
            if len(s.errors.get(name + "_r", ())) < 30:
                errors.pop(name + "_r", None), errors.pop(name + "_t", None)
        border_model = None
        if k == "windows" and border:
            border_model, border_errors = fit_border(s)
            errors.update(border_errors)
        n_clutter_ids = max(len(s.clutter_ids), 1)
        # the oblique blob detector: people seen whole miss for short runs of their own, the partly
        # hidden for as long as they stay so (one stay for both made the first run for seconds)
        stays = fit_miss_stays(s, p) if k == "oblique" else (fit_miss_stay(s, p), None)
        out[k] = DetectorModel(
            detect=detect, miss_stay=stays[0], miss_stay_whole=stays[1], err_rho=fit_err_rho(s, head_gain), head_gain=head_gain, merge=merge,
            flow_persist=fit_flow_persist(s) if k == "windows" and flow_persist else None,
            merge_stay=fit_merge_stay(s, merge), errors=errors,
            label=(sum(s.label_ok) + 1) / (len(s.label_ok) + 1) if s.label_ok else 1.0,
            clutter=s.clutter / s.frames if s.frames else 0.0,
            clutter_frames=max(1.0, s.clutter / n_clutter_ids) if k == "windows" else 1.0,
            clutter_unlabelled=s.clutter_unlabelled / s.clutter if s.clutter else 0.0,
            fragment=s.fragments / max(int(np.sum(hit)), 1),
            fragment_frames=max(1.0, s.fragments / max(len(s.fragment_ids), 1)) if k == "windows" else 1.0,
            partial=Table.fit(PARTIAL_EDGES, s.partial_columns(), np.asarray(s.partial_hit, bool)) if k == "windows" and s.partials else None,
            partial_frames=max(1.0, s.partials / max(len(s.partial_ids), 1)),
            seen_frames=WINDOW_SEEN_FRAMES if k == "windows" else 1,
            fragment_label=s.fragment_labelled / s.fragments if s.fragments and k in ("horizontal", "oblique") else 1.0,
            restart=s.restarts / s.continuing if s.continuing else 0.0,
            swap=(s.swaps + 1) / (s.splits + 2),
            max_gap=FlowParams().max_missed if k == "windows" else 0,
            tail=fit_tail(s) if k in ("overhead", "privacy") else None,
            edge_heights=list(EDGE_HEIGHT_PX) if k == "windows" and by_h else None,
            edge_corr=fit_edge_corr(s) if k == "windows" and edge_corr else None,
            border=border_model,
        )
    return PerceptionModel(out, list(fitted_on))


def correct(model: PerceptionModel, rendered: dict[str, DetectorStats], analytic: dict[str, DetectorStats],
            max_step: float = 2.0) -> PerceptionModel:
    """One step of fitting by simulation: each rate the measurement reports (detection and merge
    per bin, fragments, false detections, id restarts, swaps at a split, and the mean runs of
    merges and misses through ``merge_stay`` and ``miss_stay``) is scaled by rendered / analytic, as measured on analytic recordings simulated with ``model`` on the same scenes and
    seeds. Counting alone double-counts what the model's own mechanisms cause (a merged window
    splitting also changes ids; a missed person beside a detected one looks merged), so the
    counted rates are corrected until the analytic statistics match the rendered ones. Steps are
    limited to ``max_step`` either way; bins without data on either side are left alone."""
    import copy

    out = copy.deepcopy(model)

    def ratio(r: float, a: float) -> float:
        if not (np.isfinite(r) and np.isfinite(a)) or a <= 0:
            return 1.0
        return float(np.clip(r / a, 1 / max_step, max_step))

    def rate(n: float, d: float) -> float:
        return n / d if d else np.nan

    def bin_scale(edges, xr, hr, xa, ha):
        """Per-bin rendered / analytic rate of a table over ``edges`` (features xr, xa; events hr,
        ha), limited to ``max_step``; 1 where either side has fewer than 20 samples or the
        analytic rate is 0. Also returns the rendered table (its counts per bin)."""
        tr = Table.fit(edges, xr, np.asarray(hr, bool), strength=1e-9)
        ta = Table.fit(edges, xa, np.asarray(ha, bool), strength=1e-9)
        ok = (tr.n >= 20) & (ta.n >= 20) & (ta.p > 0)
        return np.where(ok, np.clip(tr.p / np.where(ok, ta.p, 1.0), 1 / max_step, max_step), 1.0), tr

    for k in DETECTORS:
        r, a, m = rendered[k], analytic[k], out[k]
        if not r.hit or not a.hit:
            continue
        edges = DETECT_EDGES[k]
        (Xr, hr), (Xa, ha) = r.arrays(len(edges)), a.arrays(len(edges))
        scale, _ = bin_scale(edges, list(Xr.T), hr, list(Xa.T), ha)
        m.detect.p = np.clip(m.detect.p * scale, 0.0, 1.0)
        pair_edges = m.merge.edges
        if r.pair_feat and a.pair_feat:
            scale, mr = bin_scale(pair_edges, [np.asarray(r.pair_feat, float)], r.pair_merged, [np.asarray(a.pair_feat, float)], a.pair_merged)
            m.merge.p = np.clip(m.merge.p * scale, 0.0, 1.0)
            if k in ("overhead", "privacy") and m.merge_stay is not None:
                m.merge.p = non_increasing(m.merge.p, mr.n)  # weighted by the rendered pair-frames per bin
            # merge runs: the mean run grows with 1 / (1 - stay) (1 / (1 - merge_rho) for an AR(1)
            # model); scale 1 - stay by analytic / rendered
            run_r, run_a = merge_runs(r), merge_runs(a)
            if run_r > 0 and run_a > 0:
                if m.merge_stay is not None:
                    m.merge_stay = float(np.clip(1.0 - (1.0 - m.merge_stay) * ratio(run_a, run_r), 0.0, MAX_STAY))
                else:
                    m.merge_rho = float(np.clip(1.0 - (1.0 - m.merge_rho) * ratio(run_a, run_r), 0.0, 0.998))
        # miss runs likewise (models with miss_stay only: misses the model's other mechanisms make
        # shorten or lengthen the measured runs)
        if m.miss_stay_whole is not None:  # the two stays, each on its own candidates' runs
            (whole_r, part_r), (whole_a, part_a) = miss_runs_split(r), miss_runs_split(a)
            if whole_r > 0 and whole_a > 0:
                m.miss_stay_whole = float(np.clip(1.0 - (1.0 - m.miss_stay_whole) * ratio(whole_a, whole_r), 0.0, MAX_STAY))
            run_r, run_a = part_r, part_a
        else:
            run_r, run_a = miss_runs(r), miss_runs(a)
        if m.miss_stay is not None and run_r > 0 and run_a > 0:
            m.miss_stay = float(np.clip(1.0 - (1.0 - m.miss_stay) * ratio(run_a, run_r), 0.0, MAX_STAY))
        if m.tail is not None:  # episodes cut short by misses and merges, or added by the tables' own tails
            m.tail.start.p = np.clip(m.tail.start.p * ratio(tail_share(r), tail_share(a)), 0.0, 1.0)
        m.fragment *= ratio(rate(r.fragments, sum(r.hit)), rate(a.fragments, sum(a.hit)))
        if m.partial is not None and r.partial_hit and a.partial_hit:  # per bin, as detection
            feats = [x.partial_columns()[: len(m.partial.edges)] for x in (r, a)]  # (a one-feature table: the axis rays')
            scale, _ = bin_scale(m.partial.edges, feats[0], r.partial_hit, feats[1], a.partial_hit)
            m.partial.p = np.clip(m.partial.p * scale, 0.0, 1.0)
        m.clutter *= ratio(rate(r.clutter, r.frames), rate(a.clutter, a.frames))
        m.restart = float(np.clip(m.restart * ratio(rate(r.restarts, r.continuing), rate(a.restarts, a.continuing)), 0, 1))
        if r.splits >= 10 and a.splits >= 10:
            m.swap = float(np.clip(m.swap * ratio(rate(r.swaps, r.splits), rate(a.swaps, a.splits)), 0, 1))
    out.fitted_on = list(model.fitted_on)
    return out


# ----------------------------------------------------------------------------- summaries
SUMMARY_COLUMNS = ("candidates", "detection_rate", "miss_run", "err_median", "err_p90", "edge_tb_corr", "tail_share", "err_p999", "merge_rate", "merge_run", "fragment_rate", "partial_rate",
                   "id_restart_rate", "split_swap_rate", "label_accuracy", "clutter_per_frame")


def summary(stats: dict[str, DetectorStats]) -> pd.DataFrame:
    """One row per detector of the statistics calibrate-sensing compares (NaN where none)."""
    rows = []
    for k in DETECTORS:
        s = stats[k]
        err_name = "xy" if k in ("overhead", "privacy") else "u"
        e = np.abs(np.asarray(s.errors.get(err_name, []), float))
        rows.append({
            "detector": k,
            "candidates": len(s.hit),
            "detection_rate": np.mean(s.hit) if s.hit else np.nan,
            "miss_run": miss_runs(s) if s.hit else np.nan,
            "err_median": np.median(e) if len(e) else np.nan,
            "err_p90": np.quantile(e, 0.9) if len(e) else np.nan,
            # floor detectors: |error| of unmerged detections (m), share above TAIL_M and 99.9 % quantile
            "tail_share": tail_share(s),
            "err_p999": np.quantile(s.floor_abs, 0.999) if s.floor_abs else np.nan,
            "merge_rate": np.mean(s.pair_merged) if s.pair_merged else np.nan,
            "merge_run": merge_runs(s) if s.pair_merged else np.nan,
            "fragment_rate": s.fragments / max(int(np.sum(s.hit)), 1) if s.hit else np.nan,
            "partial_rate": np.mean(s.partial_hit) if s.partial_hit else np.nan,
            "id_restart_rate": s.restarts / s.continuing if s.continuing else np.nan,
            "split_swap_rate": s.swaps / s.splits if s.splits else np.nan,
            "label_accuracy": np.mean(s.label_ok) if s.label_ok else np.nan,
            "clutter_per_frame": s.clutter / s.frames if s.frames else np.nan,
            # windows: how much the top and bottom edges' errors move together (plain windows of
            # people above the first height bin, 60 px or more, ``score_corr``)
            "edge_tb_corr": score_corr(*(np.concatenate(v) for v in zip(*(edge_pairs(s, "", k) for k in range(1, len(EDGE_HEIGHT_PX) + 1)))))
            if k == "windows" else np.nan,
        })
    return pd.DataFrame(rows)
