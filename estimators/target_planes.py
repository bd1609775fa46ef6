"""``target_planes``: optical-flow person tracking by multiple cameras (Tsutsui, Miura, Shirai).

Input: the ``boxes`` table of the oblique cameras (each camera's own tracking windows with their
horizontal centroid u, edges, top/bottom rows and mean image flow, px and px/s) and each camera's
3x4 projection ``P``. The ``bearings`` table's colour labels are *not* used: telling the target
from a look-alike mover by colour would make the paper's velocity discrimination moot, so people
are told apart by geometry and image velocity alone.

The paper's geometry (``tp_geometry``: target planes from P, eqs. 3-5; their least-squares
intersection, eq. 6; the single-camera target area, section 3.2; the person model's estimated
window, section 3.3; image velocity, eq. 7) inside a joint multi-person tracker (``tp_joint``,
issue 12): every mover is a track (floor position, velocity, the paper's cylinder); each frame
every camera's windows are explained by all tracks' projected cylinders at once - a window is one
person, several people merged into one flow region, or clutter, and a person may have no window -
and the tracks are updated by Kalman steps whose measurements are the paper's: a window's target
plane, its target area's depth range, its flow (eq. 7); a merged window's outer edges. New
people start where two cameras' target planes cross (``tp_initiate``).

The target is chosen by hand as in the paper: ``initial_xy`` (its floor position at the first
frame, m) or ``initial_window`` (``[camera, u_left, u_right, v_top, v_bottom]`` at the first
frame); it is one of the tracks, the one whose identity is reported. It is located by the first
two-camera crossing near the click, or (``adopt``, off) it is the confirmed track that started on
it when no crossing came near enough: the track whose first state, taken back to the first frame,
is likelier at the click than someone anywhere on the floor. With ``multi_person = true``
every confirmed track is reported (section 6's future work).

The output is fixed-lag (``identity_lag_s``, 1 s): who is who after two tracks were ambiguous is
decided a second after they part, by the joint likelihood of their states before and after
(``tp_identity``), and the output follows the decision from the pair's nearest approach, up to
``output_lag_s`` (3.5 s) back; a track confirmed
within the lag is reported from its birth, and in multi-person mode from a lag before its
confirmation (before its birth: moved back along its velocity, ``mode`` extrapolated). An identity's
frames between two tracks an identity decision joined, where no track carried it, are reported
on the curve through both ends when the gap is no longer than the output lag (``bridge_gaps``,
``mode`` bridged).

``run`` returns the tracks (with ``n_cameras``: cameras whose window was the track alone, and
``mode``: planes / area / merged / predicted / extrapolated / bridged) and a per-frame, per-camera status table (tracking /
merged / unreliable / lost and why, Figs. 11-12); ``estimate`` returns the tracks only.
"""
from __future__ import annotations

import copy
import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.interpolate import CubicHermiteSpline

from trackroom.recording import Calibration, Observations

from . import tp_geometry as geo
from .base import Estimator, EstimatorError, check_tracks, param, register
from .tp_frames import CameraBoxes, frame_times, person_detections, split_boxes
from .tp_identity import EXCHANGE_LOG_ODDS, IdentityLag
from .tp_initiate import propose
from .tp_joint import EXIST_REJECT, LOST, JointTrack, JointTracker, Occluders, mode_weighted, on_floor
from .tp_smooth import smooth_chains

STATUS_COLUMNS = ["t", "track_id", "camera", "status", "reason", "window"]
NO_DETECTIONS = np.zeros(0)
LOOKAHEAD_GAP = EXCHANGE_LOG_ODDS  # two explanations of the target nearer than 99:1 are both followed, and the second taken when 99:1 likelier (``lookahead``)


@dataclass
class _RunState:
    """What the frame loop carries from frame to frame: the tracks, the target's track id, the
    next new id, the identity decision, the previous frame's time, the summed explanation cost
    and the output rows. ``fork`` copies it for a second explanation (the look-ahead), with
    empty row buffers; ``take`` continues with a fork instead."""

    tracks: list
    keep: int | None
    next_id: int
    idl: IdentityLag | None
    t_prev: float
    cost: float = 0.0
    branch: tuple | None = None
    rows: list = field(default_factory=list)
    status_rows: list = field(default_factory=list)
    end_rows: list = field(default_factory=list)
    smooth: list = field(default_factory=list)  # one per row: what ``tp_smooth`` needs of its track (None: off)
    mark: tuple = (0, 0, 0)

    def target(self) -> JointTrack | None:
        """The target's track (the one carrying ``keep``), None in multi-person mode."""
        return next((tr for tr in self.tracks if tr.tid == self.keep), None)

    def fork(self) -> "_RunState":
        self.mark = (len(self.rows), len(self.status_rows), len(self.end_rows))
        tracks, idl = copy.deepcopy((self.tracks, self.idl))
        return _RunState(tracks, self.keep, self.next_id, idl, self.t_prev, self.cost)

    def take(self, other: "_RunState") -> None:
        a, b, c = self.mark
        self.rows[a:], self.status_rows[b:], self.end_rows[c:] = other.rows, other.status_rows, other.end_rows
        self.smooth[a:] = other.smooth
        self.tracks, self.keep, self.next_id, self.idl = other.tracks, other.keep, other.next_id, other.idl
        self.t_prev, self.cost, self.branch = other.t_prev, other.cost, other.branch


@dataclass
class TargetPlanesResult:
    """``tracks``: t, track_id, x, y, vx, vy (+ ``n_cameras``: reliable tracking cameras used,
    ``mode``: planes / area / predicted); ``status``: t, track_id, camera, status, reason, window (the camera's own track id it
    follows while tracking). For diagnosis (``scripts/explain_tp_losses.py``): ``internal``, every
    track the tracker held in every frame under its internal id (t, track_id, x, y, vx, vy,
    n_cameras, mode, confirmed, and cxx, cxy, cyy: the position's covariance, m^2; before the identity decision's relabelling and the output's
    selection), and ``ends``, each confirmed track the tracker dropped (t, track_id, x, y, reason:
    unseen / existence / off floor / duplicate, other: the track it duplicated), and ``decisions``,
    each identity decision scored (``tp_identity.IdentityLag.record``: t, kind - pair or handover -,
    a, b, gone, log_odds, t_pre, and the floor positions a_pre, b_pre then and a_post, b_post at t,
    as x, y columns); ``times``, every frame time the tracker ran (in single-target mode a frame
    without a row is one the target was not reported: no track carried its identity); ``lookaheads``,
    each look-ahead run (``Config.lookahead``): t, the camera and window (index, None: no window)
    of the second explanation, its extra cost at t (gap), the summed cost of both hypotheses from
    t over the look-ahead (cost: the best's, cost_alt: the second's), whether both held the same
    tracks throughout (same) and whether the second was taken; ``detections_used``, whether the
    oblique cameras' person detections (the recording's ``bearings`` table) were read
    (``person_detections`` or ``detection_planes`` on and the recording has them)."""

    tracks: pd.DataFrame
    status: pd.DataFrame
    internal: pd.DataFrame = field(default_factory=pd.DataFrame)
    ends: pd.DataFrame = field(default_factory=pd.DataFrame)
    decisions: pd.DataFrame = field(default_factory=pd.DataFrame)
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lookaheads: pd.DataFrame = field(default_factory=pd.DataFrame)
    detections_used: bool = False


