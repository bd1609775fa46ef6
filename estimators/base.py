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

from trackroom.recording import Calibration, Observations, RecordingError

TRACK_COLUMNS = ["t", "track_id", "x", "y"]
OPTIONAL_TRACK_COLUMNS = ["vx", "vy", "pxx", "pxy", "pyy", "phone_id"]

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
        missing = [k for k in cls.requires if not observations.has(k)]
        if missing:
            return f"needs {' and '.join(missing)} observations"
        if cls.requires_any and not any(observations.has(k) for k in cls.requires_any):
            return f"needs {' or '.join(cls.requires_any)} observations"
        return None

    def estimate(self, observations: Observations, calibration: Calibration) -> pd.DataFrame:
        raise NotImplementedError


def check_tracks(df: pd.DataFrame, name: str = "tracks") -> pd.DataFrame:
    """Validate an estimator's output table; returns it with columns in canonical order."""
    missing = [c for c in TRACK_COLUMNS if c not in df.columns]
    if missing:
        raise EstimatorError(f"{name}: missing columns {missing}")
    for c in ("t", "x", "y"):
        if len(df) and not np.isfinite(df[c].to_numpy(float)).all():
            raise EstimatorError(f"{name}: non-finite values in column {c!r}")
    cols = TRACK_COLUMNS + [c for c in OPTIONAL_TRACK_COLUMNS if c in df.columns]
    return df[cols].sort_values(["t", "track_id"], kind="stable").reset_index(drop=True)


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
    "REGISTRY", "Estimator", "EstimatorError", "RecordingError", "TRACK_COLUMNS", "check_tracks", "coerce_param",
    "coerce_value", "config_types", "param", "register", "type_text", "value_text",
]
