"""The perception model of analytic sensing: what a rendered detector does, in statistics.

Analytic sensing projects people through the camera model and casts occlusion rays; this model
turns that geometry into what the rendered detectors (``sim.perception``, ``sim.perception_flow``,
``sim.perception_privacy``) would have reported in the same situation, with parameters fitted from
rendered recordings (``sim.perception_fit``, ``trackroom calibrate-sensing``). The observation
tables keep the detectors' columns only: no column holds or encodes a person id (truth drives the
simulation of misses, merges and id switches, as a simulator's truth does).

Features, per camera frame and person in the field of view (``sim.analytic``):
  seen     share of the three occlusion rays (body centre, chest, head) that reach the person:
           0, 1/3, 2/3, 1 (0: in the field of view, all rays blocked; legs may still show);
  clip     share of the person's image width (the projected cylinder) inside the image;
  speed    image speed of the body centre (px/s, oblique windows) or floor speed (m/s, privacy);
  axis clip (overhead, privacy) share of the person's image axis, feet to the top of the head,
           inside the image: a ceiling camera cuts the heads of people in its tile's far corners;
  overlap  for a pair of people in one image: overlap of their image spans / the narrower span;
  gap      for a pair on the floor (overhead): their distance (m).

Per detector (``DetectorModel``; bearing blobs of horizontal cameras, bearing blobs of oblique
cameras, oblique flow windows, overhead regular and privacy floor detections):
  detect   P(reported | features): a ``Table`` over bins, fitted as counts with shrinkage towards
           the pooled rate. Misses come in runs as the rendered ones do: per person and camera
           the uniform compared with 1 - P is held from frame to frame with probability
           ``miss_stay`` (``run_events``), fitted so the mean run of misses matches the rendered
           one (models without ``miss_stay``: the uniforms compared with P are a Gaussian AR(1)
           copula with frame correlation ``rho``).
  merge    P(two people give one detection | overlap or gap): the merged detection spans both
           (union of their image spans / windows) or, on the floor, lies on the one the rendered
           overhead detector places it on (the member reaching farthest out from the point below
           the camera, ``analytic_detectors.merged_blob_member``), and carries the measurement
           error once. Merges come in runs (two people walking together stay merged): per pair
           and camera the uniform compared with P is held from frame to frame with probability
           ``merge_stay`` (``run_events``), fitted so the mean run of merges matches the rendered
           one; for floor detectors P(merge) is fitted non-increasing with the silhouette gap, so
           a merge lasts while the two stay as close as they were when it began (models without
           ``merge_stay``: the uniforms compared with P are an AR(1) copula with frame correlation
           ``merge_rho``).
  errors   ``Quantiles`` of the measurement error against the analytic reference (the centre of
           the visible part of the person's image span; the clipped window edges; the projected
           flow; the floor position): bias, scatter and tails in one inverse-CDF table. A person's
           errors persist from frame to frame as the rendered ones do (the same silhouette gives
           the same error): the uniforms behind them are a Gaussian AR(1) copula per person and
           camera with the fitted lag-one correlation ``err_rho``. Floor errors (overhead,
           privacy) are drawn along and across the camera's radial direction from tables by the
           blob's state (head cut or whole, near another person or alone:
           ``analytic_detectors.FLOOR_TABLES``), and the radial one adds ``head_gain`` times the
           head-height shift (``CameraGeometry.head_shift``): the detector places a person by the
           head, and a walking person's head bobs. Flow windows' flow errors (from the tenth fit)
           are drawn along and across the people's image velocity from tables by its speed
           (``analytic_detectors.FLOW_SPEED_EDGES``): the flow detector falls short of fast motion.
  tail     (overhead, privacy; ``Tail``) drift episodes beyond the error tables: a blob that
           drifts off its person over a few frames (a head cut by the tile's border, a blob partly
           joined with a neighbour's) and often ends in a miss. Per detected, unmerged
           person-frame an episode starts with P(start | head cut, near another person); it lasts
           a geometric number of frames (mean ``frames``) with |error| above ``TAIL_M`` growing
           linearly to a peak drawn from ``size``, in a direction (angle from the camera's radial
           direction) drawn from ``angle``; with ``miss`` the frame after it is missed.
  label    P(the appearance label is the person's own colour); otherwise another colour of the
           scene's palette, drawn uniformly (the label is an appearance class, never an id).
  clutter  false detections per camera frame (Poisson), placed uniformly in the image (floor
           region); windows of clutter live a geometric number of frames (``clutter_frames``);
           a share of false blobs has no label (``clutter_unlabelled``: "" as the detector gives
           a blob without colour votes).
  fragment extra detections on a detected person (a blob split in two, a window on the legs):
           per detected person-frame, placed relative to the person's image span / window
           (``frag_*`` error tables); fragment windows live ``fragment_frames`` frames;
  partial  (flow windows) a moving person the detector missed often still has a small window on
           part of the body (IoU with the person's window below the match gate): windows per
           missed moving person-frame by the seen share of rays (``partial``, a table; fits
           from the eighth on: by the seen share of the axis rays and of the ray to the top of the
           head, ``analytic.HEAD_TOP``: a head over a shelf leaves a strip window), born at
           that rate / ``partial_frames`` and living ``partial_frames`` frames, placed relative
           to the person's window (``part_*`` error tables); models without ``partial`` draw none;
  ids      (flow windows) the camera tracker's id: kept while the person's window continues (gaps
           up to ``max_gap`` frames), a new id after a longer gap or spontaneously with
           ``restart`` per frame; a merged window keeps its oldest member's id, and when it splits
           the id goes to the wrong person with ``swap``.

The model is one JSON file (``PerceptionModel.save``); the bundled ``perception_default.json`` was
fitted on the bundled scenes' development seeds (docs/sensing.md). ``load_model("ideal")`` is the
old analytic sensing: every visible person detected, exact labels, Gaussian noise from the
scene's ``sensors`` figures, per-person window ids.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.special import ndtr

# The flow detector's (``sim.perception_flow``) window errors against the projected truth on
# rendered ``occlusion_lab`` (320x240, 10 fps; seed 0, 35 s; windows on walking people; robust standard deviations 1.4826 MAD), in the
# calibration's terms (``SensorSpec`` plus two keys of its own): window edges ``box_sigma_px``
# (top 1.3, bottom 1.5 px); window centroid u against the body axis ``box_u_sigma_px`` (3.4 px; a
# key of its own: ``bearing_sigma_px`` stays the horizontal cameras' bearing noise, which the QP
# smoother and EKF read, ~0.2 px rendered); region flow against the body centre's image velocity
# ``flow_sigma_px_s`` (u 2.6, v 5.1 px/s per axis; standard deviations 13 and 12 px/s: heavy tails).
# Measured with ``python scripts/experiment_tsutsui.py --recording DIR --window-errors``.
# ``sim.simulate.simulate(..., sensing="rendered")`` merges these into ``calibration.noise``: noise
# levels only. (The eq. 8 width ratio (w - w_c) / w_c of these windows - isolated, fully visible
# walkers <= 0.10 in 99 % of frames and never above 0.5, two people merged side by side 0.7-1.3 -
# informs an estimator's decision threshold, ``target_planes``' ``width_ratio_threshold``, which
# lives in its Config, not in the calibration.)
RENDERED_WINDOW_NOISE = {"box_sigma_px": 1.5, "box_u_sigma_px": 3.5, "flow_sigma_px_s": 5.0}

DEFAULT_FILE = Path(__file__).with_name("perception_default.json")
FORMAT = "trackroom-perception-model/2"
# format 1 (before merges came in runs and overhead merges were judged in the image): refit it
OLD_FORMATS = ("trackroom-perception-model/1",)
DETECTORS = ("horizontal", "oblique", "windows", "overhead", "privacy")
# horizontal: bearing blobs of horizontal cameras; oblique: bearing blobs of oblique cameras;
# windows: oblique cameras' flow windows; overhead, privacy: floor detections of overhead cameras

# overhead, privacy: a blob whose silhouette lies within this many body widths of another detected
# person's in the image takes the "near" error tables (``analytic_detectors.FLOOR_TABLES``)
NEAR_GAP = 1.5
# floor errors above this (m) are the tail (``Tail``): the error tables, which stop at their 99.5 %
# quantile (about 5 cm), do not make them
TAIL_M = 0.08
# quantile levels of an error table (the ends are the 0.5 % and 99.5 % quantiles)
LEVELS = (0.005, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98, 0.995)


class ModelError(ValueError):
    """A perception model file that cannot be used (names the file and the problem)."""


@dataclass
class Table:
    """P(event | binned features): ``edges[i]`` are the bin edges of feature i; ``p`` has one
    entry per bin combination. Values beyond the outer edges fall in the outer bins."""

    edges: list[list[float]]
    p: np.ndarray
    n: np.ndarray | None = None  # trials per bin (fitted tables)

    def __call__(self, *features: np.ndarray) -> np.ndarray:
        idx = tuple(np.clip(np.searchsorted(np.asarray(e[1:-1]), np.asarray(f), side="right"), 0, len(e) - 2)
                    for e, f in zip(self.edges, features))
        return self.p[idx]

    @classmethod
    def fit(cls, edges, features: list[np.ndarray], hits: np.ndarray, strength: float = 4.0) -> "Table":
        """Rates per bin, shrunk towards the pooled rate with ``strength`` pseudo-trials."""
        shape = tuple(len(e) - 1 for e in edges)
        k, n = np.zeros(shape), np.zeros(shape)
        if len(hits):
            idx = tuple(np.clip(np.searchsorted(np.asarray(e[1:-1]), np.asarray(f), side="right"), 0, len(e) - 2)
                        for e, f in zip(edges, features))
            np.add.at(n, idx, 1.0)
            np.add.at(k, idx, np.asarray(hits, float))
        pooled = k.sum() / n.sum() if n.sum() else 0.0
        return cls([list(map(float, e)) for e in edges], (k + strength * pooled) / (n + strength), n)

    def to_dict(self) -> dict:
        d = {"edges": [[_num(x) for x in e] for e in self.edges], "p": np.round(self.p, 6).tolist()}
        if self.n is not None:
            d["n"] = self.n.astype(int).tolist()
        return d

    @classmethod
    def from_dict(cls, d) -> "Table":
        edges = [[float(x) for x in e] for e in d["edges"]]
        p = np.asarray(d["p"], float)
        if p.shape != tuple(len(e) - 1 for e in edges) or not np.all((p >= 0) & (p <= 1)):
            raise ValueError("a probability table's p must have one value in [0, 1] per bin")
        return cls(edges, p, np.asarray(d["n"], float) if "n" in d else None)


def constant(p: float) -> Table:
    return Table([[-math.inf, math.inf]], np.array([float(p)]))


@dataclass
class Quantiles:
    """An error distribution as its quantiles at ``LEVELS`` (sampled by inverse CDF)."""

    q: np.ndarray

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.at(rng.random(n))

    def at(self, u: np.ndarray) -> np.ndarray:
        """The errors at uniforms ``u`` (inverse CDF)."""
        return np.interp(u, LEVELS, self.q)

    @property
    def bias(self) -> float:
        return float(self.q[LEVELS.index(0.5)])

    @property
    def sigma(self) -> float:
        """Robust one-sigma: half the 15.9 %-84.1 % range."""
        lo, hi = np.interp([0.1587, 0.8413], LEVELS, self.q)
        return float(hi - lo) / 2

    @classmethod
    def fit(cls, x: np.ndarray, fallback: "Quantiles | None" = None, min_n: int = 30) -> "Quantiles":
        x = np.asarray(x, float)
        x = x[np.isfinite(x)]
        if len(x) < min_n:
            return fallback if fallback is not None else cls.gaussian(0.0)
        return cls(np.quantile(x, LEVELS))

    @classmethod
    def gaussian(cls, sigma: float, bias: float = 0.0) -> "Quantiles":
        from scipy.special import ndtri

        return cls(bias + sigma * ndtri(np.asarray(LEVELS)))

    def to_dict(self) -> list[float]:
        return np.round(self.q, 4).tolist()

    @classmethod
    def from_dict(cls, d) -> "Quantiles":
        q = np.asarray(d, float)
        if q.shape != (len(LEVELS),) or not np.all(np.isfinite(q)) or np.any(np.diff(q) < 0):
            raise ValueError(f"an error table must hold {len(LEVELS)} finite, non-decreasing quantiles")
        return cls(q)


def check_heights(heights, what: str) -> None:
    """``heights`` (px between image-height bins) must be positive and increasing; else one
    ``ValueError`` naming ``what``."""
    h = np.asarray(heights, float)
    if not len(h) or not np.all(np.isfinite(h)) or np.any(np.diff(h) <= 0) or h[0] <= 0:
        raise ValueError(f"{what} must be positive, increasing image heights (px), got {list(heights)}")


# the kinds of window ``EdgeCorr.rho`` is given for, and the edge tables' tag of each
# (``analytic_detectors.edge_tables``)
EDGE_CORR_KINDS = {"plain": "", "crowded": "_crowded"}


@dataclass
class EdgeCorr:
    """(windows) The correlation of a window's top and bottom edge errors: the rendered window
    grows or shrinks as a whole (development 100-109, one person's window, Spearman: -0.35 for
    plain windows of people 60 px high or more, -0.10 under 60 px, +0.03 to -0.17 for crowded
    ones). ``rho`` holds, per kind of window (``EDGE_CORR_KINDS``), one Gaussian-copula
    correlation per bin of the person's image height (``heights``: px between the bins,
    ``analytic_detectors.height_bin``); windows cut by a box keep independent edges."""

    heights: tuple[float, ...]
    rho: dict[str, tuple[float, ...]]

    def __post_init__(self):
        self.heights = tuple(float(x) for x in self.heights)
        self.rho = {str(k): tuple(float(x) for x in v) for k, v in self.rho.items()}
        check_heights(self.heights, "edge_corr: heights")
        n = len(self.heights) + 1
        for k, v in self.rho.items():
            if k not in EDGE_CORR_KINDS:
                raise ValueError(f"edge_corr: unknown kind of window {k!r}; expected {', '.join(EDGE_CORR_KINDS)}")
            if len(v) != n or not all(-1.0 < x < 1.0 for x in v):
                raise ValueError(f"edge_corr: {k} needs {n} correlations in (-1, 1), one per height bin, got {list(v)}")

    def to_dict(self) -> dict:
        return {"heights": list(self.heights), "rho": {k: [round(x, 4) for x in v] for k, v in self.rho.items()}}

    @classmethod
    def from_dict(cls, d) -> "EdgeCorr":
        if not isinstance(d, dict) or not isinstance(d.get("rho"), dict):
            raise ValueError(f"edge_corr must be {{\"heights\": [...], \"rho\": {{\"plain\": [...], ...}}}}, got {d!r}")
        return cls(tuple(d["heights"]), {k: tuple(v) for k, v in d["rho"].items()})


@dataclass
class Tail:
    """Drift episodes of a floor detector (see the module docstring, ``tail``): an episode of L
    frames (geometric, mean ``frames``) has |error| TAIL_M + (peak - TAIL_M) k / L at its k-th
    frame (k = 1..L: above TAIL_M throughout, the peak last), added to the table error along the direction at
    ``angle`` (rad) from the camera's radial direction."""

    start: Table  # P(an episode starts | head cut (0, 1), near another person (0, 1)), per detected person-frame
    frames: float = 1.0  # mean frames of an episode above TAIL_M
    size: Quantiles = field(default_factory=lambda: Quantiles(np.full(len(LEVELS), TAIL_M)))  # peak |error| (m)
    angle: Quantiles = field(default_factory=lambda: Quantiles(np.zeros(len(LEVELS))))  # from the radial direction (rad)
    miss: float = 0.0  # share of episodes followed by a miss

    def to_dict(self) -> dict:
        return {"start": self.start.to_dict(), "frames": round(self.frames, 4), "size": self.size.to_dict(),
                "angle": self.angle.to_dict(), "miss": round(self.miss, 4)}

    @classmethod
    def from_dict(cls, d) -> "Tail":
        t = cls(Table.from_dict(d["start"]), float(d["frames"]), Quantiles.from_dict(d["size"]),
                Quantiles.from_dict(d["angle"]), float(d["miss"]))
        if not (t.frames >= 1 and 0.0 <= t.miss <= 1.0):
            raise ValueError("tail: frames must be >= 1 and miss in [0, 1]")
        return t


