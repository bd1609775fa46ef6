"""Flow windows' region flow against the true image velocity, by image speed.

    python scripts/measure_flow_errors.py DIR [DIR ...] [--flow-window N] [--by-share] [--widths] [--merged-widths] [--fragments] [--border] [--below] [--centroid]   # occlusion_lab recordings, either mode

For every window of the ``boxes`` table that holds exactly one walking mover (the scene's target
or distractor, speed over 0.5 m/s: the window covers 30 % of the width of that person's projected
cylinder, 1.8 m by 0.2 m, and of no other person's, standing or not, hidden or not), the
window's flow against the image velocity of that person's body centre (0.85 m above the floor,
``tp_geometry.flow_jacobian`` times the true velocity, eq. 7). Errors are split along the true image
motion (negative: the flow is short of it) and across it, per bin of true image speed, with their
median, robust standard deviation (1.4826 MAD), the robust one relative to the speed, and the
90 % quantile of their size; and the detector's gain, the median of the flow along the motion
over the true image speed (10-120 px/s: ``target_planes``' ``flow_gain``, issue 12's
twenty-first session). Run it on rendered recordings to see how the flow detector's error
grows with the image speed, and on their analytic twins to compare. The truth is read here, by the experimenter.

``--flow-window N``: each window's flow is first averaged over the last N frames of its camera
track, as ``target_planes`` does (``flow_window``, default 1: the detector's own flows).

By the window's share of the person's width (``--by-share``; added in issue 12's fifteenth
session): the window's width over the width of that person's projected cylinder (windows
narrower than the person are fragments of its flow region: a limb, the part out of an
obstacle's shadow), the errors of ``flow_u`` and ``flow_v`` (image axes) per share bin, windows
of people whose projected cylinder crosses the left or right image border left out (their
window is the part inside the image). On rendered development recordings 100-119 a fragment's
horizontal flow error is about as large as the image speed itself (below half the width: 90 %
quantile 30-60 px/s against 4 px/s for whole windows), its vertical flow error does not grow;
the analytic windows model draws fragments moving with their person's flow, so its errors do not
depend on the share (docs/target_planes.md, "Five single changes measured").

Fragments (``--fragments``; issue 12's twenty-ninth session): ``--by-share`` needs a window to
cover 30 % of its person's width, so it counts no window narrower than that. With
``--fragments`` a window holds a person once it covers 30 % of the narrower of the two (window and
person), and the table by share starts at 0 in finer bins, with each bin's rms horizontal flow
error and the share of errors over 25 px/s: ``target_planes``' ``fragment_flow_sigma`` is
sqrt(rms(share < 0.5)^2 - rms(0.85-1.15)^2). Rendered development 100-119, flow over 5 frames:
rms 30.5 / 29.2 / 30.0 px/s at shares 0-0.15 / 0.15-0.3 / 0.3-0.5, 16.6 at 0.5-0.7, 11.5 at
0.85-1.15 (28 px/s).

By the image border (``--border``; issue 12's forty-second session): the table by image speed
again, for windows of people whose projected cylinder the left or right image border cuts and for
the rest, with the share of windows whose flow error is larger than the true image speed and the
gain of each (with ``--flow-window 5``, the tracker's mean flow: 0.739 cut and 0.878 uncut
rendered, 0.826 and 0.868 analytic).
Rendered development 100-119: the border-cut windows fall further short along the motion (median
-3.9 px/s at 10-20 px/s and -47.8 above 80, against -1.5 and -13.3 uncut), and 1.2 % of them err
by more than the image speed (uncut 0.4 %). Their analytic twins (tenth fit, draw 0): -2.8 and
-24.4 cut, -2.0 and -13.8 uncut, and 5.2 % / 4.3 % err by more than the speed: the analytic
flows' errors are wider at low image speeds whether cut or not (robust sd along the motion at
5-20 px/s 4.0-4.2 px/s uncut against 2.3 rendered), and the rendered detector's larger shortfall
on cut windows is not modelled. Since issue 12's forty-fourth session it also prints how much more a
cut window's flow errs than an uncut one's, as a share of the image speed (``cut_excess``: the
spread and the shortfall, windows at 20+ px/s): rendered development 100-119 0.247 along the
motion and 0.120 across, analytic 0.164 and 0.048 (docs/target_planes.md, "A window cut by the
image border: its flow's noise measured").

The centroid column (``--centroid``; issue 12's fifty-sixth session): for windows of one person
seen whole across the image, the region's centroid column against the projection of the body
centre's and of the visible part's centre (half-way up the part of the axis inside the image's
rows, ``visible_centre_z``): a corner camera sees a person 1-3 m away with the feet below its
image, and the projected axis slants, so the two differ by up to 14 px. Rendered development
100-119: feet below the image, rms 4.86 px against the body centre and 3.31 against the visible
part (median 2.80 and 1.31); where the two differ by more than 5 px, 7.33 and 1.61; feet in the
image 2.06 and 1.94 (0.85 m against 0.9 m). Analytic twins: 4.52 and 3.54; 7.69 and 5.43.

How often a window is much wider than its one person (``--widths``; issue 12's twenty-second
session): the share of windows wider than 1.2 ... 2 times the person's projected width, and the
fit of ``target_planes``' gross width errors (``width_tail``, ``width_tail_sigma``: one edge
moved outwards by a half-normal, ``width_tail``). Rendered development 100-119: 1.14 % wider
than 1.33 times the person, 0.34 % than 1.5, 0.09 % than 1.75; analytic 100-109: 3.8 % wider
than 1.5 (the analytic windows' edge errors have heavier tails). ``--merged-widths`` (issue 12's
sixty-first session) fits the same tail to walkers' windows that hold others too: rendered
development 100-119, 0.027 and 0.36 with people who never walk (a flow window holds moving
pixels), 0.19 and 0.75 with two walkers merged.

Then how the errors persist: the autocorrelation, over consecutive frames of one camera track
holding the same person, of the flow error along the motion and across it and of the window centroid's error (its
column minus the projected body centre's), and their integrated autocorrelation time
tau = 1 + 2 sum_L rho(L) (frames; the sum up to the first lag whose rho is not positive): a
Kalman filter that takes one such measurement a frame as independent has taken about tau
frames' worth of error as independent ones, and should multiply its variance by tau. And the fit
of rho(L) = w a^L over lags 1-10: an error that is a persistent part (share w of its variance,
Gauss-Markov of correlation time -1 / (fps ln a) s) plus a part new each frame. (Both were
tried as ``target_planes`` options in the experiment commit f93ffae and not kept:
docs/target_planes.md, "Is the track consistent?"; the first again in issue 12's fifty-second
session, not kept either.) With ``--flow-window 5`` (the flows ``target_planes`` takes:
each the mean over its camera track's last five frames) the gain is the one the tracker meets:
rendered development 100-119 0.851 (one frame: 0.924; the mean takes in the detector's short
runs of failed flows, which the one-frame median leaves out), their analytic twins 0.862 (0.907);
tau along the motion 9.8 and 11.1 frames, across it 6.4 (rendered). Last, the
episodes of flows far short of the motion (more than half of it, above 30 px/s): their share and
how long they last (the rendered detector's come in runs; ``perception_fit.fit_flow_persist``).
"""
import argparse

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from trackroom.dataset import read_recording, recording_folders
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators.target_planes import TargetPlanes
from trackroom.estimators.tp_frames import mean_flows
from trackroom.metrics.aggregate import robust_sigma
from trackroom.sim.perception_fit import lagged_products

