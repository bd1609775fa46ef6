"""Which tracks `target_planes` drops, and whether a person is left untracked by it.

    python -m scripts.explain_tp_ends DIR [DIR ...] [--param KEY=VALUE ...] [--csv FILE] [--misses FILE]

Runs the single-target tracker as ``scripts/experiment_tsutsui.py`` does (the same click; every
mover is a track inside it) and reads each confirmed track it dropped (``TargetPlanesResult.ends``:
``existence``, ``duplicate``, ``unseen``, ``off floor``) against the truth, by the experimenter:

- ``who``, ``dist``: the true person the dropped track was on - the nearest on average over its
  last ``LIFE_S`` seconds (a track drawn off its person just before the end still counts as that
  person's) - and that mean distance, m; or, when the end leaves someone untracked (below), that
  person;
- ``speed``: that person's speed over the half second before, m/s (a person stopping or standing
  makes no flow window);
- ``apart``: that person's distance to the nearest other person in the frame of the end, m (inf:
  nobody else): a duplicate dropped while the two people were more than two ``radius`` apart
  (0.4 m) was a track drawn off its person onto the other's, not one person seen twice;
- ``cover_now``, ``cover_1s``: the distance from that person to the track matched to it among the
  others the tracker held (confirmed or not), in the frame of the end and 1 s later, m (inf: none);
- ``other``: for a duplicate, the track it duplicated (the one kept; in single-target mode the
  hand-chosen target's is never dropped), empty otherwise;
- ``views``, ``views_1s``: how many of the tracker's cameras saw that person in the frame of the
  end and 1 s later, by the recording's truth (``truth_visibility``'s ``visible``); 0 is someone
  no camera could see, such as a person below a corner camera's image and behind another in the
  other views (issue 12's eighty-first session: rendered 3320, 3329). The two sensing modes
  define ``visible`` differently: rendered, at least half of the person's pixels unhidden
  (``sim.rendered``, from the segmentation); analytic, one of the rays to the body centre, chest
  and head clear (``sim.analytic``); so a person in a corner seen by its head alone counts in
  analytic recordings and not in rendered ones.

Each end is classed (``classify``): ``ghost`` (no one within ``NEAR_M`` of it on average: the
test did its job), ``person untracked`` (of the people within ``BESIDE_M`` of it when it ended,
one that a track - the dropped one or another - followed in the second before (at -1, -0.5 or 0 s)
is matched to none of
the other tracks a second after: people and tracks one to one, each pair within ``ON_M``; a real
person lost its track for a second or more, and when two tracks were drawn onto one person and
one of them was dropped, the person the pair left is that one; people no track ever followed,
such as those standing still all along, do not count), or ``second track`` (every one of them
stays tracked). The summary counts them by reason; the untracked ones are listed with
where they happened.

``fall``: for a track the existence test dropped, how many frames it took from its last frame at
the accept bound (``tp_joint.EXIST_ACCEPT``, +4.60) to the drop (empty: never at the bound, or
another reason, or a run with the look-ahead, which steps each frame once per hypothesis), read
from the tracker's own existence updates (``ExistenceLog``); the summary counts those drops by
class and fall (issue 12's hundredth session: analytic 4115 and rendered 4136, a person's track
dropped in three frames, the floor the two-mode marginal has a frame after a frame in which the
track walked). ``mu_fall``, ``in_image``: over the frames of that fall, the highest standing
probability its existence updates weighed (the frame's prior: at 0.5 or more a frame without its
window counts mostly as a standing person's) and the fewest cameras' images its projection fell
in, the tracker's own counterparts of the truth's standing and ``views``; the summary counts the
falls by both (issue 12's hundred-and-first session). ``miss_seen``, ``miss_hidden``,
``miss_out``: over the same frames, the existence evidence against the track (the negative shares,
log-odds, summed over its cameras and frames: no window where a walker would make one, or a merged
window fitting the others better) from the cameras the truth says saw the person (``visible``, as
for ``views``), from those whose image held the person hidden (``in_fov`` without ``visible``:
behind someone or something, or in rendered recordings less than half of it unhidden), and from
those whose image did not hold it (``in_fov`` false). ``--misses FILE``: those shares one row per
camera and frame (``miss_rows``), with the track's projected cylinder and the person model's at
the true person's position, so that a miss from a camera whose image did not hold the person can
be told apart: the track there too (the view's test) or the track elsewhere (its position); the
summary sums them by camera and truth for the people left untracked.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's code, also run as a file
from scripts.experiment_tsutsui import distances_at, measurement_args, measurement_parser, people_at, run_target
from scripts.explain_tp_losses import NEAR_M as BESIDE_M  # the people this near its end are the ones it may leave untracked
from scripts.explain_tp_losses import ON_M  # another track this near a person (matched one to one) still follows it
from trackroom.dataset import read_recording
from trackroom.estimators import tp_geometry as geo
from trackroom.estimators import tp_joint

NEAR_M = 0.7  # a dropped track this near a person (on average) was on that person
LATER_S = 1.0  # ... this long after the end
BEFORE_S = 1.0  # a person some track (the dropped one too) followed this long before the end was tracked
SPEED_S = 0.5  # the person's speed over this span before the end
LIFE_S = 2.0  # the person a track followed: the nearest on average over this span before its end
FALL_BINS = ((1, 3, "1-3"), (4, 10, "4-10"), (11, 10**9, "11+"))  # frames from the accept bound to an existence drop
WIN_NAMES = ("left", "right", "top", "bottom")  # a projected cylinder's window, px (``--misses``)


class ExistenceLog:
    """Wraps ``tp_joint.JointTracker.step`` (one call a frame) and ``existence`` for one run,
    keeping, by frame index, each track's existence log-odds after each frame's update, its
    standing probability the update weighed (the frame's prior, ``mu``) and how many cameras'
    images its projection fell in then (``in_image``: the tracker's own view of who can see it;
    hidden behind a shelf or another track still counts), and each camera's share of that
    update's evidence (``walk_evidence``, wrapped too) with the track's projected cylinder there
    (``windows``); ``jt``: the tracker it saw; ``close`` puts the tracker back."""

    def __init__(self):
        JT = tp_joint.JointTracker
        self.orig = JT.step, JT.__dict__["existence"], JT.walk_evidence
        self.k = -1
        self.exist: dict[int, dict[int, float]] = {}  # track id -> {frame index: existence after the update}
        self.mu: dict[int, dict[int, float]] = {}  # ... -> the standing probability it weighed
        self.in_image: dict[int, dict[int, int]] = {}  # ... -> cameras whose image its projection fell in
        self.evidence: dict[int, dict[int, dict[str, float]]] = {}  # ... -> {camera: its walk evidence}
        self.windows: dict[int, dict[int, dict[str, np.ndarray]]] = {}  # ... -> {camera: the projected cylinder, px}
        self.jt = None
        log = self

        def step(jt, *args, **kwargs):
            log.k += 1
            log.jt = jt
            return log.orig[0](jt, *args, **kwargs)

        def existence(tr, *args, **kwargs):
            out = log.orig[1].__func__(tr, *args, **kwargs)
            log.exist.setdefault(tr.tid, {})[log.k] = float(tr.exist)
            log.mu.setdefault(tr.tid, {})[log.k] = float(tr.mu)
            log.in_image.setdefault(tr.tid, {})[log.k] = sum(why != "out of view" for _, why, _ in tr.status.values())
            return out

        def walk_evidence(jt, tr, c, p, *args, **kwargs):
            out = log.orig[2](jt, tr, c, p, *args, **kwargs)
            log.evidence.setdefault(tr.tid, {}).setdefault(log.k, {})[c] = float(out)
            log.windows.setdefault(tr.tid, {}).setdefault(log.k, {})[c] = np.array(p.win, float)
            return out

        JT.step, JT.existence, JT.walk_evidence = step, staticmethod(existence), walk_evidence

    def close(self) -> None:
        JT = tp_joint.JointTracker
        JT.step, JT.existence, JT.walk_evidence = self.orig

    def fall(self, tid: int, k_end: int) -> int | None:
        """Frames from track ``tid``'s last frame at the accept bound up to frame ``k_end`` (its
        drop); None if it never was at the bound by then (or has no record)."""
        at_bound = [k for k, e in self.exist.get(tid, {}).items() if k <= k_end and e >= tp_joint.EXIST_ACCEPT - 1e-9]
        return k_end - max(at_bound) if at_bound else None

    def during_fall(self, tid: int, k_end: int) -> tuple[float, int] | None:
        """Over the frames after track ``tid``'s last frame at the accept bound up to its drop at
        ``k_end``: the highest standing probability its existence updates weighed, and the fewest
        cameras' images its projection fell in; None where ``fall`` is None or 0."""
        n = self.fall(tid, k_end)
        if not n:
            return None
        ks = [k for k in self.mu.get(tid, {}) if k_end - n < k <= k_end]
        return max(self.mu[tid][k] for k in ks), min(self.in_image[tid][k] for k in ks)

    def fall_misses(self, tid: int, k_end: int) -> list[tuple[int, str, float]]:
        """(frame index, camera, evidence) of each camera's negative share of the existence
        evidence over the frames of track ``tid``'s fall to its drop at ``k_end`` (``fall``):
        the cameras whose lack of a window (or a merged window fitting the others better) spoke
        against someone being there; empty where ``fall`` is None or 0."""
        n = self.fall(tid, k_end)
        ev = self.evidence.get(tid, {})
        if not n:
            return []
        return [(k, c, v) for k in range(k_end - n + 1, k_end + 1) for c, v in ev.get(k, {}).items() if v < 0.0]


