"""Joint design of ``target_planes`` (issue 12): every mover is a track, each camera's windows explained jointly.

Each track (``JointTrack``) is a person model of the paper (a vertical cylinder of ``height`` and
``radius``) with state s = [x, y, vx, vy] (floor position, m; velocity, m/s) and covariance S.
Per frame:

1. **Predict**: s <- F s, S <- F S F^T + Q, white acceleration of spectral density
   ``accel_sigma``^2. A track that no window explained in the last frame has most likely stopped
   (a flow tracker sees no one standing): its velocity decays by exp(-dt / ``stop_tau``). The
   position's standard deviation is capped at ``sigma_max``.
2. **Explain each camera's windows jointly** (``explain_camera``): every window is one track, a
   group of two or three tracks merged into one flow region (extent: the union of their projected
   cylinders; flow: the mean of their predicted image velocities, its spread added to the noise),
   or clutter; every track has at most one window (none: occluded, out of view or standing).
   Cost of a hypothesis: sum over explained windows of 0.5 d^2 (Mahalanobis, features: centre u,
   width - one-sided: a window cut by an obstacle is narrower -, flow u, flow v; a window ending
   at an image border that its track is predicted across is compared with the projection clipped
   to the image, ``border_side``; a window wider than predicted may be a gross error of one
   edge, probability ``width_tail``, measured on the rendered windows, which moves the centre by
   half the excess: the centre and width terms are then that mixture's; a window narrower than
   half its one track's projection, a fragment of the flow region, has ``fragment_flow_sigma``
   added to its horizontal flow noise, ``fragment_var``) and, with
   ``fit_normalised`` (the default), the Gaussian's
   normalisation against a perfectly located track's (``explain_terms``), plus
   ``c_clutter`` per clutter window and ``c_miss`` per moving track without a window (0 for a
   track predicted to stand still: it makes no window). Both are 0.5 chi^2_4(0.99): a window is
   explained by a track when that is likelier than a missed track plus a clutter window at the
   99 % gate. With ``rows_explain`` (the default) a window that two or more tracks gate adds,
   for a track alone on it, section 3.2's rows (its top above the projected head, its bottom
   below the projected feet: people on one line of sight differ in depth, so in their rows)
   relative to the gating track they fit best and to the track's own best window
   (``rows_relative``), and holds no track, alone or merged, whose projected rows its own do not
   reach (``rows_reach``). With ``occluded_rows`` (the default) a window of one confirmed track
   alone (mode planes) reaching below the lowest row at which the floor plan's boxes let the
   camera see its person adds 0.5 min(d^2, chi^2_2(0.99)), d the reach in edge-noise sd
   (``seen_bottoms``, ``occluded_rows_cost``): someone in front of the box likelier made it.
   Solved exactly by enumeration over each connected component of the
   gating graph (a track gates a window whose extent, widened by 3 sigma, holds its predicted axis), with
   ``scipy.optimize.linear_sum_assignment`` on single-person explanations where a component
   has more than ``MAX_HYPOTHESES`` hypotheses.
3. **Update** (Kalman; every measurement is linear in s):
   - a window that is one track: its centroid's target plane a [x, y]^T = b (eqs. 3-5, the row
     normalised so the residual is in metres; sigma = sigma_u / |du/dxy|; for a window cut by
     the image border, ``border_edges``: its inner edge's plane, the axis a ``radius`` beyond it); its single-camera
     target area's depth range (section 3.2), applied only when the prediction lies outside it,
     with sigma = ``radius``; its flow g J V = f (eq. 7, J at the predicted body centre; g the
     detector's gain ``flow_gain``, 1 by default, measured 0.92), skipped
     as an outlier beyond chi^2_2(0.999) (the rendered flows' tails are heavy). The flow is the
     mean over the camera track's last ``flow_window`` frames, the velocity of about
     (flow_window - 1) / 2 frames ago: with ``flow_lag`` its noise includes the walker's
     velocity change over the mean, accel_sigma^2 ``tp_frames.mean_lag_s`` (m/s)^2 per floor
     axis through J (0.12 (m/s)^2 at 5 frames, 10 fps), so a walker setting off is not held
     back by its lagging flow. With several
     cameras the plane updates are eq. 6's least-squares intersection, weighted.
   - a window wider than that one person (eq. 8 ratio above ``width_ratio_threshold``:
     someone untracked walks in it): only its edge on the track's side (the plane of that edge
     column moved ``radius`` inwards) and its flow, both with doubled sigma; its far side is a
     birth candidate.
   - a merged window: its outer edges for the outermost members (edge planes moved ``radius``
     inwards, doubled sigma: an edge may belong to a partly hidden member; refused beyond the
     plane outlier gate, where a window of the track alone takes the state as astray:
     ``update_plane``'s ``own``), its flow for every
     member with the spread of their predicted flows added to the noise, but only when they move
     alike (spread within the flow noise): the flow of people crossing is a mixture that would
     draw their velocities together. Inner members get no position.
4. **Births** (``tp_initiate.propose``): windows explained as clutter, and the far side of a
   too-wide single window, start a track only where two cameras' target planes cross inside
   both windows' target areas, at least 2 ``radius`` from every track and outside its 99 %
   position gate. **Split births** (``split``, when ``split_births``): a window too wide for the
   one confirmed track it holds (explained as it, or clutter holding its projected cylinder with
   its flow within the track's gate: ``wide_clutter``, which then gives the track its near edge
   and the region's flow and counts as a merged window for the existence test) for
   ``confirm_frames`` frames running, and a second camera's window too wide for one person as
   well (both cameras see two people side by side): the two sides' target planes of the one
   camera cross the two sides' planes of the other at the two people, 2 ``radius`` apart, both
   projected cylinders inside both windows, and no camera contradicts (``contradicts``):
   the track moves to the near crossing, a new one starts at the far one and counts its merged
   windows as hits. A track is reported after
   ``confirm_frames`` frames with a window; an unconfirmed track without a window is dropped,
   a confirmed one after ``hold_s`` without any, or when the existence test (below) rejects it;
   of two tracks nearer than 2 ``radius`` with states alike the younger is dropped (one person
   seen twice; with ``dup_prior`` only if their predicted states, before the frame's updates,
   were alike too: two people pulled together by one frame's updates are two; with
   ``dup_velocity`` only if their velocity difference is likelier for one person than for two:
   ``one_velocity``; with ``dup_standing`` a track likelier standing is compared at its standing
   mode, ``duplicate_state``); with ``wall_stops`` a track no window explained this frame and predicted
   closer than ``radius`` to a wall, or through it, stopped or turned there: it is moved onto the
   line ``radius`` inside the wall along its own uncertainty (``against_wall``); a track still
   off the floor plan (windows put it there) is dropped, except the hand-chosen target's, which
   is put back on it (``onto_floor``: the outline's nearest point, ``radius`` inside, standing,
   largest spreads).
   The hand-chosen target is located by the two-camera crossing nearest the click (``locate``),
   or (when ``adopt``, off by default) takes the confirmed track that started on it when none
   came near enough.
5. **Walking and standing** (IMM-style, ``mix_modes``): each track is a walking state s, S and
   a standing position xs, Ps with the standing probability mu; Markov switches of mean
   durations ``walk_s`` / ``stand_s``; a window of its own (or a share of a merged one that
   fits better with it than without it, ``share_fit_walks``, unless standing is the likelier
   mode: ``wake_by_own``) says it walks (mu = 0); none anywhere makes standing likelier by
   ``p_miss`` per camera in view (with ``border_windows``, for a walker cut by the image border,
   by the flow tracker's measured chance of a window for its columns inside the image).
   The reported position is the mode-weighted one. A standing person makes no flow window, so a
   standing target is held where it stands instead of following someone else's windows.
6. **Existence** (``walk_evidence``, ``existence``): a sequential test (Wald, error rates 1 %:
   ``EXIST_ACCEPT`` / ``EXIST_REJECT``) of the track being a person, on the log-likelihood
   ratio of each frame's windows: a window that is the track alone counts log ``p_detect``
   plus how much better it fits the track (its costs above plus section 3.2's rows:
   ``rows_cost``) than the best explanation without it (clutter, or another track of that view
   left without a window), at least 0; a merged window (``merged_evidence``) how much better
   it fits with the track among its members than without it, either sign (its extent and flow
   the union's, or the others' alone); a camera that should see a
   walker (moving in its image, not hidden by the floor plan's boxes, ``Occluders``, nor
   overlapping another track) and has no window counts log P(miss), from the flow tracker's
   measured detection rate ``p_detect`` and mean miss run ``miss_run`` (a two-state chain);
   for a confirmed track located by two or more views in the last frame (``slow_misses``)
   weighed by the chance that the walker is slower than ``mover_flow_px`` there, and with
   ``border_windows`` by its chance of a window when cut by the image border.
   The walking and standing modes are marginalised: with no window anywhere the frame's
   likelihood is (1 - mu) P(misses | walking) + mu (a standing person makes none), so a
   standing person loses nothing. A track with windows in one camera that the others should
   see and do not (a ghost at the wrong depth of someone else's window) is rejected.

The per-camera status of each reported track: ``tracking`` (a window that is the track alone;
its id in ``window``), ``unreliable`` (reason ``width``: alone in a window wider than one person),
``merged`` (reason: the other tracks in the window), ``lost`` (reason ``out of view`` or empty).
"""
from __future__ import annotations

import copy
import dataclasses
import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.special import chndtr
from scipy.stats import chi2

from trackroom.scenes.spec import nearest_on_segment, occluding_boxes, segment_meets_box

from . import tp_geometry as geo
from .tp_frames import CameraBoxes, mean_lag_s
from .tp_identity import gauss_loglik

BORDER_PX = 0.5  # a window edge this close to the image's edge is cut by it, px (a window reaching beyond the image was not cut)
MAX_HYPOTHESES = 4096  # exact enumeration up to this many hypotheses per component (a few ms)
C_CLUTTER = 0.5 * float(chi2.ppf(0.99, 4))  # 0.5 chi^2_4(0.99): a window left as clutter
OCCLUDED_ROWS_STEPS = 21  # heights on a person's axis, floor to head, for ``seen_bottoms``
OCCLUDED_ROWS_SPREAD = 2.0  # standard deviations of a track's position ``seen_bottoms`` looks over
FLOW_OUTLIER = float(chi2.ppf(0.999, 2))  # a flow innovation beyond this is not used
PLANE_OUTLIER = float(chi2.ppf(0.999, 1))  # nor a plane's or depth bound's
EDGE_SHARE_MIN = 0.01  # a member's share of a merged window's edge below 1 % updates it not at all (``edge_owners``)
BIRTH_GATE = float(chi2.ppf(0.99, 2))  # no birth inside a track's 99 % position gate
DUPLICATE = float(chi2.ppf(0.99, 4))  # two tracks' states this alike (and nearer than 2 radius) are one person
FLOW_CAP = float(chi2.ppf(0.99, 2))  # the flow's share of an explanation's cost is at most its 99 % gate (heavy tails)
# The track-existence test (Wald's sequential test, error rates 1 %, the design's gate level): a
# track's log-odds of being a person start at 0 (a two-camera crossing: as likely a person as not),
# are capped at log(0.99 / 0.01) (accepted: more evidence for it is not stored, so the evidence
# needed to reject a long-lived track is bounded) and the track is deleted below log(0.01 / 0.99).
EXIST_ACCEPT = float(np.log(0.99 / 0.01))
EXIST_REJECT = -EXIST_ACCEPT
VIS_FRACTIONS = (0.5, 0.75, 0.95)  # points on the person's axis (body centre, chest, head), of the height, as sim/analytic.py
MAX_RANGE = 30.0  # tp_geometry.target_area's default depth limit, m
TRACKING, LOST, UNRELIABLE, MERGED = "tracking", "lost", "unreliable", "merged"