MOVERS = ("target", "distractor")
CENTRE_Z = 0.85
HEIGHT, RADIUS = TargetPlanes.Config.height, TargetPlanes.Config.radius  # the tracker's person model, m
SPEED_BINS = (5, 10, 20, 30, 40, 60, 80, 1000)  # px/s
MAX_LAG = 30  # frames


def visible_centre_z(P: np.ndarray, xy, image_height: float, height: float = HEIGHT) -> float:
    """Height (m) half-way up the part of a person's vertical axis at floor point xy that lies in
    the image's rows (0 to ``image_height``): ``height`` / 2 for a person seen whole; higher for one
    whose feet are below the image (the window holds the upper body), lower for one whose head is
    above it. The image of the axis is a line, so each end is cut exactly where the axis crosses
    the first or last row."""
    A = P @ np.array([xy[0], xy[1], 0.0, 1.0])  # the axis point at height z: A + z P[:, 2] (homogeneous)
    B = P[:, 2]
    if A[2] <= 1e-9 or A[2] + height * B[2] <= 1e-9:
        return 0.5 * height  # behind the camera

    def row(z: float) -> float:
        return (A[1] + z * B[1]) / (A[2] + z * B[2])

    def height_at(v: float) -> float:  # the axis's height at image row v (NaN: the axis runs along that row)
        den = B[1] - v * B[2]
        return (v * A[2] - A[1]) / den if abs(den) >= 1e-12 else float("nan")

    lo = height_at(image_height) if row(0.0) > image_height else 0.0  # the feet below the image
    hi = height_at(0.0) if row(height) < 0.0 else height  # the head above it
    lo, hi = max(lo, 0.0), min(hi, height)
    return 0.5 * (lo + hi) if hi > lo else 0.5 * height