# (windows) the bins of a border-cut window's P(short): the cut side (left / right) and the
# person's horizontal image velocity (px/s): on rendered development 100-159 the windows stopping
# short are mostly of people moving left fast (left border, leaving at over 40 px/s: 32-52 %;
# right border, entering: 9-21 %; against 0-3 % moving right at 10 px/s or more) or standing
# (within 5 px/s: 15-18 %)
BORDER_EDGES = [[-math.inf, 0.5, math.inf], [-math.inf, -40.0, -10.0, 10.0, 40.0, math.inf]]


@dataclass
class Border:
    """(windows) A person cut by one image border has a window reaching that border, as the
    rendered flow tracker's box does, except in runs of frames where the window stops short of
    it (the fifteenth fit): P(short) per bin of ``BORDER_EDGES`` (``short``), runs of mean length
    set by ``stay`` (``run_events``); a short window's cut edge lies ``border_gap_<side>`` px
    inside the border and its horizontal flow is ``gain[side]`` times the person's plus
    ``border_flow_<side>`` (error tables; side ``l`` / ``r``): the flow of a window stopping short
    falls behind its person (rendered development 100-159: gain 0.61 left, 0.29 right)."""

    short: Table
    stay: float = 0.0
    gain: tuple[float, float] = (1.0, 1.0)

    def to_dict(self) -> dict:
        return {"short": self.short.to_dict(), "stay": round(self.stay, 5), "gain": [round(float(g), 4) for g in self.gain]}

    @classmethod
    def from_dict(cls, d) -> "Border":
        if not isinstance(d, dict) or "short" not in d:
            raise ValueError(f"border must be {{\"short\": table, \"stay\": s, \"gain\": [left, right]}}, got {d!r}")
        b = cls(Table.from_dict(d["short"]), float(d.get("stay", 0.0)), tuple(float(g) for g in d.get("gain", (1.0, 1.0))))
        if not 0.0 <= b.stay < 1.0 or len(b.gain) != 2 or not all(np.isfinite(b.gain)):
            raise ValueError(f"border: stay must lie in [0, 1) and gain be two finite numbers, got {b.stay}, {list(b.gain)}")
        if len(b.short.edges) != len(BORDER_EDGES):
            raise ValueError(f"border: short must be a table over {len(BORDER_EDGES)} features (side, image velocity u), got {len(b.short.edges)}")
        return b


