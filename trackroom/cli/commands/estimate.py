"""trackroom estimate: run one estimator on a recording folder and write its tracks as CSV."""
from __future__ import annotations

from trackroom.cli.commands import add_plugin_argument

NAME = "estimate"
HELP = "run an estimator on a recording folder and write tracks.csv (t, track_id, x, y, ...)"


def add_arguments(p) -> None:
    p.add_argument("recording", metavar="DIR", nargs="?", help="recording folder (from trackroom generate)")
    p.add_argument("--estimator", help="estimator name (trackroom estimate --list or trackroom estimators shows them)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="estimator parameter, parsed by its type, e.g. --param smooth=true (repeatable; --list shows them)")
    p.add_argument("--out", help="output CSV file")
    p.add_argument("--list", action="store_true", help="list the estimators, what they need and their parameters, and exit")
    add_plugin_argument(p)


def run(args) -> int:
    from pathlib import Path

    from trackroom.dataset import read_recording
    from trackroom.errors import CommandError
    from trackroom.estimators import get
    from trackroom.estimators.runner import parse_params, run_estimator

    if args.list:
        from trackroom.cli.commands.estimators import listing

        print(listing())
        return 0
    missing = [what for what, v in (("a recording folder DIR", args.recording), ("--estimator", args.estimator),
                                    ("--out", args.out)) if not v]
    if missing:
        raise CommandError(f"give {', '.join(missing)} (or --list to see the estimators)")
    params = parse_params(get(args.estimator), args.param)  # a bad name or value fails before any reading
    rec = read_recording(args.recording)
    result = run_estimator(rec, args.estimator, params)
    if result.status == "skipped":
        raise CommandError(f"{args.estimator} does not apply to {args.recording}: {result.reason}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    result.tracks.to_csv(out, index=False, float_format="%.6f")
    n = result.tracks["track_id"].nunique()
    print(f"{args.estimator}: {len(result.tracks)} rows, {n} tracks in {result.seconds:.2f} s -> {out}")
    return 0