def held_by(spans: np.ndarray, u_left: float, u_right: float, narrow: bool = False) -> np.ndarray:
    """Which people (``spans``: (P, 2) their projected columns) a window [u_left, u_right] holds:
    it covers 30 % of their projected width (``narrow``: of the narrower of window and person, so
    a narrow window holds a person it lies on, however small a part of the person)."""
    overlap = np.clip(np.minimum(spans[:, 1], u_right) - np.maximum(spans[:, 0], u_left), 0.0, None)
    covered = np.maximum(spans[:, 1] - spans[:, 0], 1.0)
    if narrow:
        covered = np.minimum(covered, max(u_right - u_left, 1.0))
    return overlap > 0.3 * covered


def errors(d, flow_window: int = 1, fragments: bool = False) -> pd.DataFrame:
    rec = read_recording(d)
    people = rec.truth.people
    Ps = {c: np.asarray(cam.P, float) for c, cam in rec.calibration.cameras_of_kind("oblique").items()}
    fps = {c: float(rec.calibration.cameras[c].fps) for c in Ps}
    widths = {c: float(rec.calibration.cameras[c].width) for c in Ps}
    heights = {c: float(rec.calibration.cameras[c].height) for c in Ps}
    boxes = mean_flows(rec.observations["boxes"].sort_values("t", kind="stable"), flow_window)
    at = {t: g for t, g in people.groupby(people.t.round(2))}
    rows = []
    for b in boxes[boxes.camera.isin(list(Ps))].itertuples():
        t = round(b.t, 2)
        g = at.get(t)
        if g is None:
            continue
        wins = np.array([geo.cylinder_window(Ps[b.camera], np.array([x, y]), HEIGHT, RADIUS) for x, y in zip(g.x, g.y)])
        spans, spans_v = wins[:, :2], wins[:, 3]  # columns; bottom row (the feet)
        holds = held_by(spans, float(b.u_left), float(b.u_right), narrow=fragments)
        if holds.sum() != 1:
            continue
        k = int(np.argmax(holds))
        pid = g.person_id.to_numpy()[k]
        if pid not in MOVERS:
            continue
        x, y, vx, vy = (float(g[c].to_numpy()[k]) for c in ("x", "y", "vx", "vy"))
        if np.hypot(vx, vy) < 0.5:
            continue
        X = np.array([x, y, CENTRE_Z])
        f = geo.flow_jacobian(Ps[b.camera], X) @ np.array([vx, vy, 0.0])  # eq. 7
        speed = float(np.hypot(*f))
        if speed <= 0.0:
            continue
        e = np.array([b.flow_u, b.flow_v]) - f
        along = float(e @ f) / speed
        across = float(e[1] * f[0] - e[0] * f[1]) / speed
        du = float(b.u) - float(geo.project(Ps[b.camera], X)[0][0])
        X_vis = np.array([x, y, visible_centre_z(Ps[b.camera], (x, y), heights[b.camera])])
        du_vis = float(b.u) - float(geo.project(Ps[b.camera], X_vis)[0][0])
        lo, hi = spans[k]
        share = (float(b.u_right) - float(b.u_left)) / max(float(hi - lo), 1.0)
        border = bool(lo < 0.0 or hi > widths[b.camera])
        below = bool(spans_v[k] > heights[b.camera])
        rows.append((str(d), t, int(round(t * fps[b.camera])), b.camera, b.track, pid, speed, along, across, du, e[0], e[1], share, border,
                     below, du_vis))
    return pd.DataFrame(rows, columns=["rec", "t", "frame", "camera", "track", "pid", "speed", "along", "across", "du",
                                       "e_u", "e_v", "share", "border", "below", "du_vis"])


