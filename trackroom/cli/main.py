"""The ``trackroom`` command line.

Each sub-command is a module in ``trackroom/cli/commands/`` with ``NAME``, ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``; adding a command is adding a module.
Expected failures (bad scene files, bad recordings, bad arguments) exit with status 2 and one
clear line on stderr, never a traceback. Output piped into a reader that stops early
(``trackroom demo | head -1``) ends quietly, as a SIGPIPE would end a Unix tool (status 141).
Commands find their own command line (absolute paths made relative) in ``args._command``.
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


class _VersionAction(argparse.Action):
    """``--version``: the version line is computed only when asked for (it runs git)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show the version (and the git commit of a checkout) and exit"):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(_version_line())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    import trackroom.cli.commands as pkg

    parser = argparse.ArgumentParser(prog="trackroom", description="Tracking testbed: scenes, simulation, estimators, metrics.")
    parser.add_argument("--version", action=_VersionAction)
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
    from trackroom.provenance import command_line

    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    args._command = command_line(argv)
    try:
        if getattr(args, "plugin", None):
            from trackroom.estimators import load_plugins

            load_plugins(args.plugin)
        rc = int(args._run(args) or 0)
        sys.stdout.flush()  # here, not at exit, so a closed pipe is caught below
        return rc
    except BrokenPipeError:
        # The reader of our stdout went away (`| head`). Point stdout at /dev/null so the
        # interpreter's final flush cannot raise again, and end quietly (Python docs, "Note on SIGPIPE").
        _silence_stdout()
        return 141
    except _expected_errors() as e:
        msg = str(e) if not isinstance(e, (FileNotFoundError, FileExistsError)) else f"{e.strerror}: {e.filename}"
        print(f"trackroom {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def _silence_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass  # stdout is not a real file (e.g. captured in tests): nothing will flush to a pipe


if __name__ == "__main__":
    sys.exit(main())
