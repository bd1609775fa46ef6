"""Where a result came from: package versions, the git commit of a source checkout, the command line.

Recordings' manifests and comparisons' outputs carry these, so a table can be traced back to the
code and the command that made it.
"""
from __future__ import annotations

import functools
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

VERSIONED = ("trackroom", "mujoco", "numpy", "scipy", "pandas", "pyarrow", "osqp", "filterpy", "opencv-python-headless")


@functools.cache
def _versions() -> tuple:
    out = {"python": platform.python_version()}
    for name in VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    commit = git_commit()
    if commit:
        out["git_commit"] = commit
    return tuple(out.items())


def versions() -> dict[str, str]:
    """Python and package versions, and ``git_commit`` when running from a git checkout (read once
    per process)."""
    return dict(_versions())


@functools.cache
def git_commit() -> str | None:
    """The commit of the checkout this package runs from (``+dirty`` with uncommitted changes to
    tracked files), or None for an installed copy or without git."""
    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists() or not (root / "pyproject.toml").is_file():
        return None
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10)
        return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def command_line(argv: list[str]) -> list[str]:
    """``["trackroom", *argv]`` with every absolute path (a word, or the value of ``--opt=PATH`` or
    ``key=PATH``) made relative to the working directory, so records name no machine's folders."""
    def rel(word: str) -> str:
        if os.path.isabs(word):
            return os.path.relpath(word)
        opt, eq, value = word.partition("=")
        if eq and os.path.isabs(value):
            return f"{opt}={os.path.relpath(value)}"
        return word

    return ["trackroom", *(rel(str(w)) for w in argv)]