@dataclass
class DetectorModel:
    """One detector's fitted behaviour (see the module docstring; unused parts stay default)."""

    detect: Table = field(default_factory=lambda: constant(1.0))
    rho: float = 0.0  # frame correlation of the miss copula
    err_rho: float = 0.0  # frame correlation of a person's measurement errors (Gaussian copula)
    merge: Table = field(default_factory=lambda: constant(0.0))
    merge_rho: float = 0.0  # frame correlation of a pair's merge copula (merges come in runs)
    # per frame, the uniform behind a miss (a merge) is kept with this probability
    # (``run_events``); None: the AR(1) copulas of rho and merge_rho instead (older models)
    miss_stay: float | None = None
    merge_stay: float | None = None
    # (bearing blobs) the stay of the misses of people seen whole (all rays reach them, wholly in
    # the image), whose misses are the detector's own and short, while partly hidden people's
    # last as long as the occlusion (``miss_stay``); None: ``miss_stay`` for everyone (older models)
    miss_stay_whole: float | None = None
    errors: dict[str, Quantiles] = field(default_factory=dict)
    label: float = 1.0
    clutter: float = 0.0  # false detections per camera frame
    clutter_frames: float = 1.0  # mean life of a clutter window, frames
    clutter_unlabelled: float = 0.0  # share of false blobs with no appearance label ("")
    fragment: float = 0.0  # extra detections on a detected person, per detected person-frame
    fragment_frames: float = 1.0  # mean life of a fragment window, frames
    fragment_label: float = 1.0  # share of fragment blobs labelled with the person's colour (else "")
    # (windows) partial windows of a moving person the detector missed (a flow region on part of
    # the body): windows per missed person-frame by the seen share of rays; None: none and no
    # random draws (models before them)
    partial: Table | None = None
    partial_frames: float = 1.0  # mean life of a partial window, frames
    # (windows) the seen share of rays that detection and partial windows depend on is its mean
    # over this many frames (``analytic_detectors.seen_share``); 1: the frame's own (models before it)
    seen_frames: int = 1
    restart: float = 0.0  # per frame, an id that continues is replaced by a new one
    swap: float = 0.0  # at a split, the merged window's id goes to the other person
    max_gap: int = 2  # frames a window's id survives without a window
    # overhead, privacy: per floor error table (``analytic_detectors.FLOOR_TABLES``) the share of
    # the geometric head-height shift (``CameraGeometry.head_shift``) in the radial error
    head_gain: dict[str, float] = field(default_factory=dict)
    tail: Tail | None = None  # overhead, privacy: drift episodes (None: models before them draw none)
    # (windows) the flow errors' persistence (w, a_slow, a_fast): their copula is the two-timescale
    # Gaussian ``two_timescale_normals``; None: err_rho's AR(1), as the other errors (models before it)
    flow_persist: tuple[float, float, float] | None = None
    # (windows) the person's image heights (px) between the edge tables' height bins: a window's
    # edge errors come from ``<edge>_h<bin>`` where the model has it (``analytic_detectors.
    # height_bin``; the thirteenth fit, not bundled); None: one table for every height
    edge_heights: list[float] | None = None
    # (windows) the top and bottom edge errors' correlation (``EdgeCorr``; the fourteenth fit,
    # not bundled); None: drawn independently (models before it draw as before)
    edge_corr: EdgeCorr | None = None
    # (windows) windows of a border-cut person stopping short of the border (``Border``; the
    # fifteenth fit); None: every such window reaches it (models before it draw as before)
    border: Border | None = None

    def error(self, name: str) -> Quantiles:
        return self.errors.get(name) or Quantiles.gaussian(0.0)

    @property
    def detects_by_head(self) -> bool:
        """(windows) whether detection depends on the head ray (a table over the axis rays' seen
        share, the head ray's and the image speed: the twelfth fit on)."""
        return len(self.detect.edges) == 3

    @property
    def uses_head(self) -> bool:
        """(windows) whether detection or partial windows depend on the head ray (a partial table
        over two features)."""
        return self.detects_by_head or (self.partial is not None and len(self.partial.edges) == 2)

    def to_dict(self) -> dict:
        return {
            "detect": self.detect.to_dict(), "rho": round(self.rho, 4), "err_rho": round(self.err_rho, 4), "merge": self.merge.to_dict(),
            "merge_rho": round(self.merge_rho, 4),
            **{k: round(v, 5) for k, v in (("miss_stay", self.miss_stay), ("miss_stay_whole", self.miss_stay_whole),
                                           ("merge_stay", self.merge_stay)) if v is not None},
            "errors": {k: v.to_dict() for k, v in self.errors.items()}, "label": round(self.label, 6),
            "clutter": round(self.clutter, 6), "clutter_frames": round(self.clutter_frames, 3),
            "clutter_unlabelled": round(self.clutter_unlabelled, 6), "fragment": round(self.fragment, 6),
            "fragment_frames": round(self.fragment_frames, 3), "fragment_label": round(self.fragment_label, 6),
            "restart": round(self.restart, 6), "swap": round(self.swap, 6), "max_gap": int(self.max_gap),
            **({"partial": self.partial.to_dict(), "partial_frames": round(self.partial_frames, 3)} if self.partial is not None else {}),
            **({"seen_frames": int(self.seen_frames)} if self.seen_frames > 1 else {}),
            **({"head_gain": {k: round(v, 4) for k, v in self.head_gain.items()}} if self.head_gain else {}),
            **({"tail": self.tail.to_dict()} if self.tail is not None else {}),
            **({"flow_persist": [round(x, 4) for x in self.flow_persist]} if self.flow_persist is not None else {}),
            **({"edge_heights": [float(x) for x in self.edge_heights]} if self.edge_heights is not None else {}),
            **({"edge_corr": self.edge_corr.to_dict()} if self.edge_corr is not None else {}),
            **({"border": self.border.to_dict()} if self.border is not None else {}),
        }

    @classmethod
    def from_dict(cls, d) -> "DetectorModel":
        m = cls(detect=Table.from_dict(d["detect"]), rho=float(d["rho"]), err_rho=float(d["err_rho"]), merge=Table.from_dict(d["merge"]),
                merge_rho=float(d["merge_rho"]),
                miss_stay=float(d["miss_stay"]) if "miss_stay" in d else None,
                merge_stay=float(d["merge_stay"]) if "merge_stay" in d else None,
                miss_stay_whole=float(d["miss_stay_whole"]) if "miss_stay_whole" in d else None,
                errors={k: Quantiles.from_dict(v) for k, v in d["errors"].items()}, label=float(d["label"]),
                clutter=float(d["clutter"]), clutter_frames=float(d["clutter_frames"]),
                clutter_unlabelled=float(d["clutter_unlabelled"]), fragment=float(d["fragment"]),
                fragment_frames=float(d["fragment_frames"]), fragment_label=float(d["fragment_label"]), restart=float(d["restart"]),
                swap=float(d["swap"]), max_gap=int(d["max_gap"]),
                partial=Table.from_dict(d["partial"]) if "partial" in d else None, partial_frames=float(d.get("partial_frames", 1.0)),
                seen_frames=int(d.get("seen_frames", 1)),
                head_gain={str(k): float(v) for k, v in d.get("head_gain", {}).items()},
                tail=Tail.from_dict(d["tail"]) if "tail" in d else None,
                flow_persist=tuple(float(x) for x in d["flow_persist"]) if "flow_persist" in d else None,
                edge_heights=[float(x) for x in d["edge_heights"]] if "edge_heights" in d else None,
                edge_corr=EdgeCorr.from_dict(d["edge_corr"]) if "edge_corr" in d else None,
                border=Border.from_dict(d["border"]) if "border" in d else None)
        if m.edge_heights is not None:
            check_heights(m.edge_heights, "edge_heights")
        if m.flow_persist is not None and (len(m.flow_persist) != 3 or not all(0.0 <= x <= 1.0 for x in m.flow_persist)
                                           or max(m.flow_persist[1:]) >= 1.0):
            raise ValueError(f"flow_persist must be (w, a_slow, a_fast), w in [0, 1] and both a in [0, 1), got {m.flow_persist}")
        for name in ("rho", "err_rho", "merge_rho", "label", "restart", "swap", "clutter_unlabelled", "fragment_label"):
            if not 0.0 <= getattr(m, name) <= 1.0:
                raise ValueError(f"{name} must lie in [0, 1], got {getattr(m, name)}")
        for name in ("miss_stay", "miss_stay_whole", "merge_stay"):
            v = getattr(m, name)
            if v is not None and not 0.0 <= v < 1.0:
                raise ValueError(f"{name} must lie in [0, 1), got {v}")
        if not all(np.isfinite(v) for v in m.head_gain.values()):
            raise ValueError("head_gain values must be finite")
        if m.clutter < 0 or m.fragment < 0 or m.clutter_frames < 1 or m.fragment_frames < 1 or m.max_gap < 0:
            raise ValueError("clutter and fragment must be >= 0, clutter_frames and fragment_frames >= 1, max_gap >= 0")
        if m.partial_frames < 1 or m.seen_frames < 1:
            raise ValueError("partial_frames and seen_frames must be >= 1")
        return m


