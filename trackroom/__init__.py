"""trackroom: a simulation-and-evaluation testbed for tracking people with sparse camera networks
and phone IMUs.

One installed package. Its sub-packages live in the repository's top-level folders and are mapped
here by setuptools' ``package-dir``:

- ``trackroom.scenes``: the scene language and camera geometry (numpy only)
- ``trackroom.sim``: the MuJoCo world, walkers, sensing (analytic and rendered), simulation
- ``trackroom.recording`` / ``trackroom.dataset``: the recording contract and recording folders
  (no simulator needed: a recording from elsewhere can be read, checked and scored)
- ``trackroom.estimators``: the estimators and their registry (bundled and plug-ins)
- ``trackroom.metrics``: CLEAR MOT, identity, position error, the Cramér-Rao bound, tables
- ``trackroom.cli``: the ``trackroom`` command (one module per sub-command)

See ``docs/api.md`` for the Python API.
"""
from __future__ import annotations

from pathlib import Path as _Path

try:
    from importlib.metadata import PackageNotFoundError as _NotFound, version as _version

    __version__ = _version("trackroom")
except _NotFound:  # running from a checkout that was never installed
    __version__ = "0+unknown"

_checkout = _Path(__file__).resolve().parent.parent
if (_checkout / "pyproject.toml").is_file() and (_checkout / "sim" / "__init__.py").is_file():
    # A source checkout: the sub-packages are the repository's top-level folders. Installed (even
    # non-editable) copies are shadowed by this folder when Python runs from the repository root,
    # so the checkout's folders must be found from here too.
    __path__.append(str(_checkout))  # noqa: F821  (package __path__)
