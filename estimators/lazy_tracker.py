"""Lazy tracker: anonymous floor detections -> piecewise-unambiguous track segments (Teixeira eq. 9).

Each camera frame k the tracker

1. predicts every live track with a constant-velocity Kalman filter (per axis, state [p, v]):
       F = [[1, dt], [0, 1]],  Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]],  H = [1, 0],  R = sigma^2,
   vectorised over tracks (the covariance is the same for x and y, so 3 numbers per track);
2. associates predicted positions to the frame's detections by ``linear_sum_assignment`` on the
   Euclidean distance, with a gate ``gate_m`` (m); unmatched detections start new tracks;
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

gap = t_n - t_e (s). The matcher uses them to carry identity evidence across breaks.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

SEGMENT_COLUMNS = ["frame", "t", "segment", "x", "y", "vx", "vy", "pvv", "zx", "zy", "svx", "svy", "svv"]


@dataclass(frozen=True)
class TrackerConfig:
    """Lazy-tracker parameters (metres, seconds)."""

    sigma_m: float = 0.15  # detection noise per axis, m (from the calibration)
    q: float = 2.0  # white-acceleration spectral density, m^2/s^3
    init_speed_sigma: float = 1.0  # prior std of a new track's velocity, m/s
    gate_m: float = 1.0  # association gate, m
    max_missed_s: float = 0.3  # a track missed longer than this ends, s
    r_enter: float = 0.6  # proximity radius that starts an ambiguity, m
    r_exit: float = 0.8  # radius beyond which the ambiguity ends (hysteresis), m
    velocity_window_s: float = 1.0  # window of the least-squares velocity used as evidence, s
    carry_s: float = 15.0  # how long an ended segment stays a candidate predecessor, s
    coast_s: float = 1.0  # longest constant-velocity extrapolation of an ended segment, s
    sigma_birth: float = 0.3  # continuity std at zero gap, m
    speed_max: float = 1.0  # growth of the continuity std with the gap, m/s

    def __post_init__(self):
        if not self.r_exit >= self.r_enter > 0:
            raise ValueError(f"need r_exit >= r_enter > 0 (got r_enter={self.r_enter}, r_exit={self.r_exit})")
        if self.gate_m <= 0 or self.max_missed_s < 0 or self.sigma_m < 0:
            raise ValueError("gate_m must be > 0, max_missed_s and sigma_m >= 0")


@dataclass
class Segments:
    """The tracker's output.

    rows: one row per (frame, segment) with a detection: ``frame, t, segment`` and the filtered
    state ``x, y, vx, vy`` (m, m/s), the velocity variance ``pvv`` (m^2/s^2, per axis), the raw
    detection ``zx, zy`` and the smoothed velocity ``svx, svy`` with its variance ``svv`` (see
    ``window_velocity``); sorted by frame.
    info: per segment: ``start_frame, end_frame, start_t, end_t, end_x, end_y, end_vx, end_vy``,
    ``end_reason`` (proximity, missed, static, end).
    predecessors: per new segment, a list of (ended segment, continuity weight density in 1/m^2).
    frame_times: (F,) time of every camera frame (s).
    """

    rows: pd.DataFrame
    info: pd.DataFrame
    predecessors: dict[int, list[tuple[int, float]]] = field(default_factory=dict)
    frame_times: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n_segments(self) -> int:
        return len(self.info)


def frames_from_detections(det: pd.DataFrame, fps: float, duration: float | None = None):
    """Group detections into camera frames: frame index k = round(t fps). Returns (frame_times,
    frame index per row, x, y) with rows sorted by frame."""
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
    )


def track_segments(frame_times: np.ndarray, frame_idx: np.ndarray, x: np.ndarray, y: np.ndarray,
                   cfg: TrackerConfig = TrackerConfig()) -> Segments:
    """Run the lazy tracker over detections grouped by frame (see module docstring)."""
    F = len(frame_times)
    bounds = np.searchsorted(frame_idx, np.arange(F + 1))
    R = max(cfg.sigma_m, 0.02) ** 2  # an ideal camera still gets a small floor, for stable gains
    q = cfg.q

    # live track arrays
    pos = np.zeros((0, 2)); vel = np.zeros((0, 2)); P = np.zeros((0, 3))  # P = [ppp, ppv, pvv]
    last_t = np.zeros(0); seg = np.zeros(0, np.int64)
    pending = np.zeros(0, bool)  # a cut decided while the track was not seen, applied when it is
    linked = np.zeros((0, 0), bool)

    out_frame, out_seg, out_state, out_z = [], [], [], []
    info: list[dict] = []
    predecessors: dict[int, list[tuple[int, float]]] = {}
    ended: list[int] = []  # ended segments still eligible as predecessors

    def new_segment(k: int) -> int:
        info.append(dict(start_frame=k, end_frame=k, start_t=frame_times[k], end_t=frame_times[k],
                         end_x=np.nan, end_y=np.nan, end_vx=0.0, end_vy=0.0, end_reason="end"))
        return len(info) - 1

    def end_segment(s: int, reason: str) -> None:
        info[s]["end_reason"] = reason
        ended.append(s)

    def link_births(k: int, births: list[int], births_xy: np.ndarray) -> None:
        t = frame_times[k]
        keep = []
        for e in ended:
            if t - info[e]["end_t"] <= cfg.carry_s:
                keep.append(e)
        ended[:] = keep
        if not keep or not births:
            return
        e_arr = np.array(keep)
        ex = np.array([[info[e]["end_x"], info[e]["end_y"]] for e in keep])
        ev = np.array([[info[e]["end_vx"], info[e]["end_vy"]] for e in keep])
        gap = t - np.array([info[e]["end_t"] for e in keep])
        pred = ex + ev * np.minimum(gap, cfg.coast_s)[:, None]
        sd = cfg.sigma_birth + cfg.speed_max * gap
        d2 = ((births_xy[:, None, :] - pred[None]) ** 2).sum(-1)
        dens = np.exp(-0.5 * d2 / sd**2) / (2 * np.pi * sd**2)
        for b, n in enumerate(births):
            near = dens[b] > 1e-6 * dens[b].max() if dens[b].max() > 0 else np.zeros(len(keep), bool)
            near &= d2[b] <= (4 * sd) ** 2
            if near.any():
                predecessors[n] = [(int(e), float(w)) for e, w in zip(e_arr[near], dens[b][near])]

    for k in range(F):
        t = frame_times[k]
        z = np.stack([x[bounds[k]:bounds[k + 1]], y[bounds[k]:bounds[k + 1]]], axis=1)
        A = len(pos)
        # 1. predict
        dt = t - last_t
        ppp, ppv, pvv = P[:, 0], P[:, 1], P[:, 2]
        Pp = np.stack([ppp + 2 * dt * ppv + dt**2 * pvv + q * dt**3 / 3, ppv + dt * pvv + q * dt**2 / 2, pvv + q * dt], axis=1)
        pred = pos + vel * dt[:, None]
        # 2. associate
        ti = np.zeros(0, np.int64); di = np.zeros(0, np.int64)
        if A and len(z):
            d = np.sqrt(((pred[:, None, :] - z[None]) ** 2).sum(-1))
            cost = np.where(d <= cfg.gate_m, d, 1e6)
            ti, di = linear_sum_assignment(cost)
            ok = cost[ti, di] < 1e6
            ti, di = ti[ok], di[ok]
        # update matched tracks
        if len(ti):
            S = Pp[ti, 0] + R
            Kp, Kv = Pp[ti, 0] / S, Pp[ti, 1] / S
            r = z[di] - pred[ti]
            pos[ti] = pred[ti] + Kp[:, None] * r
            vel[ti] = vel[ti] + Kv[:, None] * r
            P[ti] = np.stack([(1 - Kp) * Pp[ti, 0], (1 - Kp) * Pp[ti, 1], Pp[ti, 2] - Kv * Pp[ti, 1]], axis=1)
            last_t[ti] = t
        # 3. end tracks missed too long
        alive = t - last_t <= cfg.max_missed_s + 1e-9
        cut = pending.copy()
        for a in np.flatnonzero(~alive):
            end_segment(int(seg[a]), "missed")
            # a track vanishing next to others leaves a static ambiguity: cut its partners
            cut |= linked[a] & alive
        # start tracks for unmatched detections
        new_d = np.setdiff1d(np.arange(len(z)), di)
        keep = np.flatnonzero(alive)
        pos = np.concatenate([pos[keep], z[new_d]])
        vel = np.concatenate([vel[keep], np.zeros((len(new_d), 2))])
        P = np.concatenate([P[keep], np.tile([R, 0.0, cfg.init_speed_sigma**2], (len(new_d), 1))])
        last_t = np.concatenate([last_t[keep], np.full(len(new_d), t)])
        cut = np.concatenate([cut[keep], np.zeros(len(new_d), bool)])
        births = [new_segment(k) for _ in new_d]
        seg = np.concatenate([seg[keep], np.array(births, np.int64)])
        nl = len(pos)
        old_linked = np.zeros((nl, nl), bool)
        old_linked[: len(keep), : len(keep)] = linked[np.ix_(keep, keep)]
        # 4. proximity relation with hysteresis
        if nl > 1:
            dd = np.sqrt(((pos[:, None] - pos[None]) ** 2).sum(-1))
            np.fill_diagonal(dd, np.inf)
            new_linked = np.where(old_linked, dd <= cfg.r_exit, dd < cfg.r_enter)
            fresh = np.zeros(nl, bool)
            fresh[nl - len(new_d):] = True
            # a pair involving a newborn track was never "unlinked": only its partner is cut
            changed = (new_linked != old_linked)
            changed[np.ix_(fresh, fresh)] = False
            cut |= changed.any(axis=1)
            cut[fresh] = False
            linked = new_linked
        else:
            linked = np.zeros((nl, nl), bool)
        seen = last_t == t
        pending = cut & ~seen
        for a in np.flatnonzero(cut & seen):
            end_segment(int(seg[a]), "proximity")
            s = new_segment(k)
            seg[a] = s
            births.append(s)
        # the continuity of each new segment with the ones that ended before it
        born = np.isin(seg, births)
        link_births(k, [int(s) for s in seg[born]], pos[born])
        # a segment cut by proximity lives on in the segments born with it: its evidence is
        # carried by them, so it is no candidate for later births
        ended[:] = [e for e in ended if info[e]["end_reason"] != "proximity"]
        # record this frame's rows (tracks that got a detection)
        rows = np.flatnonzero(seen)
        zi = np.full((nl, 2), np.nan)
        if len(ti):
            mapping = {int(a): int(b) for a, b in zip(ti, di)}
            old_index = {int(old): new for new, old in enumerate(keep)}
            for a_old, dj in mapping.items():
                if a_old in old_index:
                    zi[old_index[a_old]] = z[dj]
        zi[nl - len(new_d):] = z[new_d]
        for a in rows:
            s = info[int(seg[a])]
            s["end_frame"] = k
            s["end_t"] = t
            s["end_x"], s["end_y"] = pos[a]
            s["end_vx"], s["end_vy"] = vel[a]
        out_frame.append(np.full(len(rows), k))
        out_seg.append(seg[rows].copy())
        out_state.append(np.concatenate([pos[rows], vel[rows], P[rows, 2:3]], axis=1))
        out_z.append(zi[rows])

    for a in range(len(pos)):
        info[int(seg[a])]["end_reason"] = "end"
    frames = np.concatenate(out_frame) if out_frame else np.zeros(0, np.int64)
    state = np.concatenate(out_state) if out_state else np.zeros((0, 5))
    zs = np.concatenate(out_z) if out_z else np.zeros((0, 2))
    rows = pd.DataFrame({
        "frame": frames.astype(np.int64), "t": frame_times[frames] if len(frames) else np.zeros(0),
        "segment": (np.concatenate(out_seg) if out_seg else np.zeros(0)).astype(np.int64),
        "x": state[:, 0], "y": state[:, 1], "vx": state[:, 2], "vy": state[:, 3], "pvv": state[:, 4],
        "zx": zs[:, 0], "zy": zs[:, 1],
    })
    svx, svy, svv = window_velocity(rows["segment"].to_numpy(), rows["t"].to_numpy(float), rows["zx"].to_numpy(float),
                                    rows["zy"].to_numpy(float), cfg.velocity_window_s, cfg.sigma_m, cfg.init_speed_sigma)
    rows["svx"], rows["svy"], rows["svv"] = svx, svy, svv
    info_df = pd.DataFrame(info, columns=["start_frame", "end_frame", "start_t", "end_t", "end_x", "end_y", "end_vx", "end_vy", "end_reason"])
    return Segments(rows=rows, info=info_df, predecessors=predecessors, frame_times=np.asarray(frame_times, float))


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