@dataclass
class PerceptionModel:
    """Every detector's model, with where it came from (``fitted_on``)."""

    detectors: dict[str, DetectorModel]
    fitted_on: list[str] = field(default_factory=list)
    ideal: bool = False
    sha256: str = ""  # of the file it was loaded from ("ideal" for ideal perception; see model_sha256)

    def __getitem__(self, name: str) -> DetectorModel:
        return self.detectors[name]

    @property
    def uses_head(self) -> bool:
        """Whether analytic sensing must cast the oblique cameras' head rays (``Occlusion.head``)."""
        return not self.ideal and "windows" in self.detectors and self.detectors["windows"].uses_head

    def noise_figures(self, kinds=("horizontal",)) -> dict[str, float]:
        """The measured noise a user of the network would quote (calibration.noise): bearing and
        floor noise. The bearing noise is the horizontal cameras' where ``kinds`` (camera kinds)
        has them, else the oblique cameras'. The flow windows' noise is not among them: target
        planes need it against the body axis of walking people, which the flow detector's
        hand-measured figures (``RENDERED_WINDOW_NOISE``) give."""
        if self.ideal:
            return {}
        h, b, w, o, p = (self.detectors[k] for k in DETECTORS)
        return {
            "bearing_sigma_px": round((h if "horizontal" in kinds or "oblique" not in kinds else b).error("u").sigma, 3),
            "floor_sigma_m": round(o.error("xy").sigma, 4),
            "privacy_floor_sigma_m": round(p.error("xy").sigma, 4),
        }

    def to_dict(self) -> dict:
        return {"format": FORMAT, "fitted_on": list(self.fitted_on),
                "detectors": {k: v.to_dict() for k, v in self.detectors.items()}}

    def save(self, path: Path) -> None:
        """Write the model as JSON, atomically (``trackroom.dataset.atomic_write``)."""
        from trackroom.dataset import atomic_write

        text = json.dumps(self.to_dict(), indent=1) + "\n"
        atomic_write(Path(path), lambda p: p.write_text(text))

    @classmethod
    def from_dict(cls, d, where: str = "perception model") -> "PerceptionModel":
        if isinstance(d, dict) and d.get("format") in OLD_FORMATS:
            raise ModelError(f"{where}: written by an older trackroom ({d['format']}); refit it with "
                             f"`trackroom calibrate-sensing` (this version reads {FORMAT})")
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise ModelError(f"{where}: not a perception model (its 'format' must be {FORMAT!r})")
        dets = d.get("detectors")
        missing = [k for k in DETECTORS if not isinstance(dets, dict) or k not in dets]
        if missing:
            raise ModelError(f"{where}: no model for detector(s) {', '.join(missing)}")
        out = {}
        for k in DETECTORS:
            try:
                out[k] = DetectorModel.from_dict(dets[k])
            except (KeyError, TypeError, ValueError) as e:
                msg = f"missing key {e}" if isinstance(e, KeyError) else str(e)
                raise ModelError(f"{where}: detector {k!r}: {msg}") from None
        return cls(out, [str(s) for s in d.get("fitted_on", [])])