def centroid_table(df: pd.DataFrame, shift_px: float = 5.0) -> pd.DataFrame:
    """The centroid column's error (px) against the body centre's projection (``du``) and against
    the visible part's centre's (``du_vis``), for windows of a person seen whole across the image
    (not cut left or right, at least half the person's width): rms and median size, by ``below``,
    and for the windows where the two predictions differ by more than ``shift_px``."""
    g = df[~df["border"].astype(bool) & (df["share"] >= 0.5)]
    shift = (g["du"] - g["du_vis"]).abs()
    out = []
    for name, h in (("feet in the image", g[~g["below"].astype(bool)]), ("feet below the image", g[g["below"].astype(bool)]),
                    (f"the two {shift_px:g}+ px apart", g[shift > shift_px])):
        # (an empty group's mean and median are NaN)
        out.append({"windows": name, "n": len(h), "rms_body_centre": float(np.sqrt((h["du"] ** 2).mean())),
                    "rms_visible_centre": float(np.sqrt((h["du_vis"] ** 2).mean())),
                    "median_body_centre": float(h["du"].abs().median()), "median_visible_centre": float(h["du_vis"].abs().median())})
    return pd.DataFrame(out)


def autocorrelation(df: pd.DataFrame, col: str, max_lag: int = MAX_LAG) -> np.ndarray:
    """rho(L), L = 0..max_lag, of column ``col`` over pairs of rows L frames apart in one camera
    track holding the same person (the column's mean over all rows removed)."""
    x = df[col].to_numpy(float) - df[col].mean()
    key = df[["rec", "camera", "track", "pid"]].astype(str).agg("|".join, axis=1).to_numpy()
    return lagged_products(key, df["frame"].to_numpy(), x, max_lag, 10) / np.mean(x**2)


def corr_time(rho: np.ndarray) -> float:
    """1 + 2 sum_L rho(L), up to the first lag whose rho is not positive."""
    tail = rho[1:]
    stop = np.flatnonzero(~(tail > 0.0))
    return float(1.0 + 2.0 * tail[: stop[0] if len(stop) else len(tail)].sum())


def table(df: pd.DataFrame) -> pd.DataFrame:
    out = []
    for lo, hi in zip(SPEED_BINS[:-1], SPEED_BINS[1:]):
        g = df[(df.speed > lo) & (df.speed <= hi)]
        if not len(g):
            continue
        out.append({"speed px/s": f"{lo}-{hi}", "n": len(g),
                    "along median": g.along.median(), "along rsd": robust_sigma(g.along), "along q90": g.along.abs().quantile(0.9),
                    "across rsd": robust_sigma(g.across), "across q90": g.across.abs().quantile(0.9),
                    "along rsd / speed": robust_sigma(g.along / g.speed), "across rsd / speed": robust_sigma(g.across / g.speed)})
    return pd.DataFrame(out)


