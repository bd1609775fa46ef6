"""Estimators: recordings' observations + calibration -> tracks. Registry by name.

Estimators come from three places, and are used alike once registered (``@register``):

- the bundled modules of this package (every module that defines an estimator registers it;
  ``available()`` imports them all, so adding an estimator is adding a module);
- installed plug-ins: the ``trackroom.estimators`` entry-point group, each entry point naming a
  module (importing it registers its estimators) or an ``Estimator`` subclass (registered here);
- ``load_plugin(spec)``: a module by dotted name, or a path to a ``.py`` file (``--plugin`` on
  the command line).

A plug-in that fails to import raises one ``EstimatorError`` naming the plug-in.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import pkgutil
import sys
from importlib.metadata import entry_points
from pathlib import Path
from types import ModuleType

from .base import REGISTRY, Estimator, EstimatorError, check_tracks, param, register

ENTRY_POINT_GROUP = "trackroom.estimators"
# where each registered estimator came from ("bundled", "entry point NAME (DIST)", "plugin SPEC")
SOURCES: dict[str, str] = {}
_loaded: dict[str, list[str]] = {}  # plug-in spec -> the estimator names it registered
_state = {"bundled": False, "entry_points": False}


def _load_bundled() -> None:
    if _state["bundled"]:
        return
    for info in pkgutil.iter_modules(__path__):
        if info.name not in ("base",) and not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")
    for name, cls in REGISTRY.items():
        if cls.__module__.startswith(__name__ + "."):
            SOURCES.setdefault(name, "bundled")
    _state["bundled"] = True


def _load_entry_points() -> None:
    if _state["entry_points"]:
        return
    _state["entry_points"] = True  # a failing plug-in is reported once, not retried on every lookup
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        dist = f" ({ep.dist.name})" if getattr(ep, "dist", None) is not None else ""
        what = f"plugin {ep.name!r} (entry point {ep.value!r}{dist} in group {ENTRY_POINT_GROUP})"
        before = set(REGISTRY)
        try:
            obj = ep.load()
            if isinstance(obj, type):
                register(obj)
            elif not isinstance(obj, ModuleType):
                raise EstimatorError(f"names {type(obj).__name__} {obj!r}, neither a module nor an Estimator subclass")
        except Exception as e:
            _state["entry_points"] = False
            raise EstimatorError(f"{what} failed to load: {_reason(e)}") from None
        names = _registered_by(obj if isinstance(obj, ModuleType) else sys.modules.get(obj.__module__), before)
        if isinstance(obj, type):
            names = sorted(set(names) | {obj.name})
        for n in names:
            SOURCES.setdefault(n, f"entry point {ep.name}{dist}")


def _reason(e: BaseException) -> str:
    return str(e) if isinstance(e, EstimatorError) else f"{type(e).__name__}: {e}"


def _registered_by(mod: ModuleType | None, before: set[str]) -> list[str]:
    """Names a module registered: new in the registry, or classes defined in it (or its package)."""
    new = set(REGISTRY) - before
    if mod is not None:
        prefix = mod.__name__
        new |= {n for n, c in REGISTRY.items() if c.__module__ == prefix or c.__module__.startswith(prefix + ".")}
    return sorted(new)


def is_plugin_path(spec: str) -> bool:
    """A plug-in given as a file (``.py`` or a path with a separator), not a dotted module name."""
    return spec.endswith(".py") or "/" in spec or "\\" in spec


def resolve_plugin(spec: str, base: str | Path | None = None) -> str:
    """A plug-in spec other processes can load: a file path made absolute (relative to ``base``,
    default the working folder); a module name as is."""
    spec = spec.strip()
    if not is_plugin_path(spec):
        return spec
    p = Path(spec).expanduser()
    if not p.is_absolute() and base is not None:
        p = Path(base) / p
    return str(p.resolve())


def load_plugin(spec: str) -> list[str]:
    """Import a plug-in (a dotted module name or a path to a ``.py`` file) and return the names of
    the estimators it registered. Loading the same plug-in again does nothing."""
    spec = spec.strip()
    if spec in _loaded:
        return _loaded[spec]
    _load_bundled()
    before = set(REGISTRY)
    if not spec:
        raise EstimatorError("plugin '': give a module name or a path to a .py file")
    if is_plugin_path(spec):
        mod = _import_file(spec)
    else:
        try:
            mod = importlib.import_module(spec)
        except ModuleNotFoundError as e:
            if e.name and (spec == e.name or spec.startswith(e.name + ".")):
                raise EstimatorError(f"plugin {spec!r}: no module named {e.name!r} (give an importable module name "
                                     "or a path to a .py file)") from None
            raise EstimatorError(f"plugin {spec!r} failed to import: {_reason(e)}") from None
        except Exception as e:
            raise EstimatorError(f"plugin {spec!r} failed to import: {_reason(e)}") from None
    names = _registered_by(mod, before)
    if not names:
        raise EstimatorError(f"plugin {spec!r} registers no estimator (decorate an Estimator subclass with "
                             "@trackroom.estimators.register)")
    for n in names:
        SOURCES.setdefault(n, f"plugin {spec}")
    _loaded[spec] = names
    return names


def _import_file(spec: str) -> ModuleType:
    path = Path(spec).expanduser().resolve()
    if not path.is_file():
        raise EstimatorError(f"plugin {spec!r}: no such file")
    # one module name per file, so loading it again (another spec for the same file) reuses it
    name = f"trackroom_plugin_{path.stem}_{hashlib.sha1(str(path).encode()).hexdigest()[:8]}"
    if name in sys.modules:
        return sys.modules[name]
    mspec = importlib.util.spec_from_file_location(name, path)
    if mspec is None or mspec.loader is None:
        raise EstimatorError(f"plugin {spec!r}: not a Python file")
    mod = importlib.util.module_from_spec(mspec)
    sys.modules[name] = mod  # dataclasses look their module up while the file runs
    try:
        mspec.loader.exec_module(mod)
    except Exception as e:
        del sys.modules[name]
        raise EstimatorError(f"plugin {spec!r} failed to import: {_reason(e)}") from None
    return mod


def load_plugins(specs) -> list[str]:
    """``load_plugin`` for each; the names registered, in order."""
    return [n for s in specs or () for n in load_plugin(s)]


def available() -> dict[str, type[Estimator]]:
    """All registered estimators (bundled, installed plug-ins, loaded plug-ins), by name."""
    _load_bundled()
    _load_entry_points()
    return dict(sorted(REGISTRY.items()))


def source(name: str) -> str:
    """Where a registered estimator came from: bundled, an entry point or a plug-in spec."""
    available()
    return SOURCES.get(name, f"module {REGISTRY[name].__module__}")


def get(name: str) -> type[Estimator]:
    est = available()
    if name not in est:
        raise EstimatorError(f"unknown estimator {name!r}; available: {', '.join(est) or 'none'}"
                             + ("" if _loaded else " (an estimator of your own: --plugin MODULE)"))
    return est[name]


__all__ = [
    "ENTRY_POINT_GROUP", "Estimator", "EstimatorError", "available", "check_tracks", "get", "load_plugin",
    "load_plugins", "param", "register", "resolve_plugin", "source",
]