def fall_bin(frames) -> str:
    """``FALL_BINS``' label of a fall of ``frames`` frames ("never at the bound": none)."""
    if frames is None or pd.isna(frames):
        return "never at the bound"
    return next(label for lo, hi, label in FALL_BINS if lo <= frames <= hi)


def _people(ppl: pd.DataFrame, t: float) -> pd.DataFrame:
    """The true people's x, y at t (``people_at``: the nearest simulation step), indexed by person_id."""
    return people_at(ppl, np.array([t])).set_index("person_id")[["x", "y"]]


def _frame(table: pd.DataFrame, t: float) -> pd.DataFrame:
    """The rows of ``table`` in the frame nearest t (within half a 10 Hz frame)."""
    return table[np.abs(table["t"].to_numpy(float) - t) < 0.05 + 1e-9]


def _tracks(internal: pd.DataFrame, t: float) -> pd.DataFrame:
    """The tracks' x, y in the frame nearest t, indexed by track_id."""
    return _frame(internal, t).groupby("track_id")[["x", "y"]].mean()


def classify(dist: float, untracked: bool) -> str:
    """The class of one dropped track (the module's docstring): ``dist`` its mean distance from
    the person it was on, ``untracked`` whether someone beside it was left without a track."""
    if not dist <= NEAR_M:
        return "ghost"
    return "person untracked" if untracked else "second track"