@register
class TargetPlanes(Estimator):
    name = "target_planes"
    description = "Tsutsui et al.: target-plane intersection of oblique cameras' flow windows, every mover a track, windows explained jointly"
    requires = ("boxes",)

    @dataclasses.dataclass
    class Config:
        initial_xy: list[float] | None = param(None, "the target's floor position [x, y] at the first frame, m (the "
                                                     "target is chosen by hand: this, initial_window or multi_person)")
        initial_window: list | None = param(None, "the target's window at the first frame: [camera, u_left, u_right, "
                                                  "v_top, v_bottom], camera name and px")
        multi_person: bool = param(False, "report every mover (beyond the paper): no initial_xy or initial_window "
                                          "needed")
        height: float = param(1.8, "person model: cylinder height, m (the tallest person's, with their gait bob)")
        radius: float = param(0.2, "person model: cylinder radius, m")
        accel_sigma: float = param(1.0, "walkers' white-acceleration noise, m/s^2/sqrt(Hz) (they stop, start and turn "
                                        "at waypoints: about 1 m/s of change within 1 s)")
        stop_tau: float = param(1.0, "a track no window explains slows as exp(-t / tau), s (it has most likely "
                                     "stopped: standing people make no flow window; a walker stops within ~1 s)")
        walk_s: float = param(8.0, "mean time a walker walks before stopping, s (the walking / standing modes' "
                                   "switching): not the scenes' 93 s of walking per stop of 0.5 s or more, but "
                                   "near the chance a slow walker begins a stop, 0.015-0.025 per 0.1 s frame "
                                   "below 0.15 m/s (scripts/measure_stop_lengths.py, development truth), taken "
                                   "for every walker since a track's speed sd (~0.2 m/s) cannot tell who slows; "
                                   "93 s lets the existence test reject pausing walkers")
        stand_s: float = param(3.0, "mean time a person stands before walking on, s (measured: stops of 0.5 s or "
                                    "more last 3.0 s on average, scripts/measure_stop_lengths.py)")
        p_miss: float = param(0.3, "probability that a walker moving at least mover_flow_px in the image of a "
                                   "camera that would see it (not hidden by the floor plan's boxes or another "
                                   "track) has no window of its own there (a merge, a fragment, someone "
                                   "untracked in front): how fast a track no window explains becomes standing")
        p_detect: float = param(0.91, "probability that a walking person has a flow window in a camera whose view "
                                      "holds them, moving at least mover_flow_px in its image and hidden neither by the "
                                      "floor plan's boxes nor by a nearer mover (rendered development recordings "
                                      "100-105: 0.913 of 10383 camera frames; the rest: standing people in front, "
                                      "fragments, the tracker's misses)")
        miss_run: float = param(5.0, "mean run of such a person's missed frames in one camera, frames (the same "
                                     "frames: 183 runs, mean 4.96, median 3, 90 % <= 12)")
        stand_sigma: float = param(0.05, "a standing person's position drift, m/sqrt(s)")
        start_sigma_v: float = param(0.5, "velocity spread of a standing person starting to walk, m/s")
        lookahead: bool = param(False, "single-target mode: where a camera's second-best explanation gives the target's "
                                       "track another window (or none) at under 99:1 against the best, both are followed "
                                       "for identity_lag_s and the second is kept when its windows are explained 99:1 "
                                       "likelier over those frames (a two-hypothesis look-ahead; no parameter value)")
        hold_s: float = param(13.0, "a confirmed track no window explains is kept this long, s (longer than every "
                                    "stop of the movers in the development recordings: up to 12.1 s in the head-on "
                                    "variant, where walkers wait for each other; scripts/measure_stop_lengths.py)")
        sigma_max: float = param(1.5, "largest position uncertainty (standard deviation) of a track, m (a walker "
                                      "slowing to a stop at 1 m/s with stop_tau 1 s moves ~1 m, plus the body)")
        max_speed: float = param(3.0, "largest speed of a person, m/s")
        birth_sigma_v: float = param(0.5, "velocity uncertainty of a new track, m/s (eq. 7 from two windows' flows "
                                          "with the flow noise below)")
        edge_sigma_frac: float = param(0.1, "spread of a window's edges and centroid about the projected cylinder's, "
                                            "fraction of the person's image width (a walker's silhouette: arms and "
                                            "legs swing about 0.1 of the body width either side)")
        width_ratio_threshold: float = param(0.5, "eq. 8 width ratio (w - w_c) / w_c above which a window holds more "
                                                  "than the one person explaining it (the paper: 1; rendered flow "
                                                  "windows of isolated walkers stay <= 0.10 in 99 % of frames, two "
                                                  "merged reach 0.7-1.3)")
        min_plane_angle_deg: float = param(12.0, "target planes closer than this to parallel do not start a track, "
                                                 "degrees")
        position_tol: float = param(1.0, "a third camera supports a new track when its window's centroid is within "
                                         "this many estimated-window widths of the crossing")
        flow_height_fraction: float = param(0.5, "height of the flow region's centroid, fraction of the person "
                                                 "model's height")
        flow_window: int = param(5, "frames of a camera track over which its flow is averaged (the rendered flows' "
                                    "tails are heavy)")
        locate_slow: bool = param(True, "single-target mode: while the target is not located, a crossing of a "
                                        "window slower than mover_flow_px (one whole person's image, not a fragment "
                                        "or a merge) with a mover's window, nearer the click than every movers' "
                                        "crossing and more than 2 radius from the nearest, keeps the target from "
                                        "being located that frame and that mover's window from starting a track "
                                        "(the movers' crossing may be a ghost of the target's window and someone "
                                        "else's; no parameter value)")
        mover_flow_px: float = param(8.0, "a window with less mean flow starts no track, and a track predicted "
                                          "slower in an image may have no window there, px/s")
        flow_lag: bool = param(True, "a window's flow, the mean over the camera track's last flow_window frames, "
                               "is the velocity of about (flow_window - 1) / 2 frames ago: its noise includes the "
                               "walker's velocity change over the mean (white acceleration accel_sigma; "
                               "tp_frames.mean_lag_s), so a walker setting off is not held back by its lagging flow "
                               "(docs/target_planes.md)")
        flow_gain: float = param(1.0, "the flow detector's gain in eq. 7, f = flow_gain J V: 1 takes a window's flow for "
                                      "its person's image velocity. Measured (scripts/measure_flow_errors.py, a window's "
                                      "flow along its person's image motion over the body centre's image speed, median "
                                      "over windows of one walker, 10-120 px/s): 0.924 on rendered development recordings "
                                      "100-119, 0.903 on their analytic twins; on the flows the tracker takes (each the mean "
                                      "over its camera track's last flow_window frames, --flow-window 5) 0.851 and 0.862. "
                                      "0.92 and 0.85 remove most of the track's lag and lower RMSE, but neither held the "
                                      "target on more recordings (docs/target_planes.md, the twenty-first, forty-first and "
                                      "fifty-second sessions; 0.85 lost the target at waypoint stops beside the look-alike "
                                      "on fresh seeds), so 1 stays")
        width_tail: float = param(0.03, "probability e that a window's width error is gross (a shadow, a limb, clutter "
                                         "joined to the region): one edge moved outwards by a half-normal of spread "
                                         "width_tail_sigma x the predicted width, the centre by half that; else the "
                                         "Gaussian (0: always). Fitted to rendered development 100-119 (windows of one "
                                         "walker: 1.14 % wider than 1.33 times the person, 0.34 % than 1.5, 0.09 % than "
                                         "1.75; scripts/measure_flow_errors.py --widths: 0.029 and 0.34)")
        width_tail_sigma: float = param(0.34, "spread of a gross width error, as a share of the predicted width (width_tail)")
        width_depth: bool = param(True, "a window of one track whose person is seen whole (in the image, clear of the "
                                        "floor plan's boxes, overlapping no other track) measures depth by its width "
                                        "(JointTracker.update_width): the image width of the body's cylindrical part at "
                                        "the track against the window's, noise and gate those of the explanation's width "
                                        "term and of a plane; no value of its own (docs/target_planes.md, twenty-eighth "
                                        "session: RMSE lower on every development set)")
        fragment_width: bool = param(True, "width_depth not for a fragment: a window narrower than half the track's "
                                           "projection (fragment_var's fragment: a limb, a sliver, the part out of an "
                                           "obstacle's shadow) is not the body's width; no value of its own (the half is "
                                           "fragment_var's). Development, 320 runs (docs/target_planes.md, hundred-and-"
                                           "second session): movers' MOTA 317 -> 318, no target lost; misses 1765 -> 1698, "
                                           "false positives 708 -> 732")
        merged_evidence: bool = param(True, "a merged window is evidence for or against each member's existence: its "
                                            "likelihood with the member against without it (else it counts nothing)")
        detection_planes: bool = param(False, "each camera's person detections (the bearings table's columns; colour labels "
                                              "unused) as target planes for the tracks without a window of their own there, "
                                              "where unambiguous (JointTracker.update_by_detections); off: it gains analytic "
                                              "and head-on identities but not rendered ones, and on rendered recordings it "
                                              "leaves more tracks standing on no one (docs/target_planes.md, thirty-eighth session)")
        detection_sigma_px: float = param(0.54, "detection_planes: the noise (px) of a person detection's column about the "
                                                "person's projected axis, people seen whole (scripts/measure_person_detections.py, "
                                                "robust sd on rendered development 100-105: 0.54; the analytic detector, "
                                                "fitted to it, 0.62)")
        share_fit_walks: bool = param(True, "a share of a merged window makes a track a walker only when the window fits "
                                            "better with it than without it (merged_evidence's likelihood ratio at least 0); "
                                            "a share that the others alone explain better counts for neither mode, so a "
                                            "person who stops beside a passer can become standing instead of being "
                                            "rejected as a walker no window shows (docs/target_planes.md, thirty-ninth "
                                            "session; on with person_detections)")
        wake_by_own: bool = param(True, "a track more likely standing than walking (standing probability at least 1/2, the "
                                        "likelier mode) is made a walker only by a window of its own: a share of a "
                                        "merged window counts for neither mode (the others in it may have made it; "
                                        "else any share sets the standing probability to 0)")
        slow_misses: bool = param(True, "the existence test's miss in a camera, for a confirmed track located by two "
                                        "or more views in the last frame (mode planes), weighed by the chance that the "
                                        "walker moves slower than mover_flow_px in that image, as the mode posterior "
                                        "weighs it; else (one view, not yet confirmed) the predicted mean decides. On "
                                        "since the fifty-fifth session (development 520: movers' MOTA 513 -> 516, "
                                        "RMSE >= 2 cameras 510 -> 511, false negatives 3402 -> 3119, positives 1501 -> 1515)")
        own_wake: bool = param(True, "a track likelier standing is made a walker by its own windows' likelihood ratio "
                                     "against clutter, with its misses in the other cameras (the mode posterior), "
                                     "not outright by any window of its own; on with wake_once since the thirtieth "
                                     "session (alone, with person_detections, it held standing look-alikes and left "
                                     "ghosts standing as often; docs/target_planes.md)")
        person_detections: bool = param(True, "a track likelier standing is also tested by the cameras' person detections (the "
                                              "bearings table's u, its colour labels unused; JointTracker."
                                              "detection_evidence), where the recording has them; on since the thirty-ninth "
                                              "session with share_fit_walks, whose tracks left standing on no one it rejects "
                                              "(off before: alone, development recordings gained and lost alike; "
                                              "docs/target_planes.md)")
        partial_detections: bool = param(True, "person_detections: also where a camera sees the person partly, as often "
                                                "detected as someone seen whole (a quarter or more of the projected width "
                                                "inside the image with every ray clear, or inside with two of three rays "
                                                "clear: tp_joint.detector_sees; rendered development 100-109 standing, "
                                                "scripts/measure_person_detections.py --views: detected 1.00 and 0.98), the "
                                                "chance of a detection in the gate from its span inside the image; on since "
                                                "the forty-third session (760 development recordings: no target lost, "
                                                "movers' MOTA on one more, false positives 2163 -> 2079)")
        p_person_detect: float = param(0.976, "person_detections: P(a detection within half the image width + 3 px of the "
                                              "axis) for a person wholly in the image, all three rays clear of the floor "
                                              "plan's boxes (development recordings 100-105, "
                                              "scripts/measure_person_detections.py: rendered 0.977, analytic 0.976)")
        person_miss_run: float = param(3.6, "person_detections: mean run of such a person's missed detections, frames (the "
                                            "same recordings: detected after a miss 0.269 rendered, 0.296 analytic)")
        coincidence_persistence: float = param(0.97, "person_detections: lag-1 persistence of a detection within the gate of a "
                                                     "standing point where no one is (the same recordings, points 1 m or more "
                                                     "from everyone: rendered 0.972, analytic 0.961)")
        flow_model_sigma: float = param(3.0, "flow error beyond the calibrated noise (a region's mean flow vs its "
                                             "centre's motion), px/s")
        fragment_flow_sigma: float = param(28.0, "horizontal flow error of a window narrower than half its one "
                                                 "person's projection (a fragment of the flow region), added in the "
                                                 "joint explanation's flow term only, px/s (rendered development "
                                                 "100-119, flow over 5 frames, windows of one walker: rms 29-30 px/s "
                                                 "under half the person's width against 11.5 whole, sqrt(30^2 - 11.5^2); "
                                                 "the vertical error does not grow); 0: off")
        area_margin: float = param(0.05, "allowance on target areas, m")
        window_margin_px: float = param(1.0, "allowance on windows, px (plus 3 sigma of the calibrated window noise)")
        consistency_margin: float = param(0.15, "a crossing starting a track may lie this far outside a window's "
                                                "target area, m")
        init_radius: float = param(0.5, "the hand-given initial position is this close to the target, m")
        wake_once: bool = param(True, "a track that may be standing pays the walking prior, -log(1 - mu), once over the "
                                "cameras that would see it, not in each one's explanation: each camera's share is "
                                "1 / their number (JointTracker.wake_share); the mode is then decided over all "
                                "cameras' evidence by own_wake. No parameter value (docs/target_planes.md, thirtieth "
                                "session: a person setting off after a short stop had windows explained as clutter "
                                "and a second track)")
        left_behind: bool = param(True, "an encounter decided without an exchange, one of whose tracks is likelier "
                                  "standing then, gives that track's identity to a track confirmed since the "
                                  "encounter began when, on 99:1 evidence, that track is the standing track's "
                                  "person walked on rather than someone new, the stand's duration counted with "
                                  "stand_s (tp_identity.IdentityLag._left_behind; found_again's scores). No "
                                  "parameter value (thirty-first session: no development output changed; seen "
                                  "head-on 1151 38.6 -> 81.1 %)")
        behind_at_birth: bool = param(True, "left_behind scores each candidate by its first state, at its birth at a "
                                            "two-camera crossing, not by its state at the decision (tp_identity.IdentityLag."
                                            "walked_on), as the successor tests do. No parameter value (forty-ninth "
                                            "session: of the 520 development recordings only head-on 131 changed, identity "
                                            "83.4 -> 98.3 %, RMSE with one camera 1.037 -> 0.157 m; seen rendered 2030 "
                                            "17.1 -> 23.1 %: the look-alike's track no longer takes the identity)")
        handover_reach: bool = param(True, "a hand-over's exchange holds from the encounter's nearest approach, as a "
                                     "pair's does (within the output lag): the survivor and the gone track exchange "
                                     "identities there, and the new track takes the survivor's from the gone "
                                     "track's end (tp_identity.IdentityLag._hand_over); off: all from the end. No "
                                     "parameter value (thirty-second session: head-on development 189 97.1 -> "
                                     "98.6 %, 172 98.0 -> 98.3 %, nothing else changed)")
        bridge_gaps: bool = param(True, "an identity's gap - frames between two of its reported rows, from different "
                                  "tracks that an identity decision joined (a hand-over, a person found again), where "
                                  "no track carried it - no longer than output_lag_s is reported, as the fixed-lag "
                                  "output's smoother would: the cubic through the rows' positions and velocities on "
                                  "either side, n_cameras 0, mode bridged (``bridge_gaps``). No parameter value")
        free_births: bool = param(True, "a crossing of target planes inside a wall or an obstacle of the floor plan "
                                  "(its clearance 0 or below: no one's axis can be there) neither starts a track nor "
                                  "locates the target (tp_initiate.propose's room test; the floor plan's outline "
                                  "alone without it). No parameter value (thirty-second session: analytic "
                                  "1181's look-alike got a track 0.6 m off, in the east wall)")
        ghost_test: bool = param(True, "a crossing of two target planes that two or more further cameras would see "
                                 "whole (in the image, not behind the floor plan's boxes) and show no window at is "
                                 "two people's planes crossing, not a person: it neither locates the target nor "
                                 "starts a track (``JointTracker.sees_no_one``; no parameter value: one camera "
                                 "seeing no one is common for people too - measured with "
                                 "scripts/measure_ghost_crossings.py, docs/target_planes.md)")
        smooth_output: bool = param(True, "report each track's walking state smoothed over the output lag: the "
                                    "fixed-lag Rauch-Tung-Striebel smoother over the frames up to output_lag_s "
                                    "after each frame, the output being final only then (``tp_smooth``; no parameter "
                                    "value: the filter's own transitions and covariances)")
        split_births: bool = param(False, "start a track at the far side of a window too wide for the one track it "
                                   "holds (eq. 8) when a second camera's window is too wide for one person as well "
                                   "(both see two people side by side; issue 12: a look-alike walking beside the "
                                   "target, merged with it in every view); off: it helps some recordings and hurts "
                                   "others, through its clutter-region updates more than its splits, which are rare "
                                   "(docs/target_planes.md)")
        fit_normalised: bool = param(True, "a window's fit to a track's prediction includes the Gaussian's "
                                     "normalisation, 0.5 log of the predicted centroid and flow variances over a "
                                     "perfectly located track's (no parameter value): a stopped person's spread-out "
                                     "walking state no longer takes a neighbour's window (with border_edges: movers' "
                                     "MOTA >= 0.9 on 166 instead of 141 of 260 development recordings; "
                                     "docs/target_planes.md)")
        rows_explain: bool = param(True, "the joint explanation weighs section 3.2's rows (rows_cost: a window's top "
                                   "above the projected head, its bottom below the projected feet, with the Gaussian's "
                                   "normalisation, rows_norm) for a window gated by two or more tracks: people on one "
                                   "line of sight differ in depth, so in their rows. Each track's rows are taken "
                                   "relative to the track they fit best and then to the track's own best window (they "
                                   "move a track between windows, never towards a miss); a track is not alone on such "
                                   "a window, nor a member of a merged one, when the window's rows do not reach its "
                                   "projected rows (rows_reach; rendered development: 3 of 240329 windows lie wholly "
                                   "above the 1.8 m head of everyone in their columns). No parameter value; on: the 520 "
                                   "development recordings meeting identity / RMSE >= 2 cameras / RMSE 1 camera / MOTA "
                                   "504 / 512 / 510 / 516 -> 508 / 514 / 514 / 516, head-on draw-1 107 lost "
                                   "(docs/target_planes.md, sixtieth session)")
        post_path: bool = param(True, "a pair's identity decision takes each track's velocity after the encounter "
                                "as its displacement over the identity lag (tp_identity.IdentityLag.post_state), not "
                                "the filter's velocity, which lags a walker whose windows were merged (no parameter "
                                "value; on: development identity 503 -> 504 of 520, head-on 180 gained, none lost; "
                                "docs/target_planes.md, fifty-eighth session)")
        dup_prior: bool = param(True, "two tracks alike now (nearer than 2 radius, states alike at the 99 % level: "
                                "DUPLICATE) are one person seen twice only if their predicted states, before this "
                                "frame's updates, pass the same test: two people pulled together by one frame's "
                                "updates (a window given to the wrong track) are two, and the younger is not "
                                "dropped. No parameter value (the duplicate test's own, on the predictions). On "
                                "since the sixty-fourth session: rendered 2635 (seen) 34.9 -> 100 %; no "
                                "development count changed (docs/target_planes.md)")
        occluded_rows: bool = param(True, "in the joint explanation a window of one confirmed track alone (located by two "
                                    "or more views last frame: mode planes) whose bottom row lies below the lowest row "
                                    "at which the floor plan lets the camera see that track's person (behind a shelf or "
                                    "a low wall: Occluders, 21 heights on its axis, over its cylinder and 2 sd of its "
                                    "position) costs 0.5 d^2 of the reach in window-edge sd, capped at 0.5 "
                                    "chi^2_2(0.99) as rows_cost: someone in front of the box likelier made it. No "
                                    "parameter value (the floor plan, the person model). On since the seventy-fourth "
                                    "session: the 520 development recordings, no count lost, analytic 104 gained, "
                                    "false positives 2019 -> 1775 (docs/target_planes.md)")
        hidden_miss: bool = param(True, "in the joint explanation a confirmed track located by two or more views last "
                                  "frame (mode planes) whose person the floor plan's boxes hide wholly from a camera "
                                  "(none of the rays to its body centre, chest, head and top of the head clear: "
                                  "Occluders) has no window there for free, as the mode posterior and the existence "
                                  "test already count it, instead of paying a clutter window. No parameter value (the "
                                  "floor plan, the person model). On since the seventieth session: rendered 2839 "
                                  "(seen) 96.6 -> 100 %; no development count changed (docs/target_planes.md)")
        wall_stops: bool = param(True, "a track no window explained this frame, predicted closer than radius to a wall of "
                                 "the floor plan or through it, is moved onto the line radius inside the wall along "
                                 "its own uncertainty (the constraint as an exact measurement; velocity corrected "
                                 "through its correlation, spreads kept) instead of being dropped off the floor "
                                 "plan: a walker unseen stops or turns at a wall. No parameter value (radius, the "
                                 "floor plan). On since the sixty-eighth session (docs/target_planes.md)")
        dup_standing: bool = param(True, "the duplicate test (alike, one_velocity) takes a track likelier standing (mu "
                                   ">= 0.5) at its standing mode: its standing position and covariance, velocity zero "
                                   "(tp_joint.duplicate_state). A walker passing a standing track is then two people "
                                   "unless its own velocity allows standing; on the walking state, its velocity "
                                   "decayed and its spreads grown while no camera told the modes apart, they were "
                                   "alike (rendered 3703 at 30.8 s). No parameter value (the modes' own states). On "
                                   "since the ninetieth session: the 520 development recordings, no count lost, "
                                   "head-on draw-1 165 gained, false positives 1723 -> 1609 (docs/target_planes.md)")
        border_windows: bool = param(True, "a walker cut by the image border makes a window with the flow tracker's "
                                     "measured chance by the columns of its projected cylinder inside the image "
                                     "(tp_joint.BORDER_WINDOW_RATE; rendered development 100-109, measure_tp_detection "
                                     "--border: 0 at up to 1 px, 0.13 at 2-3, 0.40 at 3-4, 0.75 at 4-6, 0.92 at 6-8, "
                                     "0.99 from 8 px on, as seen whole), in the mode posterior's and the existence "
                                     "test's P(no window | walking): a walker leaving a view is not taken for one who "
                                     "stopped, nor rejected, for the sliver it leaves (head-on 3701 at 22.6 s). On since "
                                     "the ninetieth session: the 520 development recordings, no count changed "
                                     "(docs/target_planes.md)")
        dup_velocity: bool = param(True, "two tracks alike (the duplicate test, and dup_prior's) are one person seen twice "
                                   "only if their velocity difference is at least as likely for one person (the sum "
                                   "of their velocity covariances) as for two walking independently (each with the "
                                   "largest velocity spread a track is given, max_speed / 2 per axis): tracks made "
                                   "uncertain by merged windows pass the 99 % test however their velocities differ "
                                   "(tp_joint.one_velocity; no parameter value). On since the sixty-seventh session: "
                                   "head-on 2724 (seen) RMSE 0.153 -> 0.105 m, head-on development 109 70.6 -> "
                                   "99.7 %; no development count lost (docs/target_planes.md)")
        border_edges: bool = param(True, "a window ending at an image border, of a track predicted across it, is the "
                                   "visible part of someone cut by it (rendered: 21 % of windows end at a border; "
                                   "their centroids lie a median 7 px inwards of the axis, their inner edges within "
                                   "1 px of the projected cylinder's): compared with the projected cylinder clipped "
                                   "to the image, and its inner edge, not its centroid, is the measured column")
        edge_share: bool = param(True, "a merged window's outer edge that lies inside the extent its outermost predicted "
                                       "member would reach (that member's region falls short, or it made none: slowing, "
                                       "standing) is shared among the members by how well each one's predicted edge "
                                       "explains it (Gaussian in the edge noise and the member's projected spread), "
                                       "each updated by its share (probabilistic data association); an edge at or "
                                       "beyond that member's prediction stays its own")
        adopt: bool = param(False, "single-target mode: while the hand-chosen target is not yet located, a confirmed "
                                   "track whose first state, taken back to the first frame by the walker model, is "
                                   "likelier at the click than someone anywhere on the floor becomes the target "
                                   "(``JointTracker.adopt``; no parameter value: the click's spread init_radius, "
                                   "accel_sigma and the floor area); off: on development seeds it found the target "
                                   "on 3 recordings and lost it on none, on fresh evaluation seeds 580-589 it took the "
                                   "look-alike on analytic 586 (docs/target_planes.md)")
        locate_tracks: bool = param(True, "single-target mode: while the hand-chosen target is not yet located, an "
                                          "unconfirmed track started since (from a crossing locate did not take) "
                                          "whose filtered state passes locate's own test becomes the target "
                                          "(``JointTracker.locate_track``; no parameter value). On: development "
                                          "analytic 146 20.6 -> 100 %, 150 4.3 -> 100 %, head-on 100 8.6 -> 100 %, "
                                          "no recording worse (docs/target_planes.md)")
        locate_back: bool = param(True, "locate_tracks: a track also passes locate's test where it was at the first "
                                        "frame, its filtered position taken back at its velocity (the target walks off "
                                        "between the click and the first crossing on it; no parameter value). On: "
                                        "analytic evaluation 1830 (seen) 29.4 -> 99.1 %; every output of 520 "
                                        "development recordings unchanged (docs/target_planes.md)")
        successor_lagged: bool = param(False, "with rejected_successor, a candidate successor must have been born "
                                       "while the target's track had a window of its own in fewer than two cameras "
                                       "(it lagged behind its person); one born beside it while it was seen in two "
                                       "views is someone else. No parameter value: the rule's own premise (a track born "
                                       "on its person while it lagged). Trial in the fifty-ninth session (analytic 2472, "
                                       "seen), on in the sixty-third, off since the sixty-fourth: successor_recent "
                                       "separates the development candidates without refusing a rightful one "
                                       "(head-on 101) (docs/target_planes.md)")
        successor_recent: bool = param(True, "with rejected_successor, a candidate successor must have been born "
                                       "no earlier before the target's track's rejection began than the existence test "
                                       "takes to reject a walker lost in one camera's view (tp_joint.JointTracker.reject_s: "
                                       "2.5 s at the measured p_detect and miss_run, 10 frames a second); one born "
                                       "earlier was born while the target's track was still on someone. No parameter "
                                       "value: derived from the existence test's. On since the sixty-fourth session: of "
                                       "the 13 development candidates (exchanges off) it keeps the 3 rightful, born "
                                       "0.9-1.8 s before the rejection, and refuses 4 born 8.2-11.4 s before; head-on "
                                       "101 93.7 -> 99.7 %, no development recording worse (docs/target_planes.md)")
        successor_found_again: bool = param(True, "with rejected_successor, a candidate successor is scored against "
                                            "someone new or the person of a confirmed track that ended before its birth "
                                            "(found again, walked on or stopped: tp_identity._continues_state, as "
                                            "multi-person relink scores one), at equal odds, not against someone new "
                                            "alone. No parameter value. On since the sixty-fourth session: head-on 2636 "
                                            "(seen), the look-alike's track dropped as a duplicate of the target's in the "
                                            "pass-through and born again scored 4.72 as the successor, -1.02 with it; "
                                            "the development candidates' decisions unchanged (docs/target_planes.md)")
        rejected_successor: bool = param(True, "single-target mode: the target's track, never dropped, rejected by the "
                                               "existence test while likelier walking passes the target's identity to a "
                                               "track born on its person while it lagged and sharing no merged window with "
                                               "it (tp_identity's successor score at 99:1; no parameter value). On: rendered "
                                               "evaluation 1849 (seen) 42.0 -> 100 %; every output of 520 development "
                                               "recordings unchanged (docs/target_planes.md)")
        init_min_cameras: int = param(2, "cameras whose windows' planes must cross before a track starts")
        handover: bool = param(True, "an encounter one of whose tracks ended is decided identity_lag_s after the "
                                     "end with the tracks confirmed since it began: the survivor may have come out "
                                     "on the other person, and a new track on its own (tp_identity); on, with "
                                     "identity_accel: head-on development identity 92.8 -> 97.7 % mean, no "
                                     "recording worse, rendered and analytic development identical "
                                     "(docs/target_planes.md)")
        confirm_frames: int = param(5, "frames with a window of its own before a track is reported")
        pair_log_odds: float = param(float(np.log(2422 / 11)), "a pair's identities are exchanged when log L(X) - log L(K) "
                                     "exceeds this (tp_identity.IdentityLag.decide): Bayes' decision at the prior odds "
                                     "of an exchange among the pair decisions of the 520 development recordings, "
                                     "labelled from the truth (scripts/measure_tp_identity.py: 11 exchanged of 2433, "
                                     "log(2422 / 11) = 5.39; log 99 until the fifty-third session)")
        handover_log_odds: float = param(float(np.log(109 / 8)), "a hand-over is made when its log-odds exceed this "
                                         "(tp_identity.IdentityLag._hand_over): Bayes' decision at the prior odds, "
                                         "measured as pair_log_odds' (8 made rightly of 117 hand-overs scored, "
                                         "log(109 / 8) = 2.61; log 99 until the fifty-third session)")
        successor_log_odds: float = param(float(np.log(3)), "with rejected_successor, the watched track's successor "
                                          "takes its identity when the successor log-odds exceed this "
                                          "(tp_identity.IdentityLag._watched_successor): Bayes' decision at the prior "
                                          "odds, measured as pair_log_odds' on the 520 development recordings' "
                                          "successor candidates (successor_recent and successor_found_again, exchanges "
                                          "off; one decision per candidate, at its first scored frame; 9 candidates, one "
                                          "labelled ambiguous - the target's track as near two people at its birth - "
                                          "and 2 rightful of the other 8: log(6 / 2) = 1.10; a small sample: the "
                                          "prior's 95 % interval gives levels -0.4 to 2.6, and any level from -1.9 "
                                          "to 2.4 decides every development candidate alike). log 99 until the "
                                          "sixty-third session, log(3 / 2) with successor_lagged in the sixty-third, "
                                          "log 2 in the sixty-fourth (3 of 9, the ambiguous one counted rightful)")
        pre_while_apart: bool = param(True, "an encounter's pre states, when the pair first comes within 4 radius, are those "
                                           "of its last frame before, merged in a view or not (not only of its last merged "
                                           "frame: a pair apart and merged nowhere is not in doubt either); on since the fifty-third "
                                           "session (development 520: identity 501 -> 502, head-on 195 40.3 -> 100 %, "
                                           "nothing else changed)")
        decide_apart: bool = param(True, "a pair that has come within 4 radius is decided identity_lag_s after it is "
                                         "apart on the floor again, even while a view still sees the two merged (the "
                                         "encounter goes on from there); without it the decision waited until no view "
                                         "merged them, up to 12 s later, and a walker model over that span tells nobody "
                                         "apart. On since the fifty-fourth session (development 520: identity 502 -> 503, "
                                         "head-on 120 31.7 -> 99.7 %, nothing else changed)")
        since_confirmed: bool = param(True, "a hand-over's or a left-behind decision's candidates are the tracks "
                                            "confirmed since the encounter's pre states, as the design says, not only "
                                            "those born since (a track born just before and confirmed after is one). "
                                            "On since the fifty-fourth session (development 520: RMSE >= 2 cameras "
                                            "509 -> 510, analytic 158 identity 94.9 -> 98.6 %, nothing else changed)")
        identity_accel: float = param(0.35, "white acceleration of the walker model that predicts a pair's states "
                                           "across an encounter in the identity decision (exchanges, hand-overs), "
                                           "m/s^2/sqrt(Hz): the largest the scenes' walkers show on development truth "
                                           "(0.14-0.35; the tracker's accel_sigma also absorbs its own model errors)")
        identity_lag_s: float = param(1.0, "fixed lag of the output, s (the issue: a smoother over the last "
                                           "second, 10 frames at the cameras' 10 fps): identities after two tracks "
                                           "were ambiguous are decided this long after they part (``tp_identity``), "
                                           "and a track is reported from this long before its confirmation (in "
                                           "multi-person mode moved back along its velocity before its birth); "
                                           "0: no lag (the tracker's own identities, tracks from confirmation)")
        output_lag_s: float = param(3.5, "how long after a frame the output may still change, s (at least "
                                         "identity_lag_s): an exchange decided identity_lag_s after a pair parted "
                                         "holds from the pair's nearest approach within this reach, not from their "
                                         "parting; 3.5 s = the decision's 1 s + 2.5 s, the most by which the true "
                                         "swap came before the parting on the development exchanges (0.4-2.5 s; "
                                         "tp_identity.IdentityLag.reach, docs/target_planes.md)")
        relink: bool = param(True, "multi-person mode: a newly confirmed track takes the identity of a confirmed "
                                   "track that ended within hold_s when it likelier continues that person's "
                                   "predicted state than it is someone new on the floor (``tp_identity``; needs "
                                   "identity_lag_s > 0)")
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
        if not cfg.flow_gain > 0:
            raise EstimatorError(f"{self.name}: flow_gain must be a positive number (a window's flow over its person's "
                                 f"image velocity; measured 0.92), got {cfg.flow_gain!r}")
        if not (0.0 <= cfg.width_tail < 1.0 and cfg.width_tail_sigma > 0):
            raise EstimatorError(f"{self.name}: width_tail must be a probability below 1 and width_tail_sigma positive (a gross "
                                 f"width error's share and spread; measured 0.03 and 0.34), got {cfg.width_tail!r} and "
                                 f"{cfg.width_tail_sigma!r}")
        if not cfg.multi_person and cfg.initial_xy is None and cfg.initial_window is None:
            raise EstimatorError(
                f"{self.name}: the target is chosen by hand: give initial_xy=[x, y] (its floor position at the "
                "first frame, m) or initial_window=[camera, u_left, u_right, v_top, v_bottom], or multi_person=true "
                "to track every mover (on the command line: --param multi_person=true)"
            )
        Ps = {c: np.asarray(calibration.cameras[c].P, float) for c in cams}
        frames = split_boxes(boxes, cams, cfg.flow_window)
        times = frame_times(calibration, cams, observations.duration, boxes)
        # per-frame flow noise (px/s): the calibrated region-mean flow noise, or window-edge noise
        # x fps for recordings without it (a mean over flow_window frames of one camera track is
        # not flow_window independent measurements a frame: consecutive means share frames)
        flow_sigma = {c: float(cfg.flow_sigma_px_s) if cfg.flow_sigma_px_s is not None else float(cfg.box_sigma_px) * calibration.cameras[c].fps for c in cams}
        jt = JointTracker(cfg, Ps, {c: float(calibration.cameras[c].width) for c in cams}, flow_sigma, float(cfg.box_sigma_px), float(cfg.box_u_sigma_px),
                          {c: float(calibration.cameras[c].fps) for c in cams})
        jt.occluders = Occluders(calibration.floorplan, Ps, cfg.height)
        # the person detections: person_detections and detection_planes use them where the
        # recording has them (a recording of flow windows alone: none; the result says which)
        detections, det_cams = person_detections(observations, cams) if (cfg.person_detections or cfg.detection_planes) else (None, [])
        jt.outline = np.asarray(getattr(calibration.floorplan, "outline", np.zeros((0, 2))), float).reshape(-1, 2)
        inside_room = calibration.floorplan.inside
        # where a person's axis can be: off the walls and obstacles too (``free_births``)
        free_floor = functools.partial(clear_of_walls, calibration.floorplan) if cfg.free_births else inside_room
        tracks: list[JointTrack] = []
        keep = None
        if not cfg.multi_person:
            xy0, accept = self._initial_target(cams, Ps, frames.get(float(times[0]), {}) if len(times) else {}, inside_room)
            sv = 0.5 * cfg.max_speed
            tr = JointTrack(0, np.r_[xy0, 0.0, 0.0], np.diag([cfg.init_radius**2] * 2 + [sv**2] * 2), confirmed=True, seen=True, located=False)
            click = (float(times[0]) if len(times) else 0.0, tr.s[:2].copy(), tr.S[:2, :2].copy())
            tracks.append(tr)
            keep = 0
        next_id = len(tracks)
        # who is who after an encounter: decided lag_s after it (tp_identity); 0: as tracked
        idl = IdentityLag(cfg.identity_lag_s, cfg.accel_sigma, cfg.radius, watch=keep) if cfg.identity_lag_s > 0 else None
        floor_area = geo.polygon_area(jt.outline)
        if idl is not None:
            # someone new: anywhere on the floor, at a walker's velocity (the new-track spread)
            idl.handover, idl.area, idl.sigma_v = cfg.handover, (floor_area if floor_area > 0 else None), 0.5 * cfg.max_speed
            idl.decide_accel = cfg.identity_accel
            idl.pair_log_odds, idl.handover_log_odds = cfg.pair_log_odds, cfg.handover_log_odds
            idl.successor_log_odds = cfg.successor_log_odds
            idl.pre_while_apart, idl.decide_apart = cfg.pre_while_apart, cfg.decide_apart
            idl.output_lag_s = cfg.output_lag_s
            idl.left_behind, idl.stand_s = cfg.left_behind, cfg.stand_s
            idl.behind_at_birth, idl.since_confirmed = cfg.behind_at_birth, cfg.since_confirmed
            idl.handover_reach = cfg.handover_reach
            idl.post_path = cfg.post_path
            if cfg.rejected_successor and not cfg.multi_person:
                idl.successor_reject, idl.hold_s = EXIST_REJECT, cfg.hold_s
                idl.successor_lagged = cfg.successor_lagged
                idl.successor_found_again = cfg.successor_found_again
                if cfg.successor_recent and len(times) > 1:
                    idl.successor_recent_s = jt.reject_s(float(np.median(np.diff(times))))
        if idl is not None and cfg.multi_person and cfg.relink and floor_area > 0:
            idl.relink_area, idl.hold_s, idl.walk_s = floor_area, cfg.hold_s, cfg.walk_s
        st = _RunState(tracks, keep, next_id, idl, float(times[0]) if len(times) else 0.0)

        def advance(st: _RunState, t: float, probe: bool = False, force=None) -> None:
            """One frame of the tracker on state ``st`` (``probe``: the target's track probed for a
            second explanation, ``jt.branch``; ``force``: a camera's explanation forced, ``jt.step``)."""
            dt, st.t_prev = t - st.t_prev, t
            frame = {c: frames.get(t, {}).get(c, CameraBoxes.empty()) for c in cams}
            if detections is not None:
                now = detections.get(round(t, 6), {})
                jt.detections = {c: now.get(c, NO_DETECTIONS) for c in det_cams}
            target = st.target()
            free = jt.step(st.tracks, frame, dt, target if probe else None, force)
            stepped = {id(tr): tr.s.copy() for tr in st.tracks} if cfg.smooth_output else {}
            st.cost += jt.frame_cost
            st.branch = jt.branch
            locating = target is not None and not target.located
            prefer = functools.partial(jt.locate_distance, target, accept) if locating else None
            ghost = (lambda c, xy: jt.sees_no_one(c, xy, frame[c])) if cfg.ghost_test else None
            proposals = propose(cfg, jt.margin_px, Ps, frame, free, free_floor, prefer, ghost, jt.not_one_person)
            taken = jt.locate(target, proposals, frame, accept) if locating else set()
            for k, (xy, support) in enumerate(proposals):
                if k in taken or any(jt.covers(tr, xy) for tr in st.tracks if tr.located):
                    continue  # a tracked person (its far side, a fragment): not someone new
                st.tracks.append(jt.birth(st.next_id, xy, support, frame))
                st.tracks[-1].born = (t, st.tracks[-1].s.copy(), st.tracks[-1].S.copy())
                st.next_id += 1
            if cfg.split_births:
                # a too-wide window's far side that one other camera's window confirms (tp_joint.JointTracker.split)
                used = {(c, j) for _, support in proposals for c, j in support.items()}
                for new in jt.split(st.tracks, frame, used, inside_room):
                    new.tid = st.next_id
                    st.tracks.append(new)
                    st.next_id += 1
            found = None
            if cfg.locate_tracks and target is not None and not target.located:
                found = jt.locate_track(target, st.tracks, accept, t, click[0])  # a track started off the click, filtered onto it
            if found is None and cfg.adopt and target is not None and not target.located:
                found = jt.adopt(target, st.tracks, click, floor_area)  # someone else's track started on the target: it is the target
            if found is not None:
                st.tracks = [tr for tr in st.tracks if tr is not found]  # the target's track took it over
            st.tracks = jt.prune(st.tracks, st.keep, inside_room)
            st.end_rows += [(t, tr.tid, tr.s[0], tr.s[1], why, other) for tr, why, other in jt.ends]
            if st.idl is not None:
                st.idl.update(t, st.tracks)
                if st.keep is not None:
                    st.keep = st.idl.holder(0)  # the target's track (an exchange may have moved it)
            for tr in st.tracks:
                # every track is kept for now (in single-target mode too: the identity decision
                # may hand the target's identity to another track retroactively, within the lag)
                x, C = tr.mode_weighted()
                st.rows.append((t, tr.tid, x[0], x[1], x[2], x[3], tr.n_used, tr.mode, tr.confirmed, C[0, 0], C[0, 1], C[1, 1]))
                # the chain is cut where the prediction capped the spreads or something after the
                # frame's updates moved the track (located, taken over, put back on the floor)
                cut = tr.capped or id(tr) not in stepped or not np.array_equal(stepped[id(tr)], tr.s)
                st.smooth.append((tr.tid, tr.s.copy(), tr.S.copy(), tr.prior, tr.F, cut,
                                  tr.mu, tr.xs, None if tr.xs is None else tr.Ps.copy()) if cfg.smooth_output else None)
                for c in cams:
                    status, reason, win = tr.status.get(c, (LOST, "", None))
                    st.status_rows.append((t, tr.tid, c, status, reason, win))

        ahead = max(int(round(cfg.identity_lag_s * min(float(calibration.cameras[c].fps) for c in cams))), 1)
        lookaheads = []
        k = 0
        while k < len(times):
            t = float(times[k])
            probe = cfg.lookahead and st.keep is not None
            fork = st.fork() if probe else None
            advance(st, t, probe)
            k += 1
            if not probe or st.branch is None or st.branch[0] >= LOOKAHEAD_GAP:
                continue
            # two explanations of the target within the 99:1 level: both are followed for the
            # identity lag's frames (the fork from the state before this frame)
            gap, c_alt, j_alt = st.branch
            cost0 = fork.cost
            advance(fork, t, force=(c_alt, fork.target(), j_alt))
            same = {tr.tid for tr in st.tracks} == {tr.tid for tr in fork.tracks}
            for t_next in times[k:k + ahead]:
                advance(st, float(t_next))
                advance(fork, float(t_next))
                same &= {tr.tid for tr in st.tracks} == {tr.tid for tr in fork.tracks}
            k += len(times[k:k + ahead])
            # the second is taken on 99:1 evidence, as every other decision (``same``, for
            # diagnosis: whether both held the same tracks throughout; the costs hold no birth or
            # death prior, so hypotheses with different tracks are compared on unequal footing -
            # docs/target_planes.md, the twentieth session)
            taken = fork.cost < st.cost - LOOKAHEAD_GAP
            lookaheads.append((t, c_alt, j_alt, gap, st.cost - cost0, fork.cost - cost0, same, taken))
            if taken:
                st.take(fork)
        tracks, idl = st.tracks, st.idl
        rows, status_rows, end_rows = st.rows, st.status_rows, st.end_rows
        if idl is not None:
            idl.finish(tracks)
        if cfg.smooth_output and len(times) > 1:
            rows = smoothed_rows(rows, st.smooth, int(round(cfg.output_lag_s / float(np.median(np.diff(times))))))
        internal = pd.DataFrame(rows, columns=["t", "track_id", "x", "y", "vx", "vy", "n_cameras", "mode", "confirmed", "cxx", "cxy", "cyy"])
        tracks_df = internal.drop(columns=["cxx", "cxy", "cyy"])
        status_df = pd.DataFrame(status_rows, columns=STATUS_COLUMNS)
        ends = pd.DataFrame(end_rows, columns=["t", "track_id", "x", "y", "reason", "other"])
        # a track is reported once confirmed, and - the output being fixed-lag - from up to
        # identity_lag_s before its confirmation: its first frames, from its birth, when it was
        # confirmed within the lag (an unconfirmed track's frames are never reported otherwise)
        tracks_df["confirmed"] = tracks_df["confirmed"].astype(bool)
        t_conf = tracks_df[tracks_df["confirmed"]].groupby("track_id")["t"].min()
        since = tracks_df["track_id"].map(t_conf).to_numpy(float)  # NaN: never confirmed
        report = tracks_df["confirmed"].to_numpy() | (tracks_df["t"].to_numpy() >= since - max(cfg.identity_lag_s, 0.0) - 1e-9)
        tracks_df = tracks_df[report].drop(columns="confirmed").reset_index(drop=True)
        since_st = status_df["track_id"].map(t_conf).to_numpy(float)
        status_df = status_df[status_df["t"].to_numpy() >= np.where(np.isnan(since_st), np.inf, since_st - max(cfg.identity_lag_s, 0.0) - 1e-9)].reset_index(drop=True)
        if cfg.multi_person:
            tracks_df = self._extend_back(tracks_df, t_conf, np.asarray(times, float), inside_room)
        if idl is not None:
            tracks_df["track_id"] = idl.relabel(tracks_df["t"].to_numpy(), tracks_df["track_id"].to_numpy())
            status_df["track_id"] = idl.relabel(status_df["t"].to_numpy(), status_df["track_id"].to_numpy())
        if not cfg.multi_person:
            tracks_df = tracks_df[tracks_df["track_id"] == 0].reset_index(drop=True)
            status_df = status_df[status_df["track_id"] == 0].reset_index(drop=True)
        if idl is not None and cfg.bridge_gaps:
            tracks_df = bridge_gaps(tracks_df, np.asarray(times, float), idl.final_s, inside_room)
        decisions = pd.DataFrame([{**{k: v for k, v in h.items() if not isinstance(v, np.ndarray)},
                            **{f"{k}_{a}": float(v[i]) for k, v in h.items() if isinstance(v, np.ndarray) for i, a in enumerate("xy")}}
                           for h in (idl.decisions if idl is not None else [])])
        return TargetPlanesResult(tracks_df, status_df, internal, ends, decisions, np.asarray(times, float),
                                  pd.DataFrame(lookaheads, columns=["t", "camera", "window", "gap", "cost", "cost_alt", "same", "taken"]),
                                  detections is not None)

    def _extend_back(self, tracks_df: pd.DataFrame, t_conf: pd.Series, times: np.ndarray, inside_room) -> pd.DataFrame:
        """Multi-person mode: each reported track's frames before its birth, back to
        ``identity_lag_s`` before its confirmation, at its first reported position moved back
        along its velocity at confirmation (constant velocity: the fixed-lag output's smoother
        over the frames before the two-camera crossing that started it); ``n_cameras`` 0, ``mode``
        ``extrapolated``. Not on the floor plan, or within 4 ``radius`` of another reported track
        then (someone else's, or the same person's previous track): not added."""
        cfg = self.config
        lag = max(cfg.identity_lag_s, 0.0)
        if lag <= 0 or not len(tracks_df):
            return tracks_df
        first = tracks_df.sort_values("t", kind="stable").groupby("track_id").head(1)
        at_conf = tracks_df.set_index(["track_id", "t"])
        extra = []
        for r in first.itertuples():
            tc = float(t_conf[r.track_id])
            ts = times[(times >= tc - lag - 1e-9) & (times < r.t - 1e-9)]
            if not len(ts):
                continue
            v = at_conf.loc[(r.track_id, tc), ["vx", "vy"]].to_numpy(float)
            xy = np.c_[r.x + v[0] * (ts - r.t), r.y + v[1] * (ts - r.t)]
            ok = np.asarray(inside_room(xy), bool).reshape(-1)
            for t, (x, y) in zip(ts[ok], xy[ok]):
                other = tracks_df[(np.abs(tracks_df["t"].to_numpy() - t) < 1e-6) & (tracks_df["track_id"].to_numpy() != r.track_id)]
                if len(other) and float(np.hypot(other["x"] - x, other["y"] - y).min()) < 4.0 * cfg.radius:
                    continue
                extra.append((t, r.track_id, x, y, v[0], v[1], 0, "extrapolated"))
        return with_rows(tracks_df, extra)

    # ------------------------------------------------------------------------------------------
    def _initial_target(self, cams, Ps, frame0, inside_room):
        """The hand-chosen target: its floor position at the first frame and the test a
        two-camera crossing must pass to locate it (``JointTracker.locate``): within
        ``init_radius`` + 2 ``radius`` of ``initial_xy``, or inside the single-camera target area
        (section 3.2) of the ``initial_window``'s window (its middle depth is the start)."""
        cfg = self.config
        if cfg.initial_xy is not None:
            xy = np.asarray(cfg.initial_xy, float)
            if xy.shape != (2,) or not np.isfinite(xy).all():
                raise EstimatorError(f"{self.name}: initial_xy must be [x, y] in metres, got {cfg.initial_xy!r}")
            if not on_floor(inside_room, xy):
                raise EstimatorError(f"{self.name}: initial_xy {cfg.initial_xy!r} lies outside the room's floor plan")
            return xy, lambda p: float(np.linalg.norm(np.asarray(p, float) - xy)) <= cfg.init_radius + 2.0 * cfg.radius
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
        return xy, lambda p: area.contains(p, cfg.radius)


