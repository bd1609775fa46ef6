"""The estimator interface and the registry.

An estimator is configured in its constructor (a typed ``Config`` dataclass of parameters with
defaults; no work done there) and does its work in one method::

    tracks = Estimator(**params).estimate(observations, calibration)

It never sees ground truth. ``requires`` lists observation kinds that must all be present;
``requires_any`` lists kinds of which at least one must be present. ``applies_to`` tells the
runner why an estimator does not apply to a recording (or None when it does).

Every Config field carries a one-line doc, with units, in its field metadata (``param(default,
doc)`` is ``dataclasses.field(default=default, metadata={"doc": doc})``); ``trackroom estimators``
lists them. Parameters are parsed strictly by their annotated type (``coerce_param`` for
command-line text, ``coerce_value`` for values from a dict or Python): a bool is true or false,
an int an integer, a float a finite number, a list a list; ``Optional`` also takes none.

Tracks are a DataFrame with columns ``t, track_id, x, y`` and optionally ``vx, vy`` (m/s),
``pxx, pxy, pyy`` (position covariance, m^2) and ``phone_id`` (the identity claimed; "" for none).
"""
from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import re
import tomllib
import types
import typing
from typing import Any, ClassVar, Literal, Union

import numpy as np
import pandas as pd

from trackroom.recording import OBSERVATION_COLUMNS, STRING_COLUMNS, Calibration, Observations, RecordingError

TRACK_COLUMNS = ["t", "track_id", "x", "y"]
OPTIONAL_TRACK_COLUMNS = ["vx", "vy", "pxx", "pxy", "pyy", "phone_id"]
# an estimator's per-camera status (``Estimator.estimate_with_status``): t (s), track_id, camera,
# status (e.g. tracking / unreliable / lost), reason (free text, "" none)
CAMERA_STATUS_COLUMNS = ["t", "track_id", "camera", "status", "reason"]

REGISTRY: dict[str, type["Estimator"]] = {}


class EstimatorError(ValueError):
    """An estimator cannot run on its input; the message says why."""


def register(cls):
    """Class decorator: add an estimator to the registry under ``cls.name``."""
    if not (isinstance(cls, type) and issubclass(cls, Estimator)):
        raise EstimatorError(f"register: {cls!r} is not a subclass of trackroom.estimators.Estimator")
    if not cls.name or not isinstance(cls.name, str):
        raise EstimatorError(f"register: {cls.__module__}.{cls.__qualname__} has no name (set the class attribute name)")
    if not dataclasses.is_dataclass(cls.Config):
        raise EstimatorError(f"register: {cls.name}: Config must be a dataclass")
    old = REGISTRY.get(cls.name)
    if old is not None and old is not cls:
        raise EstimatorError(f"estimator name {cls.name!r} registered twice ({old.__module__} and {cls.__module__})")
    REGISTRY[cls.name] = cls
    return cls


def param(default: Any, doc: str) -> Any:
    """A Config field with its one-line doc (units included), shown by ``trackroom estimators``."""
    return dataclasses.field(default=default, metadata={"doc": doc})


class Estimator:
    """Base class: subclasses set ``name``, ``Config``, ``requires``/``requires_any`` and
    implement ``estimate``."""

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()
    requires_any: ClassVar[tuple[str, ...]] = ()

    @dataclasses.dataclass
    class Config:
        pass

    def __init__(self, **params: Any):
        fields = {f.name: f for f in dataclasses.fields(self.Config)}
        unknown = sorted(set(params) - set(fields))
        if unknown:
            raise EstimatorError(
                f"{self.name}: unknown parameter(s) {unknown}; known: {sorted(fields)}"
            )
        required = sorted(n for n, f in fields.items() if n not in params and f.default is dataclasses.MISSING
                          and f.default_factory is dataclasses.MISSING)
        if required:
            raise EstimatorError(f"{self.name}: give parameter(s) {required} (they have no default)")
        self.config = self.Config(**{k: coerce_value(type(self), k, v) for k, v in params.items()})

    @classmethod
    def applies_to(cls, observations: Observations, calibration: Calibration) -> str | None:
        """None if the estimator can run on this input, else the reason it cannot."""
        # "has none" rather than "needs": the table may exist and be empty (no camera saw anyone)
        missing = [k for k in cls.requires if not observations.has(k)]
        if missing:
            return f"needs {' and '.join(missing)} observations; the recording has none"
        if cls.requires_any and not any(observations.has(k) for k in cls.requires_any):
            return f"needs {' or '.join(cls.requires_any)} observations; the recording has none"
        return None

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        raise NotImplementedError

    def estimate_with_status(self, observations: Observations,
                             calibration: Calibration) -> tuple[pd.DataFrame, pd.DataFrame | None]:
        """The tracks and, for an estimator that keeps one, its per-camera status table
        (``CAMERA_STATUS_COLUMNS``: per frame, track and camera whether the camera tracks the
        person, and why not); None for the others. Reports draw it as a timeline."""
        return self.estimate(observations, calibration), None