def matched_cover(people_xy: pd.DataFrame, tracks_xy: pd.DataFrame) -> dict[str, float]:
    """Each person's distance to the track matched to it, people and tracks one to one (least
    total distance), a pair only within ``ON_M``; inf for a person matched to none."""
    out = {str(w): np.inf for w in people_xy.index}
    if not len(people_xy) or not len(tracks_xy):
        return out
    D = np.hypot(people_xy["x"].to_numpy()[:, None] - tracks_xy["x"].to_numpy()[None],
                 people_xy["y"].to_numpy()[:, None] - tracks_xy["y"].to_numpy()[None])
    r, c = linear_sum_assignment(np.where(D <= ON_M, D, 1e6))
    for i, j in zip(r, c):
        if D[i, j] <= ON_M:
            out[str(people_xy.index[i])] = float(D[i, j])
    return out


def views_at(visibility: pd.DataFrame | None, cameras, who: str, t: float) -> int | None:
    """How many of ``cameras`` saw person ``who`` in the frame nearest t (within half a 10 Hz
    frame) by ``visibility`` (t, camera, person_id, visible); None without that table's rows."""
    if visibility is None or not len(visibility):
        return None
    v = _frame(visibility, t)
    v = v[(v["person_id"] == who) & v["camera"].isin(list(cameras))]
    if not len(v):
        return None
    return int(v.groupby("camera")["visible"].any().sum())


