"""Lazy tracker: anonymous floor detections -> piecewise-unambiguous track segments (Teixeira eq. 9).

Each camera frame k the tracker

1. predicts every live track with a constant-velocity Kalman filter (per axis, state [p, v]):
       F = [[1, dt], [0, 1]],  Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]],  H = [1, 0],  R = sigma^2,
   vectorised over tracks (the covariance is the same for x and y, so 3 numbers per track);
2. fuses detections of one frame from different cameras closer than ``duplicate_m`` (two cameras
   whose floor tiles meet both reporting one person near the border) into their mean, then
   associates predicted positions to the frame's detections by ``linear_sum_assignment`` on the
   squared distance (the Gaussian log-likelihood up to a constant), with a gate ``gate_m`` (m);
   unmatched detections start new tracks;
3. ends a track that has been missed for more than ``max_missed_s`` seconds (a detection drop-out,
   or a person standing still in front of a privacy camera);
4. keeps a proximity relation between tracks with hysteresis: two tracks become *linked* when
   their filtered positions come within ``r_enter`` (m) and *unlinked* only beyond ``r_exit`` >
   ``r_enter``, so noise around one radius does not shatter tracks. Whenever a pair's link state
   changes, both tracks end their segment and continue in new segments (a proximity ambiguity);
   when a track vanishes while linked, its partners are cut too (static ambiguity, Fig. 4b).

Being lazy, it never decides who is who across a break: each segment is one unambiguous piece of
a track hypothesis (eq. 9, theta = a chain of segments), and ``predecessors`` lists, for each new
segment, the segments that ended shortly before near it with a continuity weight

    w(n | e) = N( p_n ; p_e + v_e min(gap, coast_s),  (sigma_birth + speed_max gap)^2 I ),

gap = t_n - t_e (s), for ended segments within 3 standard deviations. An ended segment that takes
more than half of a birth's weight (against the others and a ``newcomer_density``) is consumed.
The matcher uses them to carry identity evidence across breaks.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment
from scipy.stats import norm

SEGMENT_COLUMNS = ["frame", "t", "segment", "track", "x", "y", "vx", "vy", "pvv", "zx", "zy", "svx", "svy", "svv"]


@dataclass(frozen=True)
class TrackerConfig:
    """Lazy-tracker parameters (metres, seconds)."""

    sigma_m: float = 0.15  # detection noise per axis, m (from the calibration)
    q: float = 2.0  # white-acceleration spectral density, m^2/s^3
    init_speed_sigma: float = 1.0  # prior std of a new track's velocity, m/s
    gate_m: float = 1.0  # association gate, m
    duplicate_m: float = 0.5  # detections of one frame from different cameras this close are one person, m
    max_missed_s: float = 0.3  # a track missed longer than this ends, s
    r_enter: float = 0.6  # proximity radius that starts an ambiguity, m
    r_exit: float = 0.8  # radius beyond which the ambiguity ends (hysteresis), m
    velocity_window_s: float = 1.0  # window of the least-squares velocity used as evidence, s
    carry_s: float = 15.0  # how long an ended segment stays a candidate predecessor, s
    coast_s: float = 1.0  # longest constant-velocity extrapolation of an ended segment, s
    sigma_birth: float = 0.3  # continuity std at zero gap, m
    speed_max: float = 1.0  # growth of the continuity std with the gap, m/s
    newcomer_density: float = 0.01  # 1/m^2: weight of "someone new" against the continuity densities
    consume: bool = True  # an ended segment that takes over half of a birth's weight stops being a
    # candidate for later births (False: it stays one for carry_s, and the matcher shares it out)

    def __post_init__(self):
        if not self.r_exit >= self.r_enter > 0:
            raise ValueError(f"need r_exit >= r_enter > 0 (got r_enter={self.r_enter}, r_exit={self.r_exit})")
        if self.gate_m <= 0 or self.max_missed_s < 0 or self.sigma_m < 0:
            raise ValueError("gate_m must be > 0, max_missed_s and sigma_m >= 0")


@dataclass
class Segments:
    """The tracker's output.

    rows: one row per (frame, segment) with a detection: ``frame, t, segment``, ``track`` (the
    filtered track, kept across cuts: a cut ends a segment, not the track) and the filtered
    state ``x, y, vx, vy`` (m, m/s), the velocity variance ``pvv`` (m^2/s^2, per axis), the raw
    detection ``zx, zy`` and the smoothed velocity ``svx, svy`` with its variance ``svv`` (see
    ``window_velocity``); sorted by frame.
    info: per segment: ``start_frame, end_frame, start_t, end_t, end_x, end_y, end_vx, end_vy``,
    ``end_reason`` (proximity, missed, static, end).
    predecessors: per new segment, a list of (ended segment, continuity weight density in 1/m^2).
    continues: per segment started by a cut of a live track (proximity or static ambiguity), the
    segment that the same filtered track had just before, and the probability that the
    association swapped that track with a neighbour during it,
        p_swap = Phi(-d_min / (2 sigma)),
    d_min the segment's closest approach to any other track (m): two tracks d apart whose
    detections (noise sigma per axis, each compared with a prediction about as uncertain) are
    swapped when the difference of the noises along their separation exceeds d, and that
    difference has std 2 sigma.
    partner: per segment in ``continues``, the filtered-track number of the track it came
    closest to (d_min) during its old segment: the track it may have been swapped with.
    frame_times: (F,) time of every camera frame (s).
    """

    rows: pd.DataFrame
    info: pd.DataFrame
    predecessors: dict[int, list[tuple[int, float]]] = field(default_factory=dict)
    frame_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    continues: dict[int, tuple[int, float]] = field(default_factory=dict)
    partner: dict[int, int] = field(default_factory=dict)

    @property
    def n_segments(self) -> int:
        return len(self.info)


def frames_from_detections(det: pd.DataFrame, fps: float, duration: float | None = None):
    """Group detections into camera frames: frame index k = round(t fps). Returns (frame_times,
    frame index per row, x, y, camera code per row) with rows sorted by frame."""
    if fps <= 0:
        raise ValueError(f"camera frame rate must be > 0 (got {fps})")
    t = det["t"].to_numpy(float)
    k = np.rint(t * fps).astype(np.int64)
    n_frames = int(max(k.max() + 1 if len(k) else 0, np.floor((duration or 0.0) * fps + 1e-9)))
    order = np.argsort(k, kind="stable")
    return (
        np.arange(n_frames) / fps,
        k[order],
        det["x"].to_numpy(float)[order],
        det["y"].to_numpy(float)[order],
        pd.factorize(det["camera"].astype(str))[0][order],
    )


def track_segments(frame_times: np.ndarray, frame_idx: np.ndarray, x: np.ndarray, y: np.ndarray,
                   cfg: TrackerConfig = TrackerConfig(), camera: np.ndarray | None = None) -> Segments:
    """Run the lazy tracker over detections grouped by frame (see module docstring).

    The loop over frames is the only sequential part; within a frame everything is an array
    operation over tracks, and births, deaths and cuts (rare) are handled off the common path.
    """
    F = len(frame_times)
    bounds = np.searchsorted(frame_idx, np.arange(F + 1))
    Z = np.stack([np.asarray(x, float), np.asarray(y, float)], axis=1)
    cams = np.zeros(len(Z), np.int64) if camera is None else np.asarray(camera)
    R = max(cfg.sigma_m, 0.02) ** 2  # an ideal camera still gets a small floor, for stable gains
    q = cfg.q

    # live tracks: one row each, X = [px, py, vx, vy, ppp, ppv, pvv, t_last, zx, zy]: the state
    # and covariance at the last update (time t_last) and the detection used there; a track is
    # predicted from its last update only when a detection is offered to it
    X = np.zeros((0, 10))
    seg = np.zeros(0, np.int64)
    trk = np.zeros(0, np.int64)  # filtered-track number: kept across cuts, new at a birth
    n_tracks = 0
    pending = np.zeros(0, bool)  # a cut decided while the track was not seen, applied when it is
    dmin = np.zeros(0)  # closest approach of each track's current segment to any other track, m
    dpart = np.zeros(0, np.int64)  # filtered-track number of the track at that closest approach
    continues: dict[int, tuple[int, float]] = {}
    partner: dict[int, int] = {}
    linked = np.zeros((0, 0), bool)
    gate2, enter2, exit2, dup2 = cfg.gate_m**2, cfg.r_enter**2, cfg.r_exit**2, cfg.duplicate_m**2

    n_out = 0
    out = np.zeros((len(Z), 7))  # px, py, vx, vy, pvv, zx, zy
    out_frame = np.zeros(len(Z), np.int64)
    out_seg = np.zeros(len(Z), np.int64)
    out_trk = np.zeros(len(Z), np.int64)
    start_frame: list[int] = []
    end_state: list[tuple] = []  # per segment: (t, x, y, vx, vy) when it ended
    end_reason: list[str] = []
    predecessors: dict[int, list[tuple[int, float]]] = {}
    ended: list[int] = []  # ended segments still eligible as predecessors

    def new_segment(k: int) -> int:
        start_frame.append(k); end_state.append(None); end_reason.append("end")
        return len(start_frame) - 1

    def end_segment(a: int, reason: str, t_end: float) -> None:
        s = int(seg[a])
        end_reason[s] = reason
        end_state[s] = (t_end, X[a, 0], X[a, 1], X[a, 2], X[a, 3])
        ended.append(s)

    def link_births(t: float, births: list[int], births_xy: np.ndarray) -> None:
        ended[:] = [e for e in ended if t - end_state[e][0] <= cfg.carry_s]
        if not ended or not births:
            return
        e_arr = np.array(ended)
        st = np.array([end_state[e] for e in ended])
        gap = t - st[:, 0]
        pred = st[:, 1:3] + st[:, 3:5] * np.minimum(gap, cfg.coast_s)[:, None]
        sd = cfg.sigma_birth + cfg.speed_max * gap
        d2 = ((births_xy[:, None, :] - pred[None]) ** 2).sum(-1)
        dens = np.exp(-0.5 * d2 / sd**2) / (2 * np.pi * sd**2)
        near = d2 <= (3 * sd) ** 2
        taken = np.zeros(len(e_arr), bool)
        for b, n in enumerate(births):
            if near[b].any():
                predecessors[n] = [(int(e), float(w)) for e, w in zip(e_arr[near[b]], dens[b][near[b]])]
                # an ended segment that clearly continues as this birth is no candidate for later ones
                if cfg.consume:
                    taken |= near[b] & (dens[b] > 0.5 * (dens[b][near[b]].sum() + cfg.newcomer_density))
        if taken.any():
            ended[:] = [e for e, tk in zip(ended, taken) if not tk]

    for k in range(F):
        t = frame_times[k]
        b0, b1 = bounds[k], bounds[k + 1]
        z = Z[b0:b1]
        if len(z) > 1:
            # cameras tile the floor and each reports where it measured a person: near a tile
            # border two cameras may report one person; such pairs are fused into their mean
            c = cams[b0:b1]
            diff = z[:, None] - z[None]
            close = ((diff * diff).sum(-1) < dup2) & (c[:, None] != c[None])
            if close.any():
                z = fuse_pairs(z, close)
        nz, A = len(z), len(X)
        matched = np.zeros(nz, bool)
        if A and nz:
            # 1-2. predict from the last update, associate (gated Hungarian on squared distance:
            # the Gaussian log-likelihood up to a constant), Kalman-update the matched tracks
            dt = t - X[:, 7]
            pred = X[:, 0:2] + X[:, 2:4] * dt[:, None]
            diff = pred[:, None, :] - z[None]
            d2 = (diff * diff).sum(-1)
            cost = np.where(d2 <= gate2, d2, 1e12)
            ti, di = linear_sum_assignment(cost)
            ok = cost[ti, di] < 1e12
            ti, di = ti[ok], di[ok]
            Xm = X[ti]
            h = dt[ti]
            Pp0 = Xm[:, 4] + h * (2 * Xm[:, 5] + h * Xm[:, 6]) + q * h**3 / 3
            Pp1 = Xm[:, 5] + h * Xm[:, 6] + q * h**2 / 2
            Pp2 = Xm[:, 6] + q * h
            Kp = Pp0 / (Pp0 + R)
            Kv = Pp1 / (Pp0 + R)
            r = z[di] - pred[ti]
            Xm[:, 0:2] = pred[ti] + Kp[:, None] * r
            Xm[:, 2:4] += Kv[:, None] * r
            Xm[:, 4] = (1 - Kp) * Pp0
            Xm[:, 5] = (1 - Kp) * Pp1
            Xm[:, 6] = Pp2 - Kv * Pp1
            Xm[:, 7] = t
            Xm[:, 8:10] = z[di]
            X[ti] = Xm
            matched[di] = True
        # 3. end tracks missed too long
        cut = pending
        alive = X[:, 7] >= t - cfg.max_missed_s - 1e-9
        if not alive.all():
            cut = cut.copy()
            for a in np.flatnonzero(~alive):
                end_segment(a, "missed", X[a, 7])
                cut |= linked[a] & alive  # a track vanishing next to others: static ambiguity
            keep = np.flatnonzero(alive)
            X, seg, cut, dmin, trk, dpart = X[keep], seg[keep], cut[keep], dmin[keep], trk[keep], dpart[keep]
            linked = linked[np.ix_(keep, keep)]
        # start tracks for unmatched detections
        births: list[int] = []
        n_new = 0
        if not matched.all():
            new_d = np.flatnonzero(~matched)
            n_new = len(new_d)
            if n_new:
                births = [new_segment(k) for _ in new_d]
                Xn = np.zeros((n_new, 10))
                Xn[:, 0:2] = z[new_d]
                Xn[:, 4], Xn[:, 6], Xn[:, 7] = R, cfg.init_speed_sigma**2, t
                Xn[:, 8:10] = z[new_d]
                X = np.concatenate([X, Xn])
                seg = np.concatenate([seg, np.array(births, np.int64)])
                cut = np.concatenate([cut, np.zeros(n_new, bool)])
                dmin = np.concatenate([dmin, np.full(n_new, np.inf)])
                dpart = np.concatenate([dpart, np.full(n_new, -1, np.int64)])
                trk = np.concatenate([trk, n_tracks + np.arange(n_new)])
                n_tracks += n_new
                nl = len(X)
                grown = np.zeros((nl, nl), bool)
                grown[: nl - n_new, : nl - n_new] = linked
                linked = grown
        nl = len(X)
        # 4. proximity relation with hysteresis: link below r_enter, unlink beyond r_exit
        if nl > 1:
            p = X[:, 0:2]
            diff = p[:, None] - p[None]
            d2 = (diff * diff).sum(-1)
            new_linked = np.where(linked, d2 <= exit2, d2 < enter2)
            np.fill_diagonal(new_linked, False)
            np.fill_diagonal(d2, np.inf)
            dnow = np.sqrt(d2.min(axis=1))
            closer = dnow < dmin
            dpart = np.where(closer, trk[d2.argmin(axis=1)], dpart)
            dmin = np.where(closer, dnow, dmin)
            changed = new_linked != linked
            if changed.any():
                if n_new:  # newborn tracks start a fresh segment anyway: only their partners are cut
                    changed[nl - n_new:, nl - n_new:] = False
                cut = cut | changed.any(axis=1)
                if n_new:
                    cut[nl - n_new:] = False
            linked = new_linked
        seen = X[:, 7] == t
        if cut.any():
            pending = cut & ~seen
            for a in np.flatnonzero(cut & seen):
                end_segment(a, "proximity", t)
                old = int(seg[a])
                seg[a] = new_segment(k)
                continues[int(seg[a])] = (old, float(norm.cdf(-dmin[a] / (2.0 * np.sqrt(R)))))
                partner[int(seg[a])] = int(dpart[a])
                dmin[a] = np.inf
                dpart[a] = -1
                births.append(int(seg[a]))
        else:
            pending = np.zeros(nl, bool)
        if births:
            born = np.isin(seg, births)
            link_births(t, [int(s) for s in seg[born]], X[born, 0:2])
            # a segment cut by proximity lives on in the segments born with it (its evidence is
            # carried by them), so it is no candidate for later births
            ended[:] = [e for e in ended if end_reason[e] != "proximity"]
        rows = np.flatnonzero(seen)
        n = len(rows)
        out[n_out:n_out + n] = X[rows][:, [0, 1, 2, 3, 6, 8, 9]]
        out_frame[n_out:n_out + n] = k
        out_seg[n_out:n_out + n] = seg[rows]
        out_trk[n_out:n_out + n] = trk[rows]
        n_out += n

    frames, state, segs, trks = out_frame[:n_out], out[:n_out], out_seg[:n_out], out_trk[:n_out]
    rows = pd.DataFrame({
        "frame": frames, "t": frame_times[frames] if len(frames) else np.zeros(0), "segment": segs, "track": trks,
        "x": state[:, 0], "y": state[:, 1], "vx": state[:, 2], "vy": state[:, 3], "pvv": state[:, 4],
        "zx": state[:, 5], "zy": state[:, 6],
    })
    # the evidence velocity follows the filtered track across cuts (a cut changes who may be who,
    # not the track's motion), so a new segment does not restart from a velocity of zero
    svx, svy, svv = window_velocity(trks, rows["t"].to_numpy(float), state[:, 5], state[:, 6],
                                    cfg.velocity_window_s, cfg.sigma_m, cfg.init_speed_sigma)
    rows["svx"], rows["svy"], rows["svv"] = svx, svy, svv
    # per-segment summary from its rows (the last row is where it was last seen)
    n_seg = len(start_frame)
    last = rows.groupby("segment").tail(1).set_index("segment").reindex(np.arange(n_seg))
    info = pd.DataFrame({
        "start_frame": np.array(start_frame, np.int64), "end_frame": last["frame"].to_numpy(),
        "start_t": frame_times[np.array(start_frame, np.int64)] if n_seg else np.zeros(0),
        "end_t": last["t"].to_numpy(float), "end_x": last["x"].to_numpy(float), "end_y": last["y"].to_numpy(float),
        "end_vx": last["vx"].to_numpy(float), "end_vy": last["vy"].to_numpy(float), "end_reason": end_reason,
    })
    return Segments(rows=rows, info=info, predecessors=predecessors, frame_times=np.asarray(frame_times, float),
                    continues=continues, partner=partner)


def fuse_pairs(z: np.ndarray, close: np.ndarray) -> np.ndarray:
    """Replace each pair (i, j) flagged in the symmetric boolean matrix ``close`` by its mean,
    closest pairs first, each detection in at most one pair; returns the fused detections."""
    i, j = np.nonzero(np.triu(close, 1))
    d2 = ((z[i] - z[j]) ** 2).sum(-1)
    used = np.zeros(len(z), bool)
    keep = np.ones(len(z), bool)
    z = z.copy()
    for a, b in zip(i[np.argsort(d2, kind="stable")], j[np.argsort(d2, kind="stable")]):
        if not (used[a] or used[b]):
            used[a] = used[b] = True
            z[a] = 0.5 * (z[a] + z[b])
            keep[b] = False
    return z[keep]


def window_velocity(segment: np.ndarray, t: np.ndarray, x: np.ndarray, y: np.ndarray, window_s: float,
                    sigma: float, prior_sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Causal least-squares velocity of each row's segment over its detections in (t - W, t].

    With n samples (t_j, z_j) of one segment in the window, the slope is
        v = (n S_tz - S_t S_z) / D,   D = n S_tt - S_t^2,   Var(v) = sigma^2 n / D   (m/s, m^2/s^2)
    per axis. Sums come from per-segment cumulative sums, so there is no Python loop over rows.
    Rows with fewer than 2 samples get v = 0 and the prior variance prior_sigma^2.
    """
    n_rows = len(t)
    if n_rows == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    order = np.lexsort((t, segment))
    sg, ts, xs, ys = segment[order], t[order], x[order], y[order]
    t0 = ts[np.searchsorted(sg, sg, side="left")]  # segment start time: conditioning
    tr = ts - t0
    # one sorted key per (segment, time): segments spaced far apart on the time axis
    span = float(tr.max()) + window_s + 1.0
    key = sg * span + tr
    cols = np.stack([np.ones(n_rows), tr, tr * tr, xs, tr * xs, ys, tr * ys], axis=1)
    c = np.concatenate([np.zeros((1, 7)), np.cumsum(cols, axis=0)])
    hi = np.arange(1, n_rows + 1)
    lo = np.searchsorted(key, key - window_s + 1e-9, side="right")
    s = c[hi] - c[lo]
    n, st, stt, sx, stx, sy, sty = s.T
    D = n * stt - st**2
    ok = (n >= 2) & (D > 1e-12)
    Dsafe = np.where(ok, D, 1.0)
    vx = np.where(ok, (n * stx - st * sx) / Dsafe, 0.0)
    vy = np.where(ok, (n * sty - st * sy) / Dsafe, 0.0)
    var = np.where(ok, max(sigma, 1e-3) ** 2 * n / Dsafe, prior_sigma**2)
    out = np.empty((3, n_rows))
    out[:, order] = np.stack([vx, vy, var])
    return out[0], out[1], out[2]