def ideal_model() -> PerceptionModel:
    """Every visible person detected, exact labels, no merges, ids per person (noise comes from
    the scene's ``sensors`` figures; see ``sim.analytic``)."""
    return PerceptionModel({k: DetectorModel(max_gap=0) for k in DETECTORS}, ["ideal"], ideal=True, sha256="ideal")


def model_path(spec: str | Path) -> Path:
    """The file a model spec other than "ideal" names: the bundled model for "fitted"."""
    return DEFAULT_FILE if str(spec) == "fitted" else Path(spec)


def model_sha256(spec: str | Path) -> str | None:
    """What identifies the model ``spec`` names: "ideal", or the SHA-256 of the model file's bytes
    (None when it cannot be read). Recordings keep it (``meta.perception``, from the loaded
    model's ``sha256``) and compare's cache checks it, so a refitted model is never mixed with
    recordings of an older one."""
    if str(spec) == "ideal":
        return "ideal"
    try:
        return hashlib.sha256(model_path(spec).read_bytes()).hexdigest()
    except OSError:
        return None


def load_model(spec: str | Path) -> PerceptionModel:
    """``"fitted"`` (the bundled default), ``"ideal"``, or a model file's path."""
    if str(spec) == "ideal":
        return ideal_model()
    try:
        raw = model_path(spec).read_bytes()
        data = json.loads(raw.decode())
    except OSError as e:
        raise ModelError(f"perception model {spec}: cannot be read ({e.strerror or e})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ModelError(f"perception model {spec}: not JSON ({e})") from None
    model = PerceptionModel.from_dict(data, f"perception model {spec}")
    model.sha256 = hashlib.sha256(raw).hexdigest()
    return model


# ----------------------------------------------------------------------------- sampling helpers
def correlated_uniforms(rng: np.random.Generator, shape: tuple[int, int], rho: float) -> np.ndarray:
    """(F, P) uniforms, each column a Gaussian AR(1) with lag-one correlation ``rho`` pushed
    through the normal CDF: a miss (u > P(detect)) tends to last as long as rho makes it."""
    return ndtr(correlated_normals(rng, shape, rho))


def run_events(rng: np.random.Generator, p: np.ndarray, stay: float, eligible: np.ndarray) -> np.ndarray:
    """(F, P) bool events that come in runs: per column a uniform held from frame to frame,

        X[t] = eligible[t] and U[t] < p[t],
        U[t] = U[t-1] with probability ``stay``, else a fresh uniform,

    so the events take a share p[t] of the frames whatever ``stay`` is (U[t] is uniform), and with
    p constant a run lasts 1 / ((1 - stay)(1 - p)) frames on average. A run lasts while the
    uniform is held and p stays above it: a merge begun where two silhouettes touch lasts while
    they stay close (P(merge) non-increasing with their distance, ``perception_fit.fit``) and
    ends as they part. Computed without a loop over frames: each frame takes the uniform drawn
    at the last redraw."""
    F, P = p.shape
    redraw = rng.random((F, P)) >= stay
    redraw[0] = True
    frame = np.arange(F)[:, None]
    last = np.maximum.accumulate(np.where(redraw, frame, 0), axis=0)
    u = np.take_along_axis(rng.random((F, P)), last, axis=0)
    return eligible & (u < p)


def correlated_normals(rng: np.random.Generator, shape: tuple[int, int], rho: float) -> np.ndarray:
    """The standard normal AR(1) columns behind ``correlated_uniforms`` (ndtr of them gives those
    uniforms, element by element: a caller that needs a few takes ndtr of those alone)."""
    F, P = shape
    z = rng.standard_normal((F, P))
    if rho > 0 and F > 1:
        z[1:] *= math.sqrt(1 - rho * rho)
        z = ar1(z, rho)
    return z


def two_timescale_normals(rng: np.random.Generator, shape: tuple[int, int], w: float, a_slow: float, a_fast: float) -> np.ndarray:
    """(F, P) standard normals, each column sqrt(w) S + sqrt(1 - w) R with S and R unit AR(1)
    columns of lag-one correlations a_slow and a_fast: autocorrelation w a_slow^L + (1 - w) a_fast^L
    at lag L (a slow part of share w that one AR(1) cannot give with a fast one)."""
    return math.sqrt(w) * correlated_normals(rng, shape, a_slow) + math.sqrt(1.0 - w) * correlated_normals(rng, shape, a_fast)


def ar1(x: np.ndarray, a: float) -> np.ndarray:
    """y[t] = a y[t-1] + x[t] along axis 0 (y[0] = x[0]), as a prefix scan: log2(len) whole-array
    steps y[t] += a^s y[t-s], s = 1, 2, 4, ... (scipy.signal.lfilter gives the same to rounding,
    but importing scipy.signal costs a third of a second of every command's start-up)."""
    y = np.array(x, float, copy=True)
    s, p = 1, float(a)
    while s < len(y) and p != 0.0:
        y[s:] += p * y[:-s]  # p * y[:-s] is made whole before the sum is written back
        s, p = 2 * s, p * p
    return y


def _num(x: float):
    return x if math.isfinite(x) else ("inf" if x > 0 else "-inf")