def _show(value) -> str:
    """A table cell for a message: text quoted, numbers plain (no numpy type names)."""
    return repr(value) if isinstance(value, str) else str(value.item() if hasattr(value, "item") else value)


def check_tracks(df: pd.DataFrame, name: str = "tracks", first_line: int | None = None) -> pd.DataFrame:
    """Validate a tracks table (an estimator's output, or a tracks CSV); returns it with columns in
    canonical order, ``t, x, y`` (and ``vx ... pyy`` when present) as floats, sorted by time.

    Refused with ``EstimatorError`` naming the column and the first bad row: a missing column, a
    ``t, x, y`` value that is not a finite number, a missing ``track_id``, and one track reporting
    twice at one time (which position would be scored is ambiguous). ``first_line``: the file line
    of the table's first row (2 for a CSV with a header), so messages name lines, not row indices.
    """
    if not isinstance(df, pd.DataFrame):
        raise EstimatorError(f"{name}: not a table (got {type(df).__name__})")
    missing = [c for c in TRACK_COLUMNS if c not in df.columns]
    if missing:
        raise EstimatorError(f"{name}: missing columns {missing}")
    where = (lambda i: f"line {first_line + i}") if first_line is not None else (lambda i: f"row {i}")
    df = df.reset_index(drop=True)
    numbers = {}
    for c in ("t", "x", "y", "vx", "vy", "pxx", "pxy", "pyy"):
        if c not in df.columns:
            continue
        values = pd.to_numeric(df[c], errors="coerce").to_numpy(float) if len(df) else np.zeros(0)
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            raise EstimatorError(f"{name}: column {c!r} must hold finite numbers; {where(i)} has {_show(df[c].iloc[i])}")
        numbers[c] = values
    ids = df["track_id"]
    empty = (ids.isna() | (ids.astype(str).str.strip() == "")).to_numpy(bool)
    if empty.any():
        raise EstimatorError(f"{name}: column 'track_id' is empty at {where(int(np.argmax(empty)))}; every row needs a track id")
    if ids.dtype == object and len({type(v) for v in ids}) > 1:
        numbers["track_id"] = ids.astype(str)  # mixed ids (1 and "1b") compare and sort as text
    df = df.assign(**numbers)
    ids = df["track_id"]
    twice = df.duplicated(["t", "track_id"]).to_numpy(bool)
    if twice.any():
        i = int(np.argmax(twice))
        raise EstimatorError(f"{name}: track {_show(ids.iloc[i])} has two rows at t = {df['t'].iloc[i]:g} s ({where(i)})")
    cols = TRACK_COLUMNS + [c for c in OPTIONAL_TRACK_COLUMNS if c in df.columns]
    return df[cols].sort_values(["t", "track_id"], kind="stable").reset_index(drop=True)


TIME_TOL = 1e-6  # s: an observation this far outside [0, duration] is still taken as inside
# Image coordinates (pixels) and the camera dimension they run along.
IMAGE_COLUMNS = {
    "bearings": (("u", "width"),),
    "boxes": (("u", "width"), ("u_left", "width"), ("u_right", "width"), ("v_top", "height"), ("v_bottom", "height")),
}