SHARE_BINS = (0.0, 0.3, 0.5, 0.7, 0.85, 1.15, 1.5, 10.0)  # window width / the person's projected width
FRAGMENT_BINS = (0.0, 0.15, 0.3, 0.5, 0.7, 0.85, 1.15, 1.5, 10.0)  # the same, with --fragments
BIG_ERROR = 25.0  # px/s: a flow error this large is about the image speed of a walker at 3-4 m


def share_table(df: pd.DataFrame, bins=SHARE_BINS) -> pd.DataFrame:
    """The flow error in image axes (``e_u``, ``e_v``, px/s) per bin of the window's share of its
    person's projected width (``bins``: ``SHARE_BINS``, or ``FRAGMENT_BINS`` with --fragments),
    windows of people cut by the image border left out: count, robust standard deviation, 90 %
    quantile of the size, the 90 % quantile of |e_u| relative to the true image speed, the rms of
    e_u and the share of errors (both axes) larger than ``BIG_ERROR``."""
    g0 = df[~df["border"].astype(bool)]
    out = []
    for lo, hi in zip(bins[:-1], bins[1:]):
        g = g0[(g0.share > lo) & (g0.share <= hi)]
        if not len(g):
            continue
        out.append({"share": f"{lo:g}-{hi:g}", "n": len(g), "flow_u rsd": robust_sigma(g.e_u), "flow_u q90": g.e_u.abs().quantile(0.9),
                    "flow_v rsd": robust_sigma(g.e_v), "flow_v q90": g.e_v.abs().quantile(0.9),
                    "flow_u q90 / speed": (g.e_u.abs() / g.speed).quantile(0.9),
                    "flow_u rms": float(np.sqrt((g.e_u**2).mean())), f"|e| > {BIG_ERROR:g}": float((np.hypot(g.e_u, g.e_v) > BIG_ERROR).mean())})
    return pd.DataFrame(out)


def over_speed_share(df: pd.DataFrame) -> float:
    """The share of windows whose flow error is larger than the true image speed itself
    (``--border``, for windows of people cut by the image border and for the rest)."""
    return float((np.hypot(df.e_u, df.e_v) > df.speed).mean()) if len(df) else float("nan")


CUT_MIN_SPEED = 20.0  # px/s: slower, a cut window falls short of the motion within about 1 px/s of an uncut one (the --border tables)


def cut_excess(df: pd.DataFrame, min_speed: float = CUT_MIN_SPEED, col: str = "border") -> tuple[float, float]:
    """How much more a border-cut window's flow errs than an uncut one's, as a share of the true
    image speed (a flow noise for cut windows, along and across the motion): over windows at
    ``min_speed`` px/s or more, sqrt(rsd_cut^2 - rsd_uncut^2 + (median_cut - median_uncut)^2) of
    the error over the speed, along the motion and across it (the spread and the shortfall both,
    a robust sd ``rsd``); NaN without windows of both kinds. ``col``: the column that says a
    window is cut (``border``: by the left or right border; ``below``: the person reaches below
    the image, ``--below``)."""
    g = df[df.speed >= min_speed]
    cut = g[col].astype(bool)
    if not cut.any() or cut.all():
        return float("nan"), float("nan")
    out = []
    for col in ("along", "across"):
        rc, ru = g.loc[cut, col] / g.loc[cut, "speed"], g.loc[~cut, col] / g.loc[~cut, "speed"]
        out.append(float(np.sqrt(max(robust_sigma(rc) ** 2 - robust_sigma(ru) ** 2, 0.0) + (rc.median() - ru.median()) ** 2)))
    return out[0], out[1]