def truth_view(visibility: pd.DataFrame, t: float, who: str, camera: str) -> str:
    """What the truth says of ``camera`` and person ``who`` in the frame nearest t: "seen"
    (``visible``), "hidden" (in its image, ``in_fov``, but not ``visible``) or "out" (neither, or
    no row for the person)."""
    f = _frame(visibility, t)
    f = f[(f["person_id"] == who) & (f["camera"] == camera)]
    return "seen" if bool(f["visible"].any()) else "hidden" if bool(f["in_fov"].any()) else "out"


def misses_by_truth(misses, times, visibility: pd.DataFrame | None, who: str) -> tuple[float, float, float] | None:
    """The summed negative existence evidence of ``misses`` ((frame index, camera, evidence), the
    log's ``fall_misses``), split by ``truth_view`` of camera and person ``who`` in that frame
    (``times``: each frame index's time): (seen, hidden, out); None without the truth's
    visibility."""
    if visibility is None or not len(visibility):
        return None
    out = {"seen": 0.0, "hidden": 0.0, "out": 0.0}
    for k, c, v in misses:
        out[truth_view(visibility, float(times[k]), who, c)] += v
    return round(out["seen"], 2), round(out["hidden"], 2), round(out["out"], 2)


def miss_rows(log: ExistenceLog, tid: int, misses, times, people: pd.DataFrame, visibility: pd.DataFrame,
              who: str) -> list[dict]:
    """One row per camera and frame of track ``tid``'s fall with evidence against it
    (``misses``, the log's ``fall_misses``): the evidence, ``truth_view``, and the track's projected cylinder there
    against the person model's cylinder at the true person's position (``tp_geometry.
    cylinder_window`` with the tracker's ``height`` and ``radius``), columns and rows, px."""
    jt, rows = log.jt, []
    for k, c, v in misses:
        t = float(times[k])
        xy = _people(people, t).loc[who, ["x", "y"]].to_numpy(float)
        mine, theirs = log.windows[tid][k][c], geo.cylinder_window(jt.Ps[c], xy, jt.cfg.height, jt.cfg.radius)
        rows.append({"t": round(t, 1), "camera": c, "evidence": round(v, 3), "truth": truth_view(visibility, t, who, c),
                     **{f"track_{n}": round(float(x), 1) for n, x in zip(WIN_NAMES, mine)},
                     **{f"person_{n}": round(float(x), 1) for n, x in zip(WIN_NAMES, theirs)},
                     "image_width": jt.widths[c]})
    return rows