def check_observations(observations: Observations, calibration: Calibration) -> Observations:
    """Validate observations at the estimator boundary; returns them in canonical form.

    Every table must have its documented columns (``OBSERVATION_COLUMNS``), numbers that are
    finite, names that are present, times within [0, duration] s, cameras that the calibration
    holds, and image coordinates (px) within one image size of the image. Rows out of time order
    are sorted by ``t`` (stable, so rows of one time keep their order): merged or hand-made
    tables often are, and no estimator should depend on it. Name columns are taken as text.
    Duplicated rows are kept: two detections of one time and place are legitimate measurements.
    Anything else raises ``RecordingError`` naming the table, the column and the first bad row.
    A camera in the calibration that sees nothing is no error; tables of kinds the contract does
    not define are passed on unchecked.
    """
    duration = observations.duration
    if isinstance(duration, bool) or not (isinstance(duration, numbers.Real) and np.isfinite(duration) and duration > 0):
        raise RecordingError(f"observations: duration must be a positive number of seconds, got {duration!r}")
    tables = {}
    for kind, df in observations.tables.items():
        cols = OBSERVATION_COLUMNS.get(kind)
        if cols is None:  # a table beyond the contract (an outside estimator's own): passed on as is
            tables[kind] = df
            continue
        if not isinstance(df, pd.DataFrame):
            raise RecordingError(f"{kind}: not a table (got {type(df).__name__})")
        missing = [c for c in cols if c not in df.columns]
        if missing:
            raise RecordingError(f"{kind}: missing columns {missing}")
        df = df.reset_index(drop=True)
        if not len(df):
            tables[kind] = df
            continue
        for c in cols:
            if c in STRING_COLUMNS:  # names (text); every other observation column is a number
                bad = df[c].isna().to_numpy()
                if bad.any():
                    raise RecordingError(f"{kind}: missing value in column {c!r} (first at row {int(np.argmax(bad))})")
                if df[c].dtype != object or not all(isinstance(v, str) for v in df[c]):
                    df[c] = df[c].astype(str)
                continue
            values = pd.to_numeric(df[c], errors="coerce").to_numpy(float)
            bad = ~np.isfinite(values)
            if bad.any():
                i = int(np.argmax(bad))
                raise RecordingError(f"{kind}: column {c!r} must hold finite numbers; row {i} has {_show(df[c].iloc[i])}")
            if not pd.api.types.is_numeric_dtype(df[c]) or pd.api.types.is_bool_dtype(df[c]):
                df[c] = values  # numbers written as text ("1.5") become numbers
        t = df["t"].to_numpy(float)
        out = (t < -TIME_TOL) | (t > duration + TIME_TOL)
        if out.any():
            i = int(np.argmax(out))
            raise RecordingError(f"{kind}: times must lie within the recording [0, {duration:g}] s; row {i} has t = {t[i]:g}")
        if "camera" in df.columns:
            unknown = sorted(set(df["camera"]) - set(calibration.cameras))
            if unknown:
                raise RecordingError(f"{kind}: cameras not in the calibration: {unknown}; calibrated: {sorted(calibration.cameras)}")
        for c, size in IMAGE_COLUMNS.get(kind, ()):
            # a detector reports inside its image, give or take noise; a value an image away is
            # corrupt (found by the property tests: u = 1e12 px made qp_smoother's QP non-convex)
            n = df["camera"].map({k: float(getattr(cam, size)) for k, cam in calibration.cameras.items()}).to_numpy(float)
            v = df[c].to_numpy(float)
            far = (v < -n) | (v > 2 * n)
            if far.any():
                i = int(np.argmax(far))
                raise RecordingError(f"{kind}: column {c!r} lies more than an image {size} outside camera "
                                     f"{df['camera'].iloc[i]!r}'s {n[i]:g} px image; row {i} has {v[i]:g}")
        if (np.diff(t) < 0).any():
            df = df.sort_values("t", kind="stable").reset_index(drop=True)
        tables[kind] = df
    return Observations(tables, float(duration))


class _Expected(Exception):
    """Internal: a value does not fit a type; ``what`` says what was expected."""

    def __init__(self, what: str):
        self.what = what


@functools.lru_cache(maxsize=None)
def config_types(config: type) -> dict[str, Any]:
    """The Config's fields and their annotated types (the annotation text where it cannot be
    resolved, which then takes any value)."""
    try:
        hints = typing.get_type_hints(config)
    except Exception:  # a plug-in's forward reference that does not resolve: no strict typing
        hints = {}
    return {f.name: hints.get(f.name, f.type) for f in dataclasses.fields(config)}


def _field(cls: type[Estimator], key: str) -> Any:
    types_ = config_types(cls.Config)
    if key not in types_:
        raise EstimatorError(f"{cls.name}: unknown parameter {key!r}; known: {sorted(types_)}")
    return types_[key]


def coerce_param(cls: type[Estimator], key: str, text: str) -> Any:
    """Parse a command-line ``k=v`` parameter (text) strictly into the type of the Config field:
    ``expected true or false, got 'maybe'`` and the like, as an ``EstimatorError``."""
    tp = _field(cls, key)
    try:
        return _convert(tp, text.strip(), text=True)
    except _Expected as e:
        raise EstimatorError(f"{cls.name}: parameter {key}: expected {e.what}, got {text.strip()!r}") from None


def coerce_value(cls: type[Estimator], key: str, value: Any) -> Any:
    """Check a parameter value (from a dict: a TOML table, Python) against the Config field's type;
    returns it converted (an int for a float field becomes a float, a list for a tuple a tuple)."""
    tp = _field(cls, key)
    try:
        return _convert(tp, value, text=False)
    except _Expected as e:
        raise EstimatorError(f"{cls.name}: parameter {key}: expected {e.what}, got {value!r}") from None