def mixture_moments(w: float, m1: np.ndarray, C1: np.ndarray, m2: np.ndarray, C2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of the two-component mixture (1 - w) N(m1, C1) + w N(m2, C2): each
    component's spread about the mixture's mean, weighted (moment matching)."""
    m = (1.0 - w) * m1 + w * m2
    d1, d2 = m1 - m, m2 - m
    return m, (1.0 - w) * (C1 + np.outer(d1, d1)) + w * (C2 + np.outer(d2, d2))


def mode_weighted(s: np.ndarray, S: np.ndarray, mu: float, xs: np.ndarray | None, Ps: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """A track's mode-weighted state [x, y, vx, vy] and its position's covariance (2, 2): the
    walking state ``s``, ``S`` mixed with the standing position ``xs``, ``Ps`` at standing
    probability ``mu`` (``mixture_moments``; a standing person's velocity is 0); without a
    standing position (``xs`` None), the walking state alone."""
    if xs is None:
        return s, S[:2, :2].copy()
    m, C = mixture_moments(mu, s[:2], S[:2, :2], xs, Ps)
    return np.r_[m, (1.0 - mu) * s[2:]], C


def edge_noise(box_sigma: float, edge_sigma_frac: float, width: float) -> float:
    """The noise (px) of a window's edge about the projected cylinder's of ``width`` px: the
    box noise and ``edge_sigma_frac`` of the width (``JointTracker.edge_sigma``)."""
    return float(np.hypot(box_sigma, edge_sigma_frac * width))


def alike(sa: np.ndarray, Sa: np.ndarray, sb: np.ndarray, Sb: np.ndarray, radius: float) -> bool:
    """Whether two track states (s, S) are one person's: nearer than 2 ``radius`` and alike at
    the 99 % level (``DUPLICATE``; ``JointTracker.prune``)."""
    d = sa - sb
    return float(np.linalg.norm(d[:2])) < 2 * radius and float(d @ np.linalg.solve(Sa + Sb, d)) < DUPLICATE


def duplicate_state(tr: "JointTrack", standing_mode: bool) -> tuple[np.ndarray, np.ndarray]:
    """The state (s, S) the duplicate test compares for track ``tr``: its walking state, or with
    ``standing_mode`` (``dup_standing``), for a track likelier standing (mu >= 0.5), its standing
    mode - the standing position and covariance, velocity zero (a floor of 1e-6 (m/s)^2 keeps the
    sum of two standing tracks' covariances invertible)."""
    if not (standing_mode and tr.mu >= 0.5 and tr.xs is not None):
        return tr.s, tr.S
    S = np.diag([0.0, 0.0, 1e-6, 1e-6])
    S[:2, :2] = tr.Ps
    return np.array([tr.xs[0], tr.xs[1], 0.0, 0.0]), S


def one_velocity(dv: np.ndarray, Sv: np.ndarray, sigma_v: float) -> bool:
    """Whether two tracks' velocity difference ``dv`` (2,) is at least as likely for one person
    seen twice, dv ~ N(0, Sv) (``Sv`` the sum of their velocity covariances), as for two people
    walking independently, each velocity spread ``sigma_v`` per floor axis as far as the tracker
    knows (the largest velocity spread a track is given, ``max_speed`` / 2): dv ~ N(0, Sv + 2
    sigma_v^2 I), equal prior odds. Two tracks whose velocities merged windows left uncertain are
    alike at the 99 % level (``alike``) however their velocities differ (head-on 2724 at 32.9 s:
    +0.9 and -1.1 m/s along x, each spread 0.5 m/s); this weighs the difference under both."""
    dv = np.asarray(dv, float)
    S2 = Sv + 2.0 * sigma_v**2 * np.eye(2)
    return bool(gauss_loglik(dv, Sv) >= gauss_loglik(dv, S2))


@dataclass
class JointTrack:
    """One person: state s = [x, y, vx, vy] (m, m/s), covariance S (4, 4)."""

    tid: int
    s: np.ndarray
    S: np.ndarray
    hits: int = 0
    confirmed: bool = False
    unseen_s: float = 0.0  # seconds since a window last explained it
    seen: bool = False  # a window explained it in the last frame
    located: bool = True  # False for the hand-chosen target until two cameras' planes find it near the click
    n_used: int = 0  # cameras whose window was this track alone, last frame
    mode: str = ""
    status: dict = field(default_factory=dict)  # camera -> (status, reason, window id)
    exist: float = 0.0  # log-odds that the track is a person (the existence test, ``JointTracker.existence``)
    prior: tuple | None = None  # (s, S) predicted for this frame, before its updates (``dup_prior``)
    missed: set = field(default_factory=set)  # cameras that should have seen it last frame and had no window of it
    mu: float = 0.0  # probability that the person stands (the standing mode), given the windows so far
    xs: np.ndarray | None = None  # the standing mode's floor position (m) and its covariance Ps (2, 2)
    Ps: np.ndarray | None = None
    wide_run: int = 0  # consecutive frames with a window too wide for it (the far side of one: ``JointTracker.split``)
    split: bool = False  # born from the far side of a too-wide window (``JointTracker.split``): its merged windows count as hits
    det_prev: dict = field(default_factory=dict)  # camera -> whether a person detection was at it last frame (``detection_evidence``)
    log_miss: float = 0.0  # log P(no window anywhere | walking) this frame, summed over the cameras without a window or share of it that would see a walker there (``step``)
    born: tuple | None = None  # (t, s, S) at its birth at a two-camera crossing (``JointTracker.adopt``)
    F: np.ndarray | None = None  # this frame's transition (``tp_smooth``)
    capped: bool = False  # this frame's prediction capped the spreads (``tp_smooth`` cuts the chain there)

    def mode_weighted(self) -> tuple[np.ndarray, np.ndarray]:
        """The mode-weighted state [x, y, vx, vy] and its position's covariance (``mode_weighted``)."""
        return mode_weighted(self.s, self.S, self.mu, self.xs, self.Ps)

    def estimate(self) -> np.ndarray:
        """The mode-weighted state [x, y, vx, vy] (a standing person's velocity is 0)."""
        return self.mode_weighted()[0]

    def position_cov(self) -> np.ndarray:
        """The covariance (2, 2) of ``estimate``'s position: the mode-weighted mixture's
        (``mixture_moments``)."""
        return self.mode_weighted()[1]

    @property
    def xy(self) -> np.ndarray:
        return self.s[:2]


@dataclass
class StillDetection:
    """One camera's person detection followed over frames (``JointTracker.follow_detections``)."""

    u0: float  # the column it has stayed near since ``since`` (px)
    u: float  # its column now (px)
    since: float  # s (``JointTracker.clock``)
    last: float  # s: last seen
    taken: bool = False  # a track has been updated by it (``update_by_detections``)


@dataclass
class Projection:
    """What one camera expects of one track: predicted window [u_l, u_r, v_t, v_b] (px), centroid
    column ``u`` and its variance ``var_u`` (px^2), image velocity ``flow`` (px/s) and its
    covariance ``var_f``, the Jacobian ``J`` (2, 3) of eq. 7 at the body centre."""

    win: np.ndarray
    u: float
    var_u: float
    flow: np.ndarray
    var_f: np.ndarray
    J: np.ndarray
    row: float


    @property
    def width(self) -> float:
        return max(self.win[1] - self.win[0], 1.0)


def is_fragment(p: Projection, width: float) -> bool:
    """Whether a window ``width`` px wide, explained as the one person ``p``, is a fragment of
    them: narrower than half their projection (a limb, a sliver stuck on the background, the part
    out of an obstacle's shadow). Its flow says little about whose it is (``fragment_var``) and
    its width is not the body's (``fragment_width``)."""
    return float(width) < 0.5 * p.width


def kf_update(tr: JointTrack, H: np.ndarray, z: np.ndarray, R: np.ndarray, gate: float | None = None, soft: bool = False,
              cap: float | None = None, weight: float = 1.0) -> bool:
    """Kalman update of ``tr`` with z = H s + noise(R). When the innovation's squared
    Mahalanobis distance d^2 exceeds ``gate`` the update is skipped (False), or with ``soft``
    made after scaling the position's covariance by d^2 / gate, its standard deviation at most
    to ``cap`` (m) (the state, not the measurement, is taken to be off: an overconfident state
    that went astray is pulled back instead of rejecting every later window). ``weight`` < 1: the
    measurement is this track's with that probability (else someone else's), and the update is
    the probabilistic data association's for one candidate - the state moves by ``weight`` times
    the full step, the covariance shrinks by ``weight`` times the full reduction (the spread of
    the two hypotheses' means is not added)."""
    H = np.atleast_2d(H)
    R = np.atleast_2d(R)
    r = np.atleast_1d(z) - H @ tr.s
    Sy = H @ tr.S @ H.T + R
    if gate is not None:
        d2 = float(r @ np.linalg.solve(Sy, r))
        if d2 > gate:
            if not soft:
                return False
            # the state, not the window, is taken to be off: the position's covariance grows
            # (rows and columns scaled, correlations kept), up to sigma_max
            k = np.ones(4)
            sd = float(np.sqrt(max(tr.S[0, 0], tr.S[1, 1])))
            k[:2] = min(np.sqrt(d2 / gate), max(cap / sd, 1.0)) if cap else np.sqrt(d2 / gate)
            tr.S = tr.S * np.outer(k, k)
            Sy = H @ tr.S @ H.T + R
    K = np.linalg.solve(Sy, H @ tr.S).T
    if weight < 1.0:
        # the measurement is this track's with probability ``weight`` (else someone else's):
        # the probabilistic data association's update, without the innovations' spread term
        tr.s = tr.s + K @ (weight * r)
        tr.S = tr.S - weight * (K @ Sy @ K.T)
        tr.S = 0.5 * (tr.S + tr.S.T)
        return True
    tr.s = tr.s + K @ r
    IKH = np.eye(4) - K @ H
    tr.S = IKH @ tr.S @ IKH.T + K @ R @ K.T  # Joseph form: stays symmetric positive
    return True


class Occluders:
    """The floor plan's boxes that hide people (obstacles and interior walls, each a box on the
    floor of a height), and the cameras' optical centres (from P): ``visible(c, xy)`` says whether
    a person standing at xy can be seen by camera c, as the simulator decides it (``sim/analytic.py``):
    at least one of the rays to the body centre, chest and head (VIS_FRACTIONS of ``height``)
    meets none of the boxes."""

    def __init__(self, floorplan, Ps: dict[str, np.ndarray], height: float):
        self.boxes = bx = occluding_boxes(floorplan)
        self.z = height * np.asarray(VIS_FRACTIONS)
        self.cy, self.sy = np.cos(bx[:, 5])[:, None], np.sin(bx[:, 5])[:, None]
        self.lo = np.stack([-bx[:, 2], -bx[:, 3], np.zeros(len(bx))], -1)[:, None, :]
        self.hi = np.stack([bx[:, 2], bx[:, 3], bx[:, 4]], -1)[:, None, :]
        self.centres = {c: geo.camera_centre(P) for c, P in Ps.items()}
        self.centres_local = {c: self.local(C[None, :]) for c, C in self.centres.items()}  # in each box's frame, (B, 1, 3)

    def local(self, X: np.ndarray) -> np.ndarray:
        """Points X (V, 3) in each box's frame: (B, V, 3)."""
        dx, dy = X[None, :, 0] - self.boxes[:, None, 0], X[None, :, 1] - self.boxes[:, None, 1]
        return np.stack([self.cy * dx + self.sy * dy, -self.sy * dx + self.cy * dy, np.broadcast_to(X[None, :, 2], dx.shape)], -1)

    def visible(self, c: str, xy: np.ndarray) -> bool:
        return bool(self.visible_many(c, np.asarray(xy, float)[None, :2])[0])

    def visible_many(self, c: str, xys: np.ndarray, whole: bool = False) -> np.ndarray:
        """``visible`` for the floor points xys (N, 2) at once: (N,) bool; ``whole``: all of the
        rays meet none of the boxes (the person wholly seen, as a person detector needs)."""
        n = self.clear_rays(c, xys)
        return n == len(self.z) if whole else n > 0

    def clear_rays(self, c: str, xys: np.ndarray, z: np.ndarray | None = None) -> np.ndarray:
        """How many of the rays from camera c to a person at each floor point of xys (N, 2) - to
        the body centre, chest and head, or to the heights ``z`` (m) on its axis - meet none of
        the boxes: (N,) int, 0 to the number of rays."""
        return self.clear_heights(c, xys, z).sum(1)

    def clear_heights(self, c: str, xys: np.ndarray, z: np.ndarray | None = None) -> np.ndarray:
        """Which of the rays of ``clear_rays`` meet none of the boxes: (N, len(z)) bool."""
        xys = np.asarray(xys, float).reshape(-1, 2)
        z = self.z if z is None else np.asarray(z, float)
        if not len(self.boxes):
            return np.ones((len(xys), len(z)), bool)
        V = len(z)
        pts = np.c_[np.repeat(xys, V, axis=0), np.tile(z, len(xys))]  # (N V, 3)
        a = self.centres_local[c]
        hidden, _ = segment_meets_box(a, self.local(pts) - a, self.lo, self.hi)  # (B, N V): the segment camera -> point meets the box
        return (~hidden.any(0)).reshape(len(xys), V)


def partly_in_image(win: np.ndarray, width: float) -> np.ndarray:
    """Whether projected cylinders' windows [u_l, u_r, ...] (px, (..., 4)) lie at least in part
    inside an image ``width`` px wide (a window that is not finite - behind the camera - does not)."""
    win = np.asarray(win, float)
    return np.isfinite(win).all(-1) & (win[..., 1] >= 0.0) & (win[..., 0] <= width)


def span_in_image(lo: float, hi: float, width: float) -> float:
    """Width (px) of the column span [lo, hi] inside an image ``width`` px wide; zero or less
    when the span lies beyond a border."""
    return min(float(hi), width) - max(float(lo), 0.0)


# the flow tracker's chance of a window for a walker cut by the image border, against one seen
# whole, by the columns of its projected cylinder inside the image (px, at the measured bands'
# middles): walking movers apart from the other mover, moving at least 8 px/s, not hidden by the
# floor plan's boxes, a window overlapping the part inside (+-3 px); rendered development
# recordings 100-109, 14234 camera frames (``scripts/measure_tp_detection.py --border``; 0.99
# from 8 px on, as for someone seen whole; ``border_windows``)
BORDER_WINDOW_PX = (0.5, 1.5, 2.5, 3.5, 5.0, 7.0, 10.0)
BORDER_WINDOW_RATE = (0.0, 0.09, 0.13, 0.40, 0.75, 0.92, 1.0)


def border_window_rate(win: np.ndarray, width: float) -> float:
    """``BORDER_WINDOW_RATE`` at the columns of projected cylinder ``win`` inside an image
    ``width`` px wide (1 for one seen whole)."""
    return float(np.interp(span_in_image(win[0], win[1], width), BORDER_WINDOW_PX, BORDER_WINDOW_RATE))


def wholly_in_image(win: np.ndarray, width: float) -> bool:
    """Whether a projected cylinder's window [u_l, u_r, ...] (px) lies wholly inside an image
    ``width`` px wide."""
    return bool(np.isfinite(win).all() and win[0] >= 0.0 and win[1] <= width)


# a person detector's view of someone partly seen (``scripts/measure_person_detections.py --views``,
# rendered development 100-109, standing people): with a quarter or more of the projected width
# inside the image and every ray clear, detected 1.00 (0.89 below a quarter); wholly inside with
# two of the three rays clear, 0.98 (one clear: 0.13) - as often as someone seen whole (0.99)
PARTIAL_SHARE = 0.25
PARTIAL_RAYS = 2


def detector_sees(win: np.ndarray, width: float, n_clear: int, n_rays: int, partial: bool = False) -> bool:
    """Whether a person detector sees a person whose projected cylinder's window is ``win``
    (px) in an image ``width`` px wide, ``n_clear`` of the ``n_rays`` rays to it clear of the
    floor plan's boxes: wholly (inside the image, every ray clear), or with ``partial`` also
    enough to be detected as often: at least ``PARTIAL_SHARE`` of its width inside the image and
    at least ``PARTIAL_RAYS`` rays clear, cut by the border or partly hidden but not both."""
    inside = wholly_in_image(win, width)
    if inside and n_clear >= n_rays:
        return True
    if not partial or not np.isfinite(win).all() or win[1] <= win[0]:
        return False
    share = span_in_image(win[0], win[1], width) / float(win[1] - win[0])
    return (inside and n_clear >= PARTIAL_RAYS) or (share >= PARTIAL_SHARE and n_clear >= n_rays)


def detection_gate(win: np.ndarray, var_u: float = 0.0) -> float:
    """Half-width (px) of the column band about a person's projected axis within which a person
    detection counts as theirs: half the projected width, 3 px, and two sd of the axis's column
    (``var_u``, px^2: the track's position spread)."""
    return 0.5 * float(win[1] - win[0]) + 3.0 + 2.0 * float(np.sqrt(max(var_u, 0.0)))


def coincidence_chance(gate: float, width: float, n: int, u: float | None = None) -> float:
    """P(at least one of a frame's ``n`` detections falls within ``gate`` of a point where no one
    is), the detections spread over an image ``width`` px wide: 1 - (1 - 2 gate / W)^n; with the
    point's column ``u``, only the gate's span inside the image counts (a point near or beyond
    the border)."""
    span = 2.0 * gate if u is None else max(span_in_image(u - gate, u + gate, width), 0.0)
    return 1.0 - (1.0 - min(span / width, 1.0)) ** n


def on_floor(inside_room, xy) -> bool:
    """Whether the floor point xy (2,) lies on the floor plan (``inside_room``: the floor plan's
    ``inside``, which takes points (n, 2))."""
    return bool(np.asarray(inside_room(np.asarray(xy, float)[None])).reshape(-1)[0])


class JointTracker:
    """The per-frame logic of the joint design (see the module docstring); ``cfg`` is the
    estimator's resolved Config, ``flow_sigma`` per camera (px/s), ``box_sigma`` and
    ``u_sigma`` (px) the calibrated window edge and centroid noise, ``fps`` each camera's frame
    rate (the mean flow's lag, ``flow_lag``)."""

    def __init__(self, cfg, Ps: dict[str, np.ndarray], widths: dict[str, float], flow_sigma: dict[str, float],
                 box_sigma: float, u_sigma: float, fps: dict[str, float]):
        self.cfg, self.Ps, self.widths = cfg, Ps, widths
        self.flow_sigma, self.box_sigma, self.u_sigma = flow_sigma, box_sigma, max(u_sigma, 1e-3)
        self.margin_px = cfg.window_margin_px + 3.0 * box_sigma
        self.hc = cfg.flow_height_fraction * cfg.height
        self.occluders: Occluders | None = None  # the floor plan's boxes (None: nothing hides anyone)
        self.wake_share: dict = {}  # id(track) -> share of its walking prior a camera's explanation pays (``wake_once``)
        self.detections: dict[str, np.ndarray] | None = None  # this frame's person detections per camera, u (px); None: none used
        self.outline: np.ndarray | None = None  # the floor plan's outline (k, 2), m (None: no floor plan)
        self.clock = 0.0  # s since the first frame (step's dt summed)
        self.still: dict[str, list[StillDetection]] = {}  # camera -> its person detections followed over frames (detection_planes)
        q = (1.0 - cfg.p_detect) / (cfg.p_detect * cfg.miss_run)  # P(a miss | seen the frame before)
        self.p_see_after_hit = 1.0 - min(q, 1.0)
        self.p_see_after_miss = 1.0 / cfg.miss_run
        # a window's flow is the mean over the camera track's last flow_window frames (``fps``: each
        # camera's frame rate): about the velocity of (flow_window - 1) / 2 frames ago, which strays
        # from the present one by the walker's white acceleration (accel_sigma) over the mean
        # (``flow_lag``): that variance, (m/s)^2 per floor axis, is added to the flow's noise
        self.flow_lag_var = {c: cfg.accel_sigma**2 * mean_lag_s(cfg.flow_window, 1.0 / f) for c, f in fps.items()} if cfg.flow_lag else {}

    # --- prediction ---------------------------------------------------------------------------
    def mix_modes(self, tr: JointTrack, dt: float) -> None:
        """Two-mode (walking / standing) interaction, IMM style. Mode switches are Markov with
        mean durations ``walk_s`` and ``stand_s``: per frame q_ws = dt / walk_s, q_sw = dt / stand_s;
        mu <- (1 - mu) q_ws + mu (1 - q_sw). Each mode's prior is the moment-matched mixture of the
        modes it may come from: the walking state takes in the standing one as a start from rest
        (position xs, Ps; velocity 0 with ``start_sigma_v``), the standing state the walking one's
        position (someone who stops where they are)."""
        cfg = self.cfg
        if tr.xs is None:
            tr.xs, tr.Ps = tr.s[:2].copy(), tr.S[:2, :2].copy()
            return
        mu = tr.mu
        q_ws, q_sw = min(dt / cfg.walk_s, 1.0), min(dt / cfg.stand_s, 1.0)
        mu_p = (1.0 - mu) * q_ws + mu * (1.0 - q_sw)
        ms, Cs = np.r_[tr.xs, 0.0, 0.0], np.zeros((4, 4))
        Cs[:2, :2], Cs[2:, 2:] = tr.Ps, cfg.start_sigma_v**2 * np.eye(2)
        if mu_p < 1.0:
            b = mu * q_sw / (1.0 - mu_p)  # share of the walking prior that was standing
            tr.s, tr.S = mixture_moments(b, tr.s, tr.S, ms, Cs)
        if mu_p > 0.0:
            c = (1.0 - mu) * q_ws / mu_p  # share of the standing prior that was walking
            tr.xs, tr.Ps = mixture_moments(c, tr.xs, tr.Ps, tr.s[:2], tr.S[:2, :2])
        tr.Ps = tr.Ps + cfg.stand_sigma**2 * dt * np.eye(2)  # a standing person sways and shifts a little
        tr.mu = mu_p

    def predict(self, tr: JointTrack, dt: float) -> None:
        cfg = self.cfg
        self.mix_modes(tr, dt)
        decay = 1.0 if tr.seen else float(np.exp(-dt / cfg.stop_tau))
        F = np.eye(4)
        F[0, 2] = F[1, 3] = dt
        F[2, 2] = F[3, 3] = decay
        q = cfg.accel_sigma**2
        Q1 = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        Q = np.kron(Q1, np.eye(2))
        tr.s = F @ tr.s
        tr.S = F @ tr.S @ F.T + Q
        tr.F, tr.capped = F, False
        for sl, cap in ((slice(0, 2), cfg.sigma_max), (slice(2, 4), 0.5 * cfg.max_speed)):
            # cap the spreads: a stopped walker stays near where it vanished; no one walks faster
            # than max_speed (scaling rows and columns keeps S positive definite)
            sd = np.sqrt(max(tr.S[sl.start, sl.start], tr.S[sl.start + 1, sl.start + 1]))
            if sd > cap:
                k = np.ones(4)
                k[sl] = cap / sd
                tr.S = tr.S * np.outer(k, k)
                tr.capped = True
        tr.prior = (tr.s.copy(), tr.S.copy())

    def project(self, c: str, tr: JointTrack) -> Projection | None:
        P = self.Ps[c]
        win = geo.cylinder_window(P, tr.xy, self.cfg.height, self.cfg.radius)
        if not partly_in_image(win, self.widths[c]):
            return None
        X = np.array([tr.s[0], tr.s[1], self.hc])
        (u, v), _ = geo.project(P, X)
        J = geo.flow_jacobian(P, X)
        Ju, Jf = J[0, :2], self.flow_map(J)
        return Projection(win, float(u), float(Ju @ tr.S[:2, :2] @ Ju), Jf @ tr.s[2:], Jf @ tr.S[2:, 2:] @ Jf.T, J, float(v))

    # --- joint explanation of one camera's windows -----------------------------------------------
    def explain_cost(self, c: str, projs: list[Projection], boxes: CameraBoxes, j: int) -> float:
        """0.5 d^2 of window j explained by the tracks ``projs`` (one: a person alone; more: merged),
        plus, with ``fit_normalised``, the Gaussian's normalisation (``explain_terms``)."""
        fit, norm = self.explain_terms(c, projs, boxes, j)
        return fit + norm

    def explain_terms(self, c: str, projs: list[Projection], boxes: CameraBoxes, j: int) -> tuple[float, float]:
        """(0.5 d^2, normalisation) of window j explained by ``projs``; the normalisation is 0
        without ``fit_normalised``."""
        cfg = self.cfg
        ul, ur = boxes.win[j, 0], boxes.win[j, 1]
        side = self.border_side(c, boxes, j, projs) if cfg.border_edges else 0
        if len(projs) == 1 and not side:
            p = projs[0]
            var0 = self.centroid_var(p, boxes.width[j])
            du, var_u = boxes.u[j] - p.u, var0 + p.var_u
            w_pred = w_narrow = p.width
            f_pred, var_f = p.flow, p.var_f
        elif len(projs) == 1:
            # cut by the image border: the window is the projection's part inside the image, its
            # centre half-way between the border and the inner edge (which moves with the axis)
            p = projs[0]
            L, R = max(p.win[0], 0.0), min(p.win[1], self.widths[c])
            du = 0.5 * (ul + ur) - 0.5 * (L + R)
            var0 = self.edge_sigma(p) ** 2
            var_u = var0 + 0.25 * p.var_u
            w_pred = w_narrow = max(R - L, 1.0)
            f_pred, var_f = p.flow, p.var_f
        else:
            L = min(p.win[0] for p in projs)
            R = max(p.win[1] for p in projs)
            if side:
                L, R = max(L, 0.0), min(R, self.widths[c])
            du = 0.5 * (ul + ur) - 0.5 * (L + R)
            var0 = 0.5 * self.box_sigma**2 + (cfg.edge_sigma_frac * min(p.width for p in projs)) ** 2
            var_u = var0 + float(np.mean([p.var_u for p in projs]))
            w_pred = R - L
            fs = np.array([p.flow for p in projs])
            f_pred = fs.mean(0)
            var_f = np.mean([p.var_f for p in projs], 0) + np.diag(fs.var(0))
        dw = (ur - ul) - w_pred
        sw = np.hypot(2.0 * self.box_sigma, cfg.edge_sigma_frac * w_pred)
        if len(projs) > 1:
            sw = np.sqrt(sw**2 + 2.0 * float(np.mean([p.var_u for p in projs])))  # the union's outer members move
        elif dw < 0:
            sw = 0.5 * w_narrow  # one person partly hidden (an obstacle, the image border) or a fragment
        df = boxes.flow[j] - f_pred
        Sf = var_f + self.flow_var(c) * np.eye(2)
        if len(projs) == 1 and not side:
            Sf[0, 0] += self.fragment_var(projs[0], float(boxes.width[j]))
        d2f = min(float(df @ np.linalg.solve(Sf, df)), FLOW_CAP)
        norm = 0.0
        if cfg.fit_normalised:
            # the Gaussian's normalisation, against a perfectly located track's (var0: the window
            # noise and silhouette alone; the calibrated flow noise alone): a prediction spread
            # wide fits any window near it, and is that much less likely to have made this one
            Sf0 = self.flow_var(c) * np.eye(2)
            norm = 0.5 * float(np.log(var_u / var0)) + 0.5 * float(np.log(np.linalg.det(Sf) / np.linalg.det(Sf0)))
        if cfg.width_tail > 0.0 and dw > 0.0:
            # a window wider than predicted: the core Gaussian, or (probability width_tail) a gross
            # error that moved one edge, either, outwards by dw (half-normal of spread
            # width_tail_sigma x the predicted width, as measured on the rendered windows) and the
            # window's centre by dw / 2 with it; relative to the core's normalisation
            sb = max(cfg.width_tail_sigma * w_pred, sw)
            core = np.log1p(-cfg.width_tail) - 0.5 * (du**2 / var_u + (dw / sw) ** 2)
            tail = np.log(cfg.width_tail * sw / sb) - 0.5 * (dw / sb) ** 2
            fit_wu = -float(np.logaddexp.reduce([core, tail - 0.5 * (du - 0.5 * dw) ** 2 / var_u, tail - 0.5 * (du + 0.5 * dw) ** 2 / var_u]))
            return fit_wu + 0.5 * d2f, norm
        return 0.5 * (du**2 / var_u + (dw / sw) ** 2 + d2f), norm

    def border_side(self, c: str, boxes: CameraBoxes, j: int, projs: list[Projection]) -> int:
        """-1 / +1: window j ends at the left / right image border and the tracks ``projs``
        explaining it are predicted cut by that border (their window is the part inside the
        image; its centroid is the visible part's); 0: otherwise (a window at the border that
        the prediction does not reach is compared as any other)."""
        left, right = self.cut_edges(c, boxes, j, projs)
        return -1 if left and not right else 1 if right and not left else 0

    def cut_edges(self, c: str, boxes: CameraBoxes, j: int, projs: list[Projection]) -> tuple[bool, bool]:
        """Whether window j's left / right edge is the image border cutting the tracks ``projs``
        (the edge on the border and their predicted union reaching past it): such an edge is
        where the image ends, not where a person does."""
        W = self.widths[c]
        left = abs(boxes.win[j, 0]) <= BORDER_PX and min(p.win[0] for p in projs) < 0.0
        right = abs(boxes.win[j, 1] - W) <= BORDER_PX and max(p.win[1] for p in projs) > W
        return bool(left), bool(right)

    def rows_cost(self, c: str, tr: JointTrack, p: Projection, boxes: CameraBoxes, j: int,
                  var: tuple[float, float] | None = None) -> float:
        """Section 3.2's target area as evidence of depth, for the existence test: 0.5 d^2 of the
        window's top row above the projected (tallest) head and its bottom row below the
        projected feet (one-sided: a shorter person, feet hidden by a desk), against the window
        edge noise and the track's position spread; capped at 0.5 chi^2_2(0.99), as the flow
        (the windows' rows have heavy tails: merges, fragments). ``var``: ``row_vars(c, tr)``,
        when the caller has it."""
        var = self.row_vars(c, tr) if var is None else var
        d2 = 0.0
        for v, excess in zip(var, (p.win[2] - boxes.win[j, 2], boxes.win[j, 3] - p.win[3])):
            if excess > 0.0:
                d2 += excess**2 / (v + 1e-9)
        return 0.5 * min(d2, FLOW_CAP)

    def rows_relative(self, c: str, tracks: list[JointTrack], projs: dict, boxes: CameraBoxes, gate: dict, rv: dict) -> dict:
        """``rows_explain``: (track, window) -> the track's section 3.2 rows for a window that two
        or more tracks gate (``rows_cost``, with ``rows_norm`` under ``fit_normalised``), relative
        to the gating track they fit best, and then to the track's own best window's: the rows
        choose who takes a window and move a track between windows, never towards a miss (a
        lone track's window whose rows fit it badly stays its own: a partial view). ``rv``: track
        index -> its ``row_vars`` in camera c."""
        cfg = self.cfg
        relative: dict = {}
        for j in range(len(boxes.u)):
            rc = {i: self.rows_cost(c, tracks[i], projs[i], boxes, j, rv[i]) + (self.rows_norm(rv[i]) if cfg.fit_normalised else 0.0)
                  for i in projs if j in gate[i]}
            if len(rc) > 1:
                low = min(rc.values())
                relative.update({(i, j): v - low for i, v in rc.items()})
        for i in projs:
            own = min((relative.get((i, j), 0.0) for j in gate[i]), default=0.0)
            for j in gate[i]:
                if (i, j) in relative:
                    relative[(i, j)] -= own
        return relative

    def row_vars(self, c: str, tr: JointTrack) -> tuple[float, float]:
        """Variances (px^2) of track tr's projected head and feet rows in camera c: the window
        edge noise and the track's position spread through each row's Jacobian."""
        P = self.Ps[c]
        Sxy = tr.S[:2, :2]
        var = []
        for z in (self.cfg.height, 0.0):
            jv = geo.flow_jacobian(P, np.array([tr.s[0], tr.s[1], z]))[1, :2]
            var.append(self.box_sigma**2 + float(jv @ Sxy @ jv))
        return var[0], var[1]

    def rows_norm(self, var: tuple[float, float]) -> float:
        """``fit_normalised``'s normalisation of ``rows_cost``'s two terms (``rows_explain``): 0.5
        log of each row's predicted variance (``var``, a track's ``row_vars``) over the edge noise
        alone, so that a spread-out prediction, whose rows fit any window, is not preferred for it."""
        return sum(0.5 * float(np.log((v + 1e-9) / (self.box_sigma**2 + 1e-9))) for v in var)

    def rows_reach(self, var: tuple[float, float], p: Projection, boxes: CameraBoxes, j: int) -> bool:
        """Whether window j's rows reach track projection p's (``rows_explain``): their spans
        overlap, the window's widened by 3 standard deviations of each projected row (``var``,
        the track's ``row_vars``, as ``rows_cost`` weighs them: near a camera a tenth of a metre
        moves the feet tens of pixels). A person whose projected rows lie wholly above or below a
        window is neither seen in it nor hidden by whoever made it (a near person's head at the
        bottom of a corner camera's image, a far person's body high above it), so is not in it:
        not alone on a window others gate, nor a member of a merged explanation of it."""
        head, feet = (3.0 * float(np.sqrt(v)) for v in var)
        return bool(p.win[2] <= boxes.win[j, 3] + head and p.win[3] >= boxes.win[j, 2] - feet)

    def centroid_var(self, p: Projection, width: float) -> float:
        """Variance (px^2) of a window's centroid about the track's projected axis: the
        calibrated centroid noise, the silhouette's spread about the cylinder
        (``edge_sigma_frac`` of its width) and, for a window narrower than the person (partly
        hidden, or a fragment of the region), the axis anywhere within the missing width
        (uniform: (w_c - w)^2 / 12; section 3.2's partial extraction)."""
        short = max(p.width - float(width), 0.0)
        return self.u_sigma**2 + (self.cfg.edge_sigma_frac * p.width) ** 2 + short**2 / 12.0

    def miss_walk(self, p: Projection, c: str) -> float:
        """-log P(no window | walking) in a camera that would see the track: a walker moving at
        least ``mover_flow_px`` in this image has none with ``p_miss``; one slower makes no flow
        region. Whether it moves that fast is the walking mode's predicted image velocity
        N(flow, var_f), taken isotropic (variance half its trace): P(slow) = P(|f| <
        mover_flow_px), a non-central chi-square with 2 degrees of freedom. (Deciding by the
        predicted mean alone made misses free for a track unseen for a second: its mean velocity
        decays with ``stop_tau`` while its spread does not, so the walking mode never lost to the
        standing one and its position spread grew to ``sigma_max``.) With ``border_windows`` a
        walker cut by camera c's image border has a window with 1 - ``p_miss`` times the measured
        chance for its columns inside the image (``border_window_rate``)."""
        slow = self.p_slow(p)
        seen = 1.0 - self.cfg.p_miss
        if self.cfg.border_windows:
            seen *= border_window_rate(p.win, self.widths[c])
        return -float(np.log(slow + (1.0 - slow) * (1.0 - seen)))

    def p_slow(self, p: Projection) -> float:
        """P(the walking mode moves slower than ``mover_flow_px`` in this image): its predicted
        image velocity N(flow, var_f) taken isotropic, a non-central chi-square with 2 degrees
        of freedom (``miss_walk``)."""
        var = 0.5 * float(np.trace(p.var_f))
        thr, m2 = self.cfg.mover_flow_px**2, float(p.flow @ p.flow)
        return float(chndtr(thr / var, 2, m2 / var)) if var > 1e-12 else float(m2 < thr)

    def miss_cost(self, p: Projection) -> float:
        """A track without a window: free for a track predicted standing (no flow region), else
        as dear as a clutter window. (Not the mode mixture -log((1 - mu) e^-cost + mu): that made
        misses free for a walker hidden two frames and lowered analytic seed 105 to 77.7 %.)"""
        return C_CLUTTER if float(np.linalg.norm(p.flow)) >= self.cfg.mover_flow_px else 0.0

    def miss_costs(self, c: str, tracks: list[JointTrack], projs: dict[int, Projection]) -> dict[int, float]:
        """Each projected track's cost (``projs``: index into ``tracks`` -> projection) for having
        no window in camera c: ``miss_cost``, or nothing for a track the floor plan hides wholly
        from c (``hidden_miss``: ``hidden_from``)."""
        hidden = self.hidden_from(c, tracks, projs) if self.cfg.hidden_miss else set()
        return {i: 0.0 if i in hidden else self.miss_cost(p) for i, p in projs.items()}

    def hidden_from(self, c: str, tracks: list[JointTrack], projs: dict[int, Projection]) -> set[int]:
        """The projected tracks (indices, keys of ``projs``) whose person camera c cannot see at
        all for the floor plan's boxes: none of the rays to the body centre, chest, head and top
        of the head clear (``Occluders.clear_rays``; the top of the head too, as the simulator's
        strip window of a head seen over a shelf). Only confirmed tracks located by two or more
        views last frame (mode planes, as ``slow_misses``): a track lagging in one view or in
        merged windows may have its mean in a shadow its person has left."""
        if self.occluders is None:
            return set()
        ids = [i for i in projs if tracks[i].confirmed and tracks[i].mode == "planes"]
        if not ids:
            return set()
        z = np.r_[self.occluders.z, self.cfg.height]
        n = self.occluders.clear_rays(c, np.array([tracks[i].xy for i in ids]).reshape(-1, 2), z)
        return {i for i, k in zip(ids, n) if k == 0}

    def seen_bottoms(self, c: str, tracks: list[JointTrack], projs: dict[int, Projection]) -> dict[int, float]:
        """``occluded_rows``: for each projected track (index -> its projection) whose person the
        floor plan's boxes hide from camera c below some height while a higher part is seen
        (behind a shelf or a low wall), the lowest image row a window of it alone can reach.
        Conservative: the person is taken as every vertical line of its cylinder (the axis and
        a radius either side across the camera's view) at every place within 2 standard
        deviations of the track's position across and along the view (OCCLUDED_ROWS_SPREAD);
        the lowest clear height on any of them (``Occluders.clear_heights`` at
        OCCLUDED_ROWS_STEPS heights, floor to head) gives, through the hidden height below it
        (the boundary lies between them), the row. None where any of those lines is seen at the
        floor, or none is seen at all (``hidden_from``). Only confirmed tracks located by two or
        more views last frame (mode planes, as ``hidden_from``): a track lagging in one view may
        have its mean behind a box its person has left."""
        if self.occluders is None:
            return {}
        ids = [i for i in projs if tracks[i].confirmed and tracks[i].mode == "planes"]
        if not ids:
            return {}
        cfg = self.cfg
        z = cfg.height * np.linspace(0.0, 1.0, OCCLUDED_ROWS_STEPS)
        C = self.occluders.centres[c][:2]
        pts = []
        for i in ids:
            tr = tracks[i]
            xy = np.asarray(tr.xy, float)
            along = xy - C
            along /= max(float(np.hypot(*along)), 1e-9)
            across = np.array([-along[1], along[0]])
            sa = float(np.sqrt(along @ tr.S[:2, :2] @ along))
            sc = float(np.sqrt(across @ tr.S[:2, :2] @ across))
            reach = cfg.radius + OCCLUDED_ROWS_SPREAD * sc
            pts += [xy + a * along + b * across for a in (-OCCLUDED_ROWS_SPREAD * sa, 0.0, OCCLUDED_ROWS_SPREAD * sa)
                    for b in np.linspace(-reach, reach, 5)]
        clear = self.occluders.clear_heights(c, np.array(pts), z).reshape(len(ids), -1, len(z)).any(1)  # one call for all
        out = {}
        for i, cl in zip(ids, clear):
            if cl[0] or not cl.any():
                continue  # seen at the floor (no bound), or wholly hidden (``hidden_from``)
            k = int(np.argmax(cl))  # the lowest clear height; k - 1 is hidden
            xy = tracks[i].xy
            (_, v), _ = geo.project(self.Ps[c], np.array([xy[0], xy[1], z[k - 1]]))
            out[i] = float(v)
        return out

    def occluded_rows_cost(self, bottom: float, win: np.ndarray) -> float:
        """``occluded_rows``: what a window ``win`` [u_l, u_r, v_t, v_b] of one track alone adds
        when its bottom row lies below ``bottom``, the lowest row at which the floor plan lets
        the camera see the track's person (``seen_bottoms``): 0.5 d^2 of the reach past it in
        window-edge noise standard deviations, capped at 0.5 chi^2_2(0.99) as ``rows_cost``
        (someone in front of the box likelier made it; a soft cost, not a refusal, for the
        track's spread and the edge's heavy tails; with noise-free edges, the cap)."""
        reach = float(win[3]) - bottom
        if reach <= 0.0:
            return 0.0
        d = reach / self.box_sigma if self.box_sigma > 0 else np.inf
        return 0.5 * min(d * d, FLOW_CAP)

    @staticmethod
    def walk_cost(mu: float) -> float:
        """-log P(walking): what explaining a window adds for a track of standing probability mu
        (a standing person makes no window; one who starts to walk is the walking mode)."""
        return float(-np.log(max(1.0 - mu, 1e-12)))

    def gated_windows(self, p: Projection, boxes: CameraBoxes) -> list[int]:
        """The windows a track projected as p may explain (``explain_camera``): those whose
        columns reach its centroid column within 3 standard deviations of its spread and the
        centroid noise."""
        m = 3.0 * np.sqrt(p.var_u + self.u_sigma**2)
        return [j for j in range(len(boxes)) if boxes.win[j, 0] - m <= p.u <= boxes.win[j, 1] + m]

    def explain_camera(self, c: str, tracks: list[JointTrack], boxes: CameraBoxes, probe: int | None = None,
                       force: tuple[int, int | None] | None = None) -> tuple[dict[int, tuple[int, ...]], dict[int, Projection]]:
        """The best joint explanation of camera c's windows: window index -> indices (into
        ``tracks``) of the tracks it holds (one, or a merged group); and each visible track's
        projection. Windows absent from the result are clutter. Its cost (the sum of its
        explanations', misses' and clutter's) is left in ``self.cost``. ``probe`` (an index into
        ``tracks``): the best explanation in which that track holds another window, or none
        when it holds one, is left in ``self.alternative`` as (extra cost, its window index or
        None), None when there is none (the look-ahead, ``TargetPlanes.Config.lookahead``).
        ``force`` (index, window index or None): that track holds that window (or none)."""
        projs = {i: p for i, tr in enumerate(tracks) if (p := self.project(c, tr)) is not None}
        n = len(boxes)
        cfg = self.cfg
        self.cost, self.alternative = 0.0, None
        miss = self.miss_costs(c, tracks, projs)
        if not projs or not n:
            self.cost = float(sum(miss.values())) + C_CLUTTER * n
            return {}, projs
        gate = {i: self.gated_windows(p, boxes) for i, p in projs.items()}
        # connected components of the gating graph (tracks and windows)
        comp_of: dict = {}

        def find(a):
            while comp_of.setdefault(a, a) != a:
                a = comp_of[a]
            return a

        for i, js in gate.items():
            for j in js:
                comp_of[find(("t", i))] = find(("w", j))
        comps: dict = {}
        for i in projs:
            comps.setdefault(find(("t", i)), [[], set()])[0].append(i)
        for i, js in gate.items():
            comps[find(("t", i))][1].update(js)
        result: dict[int, tuple[int, ...]] = {}
        cache: dict = {}
        walk = {i: self.walk_cost(tracks[i].mu) * self.wake_share.get(id(tracks[i]), 1.0) for i in projs}

        bottom = self.seen_bottoms(c, tracks, projs) if cfg.occluded_rows else {}
        rv = {i: self.row_vars(c, tracks[i]) for i in projs} if cfg.rows_explain else {}  # once per track, not per window
        relative = self.rows_relative(c, tracks, projs, boxes, gate, rv) if cfg.rows_explain else {}

        def cost(members: tuple[int, ...], j: int) -> float:
            key = (members, j)
            if key not in cache:
                cache[key] = self.explain_cost(c, [projs[i] for i in members], boxes, j) + sum(walk[i] for i in members) if len(members) <= 3 else np.inf
                if cfg.rows_explain and len(members) <= 3:
                    if not all(self.rows_reach(rv[i], projs[i], boxes, j) for i in members if len(members) > 1 or (i, j) in relative):
                        cache[key] = np.inf  # a person whose projected rows the window's do not reach is not in it
                    elif len(members) == 1 and (members[0], j) in relative:
                        cache[key] += relative[(members[0], j)]
                if len(members) == 1 and members[0] in bottom:
                    cache[key] += self.occluded_rows_cost(bottom[members[0]], boxes.win[j])
            return cache[key]

        gated = {j for js in gate.values() for j in js}
        self.cost = C_CLUTTER * (n - len(gated))  # windows near no track: clutter
        for ts, ws in comps.values():
            ws = sorted(ws)
            if not ws:
                self.cost += sum(miss[i] for i in ts)
                continue
            options = [[None] + gate[i] for i in ts]
            if force is not None and force[0] in ts:
                options[ts.index(force[0])] = [force[1]]
            size = int(np.prod([len(o) for o in options], dtype=float))
            if size <= MAX_HYPOTHESES:
                k_probe = ts.index(probe) if probe is not None and probe in ts else None
                best_by: dict = {}  # the probed track's option -> (cost, groups); one entry without a probe
                for combo in itertools.product(*options):
                    key = combo[k_probe] if k_probe is not None else 0
                    bound = best_by.get(key, (np.inf, None))[0]
                    groups: dict[int, list[int]] = {}
                    total = 0.0
                    for i, j in zip(ts, combo):
                        if j is None:
                            total += miss[i]
                        else:
                            groups.setdefault(j, []).append(i)
                    total += C_CLUTTER * (len(ws) - len(groups))
                    for j, mem in groups.items():
                        total += cost(tuple(mem), j)
                        if total >= bound:
                            break
                    if total < bound:
                        best_by[key] = (total, groups)
                key = min(best_by, key=lambda k: best_by[k][0]) if best_by else None
                best_cost, best = best_by[key] if best_by else (np.inf, None)
                if np.isfinite(best_cost):
                    self.cost += best_cost
                for j, mem in (best or {}).items():
                    result[j] = tuple(mem)
                if k_probe is not None:
                    alts = [(v[0] - best_cost, k) for k, v in best_by.items() if k != key and np.isfinite(v[0])]
                    if alts:
                        self.alternative = min(alts, key=lambda a: a[0])
            else:  # too many: single-person explanations only
                C = np.full((len(ts), len(ws) + len(ts)), 1e6)
                for a, i in enumerate(ts):
                    for b, j in enumerate(ws):
                        if j in gate[i]:
                            C[a, b] = cost((i,), j) - C_CLUTTER
                    C[a, len(ws) + a] = miss[i]
                r, k = linear_sum_assignment(C)
                self.cost += float(C[r, k].sum()) + C_CLUTTER * len(ws)
                for a, b in zip(r, k):
                    if b < len(ws) and C[a, b] < 1e6:
                        result[ws[b]] = (ts[a],)
        return result, projs

    # --- track existence ----------------------------------------------------------------------
    def walk_evidence(self, tr: JointTrack, c: str, p: Projection, hit_lr: float | None, merged: bool, hidden: bool = False,
                      visible: bool = True, merged_lr: float | None = None) -> float:
        """Camera c's share of the existence test's evidence: log P(what c shows of the track |
        a walking person) - log P(it | no one there).

        - A window that is this track alone: log ``p_detect`` + (C_CLUTTER - its cost): the
          window fits the person's projection better than it fits clutter (the joint
          explanation's own costs).
        - A merged window holding it: ``merged_lr``, the window's likelihood ratio for it (with
          ``merged_evidence``: the explanation's cost without it minus the cost with it, either
          sign: a window whose extent and flow are the union's says it is there, one that fits
          the others alone says it is not); None: 0 (its own window cannot be told apart).
        - No window: log P(no window | a walking person here) (no one there makes none: log 1).
          A walker is expected seen when it moves in this image (predicted image speed at least
          ``mover_flow_px``; with ``slow_misses``, for a confirmed track located by two or more
          views in the last frame, weighed by P(slow), ``p_slow``: P(no window) = P(slow) + (1 -
          P(slow)) P(miss)), is not hidden by the floor plan's boxes (``visible``: ``Occluders``,
          computed by the caller for all tracks of the view at once) and its
          projected cylinder overlaps no other track's (``hidden``: hidden by it, or merged with it
          into a window the explanation may have given to the other alone); then
          with the flow tracker's measured rate, its misses in runs: a two-state chain of
          stationary rate ``p_detect`` and mean miss run ``miss_run`` frames (after a frame with
          a window P(seen) = 1 - (1 - p_detect) / (p_detect miss_run), after a miss 1 / miss_run),
          with ``border_windows`` times the measured chance of a window for a walker cut by the
          image border (``border_window_rate``).
        Updates ``tr.missed`` (the chain's state)."""
        cfg = self.cfg
        if hit_lr is not None:
            tr.missed.discard(c)
            return float(np.log(cfg.p_detect)) + hit_lr
        if merged:
            tr.missed.discard(c)
            return 0.0 if merged_lr is None else float(merged_lr)
        if cfg.slow_misses and tr.confirmed and tr.mode == "planes":
            # its velocity measured in both floor axes: a walker slowing to a stop is no longer
            # rejected in the frame its windows end (one view measures it along its image axis
            # only, and a track on trial may be a crossing of fragments: their misses count in full)
            slow = self.p_slow(p)
        else:
            slow = float(np.linalg.norm(p.flow) < cfg.mover_flow_px)
        if hidden or slow >= 1.0 or not visible:
            tr.missed.discard(c)
            return 0.0
        see = self.p_see_after_miss if c in tr.missed else self.p_see_after_hit
        if cfg.border_windows:
            see *= border_window_rate(p.win, self.widths[c])
        tr.missed.add(c)
        return float(np.log(max(slow + (1.0 - slow) * (1.0 - see), 1e-12)))

    def detection_evidence(self, tr: JointTrack, c: str, xy: np.ndarray, Sxy: np.ndarray, projs: dict[int, Projection], i: int,
                           now: dict[str, bool]) -> float:
        """Camera c's person detections as the existence test's evidence for track i standing at
        xy (covariance Sxy): log P(them | a person there) - log P(them | no one). Only where they
        can say it: a camera whose detector reports in the recording (a key of ``detections``),
        the cylinder wholly in the image, all its rays clear of the floor plan's
        boxes (``Occluders``, whole) and overlapping no other track's projection (``projs``;
        there a detection may be the other's). A detection within the gate (half the projected
        width, plus 3 px and two sd of the projected axis) is a hit. Both hypotheses are
        two-state chains over the frames, the outcome of the last frame kept in ``now`` (the
        track's ``det_prev`` next frame): a person is detected at the stationary rate
        ``p_person_detect`` with misses in runs of mean ``person_miss_run`` frames; with no one
        there, one of the frame's n detections falls in the gate anyway with chance 1 - (1 - 2
        gate / W)^n, and as a standing ghost and the people seen near its line of sight stay
        put, that coincidence persists (``coincidence_persistence``) - so a standing person and
        a ghost are told apart by the frames where the outcomes change, and the first, not by
        counting the same static scene every frame."""
        cfg = self.cfg
        u_det = self.detections.get(c)  # None: a camera whose detector reports no one in the recording
        P, W = self.Ps[c], self.widths[c]
        win = geo.cylinder_window(P, xy, cfg.height, cfg.radius)
        if u_det is None or not self.detectable(c, xy, win, partial=cfg.partial_detections):
            return 0.0
        if self.overlapped(i, win, projs):
            return 0.0
        X = np.array([xy[0], xy[1], self.hc])
        (u, _), _ = geo.project(P, X)
        Ju = geo.flow_jacobian(P, X)[0, :2]
        gate = detection_gate(win, float(Ju @ Sxy @ Ju))
        chance = coincidence_chance(gate, W, len(u_det), u if cfg.partial_detections else None)
        hit = bool(len(u_det)) and float(np.abs(u_det - u).min()) <= gate
        pd_, run, rho = cfg.p_person_detect, cfg.person_miss_run, cfg.coincidence_persistence
        prev = tr.det_prev.get(c)
        if prev is None:
            p1, p0 = pd_, chance  # P(a hit): stationary
        elif prev:
            p1, p0 = 1.0 - (1.0 - pd_) / (pd_ * run), rho + (1.0 - rho) * chance
        else:
            p1, p0 = 1.0 / run, (1.0 - rho) * chance
        now[c] = hit
        if not hit:
            p1, p0 = 1.0 - p1, 1.0 - p0
        return float(np.log(max(p1, 1e-12)) - np.log(max(p0, 1e-12)))

    @staticmethod
    def overlapped(i: int, win: np.ndarray, projs: dict[int, Projection]) -> bool:
        """Whether the columns of window ``win`` (track i's projection) overlap another track's
        projected window in ``projs`` (index -> Projection): hidden by it, or merged with it."""
        return any(k != i and q.win[0] <= win[1] and win[0] <= q.win[1] for k, q in projs.items())

    def detectable(self, c: str, xy: np.ndarray, win: np.ndarray, partial: bool = False) -> bool:
        """Whether camera c's person detector sees a person at floor point xy (projected cylinder
        ``win``): whole - inside the image, all its rays clear of the floor plan's boxes
        (``Occluders``) - or, with ``partial``, partly but as often detected (``detector_sees``)."""
        n_rays = len(VIS_FRACTIONS)
        if not partial and not wholly_in_image(win, self.widths[c]):
            return False  # out of the image: no ray needs casting
        n_clear = n_rays if self.occluders is None else int(self.occluders.clear_rays(c, np.asarray(xy, float)[None])[0])
        return detector_sees(win, self.widths[c], n_clear, n_rays, partial)

    def follow_detections(self, c: str, u_all: np.ndarray) -> list[StillDetection]:
        """Camera c's person detections this frame, each followed from the last frame (the
        nearest within the stillness band, 3 ``detection_sigma_px``) so that how long it has
        stayed in one column is known; detections unseen for a second are forgotten."""
        band = 3.0 * self.cfg.detection_sigma_px
        hist = self.still.setdefault(c, [])
        free = set(range(len(hist)))
        out = []
        for ud in np.asarray(u_all, float):
            k = min(free, key=lambda h: abs(hist[h].u - ud), default=None)
            if k is not None and abs(hist[k].u - ud) <= band:
                free.discard(k)
                e = hist[k]
                e.u, e.last = float(ud), self.clock
                if abs(ud - e.u0) > band:  # it moved: still from now on
                    e.u0, e.since = float(ud), self.clock
            else:
                e = StillDetection(float(ud), float(ud), self.clock, self.clock)
                hist.append(e)
            out.append(e)
        self.still[c] = [e for e in hist if self.clock - e.last <= 1.0]
        return out

    def update_by_detections(self, tracks: list[JointTrack], plans: dict) -> None:
        """``detection_planes``: each camera's person detections as target planes (eq. 4 at the
        detection's column) for the tracks without a window of their own there (standing,
        merged, missed), wholly in the image and clear of the floor plan's boxes. Detections carry
        no flow and no identity, so a pair is used only when unambiguous: the one detection within
        the track's gate (``PLANE_OUTLIER`` on the detection noise and the track's projected
        spread) and within no other track's. A detection that has stayed in one column longer
        than a mover could (twice the stillness band at ``mover_flow_px``) and that no track has
        taken is someone standing whom no track follows, and is left out. The walking state's
        position and the standing state's are both updated."""
        cfg = self.cfg
        sig = cfg.detection_sigma_px
        still_s = 2.0 * 3.0 * sig / cfg.mover_flow_px
        for c in self.Ps:
            u_all = self.detections.get(c)
            if u_all is None:
                continue
            followed = self.follow_detections(c, u_all)
            keep = [k for k, e in enumerate(followed) if e.taken or self.clock - e.since < still_s]
            if not keep:
                continue
            u_det = np.asarray(u_all, float)[keep]
            followed = [followed[k] for k in keep]
            projs = plans[c][1]
            ids = [i for i, p in projs.items() if tracks[i].located and tracks[i].status.get(c, ("",))[0] != TRACKING
                   and self.detectable(c, tracks[i].xy, p.win)]
            if not ids:
                continue
            every = [i for i in projs if tracks[i].located]
            inside = np.array([[(ud - projs[i].u) ** 2 <= PLANE_OUTLIER * (projs[i].var_u + sig**2) for ud in u_det] for i in every])
            for i in ids:
                js = np.flatnonzero(inside[every.index(i)])
                if len(js) != 1 or inside[:, js[0]].sum() != 1:
                    continue
                b = int(js[0])
                followed[b].taken = True
                tr, p = tracks[i], projs[i]
                self.update_plane(tr, c, p, float(u_det[b]), sig, own=False)
                if tr.xs is not None and (row := self.plane_row(c, p, float(u_det[b]))) is not None:
                    a, rhs, g = row
                    Pa = tr.Ps @ a
                    var = float(a @ Pa) + (sig / g) ** 2
                    nu = rhs - float(a @ tr.xs)
                    if nu * nu / var <= PLANE_OUTLIER:
                        k = Pa / var
                        tr.xs, tr.Ps = tr.xs + k * nu, tr.Ps - np.outer(k, Pa)

    def reject_s(self, dt: float) -> float:
        """How long the existence test takes to reject a walking track that lost its person in the
        view of one camera that should see it, s: from ``EXIST_ACCEPT`` to
        ``EXIST_REJECT`` on that camera's misses alone (``walk_evidence``: the first miss after a
        frame with a window, then misses after a miss), at frame interval ``dt``. With the
        measured flow tracker (``p_detect`` 0.91, ``miss_run`` 5 frames) and 10 frames a second,
        25 frames: 2.5 s. More cameras missing it reject it sooner; a walker slowing, hidden or
        merged, later."""
        first = float(np.log(max(1.0 - self.p_see_after_hit, 1e-300)))
        then = float(np.log(max(1.0 - self.p_see_after_miss, 1e-300)))
        rest = EXIST_REJECT - EXIST_ACCEPT - first
        n = 1 + (int(np.ceil(rest / then - 1e-9)) if rest < 0.0 else 0)
        return n * float(dt)

    @staticmethod
    def existence(tr: JointTrack, walk: float, hit: bool, det: float = 0.0) -> None:
        """The existence test's update for one frame, the two modes marginalised: P(frame | a
        person) = (1 - mu) exp(walk) + mu [no window of its own anywhere] (a standing person
        makes no window; mu is the frame's prior standing probability), against P(frame | no
        one) (the walk evidence's denominator); times the person detections' likelihood ratio
        exp(det), the same for both modes (``detection_evidence``). The log-odds are capped at
        ``EXIST_ACCEPT``."""
        mu = tr.mu
        if hit or mu <= 0.0:
            tr.exist += float(np.log(max(1.0 - mu, 1e-300))) + walk + det
        else:
            tr.exist += float(np.logaddexp(np.log(max(1.0 - mu, 1e-300)) + walk, np.log(mu))) + det
        tr.exist = min(tr.exist, EXIST_ACCEPT)

    # --- updates --------------------------------------------------------------------------------
    def _plane(self, c: str, u: float, row: float) -> tuple[np.ndarray, float]:
        a, b = geo.target_plane(self.Ps[c], u, row)
        a, b = geo.normalise_planes(np.asarray(a, float).reshape(1, 2), np.asarray(b, float).reshape(1))
        return a[0], float(b[0])

    def update_plane(self, tr: JointTrack, c: str, p: Projection, u: float, sigma_px: float, offset_sign: float = 0.0,
                     own: bool = True, weight: float = 1.0) -> None:
        """The target plane of column u (eq. 4 at the predicted centroid row); with
        ``offset_sign`` = +1 / -1 the column is a window's left / right edge and the axis lies
        ``radius`` inwards (towards larger / smaller u). Beyond the outlier gate a column that is
        surely the track's (``own``: a window explained as it alone) is taken to show the state
        astray (``kf_update``'s soft gate); one that may be someone else's (a merged window's
        outer edge: the member it is given to may be hidden inside another's) is refused.
        ``weight``: the probability that the column is this track's (``edge_owners``)."""
        row = self.plane_row(c, p, u, offset_sign)
        if row is None:
            return
        a, b, g = row
        kf_update(tr, np.r_[a, 0.0, 0.0], np.array([b]), np.array([[(sigma_px / g) ** 2]]), gate=PLANE_OUTLIER, soft=own, cap=self.cfg.sigma_max,
                  weight=weight)

    def update_own_edge(self, tr: JointTrack, c: str, p: Projection, boxes: CameraBoxes, j: int, left: bool) -> None:
        """A too-wide window's edge on the track's side (``left``: its left edge) as the track's
        own, the axis a radius inside it; none where that edge is the image border cutting the
        track (``cut_edges``)."""
        cut = self.cut_edges(c, boxes, j, [p])[0 if left else 1] if self.cfg.border_edges else False
        if not cut:
            self.update_plane(tr, c, p, float(boxes.win[j, 0] if left else boxes.win[j, 1]), self.outer_edge_sigma(p), +1.0 if left else -1.0)

    def plane_row(self, c: str, p: Projection, u: float, offset_sign: float = 0.0) -> tuple[np.ndarray, float, float] | None:
        """(a, b, g) of ``update_plane``'s measurement a [x, y]^T = b (m) for column u, and the
        image's rate g = |du/dxy| (px/m) that turns its pixel sigma into metres; None where the
        column does not move with the floor position."""
        a, b = self._plane(c, u, p.row)
        Ju = p.J[0, :2]
        g = float(np.linalg.norm(Ju))
        if g < 1e-9:
            return None
        if offset_sign:
            b += self.cfg.radius * offset_sign * np.sign(float(Ju @ a))
        return a, b, g

    def flow_var(self, c: str) -> float:
        """Variance (px^2/s^2, per image axis) of camera c's window flow about eq. 7's J V: the
        calibrated flow noise and ``flow_model_sigma``."""
        return self.flow_sigma[c] ** 2 + self.cfg.flow_model_sigma**2

    def body_width(self, c: str, xy: np.ndarray) -> np.ndarray:
        """Image width (px) of the person's body at floor points xy (..., 2): the cylindrical part
        of a capsule-shaped person (rims at ``radius`` and ``height`` - ``radius``), which a window
        of a person seen whole spans (the rims at the floor and at ``height`` of the cylinder
        model overstate it near a camera)."""
        cfg = self.cfg
        return geo.cylinder_image_width(self.Ps[c], xy, cfg.radius, cfg.height - cfg.radius, cfg.radius)

    def update_width(self, tr: JointTrack, c: str, width: float, p: Projection) -> None:
        """A window of the track alone, its person seen whole (``width_depth``; with
        ``fragment_width`` not a fragment, ``is_fragment``): its width as a
        measurement of depth (a person's image is wider the nearer the camera), linearised at
        the prediction (central differences, 1 cm); noise as the explanation's width term,
        hypot(2 box_sigma, ``edge_sigma_frac`` w); beyond the plane gate (a gross width error)
        not used."""
        xy = tr.s[:2].copy()
        h = 0.01
        w = self.body_width(c, xy + np.array([[0.0, 0.0], [h, 0.0], [-h, 0.0], [0.0, h], [0.0, -h]]))
        if not np.isfinite(w).all():
            return
        w0, g = float(w[0]), np.array([w[1] - w[2], w[3] - w[4]]) / (2.0 * h)
        sw = float(np.hypot(2.0 * self.box_sigma, self.cfg.edge_sigma_frac * w0))
        kf_update(tr, np.r_[g, 0.0, 0.0], np.array([width - w0 + g @ xy]), np.array([[sw**2]]), gate=PLANE_OUTLIER)

    def update_depth(self, tr: JointTrack, c: str, boxes: CameraBoxes, j: int) -> None:
        """Section 3.2's depth range as an interval: pulls the track in only from outside it."""
        cfg = self.cfg
        area = geo.target_area(self.Ps[c], boxes.box(j), cfg.height, cfg.radius, margin=cfg.area_margin, margin_px=self.margin_px)
        s = float((tr.xy - area.origin) @ area.direction)
        if area.s_min <= s <= area.s_max or area.s_min > 0.5 * MAX_RANGE or area.s_max - area.s_min > 0.5 * MAX_RANGE:
            return  # inside, or no bound (a window whose top or bottom row meets no floor or head plane)
        bound = area.s_min if s < area.s_min else area.s_max
        kf_update(tr, np.r_[area.direction, 0.0, 0.0], np.array([bound + float(area.direction @ area.origin)]), np.array([[cfg.radius**2]]), gate=PLANE_OUTLIER)

    def fragment_var(self, p: Projection, width: float) -> float:
        """Extra variance (px^2/s^2) of the horizontal flow of a window ``width`` px wide explained
        as the one person ``p``, in the explanation: ``fragment_flow_sigma``^2 when narrower than
        half the person's projection (a limb, a sliver stuck on the background, the part out of
        an obstacle's shadow: the rendered fragments' region-mean flow is off by about the
        image speed), else 0. Such a window's flow then says little about whose it is. The flow
        update (``update_flow``) keeps the calibrated noise and its gate: the same noise there
        too lost head-on development 191 and 130 (docs/target_planes.md, twenty-ninth session)."""
        return self.cfg.fragment_flow_sigma**2 if is_fragment(p, width) else 0.0

    def flow_map(self, J: np.ndarray) -> np.ndarray:
        """Floor velocity -> the window's flow (2, 2): eq. 7's J (at the body centre) times the
        detector's gain ``flow_gain`` (its region-mean flow falls short of the motion)."""
        return self.cfg.flow_gain * J[:, :2]

    def flow_noise(self, c: str, p: Projection, extra_var: float = 0.0) -> np.ndarray:
        """Covariance (px^2/s^2, 2 x 2) of a window's flow about J V in a flow update: ``flow_var``
        plus ``extra_var`` per image axis, and the mean flow's lag (``flow_lag_var``) through J."""
        Jf = self.flow_map(p.J)
        return (self.flow_var(c) + extra_var) * np.eye(2) + self.flow_lag_var.get(c, 0.0) * (Jf @ Jf.T)

    def update_flow(self, tr: JointTrack, c: str, p: Projection, flow: np.ndarray, extra_var: float = 0.0, gate: float = FLOW_OUTLIER) -> None:
        """Eq. 7 with the detector's gain: the window's flow = ``flow_gain`` J V (W = 0); not used
        beyond ``gate`` (chi^2_2)."""
        H = np.zeros((2, 4))
        H[:, 2:] = self.flow_map(p.J)
        kf_update(tr, H, np.asarray(flow, float), self.flow_noise(c, p, extra_var), gate=gate)

    def edge_owners(self, ps: list[Projection], u: float, side: int, outer: int | None) -> np.ndarray | None:
        """Each member's share of a merged window's outer edge at column u on ``side`` (0 left, 1
        right); ``outer``: the member outermost on that side by the predictions (None: the edge is
        no one's, the image border cutting them). The edge is the outermost member's when it lies
        at or beyond that member's predicted edge, or without ``edge_share``. Inside it, that
        member's flow region falls short of where it is predicted to reach, or it made none (a
        walker slowing to a stop makes no flow region, so a passer's window is all there is): the
        edge is shared by how well each member's predicted edge explains it, N(u; its edge,
        ``outer_edge_sigma``^2 + its projected variance), with equal priors - a probabilistic data
        association of the edge, each member updated by its share (``kf_update``'s weight)."""
        if outer is None:
            return None
        own = np.eye(len(ps))[outer]
        if not self.cfg.edge_share or (u - float(ps[outer].win[side])) * (1.0 if side else -1.0) >= 0.0:
            return own
        ll = np.empty(len(ps))
        for k, p in enumerate(ps):
            var = self.outer_edge_sigma(p) ** 2 + p.var_u
            ll[k] = -0.5 * (u - float(p.win[side])) ** 2 / var - 0.5 * float(np.log(var))
        w = np.exp(ll - ll.max())
        return w / w.sum()

    def edge_sigma(self, p: Projection) -> float:
        return edge_noise(self.box_sigma, self.cfg.edge_sigma_frac, p.width)

    def outer_edge_sigma(self, p: Projection) -> float:
        """The noise of a window's edge used as a track's edge when the window is not the track
        alone (a merged window's outer edge, a too-wide window's edge on its track's side): twice
        ``edge_sigma``. The update and ``edge_owners``' share of the edge both use it."""
        return 2.0 * self.edge_sigma(p)

    # --- one frame ------------------------------------------------------------------------------
    def step(self, tracks: list[JointTrack], frame: dict[str, CameraBoxes], dt: float, probe: JointTrack | None = None,
             force: tuple[str, JointTrack, int | None] | None = None) -> dict[str, list[int]]:
        """Predict, explain every camera's windows, update. Returns the birth candidates: per
        camera, indices into ``frame[c]`` (extended in place with the far sides of too-wide
        windows) of windows no track explains. ``self.frame_cost``: the explanations' summed
        cost; with ``probe`` (a track), ``self.branch``: (extra cost, camera, window index or
        None) of the cheapest explanation of one camera in which the probe holds another window
        than in the best (``explain_camera``), None without one; ``force`` (camera, track,
        window index or None): that camera's explanation gives the track that window (or none)."""
        cfg = self.cfg
        self.clock += dt
        self.wide = []  # too-wide windows explained by one track: (camera, track index, window, far side's window, near side's centre u)
        for tr in tracks:
            self.predict(tr, dt)
        active = [tr for tr in tracks if tr.located]
        k_probe = next((k for k, tr in enumerate(active) if tr is probe), None)
        self.frame_cost, self.branch = 0.0, None
        # the walking prior of a track that may stand, paid once over the cameras that would see it
        # (``wake_once``; the mode is decided over all of them by the mode posterior, ``own_wake``)
        self.wake_share = {}
        may_stand = [tr for tr in active if tr.mu > 0.0] if cfg.wake_once else []
        if may_stand:
            xys = np.array([tr.xy for tr in may_stand])
            n = sum(self.in_view(c, xys).astype(int) for c in self.Ps)
            self.wake_share = {id(tr): 1.0 / max(int(k), 1) for tr, k in zip(may_stand, n)}
        plans = {}
        for c in self.Ps:
            fc = None
            if force is not None and force[0] == c:
                fc = next(((k, force[2]) for k, tr in enumerate(active) if tr is force[1]), None)
            plans[c] = self.explain_camera(c, active, frame[c], k_probe, fc)
            self.frame_cost += self.cost
            if self.alternative is not None and (self.branch is None or self.alternative[0] < self.branch[0]):
                self.branch = (self.alternative[0], c, self.alternative[1])
        idx = [i for i, tr in enumerate(tracks) if tr.located]
        # explain_camera indexes ``active``; map back to ``tracks``
        plans = {c: ({j: tuple(idx[i] for i in mem) for j, mem in ex.items()}, {idx[i]: p for i, p in pr.items()}) for c, (ex, pr) in plans.items()}
        free: dict[str, list[int]] = {}
        used = [0] * len(tracks)
        seen = [False] * len(tracks)
        walk = [0.0] * len(tracks)
        hit = [False] * len(tracks)
        fits = [False] * len(tracks)  # a share of a merged window that fits it (``share_fit_walks``)
        det = [0.0] * len(tracks)  # the person detections' evidence (detection_evidence)
        own = [0.0] * len(tracks)  # log P(its own windows | walking) against clutter (own_wake)
        for tr in tracks:
            tr.status = {}
            tr.log_miss = 0.0
        for c, (expl, projs) in plans.items():
            boxes = frame[c]
            free[c] = [j for j in range(len(boxes)) if j not in expl]
            for i in range(len(tracks)):
                if i not in projs:
                    tracks[i].status[c] = (LOST, "out of view", None)
                else:
                    tracks[i].status[c] = (LOST, "", None)
            holder = {i: (j, len(mem)) for j, mem in expl.items() for i in mem}
            wide_c = self.wide_clutter(c, tracks, projs, boxes, free[c]) if cfg.split_births else []
            in_wide = {e[3][0] for e in wide_c}  # tracks in a too-wide region left as clutter: merged with someone untracked
            # a merged window's cost with all its members, once per window (merged_evidence)
            merged_cost = {j: self.explain_cost(c, [projs[k] for k in mem], boxes, j)
                           for j, mem in expl.items() if len(mem) > 1} if cfg.merged_evidence else {}
            ids = list(projs)
            visible = dict(zip(ids, self.occluders.visible_many(c, np.array([tracks[i].xy for i in ids]).reshape(-1, 2))
                               if self.occluders is not None else np.ones(len(ids), bool)))
            rv: dict = {}  # each track's row_vars in c, once (no update between here and c's updates)

            def rows(k: int, q: Projection, j: int) -> float:
                if k not in rv:
                    rv[k] = self.row_vars(c, tracks[k])
                return self.rows_cost(c, tracks[k], q, boxes, j, rv[k])

            for i, p in projs.items():  # the existence test's evidence, from the predictions
                j, n = holder.get(i, (None, 0))
                # its projected cylinder overlaps another track's: hidden by it, or merged with it
                # into a window the explanation may have given to the other alone
                hidden = n == 0 and self.overlapped(i, p.win, projs)
                lr = merged_lr = None
                if n > 1 and cfg.merged_evidence:
                    # a merged window: explained with this member against without it
                    merged_lr = self.explain_cost(c, [projs[k] for k in expl[j] if k != i], boxes, j) - merged_cost[j]
                if n == 1:
                    # the window's likelihood ratio: this track against the best explanation
                    # without it - clutter, or another track of this view left without a window
                    alt = min([C_CLUTTER] + [self.explain_cost(c, [q], boxes, j) + rows(k, q, j)
                                             for k, q in projs.items() if k != i and k not in holder])
                    lr = max(alt - self.explain_cost(c, [p], boxes, j) - rows(i, p, j), 0.0)
                # for the mode posterior, if no camera has its window: only a camera without one or
                # a share of one (``wake_by_own``) that would see a walker there (hidden behind a
                # shelf or another track, walking or standing makes no window of one's own)
                vis = bool(visible[i])
                if vis and not hidden and n == 0:
                    tracks[i].log_miss -= self.miss_walk(p, c)
                walk[i] += self.walk_evidence(tracks[i], c, p, lr, n > 1 or i in in_wide, hidden, vis, merged_lr)
                hit[i] |= n == 1
                # a share that fits better with it than without it (or one whose fit is not
                # weighed), or its near edge of a too-wide region: it is walking in there
                fits[i] |= (n > 1 and (merged_lr is None or merged_lr >= 0.0)) or i in in_wide
                if n == 1:
                    own[i] += float(np.log(cfg.p_detect)) + lr
            extra = []
            for j, mem in expl.items():
                tid_j = boxes.track[j]
                if len(mem) == 1:
                    i = mem[0]
                    tr, p = tracks[i], projs[i]
                    seen[i] = True
                    ratio = (boxes.width[j] - p.width) / p.width
                    if ratio <= cfg.width_ratio_threshold:
                        side = self.border_side(c, boxes, j, [p]) if cfg.border_edges else 0
                        if side:  # the inner edge, as a merged window's outer edges: the axis a radius beyond it
                            self.update_plane(tr, c, p, float(boxes.win[j, 1] if side < 0 else boxes.win[j, 0]), self.edge_sigma(p), float(side))
                        else:
                            self.update_plane(tr, c, p, float(boxes.u[j]), float(np.sqrt(self.centroid_var(p, boxes.width[j]))))
                            if (cfg.width_depth and self.detectable(c, tr.xy, p.win) and not self.overlapped(i, p.win, projs)
                                    and not (cfg.fragment_width and is_fragment(p, boxes.width[j]))):
                                self.update_width(tr, c, float(boxes.width[j]), p)
                        self.update_depth(tr, c, boxes, j)
                        self.update_flow(tr, c, p, boxes.flow[j])
                        used[i] += 1
                        tr.status[c] = (TRACKING, "", tid_j)
                        continue
                    # wider than one person (eq. 8): someone untracked is in it; the edge on the
                    # track's side is its own, the far side a birth candidate
                    left = abs(boxes.win[j, 0] - p.win[0]) <= abs(boxes.win[j, 1] - p.win[1])
                    edge = boxes.win[j, 0] if left else boxes.win[j, 1]
                    self.update_own_edge(tr, c, p, boxes, j, left)
                    self.update_flow(tr, c, p, boxes.flow[j], extra_var=self.flow_sigma[c] ** 2)
                    far = np.array([boxes.win[j, 1] - p.width, boxes.win[j, 1]] if left else [boxes.win[j, 0], boxes.win[j, 0] + p.width])
                    near_u = float(edge + 0.5 * p.width if left else edge - 0.5 * p.width)
                    extra.append(((tid_j, "far"), np.r_[far, boxes.win[j, 2:]], boxes.flow[j], (i, j, near_u)))
                    tr.status[c] = (UNRELIABLE, "width", None)
                    continue
                ps = [projs[i] for i in mem]
                fs = np.array([p.flow for p in ps])
                spread = float(fs.var(0).sum())  # px^2/s^2: |f_a - f_b|^2 / 4 for two
                lo = min(range(len(mem)), key=lambda k: ps[k].win[0])
                hi = max(range(len(mem)), key=lambda k: ps[k].win[1])
                if cfg.border_edges:
                    # an outer edge the image border cuts is no one's edge: it updates no member
                    cut_l, cut_r = self.cut_edges(c, boxes, j, ps)
                    lo, hi = (None if cut_l else lo), (None if cut_r else hi)
                shares = [self.edge_owners(ps, float(boxes.win[j, side]), side, out) for side, out in ((0, lo), (1, hi))]
                for k, i in enumerate(mem):
                    tr, p = tracks[i], ps[k]
                    seen[i] = True
                    for side, sign, sh in ((0, +1.0, shares[0]), (1, -1.0, shares[1])):
                        if sh is not None and sh[k] >= EDGE_SHARE_MIN:
                            self.update_plane(tr, c, p, float(boxes.win[j, side]), self.outer_edge_sigma(p), sign, own=False,
                                              weight=float(sh[k]))
                    if spread <= self.flow_sigma[c] ** 2:
                        # members moving alike: the region's flow is theirs; moving differently
                        # (crossing), it is a mixture and would draw both velocities together,
                        # erasing what tells them apart at the separation
                        self.update_flow(tr, c, p, boxes.flow[j], extra_var=spread + self.flow_sigma[c] ** 2)
                    others = ",".join(str(tracks[o].tid) for o in mem if o != i)
                    tr.status[c] = (MERGED, others, None)
            if cfg.split_births:
                for e in wide_c:
                    # the track's own side of the region: its near edge and the region's flow, as
                    # for a too-wide window explained as it (above); without them a track merged
                    # side by side in every view has no update and lags out of the region
                    i, j = e[3][0], e[3][1]
                    tr, p = tracks[i], projs[i]
                    self.update_own_edge(tr, c, p, boxes, j, abs(boxes.win[j, 0] - p.win[0]) <= abs(boxes.win[j, 1] - p.win[1]))
                    self.update_flow(tr, c, p, boxes.flow[j], extra_var=self.flow_sigma[c] ** 2)
                    seen[i] = True
                    tr.status[c] = (UNRELIABLE, "width", None)
                    extra.append(e)
            for track, win, flow, (i, j, near_u) in extra:
                boxes, k = boxes.with_box(track, win, flow)
                free[c].append(k)
                self.wide.append((c, i, j, k, near_u))
            frame[c] = boxes
        if self.detections is not None and cfg.detection_planes:
            self.update_by_detections(tracks, plans)
        if self.detections is not None and cfg.person_detections:
            # a track likelier standing (this frame's prior): its person detections (detection_evidence)
            for i, tr in enumerate(tracks):
                now: dict[str, bool] = {}
                if tr.located and tr.mu >= 0.5:
                    xy, Sxy = (tr.xs, tr.Ps) if tr.xs is not None else (tr.xy, tr.S[:2, :2])
                    det[i] = sum(self.detection_evidence(tr, c, xy, Sxy, plans[c][1], i, now) for c in self.Ps)
                tr.det_prev = now
        wide = {i for _, i, _, _, _ in self.wide}
        for i, tr in enumerate(tracks):
            tr.wide_run = tr.wide_run + 1 if i in wide else 0
            speed = float(np.linalg.norm(tr.s[2:]))
            if speed > cfg.max_speed:
                tr.s[2:] *= cfg.max_speed / speed
            tr.n_used = used[i]
            tr.seen = seen[i]
            if tr.located:
                # a track likelier standing: its person detections too, when no window of its own
                # explains it (with ``own_wake`` its own windows may be clutter: the modes stay
                # marginalised and its detections count then too)
                sure_walk = hit[i] and not (cfg.own_wake and tr.mu >= 0.5)
                self.existence(tr, walk[i], sure_walk, 0.0 if sure_walk else det[i])  # before the mode posterior: mu is still the prior
            if tr.located:
                # mode posterior: a window of its own says it walks, and so does a share of a merged
                # one unless the track is likelier standing (``wake_by_own``: the window's others may
                # have made it; it then counts for neither mode) or the window fits the others
                # alone better (``share_fit_walks``: a standing person adds nothing to it; it
                # counts for neither mode); none anywhere is likelier standing, by P(no window |
                # walking) over the cameras
                standing = tr.mu >= 0.5
                if cfg.own_wake and standing and hit[i]:
                    # likelier standing: its own windows wake it by their likelihood ratio against
                    # clutter (a speck does not outweigh a long stand), with its misses elsewhere
                    tr.mu = tr.mu / (tr.mu + (1.0 - tr.mu) * float(np.exp(min(own[i] + tr.log_miss, 700.0))))
                else:
                    share = seen[i] and (fits[i] or not cfg.share_fit_walks)
                    walks = hit[i] or (share and not (cfg.wake_by_own and standing))
                    tr.mu = 0.0 if walks else tr.mu / (tr.mu + (1.0 - tr.mu) * float(np.exp(tr.log_miss)))
            tr.mode = "planes" if used[i] >= 2 else "area" if used[i] == 1 else "merged" if seen[i] else "predicted"
            tr.unseen_s = 0.0 if seen[i] else tr.unseen_s + dt
            if used[i] or (tr.split and seen[i]):  # a hit: a window that is this track alone (or a share of
                tr.hits += 1                         # a merged one, for a track split off a too-wide window)
            if tr.hits >= cfg.confirm_frames:
                tr.confirmed = True
        return free

    def birth(self, tid: int, xy: np.ndarray, support: dict[str, int], frame: dict[str, CameraBoxes]) -> JointTrack:
        """A new track at a crossing of target planes (``tp_initiate.propose``); its velocity by
        eq. 7 from the supporting windows' flows."""
        cfg = self.cfg
        X = np.array([xy[0], xy[1], self.hc])
        names = list(support)
        sig = [np.hypot(self.flow_sigma[c], cfg.flow_model_sigma) for c in names]
        g = cfg.flow_gain  # the detector's flow is flow_gain J V
        V = geo.velocity_from_flows([self.Ps[c] for c in names], [X] * len(names), [frame[c].flow[support[c]] / g for c in names], [x / g for x in sig])
        speed = float(np.linalg.norm(V[:2]))
        if speed > cfg.max_speed:
            V = V * (cfg.max_speed / speed)
        S = np.diag([cfg.radius**2, cfg.radius**2, cfg.birth_sigma_v**2, cfg.birth_sigma_v**2])
        tr = JointTrack(tid, np.r_[xy, V[:2]], S, hits=1, seen=True, n_used=len(support))
        return tr

    @staticmethod
    def locate_distance(tr: JointTrack, accept, xy) -> float | None:
        """How far a crossing ``xy`` lies from the hand-chosen target's click (``tr`` not yet
        located: it is held there), m, when ``accept`` (xy -> bool) takes it as the target; None
        otherwise. ``locate`` takes the nearest; ``tp_initiate.propose`` (``prefer``) puts those
        crossings first in the births' greedy pass, so that a crossing sharing a window with the
        target's own does not take it."""
        return float(np.linalg.norm(np.asarray(xy, float) - tr.xy)) if accept(xy) else None

    def locate(self, tr: JointTrack, proposals: list, frame: dict[str, CameraBoxes], accept) -> set[int]:
        """The hand-chosen target before it is located: the two-camera crossing
        (``tp_initiate.propose``) nearest the click that ``accept`` (xy -> bool) takes
        (``locate_distance``) becomes its state, as a birth would (a click is a few tenths of a
        metre off; a single window near it may be someone else or a fragment). Returns the
        proposals used."""
        best, dbest = None, np.inf
        for k, (xy, _) in enumerate(proposals):
            m = self.locate_distance(tr, accept, xy)
            if m is not None and m < dbest:
                best, dbest = k, m
        if best is None:
            return set()
        xy, support = proposals[best]
        new = self.birth(tr.tid, xy, support, frame)
        tr.s, tr.S, tr.located, tr.seen, tr.n_used, tr.mode = new.s, new.S, True, True, new.n_used, "planes"
        return {best}

    def locate_track(self, target: JointTrack, tracks: list[JointTrack], accept, t: float, t0: float | None = None) -> JointTrack | None:
        """The hand-chosen target still not located, and a track started since from a crossing
        ``locate`` did not take (a crossing of partial windows - a sliver, a fragment, a window
        cut by the image border - lands up to a metre off): while that track is unconfirmed its
        filtered state is held to ``locate``'s own test (``accept``), as a crossing would be. Of
        those it passes (filtered for at least one frame), the one nearest the click: the target's
        track takes its state (staying the target's, confirmed) and the track is returned, for the
        caller to drop. Without it the track explains the target's windows from then on and no
        crossing is left to locate the target by. With ``locate_back`` (and ``t0``, the click's
        frame time) a track also passes where it was at ``t0``, its filtered position taken back
        at its velocity: the target may have walked out of the disc before the first crossing on
        it was made."""
        best, dbest = None, np.inf
        for tr in tracks:
            if tr is target or tr.confirmed or not tr.located or tr.born is None or tr.born[0] >= t - 1e-9:
                continue
            pts = [tr.xy]
            if self.cfg.locate_back and t0 is not None:
                pts.append(tr.xy - tr.s[2:] * (t - t0))  # where it was at the click's frame, at its velocity
            for x in pts:
                d = float(np.linalg.norm(x - target.xy))
                if accept(x) and d < dbest:
                    best, dbest = tr, d
        if best is not None:
            self.take_over(target, best)
        return best

    @staticmethod
    def take_over(target: JointTrack, track: JointTrack) -> None:
        """The hand-chosen target's track becomes ``track`` (``locate_track``, ``adopt``): every
        field copied but its id, and it stays confirmed (the target is always reported)."""
        for f in dataclasses.fields(JointTrack):
            if f.name not in ("tid", "confirmed"):
                setattr(target, f.name, copy.deepcopy(getattr(track, f.name)))

    def adopt(self, target: JointTrack, tracks: list[JointTrack], click: tuple[float, np.ndarray, np.ndarray],
              floor_area: float) -> JointTrack | None:
        """The hand-chosen target still not located, and a confirmed track (someone a two-camera
        crossing found and five frames of windows of its own confirmed). ``click``: (t0, x0, P0),
        the first frame's time and the target's position there with its spread. Each track's
        first state (``born``: t_b, s_b, S_b) is taken back to t0 with the tracker's walker model
        (constant velocity, white acceleration ``accel_sigma``): x = x_b - v_b (t_b - t0). The
        track is the target when that start is likelier under the click, N(x; x0, P0 + its
        spread), than under someone anywhere on the floor, 1 / ``floor_area`` (the choice
        ``relink`` makes for a person found again); of several, the likeliest. The target's track
        takes its state and that track is returned, for the caller to drop. A crossing just
        outside ``locate``'s disc about the click (a click a few tenths of a metre off, a crossing
        as much) otherwise starts someone else's track, on the target, and the target is never
        located."""
        if not floor_area > 0:
            return None
        t0, x0, P0 = click
        best, best_llr = None, 0.0
        for tr in tracks:
            if tr is target or not (tr.confirmed and tr.located) or tr.born is None:
                continue
            tb, sb, Sb = tr.born
            dt = tb - t0
            B = np.hstack([np.eye(2), -dt * np.eye(2)])  # x(t0) = x_b - dt v_b
            C = P0 + B @ Sb @ B.T + self.cfg.accel_sigma**2 * dt**3 / 3.0 * np.eye(2)
            d = B @ sb - x0
            llr = gauss_loglik(d, C) + float(np.log(floor_area))
            if llr > best_llr:
                best, best_llr = tr, llr
        if best is not None:
            self.take_over(target, best)  # (best is confirmed, as the target is)
        return best

    def wide_clutter(self, c: str, tracks: list[JointTrack], projs: dict, boxes: CameraBoxes, free: list[int]) -> list:
        """Windows of camera c explained as clutter that hold one confirmed track's projected
        cylinder (within ``margin_px``) and are wider than it (eq. 8 ratio above
        ``width_ratio_threshold``), their flow within the track's 99 % gate: the track and
        someone walking beside it, one flow region (the explanation leaves such a window as
        clutter: its width is far from one person's). The track is on the side whose edge is
        nearer its prediction; the far side is returned as ``step``'s too-wide windows are:
        (id, window, flow, (track index, window index, near side's centre u))."""
        out = []
        for j in free:
            ul, ur = boxes.win[j, 0], boxes.win[j, 1]
            inside = [i for i, p in projs.items() if tracks[i].confirmed and tracks[i].located
                      and p.win[0] >= ul - self.margin_px - 3.0 * np.sqrt(p.var_u + self.u_sigma**2)
                      and p.win[1] <= ur + self.margin_px + 3.0 * np.sqrt(p.var_u + self.u_sigma**2)]
            if len(inside) != 1:
                continue
            i = inside[0]
            p = projs[i]
            if (ur - ul - p.width) <= self.cfg.width_ratio_threshold * p.width:
                continue
            df = boxes.flow[j] - p.flow
            Sf = p.var_f + (2.0 * self.flow_sigma[c] ** 2 + self.cfg.flow_model_sigma**2) * np.eye(2)
            if float(df @ np.linalg.solve(Sf, df)) > FLOW_CAP:
                continue
            left = abs(ul - p.win[0]) <= abs(ur - p.win[1])
            far = np.array([ur - p.width, ur] if left else [ul, ul + p.width])
            near_u = float(ul + 0.5 * p.width if left else ur - 0.5 * p.width)
            out.append(((boxes.track[j], "far"), np.r_[far, boxes.win[j, 2:]], boxes.flow[j], (i, j, near_u)))
        return out

    def holds(self, P: np.ndarray, win: np.ndarray, *xys: np.ndarray) -> bool:
        """The window ``win`` [u_l, u_r, v_t, v_b] holds the projected cylinders at every xy
        (within ``margin_px``): one flow region of those people."""
        lo, hi = np.asarray(win, float) - self.margin_px, np.asarray(win, float) + self.margin_px
        for xy in xys:
            w = geo.cylinder_window(P, xy, self.cfg.height, self.cfg.radius)
            if not (np.isfinite(w).all() and w[0] >= lo[0] and w[1] <= hi[1] and w[2] >= lo[2] and w[3] <= hi[3]):
                return False
        return True

    def in_view(self, c: str, xys: np.ndarray) -> np.ndarray:
        """Whether camera c would see a person at each floor point xys (N, 2): (N,) bool, the
        projected cylinder's columns within its image, in part at least (as ``project``), and not
        hidden by the floor plan's boxes."""
        w = geo.cylinder_window(self.Ps[c], xys, self.cfg.height, self.cfg.radius)
        seen = partly_in_image(w, self.widths[c])
        if self.occluders is not None and seen.any():
            seen &= self.occluders.visible_many(c, xys)
        return seen

    def not_one_person(self, c: str, xy: np.ndarray, width: float) -> bool:
        """A window ``width`` px wide is not one whole person at floor point xy in camera c: a
        fragment, narrower than half the projected cylinder's width inside the image
        (``fragment_var``'s test), or wider than one person (eq. 8's ratio above
        ``width_ratio_threshold``, as ``wide_clutter``'s), the image border taken off both."""
        w = geo.cylinder_window(self.Ps[c], xy, self.cfg.height, self.cfg.radius)
        if not np.isfinite(w).all():
            return True
        seen = span_in_image(w[0], w[1], self.widths[c])
        return seen <= 0.0 or width < 0.5 * seen or (width - seen) / seen > self.cfg.width_ratio_threshold

    def sees_no_one(self, c: str, xy: np.ndarray, boxes: CameraBoxes) -> bool:
        """Camera c would see a person at floor point xy whole (the projected cylinder's columns
        inside its image, not hidden by the floor plan's boxes) and has no window, of any flow,
        within ``margin_px`` of those columns: it sees no one there. A crossing of two target
        planes that two or more further cameras see no one at is two people's planes crossing (a
        ghost), not a person (``tp_initiate.propose``, ``ghost_test``)."""
        w = geo.cylinder_window(self.Ps[c], xy, self.cfg.height, self.cfg.radius)
        if not wholly_in_image(w, self.widths[c]):
            return False
        if self.occluders is not None and not self.occluders.visible(c, xy):
            return False
        if not len(boxes):
            return True
        return not bool(((boxes.win[:, 0] - self.margin_px <= w[1]) & (w[0] <= boxes.win[:, 1] + self.margin_px)).any())

    def contradicts(self, c: str, xy_f: np.ndarray, xy_n: np.ndarray, boxes: CameraBoxes) -> bool:
        """Camera c has a window holding the projected cylinder at xy_n (the track) and none
        holding the one at xy_f (the second person), though xy_f is in its view and not hidden
        by the floor plan's boxes: it sees the track and no one where the second person would be."""
        cfg = self.cfg
        wins = [geo.cylinder_window(self.Ps[c], xy, cfg.height, cfg.radius) for xy in (xy_f, xy_n)]
        if not (partly_in_image(wins[0], self.widths[c]) and np.isfinite(wins[1]).all()):
            return False
        if self.occluders is not None and not self.occluders.visible(c, xy_f):
            return False
        u = [0.5 * (w[0] + w[1]) for w in wins]
        holds = [bool(((boxes.win[:, 0] - self.margin_px <= x) & (x <= boxes.win[:, 1] + self.margin_px)).any()) for x in u] if len(boxes) else [False, False]
        return holds[1] and not holds[0]

    def split(self, tracks: list[JointTrack], frame: dict[str, CameraBoxes], taken: set, inside_room) -> list[JointTrack]:
        """Births from too-wide windows that a second camera sees side by side too (issue 12: a
        look-alike walking beside a track, merged with it in every view, never has a window of
        its own).

        A window of camera c holding one confirmed track but wider than that person (eq. 8,
        recorded by ``step`` in ``self.wide``) for ``confirm_frames`` frames running holds a
        second person at its far side. The far side's centre column (the far edge moved half a
        person's projected width inwards) and the near side's give two target planes (eqs.
        3-5). Another camera c2 confirms it only with a window that is itself too wide for one
        person (eq. 8 against the track's projected width there: c2 sees the two side by side
        too); its two sides' centre columns give two more planes, and the far and near planes
        of c crossed with them (either pairing, the one whose near crossing is nearer the track)
        place the two people, xy_far and xy_near (eq. 6). They must be at least 2 ``radius``
        apart (two bodies), xy_far on the floor plan and away from every other track, and both
        projected cylinders must lie within both windows (``holds``; section 3.2's target area
        is not used: a merged window's top row is the farther person's head, its bottom row the
        nearer one's feet). A window of c2 one person wide (the two one behind the other on its
        line of sight) is no evidence of a second person: accepting it as confirmation made
        false splits on analytic recordings (issue 12, third session). Then the track moves to
        xy_near (position spread ``radius``) and a new track starts at xy_far, its velocity
        from the windows' flows (eq. 7). Of several confirming windows the one whose planes
        cross at the largest angle is used. A track is split at most once a frame (each
        camera's too-wide window of the pair is a candidate; two far crossings more than 2
        ``radius`` apart used to start two tracks and move the track twice: issue 12, eighty-
        second session). ``taken``: far-side windows (camera, index) a crossing of free windows
        (``tp_initiate.propose``) already used.
        Returns the new tracks (ids not yet set)."""
        cfg = self.cfg
        min_angle = np.radians(cfg.min_plane_angle_deg)
        out = []
        split_now = set()  # tracks split this frame: one split each (another camera's too-wide
        # window of the same pair would move the track a second time and start a second far person)
        for c, i, j, k, near_u in self.wide:
            tr = tracks[i]
            if (c, k) in taken or i in split_now or not tr.confirmed or not tr.located or tr.wide_run < cfg.confirm_frames:
                continue  # a too-wide window for confirm_frames frames, as a new track's own windows
            b = frame[c]
            if np.linalg.norm(b.flow[k]) < cfg.mover_flow_px:
                continue
            vmid = 0.5 * (b.win[j, 2] + b.win[j, 3])
            a_f, b_f = geo.target_plane(self.Ps[c], b.u[k], vmid)
            a_n, b_n = geo.target_plane(self.Ps[c], near_u, vmid)
            best = None
            for c2, b2 in frame.items():
                if c2 == c:
                    continue
                P2 = self.Ps[c2]
                w_one = geo.cylinder_window(P2, tr.xy, cfg.height, cfg.radius)
                if not np.isfinite(w_one).all():
                    continue
                pw = max(float(w_one[1] - w_one[0]), 1.0)  # one person's width in c2, at the track
                for j2 in range(len(b2)):
                    if isinstance(b2.track[j2], tuple):  # a far side added by step, not a window
                        continue
                    ul2, ur2 = float(b2.win[j2, 0]), float(b2.win[j2, 1])
                    if (ur2 - ul2 - pw) <= cfg.width_ratio_threshold * pw:
                        continue  # c2 does not see two people side by side (eq. 8 in c2 too)
                    v2 = 0.5 * (b2.win[j2, 2] + b2.win[j2, 3])
                    sides = [geo.target_plane(P2, ul2 + 0.5 * pw, v2), geo.target_plane(P2, ur2 - 0.5 * pw, v2)]
                    pick = None
                    for sf, sn in ((0, 1), (1, 0)):  # which of c2's sides is the far person
                        try:
                            xy_f, _ = geo.intersect_planes(np.array([a_f, sides[sf][0]]), np.array([b_f, sides[sf][1]]), min_angle)
                            xy_n, _ = geo.intersect_planes(np.array([a_n, sides[sn][0]]), np.array([b_n, sides[sn][1]]), min_angle)
                        except geo.IllConditioned:
                            continue
                        if float(np.linalg.norm(xy_f - xy_n)) < 2 * cfg.radius or not on_floor(inside_room, xy_f):
                            continue
                        # each camera's window holds both: their projected cylinders lie within it
                        # (not section 3.2's target area: the window's top row is the farther
                        # person's head, its bottom row the nearer one's feet)
                        if not all(self.holds(self.Ps[cc], win, xy_f, xy_n) for cc, win in ((c, b.win[j]), (c2, b2.win[j2]))):
                            continue
                        d_n = float(np.linalg.norm(xy_n - tr.xy))  # the track is the near person
                        if pick is None or d_n < pick[0]:
                            pick = (d_n, xy_f, xy_n)
                    if pick is None:
                        continue
                    a2 = sides[0][0]
                    an = np.array([a_f, a2]) / np.linalg.norm(np.array([a_f, a2]), axis=1, keepdims=True)
                    sin = abs(float(an[0, 0] * an[1, 1] - an[0, 1] * an[1, 0]))
                    if best is None or sin > best[0]:
                        best = (sin, pick[1], pick[2], c2, j2)
            if best is None:
                continue
            _, xy_f, xy_n, c2, j2 = best
            if any(self.contradicts(c3, xy_f, xy_n, frame[c3]) for c3 in frame if c3 != c):
                continue
            if any(self.covers(o, xy_f) for o in tracks if o is not tr and o.located) or any(
                    float(np.linalg.norm(xy_f - n.xy)) < 2 * cfg.radius for n in out):
                continue
            tr.s[:2] = xy_n
            tr.S[:2, 2:] = 0.0
            tr.S[2:, :2] = 0.0
            tr.S[:2, :2] = np.eye(2) * cfg.radius**2
            new = self.birth(-1, xy_f, {c: k, c2: j2}, frame)
            new.split = True
            taken.add((c, k))
            split_now.add(i)
            out.append(new)
        return out

    def covers(self, tr: JointTrack, xy: np.ndarray) -> bool:
        """A crossing at xy is track ``tr`` itself: nearer than 2 ``radius`` (two bodies cannot
        be), or inside the 99 % gate of its position uncertainty (a track still being found,
        e.g. the hand-given target)."""
        d = np.asarray(xy, float) - tr.xy
        return float(np.linalg.norm(d)) < 2 * self.cfg.radius or float(d @ np.linalg.solve(tr.S[:2, :2], d)) < BIRTH_GATE

    def inside_wall(self, xy, inside_room) -> tuple[np.ndarray, np.ndarray] | None:
        """The point ``radius`` inside the floor plan's outline at the outline's point nearest to
        xy (on the floor plan or off it), and the outline's inward unit normal there (by a corner,
        the direction towards the outline's middle); None without an outline."""
        cfg = self.cfg
        if self.outline is None or len(self.outline) < 3:
            return None
        best = None
        for a, b in zip(self.outline, np.roll(self.outline, -1, axis=0)):
            e = b - a
            L2 = float(e @ e)
            if L2 <= 0.0:
                continue
            q = nearest_on_segment(xy, a, b)
            d = float(np.linalg.norm(xy - q))
            if best is None or d < best[0]:
                n = np.array([-e[1], e[0]]) / np.sqrt(L2)  # a normal of the edge; inwards below
                best = (d, q, n)
        if best is None:
            return None
        _, q, n = best
        if not on_floor(inside_room, q + 1e-3 * n):
            n = -n
        xy = q + cfg.radius * n
        if not on_floor(inside_room, xy):  # by a corner: towards the middle
            m = self.outline.mean(axis=0) - q
            n = m / max(float(np.linalg.norm(m)), 1e-9)
            xy = q + cfg.radius * n
        return xy, n

    def onto_floor(self, tr: JointTrack, inside_room) -> bool:
        """A person is on the floor plan. A track that left it - the hand-chosen target, which is
        never dropped, after running on along one camera's line of sight where one view cannot
        tell depth - is put back at the outline's nearest point, ``radius`` inside the wall, with
        no velocity and the largest spreads (``sigma_max``, ``max_speed`` / 2; its standing
        position the same), for the windows to find it again. Returns whether it was moved."""
        cfg = self.cfg
        if on_floor(inside_room, tr.xy):
            return False
        inside = self.inside_wall(tr.xy, inside_room)
        if inside is None:
            return False
        tr.s = np.r_[inside[0], 0.0, 0.0]
        tr.S = np.diag([cfg.sigma_max**2] * 2 + [(0.5 * cfg.max_speed) ** 2] * 2)
        tr.xs, tr.Ps = tr.s[:2].copy(), tr.S[:2, :2].copy()
        return True

    def against_wall(self, tr: JointTrack, inside_room) -> None:
        """``wall_stops``: a person's centre stays ``radius`` inside the floor plan's walls. A
        track predicted closer to (or through) the nearest wall is moved onto the line ``radius``
        inside it along its own uncertainty - the constraint taken as an exact measurement of the
        distance from the wall, its velocity corrected through their correlation, the spreads
        kept (estimate projection; up to three walls, for a corner). The standing position the
        same."""
        def project(x, C, dims):
            for _ in range(3):
                inside = self.inside_wall(x[:2], inside_room)
                if inside is None:
                    return x
                xy, n = inside
                if on_floor(inside_room, x[:2]) and float(n @ (x[:2] - xy)) >= 0.0:
                    return x
                h = np.zeros(dims)
                h[:2] = n
                Ch = C @ h
                x = x + Ch * float(n @ xy - h @ x) / float(h @ Ch)
            return x
        tr.s = project(tr.s, tr.S, 4)
        if tr.xs is not None:
            tr.xs = project(tr.xs, tr.Ps, 2)

    def prune(self, tracks: list[JointTrack], keep: int | None, inside_room) -> list[JointTrack]:
        """Drops unconfirmed tracks without a window that is theirs alone, confirmed ones unseen
        for ``hold_s`` or off the floor plan, and the younger of two tracks nearer than 2
        ``radius`` with states alike (two bodies cannot be: one person seen twice; with
        ``dup_prior``, alike as predicted for this frame too; with ``dup_velocity``, their
        velocity difference likelier for one person than for two, ``one_velocity``; with
        ``dup_standing``, a track likelier standing at its standing mode, ``duplicate_state``); never the
        track ``keep`` (the hand-chosen target), which is put back on the floor plan when it left
        it (``onto_floor``). With ``wall_stops`` a track no window explained this frame is first
        held ``radius`` inside the walls (``against_wall``)."""
        cfg = self.cfg
        out = []
        self.ends = []  # this frame's confirmed tracks dropped: (track, why, the track it duplicated or None)
        for tr in tracks:
            if tr.tid != keep:
                if not ((tr.n_used or (tr.split and tr.seen)) if not tr.confirmed else tr.unseen_s <= cfg.hold_s):
                    self.ends.append((tr, "unseen", None))
                    continue
                if tr.exist < EXIST_REJECT:  # the existence test rejects it: not a person
                    self.ends.append((tr, "existence", None))
                    continue
                if cfg.wall_stops and not tr.seen:
                    self.against_wall(tr, inside_room)
                if not on_floor(inside_room, tr.xy):
                    self.ends.append((tr, "off floor", None))
                    continue
            else:
                if cfg.wall_stops and not tr.seen:
                    self.against_wall(tr, inside_room)
                self.onto_floor(tr, inside_room)  # the target is kept, on the floor plan
            out.append(tr)
        drop = set()
        for a, b in itertools.combinations(out, 2):
            if a.tid in drop or b.tid in drop:
                continue
            (sa, Sa), (sb, Sb) = duplicate_state(a, cfg.dup_standing), duplicate_state(b, cfg.dup_standing)
            if not alike(sa, Sa, sb, Sb, cfg.radius):
                continue
            if cfg.dup_prior and a.prior is not None and b.prior is not None and not alike(*a.prior, *b.prior, cfg.radius):
                continue  # apart as predicted: two people brought together by this frame's updates
            if cfg.dup_velocity and not one_velocity(sa[2:] - sb[2:], Sa[2:, 2:] + Sb[2:, 2:], 0.5 * cfg.max_speed):
                continue  # their velocities say two people passing, not one seen twice
            young = b if (b.tid != keep and (a.tid == keep or (a.confirmed, a.hits) >= (b.confirmed, b.hits))) else a
            if young.tid != keep:
                other = a if young is b else b
                drop.add(young.tid)
                self.ends.append((young, "duplicate", other.tid))
        self.ends = [e for e in self.ends if e[0].confirmed]
        return [tr for tr in out if tr.tid not in drop]
