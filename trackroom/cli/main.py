"""The ``trackroom`` command line.

Each sub-command is a module in ``trackroom/cli/commands/`` with ``NAME``, ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``; adding a command is adding a module.
Expected failures (bad scene files, bad recordings, bad arguments) exit with status 2 and one
clear line on stderr, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering on the CPU; set before mujoco loads
# One BLAS thread per process: the problems here are small or sparse, comparisons run one process
# per core, and spinning BLAS threads on a busy 2-core machine made small dense solves ~700x slower.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


from trackroom.errors import CommandError  # noqa: E402  (re-exported: commands raise it)


def _expected_errors() -> tuple[type[BaseException], ...]:
    from trackroom.estimators.base import EstimatorError
    from trackroom.scenes.loader import SceneError
    from trackroom.recording import RecordingError

    return (CommandError, SceneError, RecordingError, EstimatorError, FileNotFoundError, FileExistsError)


def _version_line() -> str:
    from trackroom.provenance import versions

    v = versions()
    commit = f" (git {v['git_commit'][:12]}{'+dirty' if v['git_commit'].endswith('+dirty') else ''})" if v.get("git_commit") else ""
    return f"trackroom {v['trackroom']}{commit}"


def build_parser() -> argparse.ArgumentParser:
    import trackroom.cli.commands as pkg

    parser = argparse.ArgumentParser(prog="trackroom", description="Tracking testbed: scenes, simulation, estimators, metrics.")
    parser.add_argument("--version", action="version", version=_version_line())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda i: i.name):
        mod = importlib.import_module(f"{pkg.__name__}.{info.name}")
        if not hasattr(mod, "NAME"):
            continue
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        if getattr(args, "plugin", None):
            from trackroom.estimators import load_plugins

            load_plugins(args.plugin)
        return int(args._run(args) or 0)
    except _expected_errors() as e:
        msg = str(e) if not isinstance(e, (FileNotFoundError, FileExistsError)) else f"{e.strerror}: {e.filename}"
        print(f"trackroom {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