def ends_against_truth(people: pd.DataFrame, internal: pd.DataFrame, ends: pd.DataFrame,
                       visibility: pd.DataFrame | None = None, cameras=()) -> list[dict]:
    """One row per dropped track: ``people`` the truth (t, person_id, x, y), ``internal`` every
    track the tracker held (t, track_id, x, y), ``ends`` its dropped tracks (t, track_id, x, y,
    reason, other); ``visibility`` the truth's (t, camera, person_id, visible) for ``cameras``,
    the tracker's, or None (``views``: None)."""
    rows = []
    for e in ends.itertuples():
        now = _people(people, e.t)
        if not len(now):
            continue
        mine = internal[(internal["track_id"] == e.track_id) & (internal["t"] >= e.t - LIFE_S - 1e-9) & (internal["t"] <= e.t + 1e-9)]
        if not len(mine):
            mine = pd.DataFrame({"t": [e.t], "x": [e.x], "y": [e.y]})
        names, D = distances_at(people, mine["t"], mine[["x", "y"]])
        d = pd.Series(D.mean(axis=0), index=names)
        beside = now.index[np.hypot(now["x"] - e.x, now["y"] - e.y) <= BESIDE_M].union([d.idxmin()])
        others = internal[internal["track_id"] != e.track_id]

        def cover(dt: float, tracks: pd.DataFrame) -> dict[str, float]:
            p = _people(people, e.t + dt)
            return matched_cover(p.loc[p.index.intersection(beside)], _tracks(tracks, e.t + dt))

        # tracked in the second before the end (by any track, the dropped one too: at any of three
        # frames), and by none of the others a second after
        before = [cover(-dt, internal) for dt in (BEFORE_S, 0.5 * BEFORE_S, 0.0)]
        covers = [cover(0.0, others), cover(LATER_S, others)]
        left = [str(w) for w in beside if any(np.isfinite(b.get(str(w), np.inf)) for b in before) and np.isinf(covers[1].get(str(w), np.inf))]
        who = min(left, key=lambda w: float(d[w])) if left else str(d.idxmin())
        earlier = _people(people, e.t - SPEED_S)
        speed = float(np.hypot(*(now.loc[who] - earlier.loc[who]))) / SPEED_S if who in earlier.index else float("nan")
        c0, c1 = covers[0].get(who, np.inf), covers[1].get(who, np.inf)
        rest = now.drop(index=who)
        apart = float(np.hypot(rest["x"] - now.at[who, "x"], rest["y"] - now.at[who, "y"]).min()) if len(rest) else np.inf
        other = int(e.other) if e.reason == "duplicate" and pd.notna(e.other) else None  # the track it duplicated
        rows.append({"t": round(float(e.t), 1), "track": int(e.track_id), "reason": e.reason, "other": other, "x": round(float(e.x), 2),
                     "y": round(float(e.y), 2), "who": who, "dist": round(float(d[who]), 2), "speed": round(speed, 2), "apart": round(apart, 2),
                     "cover_now": round(c0, 2), "cover_1s": round(c1, 2), "views": views_at(visibility, cameras, who, e.t),
                     "views_1s": views_at(visibility, cameras, who, e.t + LATER_S), "class": classify(float(d.min()), bool(left))})
    return rows