def clear_of_walls(floorplan, xy) -> np.ndarray:
    """Whether floor points xy (n, 2) lie in the room and outside every wall and obstacle of the
    floor plan (clearance above 0: a person's axis can be there)."""
    return np.asarray(floorplan.clearance(np.asarray(xy, float)), float) > 0.0


def bridge_gaps(tracks_df: pd.DataFrame, times: np.ndarray, max_gap_s: float, inside_room) -> pd.DataFrame:
    """Each identity's frames without a row between two of its rows (the end of one track and the
    start of the next that an identity decision gave that identity: a hand-over, a person found
    again), when the gap between the rows is at most ``max_gap_s`` (the output lag: a fixed-lag
    smoother has both ends before those frames are final): the person was there, so the output
    reports the cubic Hermite curve through the two rows' positions and velocities; ``n_cameras``
    0, ``mode`` ``bridged``. A bridge that leaves the floor plan is not added, nor one after an
    ``extrapolated`` row (inside a track's extension back from its birth, whose frames near
    another reported track ``_extend_back`` leaves out)."""
    if not len(tracks_df):
        return tracks_df
    extra = []
    for ident, g in tracks_df.sort_values("t", kind="stable").groupby("track_id"):
        t = g["t"].to_numpy(float)
        k = np.searchsorted(times, t - 1e-6)  # each row's frame
        # a gap after an extrapolated row lies inside one track's extension back from its birth,
        # whose frames ``_extend_back`` left out on purpose (near another reported track)
        inside = (g["mode"].to_numpy() == "extrapolated")[:-1]
        for i in np.flatnonzero((np.diff(k) > 1) & (np.diff(t) <= max_gap_s + 1e-9) & ~inside):
            t0, t1 = t[i], t[i + 1]
            ts = times[k[i] + 1:k[i + 1]]
            ends = g.iloc[[i, i + 1]]
            curve = CubicHermiteSpline([t0, t1], ends[["x", "y"]].to_numpy(float), ends[["vx", "vy"]].to_numpy(float))
            xy, v = curve(ts), curve(ts, 1)
            if not np.all(np.asarray(inside_room(xy), bool)):
                continue
            extra += [(float(tk), ident, float(x), float(y), float(vx), float(vy), 0, "bridged")
                      for tk, (x, y), (vx, vy) in zip(ts, xy, v)]
    return with_rows(tracks_df, extra)


def smoothed_rows(rows: list, smooth: list, lag: int) -> list:
    """The output rows with each track's walking state smoothed over the ``lag`` frames after it
    (``smooth_output``, ``tp_smooth``); a row's position and its covariance are the mode-weighted
    ones (``tp_joint.mode_weighted``, as ``JointTrack.estimate`` and ``position_cov``: the walking
    state smoothed, the standing mode's as filtered)."""
    states = smooth_chains([None if r is None else r[:6] for r in smooth], lag)
    out = []
    for row, r, st in zip(rows, smooth, states):
        if r is not None and st is not None:
            x, C = mode_weighted(*st, *r[6:9])
            row = (*row[:2], *map(float, x), *row[6:9], float(C[0, 0]), float(C[0, 1]), float(C[1, 1]))
        out.append(row)
    return out


def with_rows(tracks_df: pd.DataFrame, extra: list) -> pd.DataFrame:
    """The output rows with ``extra`` rows (tuples in its columns' order) added, in time and
    track order."""
    if not extra:
        return tracks_df
    out = pd.concat([tracks_df, pd.DataFrame(extra, columns=tracks_df.columns)], ignore_index=True)
    return out.sort_values(["t", "track_id"], kind="stable").reset_index(drop=True)