def short_runs(df: pd.DataFrame, min_speed: float = 30.0, frac: float = 0.5) -> tuple[int, float, float, int]:
    """Episodes of a flow far short of the motion: among windows of true image speed over
    ``min_speed`` px/s, those whose flow falls more than ``frac`` of the speed short; returns
    (windows, their share, the mean run of consecutive such frames in one camera track of one
    person, runs of 5 frames or more)."""
    fast = df[df.speed > min_speed].sort_values(["rec", "camera", "track", "pid", "frame"])
    if not len(fast):
        return 0, 0.0, 0.0, 0
    short = (fast.along < -frac * fast.speed).to_numpy()
    key = fast[["rec", "camera", "track", "pid"]].astype(str).agg("|".join, axis=1).to_numpy()
    frame = fast["frame"].to_numpy()
    runs, cur = [], 0
    for i in range(len(fast)):
        follows = i > 0 and key[i] == key[i - 1] and frame[i] == frame[i - 1] + 1
        if short[i]:
            cur = cur + 1 if follows and cur else 1
            if i + 1 == len(fast) or not short[i + 1] or key[i + 1] != key[i] or frame[i + 1] != frame[i] + 1:
                runs.append(cur)
                cur = 0
    runs = np.asarray(runs, float)
    return len(fast), float(short.mean()), float(runs.mean()) if len(runs) else 0.0, int((runs >= 5).sum())


def persistent_fit(rho: np.ndarray, lags: int = 10) -> tuple[float, float]:
    """(w, a) of rho(L) = w a^L, least squares over L = 1..lags."""
    L = np.arange(1, lags + 1)
    y = rho[1 : lags + 1]
    ok = np.isfinite(y)
    (w, a), _ = curve_fit(lambda x, w, a: w * a**x, L[ok], y[ok], p0=(0.5, 0.8), bounds=([0.0, 0.0], [1.0, 0.999]))
    return float(w), float(a)


def gain(df: pd.DataFrame, lo: float = 10.0, hi: float = 120.0) -> float:
    """The flow detector's gain: the median over windows of the flow along the true image motion
    over the true image speed, image speeds ``lo``-``hi`` px/s (``target_planes``'
    ``flow_gain``: eq. 7 as f = flow_gain J V)."""
    g = df[(df.speed >= lo) & (df.speed < hi)]
    return float(((g.speed + g.along) / g.speed).median()) if len(g) else float("nan")


WIDTH_LEVELS = (1.2, 1.33, 1.5, 1.75, 2.0)  # window width / the person's projected width
TAIL_FIT_LEVELS = (1.33, 1.5, 1.75)  # beyond the Gaussian core (about 3 sigma of a tenth of the width)


def width_tail(share: pd.Series, levels=TAIL_FIT_LEVELS) -> tuple[float, float]:
    """``target_planes``' ``width_tail`` and ``width_tail_sigma`` from windows' width over their
    person's projected width (``share``; people cut by the image border left out): a gross width
    error occurs with probability e and moves one edge outwards by a half-normal of spread sigma
    (a share of the width), so P(share > 1 + x) = 2 e (1 - Phi(x / sigma)) beyond the core. Least
    squares on the log of the measured tail fractions at ``levels``, sigma on a 0.01 grid."""
    from scipy.stats import norm

    share = share.dropna()
    frac = np.array([(share > a).mean() for a in levels])
    if not len(share) or (frac <= 0).any():
        return float("nan"), float("nan")
    x = np.asarray(levels) - 1.0
    best = None
    for sigma in np.arange(0.05, 1.0001, 0.01):
        model = 2.0 * norm.sf(x / sigma)
        log_e = float(np.mean(np.log(frac) - np.log(model)))
        err = float(np.sum((np.log(frac) - np.log(model) - log_e) ** 2))
        if best is None or err < best[0]:
            best = (err, float(np.exp(log_e)), float(sigma))
    return best[1], best[2]