def main(argv=None) -> int:
    ap = measurement_parser(__doc__, "write the dropped tracks here")
    ap.add_argument("--misses", help="write each camera's evidence against a track over its fall to an existence drop "
                                     "here, one row per camera and frame, with the track's and the person's projected cylinders")
    dirs, params, a = measurement_args(ap, argv)
    csv = a.csv
    rows, misses = [], []
    for d in dirs:
        rec = read_recording(d)
        log = None if (params or {}).get("lookahead") else ExistenceLog()  # frames stepped twice: no frame index
        try:
            res = run_target(rec, params)
        finally:
            if log is not None:
                log.close()
        cams = rec.calibration.cameras_of_kind("oblique")
        times = np.asarray(res.times, float)
        for r in ends_against_truth(rec.truth.people, res.internal, res.ends, rec.truth.visibility, cams):
            fall = during = split = None
            if r["reason"] == "existence" and log is not None:
                k_end = int(np.argmin(np.abs(times - r["t"])))
                fall, during = log.fall(r["track"], k_end), log.during_fall(r["track"], k_end)
                fell = log.fall_misses(r["track"], k_end)  # empty, as ``during`` is None, without a fall
                if during is not None:
                    split = misses_by_truth(fell, times, rec.truth.visibility, r["who"])
                if split is not None and a.misses:  # split: only for a fall (during) with the truth's visibility
                    misses += [{"recording": d, "seed": rec.seed, "track": r["track"], "class": r["class"], "who": r["who"], **m}
                               for m in miss_rows(log, r["track"], fell, times, rec.truth.people, rec.truth.visibility, r["who"])]
            rows.append({"recording": d, "seed": rec.seed, **r, "fall": fall, "mu_fall": None if during is None else round(during[0], 3),
                         "in_image": None if during is None else during[1],
                         **{k: None if split is None else split[n] for n, k in enumerate(("miss_seen", "miss_hidden", "miss_out"))}})
    df = pd.DataFrame(rows)
    if len(df):
        df["other"] = df["other"].astype("Int64")  # empty where the end is no duplicate
        for k in ("views", "views_1s", "fall", "in_image"):
            df[k] = df[k].astype("Int64")  # empty without the truth's visibility / for another reason
    if csv:
        df.to_csv(csv, index=False)
    if a.misses:
        pd.DataFrame(misses).to_csv(a.misses, index=False)
    if not len(df):
        print(f"{len(dirs)} recordings: no confirmed track dropped")
        return 0
    print(f"{len(dirs)} recordings, {len(df)} confirmed tracks dropped:")
    print(df.groupby(["reason", "class"]).size().unstack(fill_value=0).to_string())
    drops = df[df["reason"] == "existence"]
    if len(drops):
        print("\nexistence drops by frames from the accept bound to the drop:")
        print(drops.assign(fall=drops["fall"].map(fall_bin)).groupby(["fall", "class"]).size().unstack(fill_value=0).to_string())
        fell = drops[drops["in_image"].notna()]
        if len(fell):
            print("\nthose falling from the bound, by the tracker's own view over the fall (the highest standing "
                  "probability weighed; the fewest cameras' images its projection fell in):")
            print(fell.assign(standing=np.where(fell["mu_fall"].astype(float) >= 0.5, "likelier standing", "likelier walking"),
                              in_image=fell["in_image"].astype(int).clip(upper=2).map({0: "0", 1: "1", 2: "2+"}))
                  .groupby(["standing", "in_image", "class"]).size().unstack(fill_value=0).to_string())
        split = fell[fell["miss_seen"].notna()]
        if len(split):
            print("\nthe evidence against them over the fall (log-odds summed over the cameras and frames without "
                  "a window), by what the truth says of the camera and the person: seen; in its image but hidden; "
                  "out of its image:")
            print(split.groupby("class")[["miss_seen", "miss_hidden", "miss_out"]].agg(["sum", "median"]).round(2).to_string())
    if misses:
        m = pd.DataFrame(misses)
        m = m[m["class"] == "person untracked"]
        if len(m):
            print("\nthe evidence against the tracks of people left untracked, by camera and the truth (--misses), with the "
                  "median rows by which the person's projected cylinder lies lower in the image than the track's (its top):")
            print(m.assign(lower=m["person_top"] - m["track_top"]).groupby(["camera", "truth"])
                  .agg(misses=("evidence", "size"), evidence=("evidence", "sum"), lower_px=("lower", "median")).round(2).to_string())
    lost = df[df["class"] == "person untracked"]
    if len(lost):
        print(f"\na person left untracked ({len(lost)}):")
        for r in lost.itertuples():
            why = f"duplicate of track {int(r.other)}" if pd.notna(r.other) else r.reason  # other: set for duplicates only
            seen = "" if pd.isna(r.views) else f"; seen by {r.views} cameras, 1 s later {r.views_1s}"
            print(f"seed {r.seed!s:>4} t {r.t:5.1f} s  track {r.track} ({why}) at ({r.x:.2f}, {r.y:.2f})  {r.who} {r.dist:.2f} m "
                  f"away, {r.speed:.2f} m/s, {r.apart:.2f} m from the nearest other person; nearest other track "
                  f"{r.cover_now:.2f} m, 1 s later {r.cover_1s:.2f} m{seen}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