def type_text(tp: Any) -> str:
    """A Config type as a reader writes it: ``float``, ``float | None``, ``list[float]``."""
    if isinstance(tp, str):
        return tp
    if tp is type(None):
        return "None"
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (Union, types.UnionType):
        return " | ".join(type_text(a) for a in args)
    if origin is Literal:
        return " | ".join(repr(a) for a in args)
    if origin is not None and args:
        return f"{getattr(origin, '__name__', str(origin))}[{', '.join('...' if a is Ellipsis else type_text(a) for a in args)}]"
    return getattr(tp, "__name__", str(tp).replace("typing.", ""))


def value_text(value: Any) -> str:
    """A value as it is written in ``--param k=v``: true/false, none, numbers, text, [lists]."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "none"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    return str(value)


_INT = re.compile(r"[+-]?\d+")


def _convert(tp: Any, v: Any, text: bool) -> Any:
    """``v`` (command-line text when ``text``, else a value) as type ``tp``; raises ``_Expected``."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (Union, types.UnionType):
        optional = type(None) in args
        if v is None and optional:
            return None
        if text and optional and v.lower() in ("none", "null"):
            return None
        what = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(a, v, text)
            except _Expected as e:
                what.append(e.what)
        raise _Expected(" or ".join(what + (["none"] if optional else [])))
    if origin is Literal:
        for a in args:
            if (text and str(a) == _unquote(v)) or (not text and v == a and type(v) is type(a)):
                return a
        raise _Expected("one of " + ", ".join(value_text(a) for a in args))
    if tp is bool:
        if text and v.lower() in ("true", "false"):
            return v.lower() == "true"
        if not text and isinstance(v, (bool, np.bool_)):
            return bool(v)
        raise _Expected("true or false")
    if tp is int:
        if text and _INT.fullmatch(v):
            return int(v)
        if not text and isinstance(v, numbers.Integral) and not isinstance(v, bool):
            return int(v)
        raise _Expected("an integer")
    if tp is float:
        f = math.nan
        if text:
            try:
                f = float(v)
            except ValueError:
                pass
        elif isinstance(v, numbers.Real) and not isinstance(v, bool):
            f = float(v)
        if math.isfinite(f):
            return f
        raise _Expected("a finite number")
    if tp is str:
        if text:
            return _unquote(v)
        if isinstance(v, str):
            return v
        raise _Expected("text")
    if tp in (list, tuple) or origin in (list, tuple):
        return _convert_sequence(tp, origin or tp, args, v, text)
    # an annotation this parser does not know (Any, a class of the plug-in's own): as before, text
    # is read as a TOML value where it is one, else kept as text; values are passed on as they are
    return _toml_or_text(v) if text else v


def _convert_sequence(tp: Any, container: type, args: tuple, v: Any, text: bool) -> Any:
    if text:
        v = _toml_or_text(v)
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):
        v = v.tolist()  # a numpy array from Python code
    if not isinstance(v, (list, tuple)):
        raise _Expected(f"a list such as {_example(tp)}")
    items = list(v)
    if container is tuple and args and args[-1] is not Ellipsis:
        if len(items) != len(args):
            raise _Expected(f"a list of {len(args)} such as {_example(tp)}")
        item_types = list(args)
    else:
        item_types = [args[0] if args else Any] * len(items)
    out = []
    for i, (a, x) in enumerate(zip(item_types, items)):
        try:
            out.append(x if a is Any else _convert(a, x, text=False))
        except _Expected as e:
            raise _Expected(f"a list such as {_example(tp)} (item {i + 1}: expected {e.what})") from None
    return tuple(out) if container is tuple else out


def _example(tp: Any) -> str:
    args = [a for a in typing.get_args(tp) if a is not Ellipsis]
    sample = {bool: "true", int: "1", float: "1.0", str: '"a"'}
    if typing.get_origin(tp) is tuple and args and typing.get_args(tp)[-1] is not Ellipsis:
        return "[" + ", ".join(sample.get(a, "...") for a in args) + "]"
    first = sample.get(args[0], "...") if args else "1.0"
    return f"[{first}, {first}]"


def _unquote(text: str) -> str:
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        try:
            return tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            pass
    return text


def _toml_or_text(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


__all__ = [
    "REGISTRY", "Estimator", "EstimatorError", "RecordingError", "TRACK_COLUMNS", "check_observations", "check_tracks",
    "coerce_param", "coerce_value", "config_types", "param", "register", "type_text", "value_text",
]