def walker_shares(people: pd.DataFrame, windows: pd.DataFrame, Ps: dict, widths: dict) -> pd.DataFrame:
    """Each walker's share of the windows holding them (``--merged-widths``): for every window of
    ``windows`` (boxes rows: t, camera, u_left, u_right) holding one or two walking movers
    (>= 0.5 m/s; a person is held when the window covers 30 % of their projected width) and any
    number of other people, one row per walker not cut by the image border: the window's width
    over that walker's projected width, the walkers held, whether someone who never walks (not a
    mover: a standing extra) is held too and whether a mover below walking speed is. ``Ps``:
    camera -> P; ``widths``: camera -> image width."""
    at = {t: g for t, g in people.groupby(people.t.round(2))}
    rows = []
    for b in windows[windows.camera.isin(list(Ps))].itertuples():
        g = at.get(round(b.t, 2))
        if g is None:
            continue
        spans = np.array([geo.cylinder_window(Ps[b.camera], np.array([x, y]), HEIGHT, RADIUS)[:2] for x, y in zip(g.x, g.y)])
        holds = held_by(spans, float(b.u_left), float(b.u_right))
        mover = np.isin(g.person_id.to_numpy(), list(MOVERS))
        walking = holds & (np.hypot(g.vx.to_numpy(float), g.vy.to_numpy(float)) >= 0.5) & mover
        n = int(walking.sum())
        if n not in (1, 2):
            continue
        standers, slow = bool((holds & ~mover).any()), bool((holds & mover & ~walking).any())
        for k in np.nonzero(walking)[0]:
            lo, hi = spans[k]
            if lo < 0.0 or hi > widths[b.camera]:
                continue
            rows.append(((float(b.u_right) - float(b.u_left)) / max(float(hi - lo), 1.0), n, standers, slow))
    return pd.DataFrame(rows, columns=["share", "walkers", "standers", "slow"])


