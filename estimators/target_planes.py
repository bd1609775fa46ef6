"""``target_planes``: optical-flow person tracking by multiple cameras (Tsutsui, Miura, Shirai).

Input: the ``boxes`` table of the oblique cameras (each camera's own tracking windows with their
horizontal centroid u, edges, top/bottom rows and mean image flow, px and px/s) and each camera's
3x4 projection ``P``. The ``bearings`` table's colour labels are *not* used: telling the target
from a look-alike mover by colour would make the paper's velocity discrimination moot, so people
are told apart by geometry and image velocity alone.

Per frame (all cameras at their capture times), for each target:

1. predict X = X + V dt (V: 3-D velocity, vertical part 0);
2. per camera, the estimated window (section 3.3: the person model - a vertical cylinder of
   ``height`` and ``radius`` - projected at the prediction, or over the whole target area) and
   the predicted image velocity (eq. 7);
3. per camera, its state (``tp_tracker``): a tracking camera keeps its tracker's window unless
   the reliability tests of section 4 fail; a lost or unreliable camera searches the estimated
   window for a window with the predicted image velocity, separate from other movers;
4. position from the reliable tracking cameras: the least-squares intersection of their target
   planes (eqs. 3-6, refused for near-parallel planes), checked against each camera's own
   target area; with one camera (or near-parallel planes) the single-camera target area
   (section 3.2), intersected with the other tracking cameras' areas (section 5), and the point
   of the target plane in it nearest the prediction;
5. velocity from the tracking cameras' mean flows (eq. 7, least squares; W = 0 with one camera).

The target is chosen by hand as in the paper: ``initial_xy`` (its floor position at the first
frame, m) or ``initial_window`` (``[camera, u_left, u_right, v_top, v_bottom]`` at the first
frame). With ``multi_person = true`` every mover is tracked at once (section 6's future work):
targets start from unclaimed windows (``tp_initiate``) and compete for windows per camera
(``scipy.optimize.linear_sum_assignment``); two targets on one window make it unreliable for both.

``run`` returns the tracks and a per-frame, per-camera status table (tracking / lost /
unreliable and why); ``estimate`` returns the tracks only.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from trackroom.recording import Calibration, Observations

from . import tp_geometry as geo
from .base import Estimator, EstimatorError, check_tracks, param, register
from .tp_frames import CameraBoxes, frame_times, split_boxes
from .tp_initiate import propose
from .tp_joint import JointTrack, JointTracker
from .tp_tracker import LOST, TRACKING, UNRELIABLE, CameraState, Target, TargetUpdater, width_ratio

STATUS_COLUMNS = ["t", "track_id", "camera", "status", "reason", "window"]


@dataclass
class TargetPlanesResult:
    """``tracks``: t, track_id, x, y, vx, vy (+ ``n_cameras``: reliable tracking cameras used,
    ``mode``: planes / area / predicted); ``status``: t, track_id, camera, status, reason, window (the camera's own track id it
    follows while tracking)."""

    tracks: pd.DataFrame
    status: pd.DataFrame


@register
class TargetPlanes(Estimator):
    name = "target_planes"
    description = "Tsutsui et al.: target-plane intersection of oblique cameras' flow windows, with occlusion and overlap handling"
    requires = ("boxes",)

    @dataclasses.dataclass
    class Config:
        initial_xy: list[float] | None = param(None, "the target's floor position [x, y] at the first frame, m (the "
                                                     "target is chosen by hand: this, initial_window or multi_person)")
        initial_window: list | None = param(None, "the target's window at the first frame: [camera, u_left, u_right, "
                                                  "v_top, v_bottom], camera name and px")
        multi_person: bool = param(False, "track every mover at once (beyond the paper): no initial_xy or "
                                          "initial_window needed")
        design: str = param("joint", "joint: every mover a track, each camera's windows explained jointly "
                                     "(tp_joint); rules: the single-target tracker with section 4's rules")
        accel_sigma: float = param(1.0, "joint: white-acceleration noise of the walkers, m/s^2/sqrt(Hz) (walkers "
                                        "stop, start and turn at waypoints: about 1 m/s of change within 1 s)")
        stop_tau: float = param(1.0, "joint: a track no window explains slows as exp(-t / tau), s (it has most "
                                     "likely stopped: standing people make no flow window)")
        edge_sigma_frac: float = param(0.1, "joint: spread of a window's edge about the projected cylinder's, fraction "
                                            "of the person's image width (rendered windows, development seed 100)")
        birth_sigma_v: float = param(0.5, "joint: velocity uncertainty of a new track, m/s (eq. 7 from two windows' "
                                          "flows)")
        hold_s: float = param(6.0, "joint: a confirmed track no window explains is kept this long, s (the scenes' "
                                   "walkers stop for up to 5 s at a waypoint)")
        split_merged: bool = param(True, "a window holding the target and a tracked neighbour merged gives the "
                                         "target its side's part (TargetUpdater.split_window)")
        split_min_sep: float = param(0.25, "split_merged applies when the two predicted centres are this far apart "
                                           "in the image, estimated-window widths")
        crowd_overlap: float | None = param(0.25, "a camera where two targets' estimated windows overlap by this share "
                                                  "of the narrower is left out for both, fraction; none: off")
        jump_gate: bool = param(True, "an estimate farther from the prediction than the search radius leaves out the "
                                      "straying camera")
        exclude_neighbours: bool = param(True, "section 4.1 literally: a camera track id once seen beside the target "
                                               "is never the target")
        track_others: bool = param(True, "single target: also track the other movers (4.1 taken to 3-D), so they "
                                         "hold their own windows")
        height: float = param(1.8, "person model: cylinder height, m (the tallest person's, with their gait bob)")
        radius: float = param(0.2, "person model: cylinder radius, m")
        min_plane_angle_deg: float = param(12.0, "target planes closer than this to parallel are not intersected, "
                                                 "degrees")
        width_ratio_threshold: float = param(0.5, "eq. 8 width-ratio threshold (w - w_c) / w_c above which a window "
                                                  "holds more than one person (the paper: 1; rendered flow windows of "
                                                  "isolated walkers stay <= 0.10 in 99 % of frames, two merged reach "
                                                  "0.7-1.3)")
        position_tol: float = param(1.0, "section 4.3 position test: |u - u_c| allowed, estimated-window widths")
        search_margin: float = param(0.5, "a lost camera's estimated window is widened by this when searching, "
                                          "window widths")
        overlap_gap: float = param(0.0, "windows closer than this overlap (section 4.1), window widths")
        neighbour_span: float = param(1.0, "width of the search areas beside the target (Fig. 8), window widths")
        rejoin_width_ratio: float = param(0.35, "an overlapped window is the target alone again below this eq. 8 "
                                                "width ratio")
        flow_tol_px: float = param(6.0, "image velocity similarity: |v - v_pred| <= flow_tol_px + flow_tol_rel "
                                        "|v_pred| (+ 3 sigma of the flow noise), px/s")
        flow_tol_rel: float = param(0.4, "relative part of that tolerance, fraction of |v_pred|")
        flow_height_fraction: float = param(0.5, "height of the flow region's centroid, fraction of the person "
                                                 "model's height")
        flow_window: int = param(5, "frames of a camera track over which its flow is averaged")
        mover_flow_px: float = param(8.0, "a window with less mean flow is no mover, px/s")
        velocity_smoothing: float = param(0.6, "weight of the new eq. 7 velocity against the previous one, in [0, 1]")
        velocity_prior_sigma: float = param(0.3, "the previous velocity as a prior of the eq. 7 least squares (per "
                                                 "frame), m/s")
        flow_model_sigma: float = param(3.0, "flow error beyond the calibrated noise (a region's mean flow vs its "
                                             "centre's motion), px/s")
        max_speed: float = param(3.0, "largest speed of a person, m/s")
        area_margin: float = param(0.05, "allowance on target areas, m")
        window_margin_px: float = param(1.0, "allowance on windows, px (plus 3 sigma of the calibrated window noise)")
        consistency_margin: float = param(0.15, "a plane intersection may lie this far outside a camera's target "
                                                "area, m")
        intersect_areas: bool = param(True, "section 5: intersect the target areas of all tracking cameras")
        init_radius: float = param(0.5, "uncertainty of the hand-given initial position, m")
        sigma_planes: float = param(0.25, "search radius after a multi-camera estimate, m")
        sigma_growth: float = param(0.5, "growth of the search radius while no camera tracks, m/s")
        sigma_max: float = param(1.5, "largest search radius while no camera tracks, m")
        lost_velocity_tau: float = param(1.0, "while no camera tracks, the velocity decays as exp(-t / tau), s (a "
                                              "target that vanishes from every view at once has most likely stopped)")
        sigma_v_tracked: float = param(0.1, "velocity uncertainty while a camera tracks (eq. 7 from mean flows), m/s")
        accel_max: float = param(1.0, "growth of the velocity uncertainty while no camera tracks (a walker stopping, "
                                      "starting or turning), m/s^2")
        area_gate_max: float = param(0.5, "at most this much of a single-camera area's extent widens the "
                                          "re-acquisition gate, m")
        confirm_single_frames: int = param(3, "a re-acquisition no second camera can confirm must persist this many "
                                              "frames")
        init_min_cameras: int = param(2, "multi-person: cameras whose windows agree before a target is started")
        confirm_frames: int = param(5, "multi-person: frames tracked before a target is reported")
        max_lost_s: float = param(3.0, "multi-person: a target no camera tracks for this long is dropped, s")
        box_sigma_px: float | None = param(None, "window edge noise, px; none: the calibration's box_sigma_px, else 0")
        box_u_sigma_px: float | None = param(None, "window centroid noise, px; none: the calibration's box_u_sigma_px, "
                                                   "else (analytic windows) bearing_sigma_px")
        flow_sigma_px_s: float | None = param(None, "region-mean flow noise, px/s; none: the calibration's "
                                                    "flow_sigma_px_s, else window edge noise x fps")

    # ------------------------------------------------------------------------------------------
    def resolved_config(self, calibration: Calibration) -> "TargetPlanes.Config":
        """The Config with the detector allowances filled in: a Config value wins, else the
        calibration's noise entry, else a fallback. Window edges ``box_sigma_px`` (fallback 0);
        window centroid ``box_u_sigma_px`` (fallback ``bearing_sigma_px``: the analytic windows'
        u carries the bearing noise, ``sim/noise.py``; then the edge noise); region flow
        ``flow_sigma_px_s`` (None: edge noise x fps). Only noise levels come from the
        calibration; the eq. 8 threshold ``width_ratio_threshold`` is the Config's own."""
        cfg, noise = self.config, calibration.noise or {}

        def pick(value, *keys, default=None):
            if value is not None:
                return value
            for k in keys:
                if noise.get(k) is not None:
                    return float(noise[k])
            return default

        box = float(pick(cfg.box_sigma_px, "box_sigma_px", default=0.0))
        return dataclasses.replace(
            cfg,
            box_sigma_px=box,
            box_u_sigma_px=float(pick(cfg.box_u_sigma_px, "box_u_sigma_px", "bearing_sigma_px", default=box)),
            flow_sigma_px_s=pick(cfg.flow_sigma_px_s, "flow_sigma_px_s"),
        )

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        return self.estimate_with_status(observations, calibration)[0]

    def estimate_with_status(self, observations: Observations, calibration: Calibration) -> tuple[pd.DataFrame, pd.DataFrame]:
        res = self.run(observations, calibration)
        return check_tracks(res.tracks[["t", "track_id", "x", "y", "vx", "vy"]], self.name), res.status

    def run(self, observations: Observations, calibration: Calibration) -> TargetPlanesResult:
        cfg = self.resolved_config(calibration)
        boxes = observations["boxes"]
        cams = sorted(calibration.cameras_of_kind("oblique")) or sorted(set(boxes["camera"]))
        unknown = sorted(set(boxes["camera"]) - set(calibration.cameras))
        if unknown:
            raise EstimatorError(f"{self.name}: boxes from cameras not in the calibration: {unknown}")
        cams = [c for c in cams if c in set(boxes["camera"]) or c in calibration.cameras_of_kind("oblique")]
        if not cams:
            raise EstimatorError(f"{self.name}: no oblique cameras")
        if not cfg.multi_person and cfg.initial_xy is None and cfg.initial_window is None:
            raise EstimatorError(
                f"{self.name}: the target is chosen by hand: give initial_xy=[x, y] (its floor position at the "
                "first frame, m) or initial_window=[camera, u_left, u_right, v_top, v_bottom], or multi_person=true "
                "to track every mover (on the command line: --param multi_person=true)"
            )
        Ps = {c: np.asarray(calibration.cameras[c].P, float) for c in cams}
        if cfg.design not in ("joint", "rules"):
            raise EstimatorError(f"{self.name}: design must be 'joint' or 'rules', got {cfg.design!r}")
        frames = split_boxes(boxes, cams, cfg.flow_window)
        times = frame_times(calibration, cams, observations.duration, boxes)
        if cfg.design == "joint":
            return self._run_joint(cfg, cams, Ps, frames, times, calibration)
        # flow noise (px/s) of each camera's averaged window flow: the calibrated region-mean flow
        # noise (``flow_sigma_px_s``) or, for recordings without it, window-edge noise x fps
        sigma_px = float(cfg.box_sigma_px)
        flow_sigma = {
            c: (float(cfg.flow_sigma_px_s) if cfg.flow_sigma_px_s is not None else sigma_px * calibration.cameras[c].fps) / np.sqrt(cfg.flow_window)
            for c in cams
        }
        upd = TargetUpdater(cfg, Ps, flow_sigma, sigma_px, float(cfg.box_u_sigma_px))
        upd.image_width = {c: float(calibration.cameras[c].width) for c in cams}
        inside_room = calibration.floorplan.inside

        targets: list[Target] = []
        next_id = 0
        if not cfg.multi_person:
            targets.append(self._initial_target(cams, Ps, frames.get(float(times[0]), {}) if len(times) else {}, inside_room))
            targets[0].confirmed = True
            next_id = 1
        rows: list[tuple] = []
        status_rows: list[tuple] = []
        t_prev = float(times[0]) if len(times) else 0.0
        for t in times:
            t = float(t)
            dt = t - t_prev
            t_prev = t
            frame = {c: frames.get(t, {}).get(c, CameraBoxes.empty()) for c in cams}
            for tg in targets:
                if tg.mode == "predicted":  # no camera tracked it last frame: it has most likely stopped
                    tg.vel = tg.vel * np.exp(-dt / cfg.lost_velocity_tau)
            preds = {tg.tid: tg.xy + tg.vel[:2] * dt for tg in targets}
            views = {tg.tid: upd.views(tg, preds[tg.tid]) for tg in targets}
            used = {tg.tid: {} for tg in targets}
            held = {tg.tid: [] for tg in targets}  # (camera, box) of overlapped windows still containing the target
            acquired = {tg.tid: set() for tg in targets}  # cameras that (re)acquired the target this frame
            followed = {c: set() for c in cams}
            crowded, partners = self._crowded(targets, preds, views) if cfg.crowd_overlap is not None else ({}, {})
            for c in cams:
                frame[c] = self._associate(c, frame[c], targets, views, used, held, followed, upd, dt, acquired, crowded, partners)
            for tg in list(targets):
                self._confirm(tg, preds[tg.tid], used[tg.tid], acquired[tg.tid], frame, upd)
                self._update(tg, preds[tg.tid], used[tg.tid], held[tg.tid], frame, upd, dt)
            if cfg.multi_person or cfg.track_others:
                claimed = {c: set(followed[c]) | {j for u in used.values() for cc, j in u.items() if cc == c} for c in cams}
                free = {c: [j for j in range(len(frame[c])) if j not in claimed[c]] for c in cams}
                for xy, support in propose(cfg, upd.margin_px, Ps, frame, free, inside_room):
                    if self._reacquire(targets, preds, xy, support, frame, upd, views):
                        continue
                    tg = Target(next_id, xy.copy(), {c: CameraState() for c in cams}, sigma=upd.search_sigma(xy, support))
                    next_id += 1
                    for c, j in support.items():
                        tg.cams[c] = CameraState(TRACKING, frame[c].track[j])
                    upd.velocity(tg, xy, support, frame)
                    tg.hits, tg.n_used, tg.mode = 1, len(support), "planes"
                    targets.append(tg)
                targets = [tg for tg in targets if self._alive(tg) or (not cfg.multi_person and tg.tid == 0)]
            for tg in targets:
                if not tg.confirmed or (not cfg.multi_person and tg.tid != 0):
                    continue
                rows.append((t, tg.tid, tg.xy[0], tg.xy[1], tg.vel[0], tg.vel[1], tg.n_used, tg.mode))
                for c in cams:
                    cs = tg.cams[c]
                    status_rows.append((t, tg.tid, c, cs.status, cs.reason, cs.track if cs.status == TRACKING else None))
        tracks = pd.DataFrame(rows, columns=["t", "track_id", "x", "y", "vx", "vy", "n_cameras", "mode"])
        status = pd.DataFrame(status_rows, columns=STATUS_COLUMNS)
        return TargetPlanesResult(tracks, status)

    def _run_joint(self, cfg, cams, Ps, frames, times, calibration) -> TargetPlanesResult:
        """The joint design (``tp_joint``): every mover a track; the target (single-target mode)
        is track 0, started from the hand-given position with ``init_radius`` and an unknown
        velocity (sigma ``max_speed`` / 2)."""
        # per-frame flow noise: a mean over flow_window frames of one camera track is not
        # flow_window independent measurements a frame (consecutive means share frames)
        flow_sigma = {c: float(cfg.flow_sigma_px_s) if cfg.flow_sigma_px_s is not None else float(cfg.box_sigma_px) * calibration.cameras[c].fps for c in cams}
        jt = JointTracker(cfg, Ps, {c: float(calibration.cameras[c].width) for c in cams}, flow_sigma, float(cfg.box_sigma_px), float(cfg.box_u_sigma_px))
        inside_room = calibration.floorplan.inside
        tracks: list[JointTrack] = []
        keep = None
        if not cfg.multi_person:
            t0 = self._initial_target(cams, Ps, frames.get(float(times[0]), {}) if len(times) else {}, inside_room)
            sv = 0.5 * cfg.max_speed
            tr = JointTrack(0, np.r_[t0.xy, 0.0, 0.0], np.diag([cfg.init_radius**2] * 2 + [sv**2] * 2), confirmed=True, seen=True, located=False)
            tracks.append(tr)
            keep = 0
        next_id = len(tracks)
        rows, status_rows = [], []
        t_prev = float(times[0]) if len(times) else 0.0
        for t in times:
            t = float(t)
            dt, t_prev = t - t_prev, t
            frame = {c: frames.get(t, {}).get(c, CameraBoxes.empty()) for c in cams}
            free = jt.step(tracks, frame, dt)
            proposals = propose(cfg, jt.margin_px, Ps, frame, free, inside_room)
            taken = jt.locate(tracks[0], proposals, frame) if keep is not None and not tracks[0].located else set()
            for k, (xy, support) in enumerate(proposals):
                if k in taken or any(jt.covers(tr, xy) for tr in tracks if tr.located):
                    continue  # a tracked person (its far side, a fragment): not someone new
                tracks.append(jt.birth(next_id, xy, support, frame))
                next_id += 1
            tracks = jt.prune(tracks, keep, inside_room)
            for tr in tracks:
                if not tr.confirmed or (keep is not None and tr.tid != keep):
                    continue
                rows.append((t, tr.tid, tr.s[0], tr.s[1], tr.s[2], tr.s[3], tr.n_used, tr.mode))
                for c in cams:
                    st, reason, win = tr.status.get(c, (LOST, "", None))
                    status_rows.append((t, tr.tid, c, st, reason, win))
        tracks_df = pd.DataFrame(rows, columns=["t", "track_id", "x", "y", "vx", "vy", "n_cameras", "mode"])
        return TargetPlanesResult(tracks_df, pd.DataFrame(status_rows, columns=STATUS_COLUMNS))

    # ------------------------------------------------------------------------------------------
    def _initial_target(self, cams, Ps, frame0, inside_room) -> Target:
        cfg = self.config
        states = {c: CameraState() for c in cams}
        if cfg.initial_xy is not None:
            xy = np.asarray(cfg.initial_xy, float)
            if xy.shape != (2,) or not np.isfinite(xy).all():
                raise EstimatorError(f"{self.name}: initial_xy must be [x, y] in metres, got {cfg.initial_xy!r}")
            if not bool(np.asarray(inside_room(xy[None])).reshape(-1)[0]):
                raise EstimatorError(f"{self.name}: initial_xy {cfg.initial_xy!r} lies outside the room's floor plan")
            return Target(0, xy, states, sigma=cfg.init_radius)
        w = cfg.initial_window
        if not (isinstance(w, (list, tuple)) and len(w) == 5 and w[0] in Ps):
            raise EstimatorError(f"{self.name}: initial_window must be [camera, u_left, u_right, v_top, v_bottom] with a camera of {cams}, got {w!r}")
        cam, win = w[0], np.asarray(w[1:], float)
        b = frame0.get(cam)
        if b is None or not len(b):
            raise EstimatorError(f"{self.name}: camera {cam!r} reports no window in the first frame")
        inter = np.clip(np.minimum(b.win[:, 1], win[1]) - np.maximum(b.win[:, 0], win[0]), 0, None) * np.clip(
            np.minimum(b.win[:, 3], win[3]) - np.maximum(b.win[:, 2], win[2]), 0, None
        )
        j = int(np.argmax(inter))
        if inter[j] <= 0:
            raise EstimatorError(f"{self.name}: initial_window overlaps no window of camera {cam!r} in the first frame")
        area = geo.target_area(Ps[cam], b.box(j), cfg.height, cfg.radius, margin=cfg.area_margin)
        xy = area.origin + 0.5 * (area.s_min + area.s_max) * area.direction
        states[cam] = CameraState(TRACKING, b.track[j])
        tg = Target(0, xy, states, sigma=cfg.init_radius)
        tg.area = area.polygon
        return tg

    def _crowded(self, targets, preds, views) -> tuple[dict[int, set], dict[int, dict[str, list[int]]]]:
        """Cameras in which a target's predicted window overlaps another confirmed target's
        (beyond the paper: section 4.1's overlap, foreseen from the 3-D predictions of the people
        being tracked): the intervals [u_l, u_r] of the estimated windows overlap by more than
        ``crowd_overlap`` of the narrower one. Such a camera cannot tell the two apart (their
        flows are alike, their windows merge or split anywhere), so it is left out for both.
        Two targets nearer than 2 ``radius`` on the floor are one person seen twice, not a crowd.

        Also returns, for each target and camera, the targets whose estimated windows overlap
        its own there (in every view too): the neighbours a merged window may be split with."""
        cfg = self.config
        out: dict[int, set] = {tg.tid: set() for tg in targets}
        partners: dict[int, dict[str, list[int]]] = {tg.tid: {} for tg in targets}
        live = [tg for tg in targets if tg.confirmed or tg.tid == 0]
        for a in range(len(live)):
            for b in range(a + 1, len(live)):
                ta, tb = live[a], live[b]
                if np.linalg.norm(preds[ta.tid] - preds[tb.tid]) < 2 * cfg.radius:
                    continue
                both = [c for c in views[ta.tid] if c in views[tb.tid]]
                hit = set()
                for c in both:
                    va, vb = views[ta.tid][c], views[tb.tid][c]
                    inter = min(va.win_point[1], vb.win_point[1]) - max(va.win_point[0], vb.win_point[0])
                    if inter > cfg.crowd_overlap * min(va.w_c, vb.w_c):
                        hit.add(c)
                        partners[ta.tid].setdefault(c, []).append(tb.tid)
                        partners[tb.tid].setdefault(c, []).append(ta.tid)
                if len(hit) < len(both):  # crowded in every view: no camera separates them; the per-window tests of section 4 decide
                    out[ta.tid] |= hit
                    out[tb.tid] |= hit
        return out, partners

    def _splits(self, c, boxes, targets, views, idx, partners, upd: TargetUpdater) -> dict[int, tuple[int, np.ndarray]]:
        """Targets of camera c whose window is merged with a tracked neighbour's: target id ->
        (merged window index, the target's part, ``TargetUpdater.split_window``). Only where the
        split can be trusted: the target's last estimate came from two or more cameras' planes
        (its prediction says on which side it is), and the window is the one this camera was
        already following for the target, now wider than one person (eq. 8 above
        ``rejoin_width_ratio``), holding both predicted centres and moving with the target's
        predicted image velocity (3.4.2). A lost camera is never re-acquired by a split."""
        cfg = self.config
        out = {}
        if not cfg.split_merged or not len(boxes):
            return out
        for tg in targets:
            view = views[tg.tid].get(c)
            if view is None or tg.mode != "planes":
                continue
            for otid in partners.get(tg.tid, {}).get(c, ()):
                pv = views.get(otid, {}).get(c)
                if pv is None:
                    continue
                lo = np.minimum(view.u_c, pv.u_c)
                hi = np.maximum(view.u_c, pv.u_c)
                cand = (width_ratio(boxes.width, view.w_c) > cfg.rejoin_width_ratio) & (boxes.win[:, 0] <= lo) & (boxes.win[:, 1] >= hi)
                cand &= upd.flow_ok(c, view, boxes.flow)
                j = idx.get(tg.tid)
                if j is None or not cand[j]:
                    continue
                k = j
                sub = upd.split_window(view, pv, boxes.win[k], upd.image_width.get(c))
                if sub is not None:
                    out[tg.tid] = (int(k), sub)
                    break
        return out

    def _associate(self, c, boxes, targets, views, used, held, followed, upd: TargetUpdater, dt, acquired, crowded=None, partners=None) -> CameraBoxes:
        """One camera: split merged windows, continue tracking cameras' windows, then search for
        the others. Returns the camera's windows with the split-off parts appended."""
        cfg = self.config
        crowded = crowded or {}
        claimed: dict[int, int] = {}  # box -> target id
        idx = {}
        for tg in targets:
            cs = tg.cams[c]
            if cs.status in (TRACKING, UNRELIABLE) and cs.track is not None:
                hit = np.flatnonzero(boxes.track == cs.track) if len(boxes) else []
                idx[tg.tid] = int(hit[0]) if len(hit) else None
        shared = {}
        for tid, j in idx.items():
            if j is not None:
                shared[j] = shared.get(j, 0) + 1
        splits = self._splits(c, boxes, targets, views, idx, partners or {}, upd)
        extra = []  # split-off windows, appended after the camera's own
        searchers = []
        for tg in targets:
            cs = tg.cams[c]
            view = views[tg.tid].get(c)
            j = idx.get(tg.tid)
            if view is None:
                cs.status, cs.track, cs.reason = LOST, None, "out of view"
                continue
            if tg.tid in splits:
                k, sub = splits[tg.tid]
                if cs.status != TRACKING or cs.track != boxes.track[k]:
                    acquired[tg.tid].add(c)  # a re-acquisition: to be confirmed
                cs.status, cs.track, cs.reason = TRACKING, boxes.track[k], "split"
                jj = len(boxes) + len(extra)
                extra.append(((boxes.track[k], "split", tg.tid), sub, boxes.flow[k]))
                followed[c].add(k)
                claimed[k] = tg.tid
                used[tg.tid][c] = jj
                continue
            if c in crowded.get(tg.tid, ()) and j is not None and width_ratio(boxes.width[j], view.w_c) > cfg.rejoin_width_ratio:
                # another target stands beside, in front of or behind it in this view and the
                # window is wider than one person: the two are merged in it; follow the window
                # but use nothing from this camera
                followed[c].add(j)
                cs.status, cs.reason = UNRELIABLE, "crowded"
                continue
            if j is None:
                searchers.append(tg)
                continue
            followed[c].add(j)
            if cs.status == UNRELIABLE and cs.reason == "crowded":
                cs.status = TRACKING  # separated again: judged afresh by section 4
            if cs.reason == "split":
                cs.status, cs.reason = UNRELIABLE, "overlap"  # the merged window: the target's alone only once narrow again
            if cs.status == TRACKING:
                reason = "overlap" if shared[j] > 1 else upd.check_reliable(c, cs, view, boxes, j, dt)
                if not reason:
                    claimed[j] = tg.tid
                    used[tg.tid][c] = j
                    cs.reason = ""
                    upd.remember_neighbours(cs, boxes, j)
                    continue
                cs.status, cs.reason = UNRELIABLE, reason
            # unreliable: the followed window is the target alone again only when it is narrow
            # and separate and where the target should be
            if (
                cs.reason in ("overlap", "width")
                and shared[j] == 1
                and width_ratio(boxes.width[j], view.w_c) <= cfg.rejoin_width_ratio
                and np.isfinite(upd.search_costs(c, view, boxes, set(claimed), self._others(cs))[j])
            ):
                cs.status, cs.reason = TRACKING, ""
                claimed[j] = tg.tid
                used[tg.tid][c] = j
                acquired[tg.tid].add(c)
                upd.remember_neighbours(cs, boxes, j)
                continue
            if cs.reason in ("overlap", "width"):
                held[tg.tid].append((c, j))
            searchers.append(tg)
        if searchers and len(boxes):
            blocked = set(claimed)
            # a window that overlapped (or outgrew, eq. 8) is not the target alone; it can only
            # come back by the rejoin test above. A window that failed the position test may be
            # taken again: the position test of the estimate judges it anew.
            for tg in searchers:
                j = idx.get(tg.tid)
                if j is not None and tg.cams[c].reason in ("overlap", "width"):
                    blocked.add(j)
            cost = np.vstack([upd.search_costs(c, views[tg.tid][c], boxes, blocked, self._others(tg.cams[c])) for tg in searchers])
            finite = np.isfinite(cost)
            if finite.any():
                r, k = linear_sum_assignment(np.where(finite, cost, 1e6))
                for i, j in zip(r, k):
                    if not finite[i, j]:
                        continue
                    tg = searchers[i]
                    cs = tg.cams[c]
                    cs.status, cs.track, cs.reason = TRACKING, boxes.track[j], ""
                    used[tg.tid][c] = int(j)
                    acquired[tg.tid].add(c)
                    claimed[int(j)] = tg.tid
                    followed[c].add(int(j))
                    upd.remember_neighbours(cs, boxes, int(j))
        for tg in searchers:
            cs = tg.cams[c]
            if c in used[tg.tid] or c not in views[tg.tid]:
                continue

            if cs.status == UNRELIABLE and idx.get(tg.tid) is not None:
                continue  # keeps following its window until the target is separated again
            cs.status, cs.track, cs.reason = LOST, None, ""
            cs.near = {}
        for track, sub, flow in extra:
            boxes, _ = boxes.with_box(track, sub, flow)
        return boxes

    def _others(self, cs: CameraState) -> set:
        return cs.others if self.config.exclude_neighbours else set()

    def _confirm(self, tg: Target, xy_pred, used: dict, acquired: set, frame, upd: TargetUpdater) -> None:
        """Re-acquisition test (beyond the paper, whose lost cameras trust the velocity gate alone).

        With two or more cameras that kept the target from the last frame, a camera that
        (re)acquires it is judged by the estimate's position test against their planes. With
        fewer, a newcomer must be confirmed: the planes of the kept and new cameras (eq. 6) must
        cross inside every one's target area and within the search radius of the prediction
        (newcomers straying farthest are left out one by one); a single newcomer with nothing to
        cross-check must hold the same window, with its target area covering the prediction,
        for ``confirm_single_frames`` frames. Unconfirmed cameras stay lost this frame.
        """
        cfg = self.config
        new = [c for c in acquired if c in used]
        kept = [c for c in used if c not in acquired]
        for c in kept:
            tg.cams[c].pending, tg.cams[c].pending_n = None, 0
        if not new or len(kept) >= 2:
            for c in new:
                tg.cams[c].pending, tg.cams[c].pending_n = None, 0
            return
        gate = upd.search_radius(tg)
        cand = sorted(new, key=lambda c: upd.stray(c, frame[c], used[c], xy_pred))
        while cand:
            if len(kept) + len(cand) >= 2:
                if upd.agree({c: used[c] for c in kept + cand}, frame, xy_pred, gate):
                    for c in cand:
                        tg.cams[c].pending, tg.cams[c].pending_n = None, 0
                    return
                self._reject(tg, cand.pop(), used)
                continue
            c = cand[0]  # a single newcomer: confirmed over frames
            cs = tg.cams[c]
            track = frame[c].track[used[c]]
            cs.pending_n = cs.pending_n + 1 if cs.pending == track else 1
            cs.pending = track
            area_ok = upd.area_of(c, frame[c], used[c]).contains(xy_pred, tg.sigma)
            if not (cs.pending_n >= cfg.confirm_single_frames and area_ok):
                self._reject(tg, c, used, keep_pending=area_ok)
            return

    def _reacquire(self, targets, preds, xy, support, frame, upd: TargetUpdater, views=None) -> bool:
        """A mover found by two or more cameras' crossing planes (``tp_initiate``) within the
        search radius of an existing target is that target seen by more cameras (the agreement
        ``_confirm`` asks of a re-acquisition), not a new person: its windows join the target
        in the cameras that do not track it. A window joins only if it moves as the target is
        predicted to (section 3.4.2's velocity gate, as for a lost camera's own search): a target
        that vanished from every view has most likely stopped, and a look-alike walking past it
        does not move like someone starting from rest (``TargetUpdater.flow_ok`` with the
        velocity uncertainty grown by ``accel_max`` since it was lost). If no window may join,
        the mover is still near the target, so it is not started as a new person."""
        pred = {tg.tid: preds.get(tg.tid, tg.xy) for tg in targets}  # targets started this frame: their position
        near = [tg for tg in targets if np.linalg.norm(xy - pred[tg.tid]) <= upd.search_radius(tg)]
        if not near:
            return False
        tg = min(near, key=lambda tg: float(np.linalg.norm(xy - pred[tg.tid])))
        joined = {c: j for c, j in support.items() if tg.cams[c].status != TRACKING}
        if views is not None and tg.tid in views:
            v = views[tg.tid]
            joined = {c: j for c, j in joined.items() if c in v and upd.flow_ok(c, v[c], frame[c].flow[j : j + 1])[0]}
            if not joined:
                return True
        for c, j in joined.items():
            tg.cams[c] = CameraState(TRACKING, frame[c].track[j], others=tg.cams[c].others)
        if tg.n_used < 2:  # the crossing is a better estimate than the target's own
            tg.xy, tg.sigma, tg.sigma_v, tg.area = xy.copy(), upd.search_sigma(xy, support), self.config.sigma_v_tracked, None
            tg.n_used, tg.mode, tg.misses_s = len(support), "planes", 0.0
            upd.velocity(tg, xy, support, frame)
        return True

    @staticmethod
    def _reject(tg: Target, c: str, used: dict, keep_pending: bool = False) -> None:
        cs = tg.cams[c]
        cs.status, cs.track, cs.reason = LOST, None, "unconfirmed"
        cs.near = {}
        if not keep_pending:
            cs.pending, cs.pending_n = None, 0
        used.pop(c, None)

    def _update(self, tg: Target, xy_pred, used, held, frame, upd: TargetUpdater, dt) -> None:
        cfg = self.config
        xy, poly, mode, dropped = upd.estimate(tg, xy_pred, dict(used), frame, held)
        for c in dropped:
            used.pop(c, None)
            tg.cams[c].status, tg.cams[c].reason = UNRELIABLE, "inconsistent"
        if cfg.jump_gate:
            # a person cannot be farther from the prediction than its search radius: the camera
            # whose window strays most from the prediction is left out until the estimate is there
            gate = upd.search_radius(tg)
            while mode != "predicted" and float(np.linalg.norm(xy - xy_pred)) > gate:
                worst = max(used, key=lambda c: upd.stray(c, frame[c], used[c], xy_pred))
                used.pop(worst)
                tg.cams[worst].status, tg.cams[worst].reason = UNRELIABLE, "jump"
                xy, poly, mode, more = upd.estimate(tg, xy_pred, dict(used), frame, [])
                for c in more:
                    used.pop(c, None)
                    tg.cams[c].status, tg.cams[c].reason = UNRELIABLE, "inconsistent"
        if mode == "predicted":
            tg.sigma = min(tg.sigma + cfg.sigma_growth * dt, cfg.sigma_max)
            tg.sigma_v = min(tg.sigma_v + cfg.accel_max * dt, cfg.max_speed)
            if tg.area is not None:
                tg.area = tg.area + (xy - tg.xy)
            tg.misses_s += dt
        else:
            tg.sigma = upd.search_sigma(xy, used)
            tg.sigma_v = cfg.sigma_v_tracked
            tg.area = poly if mode == "area" else None
            tg.misses_s = 0.0
            tg.hits += 1
        tg.xy = np.asarray(xy, float)
        upd.velocity(tg, tg.xy, used, frame)
        tg.n_used, tg.mode = len(used), mode
        if tg.hits >= cfg.confirm_frames:
            tg.confirmed = True

    def _alive(self, tg: Target) -> bool:
        if not tg.confirmed:
            return tg.misses_s == 0.0
        return tg.misses_s <= self.config.max_lost_s
