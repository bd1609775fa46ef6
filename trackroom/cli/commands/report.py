"""trackroom report: one self-contained HTML page for a comparison folder (``trackroom/report.py``)."""
from __future__ import annotations

NAME = "report"
HELP = "write a self-contained HTML report (tables, plots, tracks over the truth, provenance) for a compare --out folder"


def add_arguments(p) -> None:
    p.add_argument("folder", metavar="DIR", help="a comparison folder (trackroom compare --out DIR)")
    p.add_argument("--out", help="HTML path (default DIR/report.html)")


def run(args) -> int:
    from trackroom.errors import CommandError
    from trackroom.report import ReportError, write_report

    try:
        path = write_report(args.folder, args.out)
    except ReportError as e:
        raise CommandError(str(e)) from None
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0