def merged_width_lines(df: pd.DataFrame) -> list[str]:
    """``--merged-widths``: the width shares and ``width_tail`` fits of four populations of
    ``walker_shares``' rows: one walker alone; alone or with standing extras; with a mover below
    walking speed (stopping, setting off); one walker or two merged (each walker's share)."""
    lines = []
    one, nobody = df.walkers == 1, ~df.standers & ~df.slow
    for name, g in (("one walker alone", df[one & nobody]),
                    ("one walker, alone or with people who never walk", df[one & ~df.slow]),
                    ("one walker with a mover below walking speed", df[one & df.slow]),
                    ("one walker or two merged (each walker's share), no one else", df[nobody])):
        e, sigma = width_tail(g["share"])
        lines.append(f"{name} ({len(g)} shares): " + ", ".join(f"> {lv:g}: {100 * (g['share'] > lv).mean():.2f} %" for lv in WIDTH_LEVELS)
                     + f"; width_tail, width_tail_sigma {e:.3f}, {sigma:.2f}")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="+", metavar="DIR")
    ap.add_argument("--flow-window", type=int, default=1, metavar="N", help="average each window's flow over N frames of its track first")
    ap.add_argument("--by-share", action="store_true", help="also the flow error by the window's share of its person's width")
    ap.add_argument("--fragments", action="store_true", help="count windows narrower than 30 %% of their person too (by share, finer bins)")
    ap.add_argument("--border", action="store_true", help="also the error table split: windows of people cut by the image border, and the rest")
    ap.add_argument("--below", action="store_true", help="also the flow error in excess for windows of people whose feet are below the image")
    ap.add_argument("--centroid", action="store_true", help="also the centroid column's error at the body centre and at the visible part's centre")
    ap.add_argument("--widths", action="store_true", help="also how often a window is much wider than its person, and the fit of target_planes' width_tail")
    ap.add_argument("--merged-widths", action="store_true", help="also the width_tail fit over walkers' windows alone, with people not walking, "
                    "and with two walkers merged")
    a = ap.parse_args(argv)
    df = pd.concat([errors(d, a.flow_window, a.fragments) for d in recording_folders(a.recordings, ap.prog)], ignore_index=True)
    fps = float(np.median(df["frame"] / df["t"].where(df["t"] > 0)))
    print(f"{len(df)} windows holding one walking mover; flow error (px/s, flow averaged over {a.flow_window} frame(s)) by true image speed:")
    print(table(df).round(2).to_string(index=False))
    print(f"gain (median of the flow along the motion over the true image speed, 10-120 px/s; target_planes flow_gain): {gain(df):.3f}")
    if a.border:
        for cut, name in ((True, "cut by the image border"), (False, "not cut by the image border")):
            g = df[df["border"].astype(bool) == cut]
            print(f"{len(g)} windows of people {name}; flow error by true image speed"
                  f" (|error| over the image speed in {100 * over_speed_share(g):.1f} % of them; gain {gain(g):.3f}):")
            if len(g):
                print(table(g).round(2).to_string(index=False))
        along, across = cut_excess(df)
        print(f"a cut window's flow error in excess of an uncut one's, over the image speed ({CUT_MIN_SPEED:g}+ px/s): "
              f"along the motion {along:.3f}, across {across:.3f}")
    if a.below:
        g = df[~df["border"].astype(bool)]
        along, across = cut_excess(g, col="below")
        print(f"{int(g['below'].sum())} windows of people whose projected cylinder reaches below the image (the feet out of it, not cut left "
              f"or right; gain {gain(g[g['below']]):.3f} against {gain(g[~g['below']]):.3f}); their flow error in excess of the others', over the "
              f"image speed ({CUT_MIN_SPEED:g}+ px/s): along the motion {along:.3f}, across {across:.3f}")
    if a.centroid:
        print("centroid column error (px) against the body centre's projection and the visible part's centre's (windows of a person "
              "seen whole across the image):")
        print(centroid_table(df).round(2).to_string(index=False))
    if a.by_share or a.fragments:
        print("flow error (px/s, image axes) by the window's width over its person's projected width (people cut by the image border left out"
              + ("; windows covering 30 % of the narrower of window and person" if a.fragments else "") + "):")
        print(share_table(df, FRAGMENT_BINS if a.fragments else SHARE_BINS).round(2).to_string(index=False))
    if a.widths:
        sh = df.loc[~df.border, "share"]
        print(f"window width over its person's projected width ({len(sh)} windows, people cut by the image border left out): "
              + ", ".join(f"> {lv:g}: {100 * (sh > lv).mean():.2f} %" for lv in WIDTH_LEVELS))
        e, sigma = width_tail(sh)
        print(f"gross width errors (target_planes width_tail, width_tail_sigma; fitted at {', '.join(f'{lv:g}' for lv in TAIL_FIT_LEVELS)}): {e:.3f}, {sigma:.2f}")
    if a.merged_widths:
        shares = []
        for d in recording_folders(a.recordings, ap.prog):
            rec = read_recording(d)
            Ps = {c: np.asarray(cam.P, float) for c, cam in rec.calibration.cameras_of_kind("oblique").items()}
            shares.append(walker_shares(rec.truth.people, rec.observations["boxes"], Ps,
                                        {c: float(rec.calibration.cameras[c].width) for c in Ps}))
        print("walkers' shares of their windows (people cut by the image border left out):")
        for line in merged_width_lines(pd.concat(shares, ignore_index=True)):
            print("  " + line)
    lags = (1, 2, 3, 5, 10, 20)
    print("how the errors persist along a camera track (autocorrelation by lag in frames; tau: integrated autocorrelation time):")
    for col, name in (("along", "flow error along the motion"), ("across", "flow error across the motion"), ("du", "centroid column error")):
        rho = autocorrelation(df, col)
        w, a_ = persistent_fit(rho)
        print(f"  {name}: " + "  ".join(f"rho({L}) {rho[L]:+.2f}" for L in lags) + f"  tau {corr_time(rho):.1f} frames;"
              f" persistent share {w:.2f}, its correlation time {-1.0 / (fps * np.log(a_)):.2f} s")
    n, share, run, long_runs = short_runs(df)
    print(f"flows short of the motion by more than half (true image speed over 30 px/s, {n} windows): {share:.3f} of them,"
          f" in runs of {run:.1f} frames on average, {long_runs} runs of 5 frames or more")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
