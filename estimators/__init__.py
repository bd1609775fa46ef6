"""Estimators: recordings' observations + calibration -> tracks. Registry by name.

Every module in this package that defines an estimator registers it with ``@register``;
``available()`` imports them all, so adding an estimator is adding a module.
"""
from __future__ import annotations

import importlib
import pkgutil

from .base import REGISTRY, Estimator, EstimatorError, check_tracks, register


def _load_all() -> None:
    for info in pkgutil.iter_modules(__path__):
        if info.name not in ("base",) and not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")


def available() -> dict[str, type[Estimator]]:
    """All registered estimators, by name."""
    _load_all()
    return dict(sorted(REGISTRY.items()))


def get(name: str) -> type[Estimator]:
    est = available()
    if name not in est:
        raise EstimatorError(f"unknown estimator {name!r}; available: {', '.join(est) or 'none'}")
    return est[name]


__all__ = ["Estimator", "EstimatorError", "available", "check_tracks", "get", "register"]
