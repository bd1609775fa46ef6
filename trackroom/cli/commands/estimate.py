"""trackroom estimate: run one estimator on a recording folder and write its tracks as CSV."""
from __future__ import annotations

NAME = "estimate"
HELP = "run an estimator on a recording folder and write tracks.csv (t, track_id, x, y, ...)"


def add_arguments(p) -> None:
    p.add_argument("recording", metavar="DIR", help="recording folder (from trackroom generate)")
    p.add_argument("--estimator", required=True, help="estimator name (trackroom estimate --list shows them)")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="estimator parameter, e.g. --param smooth=true (repeatable)")
    p.add_argument("--out", required=True, help="output CSV file")


def run(args) -> int:
    from pathlib import Path

    from trackroom.estimators.runner import run_estimator
    from trackroom.errors import CommandError
    from trackroom.dataset import read_recording

    rec = read_recording(args.recording)
    result = run_estimator(rec, args.estimator, args.param)
    if result.status == "skipped":
        raise CommandError(f"{args.estimator} does not apply to {args.recording}: {result.reason}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    result.tracks.to_csv(out, index=False, float_format="%.6f")
    n = result.tracks["track_id"].nunique()
    print(f"{args.estimator}: {len(result.tracks)} rows, {n} tracks in {result.seconds:.2f} s -> {out}")
    return 0
